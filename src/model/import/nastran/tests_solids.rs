//! Solids (CHEXA, CPENTA, CTETRA, CPYRAM, PSOLID, MAT9) with the QRG's meaning, each against
//! an analytic value, a second deck or the kernel directly.

use super::tests::{error, parse};
use super::*;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::mass_properties::mass_properties;
use crate::fe::model_assembly::{assemble_model, element_matrices};
use crate::model::structure::{SolidFamily, SolidKind};

/// GRIDs of a 2 × 1 × 1 block of unit-cube cells over x ∈ [0, 2] (ids `1 + i + 3j + 6k`).
fn grids() -> String {
    let mut d = String::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..3 {
                d += &format!("GRID,{},,{i}.,{j}.,{k}.\n", 1 + i + 3 * j + 6 * k);
            }
        }
    }
    d
}

/// Corner grids of cell `i` (0 or 1) in CHEXA order.
fn cell(i: usize) -> [usize; 8] {
    let g = |x: usize, y: usize, z: usize| 1 + i + x + 3 * y + 6 * z;
    [
        g(0, 0, 0),
        g(1, 0, 0),
        g(1, 1, 0),
        g(0, 1, 0),
        g(0, 0, 1),
        g(1, 0, 1),
        g(1, 1, 1),
        g(0, 1, 1),
    ]
}

/// A CHEXA cell beside a cell of six CTETRA (steel, PSOLID): it imports, its grids keep only
/// translations, the free block has six rigid-body modes (below 1e-6 Hz against a first
/// elastic one of kHz) and a positive seventh, and the weight summary is ρV = 2 × 7850 kg with
/// the centre of gravity at (1, 0.5, 0.5) (1e-12).
#[test]
fn a_deck_of_hexa_and_tetra_assembles_and_has_modes() {
    let mut d = format!("MAT1,1,2.1+11,,.3,7850.\nPSOLID,5,1\n{}", grids());
    let h = cell(0);
    d += &format!(
        "CHEXA,1,5,{},{},{},{},{},{}\n,{},{}\n",
        h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7]
    );
    let t = cell(1);
    for (n, tet) in [
        [0, 1, 2, 6],
        [0, 2, 3, 6],
        [0, 3, 7, 6],
        [0, 7, 4, 6],
        [0, 4, 5, 6],
        [0, 5, 1, 6],
    ]
    .iter()
    .enumerate()
    {
        d += &format!(
            "CTETRA,{},5,{},{},{},{}\n",
            10 + n,
            t[tet[0]],
            t[tet[1]],
            t[tet[2]],
            t[tet[3]]
        );
    }
    let b = parse(&d);
    let m = &b.model;
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    assert_eq!(m.elements.len(), 7);
    assert_eq!(m.sets["pid5"].len(), 7);
    assert!(matches!(
        m.elements[&1],
        Element::Solid {
            kind: SolidKind::Hexa8,
            ..
        }
    ));
    assert!(matches!(
        m.elements[&10],
        Element::Solid {
            kind: SolidKind::Tetra4,
            ..
        }
    ));
    let (sys, info) = assemble_model(m, MassKind::Consistent).unwrap();
    assert_eq!(sys.dofs.len(), 3 * 12);
    assert_eq!(info.auto_constrained.len(), 3 * 12);
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(8),
        &SparseEigenParams::default(),
    )
    .unwrap();
    let f = modes.frequencies_hz();
    assert_eq!(modes.rigid_body_modes, 6, "{f:?}");
    assert!(f[6] > 100.0, "{f:?}");
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        let p = mass_properties(m, mass, [0.0; 3]).unwrap();
        assert!((p.mass[0] - 2.0 * 7850.0).abs() < 1e-12 * 2.0 * 7850.0);
        for (c, w) in p.centre_of_gravity.iter().zip([1.0, 0.5, 0.5]) {
            assert!((c - w).abs() < 1e-12, "{:?}", p.centre_of_gravity);
        }
    }
}

