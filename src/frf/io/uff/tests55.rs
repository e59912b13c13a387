//! Dataset 55: reading mode shapes, making complex shapes real, and writing them back.

use super::write::{ModeRecord, write_uff55};
use super::{UffError, parse_uff, realisation, to_test_modes};
use crate::core::{Component, DofId};
use faer::c64;

fn dof(n: u64, c: Component) -> DofId {
    DofId::new(n, c)
}

/// Written FE modes come back with their frequencies, their shapes to the 7 digits of the
/// `E13.5` columns, and without the components that are zero in every mode.
#[test]
fn written_modes_read_back() {
    let dofs = vec![
        dof(1, Component::Uz),
        dof(2, Component::Uz),
        dof(3, Component::Ux),
        dof(3, Component::Uz),
    ];
    let s1 = [0.25, -1.5e-3, 0.75, 1.0];
    let s2 = [1.0, 0.5, -0.125, 3.0e4];
    let modes = [
        ModeRecord {
            mode: 1,
            freq_hz: 12.5,
            modal_mass: 1.0,
            damping_ratio: 0.01,
            shape: &s1,
        },
        ModeRecord {
            mode: 2,
            freq_hz: 40.123456,
            modal_mass: 1.0,
            damping_ratio: 0.0,
            shape: &s2,
        },
    ];
    let bytes = write_uff55(&dofs, &modes, "femu test").unwrap();
    let file = parse_uff(&bytes, "modes.uff").unwrap();
    assert_eq!(file.shapes.len(), 2);
    let t = to_test_modes(&file).unwrap();
    // Nodes 1, 2: x, y zero; node 3: y zero — all left out.
    assert_eq!(t.dofs, dofs);
    assert!(
        t.notes.iter().any(|n| n.contains("5 DOF(s) zero")),
        "{:?}",
        t.notes
    );
    assert_eq!(t.freqs_hz.len(), 2);
    assert!((t.freqs_hz[1] - 40.123456).abs() < 1e-5);
    assert_eq!(t.damping_ratios, vec![0.01, 0.0]);
    assert_eq!(t.modal_mass, vec![1.0, 1.0]);
    for (c, s) in [s1, s2].iter().enumerate() {
        for (i, v) in s.iter().enumerate() {
            let got = t.shapes[(i, c)];
            assert!(
                (got - v).abs() <= 1e-6 * v.abs(),
                "mode {c} row {i}: {got} vs {v}"
            );
        }
    }
    // Rotations make the records six values per node.
    let rot = vec![dof(7, Component::Ry)];
    let one = [2.0];
    let bytes = write_uff55(
        &rot,
        &[ModeRecord {
            mode: 1,
            freq_hz: 1.0,
            modal_mass: 0.0,
            damping_ratio: 0.0,
            shape: &one,
        }],
        "",
    )
    .unwrap();
    let t = to_test_modes(&parse_uff(&bytes, "r.uff").unwrap()).unwrap();
    assert_eq!(t.dofs, rot);
    assert_eq!(t.shapes[(0, 0)], 2.0);
    let e = write_uff55(&[dof(9, Component::Scalar)], &[], "").unwrap_err();
    assert!(e.contains("scalar"), "{e}");
}

/// The mode phase collinearity from the eigenvalues of the covariance of the real and
/// imaginary parts, `((λ₁ − λ₂)/(λ₁ + λ₂))²` (Vacher et al.; `λ₁/(λ₁ + λ₂)` is Pappa's share of
/// the scatter along the best line), an independent route to the one [`realisation`] takes.
fn covariance_mpc(phi: &[c64]) -> f64 {
    let sxx: f64 = phi.iter().map(|v| v.re * v.re).sum();
    let syy: f64 = phi.iter().map(|v| v.im * v.im).sum();
    let sxy: f64 = phi.iter().map(|v| v.re * v.im).sum();
    let (tr, det) = (sxx + syy, sxx * syy - sxy * sxy);
    let root = (tr * tr / 4.0 - det).max(0.0).sqrt();
    let (l1, l2) = (tr / 2.0 + root, tr / 2.0 - root);
    ((l1 - l2) / (l1 + l2)).powi(2)
}

