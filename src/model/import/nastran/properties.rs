//! Property and material cards: PSHELL, PBAR, PBEAM, MAT1 (PBARL and PBEAML: `sections.rs`).

use super::*;
use crate::model::structure::five_sixths;

impl Builder {
    /// PSHELL with the QRG's meaning: MID1 the membrane material (blank: no membrane), MID2 the
    /// bending material (blank: membrane only — no bending, transverse shear or rotary inertia),
    /// MID3 the transverse shear material, 12I/T³ scaling the bending stiffness, TS/T the shear
    /// thickness ratio, MID4 the membrane–bending coupling (`B = T² G4`); each MID may be a MAT1,
    /// MAT2 or MAT8 (the general law of `fe::laminate`); Z1/Z2 (stress recovery) are ignored.
    /// The mass uses MID1's density (MID2's when MID1 is blank).
    pub(super) fn pshell(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let mid = |k: usize, label: &str| -> Result<Option<u64>, NastranError> {
            match c.int(k, label)? {
                None | Some(0) => Ok(None),
                Some(m) if m > 0 => Ok(Some(m as u64)),
                Some(m) => Err(c.err(
                    k,
                    label,
                    format!("{m} is not a material id"),
                    if label == "MID2" {
                        "a MAT1, MAT2 or MAT8 id (integer > 0) or blank; MID2 = -1 (plane strain) is not supported"
                    } else {
                        "a MAT1, MAT2 or MAT8 id (integer > 0) or blank"
                    },
                )),
            }
        };
        let mid1 = mid(2, "MID1")?;
        let thickness = c.positive(3, "T")?;
        let mid2 = mid(4, "MID2")?;
        let bending_ratio = c.real_or(5, "12I/T**3", 1.0)?;
        if bending_ratio <= 0.0 {
            return Err(c.err(
                5,
                "12I/T**3",
                format!("{bending_ratio} is not positive"),
                "a real number > 0 (blank: 1.0, a solid plate)",
            ));
        }
        let mid3 = mid(6, "MID3")?;
        let shear_ratio = c.real_or(7, "TS/T", five_sixths())?;
        if shear_ratio <= 0.0 {
            return Err(c.err(
                7,
                "TS/T",
                format!("{shear_ratio} is not positive"),
                "a real number > 0 (blank: 0.833333)",
            ));
        }
        // Nastran's default written with six digits means 5/6.
        let shear_ratio = if (shear_ratio - five_sixths()).abs() <= 1e-6 {
            five_sixths()
        } else {
            shear_ratio
        };
        let nsm = c.nonneg_real(8, "NSM", 0.0)?;
        c.real(9, "Z1")?;
        c.real(10, "Z2")?;
        let mid4 = mid(11, "MID4")?;
        let Some(material) = mid1.or(mid2) else {
            return Err(c.err(
                2,
                "MID1",
                "MID1 and MID2 are both blank (a shell without membrane or bending)",
                "a MAT1 id in MID1 (membrane), MID2 (bending) or both",
            ));
        };
        if let (Some(m3), None) = (mid3, mid2) {
            return Err(c.err(
                6,
                "MID3",
                format!("MID3 {m3} is given without MID2"),
                "MID3 must be blank unless MID2 is given (QRG PSHELL)",
            ));
        }
        self.new_property(c, 1, "PID", id)?;
        let mut p = ShellProperty::homogeneous(material, thickness, nsm);
        p.coupling_material = mid4;
        p.membrane = mid1.is_some();
        match mid2 {
            None => p.bending = false,
            Some(m2) => {
                p.bending_material = (m2 != material).then_some(m2);
                p.bending_ratio = bending_ratio;
                p.shear_ratio = shear_ratio;
                let m3 = match mid3 {
                    Some(m3) => m3,
                    None => {
                        if !self.mid3_blank_warned {
                            self.mid3_blank_warned = true;
                            self.warn(
                                &c.loc,
                                id,
                                format!("MID3 is blank (Nastran: no transverse shear flexibility); femu's shell keeps Mindlin shear with MID2 {m2}'s G and TS/T = {shear_ratio}, which lowers thin-plate frequencies by O((T/wavelength)^2), about 5e-4 at T/span = 0.01; the same holds for every later PSHELL with MID3 blank"),
                            );
                        }
                        m2
                    }
                };
                p.shear_material = (m3 != m2).then_some(m3);
            }
        }
        self.shells.insert(id, p);
        Ok(())
    }

