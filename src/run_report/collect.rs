//! What the report shows, read from a run's output directory: the lock file's stages and wiring,
//! and every artefact, turned into plain views (numbers and names) for the page.

use super::record::{RUN_RECORD_FILE, RunRecord, stage_warnings};
use super::{ReportError, ReportOptions};
use crate::artefact::codec::read_dir;
use crate::artefact::kinds::{correlation_from_artefact, frf_from_artefact};
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::{Artefact, ArtefactKind, Column, Table};
use crate::model::{Element, Model};
use crate::pipeline::lock::{LockFile, OUT_LOCK_FILE};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// FRFs drawn per artefact; the rest are listed, not drawn (a page must stay openable).
pub const MAX_FRF_PAIRS: usize = 64;
/// Lines drawn per FRF.
pub const MAX_FRF_LINES: usize = 20_000;
/// Faces drawn per mesh; larger meshes are listed, not drawn.
pub const MAX_MESH_FACES: usize = 200_000;
/// Rows shown per table.
pub const TABLE_ROWS: usize = 50;

/// Cached or ran, and how long a stage took.
#[derive(Clone, Debug, Serialize)]
pub struct StageTiming {
    /// `ran`, `cached`, `recovered`, … as `femu run` prints it.
    pub status: String,
    /// Wall time, s.
    pub seconds: f64,
}

/// One stage of the run.
#[derive(Clone, Debug, Serialize)]
pub struct StageView {
    /// Stage name.
    pub name: String,
    /// Stage kind.
    pub kind: String,
    /// Input port → `stage.port`.
    pub inputs: BTreeMap<String, String>,
    /// Outputs: port, artefact kind, digest.
    pub outputs: Vec<(String, String, String)>,
    /// Cached or ran and the time, when known.
    pub timing: Option<StageTiming>,
    /// Parameters as run (with defaults).
    pub params: serde_json::Value,
}

/// One FRF set, drawn in the FRF viewer.
#[derive(Clone, Debug, Serialize)]
pub struct FrfView {
    /// `stage.port`.
    pub id: String,
    /// Quantity name and its SI unit.
    pub quantity: String,
    /// Unit of the values.
    pub unit: String,
    /// Lines, Hz.
    pub freqs: Vec<Option<f64>>,
    /// Drawn FRFs.
    pub pairs: Vec<PairView>,
    /// FRFs in the artefact beyond [`MAX_FRF_PAIRS`], not drawn.
    pub omitted_pairs: usize,
}

/// One FRF: its label and complex values.
#[derive(Clone, Debug, Serialize)]
pub struct PairView {
    /// `response/excitation`.
    pub label: String,
    /// Real parts per line (null when not finite).
    pub re: Vec<Option<f64>>,
    /// Imaginary parts per line.
    pub im: Vec<Option<f64>>,
}

/// One FRF correlation: `χ_s`, `χ_a` per line and FRAC per FRF, with the sets it compared.
#[derive(Clone, Debug, Serialize)]
pub struct CorrelationView {
    /// `stage.port`.
    pub id: String,
    /// `stage.port` of the measured and predicted FRFs, when wired in this run.
    pub measured: Option<String>,
    /// See `measured`.
    pub predicted: Option<String>,
    /// Lines, Hz.
    pub freqs: Vec<Option<f64>>,
    /// `χ_s` per line (4.8).
    pub chi_s: Vec<Option<f64>>,
    /// `χ_a` per line (4.9).
    pub chi_a: Vec<Option<f64>>,
    /// FRAC per FRF (1.19): label, value.
    pub frac: Vec<(String, Option<f64>)>,
}

/// A mesh for the 3-D viewer: coordinates and faces by element.
#[derive(Clone, Debug, Serialize)]
pub struct MeshView {
    /// `stage.port`.
    pub id: String,
    /// Node coordinates, m, flattened `[x0, y0, z0, x1, …]`.
    pub xyz: Vec<f64>,
    /// Faces and lines: node indices into `xyz / 3`.
    pub faces: Vec<Vec<u32>>,
    /// The element of each face.
    pub face_element: Vec<u64>,
    /// Elements not drawn (scalar springs, masses, too many faces), with the reason.
    pub note: Option<String>,
}

