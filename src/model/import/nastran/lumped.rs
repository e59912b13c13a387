//! Springs, bushes and masses: PELAS, CBUSH with PBUSH, CONM2 (CELASi are read in
//! `scalars.rs`).

use super::*;

impl Builder {
    pub(super) fn pelas_card(&mut self, c: &Card) -> Result<(), NastranError> {
        for off in [0, 4] {
            if off == 4 && c.blank(5) {
                break;
            }
            let label = if off == 0 { "PID1" } else { "PID2" };
            let id = c.id(1 + off, label)?;
            let label_k = if off == 0 { "K1" } else { "K2" };
            if c.blank(2 + off) {
                return Err(c.err(2 + off, label_k, "the field is blank", "a stiffness >= 0"));
            }
            let k = c.nonneg_real(2 + off, label_k, 0.0)?;
            if c.real_or(3 + off, "GE", 0.0)? != 0.0 {
                self.warn(&c.loc, id, "damping GE is ignored");
            }
            c.real(4 + off, "S")?;
            self.new_property(c, 1 + off, label, id)?;
            self.pelas.insert(id, k);
        }
        Ok(())
    }

    pub(super) fn cbush(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let pid = c.id_or(2, "PID", id)?;
        let node = c.id(3, "GA")?;
        let other = c.opt_grid(4, "GB")?;
        if other == Some(node) {
            return Err(c.err(
                4,
                "GB",
                format!("GB is GA ({node})"),
                "a different grid, or blank for ground",
            ));
        }
        let orient = Self::orientation(c, 5)?;
        let cid = c.int(8, "CID")?;
        if let Some(v) = cid.filter(|v| *v < -1) {
            return Err(c.err(
                8,
                "CID",
                format!("{v} is not a coordinate system id"),
                "blank, 0 or a system id",
            ));
        }
        let system = match (cid, orient) {
            (Some(v), _) if v >= 0 => super::scalars::BushSystem::Cid(v as u64),
            (_, Some(o)) => super::scalars::BushSystem::Orient(o),
            _ => {
                self.warn(
                    &c.loc,
                    id,
                    "CID and the orientation vector are blank: the element axes are taken as the basic axes",
                );
                super::scalars::BushSystem::None
            }
        };
        if c.real(9, "S")?.is_some()
            || c.int(10, "OCID")?.is_some()
            || (11..14).any(|k| !c.blank(k))
        {
            for k in 11..14 {
                c.real(k, "Si")?;
            }
            self.warn(
                &c.loc,
                id,
                "the spring location (S, OCID, S1-S3) is ignored",
            );
        }
        self.new_element(
            c,
            id,
            ElemIn::Scalar(super::scalars::ScalarIn::Bush {
                pid,
                node,
                other,
                system,
            }),
        )
    }

    pub(super) fn pbush_card(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let rows = c.fields.len().div_ceil(8).max(1);
        let mut k = None;
        let mut b = None;
        let mut ignored = BTreeSet::new();
        for r in 0..rows {
            let kf = 2 + 8 * r;
            let flag = c.word(kf);
            let values: Vec<usize> = (kf + 1..kf + 7).collect();
            if flag.is_empty() {
                if let Some(&j) = values.iter().find(|&&j| !c.blank(j)) {
                    return Err(c.err(
                        j,
                        "value",
                        "a value follows a blank flag field",
                        "each PBUSH line starts with a flag: K, B, GE, RCV or M",
                    ));
                }
                continue;
            }
            if flag == "K" {
                let mut kv = [0.0; 6];
                for (i, &j) in values.iter().enumerate() {
                    kv[i] = c.nonneg_real(j, &format!("K{}", i + 1), 0.0)?;
                }
                k = Some(kv);
            } else if flag == "B" {
                let mut bv = [0.0; 6];
                for (i, &j) in values.iter().enumerate() {
                    bv[i] = c.nonneg_real(j, &format!("B{}", i + 1), 0.0)?;
                }
                b = Some(bv);
            } else if parse_real(&flag).is_some() {
                return Err(c.err(
                    kf,
                    "flag",
                    format!("`{}` is a number", q(&flag)),
                    "a flag: K, B, GE, RCV or M",
                ));
            } else if values.iter().any(|&j| !c.blank(j)) {
                ignored.insert(flag);
            }
        }
        self.new_property(c, 1, "PID", id)?;
        if !ignored.is_empty() {
            let list: Vec<String> = ignored.into_iter().collect();
            self.warn(
                &c.loc,
                id,
                format!(
                    "the {} line(s) are ignored (stiffness K and damping B only)",
                    list.join(", ")
                ),
            );
        }
        let k = match k {
            Some(k) => k,
            None => {
                self.warn(&c.loc, id, "no K line: the bush has zero stiffness");
                [0.0; 6]
            }
        };
        self.pbush.insert(id, k);
        if let Some(b) = b {
            self.scalars.pbush_b.insert(id, b);
        }
        Ok(())
    }

    pub(super) fn conm2(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let node = c.id(2, "G")?;
        let cid = c.int(3, "CID")?.unwrap_or(0);
        let mass = c.nonneg_real(4, "M", 0.0)?;
        let x = [
            c.real_or(5, "X1", 0.0)?,
            c.real_or(6, "X2", 0.0)?,
            c.real_or(7, "X3", 0.0)?,
        ];
        let mut inertia = [0.0; 6];
        for (i, label) in ["I11", "I21", "I22", "I31", "I32", "I33"]
            .iter()
            .enumerate()
        {
            inertia[i] = c.real_or(9 + i, label, 0.0)?;
        }
        let e = match cid {
            0 => ElemIn::Done(Element::Mass {
                node,
                mass,
                inertia,
                offset: x,
            }),
            -1 => ElemIn::MassAbsolute {
                node,
                mass,
                inertia,
                cg: x,
            },
            cid if cid > 0 => ElemIn::MassInSystem {
                node,
                mass,
                inertia,
                offset: x,
                cid: cid as u64,
            },
            _ => {
                return Err(c.err(
                    3,
                    "CID",
                    format!("{cid} is not a coordinate system"),
                    "0 (basic), -1 (X1-X3 are the basic coordinates of the centre of gravity) or a coordinate system id",
                ));
            }
        };
        self.new_element(c, id, e)
    }
}
