//! Coordinate systems and grid points: CORD1R/C/S and CORD2R/C/S (nested to any depth, the
//! CORD1 ones defined by grid points that may themselves be placed in other systems), GRID
//! positions in their CP system, GRDSET defaults, and the displacement directions of a grid's
//! CD system (QRG, "Coordinate Systems"; cylindrical `(R, θ°, Z)`, spherical `(R, θ°, φ°)`).

use super::*;

/// The three kinds of Nastran coordinate system.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum CordKind {
    /// `R`: (X, Y, Z).
    Rectangular,
    /// `C`: (R, θ, Z), θ in degrees from the x axis about z.
    Cylindrical,
    /// `S`: (R, θ, φ), θ in degrees from the z axis, φ in degrees from the x axis about z.
    Spherical,
}

impl CordKind {
    /// The kind named by the card's last letter (`CORD2C` → cylindrical).
    pub(super) fn of_card(name: &str) -> Self {
        match name.as_bytes().last() {
            Some(b'C') => CordKind::Cylindrical,
            Some(b'S') => CordKind::Spherical,
            _ => CordKind::Rectangular,
        }
    }
}

/// How a coordinate system is defined.
pub(super) enum CordDef {
    /// CORD2x: points A (origin), B (on z) and C (in the x–z plane) in system `rid`.
    Points {
        /// Reference system (0: basic).
        rid: u64,
        /// A, B, C.
        points: [[f64; 3]; 3],
    },
    /// CORD1x: grid points G1 (origin), G2 (on z) and G3 (in the x–z plane), at data fields
    /// `first..first+3`.
    Grids {
        /// G1, G2, G3.
        grids: [u64; 3],
        /// Data field index of G1 (for messages).
        first: usize,
    },
}

/// A coordinate system card as read.
pub(super) struct CordIn {
    pub(super) loc: Loc,
    pub(super) kind: CordKind,
    pub(super) def: CordDef,
}

/// A grid point as read; `None` fields are blank and take the GRDSET default.
pub(super) struct GridIn {
    pub(super) loc: Loc,
    pub(super) cp: Option<u64>,
    pub(super) x: [f64; 3],
    pub(super) cd: Option<u64>,
    pub(super) ps: Option<Vec<Component>>,
}

/// GRDSET defaults for blank GRID fields.
pub(super) struct GridDefaults {
    pub(super) loc: Loc,
    pub(super) cp: Option<u64>,
    pub(super) cd: Option<u64>,
    pub(super) ps: Option<Vec<Component>>,
}

/// A coordinate system: origin and unit axes (rows) in the basic system, and its kind.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frame {
    pub(super) origin: [f64; 3],
    pub(super) axes: [[f64; 3]; 3],
    pub(super) kind: CordKind,
}

impl Frame {
    pub(super) const BASIC: Frame = Frame {
        origin: [0.0; 3],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        kind: CordKind::Rectangular,
    };

    /// Rectangular components along the frame's axes of the point with coordinates `p`.
    fn local_rectangular(self, p: [f64; 3]) -> [f64; 3] {
        match self.kind {
            CordKind::Rectangular => p,
            CordKind::Cylindrical => {
                let t = p[1].to_radians();
                [p[0] * t.cos(), p[0] * t.sin(), p[2]]
            }
            CordKind::Spherical => {
                let (t, f) = (p[1].to_radians(), p[2].to_radians());
                [
                    p[0] * t.sin() * f.cos(),
                    p[0] * t.sin() * f.sin(),
                    p[0] * t.cos(),
                ]
            }
        }
    }

    /// The basic vector with components `v` along the frame's axes.
    fn rotate_to_basic(self, v: [f64; 3]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (i, o) in out.iter_mut().enumerate() {
            *o = v[0] * self.axes[0][i] + v[1] * self.axes[1][i] + v[2] * self.axes[2][i];
        }
        out
    }

    /// The basic position of the point with coordinates `p` in this system.
    pub(super) fn to_basic(self, p: [f64; 3]) -> [f64; 3] {
        let v = self.rotate_to_basic(self.local_rectangular(p));
        [
            self.origin[0] + v[0],
            self.origin[1] + v[1],
            self.origin[2] + v[2],
        ]
    }