/// A value per element drawn on a mesh (the leverage map).
#[derive(Clone, Debug, Serialize)]
pub struct FieldView {
    /// `stage.port`.
    pub id: String,
    /// The mesh (`stage.port`) it is drawn on.
    pub mesh: String,
    /// What the value is.
    pub label: String,
    /// Element id → value.
    pub values: BTreeMap<u64, f64>,
}

/// The updating history.
#[derive(Clone, Debug, Serialize)]
pub struct UpdateView {
    /// `stage.port`.
    pub id: String,
    /// Method and why it stopped.
    pub method: String,
    /// See `method`.
    pub stop: String,
    /// Iteration numbers.
    pub iterations: Vec<i64>,
    /// Mean `χ_s`, `χ_a` per iteration.
    pub mean_chi_s: Vec<Option<f64>>,
    /// See `mean_chi_s`.
    pub mean_chi_a: Vec<Option<f64>>,
    /// Parameter names.
    pub parameters: Vec<String>,
    /// `values[p][k] / initial[p]` per iteration.
    pub relative: Vec<Vec<Option<f64>>>,
}

/// A MAC matrix for the heat map.
#[derive(Clone, Debug)]
pub struct MacView {
    /// `stage.port`.
    pub id: String,
    /// Reference and predicted mode numbers (axes).
    pub reference: Vec<i64>,
    /// See `reference`.
    pub predicted: Vec<i64>,
    /// `(reference, predicted) → MAC`.
    pub mac: BTreeMap<(i64, i64), f64>,
    /// Pairs chosen, `(reference, predicted)`.
    pub pairs: BTreeSet<(i64, i64)>,
}

/// One aligned test point and what it was paired to.
#[derive(Clone, Debug, Serialize)]
pub struct TestPointView {
    /// Test node label.
    pub node: i64,
    /// Aligned position in model coordinates, m.
    pub xyz: [f64; 3],
    /// `node` or `element`.
    pub method: String,
    /// The grid paired to, if paired to a node.
    pub fe_node: Option<i64>,
    /// The element interpolated in, if paired to an element.
    pub fe_element: Option<i64>,
    /// Pairing distance, m (null when not finite).
    pub distance_m: Option<f64>,
    /// `ok` or `beyond_tolerance`.
    pub status: String,
}

/// The test points of a `test_map`, drawn on the mesh they were paired to.
#[derive(Clone, Debug, Serialize)]
pub struct TestPointsView {
    /// `stage.port`.
    pub id: String,
    /// The mesh (`stage.port`) they were paired to, when wired in this run and drawn.
    pub mesh: Option<String>,
    /// The largest accepted distance, m.
    pub tolerance_m: Option<f64>,
    /// The points, in the table's order.
    pub points: Vec<TestPointView>,
}

/// One parameter's marginal posterior.
#[derive(Clone, Debug, Serialize)]
pub struct ParameterPosterior {
    /// Parameter name.
    pub name: String,
    /// The update's result.
    pub updated: Option<f64>,
    /// Posterior mean.
    pub mean: Option<f64>,
    /// Posterior standard deviation.
    pub sd: Option<f64>,
    /// Credible interval, lower end.
    pub lower: Option<f64>,
    /// Credible interval, upper end.
    pub upper: Option<f64>,
    /// Split `R̂` of a Markov-chain sampler's draws.
    pub r_hat: Option<f64>,
    /// Effective sample size of a Markov-chain sampler's draws.
    pub ess: Option<f64>,
}

/// A predictive band of `|H|` for one FRF: centre and `± 2 sd` per line.
#[derive(Clone, Debug, Serialize)]
pub struct BandView {
    /// `response/excitation`.
    pub pair: String,
    /// Lines, Hz.
    pub freqs: Vec<Option<f64>>,
    /// `|H|` at the posterior mean.
    pub abs: Vec<Option<f64>>,
    /// `|H| − 2 sd` (sampled sd when present, else linearised), clipped at 0.
    pub lower: Vec<Option<f64>>,
    /// `|H| + 2 sd`.
    pub upper: Vec<Option<f64>>,
}

/// A posterior of the parameters (docs/theory.md §12): marginals, correlations, ridges and
/// predictive bands.
#[derive(Clone, Debug, Serialize)]
pub struct PosteriorView {
    /// `stage.port`.
    pub id: String,
    /// Probability of the credible intervals, when recorded.
    pub level: Option<f64>,
    /// How it was computed: `Laplace`, `TMCMC` or `MALA`.
    pub sampler: String,
    /// `ln p(y)` of a TMCMC posterior.
    pub log_evidence: Option<f64>,
    /// Per parameter, in the table's order.
    pub parameters: Vec<ParameterPosterior>,
    /// Correlation of parameter `i` with `j` (order of `parameters`).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Parameter pairs with `|correlation| >` [`RUN_RIDGE`]: names and the correlation.
    pub ridges: Vec<(String, String, f64)>,
    /// Predictive bands of `|H|`, when the posterior carries them.
    pub bands: Vec<BandView>,
}