    pub(super) fn pbar(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let area = c.positive(3, "A")?;
        let i1 = c.positive(4, "I1")?;
        let i2 = c.positive(5, "I2")?;
        let j = c.nonneg_real(6, "J", 0.0)?;
        let nsm = c.nonneg_real(7, "NSM", 0.0)?;
        for (i, label) in ["C1", "C2", "D1", "D2", "E1", "E2", "F1", "F2"]
            .iter()
            .enumerate()
        {
            c.real(9 + i, label)?;
        }
        let k1 = c.nonneg_real(17, "K1", 0.0)?;
        let k2 = c.nonneg_real(18, "K2", 0.0)?;
        c.zero(
            19,
            "I12",
            "a product of inertia is not supported: give I1 and I2 about the principal axes and orient the bar along them",
        )?;
        self.new_property(c, 1, "PID", id)?;
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section: BeamSection::General {
                    area,
                    iy: i2,
                    iz: i1,
                    j,
                    shear_y: k1,
                    shear_z: k2,
                },
                nsm,
                taper: None,
                centres: None,
            },
        );
        Ok(())
    }

    pub(super) fn pbeam(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let labels = ["A", "I1", "I2", "I12", "J", "NSM"];
        let mut end_a = [0.0; 6];
        for (i, label) in labels.iter().enumerate() {
            end_a[i] = c.real_or(3 + i, &format!("{label}(A)"), 0.0)?;
        }
        for (i, label) in [(0, "A(A)"), (1, "I1(A)"), (2, "I2(A)")] {
            if end_a[i] <= 0.0 {
                return Err(c.err(
                    3 + i,
                    label,
                    if c.blank(3 + i) {
                        "the field is blank".to_string()
                    } else {
                        format!("{} is not positive", end_a[i])
                    },
                    "a real number > 0 (femu's beam needs a positive area and second moments)",
                ));
            }
        }
        for (i, label) in [(4, "J(A)"), (5, "NSM(A)")] {
            c.nonneg_real(3 + i, label, 0.0)?;
        }
        if end_a[3] != 0.0 {
            return Err(c.err(
                6,
                "I12(A)",
                format!("product of inertia {} is not supported", end_a[3]),
                "give I1 and I2 about the principal axes and orient the beam along them",
            ));
        }
        let mut stations: Vec<(usize, f64, [Option<f64>; 6])> = Vec::new();
        let rows = c.fields.len().div_ceil(8);
        let mut r = 1;
        let mut tail = 0;
        let (mut k1, mut k2) = (1.0, 1.0);
        let (mut nsi, mut nsm_cg, mut neutral) = (0.0, [0.0; 2], [0.0; 2]);
        while r < rows {
            let k0 = 1 + 8 * r;
            let so = c.word(k0);
            let is_station = parse_real(&so).is_none() && !so.is_empty();
            if is_station {
                if !matches!(so.as_str(), "YES" | "YESA" | "NO") {
                    return Err(c.err(
                        k0,
                        "SO",
                        format!("`{}` is not a stress output flag", q(&so)),
                        "YES, YESA or NO",
                    ));
                }
                let Some(x) = c.real(k0 + 1, "X/XB")? else {
                    return Err(c.err(
                        k0 + 1,
                        "X/XB",
                        "the field is blank",
                        "the station's distance from end A over the length, 0 < X/XB <= 1",
                    ));
                };
                let mut given = [None; 6];
                for (i, label) in labels.iter().enumerate() {
                    given[i] = c.real(k0 + 2 + i, label)?;
                }
                stations.push((k0, x, given));
                r += if so == "YES" { 2 } else { 1 };
                continue;
            }
            if r == 1 {
                for i in 0..8 {
                    c.real(k0 + i, "stress point")?;
                }
            } else if tail == 0 {
                k1 = c.nonneg_real(k0, "K1", 1.0)?;
                k2 = c.nonneg_real(k0 + 1, "K2", 1.0)?;
                c.real(k0 + 2, "S1")?;
                c.real(k0 + 3, "S2")?;
                nsi = end_pair(c, k0 + 4, "NSI")?;
                if nsi < 0.0 {
                    return Err(c.err(
                        k0 + 4,
                        "NSI(A)",
                        format!("{nsi} is negative"),
                        "a mass moment of inertia per length >= 0",
                    ));
                }
                let mut warping = false;
                for (i, label) in ["CW(A)", "CW(B)"].iter().enumerate() {
                    warping |= c.real_or(k0 + 6 + i, label, 0.0)? != 0.0;
                }
                if warping {
                    self.warn(
                        &c.loc,
                        id,
                        "CW (warping) is ignored: femu's beam has Saint-Venant torsion only, as Nastran's CBEAM without warping scalar points",
                    );
                }
                tail = 1;
            } else if tail == 1 {
                // M1(A) M2(A) M1(B) M2(B) N1(A) N2(A) N1(B) N2(B).
                for (i, label) in ["M1", "M2"].iter().enumerate() {
                    nsm_cg[i] = end_pair_at(c, k0 + i, k0 + 2 + i, label)?;
                }
                for (i, label) in ["N1", "N2"].iter().enumerate() {
                    neutral[i] = end_pair_at(c, k0 + 4 + i, k0 + 6 + i, label)?;
                }
                tail = 2;
            } else if (0..8).any(|i| !c.blank(k0 + i)) {
                return Err(c.err(
                    k0,
                    "?",
                    "this continuation follows the K and M lines",
                    "PBEAM ends with the K1 line and the M1(A) line",
                ));
            }
            r += 1;
        }
        let taper = pbeam_taper(c, &end_a, &stations)?;
        self.new_property(c, 1, "PID", id)?;
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section: BeamSection::General {
                    area: end_a[0],
                    iy: end_a[2],
                    iz: end_a[1],
                    j: end_a[4],
                    shear_y: k1,
                    shear_z: k2,
                },
                nsm: end_a[5],
                taper,
                centres: BeamCentres {
                    neutral_axis: neutral,
                    nsm_cg,
                    nsi,
                }
                .nonzero(),
            },
        );
        Ok(())
    }

    pub(super) fn mat1(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "MID")?;
        let e = c.real(2, "E")?;
        if let Some(v) = e.filter(|v| *v <= 0.0) {
            return Err(c.err(
                2,
                "E",
                format!("E = {v} is not positive"),
                "E > 0 (Nastran allows E = 0 with G given; femu's isotropic elements need E > 0)",
            ));
        }
        let g = c.real(3, "G")?;
        if let Some(v) = g.filter(|v| *v < 0.0) {
            return Err(c.err(3, "G", format!("G = {v} is negative"), "G >= 0 or blank"));
        }
        let nu = c.real(4, "NU")?;
        let rho = c.nonneg_real(5, "RHO", 0.0)?;
        let mut note = None;
        let (e, nu) = match (e, g, nu) {
            (Some(e), Some(g), Some(nu)) => {
                let g_used = e / (2.0 * (1.0 + nu));
                if (g - g_used).abs() > 1e-6 * g.abs().max(g_used.abs()) {
                    note = Some(format!(
                        "G = {g} does not equal E/(2(1+NU)); E and NU are kept, so G = {g_used}"
                    ));
                }
                (e, nu)
            }
            (Some(e), Some(g), None) => {
                if g <= 0.0 {
                    return Err(c.err(
                        3,
                        "G",
                        format!("G = {g} with NU blank"),
                        "G > 0 so that NU = E/(2G) - 1",
                    ));
                }
                (e, e / (2.0 * g) - 1.0)
            }
            (Some(e), None, Some(nu)) => (e, nu),
            (None, Some(g), Some(nu)) => {
                let e = 2.0 * (1.0 + nu) * g;
                if !(e > 0.0 && e.is_finite()) {
                    return Err(c.err(
                        3,
                        "G",
                        format!(
                            "E = 2(1+NU)G = {e} derived from G = {g} and NU = {nu} is not positive"
                        ),
                        "G > 0 and -1 < NU <= 0.5 when E is blank",
                    ));
                }
                (e, nu)
            }
            (Some(e), None, None) => {
                note = Some(
                    "G and NU are blank (Nastran: G = 0); femu's isotropic material needs NU, 0 is used (G = E/2)"
                        .to_string(),
                );
                (e, 0.0)
            }
            (None, Some(_), None) => {
                return Err(c.err(
                    2,
                    "E",
                    "E and NU are blank",
                    "give two of E, G and NU (femu's isotropic material needs E)",
                ));
            }
            (None, None, _) => {
                return Err(c.err(2, "E", "E and G are both blank", "give E (and NU or G)"));
            }
        };
        if !(nu > -1.0 && nu <= 0.5) {
            return Err(c.err(
                4,
                "NU",
                format!("Poisson's ratio {nu} (given or derived) is outside (-1, 0.5]"),
                "-1 < NU <= 0.5 (Nastran Quick Reference, MAT1)",
            ));
        }
        if let Some((first, _)) = self.materials.get(&id) {
            return Err(duplicate(c, 1, "MID", "material", id, first));
        }
        if let Some(text) = note {
            self.warn(&c.loc, id, text);
        }
        self.materials
            .insert(id, (c.loc.clone(), Material { e, nu, rho }));
        Ok(())
    }
}