    /// Unit vectors (rows, in the basic system) of the displacement components 1, 2, 3 at the
    /// basic point `x`: the axes for a rectangular system, `(e_R, e_θ, e_Z)` for a cylindrical
    /// and `(e_R, e_θ, e_φ)` for a spherical one. On the polar axis, where θ or φ is undefined,
    /// the angle is taken as 0, as Nastran does.
    pub(super) fn directions_at(self, x: [f64; 3]) -> [[f64; 3]; 3] {
        let d = sub(x, self.origin);
        let q = [
            dot(d, self.axes[0]),
            dot(d, self.axes[1]),
            dot(d, self.axes[2]),
        ];
        let local = match self.kind {
            CordKind::Rectangular => return self.axes,
            CordKind::Cylindrical => {
                let t = q[1].atan2(q[0]);
                let (s, c) = if q[0] == 0.0 && q[1] == 0.0 {
                    (0.0, 1.0)
                } else {
                    t.sin_cos()
                };
                [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]
            }
            CordKind::Spherical => {
                let rho = q[0].hypot(q[1]);
                let (sf, cf) = if rho == 0.0 {
                    (0.0, 1.0)
                } else {
                    (q[1] / rho, q[0] / rho)
                };
                let r = norm(q);
                let (st, ct) = if r == 0.0 {
                    (0.0, 1.0)
                } else {
                    (rho / r, q[2] / r)
                };
                [
                    [st * cf, st * sf, ct],
                    [ct * cf, ct * sf, -st],
                    [-sf, cf, 0.0],
                ]
            }
        };
        local.map(|v| self.rotate_to_basic(v))
    }

    /// The frame with origin `a`, z axis towards `b` and x–z plane through `c` (all basic).
    fn from_points(
        a: [f64; 3],
        b: [f64; 3],
        c: [f64; 3],
        kind: CordKind,
    ) -> Result<Self, &'static str> {
        let z = sub(b, a);
        let lz = norm(z);
        if lz == 0.0 || !lz.is_finite() {
            return Err("the point on the z axis coincides with the origin");
        }
        let z = scale(z, 1.0 / lz);
        let t = sub(c, a);
        let x = sub(t, scale(z, dot(t, z)));
        let lx = norm(x);
        if lx <= 1e-12 * norm(t) || lx == 0.0 {
            return Err("the point in the x-z plane lies on the z axis");
        }
        let x = scale(x, 1.0 / lx);
        Ok(Frame {
            origin: a,
            axes: [x, cross(z, x), z],
            kind,
        })
    }
}

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

pub(super) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `Σ v_i d_i`: a vector given by components along the directions `d` (rows), in basic.
pub(super) fn combine(d: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (i, o) in out.iter_mut().enumerate() {
        *o = v[0] * d[0][i] + v[1] * d[1][i] + v[2] * d[2][i];
    }
    out
}

/// Where every grid point is and every coordinate system lies, in the basic system.
#[derive(Default)]
pub(super) struct Geometry {
    pub(super) frames: BTreeMap<u64, Frame>,
    pub(super) positions: BTreeMap<u64, [f64; 3]>,
}

/// Something whose basic position or frame is needed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Need {
    Cord(u64),
    Grid(u64),
}

