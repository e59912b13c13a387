//! What every layer shares: degrees of freedom and their labels, the sparse-matrix type and
//! its conversions, small dense helpers, the input-fault trait, the allocator settings and the
//! short lists messages name things in.

pub mod dense;
mod dof;
mod fault;
pub mod hashing;
pub mod input;
pub mod memory;
pub mod progress;
pub mod sparse;

pub use dof::{Component, DofId, DofParseError};
pub use fault::InputFault;

/// The first `shown` of `items`, comma-separated, then how many more: a list a message can
/// hold however long the data's.
pub fn first_of<T: std::fmt::Display>(
    items: impl ExactSizeIterator<Item = T>,
    shown: usize,
) -> String {
    let total = items.len();
    let mut text: Vec<String> = items.take(shown).map(|t| t.to_string()).collect();
    if total > shown {
        text.push(format!("and {} more", total - shown));
    }
    text.join(", ")
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_long_list_is_cut_with_its_count() {
        assert_eq!(super::first_of(["a", "b"].iter(), 5), "a, b");
        assert_eq!(super::first_of(1..8, 3), "1, 2, 3, and 4 more");
        assert_eq!(super::first_of(std::iter::empty::<u8>(), 3), "");
    }
}
