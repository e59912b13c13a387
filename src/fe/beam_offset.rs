//! Beams whose centroid (neutral axis) and non-structural mass lie away from the beam's axis,
//! which is the section's **shear centre** (Nastran CBEAM: PBEAM `N1 N2`, `M1 M2`, `NSI`; a
//! PBEAML section whose shear centre is not its centroid, QRG PBEAML remarks 7 and 12).
//!
//! **Kinematics.** The element's DOFs are those of the shear centre `S` (the grid line after the
//! WA/WB offsets); the centroid `N` sits at `n = (n_y, n_z)` and the NSM centre of gravity `M`
//! at `m = (m_y, m_z)` from `S`, in element axes. A point `P` at `p` of the rigid cross-section
//! moves by `u_P = u_S + θ × p` (with `θ` femu's right-handed rotation vector):
//! `u_xP = u_xS + p_z θ_y − p_y θ_z`, `u_yP = u_yS − p_z θ_x`, `u_zP = u_zS + p_y θ_x`
//! (the sign of `p_z θ_y` is that of `θ_y = −w'` in femu's `x–z` plane: a section turning by
//! `θ_y` moves its fibre at `+z` along `+x`).
//!
//! **Stiffness** (linear Vlasov theory without warping; Nastran's CBEAM ignores warping unless
//! warping scalar points are given, so CW stays ignored). Bending curvatures are rotation
//! gradients, the same for every point of the section; transverse shear forces act through the
//! shear centre, so the shear strains are those of `S`'s line, and torsion is about `S`. Only
//! the axial strain belongs to the centroid: the axial force acts at `N`, `ε = u_xN'`. Hence
//! `K = T_aᵀ K_c T_a`, `K_c` the centroidal matrix of [`super::beam`] (or of the tapered beam) and
//! `T_a` the identity but for the two axial rows, `u_xN = u_xS + n_z θ_y − n_y θ_z`. Applying
//! the full rigid offset to the stiffness instead would make the transverse displacements those
//! of `N`, `v_N = v_S − n_z θ_x`: a twisted channel would bend. Under a uniform twist the nodal
//! `v_N` of an element differ by `n_z θ_x' L` while its end slopes stay zero, which the element
//! resists with a bending energy of `12 EI (n_z θ_x')²/L²` per length (capped by the shear
//! energy `κGA (n_z θ_x')²` when the section is shear-flexible): it grows as the element shrinks,
//! so it is not a discretisation error that refinement removes but a spurious stiffening.
//!
//! **Mass.** The structural mass `ρA` sits at `N`, the NSM at `M`; the NSM's own inertia
//! `NSI` per length about `M` (about the beam's direction) adds to the torsional inertia. The
//! section's rotary and torsional inertia (`ρI_y`, `ρI_z` about the centroid, `ρI_p`) belong
//! to the section's rotations, which in Vlasov's kinematics are the slopes of the
//! shear-centre line and the twist (the axial displacement is
//! `u = ζ − η_S' y − ξ_S' z − θ_x' ω_S`): they are not moved. The mass matrix is the kinetic
//! energy of these rigid sections: `M = M_r + T_nᵀ M_s T_n + T_mᵀ M_nsm T_m + M_NSI`, with
//! `T_p` the full rigid offset of each end (the per-end `12 × 12` transform above), and `M_r`,
//! `M_s`, `M_nsm` the existing centroidal mass of the rotary and torsional inertia alone
//! (`m̄ = 0`), of the structural translational inertia alone (`ρA` as an NSM, `ρ = 0` in the
//! rotary terms) and of the NSM alone (the mass is linear in these, so their sum is the
//! existing matrix). Moving `M_r` too would replace the section's rotation by the slope of
//! the centroid line, `w_N' = w_S' + n_y θ_x'`, in the rotary inertia: an extra
//! `ρI_y (n_y θ_x')²` that refinement does not remove (it left the Gere–Lin frequencies of the
//! tests 2.6e-3 off at 128 elements, the error growing under refinement). For a **consistent** mass the centroid's translation is
//! interpolated from its nodal values with the element's own (centroidal) shape functions —
//! e.g. `u_zN(x)` the cubic of the nodal `u_zS + n_y θ_x`, rather than the cubic of `u_zS` plus
//! `n_y` times the linear `θ_x`. That choice (over integrating the cross terms of the two
//! interpolations directly) keeps `M` a sum of congruences of positive semi-definite matrices
//! (so positive semi-definite), exact for rigid-body motion (the shape functions reproduce the
//! rigid motion of `N`, so total mass, centre of mass and inertia tensor — the polar inertia
//! about `S` includes `ρA|n|²` — are exact), reuses the Timoshenko-consistent matrix
//! unchanged, and keeps the `E`/`ρ` derivatives exact (the transforms are constant). The two
//! interpolations differ by `n_y (θ_x2 − θ_x1) ξ(1 − ξ)(1 − 2ξ)` (and the end slopes by
//! `n_y θ_x'`), odd about the element's middle, so the frequencies still converge; the rate is
//! measured in the tests. `M_NSI` is the linear twist's `NSI·L/6 [[2, 1], [1, 2]]`.
//! **Lumped** (Nastran's default): femu's lumped beam puts half the translational mass, half
//! the torsional inertia `ρI_pL/2` and the rotary and HRZ shares at each end; the same
//! transforms make those halves point masses at `N` and `M`, rigidly linked to `S` (Nastran's
//! lumped beam has no torsional inertia of its own; femu's keeps `ρI_pL/2`, as it does without
//! offsets), and `NSI·L/2` on each twist.
//!
//! **Tapers.** The offsets are constant along the element (PBEAM's end-A and end-B values must
//! agree; the importer refuses differing ones).

