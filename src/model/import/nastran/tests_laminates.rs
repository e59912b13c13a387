//! Composite and offset shells (PCOMP, PCOMPG, MAT2, MAT8, THETA/MCID, ZOFFS, PSHELL MID4,
//! CQUADR/CTRIAR), each against an analytic value or an equivalent deck femu already read.

use super::tests::{error, parse};
use super::*;
use crate::core::sparse::sparse_to_dense;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model, element_matrices_with_id, parameter_derivative};
use crate::model::laminates::ShellMaterial;
use crate::model::{Parameter, ParameterKind};
use faer::Mat;

const E: f64 = 7.0e10;
const NU: f64 = 0.33;

/// Four grids of a general flat quad and a fifth for a triangle.
const GRIDS: &str = "\
GRID,1,,0.,0.,0.
GRID,2,,1.,.2,0.
GRID,3,,1.1,1.,0.
GRID,4,,0.,.9,0.
GRID,5,,-.6,.4,0.
";

fn g() -> f64 {
    E / (2.0 * (1.0 + NU))
}

/// Every element's stiffness and mass, concatenated, for comparing two decks.
fn element_blocks(m: &Model, mass: MassKind) -> Vec<(Mat<f64>, Mat<f64>)> {
    m.elements
        .iter()
        .map(|(id, e)| {
            let em = element_matrices_with_id(m, *id, e, mass).unwrap();
            (em.k, em.m)
        })
        .collect()
}

fn max_abs(a: &Mat<f64>) -> f64 {
    let mut v = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            v = v.max(a[(i, j)].abs());
        }
    }
    v
}

fn max_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    max_abs(&(a - b))
}

/// Asserts two decks give the same element matrices to `tol` relative to the largest entry.
fn same_elements(a: &Model, b: &Model, tol: f64, what: &str) {
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        for (i, ((ka, ma), (kb, mb))) in element_blocks(a, mass)
            .iter()
            .zip(element_blocks(b, mass))
            .enumerate()
        {
            let (dk, dm) = (max_diff(ka, &kb), max_diff(ma, &mb));
            assert!(
                dk <= tol * max_abs(ka) && dm <= tol * max_abs(ma),
                "{what}, element #{i} {mass:?}: dK {dk:e} of {:e}, dM {dm:e} of {:e}",
                max_abs(ka),
                max_abs(ma)
            );
        }
    }
}

/// A single isotropic MAT8 ply is the PSHELL of the same material (to round-off: 1e-12
/// relative), whatever its angle; NSM goes to both.
#[test]
fn single_isotropic_ply_is_the_pshell() {
    let elements = "CQUAD4,1,1,1,2,3,4\nCTRIA3,2,1,1,4,5\n";
    let pshell = parse(&format!(
        "{GRIDS}{elements}MAT1,1,{E:e},,{NU},2700.\nPSHELL,1,1,.002,1,,1,,.3\n"
    ));
    let pcomp = parse(&format!(
        "{GRIDS}{elements}MAT8,8,{E:e},{E:e},{NU},{g:e},{g:e},{g:e},2700.\nPCOMP,1,,.3\n,8,.002,30.\n",
        g = g()
    ));
    assert!(pcomp.warnings.is_empty(), "{:?}", pcomp.warnings);
    let lam = pcomp.model.shell_properties[&1].laminate.as_ref().unwrap();
    assert_eq!(lam.plies.len(), 1);
    assert_eq!(pcomp.model.shell_properties[&1].thickness, 0.002);
    same_elements(&pshell.model, &pcomp.model, 1e-12, "PCOMP vs PSHELL");
    // The same ply as MAT1 (PCOMP may name MAT1) and as a two-ply SYM half.
    let mat1 = parse(&format!(
        "{GRIDS}{elements}MAT1,1,{E:e},,{NU},2700.\nPCOMP,1,,.3\n,1,.002\n"
    ));
    same_elements(&pshell.model, &mat1.model, 1e-12, "PCOMP of MAT1");
    let sym = parse(&format!(
        "{GRIDS}{elements}MAT1,1,{E:e},,{NU},2700.\nPCOMP,1,,.3,,,,,SYM\n,1,.001\n"
    ));
    same_elements(&pshell.model, &sym.model, 1e-12, "PCOMP SYM");
    // LAM = MEM and BEND against the membrane-only (MID2 blank) and bending-only (MID1 blank)
    // PSHELL; SMEAR of one isotropic ply is the PSHELL itself.
    for (lam, card) in [
        ("MEM", "PSHELL,1,1,.002,,,,,.3"),
        ("BEND", "PSHELL,1,,.002,1,,1,,.3"),
        ("SMEAR", "PSHELL,1,1,.002,1,,1,,.3"),
    ] {
        let shell = parse(&format!(
            "{GRIDS}{elements}MAT1,1,{E:e},,{NU},2700.\n{card}\n"
        ));
        let comp = parse(&format!(
            "{GRIDS}{elements}MAT1,1,{E:e},,{NU},2700.\nPCOMP,1,,.3,,,,,{lam}\n,1,.002\n"
        ));
        same_elements(
            &shell.model,
            &comp.model,
            1e-12,
            &format!("PCOMP LAM = {lam}"),
        );
    }
}

