//! CQUAD8 and CTRIA6: decks reaching modes, blank midside grids against an equivalent deck with
//! MPCs, the exporter's round trip, and the errors and warnings, each naming file and line.

use super::tests::{error, parse};
use super::*;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;

/// The lowest `n` natural frequencies (Hz) of a model.
fn frequencies(m: &Model, mass: MassKind, n: usize) -> Vec<f64> {
    let (sys, _) = assemble_model(m, mass).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(n),
        &SparseEigenParams::default(),
    )
    .unwrap_or_else(|e| panic!("{e} ({} DOFs, {mass:?})", sys.dofs.len()));
    modes.frequencies_hz().to_vec()
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

const CARDS: &str = "MAT1,1,2.1+11,,.3,7850.\nPSHELL,1,1,.01,1,,1\n";

/// Grid id of point `(i, j)` of the `(2n + 1)²` grid of a unit square.
fn gid(n: usize, i: usize, j: usize) -> usize {
    j * (2 * n + 1) + i + 1
}

/// A unit square plate clamped at x = 0: the `(2n + 1)²` grid (only the grids some element uses,
/// unless `all_grids`), and `n × n` cells as CQUAD8 or two CTRIA6 each (`tria`).
fn plate(n: usize, tria: bool) -> String {
    let mut d = CARDS.to_string();
    let m = 2 * n + 1;
    for j in 0..m {
        for i in 0..m {
            if !tria && i % 2 == 1 && j % 2 == 1 {
                continue;
            }
            let ps = if i == 0 { ",123456" } else { "" };
            d += &format!(
                "GRID,{},,{:.17e},{:.17e},0.,{ps}\n",
                gid(n, i, j),
                i as f64 / (m - 1) as f64,
                j as f64 / (m - 1) as f64
            );
        }
    }
    let mut eid = 1;
    for cj in 0..n {
        for ci in 0..n {
            let (i, j) = (2 * ci, 2 * cj);
            let g = |a: usize, b: usize| gid(n, i + a, j + b);
            if tria {
                d += &format!(
                    "CTRIA6,{eid},1,{},{},{},{},{},{}\n",
                    g(0, 0),
                    g(2, 0),
                    g(2, 2),
                    g(1, 0),
                    g(2, 1),
                    g(1, 1)
                );
                d += &format!(
                    "CTRIA6,{},1,{},{},{},{},{},{}\n",
                    eid + 1,
                    g(0, 0),
                    g(2, 2),
                    g(0, 2),
                    g(1, 1),
                    g(1, 2),
                    g(0, 1)
                );
                eid += 2;
            } else {
                d += &format!(
                    "CQUAD8,{eid},1,{},{},{},{},{},{}\n,{},{}\n",
                    g(0, 0),
                    g(2, 0),
                    g(2, 2),
                    g(0, 2),
                    g(1, 0),
                    g(2, 1),
                    g(1, 2),
                    g(0, 1)
                );
                eid += 1;
            }
        }
    }
    d
}

/// The same plate of `n × n` CQUAD4.
fn quad4_plate(n: usize) -> String {
    let mut d = CARDS.to_string();
    let id = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..=n {
        for i in 0..=n {
            let ps = if i == 0 { ",123456" } else { "" };
            d += &format!(
                "GRID,{},,{:.17e},{:.17e},0.,{ps}\n",
                id(i, j),
                i as f64 / n as f64,
                j as f64 / n as f64
            );
        }
    }
    for j in 0..n {
        for i in 0..n {
            d += &format!(
                "CQUAD4,{},1,{},{},{},{}\n",
                j * n + i + 1,
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1)
            );
        }
    }
    d
}