/// The 20-, 15-, 10-node shapes and the pyramid are read from their continuation lines in the
/// QRG's order; PID blank is the EID; PSOLID IN/ISOP are accepted with a warning.
#[test]
fn quadratic_shapes_and_defaults() {
    let mut d =
        String::from("MAT1,1,2.1+11,,.3,7850.\nPSOLID,7,1,,BUBBLE\nPSOLID,3,1,,,,FULL,SMECH\n");
    // A 20-node unit hexahedron: corners then midsides in the QRG's order.
    let corners = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
    ];
    let edges = crate::fe::solid::shape::HEX_EDGES;
    let mut pts: Vec<[f64; 3]> = corners.to_vec();
    for [a, b] in edges {
        pts.push([0, 1, 2].map(|k| 0.5 * (corners[a][k] + corners[b][k])));
    }
    for (i, p) in pts.iter().enumerate() {
        d += &format!("GRID,{},,{},{},{}\n", 101 + i, p[0], p[1], p[2]);
    }
    d += "GRID,200,,0.5,0.5,2.\n";
    let ids: Vec<String> = (101..121).map(|i| i.to_string()).collect();
    d += &format!(
        "CHEXA,7,,{}\n,{}\n,{}\n",
        ids[..6].join(","),
        ids[6..14].join(","),
        ids[14..].join(",")
    );
    // A pyramid on the top face, apex 200.
    d += "CPYRAM,8,3,105,106,107,108,200\n";
    // A 10-node tetrahedron on corners 101, 102, 104, 105 with the matching midsides.
    d += "CTETRA,9,3,101,102,104,105,109,301\n,112,113,302,303\n";
    d += "GRID,301,,.5,.5,0.\nGRID,302,,.5,0.,.5\nGRID,303,,0.,.5,.5\n";
    let b = parse(&d);
    let m = &b.model;
    match &m.elements[&7] {
        Element::Solid {
            kind,
            nodes,
            property,
        } => {
            assert_eq!(*kind, SolidKind::Hexa20);
            assert_eq!(*property, 7);
            assert_eq!(nodes, &(101..121).collect::<Vec<u64>>());
        }
        e => panic!("{e:?}"),
    }
    assert!(matches!(
        m.elements[&8],
        Element::Solid {
            kind: SolidKind::Pyram5,
            ..
        }
    ));
    match &m.elements[&9] {
        Element::Solid { kind, nodes, .. } => {
            assert_eq!(*kind, SolidKind::Tetra10);
            assert_eq!(
                nodes,
                &vec![101, 102, 104, 105, 109, 301, 112, 113, 302, 303]
            );
        }
        e => panic!("{e:?}"),
    }
    assert!(
        b.warnings
            .iter()
            .any(|w| w.contains("PSOLID 7") && w.contains("IN = BUBBLE"))
            && b.warnings
                .iter()
                .any(|w| w.contains("PSOLID 3") && w.contains("ISOP = FULL")),
        "{:?}",
        b.warnings
    );
    // The element matrices are the kernel's of the same grids.
    let e = element_matrices(m, &m.elements[&7], MassKind::Consistent).unwrap();
    let direct = crate::fe::solid::solid(
        SolidKind::Hexa20,
        &pts,
        &crate::fe::solid::SolidMaterial {
            d: crate::fe::solid::isotropic(2.1e11, 0.3).unwrap(),
            rho: 7850.0,
        },
        MassKind::Consistent,
    )
    .unwrap();
    assert_eq!(e, direct);
}

/// A MAT9 holding the isotropic matrix of a MAT1 gives the same stiffness (1e-13: the 21
/// numbers are written in full precision), and a MAT9 in a rectangular CORD2R holds the
/// system's axes; PARAM,WTMASS scales its density.
#[test]
fn mat9_equals_mat1_and_takes_its_cordm() {
    let d = crate::fe::solid::isotropic(2.1e11, 0.3).unwrap();
    let mut g = Vec::new();
    for (i, j) in (0..6).flat_map(|i| (i..6).map(move |j| (i, j))) {
        g.push(crate::model::export::nastran::format_real(d[i][j]));
    }
    // The CHEXA's 8 grids need a continuation: fields 3–8 then 9–10.
    let hexa = {
        let c = cell(0).map(|v| v.to_string());
        format!(
            "{}CHEXA,1,5,{}\n,{}\n",
            grids(),
            c[..6].join(","),
            c[6..].join(",")
        )
    };
    let iso = parse(&format!("MAT1,1,2.1+11,,.3,7850.\nPSOLID,5,1\n{hexa}"));
    let mat9 = format!(
        "MAT9,1,{}\n,{}\n,{},7850.\n",
        g[..7].join(","),
        g[7..15].join(","),
        g[15..].join(",")
    );
    let aniso = parse(&format!("{mat9}PSOLID,5,1\n{hexa}"));
    assert!(aniso.model.materials.is_empty());
    let (a, b) = (
        element_matrices(&iso.model, &iso.model.elements[&1], MassKind::Consistent).unwrap(),
        element_matrices(
            &aniso.model,
            &aniso.model.elements[&1],
            MassKind::Consistent,
        )
        .unwrap(),
    );
    assert!((&a.k - &b.k).norm_max() <= 1e-13 * a.k.norm_max());
    assert_eq!(a.m, b.m);
    // CORDM: a CORD2R turned 30° about z.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let deck = format!(
        "{mat9}CORD2R,4,,0.,0.,0.,0.,0.,1.\n,{c:.17},{s:.17},0.\nPSOLID,5,1,4\nPARAM,WTMASS,.5\n{hexa}"
    );
    let turned = parse(&deck);
    let axes = turned.model.solid_properties[&5].axes.unwrap();
    let want = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
    for r in 0..3 {
        for k in 0..3 {
            assert!((axes[r][k] - want[r][k]).abs() < 1e-15, "{axes:?}");
        }
    }
    assert_eq!(turned.model.anisotropic_materials[&1].rho, 0.5 * 7850.0);
}