/// Hand CLT values of the [0/90]s and [0/90] laminates reach the element: the general law of
/// the deck's property equals the textbook A, B, D (laminate.rs tests the formulas; this the
/// card reading: ply order, blank MID/T repeating, SYM, Z0).
#[test]
fn cross_ply_cards_give_the_textbook_laminate() {
    let mat8 = "MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\n";
    let den = 1.0 - 0.3 * 0.3 * 10.0 / 140.0;
    let (q11, q22) = (140e9 / den, 10e9 / den);
    let t: f64 = 0.25e-3;
    let law = |card: &str| {
        let b = parse(&format!("{GRIDS}CQUAD4,1,1,1,2,3,4\n{mat8}{card}"));
        crate::fe::laminate::property_law(&b.model, &b.model.shell_properties[&1]).unwrap()
    };
    // [0/90]s written out, and as SYM with blank MID/T repeating the first ply's.
    let full = law(&format!("PCOMP,1\n,8,{t},0.,,,,90.\n,,,90.,,,,0.\n"));
    let sym = law(&format!("PCOMP,1,,,,,,,SYM\n,8,{t},0.,YES,,,90.\n"));
    let outer = 14.0 * t.powi(3) / 3.0;
    let inner = 2.0 * t.powi(3) / 3.0;
    for l in [&full, &sym] {
        assert!((l.a[0][0] - 2.0 * t * (q11 + q22)).abs() <= 1e-12 * l.a[0][0]);
        assert!((l.d[0][0] - (q11 * outer + q22 * inner)).abs() <= 1e-12 * l.d[0][0]);
        assert!((l.d[1][1] - (q22 * outer + q11 * inner)).abs() <= 1e-12 * l.d[1][1]);
        assert!(l.b.iter().flatten().all(|v| v.abs() <= 1e-9 * q11 * t * t));
        assert!((l.mu - 1600.0 * 4.0 * t).abs() <= 1e-15);
    }
    // [0/90] with Z0 = −t: B11 = (Q22 − Q11) t²/2 = −B22.
    let uns = law(&format!("PCOMP,1,{}\n,8,{t},0.,,8,{t},90.\n", -t));
    let b11 = (q22 - q11) * t * t / 2.0;
    assert!((uns.b[0][0] - b11).abs() <= 1e-12 * b11.abs());
    assert!((uns.b[1][1] + b11).abs() <= 1e-12 * b11.abs());
    // PCOMPG: the same plies with global ids.
    let g = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4\n{mat8}PCOMPG,1,{}\n,101,8,{t},0.\n,7,8,{t},90.\n",
        -t
    ));
    let lg = crate::fe::laminate::property_law(&g.model, &g.model.shell_properties[&1]).unwrap();
    assert_eq!(lg, uns);
    assert_eq!(
        g.model.shell_properties[&1]
            .laminate
            .as_ref()
            .unwrap()
            .global_ids,
        vec![101, 7]
    );
}

/// THETA = 90° on a ply of MAT8 equals swapping E1/E2 (with ν21, G2Z/G1Z); MCID whose x axis
/// lies at THETA from G1→G2 equals THETA; a THETA on an isotropic PSHELL changes nothing (the
/// element keeps the homogeneous kernel, bit for bit).
#[test]
fn theta_and_mcid_orient_the_material() {
    let q = "CQUAD4,1,1,1,2,3,4";
    let t = "CTRIA3,2,1,1,4,5";
    let mat = |e1: f64, e2: f64, nu: f64, g1z: f64, g2z: f64| {
        format!(
            "MAT8,8,{e1:e},{e2:e},{nu},5.+9,{g1z:e},{g2z:e},1600.\nPCOMP,1\n,8,.001,0.,,8,.0005,30.\n"
        )
    };
    let a = parse(&format!(
        "{GRIDS}{q},90.\n{t},90.\n{}",
        mat(140e9, 10e9, 0.3, 5e9, 3.5e9)
    ));
    let b = parse(&format!(
        "{GRIDS}{q}\n{t}\n{}",
        mat(10e9, 140e9, 0.3 * 10.0 / 140.0, 3.5e9, 5e9)
    ));
    // The two plies' own angles (0 and 30) also turn with the material axis.
    same_elements(&a.model, &b.model, 1e-12, "THETA 90 vs swapped E1/E2");
    // MCID: x axis at 25° + the G1→G2 angle of the quad; the triangle's G1→G2 is along 1→4.
    let psi_q = 0.2f64.atan2(1.0);
    let phi = psi_q + 25f64.to_radians();
    let c = parse(&format!(
        "{GRIDS}{q},7\n{}CORD2R,7,,0.,0.,0.,0.,0.,1.\n,{},{},0.\n",
        mat(140e9, 10e9, 0.3, 5e9, 3.5e9),
        phi.cos(),
        phi.sin()
    ));
    assert!(c.model.shell_placements[&1].axis.is_some());
    let d = parse(&format!(
        "{GRIDS}{q},25.\n{}",
        mat(140e9, 10e9, 0.3, 5e9, 3.5e9)
    ));
    same_elements(&c.model, &d.model, 1e-12, "MCID vs THETA");
    // Isotropic PSHELL: THETA stored, matrices bit-identical to none.
    let iso = "MAT1,1,7.+10,,.33,2700.\nPSHELL,1,1,.002,1,,1\n";
    let with = parse(&format!("{GRIDS}{q},33.\n{t},-12.\n{iso}"));
    let without = parse(&format!("{GRIDS}{q}\n{t}\n{iso}"));
    assert_eq!(with.model.shell_placements[&1].theta_deg, 33.0);
    assert_eq!(
        element_blocks(&with.model, MassKind::Consistent),
        element_blocks(&without.model, MassKind::Consistent)
    );
}

