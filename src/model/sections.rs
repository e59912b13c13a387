//! Beam cross-sections of Nastran's PBARL/PBEAML library (MSC Nastran Quick Reference Guide,
//! PBARL Figure 1: local `y` up, local `z` to the right, dimensions `DIM1…`): area, second
//! moments, product of inertia, torsion constant and shear factors, by closed formulas.
//!
//! Conventions (those of PBAR): `i1 = ∫ y² dA` (bending in plane 1, about element `z`),
//! `i2 = ∫ z² dA` (plane 2, about `y`), `i12 = ∫ y z dA`, all about the centroid. Each shape is
//! the union of the axis-aligned rectangles drawn in the QRG figure, so `A`, `i1`, `i2`, `i12`
//! are exact (parallel-axis sums over those rectangles).
//!
//! Torsion constant: the QRG gives the figures, not the formulas. femu uses the thin-walled
//! formulas of Nastran's element library documentation (NX/Simcenter Nastran Element Library
//! Reference, PBARL; Roark's Formulas, 7th ed., Table 10.7):
//! - open sections: `J = Σ ℓ t³ / 3` over the walls, each wall's length `ℓ` measured along its
//!   centreline to the centreline of the wall it meets (e.g. the I web `DIM1 − (DIM5 + DIM6)/2`,
//!   the L legs `DIM1 − DIM4/2`, `DIM2 − DIM3/2`);
//! - closed sections (BOX, BOX1): Bredt–Batho `J = 4 A_m² / ∮ ds/t` over the wall centrelines.
//!
//! Shear factors `k1`, `k2` (PBAR K1, K2: shear stiffness `k·A·G` in plane 1, 2): the area of
//! the walls that carry the shear of that plane, divided by `A` (webs between the flanges for
//! `k1`, flanges for `k2`), as the Element Library gives them for I, CHAN, T and L. When
//! `i12 ≠ 0` they are 0 (no shear flexibility): PBAR remark 4, "K1 and K2 are ignored if
//! I12 ≠ 0". [`principal`] rotates a section with `i12 ≠ 0` to its principal axes.
//!
//! Shear centre ([`neutral_axis_offset`]): Nastran's CBEAM puts the element axis at the shear
//! centre (QRG PBEAML remarks 7 and 12, default `MDLPRM,TWBRBML,0`), so a PBEAML whose section is
//! not doubly (or point) symmetric has its centroid off the axis. femu locates the shear centre
//! by the same thin-walled centreline model as its torsion constants (the walls' centrelines,
//! each of constant thickness, the lengths `J` uses): the pole `S` for which the sectorial
//! coordinate is orthogonal to `y` and `z`, `∫ ω_S y t ds = ∫ ω_S z t ds = 0` (Vlasov 1961,
//! *Thin-Walled Elastic Beams*, ch. I §6; Timoshenko & Gere 1961, *Theory of Elastic
//! Stability*, §5.3), with the closed cell of BOX1 by the reduced sectorial coordinate
//! `dω̄ = (r − ψ/t) ds`, `ψ = ∮ r ds / ∮ ds/t`, that makes the warping single-valued
//! (Bredt's constant shear flow). It reproduces the textbook results: the intersection of the
//! walls for T, T1, T2 and L; `e = 3 b² t_f / (6 b t_f + h t_w)` behind the web of a channel
//! (centreline `b`, `h`); `h I_t / (I_t + I_b)` above the bottom flange of an unequal I.
//! The centroid is the exact one of the rectangles (as `A`, `I` are), so the offset is the
//! exact centroid minus the thin-walled shear centre.

/// Properties of one cross-section (m², m⁴; shear factors dimensionless, 0 = shear-rigid).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionValues {
    /// Area `A`.
    pub area: f64,
    /// `I1 = ∫ y² dA` about the centroidal `z` axis (plane 1).
    pub i1: f64,
    /// `I2 = ∫ z² dA` about the centroidal `y` axis (plane 2).
    pub i2: f64,
    /// Product `I12 = ∫ y z dA`.
    pub i12: f64,
    /// Torsion constant `J`.
    pub j: f64,
    /// Shear factor of plane 1 (shear along `y`); 0: no shear flexibility.
    pub k1: f64,
    /// Shear factor of plane 2 (shear along `z`); 0: no shear flexibility.
    pub k2: f64,
}

/// Why a section's dimensions do not describe the shape.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{what}")]
pub struct SectionError {
    /// Which condition on the dimensions fails, with their values.
    pub what: String,
}

/// An axis-aligned rectangle `[z0, z1] × [y0, y1]`.
#[derive(Clone, Copy, Debug)]
struct Rect {
    z0: f64,
    z1: f64,
    y0: f64,
    y1: f64,
}

fn rect(z0: f64, z1: f64, y0: f64, y1: f64) -> Rect {
    Rect { z0, z1, y0, y1 }
}

/// `A`, `I1`, `I2`, `I12` about the centroid of a union of disjoint rectangles: for each,
/// `∫ y² = b (y1³ − y0³)/3` etc. about the origin, then the parallel-axis shift to the centroid.
fn composite(parts: &[Rect]) -> (f64, f64, f64, f64) {
    let (a, [yc, zc]) = area_and_centroid(parts);
    let (mut syy, mut szz, mut syz) = (0.0, 0.0, 0.0);
    for r in parts {
        let b = r.z1 - r.z0;
        let h = r.y1 - r.y0;
        syy += b * (r.y1.powi(3) - r.y0.powi(3)) / 3.0;
        szz += h * (r.z1.powi(3) - r.z0.powi(3)) / 3.0;
        syz += (r.y1 * r.y1 - r.y0 * r.y0) * (r.z1 * r.z1 - r.z0 * r.z0) / 4.0;
    }
    (a, syy - a * yc * yc, szz - a * zc * zc, syz - a * yc * zc)
}

/// Area and centroid `(y, z)` of a union of disjoint rectangles (first moments over area).
fn area_and_centroid(parts: &[Rect]) -> (f64, [f64; 2]) {
    let (mut a, mut sy, mut sz) = (0.0, 0.0, 0.0);
    for r in parts {
        let b = r.z1 - r.z0;
        let h = r.y1 - r.y0;
        a += b * h;
        sy += b * (r.y1 * r.y1 - r.y0 * r.y0) / 2.0;
        sz += h * (r.z1 * r.z1 - r.z0 * r.z0) / 2.0;
    }
    (a, [sy / a, sz / a])
}

fn check(ok: bool, what: impl FnOnce() -> String) -> Result<(), SectionError> {
    if ok {
        Ok(())
    } else {
        Err(SectionError { what: what() })
    }
}

fn positive(d: &[f64]) -> Result<(), SectionError> {
    for (i, v) in d.iter().enumerate() {
        check(v.is_finite() && *v > 0.0, || {
            format!("DIM{} = {v} is not a positive number", i + 1)
        })?;
    }
    Ok(())
}

/// Values from the rectangles, `J` and the shear areas `(A_y, A_z)`; shear factors dropped
/// when the product of inertia is not zero (PBAR remark 4).
fn finish(parts: &[Rect], j: f64, shear: (f64, f64)) -> SectionValues {
    let (area, i1, i2, i12) = composite(parts);
    let scale = i1.abs().max(i2.abs());
    let i12 = if i12.abs() <= 1e-13 * scale { 0.0 } else { i12 };
    let (k1, k2) = if i12 == 0.0 {
        (shear.0 / area, shear.1 / area)
    } else {
        (0.0, 0.0)
    };
    SectionValues {
        area,
        i1,
        i2,
        i12,
        j,
        k1,
        k2,
    }
}

/// PBARL `I`: `DIM1` height, `DIM2`/`DIM3` bottom/top flange width, `DIM4` web thickness,
/// `DIM5`/`DIM6` bottom/top flange thickness.
/// `J = (DIM2·DIM5³ + DIM3·DIM6³ + (DIM1 − (DIM5+DIM6)/2)·DIM4³)/3`;
/// `k1 = DIM4 (DIM1 − DIM5 − DIM6)/A`, `k2 = (DIM2·DIM5 + DIM3·DIM6)/A`.
pub fn i_section(d: [f64; 6]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [h, wb, wt, tw, tb, tt] = d;
    check(h > tb + tt, || {
        format!("DIM1 = {h} is not greater than DIM5 + DIM6 = {}", tb + tt)
    })?;
    check(tw < wb.min(wt), || {
        format!("DIM4 = {tw} is not smaller than both flange widths DIM2 = {wb}, DIM3 = {wt}")
    })?;
    let parts = [
        rect(-wb / 2.0, wb / 2.0, 0.0, tb),
        rect(-tw / 2.0, tw / 2.0, tb, h - tt),
        rect(-wt / 2.0, wt / 2.0, h - tt, h),
    ];
    let j = (wb * tb.powi(3) + wt * tt.powi(3) + (h - (tb + tt) / 2.0) * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tw * (h - tb - tt), wb * tb + wt * tt)))
}

