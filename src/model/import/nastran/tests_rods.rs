//! Rods (CROD/PROD, CONROD, CTUBE/PTUBE) and PSHELL with Nastran's meaning (MID1/MID2/MID3
//! blank or other materials, 12I/T³, TS/T), each against an analytic value or a second deck.

use super::tests::{error, parse};
use super::*;
use crate::core::sparse::sparse_to_dense;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model, element_matrices};
use crate::model::structure::{RodProperty, RodSection};
use std::f64::consts::PI;

/// The lowest `n` natural frequencies (Hz) of a model and its free DOFs.
fn frequencies(m: &Model, mass: MassKind, n: usize) -> (Vec<f64>, Vec<DofId>) {
    let (sys, _) = assemble_model(m, mass).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(n),
        &SparseEigenParams::default(),
    )
    .unwrap_or_else(|e| panic!("{e} ({} DOFs, {mass:?})", sys.dofs.len()));
    (modes.frequencies_hz().to_vec(), sys.dofs)
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// A bar of `n` rods along x, clamped at x = 0, only the axial translation free elsewhere
/// (GRID PS 23456); `element(i, g1, g2)` writes the element cards.
fn bar(n: usize, len: f64, props: &str, element: impl Fn(usize, usize, usize) -> String) -> String {
    let mut d = format!("MAT1,1,7.+10,,.33,2700.\n{props}");
    for i in 0..=n {
        let ps = if i == 0 { "123456" } else { "23456" };
        d += &format!(
            "GRID,{},,{:.17e},0.,0.,,{ps}\n",
            i + 1,
            len * i as f64 / n as f64
        );
    }
    for i in 0..n {
        d += &element(i + 1, i + 1, i + 2);
    }
    d
}

/// Fixed-free bar: f_n = (2n − 1)/(4L) √(E/ρ). 200 elements: the discretisation error of mode
/// n is about ±(k h)²/24 (k = (2n − 1)π/(2L), h = L/200), 6e-5 for mode 3, so the tolerance
/// is 1e-4 for both Nastran's lumped rod mass (frequencies below) and the coupled one (above).
#[test]
fn fixed_free_bar_axial_frequencies() {
    let len = 2.0;
    let deck = bar(200, len, "PROD,7,1,1.-4,,,\n", |e, a, b| {
        format!("CROD,{e},7,{a},{b}\n")
    });
    let m = parse(&deck).model;
    let c = (7.0e10f64 / 2700.0).sqrt();
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let (f, dofs) = frequencies(&m, mass, 3);
        assert_eq!(dofs.len(), 200, "only ux is free: rotations dropped");
        for (k, fk) in f.iter().enumerate() {
            let exact = (2 * k + 1) as f64 / (4.0 * len) * c;
            assert!(
                rel(*fk, exact) < 1e-4,
                "{mass:?} mode {}: {fk} vs {exact}",
                k + 1
            );
            let above = *fk > exact;
            assert_eq!(above, mass == MassKind::Consistent, "{mass:?} {fk} {exact}");
        }
    }
}

/// Rods in general directions with torsion and NSM: CONROD cards give exactly the matrices of
/// CROD + PROD cards with the same values; the CONROD is in no `pid<N>` set.
#[test]
fn conrod_equals_crod_with_prod() {
    let grids = "\
MAT1,1,2.1+11,,.3,7850.
GRID,1,,0.,0.,0.,,123456
GRID,2,,1.,.2,-.3
GRID,3,,.4,1.1,.5
GRID,4,,-.2,.3,1.
";
    let conn = [
        (1, 1, 2),
        (2, 2, 3),
        (3, 3, 1),
        (4, 2, 4),
        (5, 3, 4),
        (6, 4, 1),
    ];
    let mut a = format!("{grids}PROD,9,1,2.-4,3.-8,.01,.5\n");
    let mut b = grids.to_string();
    for (e, g1, g2) in conn {
        a += &format!("CROD,{e},9,{g1},{g2}\n");
        b += &format!("CONROD,{e},{g1},{g2},1,2.-4,3.-8,.01,.5\n");
    }
    let (ma, mb) = (parse(&a).model, parse(&b).model);
    assert_eq!(ma.sets["pid9"], vec![1, 2, 3, 4, 5, 6]);
    assert!(mb.sets.is_empty(), "{:?}", mb.sets);
    assert_eq!(
        mb.elements[&1],
        Element::Rod {
            nodes: [1, 2],
            section: RodSection::Own(RodProperty {
                material: 1,
                area: 2e-4,
                j: 3e-8,
                c: 0.01,
                nsm: 0.5,
                taper: None,
            }),
        }
    );
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let (sa, _) = assemble_model(&ma, mass).unwrap();
        let (sb, _) = assemble_model(&mb, mass).unwrap();
        assert_eq!(sa.dofs, sb.dofs);
        assert_eq!(sparse_to_dense(&sa.k), sparse_to_dense(&sb.k));
        assert_eq!(sparse_to_dense(&sa.m), sparse_to_dense(&sb.m));
    }
}