/// ZOFFS z0 on a PSHELL equals the single-ply PCOMP whose bottom is at Z0 = z0 − T/2 (the
/// parallel-axis terms of the offset against the lamination integrals, 1e-12); a zero ZOFFS
/// is no offset, bit for bit.
#[test]
fn zoffs_is_the_shifted_laminate_and_zero_is_none() {
    let t = 0.002;
    let z0 = 0.0015;
    let mats = format!("MAT8,8,{E:e},{E:e},{NU},{g:e},{g:e},{g:e},2700.\n", g = g());
    let offset = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4,,{z0}\nCTRIA3,2,1,1,4,5,,{z0}\n{mats}PCOMP,1\n,8,{t}\n"
    ));
    assert_eq!(offset.model.shell_placements[&2].offset, z0);
    let shifted = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4\nCTRIA3,2,1,1,4,5\n{mats}PCOMP,1,{}\n,8,{t}\n",
        z0 - t / 2.0
    ));
    same_elements(&offset.model, &shifted.model, 1e-12, "ZOFFS vs Z0");
    // An isotropic PSHELL with ZOFFS against the same PCOMP shifted.
    let pshell = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4,,{z0}\nCTRIA3,2,1,1,4,5,,{z0}\nMAT1,1,{E:e},,{NU},2700.\nPSHELL,1,1,{t},1,,1\n"
    ));
    same_elements(&pshell.model, &shifted.model, 1e-12, "PSHELL ZOFFS");
    let zero = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4,,0.\nMAT1,1,{E:e},,{NU},2700.\nPSHELL,1,1,{t},1,,1\n"
    ));
    let none = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4\nMAT1,1,{E:e},,{NU},2700.\nPSHELL,1,1,{t},1,,1\n"
    ));
    assert!(zero.model.shell_placements.is_empty());
    assert_eq!(zero.model, none.model);
}

/// PSHELL with MAT2 parts and MID4: the law is `A = T G1`, `D = T³/12 G2`, `B = T² G4`.
#[test]
fn pshell_mat2_parts_and_mid4_coupling() {
    let b = parse(&format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4\nMAT2,2,8.+10,2.+10,1.+9,6.+10,-2.+9,2.5+10,1500.\nMAT1,1,7.+10,,.3,2700.\nMAT8,3,1.+9,1.+9,.1,4.+8,4.+8,4.+8\nPSHELL,1,2,.01,2,,1,,,\n,,,3\n"
    ));
    let p = &b.model.shell_properties[&1];
    assert_eq!(p.coupling_material, Some(3));
    let l = crate::fe::laminate::property_law(&b.model, p).unwrap();
    let t = 0.01f64;
    assert!((l.a[0][0] - 8e10 * t).abs() <= 1e-6);
    assert!((l.a[1][2] + 2e9 * t).abs() <= 1e-6);
    assert!((l.d[2][2] - 2.5e10 * t.powi(3) / 12.0).abs() <= 1e-9);
    let q11 = 1e9 / (1.0 - 0.01);
    assert!((l.b[0][0] - q11 * t * t).abs() <= 1e-6 * q11 * t * t);
    assert!((l.mu - 1500.0 * t).abs() <= 1e-12);
    let g = 7e10 / 2.6;
    assert!((l.g[0][0] - 5.0 / 6.0 * g * t).abs() <= 1e-6 * g * t);
    // The element is formed (stiffness symmetric positive semi-definite with a mass).
    let em =
        element_matrices_with_id(&b.model, 1, &b.model.elements[&1], MassKind::Consistent).unwrap();
    assert!(max_diff(&em.k, &em.k.transpose().to_owned()) == 0.0);
}

/// CQUADR/CTRIAR are read as CQUAD4/CTRIA3 (THETA, ZOFFS included) with one warning.
#[test]
fn cquadr_and_ctriar_are_quad4_and_tria3_with_a_warning() {
    let props = "MAT1,1,7.+10,,.33,2700.\nPSHELL,1,1,.002,1,,1\n";
    let r = parse(&format!(
        "{GRIDS}{props}CQUADR,1,1,1,2,3,4,,.001\nCTRIAR,2,1,1,4,5,10.\nCQUADR,3,1,1,2,3,4\n"
    ));
    let w: Vec<_> = r.warnings.iter().filter(|w| w.contains("CQUADR")).collect();
    assert_eq!(w.len(), 1, "{:?}", r.warnings);
    assert!(w[0].contains("drilling"), "{}", w[0]);
    let plain = parse(&format!(
        "{GRIDS}{props}CQUAD4,1,1,1,2,3,4,,.001\nCTRIA3,2,1,1,4,5,10.\nCQUAD4,3,1,1,2,3,4\n"
    ));
    assert_eq!(r.model, plain.model);
}