/// The `|correlation|` above which two parameters are said to lie on a ridge.
pub const RUN_RIDGE: f64 = 0.9;

/// A figure a stage drew.
#[derive(Clone, Debug)]
pub struct FigureView {
    /// `stage.port`.
    pub id: String,
    /// Title from the artefact.
    pub title: String,
    /// Images: file name and bytes, one per figure (its SVG, else its PNG).
    pub images: Vec<(String, Vec<u8>)>,
}

/// The first rows of one table, as text.
#[derive(Clone, Debug)]
pub struct TablePreview {
    /// Table name.
    pub name: String,
    /// Rows in the table.
    pub rows: usize,
    /// Column names.
    pub header: Vec<String>,
    /// The first [`TABLE_ROWS`] rows.
    pub shown: Vec<Vec<String>>,
}

/// One artefact in the table listing.
#[derive(Clone, Debug)]
pub struct ArtefactView {
    /// `stage.port`.
    pub id: String,
    /// Kind name.
    pub kind: String,
    /// Content digest.
    pub digest: String,
    /// Metadata (pretty JSON).
    pub meta: String,
    /// Tables, their first rows as text.
    pub tables: Vec<TablePreview>,
    /// Why it could not be read, if so.
    pub error: Option<String>,
}

/// Everything the report shows.
#[derive(Clone, Debug, Default)]
pub struct RunView {
    /// Pipeline name.
    pub pipeline: String,
    /// femu version that ran it, and the one writing the report.
    pub femu_version: String,
    /// See `femu_version`.
    pub report_version: String,
    /// The command, when known.
    pub command: Option<String>,
    /// Stages in dependency order.
    pub stages: Vec<StageView>,
    /// FRF sets.
    pub frfs: Vec<FrfView>,
    /// FRF correlations.
    pub correlations: Vec<CorrelationView>,
    /// Meshes.
    pub meshes: Vec<MeshView>,
    /// Fields on meshes.
    pub fields: Vec<FieldView>,
    /// Updating histories.
    pub updates: Vec<UpdateView>,
    /// MAC matrices.
    pub macs: Vec<MacView>,
    /// Modal correlation pair tables (`stage.port`, table).
    pub modal_pairs: Vec<(String, Table)>,
    /// Natural frequencies (`stage.port`, Hz).
    pub frequencies: Vec<(String, Vec<f64>)>,
    /// Figures.
    pub figures: Vec<FigureView>,
    /// Test points of `test_map` artefacts.
    pub test_points: Vec<TestPointsView>,
    /// Posteriors.
    pub posteriors: Vec<PosteriorView>,
    /// Every artefact.
    pub artefacts: Vec<ArtefactView>,
    /// Warnings by stage, in stage order.
    pub warnings: Vec<(String, String)>,
}

/// Finite values as numbers, the others as `null` (JSON has no NaN).
fn finite(v: &[f64]) -> Vec<Option<f64>> {
    v.iter().map(|x| x.is_finite().then_some(*x)).collect()
}

/// Stage names in dependency order (inputs first), ties by name.
fn stage_order(lock: &LockFile) -> Vec<String> {
    let mut done: BTreeSet<String> = BTreeSet::new();
    let mut order = Vec::new();
    while order.len() < lock.stages.len() {
        let ready: Vec<String> = lock
            .stages
            .iter()
            .filter(|(n, s)| {
                !done.contains(*n)
                    && s.inputs.values().all(|from| {
                        let up = from.split('.').next().unwrap_or_default();
                        done.contains(up) || !lock.stages.contains_key(up)
                    })
            })
            .map(|(n, _)| n.clone())
            .collect();
        if ready.is_empty() {
            // A cycle cannot come from femu; list the rest as they are.
            order.extend(lock.stages.keys().filter(|n| !done.contains(*n)).cloned());
            break;
        }
        for n in ready {
            done.insert(n.clone());
            order.push(n);
        }
    }
    order
}

