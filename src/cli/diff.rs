//! `femu diff`: compare two artefacts, or two trees of artefacts, within tolerances.

use super::Failure;
use crate::artefact::Artefact;
use crate::artefact::codec::read_dir;
use crate::artefact::compare::{Tol, Tolerances, compare};
use std::path::{Path, PathBuf};

/// The options of `femu diff` beyond the two paths.
pub(super) struct DiffTolerances {
    pub(super) rtol: f64,
    pub(super) atol: f64,
    pub(super) file: Option<PathBuf>,
}

/// `femu diff`.
pub(super) fn run(a: &Path, b: &Path, t: &DiffTolerances) -> Result<u8, Failure> {
    let tol = tolerances(t)?;
    diff(a, b, &tol)
}

/// The tolerances from `--tolerances FILE`, or else `--rtol`/`--atol`; checked.
fn tolerances(t: &DiffTolerances) -> Result<Tolerances, Failure> {
    let tol: Tolerances = match &t.file {
        Some(f) => {
            let text = crate::pipeline::spec::read_bounded_text(f, 1 << 20)
                .map_err(|e| Failure::bad_input(anyhow::anyhow!("reading {}: {e}", f.display())))?;
            serde_yaml::from_str(&text)
                .map_err(|e| Failure::bad_input(anyhow::anyhow!("{}: {e}", f.display())))?
        }
        None => Tolerances {
            default: Tol {
                rtol: t.rtol,
                atol: t.atol,
                max: None,
            },
            ..Default::default()
        },
    };
    tol.check().map_err(|e| {
        Failure::bad_input(anyhow::anyhow!(
            "{}{e}",
            match &t.file {
                Some(f) => format!("{}: ", f.display()),
                None => "--rtol/--atol: ".to_string(),
            }
        ))
    })?;
    Ok(tol)
}

/// Artefact directories below `root`, by relative path.
fn artefact_dirs(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(d) = todo.pop() {
        if d.join(crate::artefact::codec::META_FILE).is_file() {
            out.push(d.strip_prefix(root).unwrap_or(&d).to_path_buf());
            continue;
        }
        if let Ok(rd) = std::fs::read_dir(&d) {
            todo.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
        }
    }
    out.sort();
    out
}

fn diff(a: &Path, b: &Path, tol: &Tolerances) -> Result<u8, Failure> {
    let read = |p: &Path| -> Result<Artefact, Failure> {
        read_dir(p).map_err(|e| Failure {
            code: 2,
            error: e.into(),
        })
    };
    for p in [a, b] {
        if !p.exists() {
            return Err(Failure {
                code: 2,
                error: anyhow::anyhow!("{} does not exist", p.display()),
            });
        }
    }
    let (da, db) = (artefact_dirs(a), artefact_dirs(b));
    if da.is_empty() || db.is_empty() {
        return Err(Failure {
            code: 2,
            error: anyhow::anyhow!(
                "no femu artefact (a directory with meta.json) under {}",
                if da.is_empty() { a } else { b }.display()
            ),
        });
    }
    let mut different = 0;
    let all: std::collections::BTreeSet<&PathBuf> = da.iter().chain(&db).collect();
    for rel in all {
        let label = if rel.as_os_str().is_empty() {
            ".".to_string()
        } else {
            rel.display().to_string()
        };
        match (da.contains(rel), db.contains(rel)) {
            (true, true) => {
                let c = compare(&read(&a.join(rel))?, &read(&b.join(rel))?, tol);
                if c.same() {
                    println!("same      {label}");
                } else {
                    different += 1;
                    println!("DIFFERENT {label}: {} values", c.count);
                    for d in &c.differences {
                        println!("    {}: {}", d.location, d.detail);
                    }
                }
            }
            (true, false) => {
                different += 1;
                println!("ONLY IN   {}: {label}", a.display());
            }
            _ => {
                different += 1;
                println!("ONLY IN   {}: {label}", b.display());
            }
        }
    }
    Ok(if different == 0 { 0 } else { 1 })
}