/// A cantilever plate (t/a = 0.01) as 6 × 6 CQUAD8 and 6 × 6 cells of CTRIA6 reaches modes
/// through `assemble_model`; with the coupled mass its first four frequencies agree with a
/// 24 × 24 CQUAD4 deck (a second path, converged to ~0.3 % there: MITC4 converges as O(h²))
/// within 1 %, and CTRIA6 with CQUAD8 within 1 %. The lumped (HRZ) mass is a further O(h²)
/// error, from below: at 6 × 6 the CQUAD8 deck is 0.4–3.1 % under the quad4 reference (modes
/// 1–4), so the lumped decks are checked by convergence against the coupled 12 × 12 CQUAD8 deck
/// (O(h⁴), far closer than quad4 24 × 24): the lumped 12 × 12 deviation is at most half the
/// 6 × 6 one (O(h²) gives a quarter; a first-order error would fail) and below 1.5 %; at 6 × 6
/// both lumped decks are within 3.5 % of the quad4 reference (CTRIA6 and CQUAD8 lump
/// differently: they differ by up to 2 % there, the same O(h²) error). The first bending
/// frequency is also near the beam value `(1.875²/2π) √(D/(ρ t))` of a unit strip (plate effect
/// `1/(1−ν²)` in D, free edges: within 3 %).
#[test]
fn quadratic_shell_decks_reach_modes_and_agree_with_quad4() {
    let q8 = parse(&plate(6, false)).model;
    assert_eq!(q8.elements.len(), 36);
    assert!(matches!(
        q8.elements[&1],
        Element::Quad8 {
            midside: [Some(_), Some(_), Some(_), Some(_)],
            ..
        }
    ));
    let t6 = parse(&plate(6, true)).model;
    let q4 = parse(&quad4_plate(24)).model;
    let f4 = frequencies(&q4, MassKind::Consistent, 4);
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        let f8 = frequencies(&q8, mass, 4);
        let f6 = frequencies(&t6, mass, 4);
        for i in 0..4 {
            if mass == MassKind::Consistent {
                assert!(
                    rel(f8[i], f4[i]) < 0.01,
                    "{mass:?} mode {i}: {f8:?} vs quad4 {f4:?}"
                );
                assert!(
                    rel(f6[i], f8[i]) < 0.01,
                    "{mass:?} mode {i}: {f6:?} vs quad8 {f8:?}"
                );
            } else {
                // The O(h²) lumping error at 6 × 6 (measured ≤ 3.1 %, converging below).
                for f in [&f8, &f6] {
                    assert!(
                        rel(f[i], f4[i]) < 0.035,
                        "{mass:?} mode {i}: {f:?} vs {f4:?}"
                    );
                }
            }
        }
        let d = 2.1e11 * 0.01f64.powi(3) / (12.0 * (1.0 - 0.09));
        let beam = 1.875f64.powi(2) / (2.0 * std::f64::consts::PI) * (d / (7850.0 * 0.01)).sqrt();
        assert!(rel(f8[0], beam) < 0.03, "{} vs {beam}", f8[0]);
    }
    let fine = parse(&plate(12, false)).model;
    let reference = frequencies(&fine, MassKind::Consistent, 4);
    let lumped6 = frequencies(&q8, MassKind::Lumped, 4);
    let lumped12 = frequencies(&fine, MassKind::Lumped, 4);
    for i in 0..4 {
        let (e6, e12) = (
            rel(lumped6[i], reference[i]),
            rel(lumped12[i], reference[i]),
        );
        assert!(
            e12 < 0.5 * e6 + 1e-4 && e12 < 0.015,
            "lumped mode {i}: 6 x 6 {lumped6:?}, 12 x 12 {lumped12:?} vs coupled 12 x 12 {reference:?}"
        );
    }
}