/// Reads the run in `out`.
pub fn collect(out: &Path, opts: &ReportOptions) -> Result<RunView, ReportError> {
    let lock_path = out.join(OUT_LOCK_FILE);
    if !lock_path.is_file() {
        return Err(ReportError::new(
            out,
            format!(
                "is not a run output directory (no {OUT_LOCK_FILE}); give the directory `femu run --out DIR` wrote"
            ),
        ));
    }
    let text = std::fs::read_to_string(&lock_path)
        .map_err(|e| ReportError::new(&lock_path, format!("cannot read: {e}")))?;
    let lock: LockFile = serde_json::from_str(&text)
        .map_err(|e| ReportError::new(&lock_path, format!("is not a femu lock file: {e}")))?;
    // Statuses, times and the command: given right after a run, else from the run record
    // `femu run --out` left beside the lock file (absent for older outputs: the page says so).
    let record: Option<RunRecord> = std::fs::read_to_string(out.join(RUN_RECORD_FILE))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let mut timings = opts.timings.clone();
    let mut command = opts.command.clone();
    if timings.is_empty()
        && let Some(r) = &record
    {
        timings = r
            .stages
            .iter()
            .map(|s| {
                let t = StageTiming {
                    status: s.status.clone(),
                    seconds: s.seconds,
                };
                (s.name.clone(), t)
            })
            .collect();
        command = Some(r.command.join(" "));
    }
    let mut view = RunView {
        pipeline: lock.pipeline.clone(),
        femu_version: lock.femu_version.clone(),
        report_version: env!("CARGO_PKG_VERSION").to_string(),
        command,
        ..RunView::default()
    };
    let mut meshes: BTreeMap<String, Model> = BTreeMap::new();
    let mut leverage: Vec<(String, String, Artefact)> = Vec::new();
    for name in stage_order(&lock) {
        let s = &lock.stages[&name];
        view.stages.push(StageView {
            name: name.clone(),
            kind: s.kind.clone(),
            inputs: s.inputs.clone(),
            outputs: s
                .outputs
                .iter()
                .map(|(p, r)| (p.clone(), r.kind.clone(), r.digest.clone()))
                .collect(),
            timing: timings.get(&name).cloned(),
            params: s.params.clone(),
        });
        let mut metas = Vec::new();
        for port in s.outputs.keys() {
            let id = format!("{name}.{port}");
            let dir = out.join(&name).join(port);
            let a = match read_dir(&dir) {
                Ok(a) => a,
                Err(e) => {
                    view.artefacts.push(ArtefactView {
                        id,
                        kind: s.outputs[port].kind.clone(),
                        digest: s.outputs[port].digest.clone(),
                        meta: String::new(),
                        tables: Vec::new(),
                        error: Some(e.to_string()),
                    });
                    continue;
                }
            };
            metas.push(a.meta.clone());
            view.artefacts.push(artefact_view(&id, &a));
            match a.kind {
                ArtefactKind::Frf => {
                    if let Ok(set) = frf_from_artefact(&a) {
                        view.frfs.push(frf_view(&id, &set));
                    }
                }
                ArtefactKind::Correlation => {
                    if let Ok(c) = correlation_from_artefact(&a) {
                        view.correlations.push(CorrelationView {
                            id,
                            measured: s.inputs.get("measured").cloned(),
                            predicted: s.inputs.get("predicted").cloned(),
                            freqs: finite(&c.freqs_hz),
                            chi_s: finite(&c.chi_s),
                            chi_a: finite(&c.chi_a),
                            frac: c
                                .pairs
                                .iter()
                                .zip(&c.frac)
                                .map(|(p, f)| {
                                    (
                                        format!("{}/{}", p.response, p.excitation),
                                        f.is_finite().then_some(*f),
                                    )
                                })
                                .collect(),
                        });
                    }
                }
                ArtefactKind::Mesh => {
                    if let Ok(m) = mesh_from_artefact(&a) {
                        view.meshes.push(mesh_view(&id, &m));
                        meshes.insert(id, m);
                    }
                }
                ArtefactKind::Leverage => {
                    if let Some(mesh) = s.inputs.get("mesh") {
                        leverage.push((id, mesh.clone(), a));
                    }
                }
                ArtefactKind::UpdateResult => {
                    if let Some(u) = update_view(&id, &a) {
                        view.updates.push(u);
                    }
                }
                ArtefactKind::ModalCorrelation => {
                    if let Some(m) = mac_view(&id, &a) {
                        view.macs.push(m);
                    }
                    if let Ok(t) = a.table("pairs") {
                        view.modal_pairs.push((id, t.clone()));
                    }
                }
                ArtefactKind::Modes => {
                    if let Ok(f) = a
                        .table("frequencies")
                        .and_then(|t| Ok(t.f64s("frequencies", "freq_hz")?.to_vec()))
                    {
                        view.frequencies.push((id, f));
                    }
                }
                ArtefactKind::Plot => {
                    if let Some(f) = figure_view(&id, &a) {
                        view.figures.push(f);
                    }
                }
                ArtefactKind::TestMap => {
                    if let Some(t) = test_points_view(&id, s.inputs.get("mesh").cloned(), &a) {
                        view.test_points.push(t);
                    }
                }
                ArtefactKind::Posterior => {
                    if let Some(p) = posterior_view(&id, &a) {
                        view.posteriors.push(p);
                    }
                }
                _ => {}
            }
        }
        for w in stage_warnings(&metas) {
            view.warnings.push((name.clone(), w));
        }
    }
    // Test points are drawn on their mesh only when that mesh is in the viewer.
    for t in &mut view.test_points {
        if t.mesh.as_ref().is_some_and(|m| !meshes.contains_key(m)) {
            t.mesh = None;
        }
    }
    for (id, mesh, a) in leverage {
        if meshes.contains_key(&mesh)
            && let Some(f) = leverage_field(&id, &mesh, &a)
        {
            view.fields.push(f);
        }
    }
    Ok(view)
}

