//! `frf.synthesise` with `method: krylov` through the pipeline: the free-free bent plate
//! (864 DOFs, 14 strips, the C2 structure) with structural and Rayleigh damping, every line of
//! 5–400 Hz against `method: direct`.

mod common;

use common::*;
use femu::artefact::ArtefactKind;
use femu::artefact::kinds::frf_from_artefact;

const FRF: &str = "      quantity: accelerance
      responses: [\"120:uz\", \"56:uz\", \"113:uz\", \"30:ux\"]
      excitations: [\"120:uz\", \"56:uz\"]
      band_hz: [5, 400]
      step_hz: 0.5
      damping: {rayleigh: {alpha: 0.8, beta: 1.0e-6}}
";

fn write_pipeline(dir: &std::path::Path) -> std::path::PathBuf {
    let text = format!(
        "name: krylov
stages:
  plate:
    kind: mesh.generate
    with: {{geometry: bent_plate}}
  matrices:
    kind: assemble
    inputs: {{mesh: plate}}
  direct:
    kind: frf.synthesise
    inputs: {{model: matrices}}
    with:
      method: direct
{FRF}  rom:
    kind: frf.synthesise
    inputs: {{model: matrices}}
    with:
      method: krylov
{FRF}"
    );
    let file = dir.join("p.yaml");
    std::fs::write(&file, text).unwrap();
    file
}

/// The reduced sweep meets the direct solution to 1e-8 of each FRF's peak (its estimate, a
/// backward error in the load, is held to the default 1e-6; the response error measured is
/// orders below it), records its expansion points in the artefact's meta, and its settings
/// reach the cache key of the Krylov stage only.
#[test]
fn krylov_matches_direct_on_the_bent_plate() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_pipeline(dir.path());
    let cache_dir = dir.path().join("cache");
    let (_, report, cache) = run(&file, &cache_dir, &[]);
    let read = |name: &str| {
        let stage = report.stages.iter().find(|s| s.name == name).unwrap();
        cache.read(&stage.key, "frf", ArtefactKind::Frf).unwrap()
    };
    let (direct, rom) = (read("direct"), read("rom"));
    let meta = rom.meta["krylov"].clone();
    let points = meta["expansion_hz"].as_array().unwrap().len();
    assert!(points >= 1, "{meta}");
    assert!(meta["worst_estimate"].as_f64().unwrap() <= 1e-6, "{meta}");
    assert!(meta["basis_size"].as_u64().unwrap() < 864 / 2, "{meta}");
    assert!(direct.meta.get("krylov").is_none());
    let (direct, rom) = (
        frf_from_artefact(&direct).unwrap(),
        frf_from_artefact(&rom).unwrap(),
    );
    assert_eq!(direct.freqs_hz, rom.freqs_hz);
    assert_eq!(direct.pairs, rom.pairs);
    for p in 0..direct.pairs.len() {
        let peak = (0..direct.freqs_hz.len())
            .map(|k| direct.values[(k, p)].norm())
            .fold(0.0, f64::max);
        for k in 0..direct.freqs_hz.len() {
            let d = (rom.values[(k, p)] - direct.values[(k, p)]).norm();
            assert!(
                d <= 1e-8 * peak,
                "{:?} at {} Hz: {d:e} of {peak:e}",
                direct.pairs[p],
                direct.freqs_hz[k]
            );
        }
    }
    // A Krylov setting re-runs the Krylov stage only.
    let (_, again, _) = run(
        &file,
        &cache_dir,
        &["rom.krylov.tolerance=1e-7", "direct.krylov.tolerance=1e-7"],
    );
    assert_eq!(executed(&again), ["rom"]);
}

/// The settings are checked before anything runs.
#[test]
fn krylov_settings_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_pipeline(dir.path());
    let out = femu()
        .args(["validate"])
        .arg(&file)
        .args(["--set", "rom.krylov.max_points=0"])
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success(), "{text}");
    assert!(
        text.contains("krylov") && text.contains("max_points") && text.contains(">= 1"),
        "{text}"
    );
}
