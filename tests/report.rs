//! The run report (`femu report`, `femu run --report`) on shipped pipelines: every section a run
//! has is on the page, and — where a Chromium is installed (CI installs Debian's and sets
//! `FEMU_REQUIRE_BROWSER=1`, which makes a missing browser a failure) — the page renders in a
//! real headless browser with no script error, every viewer drawn, and a screenshot that is not
//! blank.

mod common;

use femu::pipeline::executor::materialise_with_lock;
use femu::pipeline::lock::LockFile;
use femu::run_report::{ReportOptions, write_report};
use std::path::{Path, PathBuf};

/// Runs a shipped pipeline into `dir/out` and writes its report; returns the page's path.
fn report_of(name: &str, dir: &Path) -> PathBuf {
    let (plan, report, cache) = common::run(&common::pipeline(name), &dir.join("cache"), &[]);
    let lock = LockFile::from_run(&plan, &report);
    let out = dir.join("out");
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    let opts = ReportOptions::from_run(&report, Some(format!("femu run {name}.yaml")));
    write_report(&out, None, &opts).unwrap()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("femu-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The headless browser, if one is installed.
fn chromium() -> Option<PathBuf> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|b| {
            std::env::var_os("PATH").and_then(|path| {
                std::env::split_paths(&path)
                    .map(|d| d.join(b))
                    .find(|p| p.is_file())
            })
        });
    if found.is_none() {
        assert!(
            std::env::var_os("FEMU_REQUIRE_BROWSER").is_none(),
            "FEMU_REQUIRE_BROWSER is set but no chromium is on PATH (apt-get install chromium)"
        );
        eprintln!("no chromium on PATH: the browser half of this test did not run");
    }
    found
}

/// The page as the browser leaves it after its scripts ran, and a screenshot.
fn render(browser: &Path, page: &Path, dir: &Path) -> (String, PathBuf) {
    let shot = dir.join("shot.png");
    let common_args = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--allow-file-access-from-files",
        "--virtual-time-budget=5000",
    ];
    let url = format!("file://{}", page.display());
    let profile = format!("--user-data-dir={}", dir.join("profile").display());
    let dom = std::process::Command::new(browser)
        .args(common_args)
        .arg(&profile)
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .expect("chromium runs");
    assert!(
        dom.status.success(),
        "{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let shot_run = std::process::Command::new(browser)
        .args(common_args)
        .arg(&profile)
        .arg("--window-size=1280,2000")
        .arg(format!("--screenshot={}", shot.display()))
        .arg(&url)
        .output()
        .expect("chromium runs");
    assert!(
        shot_run.status.success(),
        "{}",
        String::from_utf8_lossy(&shot_run.stderr)
    );
    (String::from_utf8_lossy(&dom.stdout).into_owned(), shot)
}

/// Distinct colours in a PNG: a blank or failed page has a handful.
fn colours(png: &Path) -> usize {
    let img = image::open(png).expect("a PNG screenshot").to_rgb8();
    let mut seen = std::collections::BTreeSet::new();
    for p in img.pixels() {
        seen.insert(p.0);
    }
    seen.len()
}

fn check_in_browser(page: &Path, dir: &Path, viewers: &[&str]) {
    let Some(browser) = chromium() else {
        return;
    };
    let (dom, shot) = render(&browser, page, dir);
    assert!(
        dom.contains("data-rendered=\"ok\""),
        "the scripts did not finish:\n{}",
        &dom[..dom.len().min(3000)]
    );
    assert!(
        dom.contains("id=\"report-errors\" hidden"),
        "a script error was shown"
    );
    for v in viewers {
        let tag = format!("id=\"{v}\" class=\"viewer\" data-ready=\"1\"");
        assert!(dom.contains(&tag), "{v} was not drawn");
    }
    assert!(
        dom.matches("<canvas").count() >= viewers.len(),
        "canvases missing"
    );
    assert!(colours(&shot) > 50, "the screenshot is nearly blank");
}