/// A CTUBE along x: axial stiffness E A / L with A = π(OD² − ID²)/4 and torsional G J / L with
/// J = π(OD⁴ − ID⁴)/32, written here from the tube's diameters (the importer uses
/// A = π(OD − T)T); Nastran's lumped rod mass, half of (ρA + NSM)L per end, no rotary inertia.
/// A PTUBE with T blank is the solid rod. Tolerance 1e-13 relative (round-off).
#[test]
fn tube_stiffness_and_mass_by_hand() {
    let (od, t, l) = (0.05, 0.005, 1.5);
    let id = od - 2.0 * t;
    let deck = "\
MAT1,1,2.1+11,,.3,7850.
PTUBE,3,1,.05,.005,.2
PTUBE,4,1,.05
CTUBE,1,3,1,2
CTUBE,2,4,1,2
GRID,1,,0.,0.,0.
GRID,2,,1.5,0.,0.
";
    let m = parse(deck).model;
    let area = PI * (od * od - id * id) / 4.0;
    let j = PI * (od.powi(4) - id.powi(4)) / 32.0;
    let g = 2.1e11 / 2.6;
    let em = element_matrices(&m, &m.elements[&1], MassKind::Lumped).unwrap();
    assert!(rel(em.k[(0, 0)], 2.1e11 * area / l) < 1e-13);
    assert!(rel(em.k[(3, 3)], g * j / l) < 1e-13);
    assert!(rel(em.k[(3, 9)], -g * j / l) < 1e-13);
    assert_eq!(em.k[(1, 1)], 0.0);
    assert_eq!(em.k[(4, 4)], 0.0);
    let half = (7850.0 * area + 0.2) * l / 2.0;
    for d in 0..3 {
        assert!(rel(em.m[(d, d)], half) < 1e-13);
        assert_eq!(em.m[(d + 3, d + 3)], 0.0);
    }
    let solid = &m.rod_properties[&4];
    assert!(rel(solid.area, PI * od * od / 4.0) < 1e-15);
    assert!(rel(solid.j, PI * od.powi(4) / 32.0) < 1e-15);
    assert_eq!(m.sets["pid3"], vec![1]);
}

#[test]
fn bad_rod_cards_are_named() {
    let base = "MAT1,1,2.1+11,,.3,7850.\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\n";
    let cases = [
        (
            "PTUBE,3,1,.05,.005,,-.06\nCTUBE,1,3,1,2\n",
            "PTUBE field 7 (OD2): OD2 = -0.06 with wall thickness T = 0.005",
        ),
        (
            "PTUBE,3,1,.05,.03\nCTUBE,1,3,1,2\n",
            "PTUBE field 5 (T): wall thickness 0.03 is not in [0, OD/2 = 0.025]",
        ),
        (
            "PTUBE,3,1,.05\nCROD,1,3,1,2\n",
            "CROD field 3 (PID): property 3 is a PTUBE, not a PROD",
        ),
        (
            "PROD,3,1,1.-4\nCTUBE,1,3,1,2\n",
            "CTUBE field 3 (PID): property 3 is a PROD, not a PTUBE",
        ),
        (
            "CROD,1,,1,2\n",
            "CROD field 3 (PID): property 1 is not a PROD of the deck",
        ),
        (
            "PROD,3,1,0.\nCROD,1,3,1,2\n",
            "PROD field 4 (A): 0 is not positive",
        ),
        ("CONROD,1,1,1,1,1.-4\n", "CONROD field 4 (G2): G2 is G1 (1)"),
        (
            "CONROD,1,1,2,5,1.-4\n",
            "element 1 refers to material 5, which is not defined; add MAT1 5",
        ),
    ];
    for (cards, want) in cases {
        let e = error(&format!("{base}{cards}"));
        assert!(e.contains(want), "{cards}: {e}");
    }
}