/// The listing of one artefact: metadata and the first rows of every table.
fn artefact_view(id: &str, a: &Artefact) -> ArtefactView {
    let tables = a
        .tables
        .iter()
        .map(|(name, (t, _))| {
            let rows = t.rows();
            let header = t.columns.iter().map(|c| c.0.clone()).collect();
            let shown = (0..rows.min(TABLE_ROWS))
                .map(|r| t.columns.iter().map(|c| cell(&c.1, r)).collect())
                .collect();
            TablePreview {
                name: name.clone(),
                rows,
                header,
                shown,
            }
        })
        .collect();
    ArtefactView {
        id: id.to_string(),
        kind: a.kind.name().to_string(),
        digest: a.digest(),
        meta: serde_json::to_string_pretty(&a.meta).unwrap_or_default(),
        tables,
        error: None,
    }
}

/// A cell as a reader wants it: floats to 6 significant digits.
fn cell(c: &Column, r: usize) -> String {
    match c {
        Column::F64(v) => {
            let x = v[r];
            if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
                format!("{}", (x * 1e6).round() / 1e6)
            } else {
                format!("{x:.5e}")
            }
        }
        other => other.cell(r),
    }
}

fn frf_view(id: &str, set: &crate::frf::FrfSet) -> FrfView {
    let lines = set.freqs_hz.len().min(MAX_FRF_LINES);
    let shown = set.pairs.len().min(MAX_FRF_PAIRS);
    FrfView {
        id: id.to_string(),
        quantity: set.quantity.name().to_string(),
        unit: set.quantity.unit().to_string(),
        freqs: finite(&set.freqs_hz[..lines]),
        pairs: (0..shown)
            .map(|j| {
                let p = &set.pairs[j];
                let (re, im): (Vec<f64>, Vec<f64>) = (0..lines)
                    .map(|k| (set.values[(k, j)].re, set.values[(k, j)].im))
                    .unzip();
                PairView {
                    label: format!("{}/{}", p.response, p.excitation),
                    re: finite(&re),
                    im: finite(&im),
                }
            })
            .collect(),
        omitted_pairs: set.pairs.len() - shown,
    }
}

