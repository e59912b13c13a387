//! `frf.import`: measured FRFs from a Universal File (dataset 58, ASCII or binary 58b) or from a
//! long-format table (CSV or Parquet: `freq_hz, response, excitation, re, im`, with a `quantity`
//! or `unit` column or parameter), converted to SI with every conversion recorded. The reader
//! is chosen by `format:`, else by the extension (`.csv`, `.parquet`, anything else UFF). The file is
//! read when the pipeline is checked (through [`crate::core::input`]: regular files only,
//! bounded size), so a malformed record or a NaN or infinite measured value is reported then;
//! the cache key holds the digests of the FRFs and of the test geometry, not the path.
//!
//! A Universal File's nodes (datasets 15/2411, in global SI coordinates) leave as the second
//! output, `geometry`, with each node's displacement frame (its displacement coordinate system's
//! directions at the node; global when 0 or not defined) and the trace lines (dataset 82), for
//! `test.pair`. Tables and files without nodes give an empty geometry.

use crate::artefact::ArtefactKind;
use crate::artefact::Column;
use crate::artefact::kinds::frf_to_artefact;
use crate::artefact::kinds::test_geometry::test_geometry_to_artefact;
use crate::frf::io::table::{LongTable, parse_csv, table_to_frf_set};
use crate::frf::io::uff::{UffError, UffFile, read_uff, to_frf_set};
use crate::frf::{FrfSet, Quantity};
use crate::pairing::{TestGeometry, TestPoint};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::path::Path;

/// The stage.
pub struct FrfImport;

/// The file formats `frf.import` reads.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum FrfFormat {
    /// Universal File, datasets 58/58b.
    Uff,
    /// Long-format CSV table.
    Csv,
    /// Long-format Parquet table (any codec pandas/pyarrow write).
    Parquet,
}

/// Parameters of `frf.import`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Universal File (`.uff`, `.unv`) or long-format table (`.csv`, `.parquet`), relative to
    /// the pipeline file.
    pub path: String,
    /// The reader, when the extension does not tell.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub format: Option<FrfFormat>,
    /// Tables only: the quantity of the values, when no `quantity` column gives it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quantity: Option<Quantity>,
    /// Tables only: the unit of the values (e.g. `m/s^2/N`, `g/N`, `mm/N`), when no `unit`
    /// column gives it; converted to SI.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Digest of the imported FRFs, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub content_digest: Option<String>,
    /// Digest of the imported test geometry, filled in when the pipeline is checked (not for
    /// users).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry_digest: Option<String>,
}

/// The test geometry of a Universal File: its nodes with their displacement frames, and its
/// trace lines.
pub fn geometry_of(file: &UffFile) -> TestGeometry {
    let mut g = TestGeometry::default();
    for (k, (node, xyz)) in file.nodes.iter().enumerate() {
        let [def, disp, _] = file.node_systems.get(k).copied().unwrap_or([0; 3]);
        let axes = file
            .coordinate_systems
            .iter()
            .find(|c| disp != 0 && c.id == disp)
            .map(|c| c.directions_at(*xyz));
        g.points.push(match axes {
            Some(axes) => TestPoint {
                node: *node,
                xyz: *xyz,
                axes,
            },
            None => TestPoint::global(*node, *xyz),
        });
        g.systems.push([def, disp]);
    }
    g.trace_lines = file
        .trace_lines
        .iter()
        .map(|t| (t.id, t.nodes.clone()))
        .collect();
    g
}

/// The reader for a path: `format`, else the extension (`.csv`, `.parquet`; anything else UFF).
fn format_of(p: &Params) -> FrfFormat {
    if let Some(f) = p.format {
        return f;
    }
    let ext = Path::new(&p.path)
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    // Any other extension is read as a Universal File, as before tables were read.
    match ext.as_deref() {
        Some("csv") => FrfFormat::Csv,
        Some("parquet" | "pq") => FrfFormat::Parquet,
        _ => FrfFormat::Uff,
    }
}

