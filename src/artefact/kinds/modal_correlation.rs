//! The `modal_correlation` kind: two sets of modes compared (thesis §1.4, 3.54), as tables a
//! user can plot without femu.
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `pairs` | `reference_mode, predicted_mode, reference_hz, predicted_hz, eigenvalue_error, frequency_error, mac, in_band` |
//! | `mac` | `reference_mode, predicted_mode, mac` (every elastic pair) |
//! | `comac` | `dof, comac` |

use super::{ColumnLayout, Kind, Layout, col, expect_kind, meta, meta_value, parse_dofs, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::correlation::ModeCorrelation;
use faer::Mat;

/// What the tables are read against.
#[derive(Clone, Debug)]
pub struct ModalCorrelationContext<'a> {
    /// Natural frequencies of every reference mode, Hz.
    pub reference_hz: &'a [f64],
    /// Natural frequencies of every predicted mode, Hz.
    pub predicted_hz: &'a [f64],
    /// Rigid-body modes left out, (reference, predicted).
    pub rigid_body_modes: (usize, usize),
    /// Rows the shapes were compared over.
    pub dofs: &'a [DofId],
    /// Top of the validity band, Hz (pairs above it are `in_band = 0`).
    pub band_hz: Option<f64>,
    /// How pairs were found (`mac` or `order`) and the lowest MAC accepted.
    pub pairing: (&'a str, f64),
}

/// One row of `pairs`.
#[derive(Clone, Debug, PartialEq)]
pub struct PairRow {
    /// Reference mode, 1-based over all modes.
    pub reference_mode: usize,
    /// Its partner, 1-based over all modes.
    pub predicted_mode: usize,
    /// Reference natural frequency, Hz.
    pub reference_hz: f64,
    /// Predicted natural frequency, Hz.
    pub predicted_hz: f64,
    /// `(λ − λ_ref)/λ_ref` (3.54).
    pub eigenvalue_error: f64,
    /// `(f − f_ref)/f_ref`.
    pub frequency_error: f64,
    /// MAC of the pair (1.18).
    pub mac: f64,
    /// Whether the reference mode is in the validity band.
    pub in_band: bool,
}

/// A modal correlation as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalCorrelationRecord {
    /// How pairs were found (`mac` or `order`).
    pub pairing: String,
    /// The lowest MAC accepted.
    pub min_mac_accepted: f64,
    /// Rigid-body modes left out, (reference, predicted).
    pub rigid_body_modes: (usize, usize),
    /// Top of the validity band, Hz.
    pub band_hz: Option<f64>,
    /// The pairs.
    pub pairs: Vec<PairRow>,
    /// MAC of every elastic reference (rows) and predicted (columns) mode.
    pub mac: Mat<f64>,
    /// Rows the shapes were compared over.
    pub dofs: Vec<DofId>,
    /// COMAC per row.
    pub comac: Vec<f64>,
    /// Reference modes without a partner, 1-based.
    pub unpaired_reference_modes: Vec<usize>,
}

impl ModalCorrelationRecord {
    /// The record of comparison `c` read against `at`.
    pub fn new(c: &ModeCorrelation, at: &ModalCorrelationContext) -> Self {
        let pairs = c
            .pairs
            .iter()
            .map(|p| PairRow {
                reference_mode: p.reference + 1,
                predicted_mode: p.predicted + 1,
                reference_hz: at.reference_hz[p.reference],
                predicted_hz: at.predicted_hz[p.predicted],
                eigenvalue_error: p.eigenvalue_error,
                frequency_error: p.frequency_error,
                mac: p.mac,
                in_band: at.band_hz.is_none_or(|b| at.reference_hz[p.reference] <= b),
            })
            .collect();
        ModalCorrelationRecord {
            pairing: at.pairing.0.to_string(),
            min_mac_accepted: at.pairing.1,
            rigid_body_modes: at.rigid_body_modes,
            band_hz: at.band_hz,
            pairs,
            mac: c.mac.clone(),
            dofs: at.dofs.to_vec(),
            comac: c.comac.clone(),
            unpaired_reference_modes: c.unpaired.iter().map(|r| r + 1).collect(),
        }
    }
}

/// The `modal_correlation` kind.
pub struct ModalCorrelationKind;

