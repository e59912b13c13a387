//! `femu show`: an artefact's kind, digest, units, tables and a preview.

use super::Failure;
use crate::artefact::codec::{read_dir, read_meta};
use std::path::Path;

/// `femu show`.
pub(super) fn run(artefact: &Path, rows: usize) -> Result<u8, Failure> {
    if !artefact.join(crate::artefact::codec::META_FILE).is_file() {
        return Err(Failure::bad_input(anyhow::anyhow!(
            "{} is not a femu artefact: a directory holding meta.json (e.g. out/<stage>/<port>)",
            artefact.display()
        )));
    }
    show(artefact, rows)?;
    Ok(0)
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