/// WTMASS scales a rod's NSM (and, through ρ, its structural mass), CONROD's too.
#[test]
fn wtmass_scales_rod_mass() {
    let deck = "\
PARAM,WTMASS,.5
MAT1,1,2.1+11,,.3,7850.
PROD,3,1,1.-4,,,.4
CROD,1,3,1,2
CONROD,2,1,2,1,1.-4,,,.4
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
";
    let m = parse(deck).model;
    assert_eq!(m.rod_properties[&3].nsm, 0.2);
    let Element::Rod {
        section: RodSection::Own(p),
        ..
    } = &m.elements[&2]
    else {
        panic!()
    };
    assert_eq!(p.nsm, 0.2);
}

/// A square plate, `n` × `n` CQUAD4, clamped at x = 0; every other grid has PS `ps`.
fn plate(n: usize, cards: &str, ps: &str) -> String {
    let mut d = cards.to_string();
    let id = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..=n {
        for i in 0..=n {
            let ps = if i == 0 { "123456" } else { ps };
            d += &format!(
                "GRID,{},,{:.17e},{:.17e},0.,,{ps}\n",
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

const STEEL: &str = "MAT1,1,2.1+11,,.3,7850.\n";

/// Membrane only (MID2 blank): the in-plane modes of the full PSHELL (its bending DOFs held,
/// PS 345) with the membrane-only plate (PS 3, its rotations dropped because nothing stiffens
/// or loads them). The full shell keeps its drilling penalty and θz inertia, which the
/// membrane-only one has not: they differ by that O(α_d) effect, below 1e-3 here.
#[test]
fn membrane_only_pshell_keeps_the_in_plane_modes() {
    let full = parse(&plate(8, &format!("{STEEL}PSHELL,1,1,.01,1,,1\n"), "345")).model;
    let mem = parse(&plate(8, &format!("{STEEL}PSHELL,1,1,.01\n"), "3")).model;
    assert!(!mem.shell_properties[&1].bending);
    let (ff, _) = frequencies(&full, MassKind::Consistent, 4);
    let (fm, dofs) = frequencies(&mem, MassKind::Consistent, 4);
    assert!(
        dofs.iter()
            .all(|d| matches!(d.comp, Component::Ux | Component::Uy))
    );
    for (a, b) in fm.iter().zip(&ff) {
        assert!(rel(*a, *b) < 1e-3, "{fm:?} vs {ff:?}");
    }
    // Free out of plane, the membrane-only plate has no stiffness there: uz carries mass only.
    let free = parse(&plate(4, &format!("{STEEL}PSHELL,1,1,.01\n"), "")).model;
    let (sys, info) = assemble_model(&free, MassKind::Lumped).unwrap();
    assert!(info.auto_constrained.iter().all(|d| d.comp.is_rotation()));
    assert_eq!(info.auto_constrained.len(), 3 * 5 * 4);
    let k = sparse_to_dense(&sys.k);
    for (i, d) in sys.dofs.iter().enumerate() {
        if d.comp == Component::Uz {
            assert!((0..sys.dofs.len()).all(|j| k[(i, j)] == 0.0));
        }
    }
}

/// Bending only (MID1 blank): the out-of-plane modes of the full PSHELL (in-plane DOFs held,
/// PS 126) are those of the bending-only plate (PS 12; its θz dropped): the same matrices over
/// w, θx, θy, so equal to round-off (tolerance 1e-9).
#[test]
fn bending_only_pshell_keeps_the_out_of_plane_modes() {
    let full = parse(&plate(8, &format!("{STEEL}PSHELL,1,1,.01,1,,1\n"), "126")).model;
    let bend = parse(&plate(8, &format!("{STEEL}PSHELL,1,,.01,1,,1\n"), "12")).model;
    assert!(!bend.shell_properties[&1].membrane);
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let (ff, _) = frequencies(&full, mass, 5);
        let (fb, dofs) = frequencies(&bend, mass, 5);
        assert!(dofs.iter().all(|d| d.comp != Component::Rz));
        for (a, b) in fb.iter().zip(&ff) {
            assert!(rel(*a, *b) < 1e-9, "{mass:?}: {fb:?} vs {ff:?}");
        }
    }
}

/// MID2 of another material (MID3 the same): bending and shear stiffness scale with E₂/E₁, the
/// mass is MID1's, so the bending frequencies scale by √(E₂/E₁) exactly (tolerance 1e-9).
#[test]
fn mid2_of_another_modulus_scales_the_bending_frequencies() {
    let mats = format!("{STEEL}MAT1,2,5.25+11,,.3,1.\n");
    let base = parse(&plate(6, &format!("{mats}PSHELL,1,1,.01,1,,1\n"), "126")).model;
    let other = parse(&plate(6, &format!("{mats}PSHELL,1,1,.01,2,,2\n"), "126")).model;
    assert_eq!(other.shell_properties[&1].bending_material, Some(2));
    assert_eq!(other.shell_properties[&1].shear_material, None);
    let (f1, _) = frequencies(&base, MassKind::Consistent, 4);
    let (f2, _) = frequencies(&other, MassKind::Consistent, 4);
    for (a, b) in f2.iter().zip(&f1) {
        assert!(rel(*a / *b, 2.5f64.sqrt()) < 1e-9, "{f2:?} vs {f1:?}");
    }
}

/// 12I/T³ = 2 doubles the bending stiffness only: a thin plate's (t/a = 0.01) bending
/// frequencies rise by √2 up to its shear and rotary-inertia corrections, O((t/λ)²), measured
/// below 5e-4 for the first four modes (tolerance 1e-3). MID3 blank (Nastran: no shear
/// flexibility) keeps femu's Mindlin shear; against a nearly shear-rigid plate (TS/T = 10, 12
/// times stiffer in shear) the frequencies are lower by that same small effect, 1e-4 to 5e-4
/// here (bound 1e-3).
#[test]
fn bending_ratio_and_mid3_blank_on_a_thin_plate() {
    let run = |pshell: &str| {
        let m = parse(&plate(8, &format!("{STEEL}{pshell}\n"), "126")).model;
        frequencies(&m, MassKind::Consistent, 4).0
    };
    let f1 = run("PSHELL,1,1,.01,1,,1");
    let f2 = run("PSHELL,1,1,.01,1,2.,1");
    for (a, b) in f2.iter().zip(&f1) {
        assert!(rel(*a / *b, 2f64.sqrt()) < 1e-3, "{f2:?} vs {f1:?}");
    }
    let blank = run("PSHELL,1,1,.01,1");
    assert_eq!(blank, f1, "MID3 blank is MID3 = MID2");
    let rigid = run("PSHELL,1,1,.01,1,,1,10.");
    for (a, b) in blank.iter().zip(&rigid) {
        let d = (b - a) / b;
        assert!(d > 0.0 && d < 1e-3, "{blank:?} vs {rigid:?}");
    }
}

#[test]
fn pshell_fields_nastran_refuses_or_femu_cannot_take_are_named() {
    let base = format!(
        "{STEEL}GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\nCQUAD4,1,1,1,2,3,4\n"
    );
    let cases = [
        (
            "PSHELL,1,1,.01,1,,1,,,\n,,,-2\n",
            "(MID4) of continuation 1 (line 8): -2 is not a material id",
        ),
        (
            "PSHELL,1,,.01\n",
            "PSHELL field 3 (MID1): MID1 and MID2 are both blank",
        ),
        (
            "PSHELL,1,1,.01,,,1\n",
            "PSHELL field 7 (MID3): MID3 1 is given without MID2",
        ),
        (
            "PSHELL,1,1,.01,-1\n",
            "MID2 = -1 (plane strain) is not supported",
        ),
        (
            "PSHELL,1,1,.01,1,0.\n",
            "PSHELL field 6 (12I/T**3): 0 is not positive",
        ),
        (
            "PSHELL,1,1,.01,1,,1,-1.\n",
            "PSHELL field 8 (TS/T): -1 is not positive",
        ),
        (
            "PSHELL,1,1,.01,1,,7\n",
            "property 1 refers to material 7, which is not defined",
        ),
    ];
    for (card, want) in cases {
        let e = error(&format!("{base}{card}"));
        assert!(e.contains(want), "{card}: {e}");
    }
    // MID3 blank is stated once per deck; Z1/Z2 are read and ignored; 0.833333 is 5/6.
    let b = parse(&format!(
        "{base}PSHELL,1,1,.01,1,,,.833333\n,-.005,.005\nPSHELL,2,1,.02,1\n"
    ));
    let w: Vec<_> = b.warnings.iter().filter(|w| w.contains("MID3")).collect();
    assert_eq!(w.len(), 1, "{:?}", b.warnings);
    assert!(b.model.shell_properties[&1].is_homogeneous());
}

/// Young's modulus and density parameters on a set of rods (CROD sharing its PROD and its
/// material with rods and a shell outside the set, and a CONROD): the assembled exact
/// derivative equals a central difference of the assembled matrices, the value being set
/// through `Model::set_parameter_value` (which gives the set its own property and material
/// first, so nothing outside changes). The matrices are linear in E and ρ: tolerance 1e-7 of
/// the derivative's largest entry (round-off of a difference with relative step 1e-6).
#[test]
fn rod_parameters_have_exact_assembled_derivatives() {
    use crate::fe::model_assembly::parameter_derivative;
    use crate::model::{Parameter, ParameterKind};
    let deck = "\
MAT1,1,7.+10,,.33,2700.
PROD,9,1,2.-4,3.-8,,.5
PSHELL,5,1,.002,1,,1
GRID,1,,0.,0.,0.,,123456
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
CROD,1,9,1,2
CROD,2,9,2,3
CONROD,3,3,4,1,1.-4,1.-8,,.1
CROD,4,9,4,1
CQUAD4,5,5,1,2,3,4
SET1,7,1,2,3
";
    let model = parse(deck).model;
    let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
    for kind in [ParameterKind::YoungsModulus, ParameterKind::Density] {
        let p = Parameter {
            name: "p".into(),
            kind: kind.clone(),
            set: "set7".into(),
            lower: 0.0,
            upper: 1e12,
        };
        let (dk, dm) = parameter_derivative(&model, &p, &sys.dofs, MassKind::Consistent).unwrap();
        let v = model.parameter_value(&p).unwrap();
        let h = 1e-6 * v;
        let at = |x: f64| {
            let mut m = model.clone();
            m.set_parameter_value(&p, x).unwrap();
            // Outside the set nothing changed.
            for id in [4, 5] {
                let (a, b) = (
                    element_matrices(&m, &m.elements[&id], MassKind::Consistent).unwrap(),
                    element_matrices(&model, &model.elements[&id], MassKind::Consistent).unwrap(),
                );
                assert_eq!(a, b, "{kind:?}: element {id} changed");
            }
            assert_eq!(m.parameter_value(&p).unwrap(), x);
            assemble_model(&m, MassKind::Consistent).unwrap().0
        };
        let (sp, sm) = (at(v + h), at(v - h));
        for (an, fp, fm) in [
            (sparse_to_dense(&dk), sp.k_dense(), sm.k_dense()),
            (sparse_to_dense(&dm), sp.m_dense(), sm.m_dense()),
        ] {
            let scale = crate::core::dense::max_abs(an.as_ref());
            let mut worst = 0.0f64;
            for i in 0..an.nrows() {
                for j in 0..an.ncols() {
                    worst = worst.max((an[(i, j)] - (fp[(i, j)] - fm[(i, j)]) / (2.0 * h)).abs());
                }
            }
            assert!(
                worst <= 1e-7 * scale.max(1e-300),
                "{kind:?}: {worst:e} vs {scale:e}"
            );
        }
        assert!(
            crate::core::dense::max_abs(sparse_to_dense(&dk).as_ref()) > 0.0
                || kind == ParameterKind::Density
        );
    }
}

/// The wing idea: a membrane-only CQUAD4 panel (PSHELL MID2 blank) with CROD spar caps
/// along both edges, clamped at the root, held out of plane (PS 3). It imports without
/// warnings, its rotations are dropped (nothing stiffens or loads them), and its first
/// in-plane bending frequency lies within 5 % below the series-flexibility estimate
/// (Euler–Bernoulli bending of caps and web combined with the web's shear beam,
/// 1/f² = 1/f_b² + 1/f_s², an approximation: measured 2 % below it with lumped mass) and under
/// 1.02 f_b (shear only lowers it; 2 % for the mesh). Without the caps it is lower.
#[test]
fn membrane_panel_stiffened_by_rods_gives_modes() {
    let (span, chord, t, cap) = (1.0, 0.4, 0.001, 1.0e-4);
    let (nx, ny) = (20, 8);
    let id = |i: usize, j: usize| j * (nx + 1) + i + 1;
    let mut deck = "MAT1,1,7.+10,,.33,2700.\nPSHELL,1,1,.001\nPROD,2,1,1.-4\n".to_string();
    for j in 0..=ny {
        for i in 0..=nx {
            let ps = if i == 0 { "123456" } else { "3" };
            deck += &format!(
                "GRID,{},,{:.17e},{:.17e},0.,,{ps}\n",
                id(i, j),
                span * i as f64 / nx as f64,
                chord * j as f64 / ny as f64
            );
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            deck += &format!(
                "CQUAD4,{},1,{},{},{},{}\n",
                j * nx + i + 1,
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1)
            );
        }
    }
    let panel = parse(&deck).model;
    for (k, j) in [0, ny].into_iter().enumerate() {
        for i in 0..nx {
            deck += &format!(
                "CROD,{},2,{},{}\n",
                1000 + 100 * k + i,
                id(i, j),
                id(i + 1, j)
            );
        }
    }
    let b = parse(&deck);
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    let (sys, info) = assemble_model(&b.model, MassKind::Lumped).unwrap();
    assert!(
        sys.dofs
            .iter()
            .all(|d| matches!(d.comp, Component::Ux | Component::Uy))
    );
    assert_eq!(info.auto_constrained.len(), 3 * nx * (ny + 1));
    let (f, _) = frequencies(&b.model, MassKind::Lumped, 3);
    let (f0, _) = frequencies(&panel, MassKind::Lumped, 1);
    let (e, g, rho) = (7.0e10, 7.0e10 / 2.66, 2700.0);
    let ei = e * (2.0 * cap * (chord / 2.0f64).powi(2) + t * chord.powi(3) / 12.0);
    let mu = rho * (t * chord + 2.0 * cap);
    let fb = 1.875104f64.powi(2) / (2.0 * PI) * (ei / (mu * span.powi(4))).sqrt();
    let fs = (g * t * chord / mu).sqrt() / (4.0 * span);
    let dunkerley = 1.0 / (1.0 / (fb * fb) + 1.0 / (fs * fs)).sqrt();
    assert!(
        f[0] > 0.95 * dunkerley && f[0] < 1.02 * fb,
        "{f:?}: {dunkerley} .. {fb}"
    );
    assert!(f0[0] < f[0], "{f0:?} vs {f:?}");
    assert!(f.iter().all(|x| x.is_finite() && *x > 0.0));
}