/// Faces of every shell and solid, lines of beams and rods; others are counted in the note.
fn mesh_view(id: &str, m: &Model) -> MeshView {
    let index: BTreeMap<u64, u32> = m
        .nodes
        .keys()
        .enumerate()
        .map(|(i, &n)| (n, i as u32))
        .collect();
    let xyz = m.nodes.values().flat_map(|p| p.iter().copied()).collect();
    let (mut faces, mut face_element) = (Vec::new(), Vec::new());
    let mut undrawn = 0usize;
    let mut push = |e: u64, nodes: &[u64]| {
        let f: Option<Vec<u32>> = nodes.iter().map(|n| index.get(n).copied()).collect();
        if let Some(f) = f {
            faces.push(f);
            face_element.push(e);
        }
    };
    for (&id, e) in &m.elements {
        match e {
            Element::Quad4 { nodes, .. } => push(id, nodes),
            Element::Tria3 { nodes, .. } => push(id, nodes),
            Element::Quad8 { corners, .. } => push(id, corners),
            Element::Tria6 { corners, .. } => push(id, corners),
            Element::Beam { nodes, .. } | Element::Rod { nodes, .. } => push(id, nodes),
            Element::Solid { kind, nodes, .. } => {
                for f in kind.corner_faces() {
                    let ns: Vec<u64> = f.iter().filter_map(|&k| nodes.get(k).copied()).collect();
                    push(id, &ns);
                }
            }
            _ => undrawn += 1,
        }
    }
    let mut note = (undrawn > 0)
        .then(|| format!("{undrawn} point elements (springs, masses, dampers) are not drawn"));
    if faces.len() > MAX_MESH_FACES {
        note = Some(format!(
            "{} faces: more than the {MAX_MESH_FACES} the viewer draws; the mesh is listed, not drawn",
            faces.len()
        ));
        faces.clear();
        face_element.clear();
    }
    MeshView {
        id: id.to_string(),
        xyz,
        faces,
        face_element,
        note,
    }
}

/// The normalised leverage of each candidate, given to its member elements.
fn leverage_field(id: &str, mesh: &str, a: &Artefact) -> Option<FieldView> {
    let c = a.table("candidates").ok()?;
    let names = c.strs("candidates", "candidate").ok()?;
    let value = c.f64s("candidates", "normalised").ok()?;
    let of: BTreeMap<&str, f64> = names
        .iter()
        .map(String::as_str)
        .zip(value.iter().copied())
        .collect();
    let m = a.table("members").ok()?;
    let (cand, elem) = (
        m.strs("members", "candidate").ok()?,
        m.i64s("members", "element").ok()?,
    );
    let mut values = BTreeMap::new();
    for (c, &e) in cand.iter().zip(elem.iter()) {
        if let (Some(v), Ok(e)) = (of.get(c.as_str()), u64::try_from(e)) {
            let slot = values.entry(e).or_insert(f64::NEG_INFINITY);
            *slot = f64::max(*slot, *v);
        }
    }
    Some(FieldView {
        id: id.to_string(),
        mesh: mesh.to_string(),
        label: "normalised leverage (5.9)".to_string(),
        values,
    })
}

fn update_view(id: &str, a: &Artefact) -> Option<UpdateView> {
    let it = a.table("iterations").ok()?;
    let iterations = it.i64s("iterations", "iteration").ok()?.to_vec();
    let chi_s = it.f64s("iterations", "mean_chi_s").ok()?;
    let chi_a = it.f64s("iterations", "mean_chi_a").ok()?;
    let p = a.table("parameters").ok()?;
    let parameters = p.strs("parameters", "parameter").ok()?.to_vec();
    let initial = p.f64s("parameters", "initial").ok()?;
    let h = a.table("history").ok()?;
    let (hi, hp, hv) = (
        h.i64s("history", "iteration").ok()?,
        h.strs("history", "parameter").ok()?,
        h.f64s("history", "value").ok()?,
    );
    let at: BTreeMap<i64, usize> = iterations
        .iter()
        .enumerate()
        .map(|(k, &i)| (i, k))
        .collect();
    let which: BTreeMap<&str, usize> = parameters
        .iter()
        .enumerate()
        .map(|(k, n)| (n.as_str(), k))
        .collect();
    let mut relative = vec![vec![None; iterations.len()]; parameters.len()];
    for ((i, n), v) in hi.iter().zip(hp).zip(hv) {
        if let (Some(&k), Some(&q)) = (at.get(i), which.get(n.as_str())) {
            let r = v / initial[q];
            relative[q][k] = r.is_finite().then_some(r);
        }
    }
    let text = |k: &str| {
        a.meta
            .get(k)
            .and_then(|v| v.as_str())
            .unwrap_or_default()
            .to_string()
    };
    Some(UpdateView {
        id: id.to_string(),
        method: text("method"),
        stop: text("stop"),
        iterations,
        mean_chi_s: finite(chi_s),
        mean_chi_a: finite(chi_a),
        parameters,
        relative,
    })
}