/// Stated deviations and refusals name the card, field and what is valid.
#[test]
fn laminate_cards_refuse_what_femu_cannot_take() {
    let base = format!("{GRIDS}CQUAD4,1,1,1,2,3,4\n");
    let mat8 = "MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\n";
    let cases = [
        (
            format!("{mat8}PCOMP,1,,,,,,,SMCORE\n,8,.001\n"),
            "PCOMP field 2 (MID1) of continuation 1 (line 9): LAM = SMCORE with a single ply",
        ),
        (
            format!("{mat8}PCOMP,1,-.001,,,,,,SMCORE\n,8,.001,,,8,.002\n"),
            "PCOMP field 3 (Z0): Z0 = -0.001 with LAM = SMCORE",
        ),
        (
            format!("{mat8}PCOMP,1,,,,,,,SMCORX\n,8,.001\n"),
            "PCOMP field 9 (LAM): LAM = SMCORX is not supported",
        ),
        (
            format!("{mat8}PCOMP,1\n,8,,45.\n"),
            "the first ply's thickness is blank",
        ),
        (
            format!("{mat8}PCOMP,1\n,8,-.001\n"),
            "ply thickness -0.001 is not positive",
        ),
        (format!("{mat8}PCOMP,1\n"), "the laminate has no ply"),
        (
            format!("{mat8}PCOMPG,1\n,3,8,.001,,,5\n"),
            "one ply per line",
        ),
        (
            format!("{mat8}PCOMPG,1\n,3,8,.001\n,3,8,.001\n"),
            "global ply id 3 appears twice",
        ),
        (
            "MAT8,8,1.+9,1.+11,.5,5.+9\nPCOMP,1\n,8,.001\n".to_string(),
            "MAT8 field 5 (NU12)",
        ),
        (
            "MAT2,2,1.+9,2.+9,0.,1.+9,0.,1.+9\nPCOMP,1\n,2,.001\n".to_string(),
            "is not positive definite",
        ),
        (
            format!("{mat8}MAT1,8,7.+10,,.3\nPCOMP,1\n,8,.001\n"),
            "material 8",
        ),
        (
            format!("{mat8}PCOMP,1\n,9,.001\n"),
            "material 9, which is not defined",
        ),
    ];
    for (cards, want) in cases {
        let e = error(&format!("{base}{cards}"));
        assert!(e.contains(want), "{cards}: {e}");
    }
    let mcid = |cord: &str, mcid: &str| {
        error(&format!(
            "{GRIDS}CQUAD4,1,1,1,2,3,4,{mcid}\n{mat8}PCOMP,1\n,8,.001\n{cord}"
        ))
    };
    let e = mcid("", "4");
    assert!(
        e.contains("CQUAD4 field 8 (MCID): coordinate system 4 is not defined"),
        "{e}"
    );
    // A cylinder whose axis (basic x, 1 above the plate) makes r normal to the plate.
    let e = mcid("CORD2C,4,,0.,.525,1.,1.,.525,1.\n,0.,.525,2.\n", "4");
    assert!(e.contains("normal to the element"), "{e}");
    let e = mcid("CORD2R,4,,0.,0.,0.,1.,0.,0.\n,0.,0.,1.\n", "4");
    assert!(e.contains("normal to the element"), "{e}");
    // MAT8 with G1Z/G2Z blank: G12 with one warning; GE on a PCOMP warns.
    let b = parse(&format!(
        "{base}MAT8,8,1.4+11,1.+10,.3,5.+9\nMAT8,9,1.4+11,1.+10,.3,5.+9\nPCOMP,1,,,,,,.01\n,8,.001,,,9\n"
    ));
    let w = b.warnings.join("\n");
    assert_eq!(w.matches("G1Z or G2Z is blank").count(), 1, "{w}");
    assert!(w.contains("GE = 0.01"), "{w}");
    match b.model.shell_materials[&8] {
        ShellMaterial::Orthotropic { g1z, g2z, .. } => assert_eq!((g1z, g2z), (5e9, 5e9)),
        _ => panic!(),
    }
    // MAT2 as a ply: G33 for its transverse shear, stated once.
    let b = parse(&format!(
        "{base}MAT2,2,8.+10,2.+10,0.,6.+10,0.,2.5+10,1500.\nPCOMP,1\n,2,.001\n"
    ));
    assert!(
        b.warnings.iter().any(|w| w.contains("G33")),
        "{:?}",
        b.warnings
    );
}

/// The lowest natural frequencies (Hz) of a model.
fn frequencies(m: &Model, n: usize) -> Vec<f64> {
    let (sys, _) = assemble_model(m, MassKind::Consistent).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(n),
        &SparseEigenParams::default(),
    )
    .unwrap();
    modes.frequencies_hz().to_vec()
}

/// A simply supported `a × b` plate of `nx × ny` CQUAD4 (w, u, v zero on the edges) with
/// property 1 and the given property/material cards.
fn ss_plate(a: f64, b: f64, nx: usize, ny: usize, cards: &str) -> Model {
    let mut d = String::from(cards);
    for j in 0..=ny {
        for i in 0..=nx {
            let edge = i == 0 || j == 0 || i == nx || j == ny;
            d += &format!(
                "GRID,{},,{:.17e},{:.17e},0.,,{}\n",
                1 + i + j * (nx + 1),
                a * i as f64 / nx as f64,
                b * j as f64 / ny as f64,
                if edge { "123" } else { "" }
            );
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let n1 = 1 + i + j * (nx + 1);
            d += &format!(
                "CQUAD4,{},1,{},{},{},{}\n",
                1 + i + j * nx,
                n1,
                n1 + 1,
                n1 + nx + 2,
                n1 + nx + 1
            );
        }
    }
    parse(&d).model
}