/// A PBEAM value given for end A (field `ka`) and end B (field `kb`), both blank-is-0 for end
/// A and blank-is-end-A for end B (QRG PBEAM); femu's beam holds it constant, so an end-B value
/// other than end A's is an error naming it.
fn end_pair_at(c: &Card, ka: usize, kb: usize, label: &str) -> Result<f64, NastranError> {
    let a = c.real_or(ka, &format!("{label}(A)"), 0.0)?;
    let b = c.real_or(kb, &format!("{label}(B)"), a)?;
    if b != a {
        return Err(c.err(
            kb,
            &format!("{label}(B)"),
            format!("{label}(B) = {b} differs from {label}(A) = {a}"),
            format!("{label}(B) blank or equal to {label}(A): femu's beam holds the centroid and NSM offsets and NSI constant along the element"),
        ));
    }
    Ok(a)
}

/// [`end_pair_at`] for a pair in adjacent fields (`NSI(A) NSI(B)` at `k`, `k + 1`).
fn end_pair(c: &Card, k: usize, label: &str) -> Result<f64, NastranError> {
    end_pair_at(c, k, k + 1, label)
}

/// The stations of a PBEAM (field of SO, X/XB and the six values `A I1 I2 I12 J NSM`, each
/// `None` when blank) as a [`BeamTaper`] of `A, I1, I2, J` and NSM; `None` when every station
/// repeats end A. QRG: the last station is end B (X/XB = 1); blank end-B values are end A's,
/// blank values of an intermediate station are interpolated linearly between end A and end B.
pub(super) fn pbeam_taper(
    c: &Card,
    end_a: &[f64; 6],
    stations: &[(usize, f64, [Option<f64>; 6])],
) -> Result<Option<BeamTaper>, NastranError> {
    let Some(&(kb, xb, given_b)) = stations.last() else {
        return Ok(None);
    };
    if xb != 1.0 {
        return Err(c.err(
            kb + 1,
            "X/XB",
            format!("the last station is at X/XB = {xb}"),
            "the last station is end B: X/XB = 1.0",
        ));
    }
    let end_b: [f64; 6] = std::array::from_fn(|i| given_b[i].unwrap_or(end_a[i]));
    let labels = ["A", "I1", "I2", "I12", "J", "NSM"];
    let mut previous = 0.0;
    let mut out = vec![BeamStation {
        x: 0.0,
        values: vec![end_a[0], end_a[1], end_a[2], end_a[4]],
        nsm: end_a[5],
    }];
    let mut js = vec![end_a[4]];
    for &(k0, x, given) in stations {
        next_station(c, k0, x, &mut previous)?;
        let v: [f64; 6] = std::array::from_fn(|i| station_value(given[i], x, end_a[i], end_b[i]));
        for (i, must, what) in [
            (0, true, "a real number > 0"),
            (1, true, "a real number > 0"),
            (2, true, "a real number > 0"),
            (4, false, "a real number >= 0"),
            (5, false, "a real number >= 0"),
        ] {
            if !(v[i] > 0.0 || (!must && v[i] == 0.0)) || !v[i].is_finite() {
                return Err(c.err(
                    k0 + 2 + i,
                    labels[i],
                    format!("{} = {} at station X/XB = {x}", labels[i], v[i]),
                    what,
                ));
            }
        }
        if v[3] != 0.0 {
            return Err(c.err(
                k0 + 5,
                "I12",
                format!("product of inertia {} at station X/XB = {x} is not supported", v[3]),
                "give I1 and I2 about the principal axes and orient the beam along them (I12 blank or 0)",
            ));
        }
        js.push(v[4]);
        if js.iter().any(|j| *j > 0.0) && js.contains(&0.0) {
            return Err(c.err(
                k0 + 6,
                "J",
                format!("J is 0 at some stations and not at others (J so far: {js:?})"),
                "J > 0 at every station (end A included), or 0 (blank) at all",
            ));
        }
        out.push(BeamStation {
            x,
            values: vec![v[0], v[1], v[2], v[4]],
            nsm: v[5],
        });
    }
    Ok(uniform_or(out, None))
}

