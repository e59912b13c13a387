//! Real model and test-data files through pipelines: Nastran bulk data into modes, UFF 58
//! measurements into the correlation, with cache keys that follow content, not paths.

mod common;

use common::*;
use femu::artefact::kinds::{correlation_from_artefact, frf_from_artefact};
use femu::pipeline::Status;

#[test]
fn the_decks_method_and_eigrl_choose_the_modes_when_the_stage_gives_no_count() {
    // The fixture's case control has METHOD = 1 and EIGRL 1 asks for ND = 10; a band from V1
    // to V2 keeps exactly the modes of the full solution that lie in it.
    let dir = tempfile::tempdir().unwrap();
    let deck = std::fs::read_to_string(root().join("fixtures/nastran/plate_with_bar.bdf")).unwrap();
    std::fs::write(dir.path().join("plate.bdf"), &deck).unwrap();
    let pipeline = |modes_with: &str| {
        format!(
            "name: eigrl\nstages:\n  mesh:\n    kind: mesh.import\n    with: {{path: plate.bdf}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: mesh}}\n  modes:\n    kind: modes\n    inputs: {{model: matrices}}\n    with: {modes_with}\n"
        )
    };
    let modes_of = |text: &str| {
        let file = dir.path().join("p.yaml");
        std::fs::write(&file, text).unwrap();
        let (_, report, cache) = run(&file, &dir.path().join("cache"), &[]);
        let modes = report.stages.iter().find(|s| s.name == "modes").unwrap();
        let a = cache
            .read(&modes.key, "modes", femu::artefact::ArtefactKind::Modes)
            .unwrap();
        femu::artefact::kinds::modes_from_artefact(&a)
            .unwrap()
            .modes
            .frequencies_hz()
    };
    let from_deck = modes_of(&pipeline("{}"));
    let all = modes_of(&pipeline("{count: 20}"));
    assert_eq!(from_deck.len(), 10, "ND = 10");
    assert_eq!(from_deck[..], all[..10]);
    // V1 and V2 between modes 3/4 and 8/9 of the full solution.
    let (v1, v2) = (0.5 * (all[2] + all[3]), 0.5 * (all[7] + all[8]));
    std::fs::write(
        dir.path().join("plate.bdf"),
        deck.replace("EIGRL,1,,,10", &format!("EIGRL,1,{v1:.6},{v2:.6}")),
    )
    .unwrap();
    let band = modes_of(&pipeline("{}"));
    assert_eq!(band[..], all[3..8]);
    // The stage's own count wins over the deck.
    assert_eq!(modes_of(&pipeline("{count: 2}"))[..], all[..2]);
}

#[test]
fn a_nastran_deck_runs_to_modes() {
    let dir = tempfile::tempdir().unwrap();
    let deck = root().join("fixtures/nastran/plate_with_bar.bdf");
    std::fs::copy(&deck, dir.path().join("plate.bdf")).unwrap();
    let text = "name: nastran\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: plate.bdf}\n  matrices:\n    kind: assemble\n    inputs: {mesh: mesh}\n  modes:\n    kind: modes\n    inputs: {model: matrices}\n    with: {count: 6}\n";
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, text).unwrap();
    let (_, report, cache) = run(&file, &dir.path().join("cache"), &[]);
    let modes = report.stages.iter().find(|s| s.name == "modes").unwrap();
    let a = cache
        .read(&modes.key, "modes", femu::artefact::ArtefactKind::Modes)
        .unwrap();
    let m = femu::artefact::kinds::modes_from_artefact(&a).unwrap();
    assert_eq!(m.modes.len(), 6);
    assert_eq!(
        m.modes.rigid_body_modes, 0,
        "the SPC1 clamp holds the plate"
    );
    assert!(m.modes.residuals.iter().all(|r| *r < 1e-8));

    // Same content under another name: every stage cached (the key holds the model's digest).
    std::fs::rename(dir.path().join("plate.bdf"), dir.path().join("renamed.bdf")).unwrap();
    std::fs::write(&file, text.replace("plate.bdf", "renamed.bdf")).unwrap();
    let (_, again, _) = run(&file, &dir.path().join("cache"), &[]);
    let statuses: Vec<_> = again
        .stages
        .iter()
        .map(|s| (s.name.clone(), s.status))
        .collect();
    assert!(
        again.stages.iter().all(|s| s.status == Status::Cached),
        "{statuses:?}"
    );

    // Exported and re-imported, the model is the same.
    let model = femu::model::import::nastran::read_bulk(dir.path().join("renamed.bdf"))
        .unwrap()
        .model;
    let text = femu::model::export::nastran::write_bulk(&model);
    let back = femu::model::import::nastran::parse_bulk(&text, "exported.bdf")
        .unwrap()
        .model;
    assert_eq!(back, model);
}

