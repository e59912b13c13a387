//! `femu show`: an artefact's kind, digest, units, tables and a preview; or, for a run's
//! `--out` directory, the whole run: its stages, their status and time, key results and
//! warnings.

use super::Failure;
use super::summary::{
    RUN_RECORD_FILE, RunRecord, artefact_meta, column_width, is_artefact, key_results, output_meta,
    print_warnings, stage_warnings,
};
use crate::artefact::codec::{read_dir, read_meta};
use crate::pipeline::lock::{LockFile, OUT_LOCK_FILE};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// `femu show`.
pub(super) fn run(path: &Path, rows: usize) -> Result<u8, Failure> {
    if is_artefact(path) {
        show(path, rows)?;
        return Ok(0);
    }
    if path.join(OUT_LOCK_FILE).is_file() {
        show_run(path)?;
        return Ok(0);
    }
    let what = if !path.exists() {
        "is not a femu artefact or run output: no such file or directory"
    } else if !path.is_dir() {
        "is not a femu artefact or run output: not a directory"
    } else {
        "is not a femu artefact (a directory holding meta.json, e.g. out/<stage>/<port>) nor a run's output (a directory holding femu.lock.json, written by `femu run --out`)"
    };
    Err(Failure::bad_input(anyhow::anyhow!(
        "{} {what}",
        path.display()
    )))
}

/// The stages of a lock file in an order where every stage follows its inputs (ties by name).
fn stage_order(lock: &LockFile) -> Vec<String> {
    let mut done: Vec<String> = Vec::new();
    let mut left: BTreeSet<&String> = lock.stages.keys().collect();
    while !left.is_empty() {
        let ready: Vec<&String> = left
            .iter()
            .copied()
            .filter(|name| {
                lock.stages[*name].inputs.values().all(|from| {
                    let up = from.split('.').next().unwrap_or(from);
                    !left.iter().any(|l| l.as_str() == up) || up == name.as_str()
                })
            })
            .collect();
        // A cycle cannot be planned; should a hand-edited lock hold one, list the rest as is.
        let ready = if ready.is_empty() {
            left.iter().copied().collect()
        } else {
            ready
        };
        for r in ready {
            left.remove(r);
            done.push(r.clone());
        }
    }
    done
}