/// Errors name the file, line, card and field: a hexahedron turned inside out, a negative
/// midside grid, a repeated grid of a partial set, a fluid PSOLID, a repeated grid, a grid
/// beyond G13 of a CPYRAM, a MAT9 in the element system or in a cylindrical system, a MAT9 that
/// is not positive definite, a PSOLID naming no material.
#[test]
fn solid_errors_name_the_card() {
    let base = format!("MAT1,1,2.1+11,,.3,7850.\nPSOLID,5,1\n{}", grids());
    let c = cell(0).map(|v| v.to_string());
    // G1–G4 clockwise seen from G5–G8.
    let e = error(&format!(
        "{base}CHEXA,1,5,{},{},{},{},{},{}\n,{},{}\n",
        c[0], c[3], c[2], c[1], c[4], c[7], c[6], c[5]
    ));
    assert!(
        e.starts_with(
            "t.bdf line 15: CHEXA 1 (property 5 at t.bdf line 2, material 1 at t.bdf line 1)"
        ) && e.contains("Jacobian")
            && e.contains("G1-G4"),
        "{e}"
    );
    let e = error(&format!(
        "{base}CHEXA,1,5,{}\n,{},{},,-3\n",
        c[..6].join(","),
        c[6],
        c[7]
    ));
    assert!(
        e.starts_with("t.bdf line 15: CHEXA field 5 (G10) of continuation 1 (line 16)")
            && e.contains("-3 is not a grid id")
            && e.contains("blank or 0 for no midside grid"),
        "{e}"
    );
    // A repeated grid in a partial set is named by its own field (G6, not the 5th node).
    let e = error(&format!("{base}CTETRA,1,5,1,2,4,7,,1\n"));
    assert!(
        e.starts_with("t.bdf line 15: CTETRA field 9 (G6)") && e.contains("also G1"),
        "{e}"
    );
    let e = error(&format!("{base}PSOLID,6,1,,,,,PFLUID\n"));
    assert!(
        e.starts_with("t.bdf line 15: PSOLID field 8 (FCTN)") && e.contains("SMECH"),
        "{e}"
    );
    let e = error(&format!("{base}CTETRA,1,5,1,2,4,1\n"));
    assert!(
        e.starts_with("t.bdf line 15: CTETRA field 7 (G4)") && e.contains("appears twice"),
        "{e}"
    );
    let e = error(&format!(
        "{base}CPYRAM,1,5,1,2,5,4,7,8\n,9,10,11,12,13,14,15,16\n"
    ));
    assert!(
        e.starts_with(
            "t.bdf line 15: CPYRAM field 9 ((beyond the grids)) of continuation 1 (line 16)"
        ) && e.contains("at most 13 grids"),
        "{e}"
    );
    let g: Vec<String> = (0..21)
        .map(|k| {
            if [0, 6, 11, 15, 18, 20].contains(&k) {
                "1.+9"
            } else {
                ""
            }
            .to_string()
        })
        .collect();
    let mat9 = format!(
        "MAT9,2,{}\n,{}\n,{}\n",
        g[..7].join(","),
        g[7..15].join(","),
        g[15..].join(",")
    );
    let e = error(&format!("{base}{mat9}PSOLID,6,2,-1\nCTETRA,1,6,1,2,4,7\n"));
    assert!(
        e.starts_with("t.bdf line 18: PSOLID field 4 (CORDM)")
            && e.contains("element coordinate system"),
        "{e}"
    );
    // Still refused: a MAT9 in a cylindrical CORDM (axes varying over the mesh).
    let e = error(&format!(
        "{base}{mat9}CORD2C,4,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nPSOLID,6,2,4\nCTETRA,1,6,1,2,4,7\n"
    ));
    assert!(
        e.starts_with("t.bdf line 20: PSOLID field 4 (CORDM)")
            && e.contains("cylindrical or spherical")
            && e.contains("CORD2R"),
        "{e}"
    );
    let bad = mat9.replacen("1.+9", "-1.+9", 1);
    let e = error(&format!("{base}{bad}"));
    assert!(
        e.starts_with("t.bdf line 15: MAT9 field 3 (G11)") && e.contains("positive definite"),
        "{e}"
    );
    let e = error(&format!("{base}PSOLID,6,9\nCTETRA,1,6,1,2,4,7\n"));
    assert!(
        e.starts_with("t.bdf line 15: PSOLID field 3 (MID)") && e.contains("MAT1 or MAT9"),
        "{e}"
    );
}

