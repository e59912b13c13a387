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
//!
//! Each carries its simulated measurement points as grid points with fixed ids below
//! [`FIRST_MESH_NODE`] (`101..122`, `201..222`, `301..322` on the three plates; `1..10` on the
//! muffler), placed at fixed fractions of their panels and snapped to the mesh, so a pipeline
//! names the same measured DOFs at every mesh density. Every other grid point is numbered from
//! [`FIRST_MESH_NODE`]. Panels are also split into named zones (updating parameters that
//! localise an error without one parameter per element).

use super::steel;
use crate::model::{BeamProperty, BeamSection, Element, Model, ShellProperty};
use std::collections::HashMap;

/// A rectangular panel: set name, origin, edge vectors `u`, `v`, divisions, and its
/// measurement points `(id, s, t)` at fractions of `u` and `v`.
type Panel<'a> = (
    &'a str,
    [f64; 3],
    [f64; 3],
    [f64; 3],
    (usize, usize),
    &'a [(u64, f64, f64)],
);

/// Id of the first grid point that is not a measurement point.
pub const FIRST_MESH_NODE: u64 = 1001;

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
            next_node: FIRST_MESH_NODE,
            next_element: 1,
            h,
        }
    }

    fn key(&self, x: [f64; 3]) -> [i64; 3] {
        x.map(|c| (c / self.h * 1e3).round() as i64)
    }

    fn node(&mut self, x: [f64; 3]) -> u64 {
        let key = self.key(x);
        if let Some(&id) = self.by_position.get(&key) {
            return id;
        }
        let id = self.next_node;
        self.next_node += 1;
        self.model.nodes.insert(id, x);
        self.by_position.insert(key, id);
        id
    }

    /// The measurement point `id` at the grid vertex of the patch `origin + s·u + t·v`
    /// (`nu × nv` quads) nearest to the fractions `(s, t)`, created before the patch so the
    /// patch shares it. Two points on one vertex would keep the first id: the generators'
    /// least divisions keep their points apart (tested at every density).
    fn sensor(
        &mut self,
        id: u64,
        origin: [f64; 3],
        (u, v): ([f64; 3], [f64; 3]),
        (nu, nv): (usize, usize),
        (s, t): (f64, f64),
    ) {
        let (i, j) = ((s * nu as f64).round(), (t * nv as f64).round());
        let (s, t) = (i / nu as f64, j / nv as f64);
        let x = [0, 1, 2].map(|c| origin[c] + s * u[c] + t * v[c]);
        let key = self.key(x);
        if self.by_position.contains_key(&key) {
            return;
        }
        self.model.nodes.insert(id, x);
        self.by_position.insert(key, id);
    }

    /// A rectangular patch `origin + s·u + t·v`, `s, t ∈ [0, 1]`, `nu × nv` quads, into `set`;
    /// returns the new elements' ids.
    fn patch(
        &mut self,
        origin: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        (nu, nv): (usize, usize),
        property: u64,
        set: &str,
    ) -> Vec<u64> {
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
            .extend(elements.iter().copied());
        elements
    }

    /// Puts `elements` (of a patch `nu × nv`, in the patch's order) into the zone sets
    /// `{prefix}_zone_{1..}` of a `zu × zv` split, numbered along `u` first.
    fn zones(
        &mut self,
        elements: &[u64],
        (nu, nv): (usize, usize),
        (zu, zv): (usize, usize),
        prefix: &str,
    ) {
        for (n, &e) in elements.iter().enumerate() {
            let (i, j) = (n / nv, n % nv);
            let (a, b) = ((i * zu) / nu, (j * zv) / nv);
            let zone = b * zu + a + 1;
            self.model
                .sets
                .entry(format!("{prefix}_zone_{zone}"))
                .or_default()
                .push(e);
        }
    }

    fn divisions(&self, length: f64) -> usize {
        ((length / self.h).round() as usize).max(1)
    }
}