/// `femu show OUT` on a run's output directory.
fn show_run(dir: &Path) -> anyhow::Result<()> {
    let lock: LockFile = serde_json::from_str(
        &crate::pipeline::spec::read_bounded_text(&dir.join(OUT_LOCK_FILE), 64 << 20)
            .map_err(|e| anyhow::anyhow!("{}: {e}", dir.join(OUT_LOCK_FILE).display()))?,
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", dir.join(OUT_LOCK_FILE).display()))?;
    let record: Option<RunRecord> =
        crate::pipeline::spec::read_bounded_text(&dir.join(RUN_RECORD_FILE), 64 << 20)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
    let by_name: BTreeMap<&str, &super::summary::RunRecordStage> = record
        .iter()
        .flat_map(|r| r.stages.iter().map(|s| (s.name.as_str(), s)))
        .collect();
    let order: Vec<String> = match &record {
        Some(r) if r.stages.iter().all(|s| lock.stages.contains_key(&s.name)) => {
            r.stages.iter().map(|s| s.name.clone()).collect()
        }
        _ => stage_order(&lock),
    };
    println!(
        "{}: run of pipeline `{}` by femu {}, {} stages",
        dir.display(),
        lock.pipeline,
        lock.femu_version,
        lock.stages.len()
    );
    match &record {
        Some(r) => {
            let count = |st: &str| r.stages.iter().filter(|s| s.status == st).count();
            println!(
                "{} ran, {} cached{}; command: {}",
                count("ran") + count("recomputed"),
                count("cached"),
                if count("recomputed") > 0 {
                    format!(
                        " ({} recomputed after a corrupt cache entry)",
                        count("recomputed")
                    )
                } else {
                    String::new()
                },
                r.command.join(" ")
            );
        }
        None => println!("(no {RUN_RECORD_FILE}: statuses and times were not recorded)"),
    }
    // Columns as wide as their longest entry (at least as wide as they were).
    let name_w = column_width(order.iter().map(String::as_str), 20);
    let kind_w = column_width(order.iter().map(|n| lock.stages[n].kind.as_str()), 18);
    println!(
        "\n{:<name_w$} {:<kind_w$} {:<10} {:>9}  outputs",
        "stage", "kind", "status", "time (s)"
    );
    for name in &order {
        let s = &lock.stages[name];
        let (status, time) = match by_name.get(name.as_str()) {
            Some(r) => (r.status.clone(), format!("{:.3}", r.seconds)),
            None => ("-".to_string(), "-".to_string()),
        };
        let outs: Vec<String> = s
            .outputs
            .iter()
            .map(|(p, o)| format!("{p}={}", o.digest.get(..12).unwrap_or(&o.digest)))
            .collect();
        println!(
            "{name:<name_w$} {:<kind_w$} {status:<10} {time:>9}  {}",
            s.kind,
            outs.join(" ")
        );
    }
    println!("\nresults:");
    let mut any = false;
    let mut warnings = Vec::new();
    for name in &order {
        let s = &lock.stages[name];
        let mut metas = Vec::new();
        for port in s.outputs.keys() {
            let adir = dir.join(name).join(port);
            let Some(meta) = output_meta(&adir) else {
                println!(
                    "  {name}.{port}: missing from {} (not copied, or removed)",
                    dir.display()
                );
                any = true;
                continue;
            };
            let lines = key_results(&adir, &meta);
            if let Some((first, rest)) = lines.split_first() {
                println!("  {name} ({}): {first}", s.kind);
                for l in rest {
                    println!("    {l}");
                }
                any = true;
            }
            metas.push(artefact_meta(&meta));
        }
        let from_meta = stage_warnings(&metas);
        let w = match record.as_ref().and_then(|r| r.warnings.get(name)) {
            Some(w) if !w.is_empty() => w.clone(),
            _ => from_meta,
        };
        warnings.push((name.clone(), s.kind.clone(), w));
    }
    if !any {
        println!(
            "  (none of the stages' kinds has a summary; `femu show {}/<stage>/<port>` for any artefact)",
            dir.display()
        );
    }
    let mut text = Vec::new();
    print_warnings(&warnings, &mut text)?;
    if text.is_empty() {
        println!("\nno warnings");
    } else {
        print!("\n{}", String::from_utf8_lossy(&text));
    }
    Ok(())
}

fn show(dir: &Path, rows: usize) -> anyhow::Result<()> {
    let meta = read_meta(dir)?;
    let a = read_dir(dir)?;
    let digest = a.digest();
    println!(
        "{}: `{}` artefact, schema version {}, format {:?}",
        dir.display(),
        a.kind,
        a.kind.schema_version(),
        meta.format
    );
    println!(
        "digest {} ({})",
        digest,
        if digest == meta.digest {
            "verified"
        } else {
            "DOES NOT MATCH meta.json: the files were changed"
        }
    );
    if let Some(p) = meta.raw.get("producer") {
        println!("made by {p}");
    }
    println!(
        "meta: {}",
        serde_json::to_string_pretty(&serde_json::Value::Object(a.meta.clone()))?
    );
    let units = a.meta.get("units").and_then(|u| u.as_object());
    for (name, (t, storage)) in &a.tables {
        println!("\ntable `{name}` ({storage:?}, {} rows)", t.rows());
        for (c, col) in &t.columns {
            let unit = units
                .and_then(|u| u.get(c))
                .and_then(|u| u.as_str())
                .map(|u| format!(" [{u}]"))
                .unwrap_or_default();
            println!("  {c}: {}{unit}", col.type_name());
        }
        print!("{}", t.preview(rows));
    }
    for (name, bytes) in &a.blobs {
        println!("\nfile `{name}` ({} bytes)", bytes.len());
    }
    Ok(())
}
