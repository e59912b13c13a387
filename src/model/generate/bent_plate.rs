//! The thesis's benchmark (CASES.md C2, thesis fig. 2.8): two flat plates of `7n × 7n` four-node
//! shells joined along one edge and bent there, with a bar of `25n` Timoshenko beams (square
//! section) across the diagonal between opposite corners. For `n = 1`: 120 plate nodes + 24
//! bar-only nodes = 144 nodes = 864 DOFs, 98 shells, 25 beams.
//!
//! Reconstructed (the extraction lost them): the overall size 0.3 m wide and 0.625 m developed
//! length (two plates of 0.3125 m), the bend angle (30° by default) and steel. The bar runs
//! straight from the first plate's corner `(0, 0)` to the second plate's far corner `(L, W)`.
//! Sets: `strip_1 … strip_14` (each the row of `7n·n` shells at one position along the length,
//! numbered from the free end of the first plate), `plate_1`, `plate_2`, `bar`.

use super::steel;
use crate::core::{Component, DofId};
use crate::model::{BeamProperty, BeamSection, Element, Model, ShellProperty};

/// Settings of the bent plate.
#[derive(Clone, Debug, PartialEq)]
pub struct BentPlate {
    /// Mesh refinement `n`: `7n × 7n` shells per plate, `25n` beams.
    pub refine: usize,
    /// Width, m.
    pub width: f64,
    /// Length of each plate along the developed length, m.
    pub plate_length: f64,
    /// Bend angle between the plates, degrees.
    pub bend_deg: f64,
    /// Shell thickness, m.
    pub thickness: f64,
    /// Bar square-section width, m.
    pub bar_width: f64,
    /// Include the bar (the CMS study C3 uses the plates alone).
    pub with_bar: bool,
    /// Clamp the free edge of the first plate (all six DOFs) instead of free-free.
    pub clamped: bool,
}

impl Default for BentPlate {
    fn default() -> Self {
        BentPlate {
            refine: 1,
            width: 0.3,
            plate_length: 0.3125,
            bend_deg: 30.0,
            thickness: 1.4e-3,
            bar_width: 5.5e-3,
            with_bar: true,
            clamped: false,
        }
    }
}

/// Builds the model: nodes `1…` on the plates (row-major along the length), bar-only nodes from
/// `100001`; shells from 1, beams from `100001`; materials 1 (steel), properties 1 (shell), 2 (bar).
pub fn bent_plate(p: &BentPlate) -> Model {
    let n = p.refine.max(1);
    let (nx, ny) = (14 * n, 7 * n); // elements along the developed length and across the width
    let mut m = Model::default();
    m.materials.insert(1, steel());
    m.shell_properties
        .insert(1, ShellProperty::homogeneous(1, p.thickness, 0.0));
    let angle = p.bend_deg.to_radians();
    let lx = p.plate_length / (7 * n) as f64;
    let point = |i: usize, j: usize| -> [f64; 3] {
        let y = p.width * j as f64 / ny as f64;
        if i <= 7 * n {
            [lx * i as f64, y, 0.0]
        } else {
            let s = lx * (i - 7 * n) as f64;
            [p.plate_length + s * angle.cos(), y, s * angle.sin()]
        }
    };
    let id = |i: usize, j: usize| (1 + i + j * (nx + 1)) as u64;
    for j in 0..=ny {
        for i in 0..=nx {
            m.nodes.insert(id(i, j), point(i, j));
        }
    }
    let mut eid = 1u64;
    let mut strips: Vec<Vec<u64>> = vec![Vec::new(); 14];
    let (mut plate1, mut plate2) = (Vec::new(), Vec::new());
    for j in 0..ny {
        for i in 0..nx {
            m.elements.insert(
                eid,
                Element::Quad4 {
                    nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                    property: 1,
                },
            );
            strips[i / n].push(eid);
            if i < 7 * n {
                plate1.push(eid)
            } else {
                plate2.push(eid)
            }
            eid += 1;
        }
    }
    for (s, ids) in strips.into_iter().enumerate() {
        let mut ids = ids;
        ids.sort_unstable();
        m.sets.insert(format!("strip_{}", s + 1), ids);
    }
    m.sets.insert("plate_1".into(), plate1);
    m.sets.insert("plate_2".into(), plate2);
    if p.with_bar {
        m.beam_properties.insert(
            2,
            BeamProperty {
                material: 1,
                section: BeamSection::Rectangle {
                    width: p.bar_width,
                    height: p.bar_width,
                },
                nsm: 0.0,
                taper: None,
                centres: None,
            },
        );
        let (a, b) = (id(0, 0), id(nx, ny));
        let (xa, xb) = (m.nodes[&a], m.nodes[&b]);
        let nb = 25 * n;
        let axis = [xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]];
        // Orientation: local y toward the plate normal side, any vector not along the axis.
        let v = [0.0, 0.0, 1.0];
        let mut prev = a;
        let mut bar = Vec::new();
        for k in 1..=nb {
            let node = if k == nb {
                b
            } else {
                let t = k as f64 / nb as f64;
                let nid = 100000 + k as u64;
                m.nodes.insert(
                    nid,
                    [
                        xa[0] + t * axis[0],
                        xa[1] + t * axis[1],
                        xa[2] + t * axis[2],
                    ],
                );
                nid
            };
            let e = 100000 + k as u64;
            m.elements.insert(
                e,
                Element::Beam {
                    nodes: [prev, node],
                    property: 2,
                    orientation: v,
                    ends: Default::default(),
                },
            );
            bar.push(e);
            prev = node;
        }
        m.sets.insert("bar".into(), bar);
    }
    if p.clamped {
        for j in 0..=ny {
            for c in Component::ALL {
                m.constraints.push(DofId::new(id(0, j), c));
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_benchmark_has_864_dofs() {
        let m = bent_plate(&BentPlate::default());
        assert_eq!(m.nodes.len(), 144);
        assert_eq!(m.n_dofs(), 864);
        assert_eq!(
            m.elements
                .values()
                .filter(|e| matches!(e, Element::Quad4 { .. }))
                .count(),
            98
        );
        assert_eq!(
            m.elements
                .values()
                .filter(|e| matches!(e, Element::Beam { .. }))
                .count(),
            25
        );
        assert_eq!(
            m.sets.keys().filter(|k| k.starts_with("strip_")).count(),
            14
        );
        assert!(m.sets.values().filter(|_| true).all(|s| !s.is_empty()));
        assert_eq!(m.sets["strip_3"].len(), 7);
        m.validate().unwrap();
        // The bar spans the developed diagonal: from (0,0,0) to the far corner.
        let far = m.nodes[&(15 * 8)];
        assert!((far[1] - 0.3).abs() < 1e-12 && far[2] > 0.15);
    }

    #[test]
    fn the_cms_study_plates_have_720_dofs() {
        let m = bent_plate(&BentPlate {
            with_bar: false,
            ..Default::default()
        });
        assert_eq!(m.n_dofs(), 720);
        assert_eq!(m.elements.len(), 98);
    }
}
