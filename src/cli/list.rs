//! `femu list`: the stage kinds, or one kind's ports and parameter schema.

use super::Failure;
use crate::stages::registry;

/// `femu list [KIND]`.
pub(super) fn run(kind: Option<&str>) -> Result<u8, Failure> {
    let reg = registry();
    match kind {
        None => {
            for s in reg.all() {
                println!("{:<18} {}", s.kind(), s.summary());
            }
            Ok(0)
        }
        Some(k) => {
            let Some(s) = reg.get(k) else {
                let names: Vec<&str> = reg.all().iter().map(|s| s.kind()).collect();
                return Err(Failure {
                    code: 2,
                    error: anyhow::anyhow!("unknown stage kind `{k}`; kinds: {}", names.join(", ")),
                });
            };
            println!(
                "{} (impl version {}): {}",
                s.kind(),
                s.impl_version(),
                s.summary()
            );
            for p in s.inputs() {
                println!(
                    "  input  {:<12} {:<12} {}{}",
                    p.name,
                    p.kind.name(),
                    p.doc,
                    if p.required { " (required)" } else { "" }
                );
            }
            for p in s.outputs() {
                println!("  output {:<12} {:<12} {}", p.name, p.kind.name(), p.doc);
            }
            println!("  parameters (JSON Schema):");
            let schema = serde_json::to_string_pretty(&s.params_schema()).unwrap_or_default();
            for line in schema.lines() {
                println!("    {line}");
            }
            Ok(0)
        }
    }
}