/// PBARL `I1`: `DIM1` flange width less the web (half each side), `DIM2` web thickness, `DIM3`
/// web height between the flanges, `DIM4` total height; flange thickness `t = (DIM4 − DIM3)/2`.
/// `J = (2 (DIM1+DIM2) t³ + (DIM3+DIM4)/2 · DIM2³)/3`; `k1 = DIM2·DIM3/A`, `k2 = 2 (DIM1+DIM2) t/A`.
pub fn i1_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [bf, tw, hw, h] = d;
    check(h > hw, || {
        format!("DIM4 = {h} is not greater than DIM3 = {hw}")
    })?;
    let t = (h - hw) / 2.0;
    let w = bf + tw;
    let parts = [
        rect(-w / 2.0, w / 2.0, 0.0, t),
        rect(-tw / 2.0, tw / 2.0, t, t + hw),
        rect(-w / 2.0, w / 2.0, t + hw, h),
    ];
    let j = (2.0 * w * t.powi(3) + (hw + h) / 2.0 * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tw * hw, 2.0 * w * t)))
}

/// PBARL `T`: `DIM1` flange width, `DIM2` total height, `DIM3` flange thickness (flange on
/// top), `DIM4` web thickness. `J = (DIM1·DIM3³ + (DIM2 − DIM3/2)·DIM4³)/3`;
/// `k1 = DIM4 (DIM2 − DIM3)/A`, `k2 = DIM1·DIM3/A`.
pub fn t_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [b, h, tf, tw] = d;
    check(h > tf, || {
        format!("DIM2 = {h} is not greater than DIM3 = {tf}")
    })?;
    check(b > tw, || {
        format!("DIM1 = {b} is not greater than DIM4 = {tw}")
    })?;
    let parts = [
        rect(-tw / 2.0, tw / 2.0, 0.0, h - tf),
        rect(-b / 2.0, b / 2.0, h - tf, h),
    ];
    let j = (b * tf.powi(3) + (h - tf / 2.0) * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tw * (h - tf), b * tf)))
}

/// PBARL `T1`: `DIM1` flange height, `DIM2` web length, `DIM3` flange thickness, `DIM4` web
/// thickness (a T lying on its side: vertical flange, horizontal web).
/// `J = (DIM1·DIM3³ + (DIM2 + DIM3/2)·DIM4³)/3`; `k1 = DIM1·DIM3/A`, `k2 = DIM2·DIM4/A`.
pub fn t1_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [hf, lw, tf, tw] = d;
    check(hf > tw, || {
        format!("DIM1 = {hf} is not greater than DIM4 = {tw}")
    })?;
    let parts = [
        rect(0.0, tf, -hf / 2.0, hf / 2.0),
        rect(-lw, 0.0, -tw / 2.0, tw / 2.0),
    ];
    let j = (hf * tf.powi(3) + (lw + tf / 2.0) * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (hf * tf, lw * tw)))
}

/// PBARL `T2`: `DIM1` flange width, `DIM2` total height, `DIM3` flange thickness (flange at the
/// bottom), `DIM4` web thickness: the T upside down, so [`t_section`] of the same dimensions
/// (`I1`, `I2`, `J` do not change under the mirror).
pub fn t2_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    t_section(d)
}

/// PBARL `L`: `DIM1` width, `DIM2` height, `DIM3` thickness of the horizontal leg (bottom),
/// `DIM4` of the vertical leg (left). `J = ((DIM1 − DIM4/2)·DIM3³ + (DIM2 − DIM3/2)·DIM4³)/3`;
/// `I12 < 0`, so no shear factors.
pub fn l_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [b, h, t1, t2] = d;
    check(h > t1, || {
        format!("DIM2 = {h} is not greater than DIM3 = {t1}")
    })?;
    check(b > t2, || {
        format!("DIM1 = {b} is not greater than DIM4 = {t2}")
    })?;
    let parts = [rect(0.0, b, 0.0, t1), rect(0.0, t2, t1, h)];
    let j = ((b - t2 / 2.0) * t1.powi(3) + (h - t1 / 2.0) * t2.powi(3)) / 3.0;
    Ok(finish(&parts, j, (t2 * (h - t1), t1 * (b - t2))))
}

/// PBARL `CHAN`: `DIM1` width (web included), `DIM2` height, `DIM3` web thickness (web on the
/// left), `DIM4` flange thickness. `J = (2 (DIM1 − DIM3/2)·DIM4³ + (DIM2 − DIM4)·DIM3³)/3`;
/// `k1 = DIM3 (DIM2 − 2 DIM4)/A`, `k2 = 2 DIM4 (DIM1 − DIM3)/A`.
pub fn chan_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [b, h, tw, tf] = d;
    check(h > 2.0 * tf, || {
        format!("DIM2 = {h} is not greater than 2·DIM4 = {}", 2.0 * tf)
    })?;
    check(b > tw, || {
        format!("DIM1 = {b} is not greater than DIM3 = {tw}")
    })?;
    let parts = [
        rect(0.0, tw, 0.0, h),
        rect(tw, b, 0.0, tf),
        rect(tw, b, h - tf, h),
    ];
    let j = (2.0 * (b - tw / 2.0) * tf.powi(3) + (h - tf) * tw.powi(3)) / 3.0;
    Ok(finish(
        &parts,
        j,
        (tw * (h - 2.0 * tf), 2.0 * tf * (b - tw)),
    ))
}

/// PBARL `CHAN1`: `DIM1` flange width beyond the web, `DIM2` web thickness, `DIM3` web height
/// between the flanges, `DIM4` total height; flange thickness `t = (DIM4 − DIM3)/2`.
/// `J = (2 (DIM1 + DIM2/2) t³ + (DIM3+DIM4)/2 · DIM2³)/3`; `k1 = DIM2·DIM3/A`, `k2 = 2 DIM1 t/A`.
pub fn chan1_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [bf, tw, hw, h] = d;
    check(h > hw, || {
        format!("DIM4 = {h} is not greater than DIM3 = {hw}")
    })?;
    let t = (h - hw) / 2.0;
    let parts = [
        rect(0.0, tw, 0.0, h),
        rect(tw, tw + bf, 0.0, t),
        rect(tw, tw + bf, h - t, h),
    ];
    let j = (2.0 * (bf + tw / 2.0) * t.powi(3) + (hw + h) / 2.0 * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tw * hw, 2.0 * bf * t)))
}

/// PBARL `CHAN2`: `DIM1` thickness of the two upright legs, `DIM2` thickness of the base,
/// `DIM3` total height, `DIM4` total width (a U open upwards).
/// `J = ((DIM4 − DIM1)·DIM2³ + 2 (DIM3 − DIM2/2)·DIM1³)/3`;
/// `k1 = 2 DIM1 (DIM3 − DIM2)/A`, `k2 = DIM2 (DIM4 − 2 DIM1)/A`.
pub fn chan2_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [tl, tb, h, b] = d;
    check(h > tb, || {
        format!("DIM3 = {h} is not greater than DIM2 = {tb}")
    })?;
    check(b > 2.0 * tl, || {
        format!("DIM4 = {b} is not greater than 2·DIM1 = {}", 2.0 * tl)
    })?;
    let parts = [
        rect(0.0, b, 0.0, tb),
        rect(0.0, tl, tb, h),
        rect(b - tl, b, tb, h),
    ];
    let j = ((b - tl) * tb.powi(3) + 2.0 * (h - tb / 2.0) * tl.powi(3)) / 3.0;
    Ok(finish(
        &parts,
        j,
        (2.0 * tl * (h - tb), tb * (b - 2.0 * tl)),
    ))
}