/// A simply supported [0/90]s carbon plate (specially orthotropic: B = 0, D16 = D26 = 0)
/// against the closed form (Whitney 1987, *Structural Analysis of Laminated Anisotropic
/// Plates*, §5.2; Leissa 1969): `ω₁₁ = π² √(D11/a⁴ + 2(D12 + 2D66)/(a²b²) + D22/b⁴) / √(ρh)`
/// with the hand-computed D. The thin plate (a/h = 500) has a Mindlin shear correction below
/// 1e-4; the rest is MITC4's mesh error: below 0.5 % on 20 × 16 elements, falling as O(h²)
/// from 10 × 8 (ratio < 0.35), and the Richardson extrapolation of the two within 5e-4.
#[test]
fn orthotropic_simply_supported_plate_matches_the_closed_form() {
    let (a, b, t): (f64, f64, f64) = (0.5, 0.4, 0.25e-3);
    let rho: f64 = 1600.0;
    let cards = format!(
        "MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,{rho}\nPCOMP,1,,,,,,,SYM\n,8,{t},0.,,8,{t},90.\n"
    );
    let den = 1.0 - 0.3 * 0.3 * 10.0 / 140.0;
    let (q11, q22, q12, q66) = (140e9 / den, 10e9 / den, 3e9 / den, 5e9);
    let (outer, inner, all) = (
        14.0 * t.powi(3) / 3.0,
        2.0 * t.powi(3) / 3.0,
        16.0 * t.powi(3) / 3.0,
    );
    let (d11, d22, d12, d66) = (
        q11 * outer + q22 * inner,
        q22 * outer + q11 * inner,
        q12 * all,
        q66 * all,
    );
    let pi2 = std::f64::consts::PI.powi(2);
    let omega = pi2
        * (d11 / a.powi(4) + 2.0 * (d12 + 2.0 * d66) / (a * a * b * b) + d22 / b.powi(4)).sqrt()
        / (rho * 4.0 * t).sqrt();
    let exact = omega / (2.0 * std::f64::consts::PI);
    let coarse = frequencies(&ss_plate(a, b, 10, 8, &cards), 1)[0];
    let fine = frequencies(&ss_plate(a, b, 20, 16, &cards), 1)[0];
    let (ec, ef) = ((coarse - exact) / exact, (fine - exact) / exact);
    // Richardson: with O(h²) convergence the extrapolated value removes the mesh error.
    let extrapolated = fine + (fine - coarse) / 3.0;
    let ex = (extrapolated - exact) / exact;
    let msg = format!(
        "exact {exact} Hz; 10x8 {coarse} ({ec:e}), 20x16 {fine} ({ef:e}), extrapolated {extrapolated} ({ex:e})"
    );
    assert!(ef.abs() < 5e-3, "{msg}");
    assert!(ef.abs() < 0.35 * ec.abs(), "not O(h²): {msg}");
    assert!(ex.abs() < 5e-4, "{msg}");
}

/// A sandwich of two plates of thickness t on the same grids, offset by ±t/2 (ZOFFS), is one
/// plate of 2t: same frequencies to the mesh's formulation difference (each offset layer
/// condenses its own incompatible modes), checked at 0.2 %.
#[test]
fn two_offset_layers_make_the_double_plate() {
    let (a, b, t) = (0.5, 0.4, 0.001);
    let mat = "MAT1,1,7.+10,,.33,2700.\n";
    let double = ss_plate(a, b, 12, 10, &format!("{mat}PSHELL,1,1,{},1,,1\n", 2.0 * t));
    let mut layered = ss_plate(a, b, 12, 10, &format!("{mat}PSHELL,1,1,{t},1,,1\n"));
    let ids: Vec<u64> = layered.elements.keys().copied().collect();
    let top = 1000;
    for id in ids {
        let e = layered.elements[&id].clone();
        layered.elements.insert(id + top, e);
        for (eid, z) in [(id, -t / 2.0), (id + top, t / 2.0)] {
            layered.shell_placements.insert(
                eid,
                crate::model::laminates::ShellPlacement {
                    offset: z,
                    ..Default::default()
                },
            );
        }
    }
    let f2 = frequencies(&double, 3);
    let fl = frequencies(&layered, 3);
    for (x, y) in fl.iter().zip(&f2) {
        assert!(((x - y) / y).abs() < 2e-3, "{fl:?} vs {f2:?}");
    }
}