/// Three 1.2 m × 0.6 m plates (3 mm, 2 mm, 3 mm) stacked 0.3 m apart along z, held by two
/// 40 mm square beam columns at opposite corners, element size `h` (at least 12 × 6 shells a
/// plate). Sets: `plate_1..3`, each split into six zones `plate_k_zone_1..6` (3 along x × 2
/// along y, numbered along x first), and `columns`. Measurement points `100k + 1 ..= 100k + 22`
/// on plate `k`: a 6 × 4 grid at the cell centres of the plate (fractions `(i + ½)/6`,
/// `(j + ½)/4`, numbered along x first) without the two cells at the columns' corners, 66 in
/// all (the S123 benchmark's count). About `3 · 6 · (1.2/h)(0.6/h)` DOFs (1M DOFs at
/// `h ≈ 1.4 mm`).
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
            taper: None,
            centres: None,
        },
    );
    let (lx, ly, gap) = (1.2, 0.6, 0.3);
    let (nx, ny) = (b.divisions(lx).max(12), b.divisions(ly).max(6));
    let (u, v) = ([lx, 0.0, 0.0], [0.0, ly, 0.0]);
    for k in 0..3u64 {
        let origin = [0.0, 0.0, gap * k as f64];
        let mut id = 100 * (k + 1);
        for j in 0..4 {
            for i in 0..6 {
                if (i, j) == (0, 0) || (i, j) == (5, 3) {
                    continue;
                }
                id += 1;
                let at = ((i as f64 + 0.5) / 6.0, (j as f64 + 0.5) / 4.0);
                b.sensor(id, origin, (u, v), (nx, ny), at);
            }
        }
        let set = format!("plate_{}", k + 1);
        let elements = b.patch(origin, u, v, (nx, ny), k + 1, &set);
        b.zones(&elements, (nx, ny), (3, 2), &set);
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
/// element size `h` (at least 16 × 6 × 4 shells across the box). Free-free. Sets: `shell`
/// (the skin) and its six panels `bottom`, `top` (z = 0, 0.2 m), `side_1`, `side_2` (y = 0,
/// 0.3 m), `end_1`, `end_2` (x = 0, 0.8 m); `baffles` and each `baffle_1..`; `tubes`.
/// Measurement points `1..=10`: four on the top, three on `side_1`, two on the bottom, one on
/// `end_2` beside the outlet, at fixed fractions of their panels.
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
    let (nx, ny, nz) = (
        b.divisions(lx).max(16),
        b.divisions(ly).max(6),
        b.divisions(lz).max(4),
    );
    let (ex, ey, ez) = ([lx, 0.0, 0.0], [0.0, ly, 0.0], [0.0, 0.0, lz]);
    // Outer skin: six panels `(name, origin, u, v, divisions, measurement points)`.
    let panels: [Panel; 6] = [
        (
            "bottom",
            [0.0; 3],
            ex,
            ey,
            (nx, ny),
            &[(8, 0.3, 0.6), (9, 0.65, 0.35)],
        ),
        (
            "top",
            [0.0, 0.0, lz],
            ex,
            ey,
            (nx, ny),
            &[(1, 0.2, 0.3), (2, 0.45, 0.7), (3, 0.7, 0.3), (4, 0.9, 0.6)],
        ),
        (
            "side_1",
            [0.0; 3],
            ex,
            ez,
            (nx, nz),
            &[(5, 0.15, 0.5), (6, 0.5, 0.25), (7, 0.85, 0.75)],
        ),
        ("side_2", [0.0, ly, 0.0], ex, ez, (nx, nz), &[]),
        ("end_1", [0.0; 3], ey, ez, (ny, nz), &[]),
        ("end_2", [lx, 0.0, 0.0], ey, ez, (ny, nz), &[(10, 0.2, 0.8)]),
    ];
    for (name, origin, u, v, n, points) in panels {
        for &(id, s, t) in points {
            b.sensor(id, origin, (u, v), n, (s, t));
        }
        let elements = b.patch(origin, u, v, n, 1, name);
        b.model
            .sets
            .entry("shell".into())
            .or_default()
            .extend(elements);
    }
    // Baffles at equal spacing, snapped to the grid so they share the skin's nodes.
    for k in 1..=baffles {
        let i = (nx * k) / (baffles + 1);
        let x = lx * i as f64 / nx as f64;
        let elements = b.patch([x, 0.0, 0.0], ey, ez, (ny, nz), 2, "baffles");
        b.model.sets.insert(format!("baffle_{k}"), elements);
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

    /// Every measurement point exists with its id at every density, on its panel, and the
    /// zones split each plate into six equal parts.
    #[test]
    fn measurement_points_and_zones_hold_at_every_density() {
        for dofs in [500, 6_000, 40_000] {
            let m = three_plate_two_beam(three_plate_element_size(dofs));
            for k in 1..=3u64 {
                for s in 1..=22 {
                    let x = m.nodes[&(100 * k + s)];
                    assert!(
                        (x[2] - 0.3 * (k - 1) as f64).abs() < 1e-12,
                        "{dofs}: {}",
                        100 * k + s
                    );
                    assert!(x[0] > 0.0 && x[0] < 1.2 && x[1] > 0.0 && x[1] < 0.6);
                }
                assert!(!m.nodes.contains_key(&(100 * k + 23)));
                let plate = &m.sets[&format!("plate_{k}")];
                let mut zoned: Vec<u64> = (1..=6)
                    .flat_map(|z| m.sets[&format!("plate_{k}_zone_{z}")].clone())
                    .collect();
                zoned.sort_unstable();
                assert_eq!(&zoned, plate, "zones partition plate {k}");
                let sizes: Vec<usize> = (1..=6)
                    .map(|z| m.sets[&format!("plate_{k}_zone_{z}")].len())
                    .collect();
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(
                    *hi as f64 <= 1.5 * *lo as f64,
                    "{dofs}: zone sizes {sizes:?}"
                );
            }
            assert!(m.nodes.keys().filter(|&&id| id < FIRST_MESH_NODE).count() == 66);
        }
        for dofs in [500, 8_000] {
            let m = muffler(muffler_element_size(dofs, 2), 2);
            let on = |id: u64, c: usize, v: f64| (m.nodes[&id][c] - v).abs() < 1e-12;
            assert!((1..=4).all(|id| on(id, 2, 0.2)), "top");
            assert!((5..=7).all(|id| on(id, 1, 0.0)), "side_1");
            assert!((8..=9).all(|id| on(id, 2, 0.0)), "bottom");
            assert!(on(10, 0, 0.8), "end_2");
            assert_eq!(
                m.nodes.keys().filter(|&&id| id < FIRST_MESH_NODE).count(),
                10
            );
            let panels: usize = ["bottom", "top", "side_1", "side_2", "end_1", "end_2"]
                .iter()
                .map(|p| m.sets[*p].len())
                .sum();
            assert_eq!(panels, m.sets["shell"].len());
            assert_eq!(
                m.sets["baffle_1"].len() + m.sets["baffle_2"].len(),
                m.sets["baffles"].len()
            );
        }
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