impl Builder {
    pub(super) fn grid(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "ID")?;
        let cp = c.int(2, "CP")?;
        let x = [
            c.real_or(3, "X1", 0.0)?,
            c.real_or(4, "X2", 0.0)?,
            c.real_or(5, "X3", 0.0)?,
        ];
        let cd = c.int(6, "CD")?;
        let ps = if c.blank(7) {
            None
        } else {
            Some(c.comps(7, "PS")?)
        };
        let cp = match cp {
            None => None,
            Some(v) if v >= 0 => Some(v as u64),
            Some(v) => {
                return Err(c.err(
                    2,
                    "CP",
                    format!("{v} is negative"),
                    "0, blank or a coordinate system id",
                ));
            }
        };
        let cd = match cd {
            None => None,
            Some(v) if v >= 0 => Some(v as u64),
            Some(-1) => {
                return Err(c.err(
                    6,
                    "CD",
                    "CD -1 makes the grid a fluid point of a hydroelastic model",
                    "0, blank or a coordinate system id (femu has no fluid elements)",
                ));
            }
            Some(v) => {
                return Err(c.err(
                    6,
                    "CD",
                    format!("{v} is negative"),
                    "0, blank or a coordinate system id",
                ));
            }
        };
        if let Some(first) = self.grids.get(&id) {
            return Err(duplicate(c, 1, "ID", "grid", id, &first.loc));
        }
        self.grids.insert(
            id,
            GridIn {
                loc: c.loc.clone(),
                cp,
                x,
                cd,
                ps,
            },
        );
        Ok(())
    }

    /// GRDSET: defaults for the CP, CD and PS fields of every GRID that leaves them blank.
    pub(super) fn grdset(&mut self, c: &Card) -> Result<(), NastranError> {
        let cp = c.int(2, "CP")?;
        let cd = c.int(6, "CD")?;
        let ps = if c.blank(7) {
            None
        } else {
            Some(c.comps(7, "PS")?)
        };
        if let Some(first) = &self.grdset {
            return Err(c.err(
                1,
                "GRDSET",
                format!("a second GRDSET (the first is at {})", first.loc.place()),
                "at most one GRDSET card per deck",
            ));
        }
        let nonneg = |v: Option<i64>, k: usize, label: &str| match v {
            None => Ok(None),
            Some(v) if v >= 0 => Ok(Some(v as u64)),
            Some(v) => Err(c.err(
                k,
                label,
                format!("{v} is negative"),
                "0, blank or a coordinate system id",
            )),
        };
        self.grdset = Some(GridDefaults {
            loc: c.loc.clone(),
            cp: nonneg(cp, 2, "CP")?,
            cd: nonneg(cd, 6, "CD")?,
            ps,
        });
        Ok(())
    }

    /// CORD2R, CORD2C, CORD2S.
    pub(super) fn cord2(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "CID")?;
        let rid = c.nonneg(2, "RID", "0 or a coordinate system id")?;
        let labels = ["A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3"];
        let mut points = [[0.0; 3]; 3];
        for (j, label) in labels.iter().enumerate() {
            points[j / 3][j % 3] = c.real_or(3 + j, label, 0.0)?;
        }
        self.new_cord(c, 1, id, CordDef::Points { rid, points })
    }

    /// CORD1R, CORD1C, CORD1S: one or two systems per card, each from three grid points.
    pub(super) fn cord1(&mut self, c: &Card) -> Result<(), NastranError> {
        for (half, suffix) in [(0, "A"), (4, "B")] {
            if half == 4 && (1..=4).all(|j| c.blank(half + j)) {
                break;
            }
            let id = c.id(half + 1, &format!("CID{suffix}"))?;
            let mut grids = [0; 3];
            for (j, g) in grids.iter_mut().enumerate() {
                *g = c.id(half + 2 + j, &format!("G{}{suffix}", j + 1))?;
            }
            if grids[0] == grids[1] || grids[0] == grids[2] || grids[1] == grids[2] {
                return Err(c.err(
                    half + 2,
                    &format!("G1{suffix}"),
                    format!("grids {grids:?} are not three distinct points"),
                    "three distinct grid points: origin, a point on z, a point in the x-z plane",
                ));
            }
            let first = half + 2;
            self.new_cord(c, half + 1, id, CordDef::Grids { grids, first })?;
        }
        Ok(())
    }

    fn new_cord(&mut self, c: &Card, k: usize, id: u64, def: CordDef) -> Result<(), NastranError> {
        if let Some(first) = self.cords.get(&id) {
            return Err(duplicate(c, k, "CID", "coordinate system", id, &first.loc));
        }
        let kind = CordKind::of_card(&c.name);
        self.cords.insert(
            id,
            CordIn {
                loc: c.loc.clone(),
                kind,
                def,
            },
        );
        Ok(())
    }

    /// The CP of a grid with the GRDSET default applied.
    pub(super) fn grid_cp(&self, g: &GridIn) -> u64 {
        g.cp.or_else(|| self.grdset.as_ref().and_then(|d| d.cp))
            .unwrap_or(0)
    }

    /// The CD of a grid with the GRDSET default applied.
    pub(super) fn grid_cd(&self, g: &GridIn) -> u64 {
        g.cd.or_else(|| self.grdset.as_ref().and_then(|d| d.cd))
            .unwrap_or(0)
    }

    /// Grid `g`'s CD (GRDSET default applied) and, unless it is the basic system, the unit
    /// vectors of its displacement components 1–3 (rows, in basic) at the grid.
    pub(super) fn grid_directions(&self, geo: &Geometry, g: u64) -> (u64, Option<[[f64; 3]; 3]>) {
        let cd = self.grids.get(&g).map_or(0, |grid| self.grid_cd(grid));
        if cd == 0 {
            return (0, None);
        }
        let dirs = geo
            .frames
            .get(&cd)
            .zip(geo.positions.get(&g))
            .map(|(frame, x)| frame.directions_at(*x));
        (cd, dirs)
    }

    /// The PS of a grid with the GRDSET default applied.
    pub(super) fn grid_ps<'a>(&'a self, g: &'a GridIn) -> &'a [Component] {
        g.ps.as_deref()
            .or_else(|| self.grdset.as_ref().and_then(|d| d.ps.as_deref()))
            .unwrap_or(&[])
    }

    /// Places every grid and coordinate system in the basic system, following CP, RID and
    /// CORD1 grid references in dependency order (depth first, without recursion); a
    /// reference to nothing or a cycle is an error at the card that makes it.
    pub(super) fn geometry(&self) -> Result<Geometry, NastranError> {
        let mut geo = Geometry::default();
        for (&id, g) in &self.grids {
            if self.grid_cp(g) == 0 {
                geo.positions.insert(id, g.x);
            }
        }
        let starts = self
            .grids
            .keys()
            .map(|&g| Need::Grid(g))
            .chain(self.cords.keys().map(|&c| Need::Cord(c)));
        let mut on_stack: BTreeSet<(bool, u64)> = BTreeSet::new();
        for start in starts {
            let mut stack = vec![start];
            while let Some(&need) = stack.last() {
                if self.is_placed(&geo, need) {
                    stack.pop();
                    continue;
                }
                let missing: Vec<Need> = self
                    .needs(need)?
                    .into_iter()
                    .filter(|n| !self.is_placed(&geo, *n))
                    .collect();
                if missing.is_empty() {
                    self.place(&mut geo, need)?;
                    on_stack.remove(&key(need));
                    stack.pop();
                    continue;
                }
                if !on_stack.insert(key(need)) {
                    return Err(self.cycle_error(need));
                }
                for m in missing {
                    if on_stack.contains(&key(m)) {
                        return Err(self.cycle_error(m));
                    }
                    stack.push(m);
                }
            }
        }
        Ok(geo)
    }

    fn is_placed(&self, geo: &Geometry, need: Need) -> bool {
        match need {
            Need::Cord(c) => geo.frames.contains_key(&c),
            Need::Grid(g) => geo.positions.contains_key(&g),
        }
    }

    /// What `need` depends on; an error when that is not defined.
    fn needs(&self, need: Need) -> Result<Vec<Need>, NastranError> {
        match need {
            Need::Grid(g) => {
                let grid = &self.grids[&g];
                let cp = self.grid_cp(grid);
                if !self.cords.contains_key(&cp) {
                    let (loc, k) = match grid.cp {
                        Some(_) => (&grid.loc, 2),
                        None => (self.grdset.as_ref().map_or(&grid.loc, |d| &d.loc), 2),
                    };
                    return Err(loc.field_err(
                        k,
                        "CP",
                        format!("coordinate system {cp} is not defined in the deck"),
                        "0 (basic) or the id of a CORD1R/C/S or CORD2R/C/S card",
                    ));
                }
                Ok(vec![Need::Cord(cp)])
            }
            Need::Cord(cid) => {
                let cord = self.cords.get(&cid).ok_or_else(|| NastranError::Syntax {
                    file: self.top_file.to_string().into(),
                    line: 0,
                    problem: format!("coordinate system {cid} is not defined").into(),
                    valid: "define it with a CORD1R/C/S or CORD2R/C/S card".into(),
                })?;
                match &cord.def {
                    CordDef::Points { rid: 0, .. } => Ok(Vec::new()),
                    CordDef::Points { rid, .. } => {
                        if !self.cords.contains_key(rid) {
                            return Err(cord.loc.field_err(
                                2,
                                "RID",
                                format!("reference system {rid} is not defined in the deck"),
                                "0 (basic) or the id of a CORD1R/C/S or CORD2R/C/S card",
                            ));
                        }
                        Ok(vec![Need::Cord(*rid)])
                    }
                    CordDef::Grids { grids, first } => {
                        for (j, g) in grids.iter().enumerate() {
                            if !self.grids.contains_key(g) {
                                return Err(cord.loc.field_err(
                                    first + j,
                                    &format!("G{}", j + 1),
                                    format!("grid {g} is not defined in the deck"),
                                    "the id of a GRID card",
                                ));
                            }
                        }
                        Ok(grids.iter().map(|&g| Need::Grid(g)).collect())
                    }
                }
            }
        }
    }

    /// Places `need`, whose dependencies are placed.
    fn place(&self, geo: &mut Geometry, need: Need) -> Result<(), NastranError> {
        match need {
            Need::Grid(g) => {
                let grid = &self.grids[&g];
                let x = geo.frames[&self.grid_cp(grid)].to_basic(grid.x);
                geo.positions.insert(g, x);
            }
            Need::Cord(cid) => {
                let cord = &self.cords[&cid];
                let ([a, b, c], (k, label)) = match &cord.def {
                    CordDef::Points { rid, points } => {
                        let parent = if *rid == 0 {
                            Frame::BASIC
                        } else {
                            geo.frames[rid]
                        };
                        (points.map(|p| parent.to_basic(p)), (6, "B1"))
                    }
                    CordDef::Grids { grids, first } => {
                        (grids.map(|g| geo.positions[&g]), (first + 1, "G2"))
                    }
                };
                let frame = Frame::from_points(a, b, c, cord.kind).map_err(|problem| {
                    cord.loc.field_err(
                        k,
                        label,
                        problem,
                        "three points that define an origin, a z axis and an x-z plane",
                    )
                })?;
                geo.frames.insert(cid, frame);
            }
        }
        Ok(())
    }

    fn cycle_error(&self, need: Need) -> NastranError {
        match need {
            Need::Grid(g) => {
                let grid = &self.grids[&g];
                grid.loc.field_err(
                    2,
                    "CP",
                    format!("grid {g} is placed in a coordinate system that is defined through grid {g} itself"),
                    "break the cycle of CP, RID and CORD1 grid references",
                )
            }
            Need::Cord(cid) => self.cords[&cid].loc.field_err(
                1,
                "CID",
                format!(
                    "coordinate system {cid} depends on itself through RID or its defining grids"
                ),
                "a chain of references must end in the basic system",
            ),
        }
    }
}