fn mac_view(id: &str, a: &Artefact) -> Option<MacView> {
    let t = a.table("mac").ok()?;
    let (r, p, v) = (
        t.i64s("mac", "reference_mode").ok()?,
        t.i64s("mac", "predicted_mode").ok()?,
        t.f64s("mac", "mac").ok()?,
    );
    let mac: BTreeMap<(i64, i64), f64> = r
        .iter()
        .zip(p.iter())
        .zip(v)
        .map(|((&r, &p), &v)| ((r, p), v))
        .collect();
    let pairs = a
        .table("pairs")
        .ok()
        .and_then(|t| {
            let r = t.i64s("pairs", "reference_mode").ok()?;
            let p = t.i64s("pairs", "predicted_mode").ok()?;
            Some(r.iter().copied().zip(p.iter().copied()).collect())
        })
        .unwrap_or_default();
    Some(MacView {
        id: id.to_string(),
        reference: r
            .iter()
            .copied()
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect(),
        predicted: p
            .iter()
            .copied()
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect(),
        mac,
        pairs,
    })
}

fn figure_view(id: &str, a: &Artefact) -> Option<FigureView> {
    let stem = |n: &str| n.rsplit_once('.').map_or(n, |(s, _)| s).to_string();
    let mut images: BTreeMap<String, (String, Vec<u8>)> = BTreeMap::new();
    for (name, bytes) in &a.blobs {
        let svg = name.ends_with(".svg");
        if !(svg || name.ends_with(".png")) {
            continue;
        }
        let slot = images.entry(stem(name));
        match slot {
            std::collections::btree_map::Entry::Vacant(v) => {
                v.insert((name.clone(), bytes.clone()));
            }
            std::collections::btree_map::Entry::Occupied(mut o) if svg => {
                o.insert((name.clone(), bytes.clone()));
            }
            _ => {}
        }
    }
    if images.is_empty() {
        return None;
    }
    Some(FigureView {
        id: id.to_string(),
        title: a
            .meta
            .get("title")
            .and_then(|v| v.as_str())
            .unwrap_or(id)
            .to_string(),
        images: images.into_values().collect(),
    })
}

fn test_points_view(id: &str, mesh: Option<String>, a: &Artefact) -> Option<TestPointsView> {
    let t = a.table("points").ok()?;
    let name = "points";
    let node = t.i64s(name, "test_node").ok()?;
    let (x, y, z) = (
        t.f64s(name, "x_m").ok()?,
        t.f64s(name, "y_m").ok()?,
        t.f64s(name, "z_m").ok()?,
    );
    let method = t.strs(name, "method").ok()?;
    let fe_node = t.i64s(name, "fe_node").ok()?;
    let fe_element = t.i64s(name, "fe_element").ok()?;
    let distance = t.f64s(name, "distance_m").ok()?;
    let status = t.strs(name, "status").ok()?;
    let id_of = |v: i64| (v >= 0).then_some(v);
    let points = (0..node.len())
        .map(|k| TestPointView {
            node: node[k],
            xyz: [x[k], y[k], z[k]],
            method: method[k].clone(),
            fe_node: id_of(fe_node[k]),
            fe_element: id_of(fe_element[k]),
            distance_m: distance[k].is_finite().then_some(distance[k]),
            status: status[k].clone(),
        })
        .collect();
    Some(TestPointsView {
        id: id.to_string(),
        mesh,
        tolerance_m: a
            .meta
            .get("tolerance_m")
            .and_then(|v| v.as_f64())
            .filter(|v| v.is_finite() && *v > 0.0),
        points,
    })
}

