//! The `modes` kind: natural frequencies and mass-normalised mode shapes.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `frequencies` (Parquet) | `mode, freq_hz, eigenvalue_rad2_s2, residual` |
//! | `shapes` (IPC) | `dof, phi_1 … phi_m` |
//! | `dependent_shapes` (IPC; when the model has rigid elements or MPCs) | `dof, phi_1 … phi_m`: the shapes at the DOFs the constraints eliminated, recovered as `u_d = Σ c u` |
//! | `test` (Parquet; modes read from a test) | `mode, source_mode, damping_ratio, collinearity, modal_mass` |
//!
//! Modes of a model are mass-normalised (`normalisation: mass`); modes read from a test keep
//! their measured scale (`normalisation: as_measured`, residual NaN: no model to have one).

use super::{Kind, Layout, col, expect_kind, meta, meta_opt, parse_dofs, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::eigen::Modes;
use faer::Mat;

/// Modes with their DOF labels.
#[derive(Clone, Debug)]
pub struct ModesArtefact {
    /// Row labels of the shapes.
    pub dofs: Vec<DofId>,
    /// The modes.
    pub modes: Modes,
}

/// The `modes` kind.
pub struct ModesKind;

impl Kind for ModesKind {
    const KIND: ArtefactKind = ArtefactKind::Modes;
    const NAME: &'static str = "modes";
    type Value = ModesArtefact;

    fn layout() -> Layout {
        Layout {
            tables: vec![
                table(
                    "frequencies",
                    Storage::Parquet,
                    true,
                    vec![
                        col("mode", "int64", "", "mode number from 1"),
                        col("freq_hz", "float64", "Hz", "natural frequency"),
                        col(
                            "eigenvalue_rad2_s2",
                            "float64",
                            "rad^2/s^2",
                            "eigenvalue omega^2",
                        ),
                        col(
                            "residual",
                            "float64",
                            "",
                            "relative residual |K phi - lambda M phi| / |K phi|",
                        ),
                    ],
                ),
                table(
                    "shapes",
                    Storage::Ipc,
                    true,
                    vec![
                        col("dof", "string", "", "DOF label node:comp"),
                        col(
                            "phi_{r}",
                            "float64",
                            "1/sqrt(kg)",
                            "mass-normalised shape of mode r, one column per mode",
                        ),
                    ],
                ),
                table(
                    "dependent_shapes",
                    Storage::Ipc,
                    false,
                    vec![
                        col("dof", "string", "", "dependent DOF label node:comp"),
                        col(
                            "phi_{r}",
                            "float64",
                            "1/sqrt(kg)",
                            "shape of mode r at the dependent DOF",
                        ),
                    ],
                ),
                table(
                    "test",
                    Storage::Parquet,
                    false,
                    vec![
                        col("mode", "int64", "", "mode number from 1"),
                        col("source_mode", "int64", "", "mode number in the test file"),
                        col(
                            "damping_ratio",
                            "float64",
                            "",
                            "modal viscous damping ratio",
                        ),
                        col(
                            "collinearity",
                            "float64",
                            "",
                            "mode phase collinearity of the measured shape (1: real)",
                        ),
                        col(
                            "modal_mass",
                            "float64",
                            "",
                            "modal mass as written in the test file (0: not given)",
                        ),
                    ],
                ),
            ],
            meta: vec![
                meta("n_modes", "number of modes"),
                meta("n_dofs", "rows of the shapes"),
                meta("rigid_body_modes", "modes at zero frequency"),
                meta(
                    "orthogonality_error",
                    "deviation of the shapes from mass-orthonormality",
                ),
                meta("dof_index", "digest of the DOF list"),
                meta(
                    "normalisation",
                    "`mass`, or `as_measured` for modes read from a test",
                ),
                meta_opt("import_notes", "test modes: what was converted or assumed"),
                meta("units", "unit of each column"),
                meta_opt("reduced_coords", "coordinates of the reduced model solved"),
                meta_opt("reduced_physical", "its physical coordinates"),
                meta_opt("reduced_modal", "its modal coordinates"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(v: &ModesArtefact) -> Artefact {
        write(&v.dofs, &v.modes)
    }

    /// The rigid-body count is that of zero eigenvalues; the residuals and orthogonality error
    /// are as written.
    fn from_artefact(a: &Artefact) -> Result<ModesArtefact, ArtefactError> {
        let kind = Self::KIND;
        expect_kind(a, kind)?;
        let f = a.table("frequencies")?;
        let lambdas = f.f64s("frequencies", "eigenvalue_rad2_s2")?.to_vec();
        let residuals = f.f64s("frequencies", "residual")?.to_vec();
        let s = a.table("shapes")?;
        let dofs = parse_dofs(kind, "shapes", s.strs("shapes", "dof")?)?;
        let mut shapes = Mat::<f64>::zeros(dofs.len(), lambdas.len());
        for r in 0..lambdas.len() {
            let col = s.f64s("shapes", &format!("phi_{}", r + 1))?;
            for (i, v) in col.iter().enumerate() {
                shapes[(i, r)] = *v;
            }
        }
        Ok(ModesArtefact {
            dofs,
            modes: Modes {
                rigid_body_modes: lambdas.iter().filter(|l| **l == 0.0).count(),
                orthogonality_error: a
                    .meta
                    .get("orthogonality_error")
                    .and_then(|v| v.as_f64())
                    .unwrap_or(0.0),
                eigenvalues: lambdas,
                shapes,
                residuals,
            },
        })
    }
}

fn write(dofs: &[DofId], modes: &Modes) -> Artefact {
    let m = modes.len();
    let freqs = Table::new()
        .with("mode", Column::I64((1..=m as i64).collect()))
        .with("freq_hz", Column::F64(modes.frequencies_hz()))
        .with("eigenvalue_rad2_s2", Column::F64(modes.eigenvalues.clone()))
        .with("residual", Column::F64(modes.residuals.clone()));
    let shapes = shape_columns(
        Table::new().with("dof", super::dof_strs(dofs)),
        modes.shapes.as_ref(),
    );
    Artefact::new(ModesKind::KIND)
        .with_meta("n_modes", m.into())
        .with_meta("n_dofs", dofs.len().into())
        .with_meta("rigid_body_modes", modes.rigid_body_modes.into())
        .with_meta("orthogonality_error", modes.orthogonality_error.into())
        .with_meta("dof_index", super::dof_index_digest(dofs).into())
        .with_meta("normalisation", "mass".into())
        .with_meta("units", serde_json::json!({"freq_hz": "Hz", "eigenvalue_rad2_s2": "rad^2/s^2", "phi": "1/sqrt(kg)"}))
        .with_table("frequencies", freqs, Storage::Parquet)
        .with_table("shapes", shapes, Storage::Ipc)
}

/// Modes read from a test as an artefact: shapes at the test DOFs in their measured scale, with
/// damping ratios, phase collinearity and modal masses in the `test` table.
pub fn test_modes_to_artefact(t: &crate::frf::io::uff::TestModes) -> Artefact {
    let m = t.freqs_hz.len();
    let modes = Modes {
        eigenvalues: t
            .freqs_hz
            .iter()
            .map(|f| (2.0 * std::f64::consts::PI * f).powi(2))
            .collect(),
        shapes: t.shapes.clone(),
        residuals: vec![f64::NAN; m],
        orthogonality_error: f64::NAN,
        rigid_body_modes: t.freqs_hz.iter().filter(|f| **f == 0.0).count(),
    };
    let test = Table::new()
        .with("mode", Column::I64((1..=m as i64).collect()))
        .with("source_mode", Column::I64(t.source_mode.clone()))
        .with("damping_ratio", Column::F64(t.damping_ratios.clone()))
        .with("collinearity", Column::F64(t.collinearity.clone()))
        .with("modal_mass", Column::F64(t.modal_mass.clone()));
    write(&t.dofs, &modes)
        .with_meta("normalisation", "as_measured".into())
        .with_meta(
            "units",
            serde_json::json!({"freq_hz": "Hz", "eigenvalue_rad2_s2": "rad^2/s^2", "phi": "as measured"}),
        )
        .with_meta("import_notes", t.notes.clone().into())
        .with_table("test", test, Storage::Parquet)
}

/// The `dependent_shapes` table: shapes (one column per mode) at the dependent DOFs `dofs`.
pub fn dependent_shapes_table(dofs: &[DofId], shapes: faer::MatRef<'_, f64>) -> Table {
    shape_columns(Table::new().with("dof", super::dof_strs(dofs)), shapes)
}

/// `table` with the columns `phi_1, phi_2, …` of `shapes`, copied side by side (400 MB for 50
/// modes at a million DOFs).
fn shape_columns(table: Table, shapes: faer::MatRef<'_, f64>) -> Table {
    use rayon::prelude::*;
    let columns: Vec<Vec<f64>> = (0..shapes.ncols())
        .into_par_iter()
        .map(|r| shapes.col(r).iter().copied().collect())
        .collect();
    columns.into_iter().enumerate().fold(table, |t, (r, c)| {
        t.with(format!("phi_{}", r + 1), Column::F64(c))
    })
}

/// Modes as an artefact.
pub fn modes_to_artefact(dofs: &[DofId], modes: &Modes) -> Artefact {
    write(dofs, modes)
}

/// Modes from an artefact.
pub fn modes_from_artefact(a: &Artefact) -> Result<ModesArtefact, ArtefactError> {
    ModesKind::from_artefact(a)
}