/// Every exposed laminate and offset-shell parameter's analytic `∂K/∂φ`, `∂M/∂φ` against a
/// central difference of the assembled matrices (step 1e-4 relative: truncation O(1e-8),
/// round-off O(1e-12); tolerance 1e-6 of the largest entry).
#[test]
fn laminate_and_offset_derivatives_match_central_differences() {
    let t = 0.4e-3;
    let deck = format!(
        "{GRIDS}GRID,6,,1.5,.6,.1\n\
CQUAD4,1,1,1,2,3,4,20.,.0003\nCTRIA3,2,1,1,4,5,,-.0002\nCQUAD4,3,2,2,6,3,4,,.001\nCTRIA3,4,2,1,2,6\n\
CQUAD4,5,3,1,2,3,4,-15.\n\
MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\nMAT1,1,7.+10,,.33,2700.\nMAT1,3,1.+8,,.3,80.\n\
PCOMP,1,-.0001,.2\n,8,{t},0.,,1,{t},45.\n,8,{t},-30.\n\
PCOMP,3,,.1,,,,,SMCORE\n,8,{t},0.,,8,{t},90.\n,3,.005\n\
PSHELL,2,1,.002,1,,1,,.1\n"
    );
    let base = parse(&deck).model;
    let cases = [
        ("pid1", ParameterKind::ShellThickness),
        ("pid1", ParameterKind::YoungsModulus),
        ("pid1", ParameterKind::Density),
        ("pid2", ParameterKind::ShellThickness),
        ("pid2", ParameterKind::YoungsModulus),
        ("pid2", ParameterKind::Density),
        ("pid3", ParameterKind::ShellThickness),
        ("pid3", ParameterKind::YoungsModulus),
        ("pid3", ParameterKind::Density),
    ];
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        for (set, kind) in &cases {
            let p = Parameter {
                name: "p".into(),
                kind: kind.clone(),
                set: set.to_string(),
                lower: 0.0,
                upper: f64::INFINITY,
            };
            let v = base.parameter_value(&p).unwrap();
            let (sys, _) = assemble_model(&base, mass).unwrap();
            let (dk, dm) = parameter_derivative(&base, &p, &sys.dofs, mass).unwrap();
            let at = |x: f64| {
                let mut m = base.clone();
                m.set_parameter_value(&p, x).unwrap();
                let (s, _) = assemble_model(&m, mass).unwrap();
                assert_eq!(s.dofs, sys.dofs);
                (sparse_to_dense(&s.k), sparse_to_dense(&s.m))
            };
            let h = 1e-4 * v;
            let ((kp, mp), (km, mm)) = (at(v + h), at(v - h));
            let fk = (&kp - &km) * faer::Scale(0.5 / h);
            let fm = (&mp - &mm) * faer::Scale(0.5 / h);
            let (dk, dm) = (sparse_to_dense(&dk), sparse_to_dense(&dm));
            let ek = max_diff(&dk, &fk) / max_abs(&fk).max(1e-300);
            let em = max_diff(&dm, &fm) / max_abs(&fm).max(1e-300);
            assert!(
                max_abs(&fk) > 0.0 || max_abs(&fm) > 0.0,
                "{set} {kind:?}: no change"
            );
            assert!(
                ek < 1e-6 && em < 1e-6,
                "{set} {kind:?} {mass:?}: dK {ek:e}, dM {em:e}"
            );
        }
    }
    // Values: the laminate's total thickness, MAT8's E1, its density.
    let p = |kind: ParameterKind| Parameter {
        name: "p".into(),
        kind,
        set: "pid1".into(),
        lower: 0.0,
        upper: 1.0,
    };
    assert!(
        (base
            .parameter_value(&p(ParameterKind::ShellThickness))
            .unwrap()
            - 3.0 * t)
            .abs()
            < 1e-18
    );
    assert_eq!(
        base.parameter_value(&p(ParameterKind::YoungsModulus))
            .unwrap(),
        1.4e11
    );
    let mut m = base.clone();
    m.set_parameter_value(&p(ParameterKind::ShellThickness), 6.0 * t)
        .unwrap();
    let l = m.shell_properties[&1].laminate.as_ref().unwrap();
    assert_eq!(l.z0, Some(-0.0002));
    assert!(
        l.plies
            .iter()
            .all(|q| (q.thickness - 2.0 * t).abs() < 1e-18)
    );
}

/// write_bulk writes PCOMP (SYM), PCOMPG (SMEAR), MAT8, MAT2, PSHELL MID4 and THETA/MCID/ZOFFS,
/// and reading them back gives the model (the MCID axis to round-off through its CORD2R).
#[test]
fn written_laminates_read_back() {
    let deck = format!(
        "{GRIDS}CQUAD4,1,1,1,2,3,4,7,.001\nCTRIA3,2,2,1,4,5,15.\nCQUAD4,3,3,1,2,3,4,,-.002\n\
CORD2R,7,,0.,0.,0.,0.,0.,1.\n,.6,.8,0.\n\
MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\nMAT2,2,8.+10,2.+10,1.+9,6.+10,-2.+9,2.5+10,1500.\n\
MAT1,1,7.+10,,.33,2700.\n\
PCOMP,1,-.0003,.2,,,,,SYM\n,8,.0001,0.,,2,.0002,45.\nPCOMPG,2,,,,,,,SMEAR\n,11,8,.0004,10.\n,12,1,.0003,-10.\n\
PSHELL,3,2,.002,2,,1,,,\n,,,8\n"
    );
    let a = parse(&deck).model;
    let smeared = a.shell_properties[&2].laminate.as_ref().unwrap();
    assert_eq!(
        smeared.terms,
        crate::model::laminates::LaminateTerms::Smeared
    );
    let text = crate::model::export::nastran::write_bulk(&a);
    let b = parse(&text).model;
    let (pa, pb) = (&a.shell_placements[&1], &b.shell_placements[&1]);
    for k in 0..3 {
        assert!(
            (pa.axis.unwrap()[k] - pb.axis.unwrap()[k]).abs() < 1e-15,
            "{text}"
        );
    }
    let mut b2 = b.clone();
    b2.shell_placements.insert(1, pa.clone());
    assert_eq!(a, b2, "{text}");
}