use super::beam::{LocalPair, Scalar, pair};
use super::element::{ElementError, MassKind};

/// Where a beam's centroid and non-structural mass lie relative to its axis (the shear centre),
/// in element `y`, `z`; all zero for a beam whose axis carries both (the default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SectionCentres {
    /// Centroid (neutral axis) from the shear centre, `(y, z)`, m (PBEAM N1, N2).
    pub neutral_axis: [f64; 2],
    /// Centre of gravity of the non-structural mass from the shear centre, `(y, z)`, m (PBEAM
    /// M1, M2).
    pub nsm_cg: [f64; 2],
    /// Mass moment of inertia per length of the non-structural mass about its centre of
    /// gravity (about the element `x` direction), kg·m (PBEAM NSI).
    pub nsi: f64,
}

impl SectionCentres {
    /// Whether every offset and NSI is zero: the plain beam.
    pub fn is_zero(&self) -> bool {
        *self == SectionCentres::default()
    }

    /// Finite offsets and a finite, non-negative NSI.
    pub fn validate(&self) -> Result<(), ElementError> {
        for (field, v) in [("neutral_axis", self.neutral_axis), ("nsm_cg", self.nsm_cg)] {
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(ElementError::BadValue {
                    field,
                    value: *x,
                    hint: "every offset must be finite",
                });
            }
        }
        if !(self.nsi.is_finite() && self.nsi >= 0.0) {
            return Err(ElementError::BadValue {
                field: "nsi",
                value: self.nsi,
                hint: "the non-structural mass moment of inertia must be finite and >= 0",
            });
        }
        Ok(())
    }
}

/// The `12 × 12` transform from the shear centre's DOFs to those of the section point at
/// `p = (p_y, p_z)` (see the module doc); only the axial rows when `axial_only`.
pub(super) fn rigid(p: [f64; 2], axial_only: bool) -> [[f64; 12]; 12] {
    let mut t = [[0.0; 12]; 12];
    for (i, row) in t.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let [py, pz] = p;
    for b in [0, 6] {
        t[b][b + 4] = pz;
        t[b][b + 5] = -py;
        if !axial_only {
            t[b + 1][b + 3] = -pz;
            t[b + 2][b + 3] = py;
        }
    }
    t
}

/// `Tᵀ A T` (skipping the zero entries of `T`, so an identity `T` returns `A` exactly).
pub(super) fn congruence<T: Scalar>(a: &[[T; 12]; 12], t: &[[f64; 12]; 12]) -> [[T; 12]; 12] {
    let zero = T::cst(0.0);
    let mut at = [[zero; 12]; 12];
    for i in 0..12 {
        for j in 0..12 {
            let mut v = zero;
            for (s, t_row) in t.iter().enumerate() {
                if t_row[j] != 0.0 {
                    v = v + a[i][s] * T::cst(t_row[j]);
                }
            }
            at[i][j] = v;
        }
    }
    let mut out = [[zero; 12]; 12];
    for i in 0..12 {
        for j in 0..12 {
            let mut v = zero;
            for (s, t_row) in t.iter().enumerate() {
                if t_row[i] != 0.0 {
                    v = v + T::cst(t_row[i]) * at[s][j];
                }
            }
            out[i][j] = v;
        }
    }
    out
}

/// The local stiffness and mass about the shear centre from the centroidal stiffness `k` and
/// the three parts of the mass, `[rotary, structural, nsm]`: the rotary and torsional inertia
/// of the section (`ρI_y`, `ρI_z`, `ρI_p`; not moved), the structural translational inertia
/// (`ρA`, moved to the centroid) and the non-structural one (moved to its centre of gravity),
/// all in the local frame (see the module doc).
pub(super) fn about_shear_centre<T: Scalar>(
    k: &[[T; 12]; 12],
    [m_rotary, m_structural, m_nsm]: [&[[T; 12]; 12]; 3],
    c: &SectionCentres,
    l: f64,
    kind: MassKind,
) -> LocalPair<T> {
    let k = congruence(k, &rigid(c.neutral_axis, true));
    let ms = congruence(m_structural, &rigid(c.neutral_axis, false));
    let mn = congruence(m_nsm, &rigid(c.nsm_cg, false));
    let mut m = ms;
    for (row, add) in m.iter_mut().zip(m_rotary) {
        for (x, y) in row.iter_mut().zip(add) {
            *x = *x + *y;
        }
    }
    for (row, add) in m.iter_mut().zip(&mn) {
        for (x, y) in row.iter_mut().zip(add) {
            *x = *x + *y;
        }
    }
    if c.nsi != 0.0 {
        let (diag, off) = match kind {
            MassKind::Consistent => (c.nsi * l / 3.0, c.nsi * l / 6.0),
            MassKind::Lumped => (c.nsi * l / 2.0, 0.0),
        };
        pair(&mut m, 3, 9, T::cst(diag), T::cst(off));
    }
    (k, m)
}

#[cfg(test)]
#[path = "beam_offset_tests.rs"]
mod tests;