/// `pid<N>` parameters on solids: E and ρ are read and written through the PSOLID's MAT1; the
/// exported deck reads back to the same stiffness and mass (1e-12), MAT9 axes included.
#[test]
fn solid_parameters_and_export_round_trip() {
    use crate::model::{Parameter, ParameterKind};
    let c = cell(0).map(|v| v.to_string());
    let c1 = cell(1).map(|v| v.to_string());
    let deck = format!(
        "MAT1,1,2.1+11,,.3,7850.\nMAT9,2,2.+11,1.+10,,,,,1.5+11\n,,,,,1.2+11\n,5.+10,,,6.+10,,7.+10,2700.\nCORD2R,4,,0.,0.,0.,0.,.6,.8\n,1.,0.,0.\nPSOLID,5,1\nPSOLID,6,2,4\n{}CHEXA,1,5,{}\n,{}\nCHEXA,2,6,{}\n,{}\n",
        grids(),
        c[..6].join(","),
        c[6..].join(","),
        c1[..6].join(","),
        c1[6..].join(",")
    );
    let mut m = parse(&deck).model;
    let e = Parameter {
        name: "e".into(),
        kind: ParameterKind::YoungsModulus,
        set: "pid5".into(),
        lower: 1.0,
        upper: 1e12,
    };
    let rho = Parameter {
        name: "rho".into(),
        kind: ParameterKind::Density,
        set: "pid6".into(),
        lower: 1.0,
        upper: 1e5,
    };
    assert_eq!(m.parameter_value(&e).unwrap(), 2.1e11);
    assert_eq!(m.parameter_value(&rho).unwrap(), 2700.0);
    let wrong = Parameter {
        kind: ParameterKind::YoungsModulus,
        ..rho.clone()
    };
    assert!(m.parameter_value(&wrong).is_err(), "a MAT9 has no single E");
    m.set_parameter_value(&e, 1.9e11).unwrap();
    m.set_parameter_value(&rho, 2800.0).unwrap();
    assert_eq!(m.materials[&1].e, 1.9e11);
    assert_eq!(m.anisotropic_materials[&2].rho, 2800.0);
    let text = crate::model::export::nastran::write_bulk(&m);
    let back = parse(&text).model;
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        let (a, _) = assemble_model(&m, mass).unwrap();
        let (b, _) = assemble_model(&back, mass).unwrap();
        assert_eq!(a.dofs, b.dofs);
        let (ka, kb) = (a.k_dense(), b.k_dense());
        assert!((&ka - &kb).norm_max() <= 1e-12 * ka.norm_max());
        let (ma, mb) = (a.m_dense(), b.m_dense());
        assert!((&ma - &mb).norm_max() <= 1e-12 * ma.norm_max());
    }
}