impl Kind for ModalCorrelationKind {
    const KIND: ArtefactKind = ArtefactKind::ModalCorrelation;
    const NAME: &'static str = "modal_correlation";
    type Value = ModalCorrelationRecord;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        Layout {
            tables: vec![
                table("pairs", s, true, pair_columns()),
                table(
                    "mac",
                    s,
                    true,
                    vec![
                        col(
                            "reference_mode",
                            "int64",
                            "",
                            "elastic reference mode, 1-based",
                        ),
                        col(
                            "predicted_mode",
                            "int64",
                            "",
                            "elastic predicted mode, 1-based",
                        ),
                        col("mac", "float64", "", "their MAC"),
                    ],
                ),
                table(
                    "comac",
                    s,
                    true,
                    vec![
                        col("dof", "string", "", "shape row node:comp"),
                        col("comac", "float64", "", "coordinate MAC over the pairs"),
                    ],
                ),
            ],
            meta: vec![
                meta("pairing", "mac or order"),
                meta("min_mac_accepted", "the lowest MAC a pair may have"),
                meta("rigid_body_modes", "rigid-body modes left out of each set"),
                meta("n_dofs", "rows the shapes were compared over"),
                meta("band_hz", "top of the validity band, null for none"),
                meta("n_pairs", "pairs"),
                meta("n_pairs_in_band", "pairs in the band"),
                meta(
                    "unpaired_reference_modes",
                    "reference modes without a partner",
                ),
                meta(
                    "max_abs_eigenvalue_error_in_band",
                    "largest |eigenvalue_error| in the band",
                ),
                meta("min_mac_in_band", "smallest MAC in the band, null if none"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(r: &ModalCorrelationRecord) -> Artefact {
        write(r)
    }

    fn from_artefact(a: &Artefact) -> Result<ModalCorrelationRecord, ArtefactError> {
        read(a)
    }
}

fn pair_columns() -> Vec<ColumnLayout> {
    vec![
        col(
            "reference_mode",
            "int64",
            "",
            "reference mode, 1-based over all modes",
        ),
        col(
            "predicted_mode",
            "int64",
            "",
            "its partner, 1-based over all modes",
        ),
        col(
            "reference_hz",
            "float64",
            "Hz",
            "reference natural frequency",
        ),
        col(
            "predicted_hz",
            "float64",
            "Hz",
            "predicted natural frequency",
        ),
        col(
            "eigenvalue_error",
            "float64",
            "",
            "relative eigenvalue error (lambda - lambda_ref)/lambda_ref (3.54)",
        ),
        col("frequency_error", "float64", "", "(f - f_ref)/f_ref"),
        col(
            "mac",
            "float64",
            "",
            "modal assurance criterion of the pair (1.18)",
        ),
        col(
            "in_band",
            "int64",
            "",
            "1 when the reference mode is in the validity band",
        ),
    ]
}

/// The comparison as an artefact; its meta holds the summary: pairs, unpaired reference modes,
/// the largest `|ε_λ|` and the smallest MAC among in-band pairs.
pub fn modal_correlation_to_artefact(
    c: &ModeCorrelation,
    at: &ModalCorrelationContext,
) -> Artefact {
    write(&ModalCorrelationRecord::new(c, at))
}

fn write(r: &ModalCorrelationRecord) -> Artefact {
    let p = &r.pairs;
    let i = |f: fn(&PairRow) -> usize| Column::I64(p.iter().map(|x| f(x) as i64).collect());
    let f = |f: fn(&PairRow) -> f64| Column::F64(p.iter().map(f).collect());
    let pairs = Table::new()
        .with("reference_mode", i(|x| x.reference_mode))
        .with("predicted_mode", i(|x| x.predicted_mode))
        .with("reference_hz", f(|x| x.reference_hz))
        .with("predicted_hz", f(|x| x.predicted_hz))
        .with("eigenvalue_error", f(|x| x.eigenvalue_error))
        .with("frequency_error", f(|x| x.frequency_error))
        .with("mac", f(|x| x.mac))
        .with("in_band", i(|x| x.in_band as usize));
    let (rr, pr) = r.rigid_body_modes;
    let (mut ri, mut pj, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..r.mac.nrows() {
        for j in 0..r.mac.ncols() {
            ri.push((i + rr + 1) as i64);
            pj.push((j + pr + 1) as i64);
            v.push(r.mac[(i, j)]);
        }
    }
    let mac = Table::new()
        .with("reference_mode", Column::I64(ri))
        .with("predicted_mode", Column::I64(pj))
        .with("mac", Column::F64(v));
    let comac = Table::new()
        .with("dof", super::dof_strs(&r.dofs))
        .with("comac", Column::F64(r.comac.clone()));
    let banded = || p.iter().filter(|x| x.in_band);
    let max_error = banded()
        .map(|x| x.eigenvalue_error.abs())
        .fold(0.0, f64::max);
    let min_mac = banded().map(|x| x.mac).fold(f64::INFINITY, f64::min);
    Artefact::new(ModalCorrelationKind::KIND)
        .with_meta("pairing", r.pairing.as_str().into())
        .with_meta("min_mac_accepted", r.min_mac_accepted.into())
        .with_meta(
            "rigid_body_modes",
            serde_json::json!({"reference": rr, "predicted": pr}),
        )
        .with_meta("n_dofs", r.dofs.len().into())
        .with_meta("band_hz", r.band_hz.into())
        .with_meta("n_pairs", p.len().into())
        .with_meta("n_pairs_in_band", banded().count().into())
        .with_meta(
            "unpaired_reference_modes",
            r.unpaired_reference_modes.clone().into(),
        )
        .with_meta("max_abs_eigenvalue_error_in_band", max_error.into())
        .with_meta(
            "min_mac_in_band",
            if min_mac.is_finite() {
                min_mac.into()
            } else {
                serde_json::Value::Null
            },
        )
        .with_table("pairs", pairs, Storage::Parquet)
        .with_table("mac", mac, Storage::Parquet)
        .with_table("comac", comac, Storage::Parquet)
}

fn read(a: &Artefact) -> Result<ModalCorrelationRecord, ArtefactError> {
    let kind = ModalCorrelationKind::KIND;
    expect_kind(a, kind)?;
    let index = |v: i64, table: &str| {
        usize::try_from(v)
            .map_err(|_| ArtefactError::schema(kind, format!("table `{table}`: mode {v} < 0")))
    };
    let n = "pairs";
    let t = a.table(n)?;
    let (rm, pm, in_band) = (
        t.i64s(n, "reference_mode")?,
        t.i64s(n, "predicted_mode")?,
        t.i64s(n, "in_band")?,
    );
    let f = |c: &str| t.f64s(n, c);
    let (rh, ph, ee, fe, mac) = (
        f("reference_hz")?,
        f("predicted_hz")?,
        f("eigenvalue_error")?,
        f("frequency_error")?,
        f("mac")?,
    );
    let pairs = (0..rm.len())
        .map(|k| {
            Ok(PairRow {
                reference_mode: index(rm[k], n)?,
                predicted_mode: index(pm[k], n)?,
                reference_hz: rh[k],
                predicted_hz: ph[k],
                eigenvalue_error: ee[k],
                frequency_error: fe[k],
                mac: mac[k],
                in_band: in_band[k] != 0,
            })
        })
        .collect::<Result<Vec<_>, ArtefactError>>()?;
    #[derive(serde::Deserialize)]
    struct Rigid {
        reference: usize,
        predicted: usize,
    }
    let rigid: Rigid = meta_value(a, "rigid_body_modes")?;
    let t = a.table("comac")?;
    Ok(ModalCorrelationRecord {
        pairing: a.meta_str("pairing")?.to_string(),
        min_mac_accepted: meta_value(a, "min_mac_accepted")?,
        rigid_body_modes: (rigid.reference, rigid.predicted),
        band_hz: meta_value(a, "band_hz")?,
        pairs,
        mac: read_mac(a)?,
        dofs: parse_dofs(kind, "comac", t.strs("comac", "dof")?)?,
        comac: t.f64s("comac", "comac")?.to_vec(),
        unpaired_reference_modes: meta_value(a, "unpaired_reference_modes")?,
    })
}

/// The elastic MAC matrix from its row-major table (a row per reference mode's run of
/// predicted modes).
fn read_mac(a: &Artefact) -> Result<Mat<f64>, ArtefactError> {
    let t = a.table("mac")?;
    let rm = t.i64s("mac", "reference_mode")?;
    let v = t.f64s("mac", "mac")?;
    let cols = rm.iter().take_while(|r| Some(*r) == rm.first()).count();
    if cols == 0 {
        return Ok(Mat::zeros(0, 0));
    }
    if v.len() % cols != 0 {
        return Err(ArtefactError::schema(
            ModalCorrelationKind::KIND,
            format!("table `mac`: {} rows are not whole runs of {cols}", v.len()),
        ));
    }
    Ok(Mat::from_fn(v.len() / cols, cols, |i, j| v[i * cols + j]))
}