#[test]
fn a_bad_card_is_reported_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.bdf"),
        "BEGIN BULK\nGRID,1,,0.,0.,abc\nENDDATA\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("p.yaml"),
        "name: bad\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: bad.bdf}\n",
    )
    .unwrap();
    let out = femu()
        .arg("validate")
        .arg(dir.path().join("p.yaml"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("p.yaml:5:") && err.contains("bad.bdf") && err.contains("GRID"),
        "{err}"
    );
}

/// The four-DOF "measurements" written to UFF 58 (ASCII and binary) and read back by `frf.import`
/// give the same correlation as the synthesised artefact they came from.
#[test]
fn uff_measurements_feed_the_correlation() {
    let dir = tempfile::tempdir().unwrap();
    let (_, report, cache) = run(&pipeline("four-dof"), &dir.path().join("cache"), &[]);
    let stage = |name: &str| {
        report
            .stages
            .iter()
            .find(|s| s.name == name)
            .unwrap()
            .key
            .clone()
    };
    let measured = frf_from_artefact(
        &cache
            .read(&stage("measured"), "frf", femu::artefact::ArtefactKind::Frf)
            .unwrap(),
    )
    .unwrap();
    let reference = correlation_from_artefact(
        &cache
            .read(
                &stage("correlation"),
                "correlation",
                femu::artefact::ArtefactKind::Correlation,
            )
            .unwrap(),
    )
    .unwrap();
    for (name, binary, tol) in [("m.uff", true, 1e-15), ("a.uff", false, 1e-10)] {
        std::fs::write(
            dir.path().join(name),
            femu::frf::io::uff::write_uff58(&measured, binary),
        )
        .unwrap();
        let text = std::fs::read_to_string(pipeline("four-dof")).unwrap().replace(
            "  measured:\n    kind: noise.add",
            &format!("  measured:\n    kind: frf.import\n    with: {{path: {name}}}\n  unused:\n    kind: noise.add"),
        );
        let file = dir.path().join("p.yaml");
        std::fs::write(&file, text).unwrap();
        let (_, r, cache) = run(&file, &dir.path().join("cache"), &[]);
        let key = r
            .stages
            .iter()
            .find(|s| s.name == "correlation")
            .unwrap()
            .key
            .clone();
        let c = correlation_from_artefact(
            &cache
                .read(
                    &key,
                    "correlation",
                    femu::artefact::ArtefactKind::Correlation,
                )
                .unwrap(),
        )
        .unwrap();
        for k in 0..c.chi_s.len() {
            assert!(
                (c.chi_s[k] - reference.chi_s[k]).abs() <= tol
                    && (c.chi_a[k] - reference.chi_a[k]).abs() <= tol,
                "{name} line {k}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Bad input: every user-named file through one bounded reader, errors at check time with
// file:line, nothing of an unrelated file quoted.

/// `femu validate` (or `run`) with `env`, killed after 60 s so that an unbounded read fails the
/// test instead of exhausting the machine's memory.
fn femu_bounded(args: &[&std::ffi::OsStr], env: &[(&str, &str)]) -> (Option<i32>, String) {
    let mut cmd = femu();
    cmd.args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().unwrap();
    let t0 = std::time::Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if t0.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("femu {args:?} did not finish within 60 s (an unbounded read?)");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A pipeline of one import stage reading `path` (with extra `with:` entries), written in `dir`.
fn import_pipeline(
    dir: &std::path::Path,
    kind: &str,
    path: &str,
    extra: &str,
) -> std::path::PathBuf {
    let file = dir.join("p.yaml");
    std::fs::write(
        &file,
        format!(
            "name: imp\nstages:\n  imp:\n    kind: {kind}\n    with: {{path: '{path}'{extra}}}\n"
        ),
    )
    .unwrap();
    file
}

fn validate(file: &std::path::Path, env: &[(&str, &str)]) -> (Option<i32>, String) {
    femu_bounded(&["validate".as_ref(), file.as_os_str()], env)
}

#[test]
fn devices_are_refused_at_check_time_without_reading_them() {
    let dir = tempfile::tempdir().unwrap();
    for kind in ["mesh.import", "frf.import"] {
        for dev in ["/dev/zero", "/dev/urandom"] {
            let p = import_pipeline(dir.path(), kind, dev, "");
            let (code, err) = validate(&p, &[]);
            assert_eq!(code, Some(2), "{kind} {dev}: {err}");
            assert!(
                err.contains(dev) && err.contains("is a character device, not a regular file"),
                "{kind} {dev}: {err}"
            );
        }
        let p = import_pipeline(dir.path(), kind, ".", "");
        let (code, err) = validate(&p, &[]);
        assert_eq!(code, Some(2), "{err}");
        assert!(err.contains("is a directory, not a regular file"), "{err}");
    }
}

#[test]
fn the_size_limit_holds_for_a_deck_with_includes_and_can_be_raised() {
    let dir = tempfile::tempdir().unwrap();
    let deck = std::fs::read_to_string(root().join("fixtures/nastran/plate_with_bar.bdf")).unwrap();
    // The deck's bulk data (about 3 kB) in an INCLUDE under a 20-byte main file.
    let bulk = &deck[deck.find("BEGIN BULK").unwrap() + "BEGIN BULK".len()..];
    assert!(bulk.len() > 2048);
    std::fs::write(dir.path().join("cards.bdf"), bulk).unwrap();
    std::fs::write(dir.path().join("main.bdf"), "INCLUDE 'cards.bdf'\n").unwrap();
    let p = import_pipeline(dir.path(), "mesh.import", "main.bdf", "");
    let (code, err) = validate(&p, &[("FEMU_MAX_INPUT_BYTES", "2K")]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("main.bdf line 1: INCLUDE of `cards.bdf` failed")
            && err.contains("larger than the input limit of")
            && err.contains("FEMU_MAX_INPUT_BYTES"),
        "{err}"
    );
    let (code, err) = validate(&p, &[("FEMU_MAX_INPUT_BYTES", "8K")]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = validate(&p, &[("FEMU_MAX_INPUT_BYTES", "lots")]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("FEMU_MAX_INPUT_BYTES = `lots` is not a byte count"),
        "{err}"
    );
    // The UFF reader under the same limit.
    std::fs::copy(
        root().join("fixtures/uff/four_dof_receptance.uff"),
        dir.path().join("m.uff"),
    )
    .unwrap();
    let p = import_pipeline(dir.path(), "frf.import", "m.uff", "");
    let (code, err) = validate(&p, &[("FEMU_MAX_INPUT_BYTES", "1000")]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("larger than the input limit of 1000 bytes"),
        "{err}"
    );
    assert_eq!(validate(&p, &[]).0, Some(0));
}

#[test]
fn a_file_of_another_kind_is_not_quoted_in_errors() {
    let dir = tempfile::tempdir().unwrap();
    let secret = "root:x:0:0:hunter2-topsecret:/root:/bin/bash\nalice:x:1000:1000:Alice Secret:/home/alice:/bin/sh\n";
    std::fs::write(dir.path().join("passwd"), secret).unwrap();
    std::fs::write(
        dir.path().join("words.txt"),
        "Lorem ipsum dolor\nsit amet\n",
    )
    .unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    for kind in ["mesh.import", "frf.import"] {
        for (path, words) in [
            (
                "../passwd",
                &["root", "hunter2", "alice", "Secret", "bash"][..],
            ),
            ("../words.txt", &["Lorem", "LOREM", "ipsum", "dolor"][..]),
        ] {
            let p = import_pipeline(&sub, kind, path, "");
            let (code, err) = validate(&p, &[]);
            assert_eq!(code, Some(2), "{kind} {path}: {err}");
            assert!(err.contains(path.trim_start_matches("../")), "{err}");
            assert!(err.contains("does not look like"), "{kind} {path}: {err}");
            for w in words {
                assert!(!err.contains(w), "{kind} {path} quotes {w}: {err}");
            }
        }
    }
}

/// The fixture's first data value replaced by `bad` (ASCII), or one value of its FRF set made
/// `bad` and written as 58b.
fn uff_with(bad: &str, binary: bool) -> Vec<u8> {
    let fixture = root().join("fixtures/uff/four_dof_receptance.uff");
    if !binary {
        let text = std::fs::read_to_string(&fixture).unwrap();
        return text.replacen("-1.751989356819E-05", bad, 1).into_bytes();
    }
    let file = femu::frf::io::uff::read_uff(&fixture).unwrap();
    let mut set = femu::frf::io::uff::to_frf_set(&file.frfs).unwrap();
    let v: f64 = bad.parse().unwrap();
    set.values[(3, 1)] = faer::c64::new(0.0, v);
    femu::frf::io::uff::write_uff58(&set, true)
}

#[test]
fn nan_or_inf_in_measured_frfs_is_an_error_naming_record_line_and_frequency() {
    let dir = tempfile::tempdir().unwrap();
    for (bad, binary, want) in [
        (
            "NaN",
            false,
            "m.uff:15: dataset 58 (FRF record 1 of the file, header at line 2), H(1:ux, 1:ux): the value of spectral line 3 (15 Hz) is NaN in the real part",
        ),
        (
            "inf",
            false,
            "m.uff:15: dataset 58 (FRF record 1 of the file, header at line 2), H(1:ux, 1:ux): the value of spectral line 3 (15 Hz) is inf in the real part",
        ),
        (
            "-1.0E+999",
            false,
            "the value of spectral line 3 (15 Hz) is -inf in the real part",
        ),
        (
            "NaN",
            true,
            "dataset 58b (FRF record 2 of the file, header at line",
        ),
        (
            "inf",
            true,
            "the value of spectral line 4 (20 Hz) is inf in the imaginary part",
        ),
    ] {
        std::fs::write(dir.path().join("m.uff"), uff_with(bad, binary)).unwrap();
        let p = import_pipeline(dir.path(), "frf.import", "m.uff", "");
        let (code, err) = validate(&p, &[]);
        assert_eq!(code, Some(2), "{bad} {binary}: {err}");
        assert!(err.contains(want), "{bad} {binary}: {err}");
        assert!(err.contains("measured values must be finite"), "{err}");
    }
    // The unchanged file is accepted (the tests above fail for the value, not the file).
    std::fs::write(
        dir.path().join("m.uff"),
        uff_with("-1.751989356819E-05", false),
    )
    .unwrap();
    assert_eq!(
        validate(&import_pipeline(dir.path(), "frf.import", "m.uff", ""), &[]).0,
        Some(0)
    );
}

#[test]
fn cards_femu_does_not_read_fail_the_check_unless_ignored_and_are_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let deck = std::fs::read_to_string(root().join("fixtures/nastran/plate_with_bar.bdf")).unwrap();
    let with_cshear = deck.replace("ENDDATA", "CSHEAR,900,1,1,2,3,7\nENDDATA");
    let line = with_cshear
        .lines()
        .position(|l| l.starts_with("CSHEAR"))
        .unwrap()
        + 1;
    std::fs::write(dir.path().join("plate.bdf"), &with_cshear).unwrap();
    let p = import_pipeline(dir.path(), "mesh.import", "plate.bdf", "");
    let (code, err) = validate(&p, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("1 card(s) femu does not read may change the stiffness, mass or constraints")
            && err.contains("CSHEAR ×1 (first at ")
            && err.contains(&format!("plate.bdf line {line})")),
        "{err}"
    );
    // Accepted on request: run, and the artefact's meta lists what was skipped and dropped.
    let p = import_pipeline(
        dir.path(),
        "mesh.import",
        "plate.bdf",
        ", ignore_cards: [cshear]",
    );
    let (_, report, cache) = run(&p, &dir.path().join("cache"), &[]);
    let a = cache
        .read(
            &report.stages[0].key,
            "mesh",
            femu::artefact::ArtefactKind::Mesh,
        )
        .unwrap();
    assert_eq!(a.meta["ignored_cards"], serde_json::json!({"CSHEAR": 1}));
    assert_eq!(
        a.meta["skipped_cards"],
        serde_json::json!({"PARAM,POST": 1})
    );
    assert_eq!(
        a.meta["eigenvalue_request"],
        serde_json::json!({"count": 10}),
        "EIGRL is read: METHOD = 1 selects it"
    );
    assert_eq!(a.meta["ignore_cards"], serde_json::json!(["cshear"]));
    // An ignore list naming a card femu reads is refused at check time.
    let p = import_pipeline(
        dir.path(),
        "mesh.import",
        "plate.bdf",
        ", ignore_cards: [GRID]",
    );
    let (code, err) = validate(&p, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("femu reads GRID, so it cannot be ignored"),
        "{err}"
    );
}

#[test]
fn a_material_femu_cannot_use_fails_the_check_at_its_card() {
    let dir = tempfile::tempdir().unwrap();
    let deck = std::fs::read_to_string(root().join("fixtures/nastran/plate_with_bar.bdf")).unwrap();
    let mat = deck.lines().find(|l| l.starts_with("MAT1")).unwrap();
    let line = deck.lines().position(|l| l.starts_with("MAT1")).unwrap() + 1;
    // Small field: E in columns 25-32.
    let zero = mat.replacen("2.1+11  ", "0.      ", 1);
    assert_ne!(zero, mat);
    std::fs::write(dir.path().join("plate.bdf"), deck.replace(mat, &zero)).unwrap();
    let p = import_pipeline(dir.path(), "mesh.import", "plate.bdf", "");
    let (code, err) = validate(&p, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "plate.bdf line {line}: MAT1 field 3 (E): E = 0 is not positive"
        )),
        "{err}"
    );
}

/// `mesh.export` writes a parameter change back into the user's deck: the PSHELL thickness and
/// the PBARL BAR height change, nothing else does, and the deck read back is the updated model.
#[test]
fn updated_values_go_back_into_the_users_deck() {
    let dir = tempfile::tempdir().unwrap();
    let deck = root().join("fixtures/nastran/plate_with_bar.bdf");
    std::fs::copy(&deck, dir.path().join("plate.bdf")).unwrap();
    let text = "name: export\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: plate.bdf}\n  updated:\n    kind: mesh.parameters\n    inputs: {mesh: mesh}\n    with:\n      declare:\n        - {name: t, kind: shell_thickness, set: pid1}\n        - {name: h, kind: beam_height, set: pid2}\n      values: {t: 0.0022, h: 0.025}\n  deck:\n    kind: mesh.export\n    inputs: {mesh: updated}\n    with: {path: plate.bdf}\n";
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, text).unwrap();
    let (_, report, cache) = run(&file, &dir.path().join("cache"), &[]);
    let key = |name: &str| &report.stages.iter().find(|s| s.name == name).unwrap().key;
    let a = cache
        .read(
            key("deck"),
            "deck",
            femu::artefact::ArtefactKind::NastranDeck,
        )
        .unwrap();
    use femu::artefact::kinds::Kind;
    let written = femu::artefact::kinds::nastran_deck::NastranDeckKind::from_artefact(&a).unwrap();
    let changed: Vec<String> = written
        .changes
        .iter()
        .map(|c| format!("{} {} {} -> {}", c.card, c.field, c.old, c.new))
        .collect();
    assert_eq!(
        changed,
        ["PSHELL 1 T 2.-3 -> .0022", "PBARL 2 DIM2 .02 -> .025"],
        "{changed:?}"
    );
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    for (name, bytes) in &written.files {
        std::fs::write(out.join(name), bytes).unwrap();
    }
    let back = femu::model::import::nastran::read_bulk(out.join("plate.bdf"))
        .unwrap()
        .model;
    let mesh = cache
        .read(key("updated"), "mesh", femu::artefact::ArtefactKind::Mesh)
        .unwrap();
    let updated = femu::artefact::mesh::mesh_from_artefact(&mesh).unwrap();
    assert_eq!(back.shell_properties, updated.shell_properties);
    assert_eq!(back.beam_properties, updated.beam_properties);
    assert_eq!(back.materials, updated.materials);
    assert_eq!(back.elements, updated.elements);
    // Every line of the original outside the two cards is in the written deck as it was.
    let original = std::fs::read_to_string(dir.path().join("plate.bdf")).unwrap();
    let new = String::from_utf8(written.files[0].1.clone()).unwrap();
    let kept = original
        .lines()
        .filter(|l| !(l.starts_with("PSHELL") || l.starts_with("PBARL") || l.starts_with("+PB2")))
        .all(|l| new.lines().any(|n| n == l));
    assert!(kept, "{new}");
}

/// The shipped mixed deck against hand values: total mass and centre of gravity from the
/// drawing (panel 0.6 × 0.4 × 0.003 m steel, two 10 × 25 mm bars offset 14 mm down, a
/// 0.1 × 0.1 × 0.04 m aluminium block, 2.5 kg 30 mm above its mount at 0.06 m, 0.3 kg at
/// r = 0.6 m, θ = 10° about (−0.1, 0.2) at z = 0.02), and the 12 modes its EIGRL asks for.
#[test]
fn the_shipped_mixed_deck_has_its_drawings_mass_and_the_modes_its_eigrl_asks_for() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, report, cache) = run(&pipeline("nastran-model"), &tmp.path().join("cache"), &[]);
    let read = |stage: &str, port: &str, kind| {
        let s = report.stages.iter().find(|s| s.name == stage).unwrap();
        cache.read(&s.key, port, kind).unwrap()
    };
    let mesh = read("panel", "mesh", femu::artefact::ArtefactKind::Mesh);
    let summary = &mesh.meta["weight_summary"];
    let (panel, bars, block) = (
        0.6 * 0.4 * 0.003 * 7850.0,
        2.0 * 0.6 * 0.010 * 0.025 * 7850.0,
        0.1 * 0.1 * 0.04 * 2700.0,
    );
    let accessory = [
        -0.1 + 0.6 * 10f64.to_radians().cos(),
        0.2 + 0.6 * 10f64.to_radians().sin(),
        0.02,
    ];
    let total = panel + bars + block + 2.5 + 0.3;
    let cg = [
        (total - 0.3) * 0.3 + 0.3 * accessory[0],
        (total - 0.3) * 0.2 + 0.3 * accessory[1],
        bars * -0.014 + block * 0.02 + 2.5 * 0.09 + 0.3 * 0.02,
    ]
    .map(|m| m / total);
    for k in 0..3 {
        let mass = summary["mass"][k].as_f64().unwrap();
        let c = summary["centre_of_gravity"][k].as_f64().unwrap();
        assert!((mass - total).abs() < 1e-12 * total, "{mass} vs {total}");
        assert!((c - cg[k]).abs() < 1e-12, "{k}: {c} vs {}", cg[k]);
    }
    let modes = femu::artefact::kinds::modes_from_artefact(&read(
        "modes",
        "modes",
        femu::artefact::ArtefactKind::Modes,
    ))
    .unwrap();
    assert_eq!(
        (modes.modes.len(), modes.modes.rigid_body_modes),
        (12, 0),
        "EIGRL 10: ND = 12, clamped"
    );
    assert!(modes.modes.residuals.iter().all(|r| *r < 1e-9));
}
