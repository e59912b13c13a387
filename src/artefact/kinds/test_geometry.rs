//! The `test_geometry` kind: the points of a test (from a Universal File's datasets 15/2411),
//! in SI and global test coordinates, with each point's displacement frame, and the trace
//! lines (dataset 82) between them.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `nodes` (Parquet) | `node, x_m, y_m, z_m, definition_system, displacement_system, e1_x … e3_z` |
//! | `trace_lines` (Parquet, optional) | `trace_line, node` |

use super::{Kind, Layout, col, expect_kind, meta, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::pairing::{TestGeometry, TestPoint};

/// The `test_geometry` kind.
pub struct TestGeometryKind;

const AXES: [&str; 9] = [
    "e1_x", "e1_y", "e1_z", "e2_x", "e2_y", "e2_z", "e3_x", "e3_y", "e3_z",
];

impl Kind for TestGeometryKind {
    const KIND: ArtefactKind = ArtefactKind::TestGeometry;
    const NAME: &'static str = "test_geometry";
    type Value = TestGeometry;

    fn layout() -> Layout {
        let axis = |name: &'static str| {
            col(
                name,
                "float64",
                "",
                "displacement frame: component of axis 1, 2 or 3 (e1..e3) along global x, y or z",
            )
        };
        let mut nodes = vec![
            col("node", "int64", "", "test node label"),
            col("x_m", "float64", "m", "global x"),
            col("y_m", "float64", "m", "global y"),
            col("z_m", "float64", "m", "global z"),
            col(
                "definition_system",
                "int64",
                "",
                "coordinate system the file gave the position in (0: global)",
            ),
            col(
                "displacement_system",
                "int64",
                "",
                "coordinate system of the node's measurement directions (0: global)",
            ),
        ];
        nodes.extend(AXES.iter().map(|n| axis(n)));
        Layout {
            tables: vec![
                table("nodes", Storage::Parquet, true, nodes),
                table(
                    "trace_lines",
                    Storage::Parquet,
                    false,
                    vec![
                        col("trace_line", "int64", "", "trace line number"),
                        col(
                            "node",
                            "int64",
                            "",
                            "node label in drawing order, 0 lifts the pen",
                        ),
                    ],
                ),
            ],
            meta: vec![meta("n_nodes", "test points")],
            blobs: vec![],
        }
    }

    fn to_artefact(g: &TestGeometry) -> Artefact {
        test_geometry_to_artefact(g)
    }

    fn from_artefact(a: &Artefact) -> Result<TestGeometry, ArtefactError> {
        test_geometry_from_artefact(a)
    }
}

/// Test geometry as an artefact.
pub fn test_geometry_to_artefact(g: &TestGeometry) -> Artefact {
    let p = &g.points;
    let f = |k: usize| Column::F64(p.iter().map(|q| q.xyz[k]).collect());
    let sys = |k: usize| {
        Column::I64(
            (0..p.len())
                .map(|i| g.systems.get(i).map_or(0, |s| s[k] as i64))
                .collect(),
        )
    };
    let mut nodes = Table::new()
        .with(
            "node",
            Column::I64(p.iter().map(|q| q.node as i64).collect()),
        )
        .with("x_m", f(0))
        .with("y_m", f(1))
        .with("z_m", f(2))
        .with("definition_system", sys(0))
        .with("displacement_system", sys(1));
    for (k, name) in AXES.iter().enumerate() {
        nodes = nodes.with(
            *name,
            Column::F64(p.iter().map(|q| q.axes[k / 3][k % 3]).collect()),
        );
    }
    let mut a = Artefact::new(TestGeometryKind::KIND)
        .with_meta("n_nodes", p.len().into())
        .with_table("nodes", nodes, Storage::Parquet);
    if !g.trace_lines.is_empty() {
        let (mut line, mut node) = (Vec::new(), Vec::new());
        for (id, ns) in &g.trace_lines {
            for n in ns {
                line.push(*id as i64);
                node.push(*n as i64);
            }
        }
        a = a.with_table(
            "trace_lines",
            Table::new()
                .with("trace_line", Column::I64(line))
                .with("node", Column::I64(node)),
            Storage::Parquet,
        );
    }
    a
}

fn label(kind: ArtefactKind, table: &str, row: usize, v: i64) -> Result<u64, ArtefactError> {
    u64::try_from(v).map_err(|_| {
        ArtefactError::schema(
            kind,
            format!("table `{table}` row {row}: label {v} is negative"),
        )
    })
}

/// Test geometry from an artefact.
pub fn test_geometry_from_artefact(a: &Artefact) -> Result<TestGeometry, ArtefactError> {
    let kind = ArtefactKind::TestGeometry;
    expect_kind(a, kind)?;
    let t = a.table("nodes")?;
    let node = t.i64s("nodes", "node")?;
    let (x, y, z) = (
        t.f64s("nodes", "x_m")?,
        t.f64s("nodes", "y_m")?,
        t.f64s("nodes", "z_m")?,
    );
    let (ds, dp) = (
        t.i64s("nodes", "definition_system")?,
        t.i64s("nodes", "displacement_system")?,
    );
    let axes: Vec<&[f64]> = AXES
        .iter()
        .map(|n| t.f64s("nodes", n))
        .collect::<Result<_, _>>()?;
    let mut g = TestGeometry::default();
    for i in 0..node.len() {
        let mut e = [[0.0; 3]; 3];
        for (k, col) in axes.iter().enumerate() {
            e[k / 3][k % 3] = col[i];
        }
        g.points.push(TestPoint {
            node: label(kind, "nodes", i, node[i])?,
            xyz: [x[i], y[i], z[i]],
            axes: e,
        });
        let s = |v: i64| {
            u32::try_from(v).map_err(|_| {
                ArtefactError::schema(kind, format!("table `nodes` row {i}: system {v}"))
            })
        };
        g.systems.push([s(ds[i])?, s(dp[i])?]);
    }
    if let Some((tl, _)) = a.tables.get("trace_lines") {
        let (line, node) = (
            tl.i64s("trace_lines", "trace_line")?,
            tl.i64s("trace_lines", "node")?,
        );
        for (i, (&l, &n)) in line.iter().zip(node.iter()).enumerate() {
            let l = label(kind, "trace_lines", i, l)?;
            let n = label(kind, "trace_lines", i, n)?;
            match g.trace_lines.last_mut() {
                Some((id, ns)) if *id == l => ns.push(n),
                _ => g.trace_lines.push((l, vec![n])),
            }
        }
    }
    Ok(g)
}
