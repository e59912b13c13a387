//! The `test_map` kind: each measured DOF as a weighted sum of model DOFs (docs/theory.md
//! §14, (14.6)), with how every test point was aligned and paired.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `map` (Parquet) | `test_dof, fe_dof, weight` |
//! | `points` (Parquet) | `test_node, x_m, y_m, z_m, method, fe_node, fe_element, shape, xi, eta, zeta, distance_m, nearest_node, nearest_distance_m, status` |
//! | `point_weights` (Parquet) | `test_node, fe_node, weight` |

use super::{Kind, Layout, col, expect_kind, meta, meta_value, parse_dofs, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::pairing::{FitReport, MapRow, PairedBy, PointPairing, RigidTransform, Shape, TestMap};

/// The `test_map` kind.
pub struct TestMapKind;

impl Kind for TestMapKind {
    const KIND: ArtefactKind = ArtefactKind::TestMap;
    const NAME: &'static str = "test_map";
    type Value = TestMap;

    fn layout() -> Layout {
        Layout {
            tables: vec![
                table(
                    "map",
                    Storage::Parquet,
                    true,
                    vec![
                        col("test_dof", "string", "", "measured DOF node:comp"),
                        col("fe_dof", "string", "", "model DOF node:comp"),
                        col(
                            "weight",
                            "float64",
                            "",
                            "shape function × direction cosine (14.6)",
                        ),
                    ],
                ),
                table(
                    "points",
                    Storage::Parquet,
                    true,
                    vec![
                        col("test_node", "int64", "", "test node label"),
                        col("x_m", "float64", "m", "aligned position, model x"),
                        col("y_m", "float64", "m", "aligned position, model y"),
                        col("z_m", "float64", "m", "aligned position, model z"),
                        col("method", "string", "", "`node` or `element`"),
                        col("fe_node", "int64", "", "the grid paired to (node), else -1"),
                        col(
                            "fe_element",
                            "int64",
                            "",
                            "the element interpolated in (element), else -1",
                        ),
                        col(
                            "shape",
                            "string",
                            "",
                            "quad4, tria3, hexa8, tetra4, or empty",
                        ),
                        col("xi", "float64", "", "natural coordinate 1 (NaN for a node)"),
                        col(
                            "eta",
                            "float64",
                            "",
                            "natural coordinate 2 (NaN for a node)",
                        ),
                        col(
                            "zeta",
                            "float64",
                            "",
                            "natural coordinate 3 (NaN for a node)",
                        ),
                        col(
                            "distance_m",
                            "float64",
                            "m",
                            "to the grid, or to the element (out of plane for shells)",
                        ),
                        col("nearest_node", "int64", "", "nearest grid"),
                        col("nearest_distance_m", "float64", "m", "distance to it"),
                        col("status", "string", "", "`ok` or `beyond_tolerance`"),
                    ],
                ),
                table(
                    "point_weights",
                    Storage::Parquet,
                    true,
                    vec![
                        col("test_node", "int64", "", "test node label"),
                        col("fe_node", "int64", "", "model grid"),
                        col("weight", "float64", "", "shape function value (14.4)"),
                    ],
                ),
            ],
            meta: vec![
                meta(
                    "alignment",
                    "rotation (rows) and translation_m with x_model = R x_test + t (14.1); fit residuals and rms_m when fitted",
                ),
                meta("method", "pairing method: nearest, interpolate or auto"),
                meta("tolerance_m", "largest accepted pairing distance"),
                meta(
                    "summary",
                    "points, measured DOFs, map rows, largest and RMS distance, points beyond tolerance",
                ),
                meta("warnings", "points paired beyond the tolerance"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(m: &TestMap) -> Artefact {
        test_map_to_artefact(m)
    }

    fn from_artefact(a: &Artefact) -> Result<TestMap, ArtefactError> {
        test_map_from_artefact(a)
    }
}

/// A test map as an artefact.
pub fn test_map_to_artefact(m: &TestMap) -> Artefact {
    let map = Table::new()
        .with(
            "test_dof",
            Column::Str(m.rows.iter().map(|r| r.test_dof.to_string()).collect()),
        )
        .with(
            "fe_dof",
            Column::Str(m.rows.iter().map(|r| r.fe_dof.to_string()).collect()),
        )
        .with(
            "weight",
            Column::F64(m.rows.iter().map(|r| r.weight).collect()),
        );
    let p = &m.points;
    let i64s = |f: &dyn Fn(&PointPairing) -> i64| Column::I64(p.iter().map(f).collect());
    let f64s = |f: &dyn Fn(&PointPairing) -> f64| Column::F64(p.iter().map(f).collect());
    let strs = |f: &dyn Fn(&PointPairing) -> String| Column::Str(p.iter().map(f).collect());
    let natural = |q: &PointPairing, k: usize| match &q.paired_by {
        PairedBy::Element { natural, .. } => natural[k],
        PairedBy::Node(_) => f64::NAN,
    };
    let points = Table::new()
        .with("test_node", i64s(&|q| q.test_node as i64))
        .with("x_m", f64s(&|q| q.xyz[0]))
        .with("y_m", f64s(&|q| q.xyz[1]))
        .with("z_m", f64s(&|q| q.xyz[2]))
        .with(
            "method",
            strs(&|q| match q.paired_by {
                PairedBy::Node(_) => "node".into(),
                PairedBy::Element { .. } => "element".into(),
            }),
        )
        .with(
            "fe_node",
            i64s(&|q| match q.paired_by {
                PairedBy::Node(n) => n as i64,
                PairedBy::Element { .. } => -1,
            }),
        )
        .with(
            "fe_element",
            i64s(&|q| match q.paired_by {
                PairedBy::Node(_) => -1,
                PairedBy::Element { id, .. } => id as i64,
            }),
        )
        .with(
            "shape",
            strs(&|q| match &q.paired_by {
                PairedBy::Node(_) => String::new(),
                PairedBy::Element { shape, .. } => shape.name().into(),
            }),
        )
        .with("xi", f64s(&|q| natural(q, 0)))
        .with("eta", f64s(&|q| natural(q, 1)))
        .with("zeta", f64s(&|q| natural(q, 2)))
        .with("distance_m", f64s(&|q| q.distance))
        .with("nearest_node", i64s(&|q| q.nearest_node.0 as i64))
        .with("nearest_distance_m", f64s(&|q| q.nearest_node.1))
        .with(
            "status",
            strs(&|q| {
                if q.within_tolerance {
                    "ok".into()
                } else {
                    "beyond_tolerance".into()
                }
            }),
        );
    let (mut wn, mut wf, mut ww) = (Vec::new(), Vec::new(), Vec::new());
    for q in p {
        for (n, w) in &q.nodes {
            wn.push(q.test_node as i64);
            wf.push(*n as i64);
            ww.push(*w);
        }
    }
    let weights = Table::new()
        .with("test_node", Column::I64(wn))
        .with("fe_node", Column::I64(wf))
        .with("weight", Column::F64(ww));
    let mut alignment = serde_json::json!({
        "rotation": m.transform.rotation,
        "translation_m": m.transform.translation,
    });
    if let Some(fit) = &m.fit {
        alignment["fit"] = serde_json::json!({
            "residuals": fit.residuals.iter().map(|(t, f, r)| serde_json::json!({"test_node": t, "fe_node": f, "residual_m": r})).collect::<Vec<_>>(),
            "rms_m": fit.rms,
        });
    }
    let dists: Vec<f64> = p.iter().map(|q| q.distance).collect();
    let mut dofs: Vec<String> = m.rows.iter().map(|r| r.test_dof.to_string()).collect();
    dofs.dedup();
    let summary = serde_json::json!({
        "n_points": p.len(),
        "n_test_dofs": dofs.len(),
        "n_rows": m.rows.len(),
        "max_distance_m": dists.iter().copied().fold(0.0, f64::max),
        "rms_distance_m": if dists.is_empty() { 0.0 } else { (dists.iter().map(|d| d * d).sum::<f64>() / dists.len() as f64).sqrt() },
        "n_beyond_tolerance": p.iter().filter(|q| !q.within_tolerance).count(),
    });
    Artefact::new(TestMapKind::KIND)
        .with_meta("alignment", alignment)
        .with_meta("method", m.method.as_str().into())
        .with_meta("tolerance_m", m.tolerance.into())
        .with_meta("summary", summary)
        .with_meta("warnings", serde_json::json!(m.warnings))
        .with_table("map", map, Storage::Parquet)
        .with_table("points", points, Storage::Parquet)
        .with_table("point_weights", weights, Storage::Parquet)
}

#[derive(serde::Deserialize)]
struct Residual {
    test_node: u64,
    fe_node: u64,
    residual_m: f64,
}

#[derive(serde::Deserialize)]
struct Fit {
    residuals: Vec<Residual>,
    rms_m: f64,
}

#[derive(serde::Deserialize)]
struct Alignment {
    rotation: [[f64; 3]; 3],
    translation_m: [f64; 3],
    #[serde(default)]
    fit: Option<Fit>,
}

/// A test map from an artefact.
pub fn test_map_from_artefact(a: &Artefact) -> Result<TestMap, ArtefactError> {
    let kind = ArtefactKind::TestMap;
    expect_kind(a, kind)?;
    let bad = |m: String| ArtefactError::schema(kind, m);
    let t = a.table("map")?;
    let test = parse_dofs(kind, "map", t.strs("map", "test_dof")?)?;
    let fe = parse_dofs(kind, "map", t.strs("map", "fe_dof")?)?;
    let w = t.f64s("map", "weight")?;
    let rows = test
        .into_iter()
        .zip(fe)
        .zip(w)
        .map(|((test_dof, fe_dof), &weight)| MapRow {
            test_dof,
            fe_dof,
            weight,
        })
        .collect();
    let pt = a.table("points")?;
    let n = "points";
    let (node, x, y, z) = (
        pt.i64s(n, "test_node")?,
        pt.f64s(n, "x_m")?,
        pt.f64s(n, "y_m")?,
        pt.f64s(n, "z_m")?,
    );
    let (method, fe_node, fe_el, shape) = (
        pt.strs(n, "method")?,
        pt.i64s(n, "fe_node")?,
        pt.i64s(n, "fe_element")?,
        pt.strs(n, "shape")?,
    );
    let (xi, eta, zeta) = (pt.f64s(n, "xi")?, pt.f64s(n, "eta")?, pt.f64s(n, "zeta")?);
    let (dist, near, near_d, status) = (
        pt.f64s(n, "distance_m")?,
        pt.i64s(n, "nearest_node")?,
        pt.f64s(n, "nearest_distance_m")?,
        pt.strs(n, "status")?,
    );
    let wt = a.table("point_weights")?;
    let (wn, wf, ww) = (
        wt.i64s("point_weights", "test_node")?,
        wt.i64s("point_weights", "fe_node")?,
        wt.f64s("point_weights", "weight")?,
    );
    let id = |v: i64, what: &str, row: usize| {
        u64::try_from(v).map_err(|_| bad(format!("table `points` row {row}: {what} {v}")))
    };
    let mut points = Vec::with_capacity(node.len());
    for i in 0..node.len() {
        let paired_by = match method[i].as_str() {
            "node" => PairedBy::Node(id(fe_node[i], "fe_node", i)?),
            "element" => PairedBy::Element {
                id: id(fe_el[i], "fe_element", i)?,
                shape: Shape::from_name(&shape[i])
                    .ok_or_else(|| bad(format!("table `points` row {i}: shape `{}`", shape[i])))?,
                natural: [xi[i], eta[i], zeta[i]],
            },
            m => return Err(bad(format!("table `points` row {i}: method `{m}`"))),
        };
        let test_node = id(node[i], "test_node", i)?;
        let nodes = (0..wn.len())
            .filter(|&k| wn[k] == node[i])
            .map(|k| Ok((id(wf[k], "fe_node", k)?, ww[k])))
            .collect::<Result<Vec<_>, ArtefactError>>()?;
        points.push(PointPairing {
            test_node,
            xyz: [x[i], y[i], z[i]],
            paired_by,
            nodes,
            distance: dist[i],
            nearest_node: (id(near[i], "nearest_node", i)?, near_d[i]),
            within_tolerance: status[i] == "ok",
        });
    }
    let al: Alignment = meta_value(a, "alignment")?;
    let transform = RigidTransform {
        rotation: al.rotation,
        translation: al.translation_m,
    };
    let fit = al.fit.map(|f| FitReport {
        transform,
        residuals: f
            .residuals
            .iter()
            .map(|r| (r.test_node, r.fe_node, r.residual_m))
            .collect(),
        rms: f.rms_m,
    });
    Ok(TestMap {
        transform,
        fit,
        method: a.meta_str("method")?.to_string(),
        tolerance: meta_value(a, "tolerance_m")?,
        points,
        rows,
        warnings: meta_value(a, "warnings")?,
    })
}
