//! The report's pieces against what they must guarantee: text escaped everywhere a user's names
//! appear, inline data that cannot close its script element, images encoded to the standard,
//! stages ordered by their wiring.

use super::collect::{StageView, collect};
use super::page::{base64_for_test, render_html};
use super::svg::{escape, pipeline_graph};
use super::*;

fn stage(name: &str, inputs: &[(&str, &str)]) -> StageView {
    StageView {
        name: name.into(),
        kind: "noise.add".into(),
        inputs: inputs
            .iter()
            .map(|(p, f)| (p.to_string(), f.to_string()))
            .collect(),
        outputs: vec![("frf".into(), "frf".into(), "ab".repeat(32))],
        timing: None,
        params: serde_json::Value::Null,
    }
}

/// RFC 4648's test vectors.
#[test]
fn base64_follows_rfc_4648() {
    for (plain, coded) in [
        ("", ""),
        ("f", "Zg=="),
        ("fo", "Zm8="),
        ("foo", "Zm9v"),
        ("foob", "Zm9vYg=="),
        ("fooba", "Zm9vYmE="),
        ("foobar", "Zm9vYmFy"),
    ] {
        assert_eq!(base64_for_test(plain.as_bytes()), coded);
    }
}

#[test]
fn text_is_escaped() {
    assert_eq!(
        escape(r#"<b a="1">&'"#),
        "&lt;b a=&quot;1&quot;&gt;&amp;&#39;"
    );
}

/// A warning that tries to close the data's script element stays text, in the data and on the
/// page.
#[test]
fn user_text_cannot_escape_its_place() {
    let evil = "</script><script>alert(1)</script>";
    let view = RunView {
        pipeline: evil.into(),
        stages: vec![stage(evil, &[])],
        warnings: vec![(evil.into(), evil.into())],
        frfs: vec![super::collect::FrfView {
            id: evil.into(),
            quantity: "receptance".into(),
            unit: "m/N".into(),
            freqs: vec![Some(1.0)],
            pairs: vec![],
            omitted_pairs: 0,
        }],
        ..RunView::default()
    };
    let html = render_html(&view);
    assert_eq!(
        html.matches("<script").count(),
        2,
        "only the page's own scripts"
    );
    assert_eq!(html.matches("</script>").count(), 2);
    assert!(!html.contains("alert(1)</script>"));
    assert!(html.contains("&lt;/script&gt;"));
}

/// Every stage is drawn, one box per stage, and one arrow per wired input.
#[test]
fn the_graph_draws_every_stage_and_wire() {
    let stages = vec![
        stage("a", &[]),
        stage("b", &[("frf", "a.frf")]),
        stage("c", &[("measured", "a.frf"), ("predicted", "b.frf")]),
    ];
    let svg = pipeline_graph(&stages);
    assert_eq!(svg.matches("<rect").count(), 3);
    assert_eq!(svg.matches("marker-end=").count(), 3);
    for n in ["a", "b", "c"] {
        assert!(svg.contains(&format!(">{n}</text>")), "{n}");
    }
}

/// A directory without a lock file is refused, naming what to give instead.
#[test]
fn a_directory_that_is_not_a_run_is_refused() {
    let dir = std::env::temp_dir().join(format!("femu-report-empty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let e = collect(&dir, &ReportOptions::default()).unwrap_err();
    assert!(e.to_string().contains("femu run --out"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
