//! Names that become paths. A pipeline, stage, port or key name is joined to a root directory
//! only when it is one plain path component; anything else (`..`, `/abs`, `a/b`, an empty name,
//! control characters) is refused instead of escaping the root.

use std::path::{Component, Path};

/// Why `name` is not a single safe path component, or `None` when it is.
pub fn unsafe_reason(name: &str) -> Option<&'static str> {
    if name.is_empty() {
        return Some("it is empty");
    }
    if name.len() > 200 {
        return Some("it is longer than 200 bytes");
    }
    if name == "." || name == ".." {
        return Some("it names a directory itself, not an entry in it");
    }
    if name.contains(['/', '\\']) {
        return Some("it holds a path separator");
    }
    if name.chars().any(char::is_control) {
        return Some("it holds a control character");
    }
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(_)), None) => None,
        _ => Some("it is not one plain file name (a drive or root prefix?)"),
    }
}

/// What a valid name looks like, for messages.
pub const VALID_NAME: &str =
    "one plain file name: not empty, no `/` or `\\`, not `.` or `..`, no control characters";

/// A relative path of safe components (a file of an entry, e.g. `frf/meta.json`).
pub fn unsafe_relative_reason(rel: &str) -> Option<&'static str> {
    if rel.is_empty() {
        return Some("it is empty");
    }
    rel.split('/').find_map(unsafe_reason)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_names_pass_and_escapes_do_not() {
        for ok in ["four-dof", "sweep@k=1.5,m=2", "a.b", "x_y", ".hidden"] {
            assert_eq!(unsafe_reason(ok), None, "{ok}");
        }
        for bad in [
            "",
            ".",
            "..",
            "../x",
            "../../x",
            "/abs",
            "/any/dir/x",
            "a/b",
            "a\\b",
            "x\0",
            "x\n",
        ] {
            assert!(unsafe_reason(bad).is_some(), "{bad:?}");
        }
        assert_eq!(unsafe_relative_reason("frf/meta.json"), None);
        for bad in ["../x", "/etc/passwd", "a//b", "a/../b", ""] {
            assert!(unsafe_relative_reason(bad).is_some(), "{bad:?}");
        }
    }
}
