//! The scale cases of CASES.md C5, parameterised by mesh density from a few thousand to about a
//! million DOFs. The thesis's own S123 benchmark and muffler data are not public; these are
//! structures of the same kind:
//! - [`three_plate_two_beam`]: three flat rectangular plates stacked along z and held together by
//!   two beam columns along z at opposite corners (an S123-like assembly of three plates and two
//!   beams).
//! - [`muffler`]: a closed rectangular shell box (length along x) with internal transverse
//!   baffles and square inlet/outlet tubes through the end plates, all four-node shells.
//!
//! Both use one element size `h` everywhere, so the DOF count grows as `1/h²`.

use super::steel;
use crate::model::{BeamProperty, BeamSection, Element, Model, ShellProperty};
use std::collections::HashMap;

/// Builds shells on a structured grid of points, sharing nodes by rounded coordinates.
struct Builder {
    model: Model,
    by_position: HashMap<[i64; 3], u64>,
    next_node: u64,
    next_element: u64,
    h: f64,
}

impl Builder {
    fn new(h: f64) -> Self {
        let mut model = Model::default();
        model.materials.insert(1, steel());
        Builder {
            model,
            by_position: HashMap::new(),
            next_node: 1,
            next_element: 1,
            h,
        }
    }

    fn node(&mut self, x: [f64; 3]) -> u64 {
        let key = x.map(|c| (c / self.h * 1e3).round() as i64);
        if let Some(&id) = self.by_position.get(&key) {
            return id;
        }
        let id = self.next_node;
        self.next_node += 1;
        self.model.nodes.insert(id, x);
        self.by_position.insert(key, id);
        id
    }

    /// A rectangular patch `origin + s·u + t·v`, `s, t ∈ [0, 1]`, `nu × nv` quads, into `set`.
    fn patch(
        &mut self,
        origin: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        (nu, nv): (usize, usize),
        property: u64,
        set: &str,
    ) {
        let at = |i: usize, j: usize| -> [f64; 3] {
            let (s, t) = (i as f64 / nu as f64, j as f64 / nv as f64);
            [
                origin[0] + s * u[0] + t * v[0],
                origin[1] + s * u[1] + t * v[1],
                origin[2] + s * u[2] + t * v[2],
            ]
        };
        let mut ids = vec![vec![0u64; nv + 1]; nu + 1];
        for (i, row) in ids.iter_mut().enumerate() {
            for (j, id) in row.iter_mut().enumerate() {
                *id = self.node(at(i, j));
            }
        }
        let mut elements = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                let e = self.next_element;
                self.next_element += 1;
                self.model.elements.insert(
                    e,
                    Element::Quad4 {
                        nodes: [ids[i][j], ids[i + 1][j], ids[i + 1][j + 1], ids[i][j + 1]],
                        property,
                    },
                );
                elements.push(e);
            }
        }
        self.model
            .sets
            .entry(set.to_string())
            .or_default()
            .extend(elements);
    }

    fn divisions(&self, length: f64) -> usize {
        ((length / self.h).round() as usize).max(1)
    }
}

/// Three 1.2 m × 0.6 m plates (3 mm, 2 mm, 3 mm) stacked 0.3 m apart along z, held by two
/// 40 mm square beam columns at opposite corners, element size `h`.
/// Sets: `plate_1..3`, `columns`. About `3 · 6 · (1.2/h)(0.6/h)` DOFs (1M DOFs at `h ≈ 1.4 mm`).
pub fn three_plate_two_beam(h: f64) -> Model {
    let mut b = Builder::new(h);
    for (p, t) in [(1u64, 3e-3), (2, 2e-3), (3, 3e-3)] {
        b.model
            .shell_properties
            .insert(p, ShellProperty::homogeneous(1, t, 0.0));
    }
    b.model.beam_properties.insert(
        10,
        BeamProperty {
            material: 1,
            section: BeamSection::Rectangle {
                width: 0.04,
                height: 0.04,
            },
            nsm: 0.0,
        },
    );
    let (lx, ly, gap) = (1.2, 0.6, 0.3);
    let (nx, ny) = (b.divisions(lx), b.divisions(ly));
    for k in 0..3u64 {
        b.patch(
            [0.0, 0.0, gap * k as f64],
            [lx, 0.0, 0.0],
            [0.0, ly, 0.0],
            (nx, ny),
            k + 1,
            &format!("plate_{}", k + 1),
        );
    }
    // Two beams: along z at (0, 0) and (lx, ly), through all three plates.
    let nz = b.divisions(gap);
    let mut columns = Vec::new();
    for corner in [[0.0, 0.0], [lx, ly]] {
        let mut prev = b.node([corner[0], corner[1], 0.0]);
        for k in 1..=2 * nz {
            let z = gap * 2.0 * k as f64 / (2 * nz) as f64;
            let n = b.node([corner[0], corner[1], z]);
            let e = b.next_element;
            b.next_element += 1;
            b.model.elements.insert(
                e,
                Element::Beam {
                    nodes: [prev, n],
                    property: 10,
                    orientation: [1.0, 0.0, 0.0],
                    ends: Default::default(),
                },
            );
            columns.push(e);
            prev = n;
        }
    }
    b.model.sets.insert("columns".into(), columns);
    b.model
}