/// Bredt–Batho `J = 4 A_m² / ∮ ds/t` of a rectangular box whose wall centrelines enclose
/// `bm × hm`, with top, bottom, left, right wall thicknesses.
fn bredt(bm: f64, hm: f64, top: f64, bottom: f64, left: f64, right: f64) -> f64 {
    let am = bm * hm;
    4.0 * am * am / (bm / top + bm / bottom + hm / left + hm / right)
}

/// PBARL `BOX`: `DIM1` width, `DIM2` height, `DIM3` thickness of the top and bottom walls,
/// `DIM4` of the side walls. `J = 2 t₃ t₄ (DIM1 − t₄)² (DIM2 − t₃)² / (DIM1 t₄ + DIM2 t₃ − t₄² − t₃²)`
/// (Bredt–Batho on the centrelines); `k1 = 2 DIM4 (DIM2 − 2 DIM3)/A`, `k2 = 2 DIM3 (DIM1 − 2 DIM4)/A`.
pub fn box_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [b, h, th, tv] = d;
    box1_section([b, h, th, th, tv, tv])
}

/// PBARL `BOX1`: `DIM1` width, `DIM2` height, `DIM3`/`DIM4` top/bottom wall thickness,
/// `DIM5`/`DIM6` right/left wall thickness. `J` by Bredt–Batho on the centrelines,
/// `4 A_m² / (b_m/DIM3 + b_m/DIM4 + h_m/DIM5 + h_m/DIM6)` with `b_m = DIM1 − (DIM5+DIM6)/2`,
/// `h_m = DIM2 − (DIM3+DIM4)/2`; `k1 = (DIM5+DIM6)(DIM2 − DIM3 − DIM4)/A`,
/// `k2 = (DIM3+DIM4)(DIM1 − DIM5 − DIM6)/A` (0 when unequal walls make `I12 ≠ 0`).
pub fn box1_section(d: [f64; 6]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [b, h, tt, tb, tr, tl] = d;
    check(h > tt + tb, || {
        format!(
            "the height {h} is not greater than the top and bottom walls {}",
            tt + tb
        )
    })?;
    check(b > tr + tl, || {
        format!(
            "the width {b} is not greater than the side walls {}",
            tr + tl
        )
    })?;
    let parts = [
        rect(0.0, b, 0.0, tb),
        rect(0.0, b, h - tt, h),
        rect(0.0, tl, tb, h - tt),
        rect(b - tr, b, tb, h - tt),
    ];
    let j = bredt(b - (tl + tr) / 2.0, h - (tt + tb) / 2.0, tt, tb, tl, tr);
    Ok(finish(
        &parts,
        j,
        ((tl + tr) * (h - tt - tb), (tt + tb) * (b - tl - tr)),
    ))
}

/// PBARL `H`: `DIM1` web length between the two upright flanges, `DIM2` the two flanges'
/// thickness together (`DIM2/2` each), `DIM3` flange height, `DIM4` web thickness.
/// `J = (2 DIM3 (DIM2/2)³ + (DIM1 + DIM2/2)·DIM4³)/3`; `k1 = DIM2·DIM3/A`, `k2 = DIM1·DIM4/A`.
pub fn h_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [lw, tf2, hf, tw] = d;
    check(hf > tw, || {
        format!("DIM3 = {hf} is not greater than DIM4 = {tw}")
    })?;
    let tf = tf2 / 2.0;
    let parts = [
        rect(0.0, tf, -hf / 2.0, hf / 2.0),
        rect(tf, tf + lw, -tw / 2.0, tw / 2.0),
        rect(tf + lw, tf2 + lw, -hf / 2.0, hf / 2.0),
    ];
    let j = (2.0 * hf * tf.powi(3) + (lw + tf) * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tf2 * hf, lw * tw)))
}

/// PBARL `CROSS`: `DIM1` the two horizontal arms' length together, `DIM2` thickness of the
/// upright bar, `DIM3` its height, `DIM4` thickness of the arms.
/// `J = (DIM3·DIM2³ + (DIM1 + DIM2)·DIM4³)/3` (arms to the bar's centreline);
/// `k1 = DIM2·DIM3/A`, `k2 = DIM1·DIM4/A`.
pub fn cross_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [la, tv, hv, ta] = d;
    check(hv > ta, || {
        format!("DIM3 = {hv} is not greater than DIM4 = {ta}")
    })?;
    let parts = [
        rect(-tv / 2.0 - la / 2.0, -tv / 2.0, -ta / 2.0, ta / 2.0),
        rect(-tv / 2.0, tv / 2.0, -hv / 2.0, hv / 2.0),
        rect(tv / 2.0, tv / 2.0 + la / 2.0, -ta / 2.0, ta / 2.0),
    ];
    let j = (hv * tv.powi(3) + (la + tv) * ta.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tv * hv, la * ta)))
}

/// PBARL `Z`: `DIM1` flange width beyond the web, `DIM2` web thickness, `DIM3` web height
/// between the flanges, `DIM4` total height; flange thickness `t = (DIM4 − DIM3)/2`, top flange
/// to the left, bottom flange to the right. `J = (2 (DIM1 + DIM2/2) t³ + (DIM3+DIM4)/2 · DIM2³)/3`;
/// `I12 < 0`, so no shear factors.
pub fn z_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [bf, tw, hw, h] = d;
    check(h > hw, || {
        format!("DIM4 = {h} is not greater than DIM3 = {hw}")
    })?;
    let t = (h - hw) / 2.0;
    let parts = [
        rect(-bf, 0.0, h - t, h),
        rect(0.0, tw, 0.0, h),
        rect(tw, tw + bf, 0.0, t),
    ];
    let j = (2.0 * (bf + tw / 2.0) * t.powi(3) + (hw + h) / 2.0 * tw.powi(3)) / 3.0;
    Ok(finish(&parts, j, (tw * hw, 2.0 * bf * t)))
}

/// PBARL `HAT`: `DIM1` height, `DIM2` wall thickness `t`, `DIM3` width of the top (outside),
/// `DIM4` width of each brim beyond the web. `J = ℓ t³/3` with the centreline length
/// `ℓ = (DIM3 − t) + 2 (DIM1 − t) + 2 (DIM4 + t/2)`; `k1 = 2 t (DIM1 − 2t)/A`,
/// `k2 = (DIM3 + 2 DIM4 + 2t) t/A`.
pub fn hat_section(d: [f64; 4]) -> Result<SectionValues, SectionError> {
    positive(&d)?;
    let [h, t, w, brim] = d;
    check(h > 2.0 * t, || {
        format!("DIM1 = {h} is not greater than 2·DIM2 = {}", 2.0 * t)
    })?;
    check(w > 2.0 * t, || {
        format!("DIM3 = {w} is not greater than 2·DIM2 = {}", 2.0 * t)
    })?;
    let x = w / 2.0;
    let parts = [
        rect(-x - brim, -x + t, 0.0, t),
        rect(-x, -x + t, t, h - t),
        rect(-x, x, h - t, h),
        rect(x - t, x, t, h - t),
        rect(x - t, x + brim, 0.0, t),
    ];
    let length = (w - t) + 2.0 * (h - t) + 2.0 * (brim + t / 2.0);
    let j = length * t.powi(3) / 3.0;
    Ok(finish(
        &parts,
        j,
        (2.0 * t * (h - 2.0 * t), (w + 2.0 * brim + 2.0 * t) * t),
    ))
}

/// The values of a PBARL/PBEAML library section other than BAR, ROD, TUBE and TUBE2 (which
/// are femu's own sections) from its dimensions `d` (as many as the type has); `None` for a
/// type not in this list.
pub fn library_values(kind: &str, d: &[f64]) -> Option<Result<SectionValues, SectionError>> {
    let four = || [d[0], d[1], d[2], d[3]];
    let six = || [d[0], d[1], d[2], d[3], d[4], d[5]];
    let n = match kind {
        "I" | "BOX1" => 6,
        "I1" | "T" | "T1" | "T2" | "L" | "CHAN" | "CHAN1" | "CHAN2" | "BOX" | "H" | "CROSS"
        | "Z" | "HAT" => 4,
        _ => return None,
    };
    if d.len() < n {
        return Some(Err(SectionError {
            what: format!("a {kind} section has {n} dimensions, {} given", d.len()),
        }));
    }
    Some(match kind {
        "I" => i_section(six()),
        "I1" => i1_section(four()),
        "T" => t_section(four()),
        "T1" => t1_section(four()),
        "T2" => t2_section(four()),
        "L" => l_section(four()),
        "CHAN" => chan_section(four()),
        "CHAN1" => chan1_section(four()),
        "CHAN2" => chan2_section(four()),
        "BOX" => box_section(four()),
        "BOX1" => box1_section(six()),
        "H" => h_section(four()),
        "CROSS" => cross_section(four()),
        "Z" => z_section(four()),
        _ => hat_section(four()),
    })
}

