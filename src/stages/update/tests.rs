use super::*;
use crate::pipeline::stage::parse_params;
use crate::pipeline::{Stage, Typed};
use serde_json::json;

fn check(with: serde_json::Value, ports: &[&str]) -> Result<serde_json::Value, Vec<ParamIssue>> {
    Typed::<Update>::new().check(&with, &CheckContext::with_ports(ports))
}

fn parse(with: serde_json::Value) -> Params {
    parse_params(&with).unwrap()
}

#[test]
fn rfm_needs_lines_and_one_model() {
    let e = check(json!({"method": "rfm"}), &["mesh", "model", "measured"]).unwrap_err();
    assert!(e.iter().any(|i| i.message.contains("exactly one")));
    assert!(e.iter().any(|i| i.path == vec!["lines_hz"]));
}

#[test]
fn eigensensitivity_needs_measured_modes() {
    let e = check(json!({"method": "eigensensitivity"}), &["mesh", "measured"]).unwrap_err();
    assert!(e[0].message.contains("measured_modes"), "{}", e[0].message);
}

#[test]
fn each_method_reads_its_own_fields() {
    let Params::Pc(p) = parse(json!({"method": "pc", "damping": {"structural": 0.01},
        "modes": {"count": 12}, "pc": {"smoothing": [0.1, 0.03], "subset_kappa": 5e7}}))
    else {
        panic!("not pc")
    };
    assert_eq!(p.modes.count.map(Count::get), Some(12));
    assert_eq!(p.pc.smoothing.len(), 2);
    assert_eq!(p.pc.kappa_f.get(), 0.95);
    let Params::Rfm(p) = parse(json!({"method": "rfm", "lines_hz": [5.0, 9.0]})) else {
        panic!("not rfm")
    };
    assert_eq!(p.lines_hz.len(), 2);
    assert_eq!(p.tolerance.get(), 1e-8);
    let Params::Eigensensitivity(p) = parse(json!({"method": "eigensensitivity",
        "measured_dofs": ["1:ux"], "min_mac": 0.8, "subset_kappa": 10.0}))
    else {
        panic!("not eigensensitivity")
    };
    assert_eq!(p.min_mac.get(), 0.8);
    assert_eq!(p.subset_kappa.map(|k| k.get()), Some(10.0));
    let Params::Damping(p) = parse(json!({"method": "damping", "damping": {"viscous": 0.01},
        "damping_modes": [7, 8]}))
    else {
        panic!("not damping")
    };
    // The damping identification's own defaults (DampingSettings::default).
    assert_eq!(p.pc.kappa_f.get(), 1.0);
    assert_eq!(p.pc.resonance_lines.get(), 0.0);
    assert_eq!(p.pc.subset_kappa.map(|k| k.get()), Some(1e7));
    assert_eq!(p.tolerance.get(), 1e-2);
    assert_eq!(p.damping_modes[0].get(), 7);
}

#[test]
fn a_field_of_another_method_is_refused() {
    for (with, field) in [
        (json!({"method": "rfm", "lines_hz": [5.0], "pc": {}}), "pc"),
        (json!({"method": "pc", "lines_hz": [5.0]}), "lines_hz"),
        (
            json!({"method": "pc", "damping_modes": [1]}),
            "damping_modes",
        ),
        (
            json!({"method": "damping", "pc": {"smoothing": [0.1]}}),
            "smoothing",
        ),
        (
            json!({"method": "damping", "sensitive_start": {}}),
            "sensitive_start",
        ),
    ] {
        let e = parse_params::<Params>(&with).unwrap_err();
        assert!(e.message.contains(field), "{with}: {}", e.message);
    }
    let e = parse_params::<Params>(&json!({"method": "simplex"})).unwrap_err();
    assert!(e.message.contains("unknown variant"), "{}", e.message);
    let e = parse_params::<Params>(&json!({"lines_hz": [1.0]})).unwrap_err();
    assert!(e.message.contains("method"), "{}", e.message);
}

