//! `femu diff`: compare two artefacts, or two trees of artefacts, within tolerances. A summary
//! comes first (artefacts same and different, the largest difference of each differing
//! column), then the tolerances used, then every artefact's differences with rows named by
//! their key columns.

use super::Failure;
use crate::artefact::codec::read_dir;
use crate::artefact::compare::{Comparison, MAX_LISTED, Tol, Tolerances, compare_listing};
use crate::artefact::{Artefact, ArtefactKind};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The options of `femu diff` beyond the two paths.
pub(super) struct DiffTolerances {
    pub(super) rtol: Option<f64>,
    pub(super) atol: Option<f64>,
    pub(super) file: Option<PathBuf>,
}

/// Tolerances chosen by the user for every artefact, or femu's per kind.
enum Chosen {
    /// From `--tolerances` or `--rtol`/`--atol`, with where they came from.
    Given(Tolerances, String),
    /// [`Tolerances::defaults_for`] each artefact's kind.
    PerKind,
}

impl Chosen {
    fn for_kind(&self, kind: ArtefactKind) -> Tolerances {
        match self {
            Chosen::Given(t, _) => t.clone(),
            Chosen::PerKind => Tolerances::defaults_for(kind),
        }
    }
}

/// `femu diff`.
pub(super) fn run(a: &Path, b: &Path, t: &DiffTolerances, full: bool) -> Result<u8, Failure> {
    let tol = tolerances(t)?;
    diff(a, b, &tol, full)
}

