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

fn posterior(correlation_23: f64) -> super::collect::PosteriorView {
    use super::collect::ParameterPosterior;
    let names = ["m1", "m2", "m3"];
    let r = |i: usize, j: usize| {
        if i == j {
            1.0
        } else if (i, j) == (1, 2) || (i, j) == (2, 1) {
            correlation_23
        } else {
            0.1
        }
    };
    let correlation: Vec<Vec<Option<f64>>> = (0..3)
        .map(|i| (0..3).map(|j| Some(r(i, j))).collect())
        .collect();
    super::collect::PosteriorView {
        id: "pc.posterior".into(),
        level: Some(0.9),
        sampler: "Laplace".into(),
        log_evidence: None,
        parameters: names
            .iter()
            .map(|n| ParameterPosterior {
                name: n.to_string(),
                updated: Some(1.0),
                mean: Some(1.01),
                sd: Some(0.02),
                lower: Some(0.98),
                upper: Some(1.04),
                r_hat: None,
                ess: None,
            })
            .collect(),
        ridges: if correlation_23.abs() > super::collect::RUN_RIDGE {
            vec![("m2".into(), "m3".into(), correlation_23)]
        } else {
            vec![]
        },
        correlation,
        bands: vec![],
    }
}

/// A ridge is said in words with its sign and the pair's names; without one the page says the
/// data determine each parameter. The correlation matrix has one cell per pair of parameters.
#[test]
fn the_posterior_names_its_ridges() {
    let page = |r: f64| {
        render_html(&RunView {
            posteriors: vec![posterior(r)],
            ..RunView::default()
        })
    };
    let ridge = page(-0.97);
    assert!(ridge.contains(
        "m2 and m3 are correlated at −0.97: the data determine their combination, not each."
    ));
    assert!(ridge.contains("<th>90 % interval</th>"));
    assert!(ridge.contains("id=\"posterior-viewer\" class=\"viewer\""));
    assert_eq!(ridge.matches("<rect class=\"corr\"").count(), 9);
    assert!(ridge.contains("m2 and m3: correlation −0.97"));
    let none = page(0.5);
    assert!(!none.contains("are correlated at"));
    assert!(none.contains("No two parameters are correlated beyond ±0.9"));
}

/// The pairing table lists the farthest point first, names what each point was paired to and
/// marks points beyond the tolerance.
#[test]
fn the_pairing_table_lists_the_farthest_first() {
    use super::collect::{TestPointView, TestPointsView};
    let point = |node: i64, fe_node: Option<i64>, fe_element: Option<i64>, d: f64| TestPointView {
        node,
        xyz: [0.0; 3],
        method: if fe_node.is_some() { "node" } else { "element" }.into(),
        fe_node,
        fe_element,
        distance_m: Some(d),
        status: if d > 0.002 { "beyond_tolerance" } else { "ok" }.into(),
    };
    let html = render_html(&RunView {
        test_points: vec![TestPointsView {
            id: "pair.map".into(),
            mesh: Some("plate.mesh".into()),
            tolerance_m: Some(0.002),
            points: vec![
                point(101, Some(1), None, 0.0),
                point(9004, None, Some(12), 0.001),
                point(9009, Some(3), None, 0.005),
            ],
        }],
        ..RunView::default()
    });
    let at = |s: &str| html.find(s).unwrap_or_else(|| panic!("missing {s}"));
    assert!(at("<td>9009</td>") < at("<td>9004</td>") && at("<td>9004</td>") < at("<td>101</td>"));
    assert!(
        html.contains("<tr class=\"bad\"><td>9009</td><td>node 3</td><td class=\"num\">5</td>")
    );
    assert!(html.contains("<td>9004</td><td>element 12</td><td class=\"num\">1</td><td>ok</td>"));
    assert!(html.contains("tolerance 2 mm, paired to the mesh plate.mesh"));
}