/// One straight wall of a thin-walled section's centreline, from `a` to `b` (`(y, z)`, m),
/// of thickness `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    /// Start `(y, z)`: the first wall's start, or a point where an earlier wall ends or starts.
    pub a: [f64; 2],
    /// End `(y, z)`.
    pub b: [f64; 2],
    /// Thickness.
    pub t: f64,
}

fn wall(a: [f64; 2], b: [f64; 2], t: f64) -> Wall {
    Wall { a, b, t }
}

/// The shape of a library section whose shear centre may be off its centroid: the rectangles
/// of its QRG figure (as its section function draws them), its centreline walls, and whether
/// they close a cell. `None` for a section whose symmetry puts the shear centre at the
/// centroid: BAR, ROD, TUBE, TUBE2, I1, BOX, H, CROSS, Z (point symmetry), I with equal flanges,
/// BOX1 with equal opposite walls. The dimensions must describe the shape (the section
/// functions check them).
fn shape(kind: &str, d: &[f64]) -> Option<(Vec<Rect>, Vec<Wall>, bool)> {
    let g = |i: usize| d[i];
    Some(match kind {
        "I" if !(d[1] == d[2] && d[4] == d[5]) => {
            let [h, wb, wt, tw, tb, tt] = [g(0), g(1), g(2), g(3), g(4), g(5)];
            let (j0, j1) = ([tb / 2.0, 0.0], [h - tt / 2.0, 0.0]);
            (
                vec![
                    rect(-wb / 2.0, wb / 2.0, 0.0, tb),
                    rect(-tw / 2.0, tw / 2.0, tb, h - tt),
                    rect(-wt / 2.0, wt / 2.0, h - tt, h),
                ],
                vec![
                    wall(j0, j1, tw),
                    wall(j0, [tb / 2.0, -wb / 2.0], tb),
                    wall(j0, [tb / 2.0, wb / 2.0], tb),
                    wall(j1, [h - tt / 2.0, -wt / 2.0], tt),
                    wall(j1, [h - tt / 2.0, wt / 2.0], tt),
                ],
                false,
            )
        }
        "T" | "T2" => {
            let [b, h, tf, tw] = [g(0), g(1), g(2), g(3)];
            // T: flange on top; T2: the same T upside down (flange at the bottom).
            let (flange, web, yf, foot) = if kind == "T" {
                (h - tf..h, 0.0..h - tf, h - tf / 2.0, 0.0)
            } else {
                (0.0..tf, tf..h, tf / 2.0, h)
            };
            let j = [yf, 0.0];
            (
                vec![
                    rect(-tw / 2.0, tw / 2.0, web.start, web.end),
                    rect(-b / 2.0, b / 2.0, flange.start, flange.end),
                ],
                vec![
                    wall([foot, 0.0], j, tw),
                    wall(j, [yf, -b / 2.0], tf),
                    wall(j, [yf, b / 2.0], tf),
                ],
                false,
            )
        }
        "T1" => {
            let [hf, lw, tf, tw] = [g(0), g(1), g(2), g(3)];
            let j = [0.0, tf / 2.0];
            (
                vec![
                    rect(0.0, tf, -hf / 2.0, hf / 2.0),
                    rect(-lw, 0.0, -tw / 2.0, tw / 2.0),
                ],
                vec![
                    wall([0.0, -lw], j, tw),
                    wall(j, [-hf / 2.0, tf / 2.0], tf),
                    wall(j, [hf / 2.0, tf / 2.0], tf),
                ],
                false,
            )
        }
        "L" => {
            let [b, h, t1, t2] = [g(0), g(1), g(2), g(3)];
            let j = [t1 / 2.0, t2 / 2.0];
            (
                vec![rect(0.0, b, 0.0, t1), rect(0.0, t2, t1, h)],
                vec![wall([t1 / 2.0, b], j, t1), wall(j, [h, t2 / 2.0], t2)],
                false,
            )
        }
        "CHAN" | "CHAN1" => {
            // CHAN1 is the CHAN of width DIM1 + DIM2 and flange thickness (DIM4 − DIM3)/2.
            let [b, h, tw, tf] = if kind == "CHAN" {
                [g(0), g(1), g(2), g(3)]
            } else {
                [g(0) + g(1), g(3), g(1), (g(3) - g(2)) / 2.0]
            };
            let (p, q) = ([tf / 2.0, tw / 2.0], [h - tf / 2.0, tw / 2.0]);
            (
                vec![
                    rect(0.0, tw, 0.0, h),
                    rect(tw, b, 0.0, tf),
                    rect(tw, b, h - tf, h),
                ],
                vec![
                    wall([tf / 2.0, b], p, tf),
                    wall(p, q, tw),
                    wall(q, [h - tf / 2.0, b], tf),
                ],
                false,
            )
        }
        "CHAN2" => {
            let [tl, tb, h, b] = [g(0), g(1), g(2), g(3)];
            let (p, q) = ([tb / 2.0, tl / 2.0], [tb / 2.0, b - tl / 2.0]);
            (
                vec![
                    rect(0.0, b, 0.0, tb),
                    rect(0.0, tl, tb, h),
                    rect(b - tl, b, tb, h),
                ],
                vec![
                    wall([h, tl / 2.0], p, tl),
                    wall(p, q, tb),
                    wall(q, [h, b - tl / 2.0], tl),
                ],
                false,
            )
        }
        "HAT" => {
            let [h, t, w, brim] = [g(0), g(1), g(2), g(3)];
            let x = w / 2.0;
            let c = x - t / 2.0;
            let pts = [
                [t / 2.0, -x - brim],
                [t / 2.0, -c],
                [h - t / 2.0, -c],
                [h - t / 2.0, c],
                [t / 2.0, c],
                [t / 2.0, x + brim],
            ];
            (
                vec![
                    rect(-x - brim, -x + t, 0.0, t),
                    rect(-x, -x + t, t, h - t),
                    rect(-x, x, h - t, h),
                    rect(x - t, x, t, h - t),
                    rect(x - t, x + brim, 0.0, t),
                ],
                pts.windows(2).map(|p| wall(p[0], p[1], t)).collect(),
                false,
            )
        }
        "BOX1" if !(d[2] == d[3] && d[4] == d[5]) => {
            let [b, h, tt, tb, tr, tl] = [g(0), g(1), g(2), g(3), g(4), g(5)];
            let c = [
                [tb / 2.0, tl / 2.0],
                [tb / 2.0, b - tr / 2.0],
                [h - tt / 2.0, b - tr / 2.0],
                [h - tt / 2.0, tl / 2.0],
            ];
            (
                vec![
                    rect(0.0, b, 0.0, tb),
                    rect(0.0, b, h - tt, h),
                    rect(0.0, tl, tb, h - tt),
                    rect(b - tr, b, tb, h - tt),
                ],
                vec![
                    wall(c[0], c[1], tb),
                    wall(c[1], c[2], tr),
                    wall(c[2], c[3], tt),
                    wall(c[3], c[0], tl),
                ],
                true,
            )
        }
        _ => return None,
    })
}