/// The four-DOF study: FRFs with their correlation, modes, the stages' figures, every artefact.
#[test]
fn four_dof_report_shows_frfs_modes_and_figures() {
    let dir = temp("four-dof");
    let page = report_of("four-dof", &dir);
    let html = std::fs::read_to_string(&page).unwrap();
    for must in [
        "femu run report: four-dof",
        "id=\"frf-viewer\"",
        "id=\"modal\"",
        "natural frequencies",
        "id=\"figures\"",
        "data:image/svg+xml;base64,",
        "command: <code>femu run four-dof.yaml</code>",
        "class=\"graph\"",
    ] {
        assert!(html.contains(must), "missing {must}");
    }
    assert!(
        !html.contains("src=\"http"),
        "the page must not load anything"
    );
    // Every artefact of the run is listed.
    let n = common::artefact_dirs(&dir.join("out")).len();
    assert_eq!(html.matches("<details>").count(), n);
    // The page is a function of the run: written twice, the same bytes.
    let again = write_report(
        &dir.join("out"),
        Some(&dir.join("again.html")),
        &ReportOptions::default(),
    )
    .unwrap();
    let first = write_report(
        &dir.join("out"),
        Some(&dir.join("first.html")),
        &ReportOptions::default(),
    )
    .unwrap();
    assert_eq!(std::fs::read(again).unwrap(), std::fs::read(first).unwrap());
    check_in_browser(&page, &dir, &["frf-viewer"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Localisation on the bent plate: the mesh in 3-D with the leverage on it, and its figures.
#[test]
fn localisation_report_shows_the_mesh_with_the_leverage() {
    let dir = temp("localise");
    let page = report_of("bent-plate-localise", &dir);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("id=\"mesh-viewer\""));
    assert!(html.contains("normalised leverage (5.9)"));
    check_in_browser(&page, &dir, &["mesh-viewer", "frf-viewer"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An update: its history drawn, its parameter table shown.
#[test]
fn update_report_shows_the_history() {
    let dir = temp("rfm");
    let page = report_of("four-dof-rfm", &dir);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("id=\"update-viewer\""));
    assert!(html.contains("<th>relative_change</th>"));
    check_in_browser(&page, &dir, &["update-viewer", "frf-viewer"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Through the command line: `femu run --report` writes the page beside the artefacts, `femu
/// report` rewrites it, and a directory that is not a run's output is bad input (exit 2).
#[test]
fn the_commands_write_the_page() {
    let dir = temp("cli");
    let out = dir.join("out");
    let run = common::femu()
        .args(["run", "--quiet", "--report", "--out"])
        .arg(&out)
        .arg("--cache-dir")
        .arg(dir.join("cache"))
        .arg(common::pipeline("four-dof"))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.contains("femu run report: four-dof") && page.contains("ran"));
    let again = common::femu()
        .arg("report")
        .arg(&out)
        .args(["--output"])
        .arg(dir.join("r.html"))
        .output()
        .unwrap();
    assert!(again.status.success());
    // The statuses and times come from the run record `femu run --out` left; without it the
    // page says they were not recorded.
    let page = std::fs::read_to_string(dir.join("r.html")).unwrap();
    assert!(page.contains("ran · ") && !page.contains("time not recorded"));
    std::fs::remove_file(out.join("femu.run.json")).unwrap();
    let bare = common::femu().arg("report").arg(&out).output().unwrap();
    assert!(bare.status.success());
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.contains("time not recorded"));
    let bad = common::femu().arg("report").arg(&dir).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("femu run --out"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Test points paired to a plate (the lab fixture of tests/pairing.rs): drawn as markers in the
/// 3-D mesh view, listed with what they were paired to and how far.
#[test]
fn pairing_report_shows_the_test_points_on_the_mesh() {
    let dir = temp("pairing");
    std::fs::copy(
        common::root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.join("lab-plate.uff"),
    )
    .unwrap();
    let yaml = "name: lab-pair\nstages:\n  plate:\n    kind: mesh.generate\n    with: {geometry: flat_plate, a_m: 0.4, b_m: 0.3, nx: 4, ny: 3, thickness_m: 0.002}\n  lab:\n    kind: frf.import\n    with: {path: lab-plate.uff}\n  pair:\n    kind: test.pair\n    inputs: {mesh: plate, geometry: lab.geometry, frf: lab.frf}\n    with: {tolerance_m: 0.002, alignment: {fit: [{test: 101, fe: 1}, {test: 105, fe: 5}, {test: 120, fe: 20}, {test: 116, fe: 16}]}}\n";
    let file = dir.join("lab-pair.yaml");
    std::fs::write(&file, yaml).unwrap();
    let (plan, report, cache) = common::run(&file, &dir.join("cache"), &[]);
    let lock = LockFile::from_run(&plan, &report);
    let out = dir.join("out");
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    let opts = ReportOptions::from_run(&report, Some("femu run lab-pair.yaml".into()));
    let page = write_report(&out, None, &opts).unwrap();
    let html = std::fs::read_to_string(&page).unwrap();
    let view = femu::run_report::collect(&out, &ReportOptions::default()).unwrap();
    assert_eq!(view.test_points.len(), 1);
    let points = &view.test_points[0];
    assert_eq!(points.mesh.as_deref(), Some("plate.mesh"));
    assert!(points.points.len() >= 8, "{}", points.points.len());
    for must in [
        "id=\"pairing\"",
        "<th>distance (mm)</th>",
        "tolerance 2 mm",
        "<td>9001</td><td>element 6</td>",
        "<td>101</td><td>node 1</td>",
        "\"test_points\":[{\"id\":\"pair.map\",\"mesh\":\"plate.mesh\"",
    ] {
        assert!(html.contains(must), "missing {must}");
    }
    check_in_browser(&page, &dir, &["mesh-viewer"]);
    if let Some(browser) = chromium() {
        let (dom, _) = render(&browser, &page, &dir);
        let n = format!("data-test-points=\"{}\"", points.points.len());
        assert!(dom.contains(&n), "the test points were not drawn ({n})");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The Bayesian four-DOF study: per posterior how it was computed (Laplace, MALA with R̂ and
/// effective samples per mass, TMCMC with its evidence), per mass its posterior mean, sd and
/// interval, the correlation matrix, the ridge sentence for every pair of masses correlated beyond ±0.9 (or that there is
/// none), the predictive bands in the FRF viewer; the version and command in the header.
#[test]
fn posterior_report_shows_intervals_correlations_and_ridges() {
    let dir = temp("bayes");
    let page = report_of("four-dof-bayes", &dir);
    let html = std::fs::read_to_string(&page).unwrap();
    let view = femu::run_report::collect(&dir.join("out"), &ReportOptions::default()).unwrap();
    let mut ids: Vec<&str> = view.posteriors.iter().map(|p| p.id.as_str()).collect();
    ids.sort_unstable();
    assert_eq!(
        ids,
        [
            "pc.posterior",
            "pc_estimated.posterior",
            "pc_mala.posterior",
            "tmcmc_chi_s.posterior",
            "tmcmc_frf.posterior",
            "tmcmc_modes.posterior"
        ]
    );
    let sampler = |id: &str| {
        let p = view.posteriors.iter().find(|p| p.id == id).unwrap();
        (
            p.sampler.as_str(),
            p.log_evidence.is_some(),
            p.parameters[0].r_hat.is_some(),
        )
    };
    assert_eq!(sampler("pc.posterior"), ("Laplace", false, false));
    assert_eq!(sampler("pc_mala.posterior"), ("MALA", false, true));
    assert_eq!(sampler("tmcmc_frf.posterior"), ("TMCMC", true, false));
    for must in [
        "id=\"posterior\"",
        "id=\"posterior-viewer\"",
        "<th>90 % interval</th>",
        "<td>m2</td>",
        "Laplace (Gaussian at the mode)",
        "MALA samples",
        "<th>R̂</th><th>effective samples</th>",
        "TMCMC samples, ln evidence",
        "svg class=\"correlation\"",
        "m1 and m2: correlation",
        &format!("run by femu {}", env!("CARGO_PKG_VERSION")),
        "command: <code>femu run four-dof-bayes.yaml</code>",
    ] {
        assert!(html.contains(must), "missing {must}");
    }
    let p = view
        .posteriors
        .iter()
        .find(|p| p.id == "pc.posterior")
        .unwrap();
    assert_eq!(p.parameters.len(), 4);
    assert!(!p.bands.is_empty(), "the study has predictive bands of |H|");
    check_in_browser(
        &page,
        &dir,
        &["posterior-viewer", "frf-viewer", "update-viewer"],
    );
    let dom = chromium().map(|b| render(&b, &page, &dir).0);
    for p in &view.posteriors {
        // Every pair beyond ±0.9 is named, and only those.
        let mut beyond = Vec::new();
        let n = p.parameters.len();
        for i in 0..n {
            for j in i + 1..n {
                if p.correlation[i][j].is_some_and(|r| r.abs() > 0.9) {
                    beyond.push((i, j));
                }
            }
        }
        assert_eq!(p.ridges.len(), beyond.len());
        for (a, b, r) in &p.ridges {
            let r = format!("{r:.2}").replace('-', "−");
            let sentence = format!(
                "{a} and {b} are correlated at {r}: the data determine their combination, not each."
            );
            assert!(html.contains(&sentence), "missing {sentence}");
            if let Some(dom) = &dom {
                assert!(dom.contains(&sentence), "not in the DOM: {sentence}");
            }
        }
    }
    if view.posteriors.iter().any(|p| p.ridges.is_empty()) {
        assert!(html.contains("No two parameters are correlated beyond ±0.9"));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
