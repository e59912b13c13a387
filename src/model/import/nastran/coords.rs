//! Coordinate systems: CORD2R frames (RID chains resolved) and GRID positions.

use super::*;

/// A rectangular frame: origin and unit axes (rows) in the basic system.
#[derive(Clone, Copy)]
pub(super) struct Frame {
    pub(super) origin: [f64; 3],
    pub(super) axes: [[f64; 3]; 3],
}

impl Frame {
    const BASIC: Frame = Frame {
        origin: [0.0; 3],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    pub(super) fn to_basic(self, p: [f64; 3]) -> [f64; 3] {
        let mut out = self.origin;
        for (i, o) in out.iter_mut().enumerate() {
            *o += p[0] * self.axes[0][i] + p[1] * self.axes[1][i] + p[2] * self.axes[2][i];
        }
        out
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

impl Builder {
    pub(super) fn grid(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "ID")?;
        let cp = c.nonneg(2, "CP", "0 or a coordinate system id")?;
        let x = [
            c.real_or(3, "X1", 0.0)?,
            c.real_or(4, "X2", 0.0)?,
            c.real_or(5, "X3", 0.0)?,
        ];
        let cd = c.int(6, "CD")?.unwrap_or(0);
        let ps = c.comps(7, "PS")?;
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

    pub(super) fn cord2r(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "CID")?;
        let rid = c.nonneg(2, "RID", "0 or a CORD2R id")?;
        let labels = ["A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3"];
        let mut points = [[0.0; 3]; 3];
        for (j, label) in labels.iter().enumerate() {
            points[j / 3][j % 3] = c.real_or(3 + j, label, 0.0)?;
        }
        if let Some(first) = self.cords.get(&id) {
            return Err(duplicate(c, 1, "CID", "coordinate system", id, &first.loc));
        }
        self.cords.insert(
            id,
            CordIn {
                loc: c.loc.clone(),
                rid,
                points,
            },
        );
        Ok(())
    }

    /// Frames of every CORD2R, resolving RID chains without recursion.
    pub(super) fn frames(&self) -> Result<BTreeMap<u64, Frame>, NastranError> {
        let mut done: BTreeMap<u64, Frame> = BTreeMap::new();
        for &start in self.cords.keys() {
            let mut chain = vec![start];
            loop {
                let cord = &self.cords[chain.last().unwrap_or(&start)];
                let rid = cord.rid;
                if rid == 0 || done.contains_key(&rid) {
                    break;
                }
                if chain.contains(&rid) {
                    return Err(cord.loc.field_err(
                        2,
                        "RID",
                        format!("RID {rid} closes a cycle of coordinate systems"),
                        "a chain of RIDs must end in 0 (basic)",
                    ));
                }
                if !self.cords.contains_key(&rid) {
                    return Err(cord.loc.field_err(
                        2,
                        "RID",
                        format!("RID {rid} is not a CORD2R"),
                        "0 (basic) or the id of a CORD2R card (other coordinate system cards are not supported)",
                    ));
                }
                chain.push(rid);
            }
            for &cid in chain.iter().rev() {
                if done.contains_key(&cid) {
                    continue;
                }
                let cord = &self.cords[&cid];
                let parent = if cord.rid == 0 {
                    Frame::BASIC
                } else {
                    done[&cord.rid]
                };
                let [a, b, cc] = cord.points.map(|p| parent.to_basic(p));
                let z = sub(b, a);
                let lz = norm(z);
                if lz == 0.0 || !lz.is_finite() {
                    return Err(cord.loc.field_err(
                        6,
                        "B1",
                        "point B coincides with A",
                        "B must lie on the z axis, away from the origin A",
                    ));
                }
                let z = scale(z, 1.0 / lz);
                let t = sub(cc, a);
                let x = sub(t, scale(z, dot(t, z)));
                let lx = norm(x);
                if lx <= 1e-12 * norm(t) || lx == 0.0 {
                    return Err(cord.loc.field_err(
                        9,
                        "C1",
                        "point C lies on the z axis through A and B",
                        "C must lie in the x-z plane, off the z axis",
                    ));
                }
                let x = scale(x, 1.0 / lx);
                let y = cross(z, x);
                done.insert(
                    cid,
                    Frame {
                        origin: a,
                        axes: [x, y, z],
                    },
                );
            }
        }
        Ok(done)
    }
}