#[test]
fn out_of_range_settings_name_the_field_and_the_range() {
    let e = check(
        json!({"method": "pc", "pc": {"kappa_f": 1.5}}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert!(e[0].message.contains("pc.kappa_f"), "{}", e[0].message);
    assert!(e[0].message.contains("(0, 1]"), "{}", e[0].message);
    let e = check(
        json!({"method": "pc", "pc": {"subset_kappa": 0.5}}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert!(e[0].message.contains("pc.subset_kappa"), "{}", e[0].message);
    assert!(e[0].message.contains("[1, ∞)"), "{}", e[0].message);
    let e = check(
        json!({"method": "damping", "damping_modes": [0]}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert!(
        e[0].message.contains("damping_modes[0]"),
        "{}",
        e[0].message
    );
    assert!(e[0].message.contains(">= 1"), "{}", e[0].message);
}

#[test]
fn old_spellings_are_read_with_a_deprecation() {
    let cases = [
        (
            json!({"method": "pc", "mode_count": 8}),
            "mode_count",
            "modes.count",
        ),
        (
            json!({"method": "damping", "damping": {"structural": 0.01}, "modes_max_hz": 400.0}),
            "modes_max_hz",
            "modes.max_freq_hz",
        ),
        (
            json!({"method": "eigensensitivity", "mode_count": 8}),
            "mode_count",
            "modes.count",
        ),
        (
            json!({"method": "eigensensitivity", "pc": {"subset_kappa": 1e7}}),
            "pc.subset_kappa",
            "subset_kappa",
        ),
        (
            json!({"method": "eigensensitivity", "pc": {"weighting_gamma": 0.5}}),
            "pc.weighting_gamma",
            "weighting_gamma",
        ),
    ];
    for (with, old, new) in cases {
        let mut p = parse(with.clone());
        let (issues, found) = p.migrate();
        assert!(issues.is_empty(), "{with}: {issues:?}");
        assert_eq!(found.len(), 1, "{with}");
        assert_eq!((found[0].old, found[0].new), (old, new));
        assert!(found[0].to_string().contains("deprecated"));
        // The checked form holds the new spelling alone, and reads back.
        let ports = match p.method() {
            Method::Eigensensitivity => vec!["mesh", "measured_modes"],
            _ => vec!["mesh", "measured"],
        };
        let checked = check(with.clone(), &ports).unwrap();
        assert!(checked.get(old).is_none(), "{checked}");
        let again: Params = parse(checked.clone());
        assert_eq!(serde_json::to_value(&again).unwrap(), checked);
    }
    let checked = check(
        json!({"method": "pc", "mode_count": 8}),
        &["mesh", "measured"],
    )
    .unwrap();
    assert_eq!(checked["modes"]["count"], 8);
    let e = check(
        json!({"method": "pc", "mode_count": 8, "modes": {"count": 9}}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert_eq!(e[0].path, vec!["modes"]);
}

#[test]
fn every_default_reads_back() {
    for with in [
        json!({"method": "pc"}),
        json!({"method": "rfm", "lines_hz": [1.0]}),
        json!({"method": "eigensensitivity"}),
        json!({"method": "damping", "damping": {"structural": 0.01}}),
    ] {
        let p = parse(with);
        let v = serde_json::to_value(&p).unwrap();
        let again: Params = parse(v.clone());
        assert_eq!(serde_json::to_value(&again).unwrap(), v);
    }
}

#[test]
fn method_combinations_the_types_cannot_say() {
    let e = check(
        json!({"method": "pc", "damping": {"rayleigh": {"alpha": 1.0, "beta": 0.0}}}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert_eq!(e[0].path, vec!["damping"]);
    let e = check(json!({"method": "damping"}), &["mesh", "measured"]).unwrap_err();
    assert!(e[0].message.contains("structural"), "{}", e[0].message);
    let e = check(
        json!({"method": "rfm", "lines_hz": [1.0]}),
        &["mesh", "measured", "partition"],
    )
    .unwrap_err();
    assert!(e[0].message.contains("disconnect `partition`"));
    let e = check(
        json!({"method": "pc", "modes": {"count": 3, "max_freq_hz": 10.0}}),
        &["mesh", "measured"],
    )
    .unwrap_err();
    assert_eq!(e[0].path, vec!["modes", "count"]);
}