#[test]
fn collinearity_matches_the_covariance_form() {
    let cases: [&[c64]; 3] = [
        &[c64::new(1.0, 0.0), c64::new(1.0, 1.0)],
        &[c64::new(0.3, -0.2), c64::new(-1.0, 0.4), c64::new(0.5, 0.5)],
        &[c64::new(2.0, 0.1), c64::new(-1.0, 0.05)],
    ];
    for phi in cases {
        let (_, mpc) = realisation(phi);
        let reference = covariance_mpc(phi);
        assert!((mpc - reference).abs() < 1e-12, "{mpc} vs {reference}");
    }
    // [1, 1+i]: |Σφ²|² / (Σ|φ|²)² = 5/9.
    let (_, mpc) = realisation(&[c64::new(1.0, 0.0), c64::new(1.0, 1.0)]);
    assert!((mpc - 5.0 / 9.0).abs() < 1e-15);
    // A circular shape has no best real direction.
    let (_, mpc) = realisation(&[c64::new(1.0, 0.0), c64::new(0.0, 1.0)]);
    assert!(mpc.abs() < 1e-15);
}

/// A hand-written complex mode (analysis type 3), values touching in their columns: the
/// frequency and damping come from the eigenvalue, the shape is the monophase shape's real
/// direction with its largest component positive.
#[test]
fn complex_mode_is_made_real() {
    let (zeta, w) = (0.02_f64, 2.0 * std::f64::consts::PI * 50.0);
    let lambda = c64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
    let real = [0.5, -1.0, 0.25];
    let rot = c64::new(0.3_f64.cos(), 0.3_f64.sin());
    let phi: Vec<c64> = real.iter().map(|r| rot * *r).collect();
    let e = |x: f64| format!("{x:13.5E}").replace('E', "E+").replace("E+-", "E-");
    let mut text = String::from(
        "    -1\n    55\nLab modes\nNONE\nNONE\nNONE\nNONE\n         1         3         2        12         5         3\n         2         6         1         4\n",
    );
    for v in [lambda.re, lambda.im, 0.0, 1.0, 0.0, 0.0] {
        text.push_str(&e(v));
    }
    text.push('\n');
    text.push_str("       101\n");
    for v in [phi[0].re, phi[0].im, 0.0, 0.0, phi[1].re, phi[1].im] {
        text.push_str(&e(v));
    }
    text.push_str("\n       102\n");
    for v in [0.0, 0.0, 0.0, 0.0, phi[2].re, phi[2].im] {
        text.push_str(&e(v));
    }
    text.push_str("\n    -1\n");
    let file = parse_uff(text.as_bytes(), "lab.uff").unwrap();
    let t = to_test_modes(&file).unwrap();
    assert_eq!(
        t.dofs,
        vec![
            dof(101, Component::Ux),
            dof(101, Component::Uz),
            dof(102, Component::Uz)
        ]
    );
    assert!((t.freqs_hz[0] - 50.0).abs() < 1e-4, "{}", t.freqs_hz[0]);
    assert!((t.damping_ratios[0] - zeta).abs() < 1e-5);
    assert!((t.collinearity[0] - 1.0).abs() < 1e-9);
    // Largest component (−1.0) made positive: the shape is −real.
    for (i, r) in real.iter().enumerate() {
        assert!(
            (t.shapes[(i, 0)] + r).abs() < 1e-5,
            "{} vs {}",
            t.shapes[(i, 0)],
            -r
        );
    }
    assert!(t.notes.iter().any(|n| n.contains("made real")));
    assert_eq!(t.source_mode, vec![4]);
}

/// Data at nodes that are not mode shapes are skipped with the reason; a file with none is
/// refused, saying so.
#[test]
fn other_data_at_nodes_are_skipped() {
    let text = "    -1\n    55\nODS\nNONE\nNONE\nNONE\nNONE\n         1         5         2         8         5         3\n         2         1         1         7\n  1.00000E+02\n         1\n  1.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00\n    -1\n";
    let file = parse_uff(text.as_bytes(), "ods.uff").unwrap();
    assert_eq!(file.skipped_shapes, 1);
    assert!(
        file.warnings
            .iter()
            .any(|w| w.contains("ods.uff:2") && w.contains("analysis type 5 (frequency response)")),
        "{:?}",
        file.warnings
    );
    let e = to_test_modes(&file).unwrap_err();
    assert!(matches!(e, UffError::NoShapes { skipped: 1 }));
    assert!(
        e.to_string()
            .contains("1 other dataset 55 record(s) were skipped"),
        "{e}"
    );
}

