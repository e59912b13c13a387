//! Composite and offset shell cards: PCOMP, PCOMPG, MAT2, MAT8, and the THETA/MCID and ZOFFS
//! fields of CQUAD4, CTRIA3, CQUADR and CTRIAR (their other fields are read in `elements.rs`).
//! The lamination theory is `crate::fe::laminate`.

use super::*;
use crate::model::laminates::{Laminate, LaminateTerms, Ply, ShellMaterial, ShellPlacement};

/// An element's material axis as the card gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum AxisIn {
    /// THETA, degrees.
    Theta(f64),
    /// MCID.
    Mcid(u64),
}

/// What the laminate cards have read.
#[derive(Default)]
pub(super) struct LaminatesIn {
    /// MAT2 and MAT8 by id.
    pub(super) materials: BTreeMap<u64, (Loc, ShellMaterial)>,
    /// THETA/MCID and ZOFFS by element id (only elements that give one).
    pub(super) placements: BTreeMap<u64, (Loc, usize, AxisIn, f64)>,
    /// Deviations stated once per deck.
    pub(super) shear_blank_warned: bool,
    pub(super) mat2_shear_warned: bool,
    pub(super) drilling_warned: bool,
}

impl Builder {
    /// MAT8 (QRG): `MID E1 E2 NU12 G12 G1Z G2Z RHO`; the strengths, expansion coefficients, TREF
    /// and GE are not used by a modal analysis. G1Z/G2Z blank mean, to Nastran, no transverse
    /// shear flexibility; femu's shells are Mindlin plates and use G12 for them, with a warning
    /// (as for a PSHELL with MID3 blank).
    pub(super) fn mat8(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "MID")?;
        let e1 = c.positive(2, "E1")?;
        let e2 = c.positive(3, "E2")?;
        let nu12 = c.req_real(4, "NU12")?;
        if !(nu12 * nu12 < e1 / e2) {
            return Err(c.err(
                4,
                "NU12",
                format!("NU12 = {nu12} with E1 = {e1}, E2 = {e2} gives a stiffness that is not positive definite"),
                "NU12^2 < E1/E2 (a physically admissible orthotropic ply)",
            ));
        }
        let g12 = c.positive(5, "G12")?;
        let g1z = c.real(6, "G1Z")?;
        let g2z = c.real(7, "G2Z")?;
        for (k, label, v) in [(6, "G1Z", g1z), (7, "G2Z", g2z)] {
            if let Some(v) = v.filter(|v| *v <= 0.0) {
                return Err(c.err(
                    k,
                    label,
                    format!("{v} is not positive"),
                    "a real number > 0, or blank",
                ));
            }
        }
        if (g1z.is_none() || g2z.is_none()) && !self.laminates.shear_blank_warned {
            self.laminates.shear_blank_warned = true;
            self.warn(
                &c.loc,
                id,
                format!("G1Z or G2Z is blank (Nastran: no transverse shear flexibility); femu's shells keep Mindlin shear and use G12 = {g12} for it, which lowers thin-plate frequencies by O((T/wavelength)^2); the same holds for every later MAT8 with G1Z/G2Z blank"),
            );
        }
        let rho = c.nonneg_real(8, "RHO", 0.0)?;
        self.new_shell_material(
            c,
            id,
            ShellMaterial::Orthotropic {
                e1,
                e2,
                nu12,
                g12,
                g1z: g1z.unwrap_or(g12),
                g2z: g2z.unwrap_or(g12),
                rho,
            },
        )
    }

    /// MAT2 (QRG): `MID G11 G12 G13 G22 G23 G33 RHO`, the plane-stress matrix over
    /// `(ε1, ε2, γ12)`; the expansion coefficients, TREF, GE, allowables and MCSID are not used.
    pub(super) fn mat2(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "MID")?;
        let labels = ["G11", "G12", "G13", "G22", "G23", "G33"];
        let mut g = [0.0; 6];
        for (i, label) in labels.iter().enumerate() {
            g[i] = c.real_or(2 + i, label, 0.0)?;
        }
        let m = crate::fe::laminate::PlyMaterial::Anisotropic {
            g: [[g[0], g[1], g[2]], [g[1], g[3], g[4]], [g[2], g[4], g[5]]],
            shear: [g[5].max(f64::MIN_POSITIVE), g[5].max(f64::MIN_POSITIVE)],
        };
        if m.validate().is_err() {
            return Err(c.err(
                2,
                "G11",
                format!("G = {g:?} is not positive definite"),
                "a positive definite plane-stress matrix G11 ... G33 (femu's shells need positive stiffness)",
            ));
        }
        let rho = c.nonneg_real(8, "RHO", 0.0)?;
        self.new_shell_material(c, id, ShellMaterial::Anisotropic { g, rho })
    }

    fn new_shell_material(
        &mut self,
        c: &Card,
        id: u64,
        m: ShellMaterial,
    ) -> Result<(), NastranError> {
        let first = self
            .materials
            .get(&id)
            .map(|x| x.0.clone())
            .or_else(|| self.laminates.materials.get(&id).map(|x| x.0.clone()));
        if let Some(first) = first {
            return Err(duplicate(c, 1, "MID", "material", id, &first));
        }
        self.laminates.materials.insert(id, (c.loc.clone(), m));
        Ok(())
    }

    /// PCOMP and PCOMPG (QRG): `PID Z0 NSM SB FT TREF GE LAM`, then plies bottom to top — PCOMP
    /// four fields each (`MIDi Ti THETAi SOUTi`, blank MIDi/Ti repeat the previous ply's), PCOMPG
    /// one line each (`GPLYIDi MIDi Ti THETAi SOUTi`). LAM blank or SYM (plies mirrored), MEM
    /// (membrane terms only), BEND (bending terms only), SMEAR (stacking sequence ignored; see
    /// [`LaminateTerms`]), SMCORE (smeared faces about the last ply, the core; Z0 must be
    /// blank or −T/2); other words are errors. Z0 blank: −T/2. SB, FT, TREF and
    /// SOUT are stress-recovery data and not used; GE ≠ 0 (structural damping) is not applied,
    /// with a warning.
    pub(super) fn pcomp(&mut self, c: &Card) -> Result<(), NastranError> {
        let global = c.name == "PCOMPG";
        let id = c.id(1, "PID")?;
        let z0 = c.real(2, "Z0")?;
        let nsm = c.nonneg_real(3, "NSM", 0.0)?;
        c.real(4, "SB")?;
        c.real(6, "TREF")?;
        if let Some(ge) = c.real(7, "GE")?.filter(|g| *g != 0.0) {
            self.warn(
                &c.loc,
                id,
                format!("GE = {ge} (structural damping) is not applied: femu's model has no element damping; give damping in the FRF stage"),
            );
        }
        let lam = c.word(8);
        let (symmetric, terms) = match lam.as_str() {
            "" => (false, LaminateTerms::All),
            "SYM" => (true, LaminateTerms::All),
            "MEM" => (false, LaminateTerms::Membrane),
            "BEND" => (false, LaminateTerms::Bending),
            "SMEAR" => (false, LaminateTerms::Smeared),
            "SMCORE" => (false, LaminateTerms::SmearedCore),
            other => {
                return Err(c.err(
                    8,
                    "LAM",
                    format!("LAM = {other} is not supported"),
                    "blank (all plies given), SYM (plies mirrored about the middle), MEM (membrane terms only), BEND (bending terms only), SMEAR (stacking sequence ignored) or SMCORE (smeared face sheets about the last ply, the core)",
                ));
            }
        };
        if terms == LaminateTerms::Smeared {
            self.warn(
                &c.loc,
                id,
                "LAM = SMEAR: Nastran's derived shell has no MID3 (no transverse shear flexibility); femu keeps the laminate's transverse shear 5/6 Σ G t (an O((T/wavelength)²) effect on frequencies)",
            );
        }
        let mut plies = Vec::new();
        let mut global_ids = Vec::new();
        let (mut last_mid, mut last_t): (Option<u64>, Option<f64>) = (None, None);
        let step = if global { 8 } else { 4 };
        let mut next = 9;
        while next <= c.fields.len() {
            let k0 = next;
            next += step;
            // `k` is the ply's MID field; a PCOMPG line starts with GPLYID before it.
            let k = if global { k0 + 1 } else { k0 };
            if (k0..k + 4).all(|j| c.blank(j)) {
                continue;
            }
            if global {
                let g = c.id(k - 1, "GPLYID")?;
                if global_ids.contains(&g) {
                    return Err(c.err(
                        k - 1,
                        "GPLYID",
                        format!("global ply id {g} appears twice"),
                        "the global ply ids of a PCOMPG must be distinct",
                    ));
                }
                global_ids.push(g);
                for j in k + 4..k + 7 {
                    if !c.blank(j) {
                        return Err(c.err(
                            j,
                            "PCOMPG",
                            format!("`{}` after SOUT", q(c.text(j))),
                            "one ply per line: GPLYID MID T THETA SOUT (the DS/NRPT and EXPLICIT lines are not read)",
                        ));
                    }
                }
            }
            let mid = match c.int(k, "MIDi")? {
                None => last_mid,
                Some(m) if m > 0 => Some(m as u64),
                Some(m) => {
                    return Err(c.err(
                        k,
                        "MIDi",
                        format!("{m} is not a material id"),
                        "a MAT1, MAT2 or MAT8 id (integer > 0)",
                    ));
                }
            };
            let Some(mid) = mid else {
                return Err(c.err(
                    k,
                    "MID1",
                    "the first ply's material is blank",
                    "MID1 is required (later blank MIDi repeat the previous one)",
                ));
            };
            let t = match c.real(k + 1, "Ti")? {
                None => last_t,
                Some(t) if t > 0.0 => Some(t),
                Some(t) => {
                    return Err(c.err(
                        k + 1,
                        "Ti",
                        format!("ply thickness {t} is not positive"),
                        "a real number > 0 (blank: the previous ply's)",
                    ));
                }
            };
            let Some(t) = t else {
                return Err(c.err(
                    k + 1,
                    "T1",
                    "the first ply's thickness is blank",
                    "T1 > 0 is required (later blank Ti repeat the previous one)",
                ));
            };
            let theta = c.real_or(k + 2, "THETAi", 0.0)?;
            let sout = c.word(k + 3);
            if !matches!(sout.as_str(), "" | "YES" | "NO") {
                return Err(c.err(
                    k + 3,
                    "SOUTi",
                    format!("`{}` is not YES or NO", q(&sout)),
                    "YES, NO or blank",
                ));
            }
            (last_mid, last_t) = (Some(mid), Some(t));
            plies.push(Ply {
                material: mid,
                thickness: t,
                theta_deg: theta,
            });
        }
        if plies.is_empty() {
            return Err(c.err(
                9,
                "MID1",
                "the laminate has no ply",
                "at least one ply: MID1 T1 THETA1 SOUT1 on the continuation",
            ));
        }
        if terms == LaminateTerms::SmearedCore {
            // QRG PCOMP remarks 13 and 17: faces, then the core; the core's middle surface is
            // the reference plane, and a Z0 that moves it is a fatal error.
            if plies.len() < 2 {
                return Err(c.err(
                    9,
                    "MID1",
                    "LAM = SMCORE with a single ply",
                    "the face sheet plies, then the core as the last ply",
                ));
            }
            let t: f64 = plies.iter().map(|p| p.thickness).sum();
            if let Some(z) = z0.filter(|z| (z + 0.5 * t).abs() > 1e-9 * t) {
                return Err(c.err(
                    2,
                    "Z0",
                    format!("Z0 = {z} with LAM = SMCORE, whose reference plane is the core's middle surface (Z0 = {})", -0.5 * t),
                    "Z0 blank (or -T/2); offset the element with ZOFFS instead",
                ));
            }
        }
        let lam = Laminate {
            plies,
            z0,
            symmetric,
            global_ids,
            terms,
        };
        self.new_property(c, 1, "PID", id)?;
        let mut p = ShellProperty::homogeneous(lam.plies[0].material, lam.thickness(), nsm);
        p.laminate = Some(lam);
        self.shells.insert(id, p);
        Ok(())
    }

    /// THETA/MCID and ZOFFS of a shell element card (fields `k`, `k + 1`): an integer is MCID
    /// (the coordinate system's x axis projected on the element), a real THETA (degrees from
    /// the G1→G2 edge); ZOFFS the reference plane's offset along the element normal. Blank, 0.0
    /// and 0.0 are none. CQUADR/CTRIAR are read as CQUAD4/CTRIA3 with a warning once per deck.
    pub(super) fn shell_placement(
        &mut self,
        c: &Card,
        id: u64,
        k: usize,
    ) -> Result<(), NastranError> {
        let axis = if c.blank(k) {
            AxisIn::Theta(0.0)
        } else if parse_int(c.text(k)).is_some() {
            match c.int(k, "MCID")? {
                Some(m) if m >= 0 => AxisIn::Mcid(m as u64),
                m => {
                    return Err(c.err(
                        k,
                        "MCID",
                        format!("MCID {} is negative", m.unwrap_or(0)),
                        "an integer >= 0 (a coordinate system id) or a real THETA",
                    ));
                }
            }
        } else {
            let theta = c.req_real(k, "THETA")?;
            if !theta.is_finite() {
                return Err(c.err(k, "THETA", "THETA is not finite", "a real angle in degrees"));
            }
            AxisIn::Theta(theta)
        };
        let zoffs = c.real_or(k + 1, "ZOFFS", 0.0)?;
        if !zoffs.is_finite() {
            return Err(c.err(k + 1, "ZOFFS", "ZOFFS is not finite", "a real offset"));
        }
        if matches!(c.name.as_str(), "CQUADR" | "CTRIAR") && !self.laminates.drilling_warned {
            self.laminates.drilling_warned = true;
            self.warn(
                &c.loc,
                id,
                format!("{} is formed as femu's {} (MITC plate, QM6/CST membrane and a drilling penalty, docs/theory.md), not Nastran's drilling-DOF formulation: in-plane results differ at the level of the formulation; the same holds for every later CQUADR/CTRIAR", c.name, if c.name == "CQUADR" { "quad4" } else { "tria3" }),
            );
        }
        if axis != AxisIn::Theta(0.0) || zoffs != 0.0 {
            self.laminates
                .placements
                .insert(id, (c.loc.clone(), k, axis, zoffs));
        }
        Ok(())
    }

    /// The basic position of a shell element's centre (the mean of its corner grids), if it is
    /// a shell whose grids are all placed.
    fn shell_centre(&self, model: &Model, eid: u64) -> Option<[f64; 3]> {
        let corners: &[u64] = match self.elements.get(&eid)? {
            (_, ElemIn::Done(Element::Quad4 { nodes, .. })) => nodes,
            (_, ElemIn::Done(Element::Tria3 { nodes, .. })) => nodes,
            (_, ElemIn::Done(Element::Quad8 { corners, .. })) => corners,
            (_, ElemIn::Done(Element::Tria6 { corners, .. })) => corners,
            _ => return None,
        };
        let mut c = [0.0; 3];
        for g in corners {
            let x = model.nodes.get(g)?;
            for (ci, xi) in c.iter_mut().zip(x) {
                *ci += xi / corners.len() as f64;
            }
        }
        Some(c)
    }

    /// Moves the MAT2/MAT8 materials and the element placements into `model` (MCID resolved to
    /// a basic direction: a rectangular system's x axis, a cylindrical or spherical system's r
    /// axis at the element centre), applies WTMASS to their densities, and states the MAT2
    /// transverse shear deviation.
    pub(super) fn finish_laminates(
        &mut self,
        model: &mut Model,
        geo: &Geometry,
    ) -> Result<(), NastranError> {
        let w = self.wtmass.as_ref().map_or(1.0, |(_, w)| *w);
        let materials = std::mem::take(&mut self.laminates.materials);
        for (id, (loc, mut m)) in materials.clone() {
            if let Some((first, _)) = self.materials.get(&id) {
                return Err(loc.field_err(
                    1,
                    "MID",
                    format!(
                        "material {id} is also defined by the MAT1 at {}",
                        first.place()
                    ),
                    "one material card per id",
                ));
            }
            *m.rho_mut() *= w;
            model.shell_materials.insert(id, m);
        }
        // MAT2 as a ply or a transverse shear material: its transverse shear moduli are G33.
        let mut noted = None;
        for (pid, p) in &model.shell_properties {
            let shear_mids: Vec<u64> = match &p.laminate {
                Some(l) => l.plies.iter().map(|q| q.material).collect(),
                None if p.bending => vec![p.shear_mid()],
                None => Vec::new(),
            };
            if let Some(mid) = shear_mids.into_iter().find(|m| {
                matches!(
                    model.shell_materials.get(m),
                    Some(ShellMaterial::Anisotropic { .. })
                )
            }) {
                noted.get_or_insert((*pid, mid));
            }
        }
        if let (Some((pid, mid)), false) = (noted, self.laminates.mat2_shear_warned) {
            self.laminates.mat2_shear_warned = true;
            let loc = materials[&mid].0.clone();
            self.warn(
                &loc,
                mid,
                format!("MAT2 has no transverse shear moduli; as the transverse shear material of property {pid} (and every other such use) femu takes G33 for G1Z and G2Z"),
            );
        }
        for (eid, (loc, k, axis, zoffs)) in std::mem::take(&mut self.laminates.placements) {
            let mut pl = ShellPlacement {
                offset: zoffs,
                ..Default::default()
            };
            match axis {
                AxisIn::Theta(t) => pl.theta_deg = t,
                AxisIn::Mcid(0) => pl.axis = Some([1.0, 0.0, 0.0]),
                AxisIn::Mcid(m) => {
                    let Some(f) = geo.frames.get(&m) else {
                        return Err(loc.field_err(
                            k,
                            "MCID",
                            format!("coordinate system {m} is not defined"),
                            "a CORD1R/CORD2R id (or 0 for basic), or a real THETA",
                        ));
                    };
                    pl.axis = Some(if f.kind == CordKind::Rectangular {
                        f.axes[0]
                    } else {
                        // QRG (CQUAD4, MCID): a cylindrical or spherical system's r axis is
                        // projected through the element centre, the mean of its corners.
                        let centre = self.shell_centre(model, eid).ok_or_else(|| {
                            loc.field_err(
                                k,
                                "MCID",
                                format!("element {eid} has an undefined grid, so the r axis of coordinate system {m} cannot be evaluated at its centre"),
                                "every grid of the element defined by a GRID card",
                            )
                        })?;
                        f.directions_at(centre)[0]
                    });
                }
            }
            if !pl.is_default() {
                model.shell_placements.insert(eid, pl);
            }
        }
        Ok(())
    }
}