/// The shear centre `(y, z)` of a thin-walled section given by its centreline walls (an open
/// tree of walls, or one closed cell when `closed`: the walls in order round it), in the
/// walls' coordinates (see the module doc). The sectorial coordinate `ω_P` about the origin is
/// linear along each wall, `Δω = y_a Δz − z_a Δy` (less `ψ ℓ/t` round a cell); with centroidal
/// `y`, `z` of the centreline model, moving the pole to `S` adds `(y_P − y_S) z − (z_P − z_S) y`
/// to `ω`, and the orthogonality conditions are the 2 × 2 system
/// `a I_yz − b I_yy = −I_ωy`, `a I_zz − b I_yz = −I_ωz` for `a = y_P − y_S`, `b = z_P − z_S`.
pub fn thin_walled_shear_centre(walls: &[Wall], closed: bool) -> [f64; 2] {
    let len = |w: &Wall| ((w.b[0] - w.a[0]).powi(2) + (w.b[1] - w.a[1]).powi(2)).sqrt();
    let sweep = |w: &Wall| w.a[0] * (w.b[1] - w.a[1]) - w.a[1] * (w.b[0] - w.a[0]);
    let (mut area, mut sy, mut sz) = (0.0, 0.0, 0.0);
    for w in walls {
        let da = w.t * len(w);
        area += da;
        sy += da * (w.a[0] + w.b[0]) / 2.0;
        sz += da * (w.a[1] + w.b[1]) / 2.0;
    }
    let (yb, zb) = (sy / area, sz / area);
    let psi = if closed {
        walls.iter().map(sweep).sum::<f64>() / walls.iter().map(|w| len(w) / w.t).sum::<f64>()
    } else {
        0.0
    };
    // ∫ f g over a wall with f, g linear: ℓ t (f₀g₀/3 + (f₀g₁ + f₁g₀)/6 + f₁g₁/3).
    let product = |f: [f64; 2], g: [f64; 2]| {
        f[0] * g[0] / 3.0 + (f[0] * g[1] + f[1] * g[0]) / 6.0 + f[1] * g[1] / 3.0
    };
    let mut omega: Vec<([f64; 2], f64)> = vec![(walls[0].a, 0.0)];
    let (mut iyy, mut izz, mut iyz, mut iwy, mut iwz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for w in walls {
        let w0 = omega
            .iter()
            .find(|(p, _)| *p == w.a)
            .map(|(_, v)| *v)
            .expect("each wall starts where an earlier one is");
        let w1 = w0 + sweep(w) - psi * len(w) / w.t;
        if !omega.iter().any(|(p, _)| *p == w.b) {
            omega.push((w.b, w1));
        }
        let da = w.t * len(w);
        let y = [w.a[0] - yb, w.b[0] - yb];
        let z = [w.a[1] - zb, w.b[1] - zb];
        let om = [w0, w1];
        iyy += da * product(y, y);
        izz += da * product(z, z);
        iyz += da * product(y, z);
        iwy += da * product(om, y);
        iwz += da * product(om, z);
    }
    let det = iyy * izz - iyz * iyz;
    let a = (iwy * iyz - iyy * iwz) / det;
    let b = (izz * iwy - iyz * iwz) / det;
    [-a, -b]
}

/// The offset `(y, z)` of a library section's centroid from its shear centre, in the axes of
/// its QRG figure (before any principal turn), m: the exact centroid of its rectangles minus
/// the thin-walled shear centre (see the module doc); exactly zero for the sections whose
/// symmetry puts both at one point ([`shape`]), and a component below `1e-12` of the largest
/// dimension (round-off of a symmetric sum) is zero. The dimensions must describe the shape.
pub fn neutral_axis_offset(kind: &str, d: &[f64]) -> [f64; 2] {
    let Some((parts, walls, closed)) = shape(kind, d) else {
        return [0.0; 2];
    };
    let (_, c) = area_and_centroid(&parts);
    let s = thin_walled_shear_centre(&walls, closed);
    let size = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    [c[0] - s[0], c[1] - s[1]].map(|x| if x.abs() <= 1e-12 * size { 0.0 } else { x })
}

/// A section turned to its principal axes: the values about them, and the angle `θ` (rad,
/// `|θ| ≤ π/4`) from the element `y` axis to the principal axis that becomes the new `y`,
/// positive from `y` towards `z`. With `S = [[I1, I12], [I12, I2]]`,
/// `tan 2θ = 2 I12 / (I1 − I2)`, `I1' = c² I1 + 2cs I12 + s² I2`, `I2' = s² I1 − 2cs I12 + c² I2`
/// (`c = cos θ`, `s = sin θ`: the eigenvalues of `S`). `J`, the area and the polar moment do not
/// change; a section with `I12 = 0` comes back as it is with `θ = 0`.
pub fn principal(s: &SectionValues) -> (SectionValues, f64) {
    if s.i12 == 0.0 {
        return (*s, 0.0);
    }
    let theta = 0.5 * (2.0 * s.i12).atan2(s.i1 - s.i2);
    // Keep the smaller turn: the axis nearest to the element y.
    let theta = if theta > std::f64::consts::FRAC_PI_4 {
        theta - std::f64::consts::FRAC_PI_2
    } else if theta < -std::f64::consts::FRAC_PI_4 {
        theta + std::f64::consts::FRAC_PI_2
    } else {
        theta
    };
    let (sn, cs) = theta.sin_cos();
    let i1 = s.i1 * cs * cs + 2.0 * s.i12 * sn * cs + s.i2 * sn * sn;
    let i2 = s.i1 * sn * sn - 2.0 * s.i12 * sn * cs + s.i2 * cs * cs;
    (
        SectionValues {
            i1,
            i2,
            i12: 0.0,
            ..*s
        },
        theta,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `A, I1 = ∫y², I2 = ∫z², I12 = ∫yz` about the centroid of polygons given by their
    /// vertices `(z, y)` counter-clockwise, by Green's theorem (signed: a clockwise polygon is a
    /// hole): a second, independent way to integrate the shapes.
    fn polygon(outlines: &[Vec<(f64, f64)>]) -> (f64, f64, f64, f64) {
        let (mut a, mut sy, mut sz, mut syy, mut szz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for pts in outlines {
            for i in 0..pts.len() {
                let (z0, y0) = pts[i];
                let (z1, y1) = pts[(i + 1) % pts.len()];
                let c = z0 * y1 - z1 * y0;
                a += c / 2.0;
                sy += (y0 + y1) * c / 6.0;
                sz += (z0 + z1) * c / 6.0;
                syy += (y0 * y0 + y0 * y1 + y1 * y1) * c / 12.0;
                szz += (z0 * z0 + z0 * z1 + z1 * z1) * c / 12.0;
                syz += (z0 * y1 + 2.0 * z0 * y0 + 2.0 * z1 * y1 + z1 * y0) * c / 24.0;
            }
        }
        let (yc, zc) = (sy / a, sz / a);
        (a, syy - a * yc * yc, szz - a * zc * zc, syz - a * yc * zc)
    }

    fn reversed(mut p: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
        p.reverse();
        p
    }

    fn rectangle(z0: f64, z1: f64, y0: f64, y1: f64) -> Vec<(f64, f64)> {
        vec![(z0, y0), (z1, y0), (z1, y1), (z0, y1)]
    }

    /// Agreement to 1e-12 relative (both are exact; round-off of sums of cubes of ~0.1 m).
    fn assert_same(name: &str, s: &SectionValues, p: (f64, f64, f64, f64)) {
        let scale = s.i1.abs().max(s.i2.abs());
        assert!(
            (s.area - p.0).abs() <= 1e-12 * p.0,
            "{name} A {} {}",
            s.area,
            p.0
        );
        for (what, got, want) in [("I1", s.i1, p.1), ("I2", s.i2, p.2), ("I12", s.i12, p.3)] {
            assert!(
                (got - want).abs() <= 1e-12 * scale,
                "{name} {what}: {got:e} vs polygon {want:e}"
            );
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs()
    }

    #[test]
    fn areas_and_second_moments_match_the_outline_integrals() {
        let (h, wb, wt, tw, tb, tt) = (0.3, 0.16, 0.12, 0.01, 0.02, 0.015);
        let i = i_section([h, wb, wt, tw, tb, tt]).unwrap();
        let outline = vec![
            (-wb / 2.0, 0.0),
            (wb / 2.0, 0.0),
            (wb / 2.0, tb),
            (tw / 2.0, tb),
            (tw / 2.0, h - tt),
            (wt / 2.0, h - tt),
            (wt / 2.0, h),
            (-wt / 2.0, h),
            (-wt / 2.0, h - tt),
            (-tw / 2.0, h - tt),
            (-tw / 2.0, tb),
            (-wb / 2.0, tb),
        ];
        assert_same("I", &i, polygon(&[outline]));

        let (b, h, tf, tw) = (0.2, 0.25, 0.02, 0.012);
        let t = t_section([b, h, tf, tw]).unwrap();
        let top = vec![
            (-tw / 2.0, 0.0),
            (tw / 2.0, 0.0),
            (tw / 2.0, h - tf),
            (b / 2.0, h - tf),
            (b / 2.0, h),
            (-b / 2.0, h),
            (-b / 2.0, h - tf),
            (-tw / 2.0, h - tf),
        ];
        assert_same("T", &t, polygon(&[top]));
        let bottom = vec![
            (-b / 2.0, 0.0),
            (b / 2.0, 0.0),
            (b / 2.0, tf),
            (tw / 2.0, tf),
            (tw / 2.0, h),
            (-tw / 2.0, h),
            (-tw / 2.0, tf),
            (-b / 2.0, tf),
        ];
        assert_same(
            "T2",
            &t2_section([b, h, tf, tw]).unwrap(),
            polygon(&[bottom]),
        );

        let (b, h, t1, t2) = (0.1, 0.15, 0.01, 0.008);
        let l = l_section([b, h, t1, t2]).unwrap();
        let outline = vec![(0.0, 0.0), (b, 0.0), (b, t1), (t2, t1), (t2, h), (0.0, h)];
        assert_same("L", &l, polygon(&[outline]));
        assert!(l.i12 < 0.0 && l.k1 == 0.0 && l.k2 == 0.0);

        let (b, h, tw, tf) = (0.08, 0.2, 0.009, 0.012);
        let chan = chan_section([b, h, tw, tf]).unwrap();
        let outline = vec![
            (0.0, 0.0),
            (b, 0.0),
            (b, tf),
            (tw, tf),
            (tw, h - tf),
            (b, h - tf),
            (b, h),
            (0.0, h),
        ];
        assert_same("CHAN", &chan, polygon(std::slice::from_ref(&outline)));
        // CHAN1 of the same shape: flange beyond the web b − tw, web height h − 2 tf.
        let chan1 = chan1_section([b - tw, tw, h - 2.0 * tf, h]).unwrap();
        assert_same("CHAN1", &chan1, polygon(&[outline]));

        let (tl, tb, h, b) = (0.01, 0.015, 0.1, 0.2);
        let outline = vec![
            (0.0, 0.0),
            (b, 0.0),
            (b, h),
            (b - tl, h),
            (b - tl, tb),
            (tl, tb),
            (tl, h),
            (0.0, h),
        ];
        assert_same(
            "CHAN2",
            &chan2_section([tl, tb, h, b]).unwrap(),
            polygon(&[outline]),
        );

        let (b, h, th, tv) = (0.2, 0.1, 0.01, 0.02);
        let outer = rectangle(0.0, b, 0.0, h);
        let inner = reversed(rectangle(tv, b - tv, th, h - th));
        assert_same(
            "BOX",
            &box_section([b, h, th, tv]).unwrap(),
            polygon(&[outer.clone(), inner]),
        );
        let (tt, tb, tr, tl) = (0.01, 0.02, 0.005, 0.015);
        let inner = reversed(rectangle(tl, b - tr, tb, h - tt));
        let box1 = box1_section([b, h, tt, tb, tr, tl]).unwrap();
        assert_same("BOX1", &box1, polygon(&[outer, inner]));
        assert!(box1.i12 != 0.0);

        let (lw, tf2, hf, tw) = (0.15, 0.02, 0.2, 0.01);
        let tf = tf2 / 2.0;
        let outline = vec![
            (0.0, -hf / 2.0),
            (tf, -hf / 2.0),
            (tf, -tw / 2.0),
            (tf + lw, -tw / 2.0),
            (tf + lw, -hf / 2.0),
            (tf2 + lw, -hf / 2.0),
            (tf2 + lw, hf / 2.0),
            (tf + lw, hf / 2.0),
            (tf + lw, tw / 2.0),
            (tf, tw / 2.0),
            (tf, hf / 2.0),
            (0.0, hf / 2.0),
        ];
        assert_same(
            "H",
            &h_section([lw, tf2, hf, tw]).unwrap(),
            polygon(&[outline]),
        );

        let (la, tv, hv, ta) = (0.12, 0.02, 0.18, 0.015);
        let (u, w) = (tv / 2.0, tv / 2.0 + la / 2.0);
        let outline = vec![
            (-u, -hv / 2.0),
            (u, -hv / 2.0),
            (u, -ta / 2.0),
            (w, -ta / 2.0),
            (w, ta / 2.0),
            (u, ta / 2.0),
            (u, hv / 2.0),
            (-u, hv / 2.0),
            (-u, ta / 2.0),
            (-w, ta / 2.0),
            (-w, -ta / 2.0),
            (-u, -ta / 2.0),
        ];
        assert_same(
            "CROSS",
            &cross_section([la, tv, hv, ta]).unwrap(),
            polygon(&[outline]),
        );

        let (bf, tw, hw, h) = (0.06, 0.008, 0.18, 0.2);
        let t = (h - hw) / 2.0;
        let outline = vec![
            (0.0, 0.0),
            (tw + bf, 0.0),
            (tw + bf, t),
            (tw, t),
            (tw, h),
            (-bf, h),
            (-bf, h - t),
            (0.0, h - t),
        ];
        let z = z_section([bf, tw, hw, h]).unwrap();
        assert_same("Z", &z, polygon(&[outline]));
        assert!(z.i12 < 0.0);
        let w = bf + tw;
        let outline = vec![
            (-w / 2.0, 0.0),
            (w / 2.0, 0.0),
            (w / 2.0, t),
            (tw / 2.0, t),
            (tw / 2.0, t + hw),
            (w / 2.0, t + hw),
            (w / 2.0, h),
            (-w / 2.0, h),
            (-w / 2.0, t + hw),
            (-tw / 2.0, t + hw),
            (-tw / 2.0, t),
            (-w / 2.0, t),
        ];
        assert_same(
            "I1",
            &i1_section([bf, tw, hw, h]).unwrap(),
            polygon(&[outline]),
        );

        let (hf, lw, tf, tw) = (0.2, 0.1, 0.012, 0.01);
        let outline = vec![
            (0.0, -hf / 2.0),
            (tf, -hf / 2.0),
            (tf, hf / 2.0),
            (0.0, hf / 2.0),
            (0.0, tw / 2.0),
            (-lw, tw / 2.0),
            (-lw, -tw / 2.0),
            (0.0, -tw / 2.0),
        ];
        assert_same(
            "T1",
            &t1_section([hf, lw, tf, tw]).unwrap(),
            polygon(&[outline]),
        );

        let (h, t, wd, brim) = (0.1, 0.004, 0.08, 0.03);
        let x = wd / 2.0;
        let outline = vec![
            (-x - brim, 0.0),
            (-x + t, 0.0),
            (-x + t, h - t),
            (x - t, h - t),
            (x - t, 0.0),
            (x + brim, 0.0),
            (x + brim, t),
            (x, t),
            (x, h),
            (-x, h),
            (-x, t),
            (-x - brim, t),
        ];
        assert_same(
            "HAT",
            &hat_section([h, t, wd, brim]).unwrap(),
            polygon(&[outline]),
        );
    }

    /// Torsion constants against hand evaluations of the thin-walled formulas, and BOX against
    /// Bredt–Batho written as `4 A_m² / ∮ ds/t`.
    #[test]
    fn torsion_constants_match_hand_values() {
        // I: 2 flanges 0.15 × 0.02, web centreline 0.3 − 0.02 = 0.28 long, 0.01 thick:
        // (2·0.15·8e-6 + 0.28·1e-6)/3 = 2.68e-6/3.
        let i = i_section([0.3, 0.15, 0.15, 0.01, 0.02, 0.02]).unwrap();
        assert!(close(i.j, 2.68e-6 / 3.0), "{}", i.j);
        // BOX 0.2 × 0.1, top/bottom 0.01, sides 0.02: A_m = 0.18·0.09 = 0.0162,
        // ∮ds/t = 2·0.18/0.01 + 2·0.09/0.02 = 45, J = 4·0.0162²/45 = 2.3328e-5.
        let b = box_section([0.2, 0.1, 0.01, 0.02]).unwrap();
        assert!(close(b.j, 2.3328e-5), "{}", b.j);
        // L 0.1 × 0.15, t 0.01 / 0.008: ((0.1 − 0.004)·1e-6 + (0.15 − 0.005)·5.12e-7)/3.
        let l = l_section([0.1, 0.15, 0.01, 0.008]).unwrap();
        assert!(close(l.j, (0.096e-6 + 0.145 * 5.12e-7) / 3.0), "{}", l.j);
        // CROSS: (0.18·0.02³ + (0.12 + 0.02)·0.015³)/3.
        let c = cross_section([0.12, 0.02, 0.18, 0.015]).unwrap();
        assert!(close(c.j, (0.18 * 8e-6 + 0.14 * 3.375e-6) / 3.0), "{}", c.j);
        // HAT t = 0.004: ℓ = (0.08 − 0.004) + 2 (0.1 − 0.004) + 2 (0.03 + 0.002) = 0.332.
        let hat = hat_section([0.1, 0.004, 0.08, 0.03]).unwrap();
        assert!(close(hat.j, 0.332 * 6.4e-8 / 3.0), "{}", hat.j);
        // Thin-walled limit: a thin BOX tends to the thin tube value 2 t b² h² / (b + h) on the
        // outer dimensions, within the centreline correction O(t/b + t/h) (bound 3(t/b + t/h)).
        let t = 1e-4;
        let thin = box_section([0.2, 0.1, t, t]).unwrap();
        let tube = 2.0 * t * 0.04 * 0.01 / 0.3;
        let bound = 3.0 * (t / 0.2 + t / 0.1);
        assert!((thin.j - tube).abs() < bound * tube, "{} {tube}", thin.j);
        // Shear factors of the I: web 0.26·0.01, flanges 2·0.15·0.02 over A = 0.0086.
        assert!(close(i.k1, 0.0026 / 0.0086) && close(i.k2, 0.006 / 0.0086));
    }

    /// The principal turn, checked by integrating the outline in the turned axes: the product
    /// of inertia vanishes there and the principal moments are the outline's.
    #[test]
    fn principal_axes_diagonalise_the_section() {
        let (b, h, t1, t2) = (0.1, 0.15, 0.01, 0.008);
        let outline = [(0.0, 0.0), (b, 0.0), (b, t1), (t2, t1), (t2, h), (0.0, h)];
        let l = l_section([b, h, t1, t2]).unwrap();
        let (p, theta) = principal(&l);
        assert!(theta.abs() <= std::f64::consts::FRAC_PI_4);
        let (s, c) = theta.sin_cos();
        // New coordinates: y' = c y + s z, z' = −s y + c z.
        let turned: Vec<(f64, f64)> = outline
            .iter()
            .map(|&(z, y)| (-s * y + c * z, c * y + s * z))
            .collect();
        let q = polygon(&[turned]);
        assert_same("L turned", &p, q);
        assert!(q.3.abs() < 1e-12 * q.1.max(q.2));
        assert_eq!((p.area, p.j), (l.area, l.j));
        // Equal legs: principal axes at 45°, moments I ± |I12|.
        let e = l_section([0.1, 0.1, 0.01, 0.01]).unwrap();
        let (pe, te) = principal(&e);
        assert!((te.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        let (hi, lo) = (e.i1 + e.i12.abs(), e.i1 - e.i12.abs());
        assert!(close(pe.i1.max(pe.i2), hi) && close(pe.i1.min(pe.i2), lo));
        let sym = i_section([0.3, 0.15, 0.15, 0.01, 0.02, 0.02]).unwrap();
        assert_eq!(principal(&sym), (sym, 0.0));
    }

    #[test]
    fn impossible_dimensions_are_refused_with_the_condition() {
        let e = i_section([0.03, 0.15, 0.15, 0.01, 0.02, 0.02]).unwrap_err();
        assert!(e.what.contains("DIM5 + DIM6"), "{e}");
        let e = box_section([0.2, 0.1, 0.06, 0.02]).unwrap_err();
        assert!(e.what.contains("top and bottom"), "{e}");
        let e = chan_section([0.1, 0.2, -0.01, 0.01]).unwrap_err();
        assert!(e.what.contains("DIM3"), "{e}");
    }

    /// The shapes the shear centre uses are the section functions' own: their rectangles give
    /// the same `A, I1, I2, I12` (to 1e-12: the same rectangles, but T2's drawn upside down
    /// where its section function reuses the T), for every type with a shape.
    #[test]
    fn shear_centre_shapes_are_the_sections_rectangles() {
        let cases: [(&str, &[f64]); 10] = [
            ("I", &[0.3, 0.16, 0.12, 0.01, 0.02, 0.015]),
            ("T", &[0.2, 0.25, 0.02, 0.012]),
            ("T2", &[0.2, 0.25, 0.02, 0.012]),
            ("T1", &[0.2, 0.1, 0.012, 0.01]),
            ("L", &[0.1, 0.15, 0.01, 0.008]),
            ("CHAN", &[0.08, 0.2, 0.009, 0.012]),
            ("CHAN1", &[0.06, 0.008, 0.18, 0.2]),
            ("CHAN2", &[0.01, 0.015, 0.1, 0.2]),
            ("HAT", &[0.1, 0.004, 0.08, 0.03]),
            ("BOX1", &[0.2, 0.1, 0.01, 0.02, 0.005, 0.015]),
        ];
        for (kind, d) in cases {
            let v = library_values(kind, d).unwrap().unwrap();
            let (parts, _, _) = shape(kind, d).unwrap();
            let (a, i1, i2, i12) = composite(&parts);
            let i12 = if i12.abs() <= 1e-13 * i1.abs().max(i2.abs()) {
                0.0
            } else {
                i12
            };
            let scale = v.i1.abs().max(v.i2.abs());
            assert!((a - v.area).abs() <= 1e-12 * v.area, "{kind} A");
            for (got, want) in [(i1, v.i1), (i2, v.i2), (i12, v.i12)] {
                assert!(
                    (got - want).abs() <= 1e-12 * scale,
                    "{kind}: {got:e} {want:e}"
                );
            }
        }
        // Symmetric sections have none, so their offset is exactly zero.
        for (kind, d) in [
            ("I", &[0.3, 0.15, 0.15, 0.01, 0.02, 0.02][..]),
            ("BOX1", &[0.2, 0.1, 0.01, 0.01, 0.02, 0.02]),
            ("Z", &[0.06, 0.008, 0.18, 0.2]),
            ("H", &[0.15, 0.02, 0.2, 0.01]),
            ("BOX", &[0.2, 0.1, 0.01, 0.02]),
        ] {
            assert!(shape(kind, d).is_none(), "{kind}");
            assert_eq!(neutral_axis_offset(kind, d), [0.0, 0.0], "{kind}");
        }
    }

    /// The thin-walled shear centre against the textbook closed forms (all on the same
    /// centreline model, so to round-off, 1e-12 of the section size): T, T1, T2 and L at the
    /// walls' intersection; the channel `e = 3 b² t_f / (6 b t_f + h t_w)` behind the web
    /// (centreline `b = DIM1 − DIM3/2`, `h = DIM2 − DIM4`), CHAN1 the same as the CHAN of that
    /// shape; the unequal I at `h I_t/(I_t + I_b)` above the bottom flange's centreline. The
    /// offset is the exact centroid (hand-computed here) minus that point.
    #[test]
    fn shear_centres_match_the_closed_forms() {
        let near = |a: [f64; 2], b: [f64; 2], what: &str| {
            eprintln!(
                "{what}: offset {a:?}, closed form differs by {:e} m",
                (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
            );
            assert!(
                (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12,
                "{what}: {a:?} against {b:?}"
            );
        };
        // T: flange b × tf on top of a web tw × (h − tf).
        let (b, h, tf, tw) = (0.2, 0.25, 0.02, 0.012);
        let (aw, af) = (tw * (h - tf), b * tf);
        let yc = (aw * (h - tf) / 2.0 + af * (h - tf / 2.0)) / (aw + af);
        near(
            neutral_axis_offset("T", &[b, h, tf, tw]),
            [yc - (h - tf / 2.0), 0.0],
            "T",
        );
        // T2: the same T upside down, so the opposite offset.
        let t = neutral_axis_offset("T", &[b, h, tf, tw]);
        near(
            neutral_axis_offset("T2", &[b, h, tf, tw]),
            [-t[0], 0.0],
            "T2",
        );
        // T1: flange tf wide (z from 0 to tf), web lw long to the left.
        let (hf, lw, tf1, tw1) = (0.2, 0.1, 0.012, 0.01);
        let (af, aw) = (hf * tf1, lw * tw1);
        let zc = (af * tf1 / 2.0 - aw * lw / 2.0) / (af + aw);
        near(
            neutral_axis_offset("T1", &[hf, lw, tf1, tw1]),
            [0.0, zc - tf1 / 2.0],
            "T1",
        );
        // L: legs meet at (t1/2, t2/2).
        let (b, h, t1, t2) = (0.1, 0.15, 0.01, 0.008);
        let (ah, av) = (b * t1, t2 * (h - t1));
        let yc = (ah * t1 / 2.0 + av * (t1 + h) / 2.0) / (ah + av);
        let zc = (ah * b / 2.0 + av * t2 / 2.0) / (ah + av);
        near(
            neutral_axis_offset("L", &[b, h, t1, t2]),
            [yc - t1 / 2.0, zc - t2 / 2.0],
            "L",
        );
        // CHAN: web on the left; the shear centre e behind the web's centreline.
        let (b, h, tw, tf) = (0.08, 0.2, 0.009, 0.012);
        let (bc, hc) = (b - tw / 2.0, h - tf);
        let e = 3.0 * bc * bc * tf / (6.0 * bc * tf + hc * tw);
        let (aw, af) = (tw * h, 2.0 * tf * (b - tw));
        let zc = (aw * tw / 2.0 + af * (tw + b) / 2.0) / (aw + af);
        let chan = neutral_axis_offset("CHAN", &[b, h, tw, tf]);
        near(chan, [0.0, zc - (tw / 2.0 - e)], "CHAN");
        let chan1 = neutral_axis_offset("CHAN1", &[b - tw, tw, h - 2.0 * tf, h]);
        near(chan1, chan, "CHAN1");
        // Unequal I: S on the web at h_c I_t/(I_t + I_b) above the bottom flange centreline.
        let (h, wb, wt, tw, tb, tt) = (0.3, 0.16f64, 0.12f64, 0.01, 0.02, 0.015);
        let (it, ib) = (tt * wt.powi(3) / 12.0, tb * wb.powi(3) / 12.0);
        let ys = tb / 2.0 + (h - (tb + tt) / 2.0) * it / (it + ib);
        let (a1, a2, a3) = (wb * tb, tw * (h - tb - tt), wt * tt);
        let yc = (a1 * tb / 2.0 + a2 * (h + tb - tt) / 2.0 + a3 * (h - tt / 2.0)) / (a1 + a2 + a3);
        near(
            neutral_axis_offset("I", &[h, wb, wt, tw, tb, tt]),
            [yc - ys, 0.0],
            "I",
        );
    }

    /// The shear centre by a second, independent route: the shear flow. On the same centreline
    /// walls, a shear force in `y` (then in `z`) gives the open-section flow
    /// `q(s) = −∫ t g ds` with `g` the normal-stress gradient of that force (`∝ I_zz y − I_yz z`
    /// for a force along `y` in centroidal axes, `I_yy = ∫y²`, …, which has no moment about `y`),
    /// plus, round a closed cell, the constant flow that makes the twist `∮ q/t ds` zero. The
    /// flow is quadratic along each wall, so Simpson's rule integrates its resultant and moment
    /// exactly; the line of action of the two resultants is the shear centre. Chains (CHAN,
    /// CHAN2, HAT, L) and the closed BOX1 with unequal walls (where `I_yz ≠ 0` too) agree with
    /// the sectorial route to 1e-12 of the size (round-off); a sign error in the pole shift or
    /// `ψ` moves the point by O(the section).
    #[test]
    fn shear_centres_match_the_shear_flow() {
        let cases: [(&str, &[f64]); 6] = [
            ("CHAN", &[0.08, 0.2, 0.009, 0.012]),
            ("CHAN2", &[0.01, 0.015, 0.1, 0.2]),
            ("HAT", &[0.1, 0.004, 0.08, 0.03]),
            ("L", &[0.1, 0.15, 0.01, 0.008]),
            ("BOX1", &[0.2, 0.1, 0.01, 0.02, 0.005, 0.015]),
            ("BOX1", &[0.2, 0.1, 0.01, 0.01, 0.005, 0.02]),
        ];
        for (kind, d) in cases {
            let (_, walls, closed) = shape(kind, d).unwrap();
            // Centreline centroid and second moments (exact for linear y, z on each wall).
            let len = |w: &Wall| ((w.b[0] - w.a[0]).powi(2) + (w.b[1] - w.a[1]).powi(2)).sqrt();
            let area: f64 = walls.iter().map(|w| w.t * len(w)).sum();
            let yb = walls
                .iter()
                .map(|w| w.t * len(w) * (w.a[0] + w.b[0]) / 2.0)
                .sum::<f64>()
                / area;
            let zb = walls
                .iter()
                .map(|w| w.t * len(w) * (w.a[1] + w.b[1]) / 2.0)
                .sum::<f64>()
                / area;
            let (mut iyy, mut izz, mut iyz) = (0.0, 0.0, 0.0);
            for w in &walls {
                let (y0, y1, z0, z1) = (w.a[0] - yb, w.b[0] - yb, w.a[1] - zb, w.b[1] - zb);
                let da = w.t * len(w);
                iyy += da * (y0 * y0 + y0 * y1 + y1 * y1) / 3.0;
                izz += da * (z0 * z0 + z0 * z1 + z1 * z1) / 3.0;
                iyz += da * (2.0 * y0 * z0 + y0 * z1 + y1 * z0 + 2.0 * y1 * z1) / 6.0;
            }
            // (F_y, F_z, M_x about the origin) of the flow of the gradient (cy, cz).
            let flow = |cy: f64, cz: f64| {
                let g = |p: [f64; 2]| cy * (p[0] - yb) + cz * (p[1] - zb);
                // Per wall: q at start, middle, end (the walls are chained in order).
                let mut q0 = 0.0;
                let mut qs = Vec::new();
                for w in &walls {
                    let l = len(w);
                    let mid = [(w.a[0] + w.b[0]) / 2.0, (w.a[1] + w.b[1]) / 2.0];
                    let qm = q0 - w.t * (g(w.a) + g(mid)) / 2.0 * (l / 2.0);
                    let q1 = q0 - w.t * (g(w.a) + g(w.b)) / 2.0 * l;
                    qs.push([q0, qm, q1]);
                    q0 = q1;
                }
                let integral = |q: &[f64; 3], l: f64| l / 6.0 * (q[0] + 4.0 * q[1] + q[2]);
                let shift = if closed {
                    let twist: f64 = walls
                        .iter()
                        .zip(&qs)
                        .map(|(w, q)| integral(q, len(w)) / w.t)
                        .sum();
                    let compliance: f64 = walls.iter().map(|w| len(w) / w.t).sum();
                    -twist / compliance
                } else {
                    0.0
                };
                let (mut fy, mut fz, mut mx) = (0.0, 0.0, 0.0);
                for (w, q) in walls.iter().zip(&qs) {
                    let l = len(w);
                    let total = integral(q, l) + shift * l;
                    let (dy, dz) = ((w.b[0] - w.a[0]) / l, (w.b[1] - w.a[1]) / l);
                    fy += total * dy;
                    fz += total * dz;
                    mx += total * (w.a[0] * dz - w.a[1] * dy);
                }
                (fy, fz, mx)
            };
            let (fy1, fz1, m1) = flow(izz, -iyz);
            let (fy2, fz2, m2) = flow(-iyz, iyy);
            // The y-force case has no z resultant and vice versa.
            assert!(
                fz1.abs() < 1e-9 * fy1.abs() && fy2.abs() < 1e-9 * fz2.abs(),
                "{kind}"
            );
            // M = y_S F_z − z_S F_y for each.
            let z_s = -m1 / fy1;
            let y_s = m2 / fz2;
            let s = thin_walled_shear_centre(&walls, closed);
            let size = d.iter().fold(0.0f64, |m, x| m.max(*x));
            eprintln!(
                "{kind} {d:?}: shear centre {s:?}, shear flow differs by {:e} m",
                (s[0] - y_s).abs().max((s[1] - z_s).abs())
            );
            assert!(
                (s[0] - y_s).abs() < 1e-12 * size.max(1.0)
                    && (s[1] - z_s).abs() < 1e-12 * size.max(1.0),
                "{kind} {d:?}: sectorial {s:?}, shear flow {:?}",
                [y_s, z_s]
            );
        }
    }
}