/// A muffler-like closed box 0.8 m × 0.3 m × 0.2 m of 1.5 mm steel with `baffles` transverse
/// internal plates (1 mm) and square 60 mm inlet/outlet tubes 0.1 m long on the end plates,
/// element size `h`. Free-free. Sets: `shell`, `baffles`, `tubes`.
pub fn muffler(h: f64, baffles: usize) -> Model {
    let mut b = Builder::new(h);
    b.model
        .shell_properties
        .insert(1, ShellProperty::homogeneous(1, 1.5e-3, 0.0));
    b.model
        .shell_properties
        .insert(2, ShellProperty::homogeneous(1, 1.0e-3, 0.0));
    b.model
        .shell_properties
        .insert(3, ShellProperty::homogeneous(1, 2.0e-3, 0.0));
    let (lx, ly, lz) = (0.8, 0.3, 0.2);
    let (nx, ny, nz) = (b.divisions(lx), b.divisions(ly), b.divisions(lz));
    // Outer skin: four sides and two ends.
    b.patch(
        [0.0, 0.0, 0.0],
        [lx, 0.0, 0.0],
        [0.0, ly, 0.0],
        (nx, ny),
        1,
        "shell",
    );
    b.patch(
        [0.0, 0.0, lz],
        [lx, 0.0, 0.0],
        [0.0, ly, 0.0],
        (nx, ny),
        1,
        "shell",
    );
    b.patch(
        [0.0, 0.0, 0.0],
        [lx, 0.0, 0.0],
        [0.0, 0.0, lz],
        (nx, nz),
        1,
        "shell",
    );
    b.patch(
        [0.0, ly, 0.0],
        [lx, 0.0, 0.0],
        [0.0, 0.0, lz],
        (nx, nz),
        1,
        "shell",
    );
    b.patch(
        [0.0, 0.0, 0.0],
        [0.0, ly, 0.0],
        [0.0, 0.0, lz],
        (ny, nz),
        1,
        "shell",
    );
    b.patch(
        [lx, 0.0, 0.0],
        [0.0, ly, 0.0],
        [0.0, 0.0, lz],
        (ny, nz),
        1,
        "shell",
    );
    // Baffles at equal spacing, snapped to the grid so they share the skin's nodes.
    for k in 1..=baffles {
        let i = (nx * k) / (baffles + 1);
        let x = lx * i as f64 / nx as f64;
        b.patch(
            [x, 0.0, 0.0],
            [0.0, ly, 0.0],
            [0.0, 0.0, lz],
            (ny, nz),
            2,
            "baffles",
        );
    }
    // Inlet and outlet tubes: four walls each, on the end plates' grid.
    let side = 0.06;
    let (j0, k0) = (
        ((ly - side) / 2.0 / ly * ny as f64).round() as usize,
        ((lz - side) / 2.0 / lz * nz as f64).round() as usize,
    );
    let (j1, k1) = (
        ((ly + side) / 2.0 / ly * ny as f64).round() as usize,
        ((lz + side) / 2.0 / lz * nz as f64).round() as usize,
    );
    let (y0, y1) = (ly * j0 as f64 / ny as f64, ly * j1 as f64 / ny as f64);
    let (z0, z1) = (lz * k0 as f64 / nz as f64, lz * k1 as f64 / nz as f64);
    let nl = b.divisions(0.1);
    let (nyt, nzt) = ((j1 - j0).max(1), (k1 - k0).max(1));
    for (x, dir) in [(0.0, -0.1), (lx, 0.1)] {
        b.patch(
            [x, y0, z0],
            [dir, 0.0, 0.0],
            [0.0, y1 - y0, 0.0],
            (nl, nyt),
            3,
            "tubes",
        );
        b.patch(
            [x, y0, z1],
            [dir, 0.0, 0.0],
            [0.0, y1 - y0, 0.0],
            (nl, nyt),
            3,
            "tubes",
        );
        b.patch(
            [x, y0, z0],
            [dir, 0.0, 0.0],
            [0.0, 0.0, z1 - z0],
            (nl, nzt),
            3,
            "tubes",
        );
        b.patch(
            [x, y1, z0],
            [dir, 0.0, 0.0],
            [0.0, 0.0, z1 - z0],
            (nl, nzt),
            3,
            "tubes",
        );
    }
    for ids in b.model.sets.values_mut() {
        ids.sort_unstable();
    }
    b.model
}

/// Element size giving about `dofs` DOFs for the muffler with `baffles` baffles (area-based).
pub fn muffler_element_size(dofs: usize, baffles: usize) -> f64 {
    let (lx, ly, lz) = (0.8, 0.3, 0.2);
    let area =
        2.0 * (lx * ly + lx * lz + ly * lz) + baffles as f64 * ly * lz + 2.0 * 4.0 * 0.06 * 0.1;
    (6.0 * area / dofs as f64).sqrt()
}

/// Element size giving about `dofs` DOFs for the three-plate two-beam assembly.
pub fn three_plate_element_size(dofs: usize) -> f64 {
    (6.0 * 3.0 * 1.2 * 0.6 / dofs as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
    use crate::fe::element::MassKind;
    use crate::fe::model_assembly::assemble_model;

    #[test]
    fn muffler_is_closed_free_free_and_sized_as_asked() {
        let h = muffler_element_size(8000, 2);
        let m = muffler(h, 2);
        m.validate().unwrap();
        let n = m.n_dofs();
        assert!((6000..11000).contains(&n), "{n} DOFs");
        let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
        let (modes, _) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(9),
            &SparseEigenParams::default(),
        )
        .unwrap();
        assert_eq!(modes.rigid_body_modes, 6, "one connected free body");
        assert!(modes.residuals.iter().all(|r| *r < 1e-8));
    }

    #[test]
    fn three_plates_are_held_together_by_the_columns() {
        let m = three_plate_two_beam(three_plate_element_size(6000));
        m.validate().unwrap();
        let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
        let (modes, _) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(8),
            &SparseEigenParams::default(),
        )
        .unwrap();
        assert_eq!(modes.rigid_body_modes, 6, "one connected free body");
    }
}