/// The tolerances from `--tolerances FILE`, or else `--rtol`/`--atol`, or else femu's per kind;
/// checked.
fn tolerances(t: &DiffTolerances) -> Result<Chosen, Failure> {
    let (tol, source): (Tolerances, String) = match (&t.file, t.rtol, t.atol) {
        (Some(f), _, _) => {
            let text = crate::pipeline::spec::read_bounded_text(f, 1 << 20)
                .map_err(|e| Failure::bad_input(anyhow::anyhow!("reading {}: {e}", f.display())))?;
            let tol = serde_yaml::from_str(&text)
                .map_err(|e| Failure::bad_input(anyhow::anyhow!("{}: {e}", f.display())))?;
            (tol, format!("from {}", f.display()))
        }
        (None, None, None) => return Ok(Chosen::PerKind),
        (None, rtol, atol) => (
            Tolerances {
                default: Tol {
                    rtol: rtol.unwrap_or(1e-9),
                    atol: atol.unwrap_or(0.0),
                    ..Default::default()
                },
                ..Default::default()
            },
            "from --rtol/--atol".to_string(),
        ),
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
    Ok(Chosen::Given(tol, source))
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

/// What one artefact path came to.
enum Outcome {
    Same,
    Different(Box<Comparison>),
    OnlyIn(PathBuf),
}

fn diff(a: &Path, b: &Path, chosen: &Chosen, full: bool) -> Result<u8, Failure> {
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
    let listed = if full { usize::MAX } else { MAX_LISTED };
    let all: std::collections::BTreeSet<&PathBuf> = da.iter().chain(&db).collect();
    let mut outcomes: Vec<(String, Outcome)> = Vec::new();
    let mut kinds: BTreeMap<ArtefactKind, usize> = BTreeMap::new();
    for rel in all {
        let label = if rel.as_os_str().is_empty() {
            ".".to_string()
        } else {
            rel.display().to_string()
        };
        let outcome = match (da.contains(rel), db.contains(rel)) {
            (true, true) => {
                let (x, y) = (read(&a.join(rel))?, read(&b.join(rel))?);
                *kinds.entry(y.kind).or_default() += 1;
                let c = compare_listing(&x, &y, &chosen.for_kind(y.kind), listed);
                if c.same() {
                    Outcome::Same
                } else {
                    Outcome::Different(Box::new(c))
                }
            }
            (true, false) => Outcome::OnlyIn(a.to_path_buf()),
            _ => Outcome::OnlyIn(b.to_path_buf()),
        };
        outcomes.push((label, outcome));
    }
    print_summary(a, b, &outcomes, full);
    print_tolerances(chosen, &kinds);
    let mut different = 0;
    println!();
    for (label, outcome) in &outcomes {
        match outcome {
            Outcome::Same => println!("same      {label}"),
            Outcome::OnlyIn(p) => {
                different += 1;
                println!("ONLY IN   {}: {label}", p.display());
            }
            Outcome::Different(c) => {
                different += 1;
                println!("DIFFERENT {label}: {} values", c.count);
                let mut shown: BTreeMap<String, usize> = BTreeMap::new();
                for d in &c.differences {
                    println!("    {}: {}", d.location, d.detail);
                    let column = column_of(&d.location);
                    *shown.entry(column).or_default() += 1;
                }
                for (column, cd) in &c.columns {
                    let n = shown.get(column).copied().unwrap_or(0);
                    if cd.count > n {
                        println!(
                            "    … {} more in {column} (--full lists every one)",
                            cd.count - n
                        );
                    }
                }
            }
        }
    }
    Ok(if different == 0 { 0 } else { 1 })
}

/// The column a difference's location belongs to (as [`Comparison::columns`] keys it).
fn column_of(location: &str) -> String {
    location
        .split(" row ")
        .next()
        .and_then(|c| c.split(" (").next())
        .unwrap_or(location)
        .to_string()
}

/// The summary: counts, then the differing columns, largest relative difference first.
fn print_summary(a: &Path, b: &Path, outcomes: &[(String, Outcome)], full: bool) {
    let same = outcomes
        .iter()
        .filter(|o| matches!(o.1, Outcome::Same))
        .count();
    let different = outcomes
        .iter()
        .filter(|o| matches!(o.1, Outcome::Different(_)))
        .count();
    let only = outcomes.len() - same - different;
    println!(
        "comparing {} (new) with {} (reference): {} artefact{}, {same} same, {different} different{}",
        a.display(),
        b.display(),
        outcomes.len(),
        if outcomes.len() == 1 { "" } else { "s" },
        if only > 0 {
            format!(", {only} only on one side")
        } else {
            String::new()
        }
    );
    let mut rows: Vec<(&str, &String, &crate::artefact::compare::ColumnDifferences)> = outcomes
        .iter()
        .filter_map(|(label, o)| match o {
            Outcome::Different(c) => Some((label.as_str(), c)),
            _ => None,
        })
        .flat_map(|(label, c)| c.columns.iter().map(move |(col, cd)| (label, col, cd)))
        .collect();
    if rows.is_empty() {
        return;
    }
    // Largest relative difference first; differences without a size (text, layout) last.
    let key = |r: f64| if r.is_nan() { f64::NEG_INFINITY } else { r };
    rows.sort_by(|x, y| key(y.2.worst_rel).total_cmp(&key(x.2.worst_rel)));
    let shown = if full { rows.len() } else { rows.len().min(10) };
    println!("largest differences by column:");
    for (label, col, cd) in &rows[..shown] {
        let size = if cd.worst_abs.is_nan() {
            String::new()
        } else {
            format!(
                ", largest |Δ| {:.3e} ({:.3e} relative)",
                cd.worst_abs, cd.worst_rel
            )
        };
        println!(
            "  {label}: {col}: {} value{}{size} at {}",
            cd.count,
            if cd.count == 1 { "" } else { "s" },
            cd.worst_at
        );
    }
    if rows.len() > shown {
        println!(
            "  … {} more columns differ (--full lists them all)",
            rows.len() - shown
        );
    }
}

/// The tolerances used, per artefact kind compared.
fn print_tolerances(chosen: &Chosen, kinds: &BTreeMap<ArtefactKind, usize>) {
    match chosen {
        Chosen::Given(t, source) => {
            println!("tolerances ({source}):");
            for line in t.describe() {
                println!("  {line}");
            }
        }
        Chosen::PerKind => {
            println!(
                "tolerances (femu's defaults per artefact kind, ignoring round-off; --rtol/--atol or --tolerances FILE to choose):"
            );
            // Kinds with the same rules share a line.
            let mut rules: Vec<(String, Vec<String>)> = Vec::new();
            for kind in kinds.keys() {
                let text = Tolerances::defaults_for(*kind).describe().join("; ");
                match rules.iter_mut().find(|r| r.0 == text) {
                    Some(r) => r.1.push(kind.to_string()),
                    None => rules.push((text, vec![kind.to_string()])),
                }
            }
            for (text, kinds) in rules {
                println!("  {}: {text}", kinds.join(", "));
            }
        }
    }
}