/// A Parquet long table, read under the input policy.
fn parquet_table(full: &Path) -> Result<LongTable, String> {
    let file = full.display().to_string();
    crate::core::input::read_input(full).map_err(|e| format!("{file}: {e}"))?;
    let t = crate::artefact::codec::read_parquet(full).map_err(|e| e.to_string())?;
    let bad = |e: crate::artefact::TableError| format!("{file}: {e}");
    let strs = |c: &str| -> Option<Vec<String>> {
        match t.column(c) {
            Some(Column::Str(v)) => Some(v.clone()),
            _ => None,
        }
    };
    Ok(LongTable {
        file: file.clone(),
        csv: false,
        freq_hz: t.f64s(&file, "freq_hz").map_err(bad)?.to_vec(),
        response: t.strs(&file, "response").map_err(bad)?.to_vec(),
        excitation: t.strs(&file, "excitation").map_err(bad)?.to_vec(),
        re: t.f64s(&file, "re").map_err(bad)?.to_vec(),
        im: t.f64s(&file, "im").map_err(bad)?.to_vec(),
        quantity: strs("quantity"),
        unit: strs("unit"),
    })
}

/// What a file gives: the FRFs, the test geometry (empty for tables) and the notes.
type Imported = (FrfSet, TestGeometry, Vec<String>);

fn import(base: &Path, p: &Params) -> Result<Imported, String> {
    let full = base.join(&p.path);
    let format = format_of(p);
    if format == FrfFormat::Uff && (p.quantity.is_some() || p.unit.is_some()) {
        return Err(format!(
            "{}: `quantity` and `unit` are for tables; a Universal File says them in records 9-10",
            p.path
        ));
    }
    let (table, mut notes) = match format {
        FrfFormat::Uff => {
            let file = read_uff(&full).map_err(|e| e.to_string())?;
            let set = to_frf_set(&file.frfs).map_err(|e| match e {
                UffError::NoFrfs => format!("{}: {e}", full.display()),
                e => e.to_string(),
            })?;
            let mut notes = crate::frf::io::uff::grouped_conversions(&file);
            notes.extend(file.warnings.iter().cloned());
            if let Some(h) = &file.header {
                notes.push(format!(
                    "{}: header (dataset 151, line {}): model `{}`, written by `{}` on `{}`",
                    full.display(),
                    h.line,
                    h.model,
                    h.program,
                    h.written
                ));
            }
            return Ok((set, geometry_of(&file), notes));
        }
        FrfFormat::Csv => {
            let bytes = crate::core::input::read_input(&full)
                .map_err(|e| format!("{}: {e}", full.display()))?;
            let text = String::from_utf8(bytes)
                .map_err(|_| format!("{}: not UTF-8 text", full.display()))?;
            parse_csv(&text, &full.display().to_string())?
        }
        FrfFormat::Parquet => (parquet_table(&full)?, Vec::new()),
    };
    let (set, more) = table_to_frf_set(&table, p.quantity.map(|q| q.name()), p.unit.as_deref())?;
    notes.extend(more);
    Ok((set, TestGeometry::default(), notes))
}

impl TypedStage for FrfImport {
    type Params = Params;
    const KIND: &'static str = "frf.import";
    const SUMMARY: &'static str = "Measured FRFs from a Universal File (dataset 58/58b) or a CSV/Parquet long table, converted to SI";
    // 2: the test geometry is a second output; 3: a note many FRF records share is recorded
    // once, with the records it applies to; 4: nodes in local displacement systems are named
    // in one warning.
    const IMPL_VERSION: u32 = 4;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("frf", ArtefactKind::Frf, "the measured FRFs"),
            PortSpec::required(
                "geometry",
                ArtefactKind::TestGeometry,
                "the test points of datasets 15/2411 with their displacement frames (empty for tables and files without nodes)",
            ),
        ]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        match import(&ctx.base_dir, p) {
            Ok((set, geometry, _)) => {
                p.content_digest = Some(frf_to_artefact(&set).digest());
                p.geometry_digest = Some(test_geometry_to_artefact(&geometry).digest());
                Vec::new()
            }
            Err(e) => vec![ParamIssue::at("path", e)],
        }
    }

    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        crate::pipeline::stage::without_path(params)
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        // Normally found when checking; here only when the file changed since.
        let (set, geometry, notes) =
            import(&inputs.base_dir, p).map_err(StageError::input_at("path"))?;
        let a = frf_to_artefact(&set);
        let g = test_geometry_to_artefact(&geometry);
        if p.content_digest.as_deref() != Some(a.digest().as_str())
            || p.geometry_digest.as_deref() != Some(g.digest().as_str())
        {
            return Err(StageError::input(
                "path",
                format!(
                    "{} changed between checking and running the pipeline; run again",
                    p.path
                ),
            ));
        }
        let a = a.with_meta("import_notes", notes.into());
        Ok(StageOutputs::from([
            ("frf".to_string(), a),
            ("geometry".to_string(), g),
        ]))
    }
}