fn key(need: Need) -> (bool, u64) {
    match need {
        Need::Cord(c) => (true, c),
        Need::Grid(g) => (false, g),
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{error, parse};
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= 1e-12 * (1.0 + b[i].abs()))
    }

    #[test]
    fn cylindrical_and_spherical_points_and_directions() {
        let f = Frame {
            origin: [1.0, 2.0, 3.0],
            axes: Frame::BASIC.axes,
            kind: CordKind::Cylindrical,
        };
        let x = f.to_basic([2.0, 90.0, 5.0]);
        assert!(close(x, [1.0, 4.0, 8.0]), "{x:?}");
        let d = f.directions_at(x);
        assert!(close(d[0], [0.0, 1.0, 0.0]) && close(d[1], [-1.0, 0.0, 0.0]));
        let s = Frame {
            kind: CordKind::Spherical,
            ..Frame::BASIC
        };
        // θ = 90° (equator), φ = 0: on +x; e_θ points to −z, e_φ to +y.
        let x = s.to_basic([3.0, 90.0, 0.0]);
        assert!(close(x, [3.0, 0.0, 0.0]), "{x:?}");
        let d = s.directions_at(x);
        assert!(
            close(d[0], [1.0, 0.0, 0.0])
                && close(d[1], [0.0, 0.0, -1.0])
                && close(d[2], [0.0, 1.0, 0.0])
        );
        // Each set of directions is orthonormal and right-handed.
        for p in [[1.0, 30.0, 40.0], [2.0, 150.0, -70.0]] {
            let d = s.directions_at(s.to_basic(p));
            assert!((dot(cross(d[0], d[1]), d[2]) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn nested_cord2_and_cord1_place_grids() {
        // System 1: cylindrical about basic z through (1,0,0). System 2: rectangular, defined in
        // system 1: origin at R=1, θ=90° (basic (1,1,0)), z along basic z, C at system 1's
        // origin, so x = basic −y and y = basic +x. System 3: CORD1R on grids of system 2.
        let deck = "\
CORD2C,1,0,1.,0.,0.,1.,0.,1.,+C1
+C1,2.,0.,0.
CORD2R,2,1,1.,90.,0.,1.,90.,1.,+C2
+C2,0.,90.,0.
GRID,10,2,0.,0.,0.
GRID,11,2,0.,0.,1.
GRID,12,2,1.,0.,0.
CORD1R,3,10,11,12
GRID,20,3,0.,1.,0.
GRID,21,1,2.,0.,0.
CONM2,1,20,,1.
";
        let b = parse(deck);
        let n = &b.model.nodes;
        assert!(close(n[&10], [1.0, 1.0, 0.0]), "{:?}", n[&10]);
        assert!(close(n[&11], [1.0, 1.0, 1.0]), "{:?}", n[&11]);
        assert!(close(n[&12], [1.0, 0.0, 0.0]), "{:?}", n[&12]);
        assert!(close(n[&20], [2.0, 1.0, 0.0]), "{:?}", n[&20]);
        assert!(close(n[&21], [3.0, 0.0, 0.0]), "{:?}", n[&21]);
    }

    #[test]
    fn grdset_supplies_blank_cp_and_ps() {
        let deck = "\
GRDSET,,5,,,,,6
CORD2R,5,0,0.,0.,1.,0.,0.,2.,+C
+C,1.,0.,1.
GRID,1,,0.,0.,0.
GRID,2,0,1.,0.,0.,,345
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
CQUAD4,1,1,1,2,3,4
PSHELL,1,1,.01
MAT1,1,7.e10,,.3,2700.
";
        let b = parse(deck);
        assert!(close(b.model.nodes[&1], [0.0, 0.0, 1.0]));
        assert!(
            close(b.model.nodes[&2], [1.0, 0.0, 0.0]),
            "explicit CP 0 wins"
        );
        let c = &b.model.constraints;
        assert!(
            c.contains(&DofId::new(1, Component::Rz)) && !c.contains(&DofId::new(1, Component::Uz))
        );
        assert!(
            c.contains(&DofId::new(2, Component::Uz)) && !c.contains(&DofId::new(2, Component::Rz))
        );
    }

    #[test]
    fn undefined_references_and_cycles_name_the_card() {
        let base = "CQUAD4,1,1,1,2,3,4\nPSHELL,1,1,.01\nMAT1,1,7.e10,,.3,2700.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n";
        let e = error(&format!("GRID,1,7,0.,0.,0.\n{base}"));
        assert!(
            e.contains("t.bdf line 1: GRID field 3 (CP)") && e.contains("system 7 is not defined"),
            "{e}"
        );
        let e = error(&format!(
            "CORD2R,7,8,0.,0.,0.,0.,0.,1.\n,1.\nGRID,1,7,0.,0.,0.\n{base}"
        ));
        assert!(
            e.contains("CORD2R field 3 (RID)") && e.contains("8 is not defined"),
            "{e}"
        );
        // System 5 is defined by grid 1, which is placed in system 5.
        let e = error(&format!("CORD1R,5,1,2,3\nGRID,1,5,0.,0.,0.\n{base}"));
        assert!(e.contains("itself"), "{e}");
        let e = error(&format!("CORD1R,5,2,2,3\nGRID,1,,0.,0.,0.\n{base}"));
        assert!(e.contains("not three distinct points"), "{e}");
    }

    /// System 5: rectangular, rotated 90° about basic z (x' = basic y, y' = −basic x).
    /// System 6: rectangular, rotated 45° about basic z.
    const SYSTEMS: &str = "\
CORD2R,5,0,0.,0.,0.,0.,0.,1.,+A
+A,0.,1.,0.
CORD2R,6,0,0.,0.,0.,0.,0.,1.,+B
+B,1.,1.,0.
";
    const PLATE: &str = "\
CQUAD4,1,1,1,2,3,4
PSHELL,1,1,.01
MAT1,1,7.e10,,.3,2700.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
";

    #[test]
    fn constraints_and_springs_in_the_displacement_system() {
        // PS 145 and the spring's component 2 are components of system 5 at grid 1: the
        // model's DOFs there are along system 5's axes (x' = basic y, y' = −basic x).
        let b = parse(&format!(
            "{SYSTEMS}{PLATE}GRID,1,,0.,0.,0.,5,145\nCELAS2,9,1.+3,1,2\n"
        ));
        let c: Vec<String> = b
            .model
            .constraints
            .iter()
            .map(|d| format!("{}:{}", d.node, d.comp.name()))
            .collect();
        assert_eq!(c, ["1:ux", "1:rx", "1:ry"]);
        let r = b.model.displacement_systems[&1];
        assert!(
            close(r[0], [0.0, 1.0, 0.0]) && close(r[1], [-1.0, 0.0, 0.0]),
            "{r:?}"
        );
        let Element::ScalarSpring { dof, .. } = &b.model.elements[&9] else {
            panic!("{:?}", b.model.elements[&9]);
        };
        assert_eq!(
            *dof,
            DofId::new(1, Component::Uy),
            "component 2 of system 5"
        );
        // In the 45° system a single component is a constraint like any other.
        let b = parse(&format!("{SYSTEMS}{PLATE}GRID,1,,0.,0.,0.,6,1\n"));
        assert_eq!(b.model.constraints, [DofId::new(1, Component::Ux)]);
        // A grid whose CD axes are the basic ones has no displacement system.
        let b = parse(&format!(
            "{PLATE}CORD2R,8,0,5.,0.,0.,5.,0.,1.\n,6.,0.,0.\nGRID,1,,0.,0.,0.,8\n"
        ));
        assert!(b.model.displacement_systems.is_empty());
        let e = error(&format!("{PLATE}GRID,1,,0.,0.,0.,8\n"));
        assert!(
            e.contains("GRID field 7 (CD)") && e.contains("system 8 is not defined"),
            "{e}"
        );
    }

    #[test]
    fn bar_orientation_and_conm2_in_a_coordinate_system() {
        // CBAR X1–X3 are in the displacement system of GA: (1,0,0) in system 5 is basic +y.
        let b = parse(&format!(
            "{SYSTEMS}{PLATE}GRID,1,,0.,0.,0.,5\nGRID,7,,0.,0.,1.\nCBAR,2,20,1,7,1.,0.,0.\nPBAR,20,1,1.-4,1.-8,1.-8,1.-8\nCONM2,3,2,5,2.,1.,0.,0.,,+M\n+M,3.,.5,4.,0.,0.,5.\n"
        ));
        let Element::Beam { orientation, .. } = &b.model.elements[&2] else {
            panic!()
        };
        assert!(close(*orientation, [0.0, 1.0, 0.0]), "{orientation:?}");
        let Element::Mass {
            offset,
            inertia,
            mass,
            ..
        } = &b.model.elements[&3]
        else {
            panic!()
        };
        assert_eq!(*mass, 2.0);
        assert!(close(*offset, [0.0, 1.0, 0.0]), "{offset:?}");
        // J' = [[3, -.5, 0], [-.5, 4, 0], [0, 0, 5]] along (y, -x, z): J_basic = [[4, .5, 0],
        // [.5, 3, 0], [0, 0, 5]], that is I11 = 4, I21 = -.5, I22 = 3.
        let want = [4.0, -0.5, 3.0, 0.0, 0.0, 5.0];
        assert!(
            inertia.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{inertia:?}"
        );
    }
}
