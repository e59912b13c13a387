//! `femu sweep collect`: join the finished points into one table.

use super::{Failure, Where, fail, open};
use crate::cache::Cache;
use crate::sweep::{Resolved, StateDir, collect};
use std::path::{Path, PathBuf};

/// `femu sweep collect`.
pub(super) fn run(file: &Path, to: Option<PathBuf>, w: &Where) -> Result<u8, Failure> {
    let (resolved, cache, state) = open(file, w)?;
    let to = to.unwrap_or_else(|| state.root().join("collected"));
    print_collect(&resolved, &state, &cache, &to)?;
    Ok(0)
}

/// Collects into `to` and says what went in, what is missing and which plots were drawn.
pub(super) fn print_collect(
    resolved: &Resolved,
    state: &StateDir,
    cache: &Cache,
    to: &Path,
) -> Result<(), Failure> {
    let c = collect(resolved, state, cache, to).map_err(fail)?;
    println!(
        "collected {} points, {} rows into {} (digest {})",
        c.points,
        c.table.rows(),
        c.path.display(),
        &c.digest[..16]
    );
    if !c.missing.is_empty() {
        println!(
            "  {} points are not finished and not in the table (`femu sweep status`)",
            c.missing.len()
        );
    }
    for p in &c.plots {
        println!("  plot {}", p.display());
    }
    Ok(())
}