/// `None` when every station repeats end A (to 1e-9 relative, as a deck's printed digits
/// allow), else the taper.
/// Checks that a station's `X/XB` (field `k0 + 1`) follows the `previous` one within (0, 1],
/// and makes it the previous one.
pub(super) fn next_station(
    c: &Card,
    k0: usize,
    x: f64,
    previous: &mut f64,
) -> Result<(), NastranError> {
    if !(x > *previous && x <= 1.0) {
        return Err(c.err(
            k0 + 1,
            "X/XB",
            format!("station X/XB = {x} does not follow the previous one ({previous})"),
            "stations by increasing X/XB in (0, 1], the last at 1.0 (end B)",
        ));
    }
    *previous = x;
    Ok(())
}

/// A station's value: as given, or blank, linear between end A and end B at `x`.
pub(super) fn station_value(given: Option<f64>, x: f64, end_a: f64, end_b: f64) -> f64 {
    given.unwrap_or(end_a + x * (end_b - end_a))
}

pub(super) fn uniform_or(stations: Vec<BeamStation>, library: Option<String>) -> Option<BeamTaper> {
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
    let a = &stations[0];
    let uniform = stations
        .iter()
        .all(|s| s.values.iter().zip(&a.values).all(|(u, v)| same(*u, *v)) && same(s.nsm, a.nsm));
    (!uniform).then_some(BeamTaper { library, stations })
}