/// Partial midside sets and the 13-node pyramid (QRG: any midside grid may be blank or 0): a
/// CHEXA with 7 of its 12 midside grids (G10, G12 absent, G14 written as 0, G15, G16 blank) is
/// the variable-node hexahedron with its grids in field order; a CPYRAM with all of G6–G13 on
/// its top face is PYRAM13; a CTETRA and a CPENTA with partial sets are variable-node elements.
/// The hexahedron's matrices are the kernel's of the same grids (bit for bit); the CHEXA and
/// CPYRAM together weigh ρ(1 + 1/3) (1e-12, both masses) and have six rigid-body modes; the
/// exported deck writes absent midside grids blank and reads back to the same elements.
#[test]
fn partial_midside_grids_and_the_13_node_pyramid() {
    let mut d = String::from("MAT1,1,2.1+11,,.3,7850.\nPSOLID,3,1\n");
    let corners = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
    ];
    let mut pts: Vec<[f64; 3]> = corners.to_vec();
    for [a, b] in crate::fe::solid::shape::HEX_EDGES {
        pts.push([0, 1, 2].map(|k| 0.5 * (corners[a][k] + corners[b][k])));
    }
    for (i, p) in pts.iter().enumerate() {
        d += &format!("GRID,{},,{},{},{}\n", 101 + i, p[0], p[1], p[2]);
    }
    // Apex 200 above the top face and the midpoints 201–204 of its edges to the top corners.
    d += "GRID,200,,0.5,0.5,2.\n";
    for (i, c) in corners[4..].iter().enumerate() {
        d += &format!(
            "GRID,{},,{},{},{}\n",
            201 + i,
            0.5 * (c[0] + 0.5),
            0.5 * (c[1] + 0.5),
            0.5 * (c[2] + 2.0)
        );
    }
    // G9 … G20: 109, -, 111, -, 113, 0, -, -, 117, 118, 119, 120.
    d += "CHEXA,7,3,101,102,103,104,105,106\n,107,108,109,,111,,113,0\n,,,117,118,119,120\n";
    d += "CPYRAM,8,3,105,106,107,108,200,117\n,118,119,120,201,202,203,204\n";
    d += "CTETRA,9,3,101,102,104,105,109,\n,112\n";
    d += "CPENTA,10,3,101,102,103,105,106,107\n,109\n";
    let b = parse(&d);
    let m = &b.model;
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    let solid = |id: u64| match &m.elements[&id] {
        Element::Solid { kind, nodes, .. } => (*kind, nodes.clone()),
        e => panic!("{e:?}"),
    };
    let hexa = SolidKind::Variable {
        family: SolidFamily::Hexa,
        midside: 0b1111_0001_0101,
    };
    assert_eq!(
        solid(7),
        (
            hexa,
            vec![
                101, 102, 103, 104, 105, 106, 107, 108, 109, 111, 113, 117, 118, 119, 120
            ]
        )
    );
    assert_eq!(
        solid(8),
        (
            SolidKind::Pyram13,
            vec![
                105, 106, 107, 108, 200, 117, 118, 119, 120, 201, 202, 203, 204
            ]
        )
    );
    assert_eq!(
        solid(9),
        (
            SolidKind::Variable {
                family: SolidFamily::Tetra,
                midside: 0b101
            },
            vec![101, 102, 104, 105, 109, 112]
        )
    );
    assert_eq!(
        solid(10),
        (
            SolidKind::Variable {
                family: SolidFamily::Penta,
                midside: 0b1
            },
            vec![101, 102, 103, 105, 106, 107, 109]
        )
    );
    let xyz: Vec<[f64; 3]> = solid(7).1.iter().map(|n| m.nodes[n]).collect();
    let e = element_matrices(m, &m.elements[&7], MassKind::Consistent).unwrap();
    let direct = crate::fe::solid::solid(
        hexa,
        &xyz,
        &crate::fe::solid::SolidMaterial {
            d: crate::fe::solid::isotropic(2.1e11, 0.3).unwrap(),
            rho: 7850.0,
        },
        MassKind::Consistent,
    )
    .unwrap();
    assert_eq!(e, direct);
    // The CHEXA and the CPYRAM alone: a free body of volume 1 + 1/3.
    let mut two = m.clone();
    two.elements.retain(|id, _| *id == 7 || *id == 8);
    two.sets.clear();
    two.add_property_sets();
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        let p = mass_properties(&two, mass, [0.0; 3]).unwrap();
        let want = 7850.0 * 4.0 / 3.0;
        for v in p.mass {
            assert!(((v - want) / want).abs() < 1e-12, "{mass:?}: {v} vs {want}");
        }
    }
    let (sys, _) = assemble_model(&two, MassKind::Consistent).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(8),
        &SparseEigenParams::default(),
    )
    .unwrap();
    let f = modes.frequencies_hz();
    assert_eq!(modes.rigid_body_modes, 6, "{f:?}");
    assert!(f[6] > 100.0, "{f:?}");
    // Export: absent midside grids are blank fields, and the deck reads back the same.
    let text = crate::model::export::nastran::write_bulk(m);
    let back = parse(&text).model;
    for id in 7..=10 {
        assert_eq!(back.elements[&id], m.elements[&id], "element {id}:\n{text}");
    }
}