/// An updated laminate thickness and MAT8 modulus are written into the user's deck (every
/// ply's T, E1/E2/G12/G1Z/G2Z in proportion, the blank G2Z kept blank), and the deck read
/// back is the updated model.
#[test]
fn updated_laminate_values_are_written_back_into_the_deck() {
    use crate::model::export::deck_update::update_deck;
    use crate::model::import::nastran::{read_bulk, read_deck};
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "BEGIN BULK\nPARAM,WTMASS,.5\n{GRIDS}CQUAD4,1,1,1,2,3,4,30.\nCTRIA3,2,1,1,4,5\nCQUAD4,3,2,1,2,3,4\n\
MAT8,8,1.4+11,1.+10,.3,5.+9,4.+9,,1600.\nPCOMP,1,-.0004,.1\n,8,.0002,0.,,,,90.\n\
MAT1,1,7.+10,,.33,2700.\nPCOMP,2\n,8,.001,,,1,.001\nENDDATA\n"
    );
    let path = dir.path().join("lam.bdf");
    std::fs::write(&path, text).unwrap();
    let original = read_bulk(&path).unwrap().model;
    let mut updated = original.clone();
    let p = |kind: ParameterKind, set: &str| Parameter {
        name: "p".into(),
        kind,
        set: set.into(),
        lower: 0.0,
        upper: 1.0,
    };
    updated
        .set_parameter_value(&p(ParameterKind::ShellThickness, "pid1"), 0.0005)
        .unwrap();
    updated
        .set_parameter_value(&p(ParameterKind::YoungsModulus, "pid1"), 1.5e11)
        .unwrap();
    updated
        .set_parameter_value(&p(ParameterKind::Density, "pid1"), 1700.0)
        .unwrap();
    // MAT8 8 is shared with PCOMP 2, so pid1 got its own copy.
    assert_eq!(updated.shell_materials.len(), 2);
    let deck = read_deck(&path).unwrap();
    let out = update_deck(&deck, &original, &updated, &[]).unwrap();
    let back_path = dir.path().join("back.bdf");
    std::fs::write(&back_path, &out.files[0].1).unwrap();
    let back = read_bulk(&back_path).unwrap().model;
    // The copy's id may differ from the model's; compare values through the properties.
    let (pu, pb) = (&updated.shell_properties, &back.shell_properties);
    assert_eq!(pu.len(), pb.len());
    let plies = |m: &Model, pid: u64| m.shell_properties[&pid].laminate.clone().unwrap();
    for pid in [1, 2] {
        let (lu, lb) = (plies(&updated, pid), plies(&back, pid));
        assert_eq!(lu.z0, lb.z0);
        for (x, y) in lu.plies.iter().zip(&lb.plies) {
            assert!((x.thickness - y.thickness).abs() <= 1e-15 * x.thickness);
            // Values are written in at most 16 characters (at least 15 digits here).
            let json = |m: &Model, id: u64| match m.shell_materials.get(&id) {
                Some(s) => serde_json::to_value(s).unwrap(),
                None => serde_json::to_value(&m.materials[&id]).unwrap(),
            };
            let (a, b) = (json(&updated, x.material), json(&back, y.material));
            for (k, v) in a.as_object().unwrap() {
                if let (Some(x), Some(y)) = (v.as_f64(), b[k].as_f64()) {
                    assert!((x - y).abs() <= 1e-14 * x.abs(), "{k}: {x} vs {y}");
                }
            }
        }
    }
    let (ku, _) = assemble_model(&updated, MassKind::Consistent).unwrap();
    let (kb, _) = assemble_model(&back, MassKind::Consistent).unwrap();
    let (a, b) = (sparse_to_dense(&ku.k), sparse_to_dense(&kb.k));
    assert!(max_diff(&a, &b) <= 1e-12 * max_abs(&a));
    let (a, b) = (sparse_to_dense(&ku.m), sparse_to_dense(&kb.m));
    assert!(max_diff(&a, &b) <= 1e-12 * max_abs(&a));
    let written = String::from_utf8(out.files[0].1.clone()).unwrap();
    assert!(written.contains("MAT8"), "{written}");
}

/// A cylindrical or spherical MCID orients the material by its r axis at the element centre
/// (the mean of the corners), projected on the element (QRG, CQUAD4 MCID): the same matrices,
/// to round-off, as a rectangular MCID whose x axis is that r direction.
#[test]
fn curvilinear_mcid_takes_the_r_axis_at_the_centre() {
    let mat8 = "MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\nPCOMP,1\n,8,.001,0.,,8,.0005,30.\n";
    let deck = |mcid: u64, cord: &str| {
        parse(&format!(
            "{GRIDS}CQUAD4,1,1,1,2,3,4,{mcid}\nCTRIA3,2,1,1,4,5,{mcid}\n{mat8}{cord}"
        ))
    };
    // Centres: the quad's (0.525, 0.525, 0), the triangle's (−0.2, 0.433…, 0).
    let rect = |x: [f64; 3]| {
        format!(
            "CORD2R,9,,0.,0.,0.,0.,0.,1.\n,{:e},{:e},{:e}\n",
            x[0], x[1], x[2]
        )
    };
    // Cylinder about basic z through the origin: r at the quad's centre is (1, 1, 0)/√2, at the
    // triangle's (−0.2, 1.3/3, 0) normalised; each element is checked against its own direction.
    let cyl = deck(4, "CORD2C,4,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n");
    let quad_r = deck(9, &rect([1.0, 1.0, 0.0]));
    let tria_r = deck(9, &rect([-0.2, 1.3 / 3.0, 0.0]));
    // Largest difference of element `i`'s K and M between two imports, relative to each.
    let diff = |a: &BulkImport, b: &BulkImport, i: usize| {
        let (ea, eb) = (
            &element_blocks(&a.model, MassKind::Consistent)[i],
            &element_blocks(&b.model, MassKind::Consistent)[i],
        );
        (max_abs(&(&ea.0 - &eb.0)) / max_abs(&ea.0)).max(max_abs(&(&ea.1 - &eb.1)) / max_abs(&ea.1))
    };
    let close = |a: &BulkImport, b: &BulkImport, i: usize, what: &str| {
        let d = diff(a, b, i);
        assert!(d <= 1e-12, "{what}: {d:e}");
    };
    close(&cyl, &quad_r, 0, "cylindrical MCID, quad");
    close(&cyl, &tria_r, 1, "cylindrical MCID, triangle");
    // The direction really changes the matrices (a rectangular MCID along basic x differs).
    let x_axis = deck(9, &rect([1.0, 0.0, 0.0]));
    assert!(diff(&cyl, &x_axis, 0) > 1e-3);
    // Sphere centred 2 below a point near the quad's centre: r ∝ (0.3, −0.4, 2), whose
    // projection on the plate is (0.3, −0.4).
    let sph = deck(
        4,
        "CORD2S,4,,.225,.925,-2.,.225,.925,-1.\n,1.225,.925,-2.\n",
    );
    let sph_r = deck(9, &rect([0.3, -0.4, 0.0]));
    close(&sph, &sph_r, 0, "spherical MCID, quad");
}