/// Blank midside grids (straight edges): the deck equals, to round-off, the same deck with the
/// midside grids present at the edge midpoints and tied to the corners by MPCs
/// `u_m − ½ u_a − ½ u_b = 0` in all six components (an independent path through femu's
/// multipoint constraints). G6 and G8 (the edges along y) are blanked in every element, so each
/// such edge is straight in both its elements; each shared midside grid gets one MPC per
/// component (Nastran and femu refuse a DOF dependent twice). Consistent mass, tolerance 1e-8 (eigenvalues of
/// differently assembled systems); the lumped mass differs (the blank edge's share goes to the
/// corners, the tied grid keeps its own), so there only the modes are checked to exist.
#[test]
fn blank_midside_grids_equal_midpoint_grids_tied_by_mpcs() {
    let n = 3;
    let full = plate(n, false);
    let mut blank = String::new();
    let mut tied = String::new();
    let mut terms = Vec::new();
    let mut lines = full.lines();
    while let Some(line) = lines.next() {
        if line.starts_with("CQUAD8") {
            let cont = lines.next().unwrap();
            let f: Vec<&str> = line.split(',').collect();
            let c: Vec<&str> = cont.split(',').collect();
            blank += &format!(
                "{},{},{},{},{},{},{},{},\n,{},\n",
                f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], c[1]
            );
            tied += &format!("{line}\n{cont}\n");
            // G6 between G2 and G3, G8 between G4 and G1. The corners in ascending order: the
            // edge shared by two elements is G2–G3 in one and G4–G1 (reversed) in the other, and
            // it must give one MPC per component (a DOF may be dependent in one MPC only).
            for (m, a, b) in [(f[8], f[4], f[5]), (c[2], f[6], f[3])] {
                let (a, b) = (a.parse::<u64>().unwrap(), b.parse::<u64>().unwrap());
                terms.push((m.to_string(), a.min(b), a.max(b)));
            }
        } else {
            blank += &format!("{line}\n");
            tied += &format!("{line}\n");
        }
    }
    terms.sort();
    terms.dedup();
    for (m, a, b) in &terms {
        // Grids on the clamped edge (x = 0) are fixed with their corners: no MPC there.
        if (m.parse::<usize>().unwrap() - 1) % (2 * n + 1) == 0 {
            continue;
        }
        for c in 1..=6 {
            tied += &format!("MPC,1,{m},{c},-1.,{a},{c},.5\n,,{b},{c},.5\n");
        }
    }
    let b = parse(&blank);
    let t = parse(&tied);
    assert!(matches!(
        b.model.elements[&1],
        Element::Quad8 {
            midside: [Some(_), None, Some(_), None],
            ..
        }
    ));
    let fb = frequencies(&b.model, MassKind::Consistent, 5);
    let ft = frequencies(&t.model, MassKind::Consistent, 5);
    for i in 0..5 {
        assert!(rel(fb[i], ft[i]) < 1e-8, "mode {i}: {fb:?} vs {ft:?}");
    }
    let fl = frequencies(&b.model, MassKind::Lumped, 5);
    assert!(fl.iter().all(|f| f.is_finite() && *f > 0.0), "{fl:?}");
}

/// The exporter writes CQUAD8/CTRIA6 (blank where a midside grid is omitted) and re-importing
/// gives the same elements.
#[test]
fn exported_quadratic_shells_read_back() {
    let mut m = parse(&plate(2, true)).model;
    let g = |i: usize, j: usize| gid(2, i, j) as u64;
    if let Some(Element::Tria6 { midside, .. }) = m.elements.get_mut(&1) {
        midside[1] = None;
    }
    m.elements.insert(
        100,
        Element::Quad8 {
            corners: [g(0, 0), g(2, 0), g(2, 2), g(0, 2)],
            midside: [Some(g(1, 0)), None, Some(g(1, 2)), None],
            property: 1,
        },
    );
    let text = crate::model::export::nastran::write_bulk(&m);
    assert!(text.contains("CQUAD8") && text.contains("CTRIA6"), "{text}");
    let back = parse(&text).model;
    for (id, e) in &m.elements {
        assert_eq!(back.elements.get(id), Some(e), "element {id}");
    }
}

