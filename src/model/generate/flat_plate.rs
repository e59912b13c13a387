//! A flat rectangular plate of four-node shells in the x-y plane (NAFEMS FV12/FV16 and the
//! scale benchmarks).

use crate::core::{Component, DofId};
use crate::model::{Element, Material, Model, ShellProperty};

/// Edge support of a flat plate.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum PlateSupport {
    /// No support (six rigid-body modes).
    Free,
    /// The edge `x = 0` clamped (all six DOFs).
    ClampedEdge,
    /// All four edges simply supported (`uz = 0`; in-plane rigid motion removed at one corner).
    SimplySupported,
}

/// A flat plate.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatPlate {
    /// Length along x, m.
    pub a: f64,
    /// Width along y, m.
    pub b: f64,
    /// Elements along x.
    pub nx: usize,
    /// Elements along y.
    pub ny: usize,
    /// Thickness, m.
    pub thickness: f64,
    /// Material.
    pub material: Material,
    /// Support.
    pub support: PlateSupport,
}

/// The plate as a model: nodes `1 + i + j (nx + 1)`, elements from 1, property 1, material 1,
/// one set `plate` holding every element.
pub fn flat_plate(p: &FlatPlate) -> Model {
    let mut m = Model::default();
    let id = |i: usize, j: usize| (1 + i + j * (p.nx + 1)) as u64;
    for j in 0..=p.ny {
        for i in 0..=p.nx {
            m.nodes.insert(
                id(i, j),
                [
                    p.a * i as f64 / p.nx as f64,
                    p.b * j as f64 / p.ny as f64,
                    0.0,
                ],
            );
        }
    }
    m.materials.insert(1, p.material.clone());
    m.shell_properties
        .insert(1, ShellProperty::homogeneous(1, p.thickness, 0.0));
    let mut eid = 1;
    for j in 0..p.ny {
        for i in 0..p.nx {
            m.elements.insert(
                eid,
                Element::Quad4 {
                    nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                    property: 1,
                },
            );
            eid += 1;
        }
    }
    m.sets
        .insert("plate".into(), m.elements.keys().copied().collect());
    match p.support {
        PlateSupport::Free => {}
        PlateSupport::ClampedEdge => {
            for j in 0..=p.ny {
                for c in Component::ALL {
                    m.constraints.push(DofId::new(id(0, j), c));
                }
            }
        }
        PlateSupport::SimplySupported => {
            for j in 0..=p.ny {
                for i in 0..=p.nx {
                    if i == 0 || j == 0 || i == p.nx || j == p.ny {
                        m.constraints.push(DofId::new(id(i, j), Component::Uz));
                    }
                }
            }
            // In-plane rigid motion: fix ux, uy at one corner, uy at the next, and the drilling rotations.
            m.constraints.push(DofId::new(id(0, 0), Component::Ux));
            m.constraints.push(DofId::new(id(0, 0), Component::Uy));
            m.constraints.push(DofId::new(id(p.nx, 0), Component::Uy));
        }
    }
    m.constraints.sort();
    m.constraints.dedup();
    m
}
