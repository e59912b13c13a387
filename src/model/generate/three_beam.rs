//! The clamped three-beam assembly (CASES.md C4, thesis §7.1): two parallel slender steel beams
//! along x and one between them along y, joined at their midpoints by six-DOF lumped springs
//! (the bolted joint), each beam's trailing end held to ground by six-DOF springs (the clamps),
//! and lumped masses at three measurement points. Unclamped: 3 × 36 nodes = 648 DOFs.
//!
//! Reconstructed (the thesis's drawing is not in the extracted text): beam lengths 0.6 m,
//! rectangular section 25 mm × 8 mm, vertical gap 8 mm between beam axes at the joint, joint
//! springs 1e8 N/m and 1e5 N·m/rad, clamp springs 1e7 N/m and 1e5 N·m/rad (the initial model;
//! the thesis found the real clamps softer in y and θz: about 3e6 N/m and 1.4e4 N·m/rad),
//! 50 g accelerometer masses. Sets: `clamp_1..3`, `joint_1..2`, `mass_1..3`, `beam_1..3`.

use super::steel;
use crate::model::{BeamProperty, BeamSection, Element, Model};

/// Settings of the three-beam assembly.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreeBeam {
    /// Elements per beam (35 gives 648 DOFs).
    pub elements_per_beam: usize,
    /// Beam length, m.
    pub length: f64,
    /// Clamp stiffness `[kx, ky, kz, krx, kry, krz]`.
    pub clamp: [f64; 6],
    /// Joint stiffness `[kx, ky, kz, krx, kry, krz]`.
    pub joint: [f64; 6],
    /// Accelerometer mass, kg.
    pub sensor_mass: f64,
}

impl Default for ThreeBeam {
    fn default() -> Self {
        ThreeBeam {
            elements_per_beam: 35,
            length: 0.6,
            clamp: [1e7, 1e7, 1e7, 1e5, 1e5, 1e5],
            joint: [1e8, 1e8, 1e8, 1e5, 1e5, 1e5],
            sensor_mass: 0.05,
        }
    }
}

/// Builds the model. Beam `b` (1–3) has nodes `1000 b + k`, elements `1000 b + k`; springs and
/// masses from 9001.
pub fn three_beam(p: &ThreeBeam) -> Model {
    let ne = p.elements_per_beam.max(2);
    // The joint node `ne / 2` sits at the crossing (exactly mid-length when `ne` is even).
    let (l0, l1) = (
        -p.length * (ne / 2) as f64 / ne as f64,
        p.length * (ne - ne / 2) as f64 / ne as f64,
    );
    let mut m = Model::default();
    m.materials.insert(1, steel());
    m.beam_properties.insert(
        1,
        BeamProperty {
            material: 1,
            section: BeamSection::Rectangle {
                width: 0.025,
                height: 0.008,
            },
            nsm: 0.0,
            taper: None,
            centres: None,
        },
    );
    let gap = 0.008;
    // Beams 1 and 3 along x at z = ±gap, beam 2 along y at z = 0; joint nodes above the origin.
    let lines: [([f64; 3], [f64; 3], [f64; 3]); 3] = [
        ([l0, 0.0, gap], [l1, 0.0, gap], [0.0, 1.0, 0.0]),
        ([0.0, l0, 0.0], [0.0, l1, 0.0], [1.0, 0.0, 0.0]),
        ([l0, 0.0, -gap], [l1, 0.0, -gap], [0.0, 1.0, 0.0]),
    ];
    for (b, (a, z, v)) in lines.iter().enumerate() {
        let base = 1000 * (b as u64 + 1);
        let mut ids = Vec::new();
        for k in 0..=ne {
            let t = k as f64 / ne as f64;
            m.nodes.insert(
                base + k as u64,
                [
                    a[0] + t * (z[0] - a[0]),
                    a[1] + t * (z[1] - a[1]),
                    a[2] + t * (z[2] - a[2]),
                ],
            );
            if k > 0 {
                let e = base + k as u64;
                m.elements.insert(
                    e,
                    Element::Beam {
                        nodes: [base + k as u64 - 1, base + k as u64],
                        property: 1,
                        orientation: *v,
                        ends: Default::default(),
                    },
                );
                ids.push(e);
            }
        }
        m.sets.insert(format!("beam_{}", b + 1), ids);
    }
    let mid = |b: u64| 1000 * b + (ne / 2) as u64;
    let mut eid = 9001u64;
    // Clamps at each beam's trailing (first) node.
    for b in 1..=3u64 {
        m.elements.insert(
            eid,
            Element::Bush {
                node: 1000 * b,
                other: None,
                k: p.clamp,
                axes: None,
                b: [0.0; 6],
            },
        );
        m.sets.insert(format!("clamp_{b}"), vec![eid]);
        eid += 1;
    }
    // Joint: beam 2's midpoint to beams 1 and 3.
    for (s, b) in [(1, 1u64), (2, 3u64)] {
        m.elements.insert(
            eid,
            Element::Bush {
                node: mid(2),
                other: Some(mid(b)),
                k: p.joint,
                axes: None,
                b: [0.0; 6],
            },
        );
        m.sets.insert(format!("joint_{s}"), vec![eid]);
        eid += 1;
    }
    // Sensors three quarters along each beam.
    for b in 1..=3u64 {
        let node = 1000 * b + (3 * ne / 4) as u64;
        m.elements.insert(
            eid,
            Element::Mass {
                node,
                mass: p.sensor_mass,
                inertia: [0.0; 6],
                offset: [0.0; 3],
            },
        );
        m.sets.insert(format!("mass_{b}"), vec![eid]);
        eid += 1;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unclamped_it_has_648_dofs() {
        let m = three_beam(&ThreeBeam::default());
        assert_eq!(m.n_dofs(), 648);
        m.validate().unwrap();
        assert_eq!(m.sets.len(), 3 + 3 + 2 + 3);
    }
}
