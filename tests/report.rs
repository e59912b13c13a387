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