/// Malformed records are refused with the file, line, record and field.
#[test]
fn malformed_records_are_refused() {
    let head = "    -1\n    55\nA\nB\nC\nD\nE\n";
    let r6 = "         1         2         2         8         2         3\n";
    let r7 = "         2         4         1         1\n";
    let r8 = "  1.00000E+01  1.00000E+00  0.00000E+00  0.00000E+00\n";
    let cases = [
        (
            format!(
                "{head}         1         2         2         8         2         6\n{r7}{r8}    -1\n"
            ),
            "record 6, field 6 (values per node)",
        ),
        (
            format!("{head}{r6}{r7}{r8}         1\n  1.00000E+00  2.00000E+00\n    -1\n"),
            "values of node 1",
        ),
        (
            format!("{head}{r6}{r7}{r8}         1\n  1.00000E+00  NaN  1.0\n    -1\n"),
            "value 2 of node 1",
        ),
        (
            format!(
                "{head}{r6}{r7}{r8}         1\n  1.0 2.0 3.0\n         1\n  1.0 2.0 3.0\n    -1\n"
            ),
            "each node once per mode",
        ),
        (
            format!("{head}{r6}         2         3         1         1\n{r8}    -1\n"),
            "numbers of integer and real values",
        ),
    ];
    for (text, want) in cases {
        let e = parse_uff(text.as_bytes(), "bad.uff")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bad.uff:") && e.contains(want),
            "{e}\nwanted {want}"
        );
    }
    let one = format!("{head}{r6}{r7}{r8}         1\n  1.0 2.0 3.0\n    -1\n");
    let twice = format!("{one}{one}");
    let file = parse_uff(twice.as_bytes(), "twice.uff").unwrap();
    let e = to_test_modes(&file).unwrap_err().to_string();
    assert!(
        e.contains("twice.uff:15") && e.contains("mode 1") && e.contains("line 2"),
        "{e}"
    );
}

/// Under a dataset 164 in millimetres, a shape's translations come in metres and its rotations
/// stay in radians (a mixed shape would otherwise weigh translations 1000:1), and the
/// conversion is recorded once for the file.
#[test]
fn translations_follow_the_164_length_unit_and_rotations_do_not() {
    let dofs = vec![
        dof(1, Component::Ux),
        dof(1, Component::Uz),
        dof(1, Component::Rx),
        dof(2, Component::Uz),
        dof(2, Component::Ry),
    ];
    let s1 = [2.5, -4.0, 0.003, 8.0, -0.002];
    let s2 = [1.0, 2.0, -0.001, -3.0, 0.004];
    let records = [(1, 10.0, &s1), (2, 25.0, &s2)].map(|(mode, freq_hz, shape)| ModeRecord {
        mode,
        freq_hz,
        modal_mass: 0.0,
        damping_ratio: 0.0,
        shape,
    });
    let units = concat!(
        "    -1\n   164\n",
        "         5mm (milli newton)            2\n",
        "  1.00000000000000000D+03  1.00000000000000000D+03  1.00000000000000000D+00\n",
        "  2.73150000000000000D+02\n",
        "    -1\n"
    );
    let mut bytes = units.as_bytes().to_vec();
    bytes.extend(write_uff55(&dofs, &records, "mm shapes").unwrap());
    let file = parse_uff(&bytes, "mm.uff").unwrap();
    let notes: Vec<&String> = file
        .conversions
        .iter()
        .filter(|c| c.contains("dataset 55"))
        .collect();
    assert_eq!(notes.len(), 1, "{:?}", file.conversions);
    assert!(notes[0].contains("2 dataset 55 mode shape(s)") && notes[0].contains("rad unchanged"));
    let t = to_test_modes(&file).unwrap();
    assert_eq!(t.dofs, dofs);
    for (c, s) in [s1, s2].iter().enumerate() {
        for (i, v) in s.iter().enumerate() {
            let want = if dofs[i].comp.is_rotation() {
                *v
            } else {
                v * 1e-3
            };
            let got = t.shapes[(i, c)];
            // Each shape's sign is fixed by its largest component (a translation here).
            assert!(
                (got.abs() - want.abs()).abs() <= 1e-6 * want.abs() && got * want > 0.0,
                "mode {c} {}: {got} vs {want}",
                dofs[i]
            );
        }
    }

    // The same file in metres (no dataset 164) is read as written.
    let plain = parse_uff(&write_uff55(&dofs, &records, "m").unwrap(), "m.uff").unwrap();
    assert!(plain.conversions.is_empty());
    let t = to_test_modes(&plain).unwrap();
    assert!((t.shapes[(0, 0)] - 2.5).abs() < 1e-6 && (t.shapes[(2, 0)] - 0.003).abs() < 1e-9);
}
