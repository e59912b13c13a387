//! `femu explain`: the resolved plan with wiring, parameters and the last run's cache state.

use super::load::load_plan;
use super::{CacheArgs, Failure, PipelineArgs};
use crate::cache::Cache;
use crate::pipeline::Plan;
use crate::pipeline::lock::LockFile;
use std::path::Path;

/// `femu explain`.
pub(super) fn run(p: &PipelineArgs, c: &CacheArgs) -> Result<u8, Failure> {
    let plan = load_plan(p)?;
    explain(&plan, &c.dir());
    Ok(0)
}

fn explain(plan: &Plan, cache_dir: &Path) {
    println!("pipeline `{}`: {}", plan.name, plan.description.trim());
    let cache = Cache::open(cache_dir).ok();
    let lock: Option<LockFile> = cache
        .as_ref()
        .and_then(|c| c.lock_path(&plan.name).ok())
        .and_then(|p| std::fs::read_to_string(p).ok())
        .and_then(|text| serde_json::from_str(&text).ok());
    for (i, n) in plan.nodes.iter().enumerate() {
        println!(
            "\n{}. {} ({}) — {}",
            i + 1,
            n.name,
            n.stage.kind(),
            n.stage.summary()
        );
        if !n.description.is_empty() {
            println!("   {}", n.description.trim());
        }
        for (port, r) in &n.inputs {
            println!("   in  {port} <- {}.{}", plan.nodes[r.node].name, r.port);
        }
        for p in n.stage.outputs() {
            println!("   out {} ({})", p.name, p.kind);
        }
        let params = serde_yaml::to_string(&n.params).unwrap_or_default();
        for line in params.lines() {
            println!("   | {line}");
        }
        if let Some(lock) = &lock {
            if let Some(s) = lock.stages.get(&n.name) {
                let changes = param_changes(&s.params, &n.params);
                if changes.is_empty() {
                    println!("   last run: key {} (params unchanged)", &s.key[..16]);
                } else {
                    println!(
                        "   last run: key {} (params changed since: {})",
                        &s.key[..16],
                        changes.join("; ")
                    );
                }
            } else {
                println!("   last run: not in it (a new stage, or run with --only)");
            }
        }
    }
}

/// How `new` differs from `old`, one entry per changed leaf: `seed: 1 → 2`,
/// `band_hz[1]: 40.0 → 50.0`, `pc.kappa_f: added (0.9)`, `damping: removed`.
pub(super) fn param_changes(old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    let mut out = Vec::new();
    changes_at("", old, new, &mut out);
    out
}

fn short(v: &serde_json::Value) -> String {
    let s = v.to_string();
    if s.chars().count() > 60 {
        format!("{}…", s.chars().take(59).collect::<String>())
    } else {
        s
    }
}

fn changes_at(path: &str, old: &serde_json::Value, new: &serde_json::Value, out: &mut Vec<String>) {
    use serde_json::Value;
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (old, new) {
        (Value::Object(a), Value::Object(b)) => {
            let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
            for k in keys {
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => changes_at(&join(k), x, y, out),
                    (None, Some(y)) => out.push(format!("{}: added ({})", join(k), short(y))),
                    (Some(x), None) => out.push(format!("{}: removed (was {})", join(k), short(x))),
                    (None, None) => {}
                }
            }
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                changes_at(&format!("{path}[{i}]"), x, y, out);
            }
        }
        (x, y) if x != y => out.push(format!(
            "{}: {} → {}",
            if path.is_empty() { "(all)" } else { path },
            short(x),
            short(y)
        )),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::param_changes;
    use serde_json::json;

    #[test]
    fn names_every_changed_parameter() {
        let old = json!({"seed": 1, "level": 0.05, "band_hz": [0.0, 40.0], "pc": {"kappa_f": 0.95}, "gone": true});
        let new = json!({"seed": 2, "level": 0.05, "band_hz": [0.0, 50.0], "pc": {"kappa_f": 0.95, "max_step": 1}, "responses": ["1:ux", "2:ux"]});
        assert_eq!(
            param_changes(&old, &new),
            [
                "band_hz[1]: 40.0 → 50.0",
                "gone: removed (was true)",
                "pc.max_step: added (1)",
                "responses: added ([\"1:ux\",\"2:ux\"])",
                "seed: 1 → 2",
            ]
        );
        assert!(param_changes(&old, &old).is_empty());
        assert_eq!(
            param_changes(&json!({"r": [1, 2]}), &json!({"r": [1]})),
            ["r: [1,2] → [1]"]
        );
    }
}