/// LAM = SMCORE (QRG PCOMP remark 13): with a single face material the smeared faces are the
/// plain laminate [faces/2, core, faces/2] (1e-12: the same integrals, summed differently);
/// with a 0°/90° face pair the law ignores the faces' order (LAM blank does not), `B = 0`, and
/// `A`, `D` are the hand formulas `A = A_f + A_c`, `D = D_c + (A_f/t_f)·⅔((h + t_f/2)³ − h³)`.
#[test]
fn smcore_is_a_sandwich_of_smeared_faces() {
    use crate::fe::laminate::{ShellLaw, property_law};
    let mats = "MAT8,8,1.4+11,1.+10,.3,5.+9,5.+9,3.5+9,1600.\nMAT1,1,7.+10,,.33,2700.\nMAT1,2,1.+8,,.3,80.\n";
    let law = |pcomp: &str| -> ShellLaw {
        let d = parse(&format!("{GRIDS}CQUAD4,1,1,1,2,3,4\n{mats}{pcomp}"));
        property_law(&d.model, &d.model.shell_properties[&1]).unwrap()
    };
    let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(b.abs()).max(1e-300);
    let same = |x: &ShellLaw, y: &ShellLaw, tol: f64, what: &str| {
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    rel(x.a[i][j], y.a[i][j]) <= tol || (x.a[i][j] - y.a[i][j]).abs() < 1e-3,
                    "{what} A"
                );
                assert!(
                    rel(x.d[i][j], y.d[i][j]) <= tol || (x.d[i][j] - y.d[i][j]).abs() < 1e-12,
                    "{what} D"
                );
                assert!((x.b[i][j] - y.b[i][j]).abs() <= 1e-9, "{what} B");
            }
        }
        for i in 0..2 {
            for j in 0..2 {
                assert!(
                    rel(x.g[i][j], y.g[i][j]) <= tol || (x.g[i][j] - y.g[i][j]).abs() < 1e-3,
                    "{what} G"
                );
            }
        }
        for (u, v, name) in [
            (x.mu, y.mu, "mu"),
            (x.inertia, y.inertia, "I"),
            (x.thickness, y.thickness, "T"),
        ] {
            assert!(rel(u, v) <= tol, "{what} {name}: {u:e} vs {v:e}");
        }
        assert!(
            x.first_moment.abs() <= 1e-15 && y.first_moment.abs() <= 1e-15,
            "{what} S"
        );
    };
    // Aluminium faces of 0.3 and 0.5 mm (smeared to 0.4 mm each side) about a 10 mm core.
    let sandwich = law("PCOMP,1,,,,,,,SMCORE\n,1,.0003,,,1,.0005\n,2,.01\n");
    let plain = law("PCOMP,1\n,1,.0004,,,2,.01\n,1,.0004\n");
    same(&sandwich, &plain, 1e-12, "isotropic faces");
    // A 0°/90° MAT8 face pair in either order.
    let (t, tc): (f64, f64) = (0.25e-3, 8e-3);
    let a = law(&format!(
        "PCOMP,1,,,,,,,SMCORE\n,8,{t},0.,,8,{t},90.\n,2,{tc}\n"
    ));
    let b = law(&format!(
        "PCOMP,1,,,,,,,SMCORE\n,8,{t},90.,,8,{t},0.\n,2,{tc}\n"
    ));
    same(&a, &b, 1e-14, "face order");
    let c = law(&format!(
        "PCOMP,1\n,8,{t},0.,,8,{t},90.\n,2,{tc},,,8,{t},90.\n,8,{t},0.\n"
    ));
    let d = law(&format!(
        "PCOMP,1\n,8,{t},90.,,8,{t},0.\n,2,{tc},,,8,{t},0.\n,8,{t},90.\n"
    ));
    assert!(
        rel(c.d[0][0], d.d[0][0]) > 1e-3,
        "LAM blank keeps the order"
    );
    // Hand formulas: Q11 = E1/(1 − ν12 ν21), Q22 = E2/(1 − ν12 ν21), ν21 = ν12 E2/E1.
    let (e1, e2, nu12) = (1.4e11, 1.0e10, 0.3);
    let den = 1.0 - nu12 * nu12 * e2 / e1;
    let (q11, q22) = (e1 / den, e2 / den);
    let qc = 1.0e8 / (1.0 - 0.09);
    let tf = 2.0 * t;
    let h = 0.5 * tc;
    let i_f = 2.0 / 3.0 * ((h + 0.5 * tf).powi(3) - h.powi(3));
    let a11 = (q11 + q22) * t + qc * tc;
    let d11 = qc * tc.powi(3) / 12.0 + (q11 + q22) * t / tf * i_f;
    assert!(
        rel(a.a[0][0], a11) < 1e-13,
        "A11 {:e} vs {a11:e}",
        a.a[0][0]
    );
    assert!(rel(a.a[1][1], a11) < 1e-13, "A22");
    assert!(
        rel(a.d[0][0], d11) < 1e-13,
        "D11 {:e} vs {d11:e}",
        a.d[0][0]
    );
    assert!(rel(a.d[1][1], d11) < 1e-13, "D22");
    let mu = 1600.0 * tf + 80.0 * tc;
    assert!(rel(a.mu, mu) < 1e-14, "mu");
    assert!(
        rel(a.inertia, 80.0 * tc.powi(3) / 12.0 + 1600.0 * i_f) < 1e-13,
        "I"
    );
}