/// Reads a posterior by its tables, so every method writing the `posterior` kind shows: the
/// marginals from `parameters`, the correlations from `covariance`, the bands from `frf_band`.
fn posterior_view(id: &str, a: &Artefact) -> Option<PosteriorView> {
    let t = a.table("parameters").ok()?;
    let names = t.strs("parameters", "parameter").ok()?.to_vec();
    let column = |c: &str| -> Vec<Option<f64>> {
        t.f64s("parameters", c)
            .map(finite)
            .unwrap_or_else(|_| vec![None; names.len()])
    };
    let (updated, mean, sd, lower, upper) = (
        column("updated"),
        column("mean"),
        column("sd"),
        column("lower"),
        column("upper"),
    );
    // R̂ and effective sample sizes by parameter name, for a Markov-chain sampler's posterior.
    let mut chains: BTreeMap<String, (Option<f64>, Option<f64>)> = BTreeMap::new();
    if let Ok(m) = a.table("mcmc_parameters")
        && let (Ok(p), Ok(r), Ok(e)) = (
            m.strs("mcmc_parameters", "parameter"),
            m.f64s("mcmc_parameters", "r_hat"),
            m.f64s("mcmc_parameters", "ess"),
        )
    {
        for ((p, r), e) in p.iter().zip(finite(r)).zip(finite(e)) {
            chains.insert(p.clone(), (r, e));
        }
    }
    let parameters = (0..names.len())
        .map(|k| {
            let (r_hat, ess) = chains.get(&names[k]).copied().unwrap_or((None, None));
            ParameterPosterior {
                name: names[k].clone(),
                updated: updated[k],
                mean: mean[k],
                sd: sd[k],
                lower: lower[k],
                upper: upper[k],
                r_hat,
                ess,
            }
        })
        .collect();
    let meta_str = |k: &str| a.meta.get(k).and_then(|v| v.as_str());
    let sampler = match (meta_str("sampler"), meta_str("method")) {
        (Some("mala"), _) => "MALA",
        (_, Some("tmcmc")) => "TMCMC",
        _ => "Laplace",
    };
    let at: BTreeMap<&str, usize> = names
        .iter()
        .enumerate()
        .map(|(k, n)| (n.as_str(), k))
        .collect();
    let mut correlation = vec![vec![None; names.len()]; names.len()];
    if let Ok(c) = a.table("covariance")
        && let (Ok(pi), Ok(pj), Ok(r)) = (
            c.strs("covariance", "parameter_i"),
            c.strs("covariance", "parameter_j"),
            c.f64s("covariance", "correlation"),
        )
    {
        for ((i, j), v) in pi.iter().zip(pj).zip(r) {
            if let (Some(&i), Some(&j)) = (at.get(i.as_str()), at.get(j.as_str())) {
                correlation[i][j] = v.is_finite().then_some(*v);
            }
        }
    }
    let mut ridges = Vec::new();
    for i in 0..names.len() {
        for j in i + 1..names.len() {
            let r = correlation[i][j].or(correlation[j][i]);
            if let Some(r) = r.filter(|r| r.abs() > RUN_RIDGE) {
                ridges.push((names[i].clone(), names[j].clone(), r));
            }
        }
    }
    Some(PosteriorView {
        id: id.to_string(),
        level: a.meta.get("credible_level").and_then(|v| v.as_f64()),
        sampler: sampler.into(),
        log_evidence: a
            .meta
            .get("log_evidence")
            .and_then(|v| v.as_f64())
            .filter(|v| v.is_finite()),
        parameters,
        correlation,
        ridges,
        bands: bands(a).unwrap_or_default(),
    })
}

/// The `frf_band` table as one band per FRF, lines in the table's order.
fn bands(a: &Artefact) -> Option<Vec<BandView>> {
    let t = a.table("frf_band").ok()?;
    let n = "frf_band";
    let (f, pair, abs) = (
        t.f64s(n, "freq_hz").ok()?,
        t.strs(n, "pair").ok()?,
        t.f64s(n, "abs").ok()?,
    );
    let linear = t.f64s(n, "sd_linear").ok();
    let sampled = t.f64s(n, "sd_sampled").ok();
    let mut out: Vec<BandView> = Vec::new();
    for k in 0..f.len() {
        let sd = sampled
            .map(|s| s[k])
            .filter(|v| v.is_finite())
            .or_else(|| linear.map(|s| s[k]).filter(|v| v.is_finite()));
        let i = match out.iter().position(|b| b.pair == pair[k]) {
            Some(i) => i,
            None => {
                out.push(BandView {
                    pair: pair[k].clone(),
                    freqs: Vec::new(),
                    abs: Vec::new(),
                    lower: Vec::new(),
                    upper: Vec::new(),
                });
                out.len() - 1
            }
        };
        let b = &mut out[i];
        let ok = |v: f64| v.is_finite().then_some(v);
        b.freqs.push(ok(f[k]));
        b.abs.push(ok(abs[k]));
        b.lower
            .push(sd.and_then(|s| ok((abs[k] - 2.0 * s).max(0.0))));
        b.upper.push(sd.and_then(|s| ok(abs[k] + 2.0 * s)));
    }
    Some(out)
}
