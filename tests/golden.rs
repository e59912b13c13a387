//! Every shipped pipeline runs here and its artefacts are diffed against the golden artefacts in
//! `fixtures/golden/<pipeline>/` with the per-column tolerances in its `tolerances.yaml`.
//! `FEMU_BLESS=1 cargo test --release --test golden` regenerates them on purpose.

mod common;

use common::*;

fn check_pipeline(name: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline(name), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    check_golden(name, &out, &[]);
}

#[test]
fn four_dof_matches_its_golden_artefacts() {
    check_pipeline("four-dof");
}

#[test]
fn four_dof_rfm_matches_its_golden_artefacts() {
    check_pipeline("four-dof-rfm");
}

#[test]
fn structures_modes_match_their_golden_artefacts() {
    check_pipeline("structures-modes");
}

#[test]
fn nastran_model_matches_its_golden_artefacts() {
    check_pipeline("nastran-model");
}

/// A change of a value well beyond its column's tolerance: 1 % relative and ten times the
/// absolute floor, alternating in sign along the column (so a mode shape leaves its span and a
/// sign flip cannot hide it), a number in place of a NaN, or ten times an upper bound.
fn beyond(t: &femu::artefact::compare::Tol, v: f64, i: usize) -> f64 {
    let sign = if i.is_multiple_of(2) { 1.0 } else { -1.0 };
    match t.max {
        Some(m) => sign * (10.0 * m + 1e-300),
        // A column of "not applicable" NaNs must not start holding numbers unnoticed.
        None if v.is_nan() => 1.0,
        None => v + sign * (0.01 * v.abs() + 10.0 * t.atol + 1e-300),
    }
}

/// No golden tolerance is vacuous: perturbing any one numeric column of any golden artefact
/// (or any numeric meta entry) beyond its tolerance makes the comparison fail. A tolerance such
/// as `rtol: 1` on a non-negative column, which accepts everything, fails this test.
#[test]
fn every_golden_tolerance_can_fail() {
    use femu::artefact::Column;
    use femu::artefact::codec::read_dir;
    use femu::artefact::compare::{Tolerances, compare};
    let golden = root().join("fixtures/golden");
    let mut checked = 0;
    let mut vacuous = Vec::new();
    for entry in std::fs::read_dir(&golden).unwrap().flatten() {
        let dir = entry.path();
        let Ok(text) = std::fs::read_to_string(dir.join("tolerances.yaml")) else {
            continue;
        };
        let tol: Tolerances = serde_yaml::from_str(&text).unwrap();
        for rel in artefact_dirs(&dir) {
            let b = read_dir(&dir.join(&rel)).unwrap();
            for (name, (table, _)) in &b.tables {
                for (ci, (column, values)) in table.columns.iter().enumerate() {
                    let Column::F64(values) = values else {
                        continue;
                    };
                    if values.is_empty() {
                        continue;
                    }
                    let t = tol.of(name, column);
                    let mut a = b.clone();
                    let perturbed: Vec<f64> = values
                        .iter()
                        .enumerate()
                        .map(|(i, v)| beyond(&t, *v, i))
                        .collect();
                    a.tables.get_mut(name).unwrap().0.columns[ci].1 = Column::F64(perturbed);
                    checked += 1;
                    if compare(&a, &b, &tol).same() {
                        vacuous.push(format!(
                            "{}/{}: {name}.{column}",
                            dir.display(),
                            rel.display()
                        ));
                    }
                }
            }
            for (key, value) in &b.meta {
                let Some(v) = value.as_f64().filter(|_| value.is_f64()) else {
                    continue;
                };
                let t = tol.of("meta", key);
                let mut a = b.clone();
                a.meta
                    .insert(key.clone(), serde_json::json!(beyond(&t, v, 0)));
                checked += 1;
                if compare(&a, &b, &tol).same() {
                    vacuous.push(format!("{}/{}: meta.{key}", dir.display(), rel.display()));
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} columns checked");
    assert!(
        vacuous.is_empty(),
        "vacuous tolerances:\n{}",
        vacuous.join("\n")
    );
}
