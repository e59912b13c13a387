//! `femu cache ls` and `femu cache gc`.

use super::{CacheAction, Failure};
use crate::cache::Cache;

/// `femu cache …`.
pub(super) fn run(action: CacheAction) -> Result<u8, Failure> {
    match action {
        CacheAction::Ls { c } => {
            let cache = Cache::open(&c.dir())?;
            let entries = cache.entries()?;
            let total: u64 = entries.iter().map(|e| e.bytes).sum();
            for e in &entries {
                let outs: Vec<String> = e.outputs.iter().map(|(p, k)| format!("{p}:{k}")).collect();
                println!(
                    "{}  {:<18} {:>10} B  {}",
                    &e.key[..16],
                    e.stage_kind,
                    e.bytes,
                    outs.join(" ")
                );
            }
            println!(
                "{} entries, {} bytes in {}",
                entries.len(),
                total,
                c.dir().display()
            );
        }
        CacheAction::Gc { c, all } => {
            let cache = Cache::open(&c.dir())?;
            let keep = if all {
                Default::default()
            } else {
                cache.locked_keys()
            };
            let (n, bytes) = cache.gc(&keep)?;
            println!("removed {n} entries ({bytes} bytes); kept {}", keep.len());
        }
    }
    Ok(0)
}