/// Errors name the file, line and field; corner thicknesses warn.
#[test]
fn bad_quadratic_shell_cards_are_named_and_thicknesses_warn() {
    let base = "MAT1,1,2.1+11,,.3,7850.\nPSHELL,1,1,.01,1,,1\nGRID,1,,0.,0.,0.\nGRID,2,,2.,0.,0.\nGRID,3,,2.,2.,0.\nGRID,4,,0.,2.,0.\nGRID,5,,1.,0.,0.\nGRID,6,,2.,1.,0.\nGRID,7,,1.,2.,0.\nGRID,8,,0.,1.,0.\n";
    // ZOFFS (CQUAD8 line 2 field 9).
    let e = error(&format!("{base}CQUAD8,1,1,1,2,3,4,5,6\n,7,8,,,,,,.1\n"));
    assert!(e.contains("t.bdf line 11") && e.contains("ZOFFS"), "{e}");
    // CTRIA6 ZOFFS (line 2 field 3).
    let e = error(&format!("{base}CTRIA6,1,1,1,2,3,5,6,8\n,,.1\n"));
    assert!(e.contains("t.bdf line 11") && e.contains("ZOFFS"), "{e}");
    // A repeated grid.
    let e = error(&format!("{base}CQUAD8,1,1,1,2,3,4,5,6\n,7,5\n"));
    assert!(
        e.contains("t.bdf line 11") && e.contains("G8") && e.contains("appears twice"),
        "{e}"
    );
    // A blank corner.
    let e = error(&format!("{base}CTRIA6,1,1,1,,3,5,6,8\n"));
    assert!(e.contains("t.bdf line 11") && e.contains("G2"), "{e}");
    // A midside grid far from its edge's middle: the element check names the card.
    let e = error(&format!(
        "{base}GRID,9,,1.,1.,0.\nCQUAD8,1,1,1,2,3,4,9,6\n,7,8\n"
    ));
    assert!(e.contains("line 12") && e.contains("midside"), "{e}");
    // Corner thicknesses: a warning, PSHELL T used.
    let b = parse(&format!(
        "{base}CQUAD8,1,1,1,2,3,4,5,6\n,7,8,.02,.02,.02,.02\n"
    ));
    assert!(
        b.warnings
            .iter()
            .any(|w| w.contains("t.bdf line 11") && w.contains("T1-T4")),
        "{:?}",
        b.warnings
    );
    // A quadratic shell on a laminate (or MAT8/MAT2) property: the kernel is isotropic.
    let lam = base.replace("PSHELL,1,1,.01,1,,1\n", "PCOMP,1\n,1,.005,0.,,1,.005,90.\n");
    let e = error(&format!("{lam}CQUAD8,1,1,1,2,3,4,5,6\n,7,8\n"));
    assert!(
        e.contains("element 1") && e.contains("property 1") && e.contains("MAT1"),
        "{e}"
    );
    // All midside grids blank: a straight-sided element.
    let b = parse(&format!("{base}CTRIA6,1,1,1,2,3\n"));
    assert_eq!(
        b.model.elements[&1],
        Element::Tria6 {
            corners: [1, 2, 3],
            midside: [None; 3],
            property: 1
        }
    );
}

/// Quadratic shells on grids with a displacement system (GRID CD): the element matrices are
/// turned into the grids' systems like every other element's, so a deck whose every grid has a
/// rotated CD (and the clamped grids all six components held in it, the same constraint) has
/// the frequencies of the deck without, to 1e-8 (eigenvalues of differently rotated systems).
#[test]
fn quadratic_shells_on_grids_with_displacement_systems() {
    for tria in [false, true] {
        let plain = plate(3, tria);
        let rotated = format!(
            "CORD2R,5,,0.,0.,0.,.3,.4,.866\n,1.,.2,.1\n{}",
            plain
                .replace("0.,\n", "0.,5\n")
                .replace("0.,,123456\n", "0.,5,123456\n")
        );
        let a = parse(&plain).model;
        let b = parse(&rotated).model;
        assert_eq!(b.displacement_systems.len(), b.nodes.len());
        let fa = frequencies(&a, MassKind::Consistent, 5);
        let fb = frequencies(&b, MassKind::Consistent, 5);
        for i in 0..5 {
            assert!(
                rel(fb[i], fa[i]) < 1e-8,
                "tria {tria} mode {i}: {fb:?} vs {fa:?}"
            );
        }
    }
}
