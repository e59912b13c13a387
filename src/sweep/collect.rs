//! Collection: every finished point's swept values joined with the columns named in `collect:`,
//! read from the point's artefacts in the cache, into one Parquet table; and the box plots of
//! `plots:`.
//!
//! The table is tidy: one row per point, or per row of the point's collected table columns when
//! a source is a whole column (`stage.port.table.column` without `reduce`) — all such columns of
//! one sweep must then have the same length within a point, and a `row` column numbers them.
//! Scalars (`meta` values and reduced columns) repeat on each of the point's rows. Rows follow
//! the expansion order, so the same sweep gives the same table, byte for byte.

use super::SweepError;
use super::expand::{ParamPath, PlannedPoint, Resolved};
use super::spec::{PlotSpec, Reduce, SourcedSweep};
use super::state::{PointState, PointStatus, StateDir, write_atomic};
use crate::artefact::codec::write_parquet;
use crate::artefact::kinds::layout;
use crate::artefact::{ArtefactKind, Column, Table};
use crate::cache::Cache;
use crate::pipeline::Plan;
use crate::pipeline::diagnostic::{Diagnostic, nearest};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Where a collected column comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A value in the artefact's metadata.
    Meta(Vec<String>),
    /// One column of a table.
    Column(String, String),
    /// Every column of a table.
    Table(String),
}

/// One `collect:` entry, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CollectItem {
    /// Column name (prefix of `name.column` for a whole table).
    pub name: String,
    /// Stage.
    pub stage: String,
    /// Output port.
    pub port: String,
    /// What to read.
    pub source: Source,
    /// Reduction to one value per point.
    pub reduce: Option<Reduce>,
}

fn matches_layout(pattern: &str, name: &str) -> bool {
    match pattern.split_once('{') {
        Some((prefix, _)) => name.starts_with(prefix),
        None => pattern == name,
    }
}

/// The forms a collected column's source takes, for help texts.
const HELP_FORMS: &str = "write `stage.port.table.column`, `stage.port.table`, `stage.port.meta.key`, or `{from: stage.port.table.column, reduce: mean}`";

/// Checks `collect:` and `plots:` against a plan of the sweep's pipeline.
pub fn check_collect(
    sweep: &SourcedSweep,
    plan: &Plan,
    params: &[ParamPath],
) -> Result<Vec<CollectItem>, Vec<Diagnostic>> {
    let mut diags = Vec::new();
    let mut items = Vec::new();
    for (name, raw) in &sweep.spec.collect {
        match collect_item(sweep, plan, params, name, raw) {
            Ok(item) => items.push(item),
            Err(d) => diags.push(d),
        }
    }
    for (i, p) in sweep.spec.plots.iter().enumerate() {
        check_plot(sweep, i, p, &items, params, &mut diags);
    }
    if diags.is_empty() {
        Ok(items)
    } else {
        Err(diags)
    }
}

/// One `collect:` entry: its form, its column name, its source in the plan and its reduction.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn collect_item(
    sweep: &SourcedSweep,
    plan: &Plan,
    params: &[ParamPath],
    name: &str,
    raw: &Value,
) -> Result<CollectItem, Diagnostic> {
    let field = format!("collect.{name}");
    let (from, reduce, from_at) = collect_form(sweep, name, raw)?;
    check_column_name(sweep, name, params)?;
    let bad = |(msg, help): (String, String)| {
        sweep
            .at_value(&from_at, msg)
            .field(field.clone())
            .help(help)
    };
    let parts: Vec<&str> = from.split('.').collect();
    let source = source_of(plan, &from, &parts).map_err(bad)?;
    if reduce.is_some() && !matches!(source, Source::Column(..)) {
        return Err(bad((
            "`reduce` applies to one table column".into(),
            "use `stage.port.table.column` as `from`, or drop `reduce`".into(),
        )));
    }
    Ok(CollectItem {
        name: name.to_string(),
        stage: parts[0].to_string(),
        port: parts[1].to_string(),
        source,
        reduce,
    })
}

/// A `collect:` entry's source path, reduction and where the path is written: a path, or a
/// mapping of `from` and `reduce`.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn collect_form<'a>(
    sweep: &SourcedSweep,
    name: &'a str,
    raw: &Value,
) -> Result<(String, Option<Reduce>, Vec<&'a str>), Diagnostic> {
    let at = ["collect", name];
    let field = format!("collect.{name}");
    let map = match raw {
        Value::String(s) => return Ok((s.clone(), None, at.to_vec())),
        Value::Object(map) => map,
        _ => {
            return Err(sweep
                .at_value(&at, "a collected column is a source path or a mapping")
                .field(field)
                .help(HELP_FORMS));
        }
    };
    if let Some(k) = map.keys().find(|k| *k != "from" && *k != "reduce") {
        return Err(sweep
            .at_key(&["collect", name, k], format!("unknown key `{k}`"))
            .field(field)
            .help("a collected column has `from` and `reduce`"));
    }
    let Some(Value::String(from)) = map.get("from") else {
        return Err(sweep
            .at_value(&at, "`from` must name a source")
            .field(field)
            .help(HELP_FORMS));
    };
    let reduce = match map.get("reduce") {
        None => None,
        Some(Value::String(r)) => Some(Reduce::from_name(r).ok_or_else(|| {
            sweep
                .at_value(
                    &["collect", name, "reduce"],
                    format!("unknown reduction `{r}`"),
                )
                .field(format!("{field}.reduce"))
                .help(format!("reductions: {}", Reduce::NAMES))
        })?),
        Some(_) => {
            return Err(sweep
                .at_value(&["collect", name, "reduce"], "`reduce` must be a name")
                .field(format!("{field}.reduce"))
                .help(format!("reductions: {}", Reduce::NAMES)));
        }
    };
    Ok((from.clone(), reduce, vec!["collect", name, "from"]))
}

/// A collected column's name is a file-safe name not taken by `point`, `row` or a swept
/// parameter.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn check_column_name(
    sweep: &SourcedSweep,
    name: &str,
    params: &[ParamPath],
) -> Result<(), Diagnostic> {
    if name.is_empty()
        || name.contains(['/', '\\'])
        || params.iter().any(|p| p.short() == *name)
        || name == "point"
        || name == "row"
    {
        return Err(sweep
            .at_key(&["collect", name], format!("`{name}` cannot name a collected column"))
            .field(format!("collect.{name}"))
            .help("`point`, `row` and the swept parameters' `stage.param` are taken; use another name without `/`"));
    }
    Ok(())
}

/// What `from` (split at dots into `parts`) reads: a stage's output port, then `meta.KEY…`, a
/// table or a table's column of its artefact kind; or the problem and its help.
fn source_of(plan: &Plan, from: &str, parts: &[&str]) -> Result<Source, (String, String)> {
    if parts.len() < 3 || parts.iter().any(|p| p.is_empty()) {
        return Err((format!("`{from}` is not a source path"), HELP_FORMS.into()));
    }
    let Some(node) = plan.nodes.iter().find(|n| n.name == parts[0]) else {
        let names: Vec<&str> = plan.nodes.iter().map(|n| n.name.as_str()).collect();
        let help = match nearest(parts[0], names.iter().copied()) {
            Some(n) => format!("did you mean `{n}`?"),
            None => format!("stages are: {}", names.join(", ")),
        };
        return Err((format!("no stage `{}` in the pipeline", parts[0]), help));
    };
    let outputs = node.stage.outputs();
    let Some(port) = outputs.iter().find(|o| o.name == parts[1]) else {
        let list: Vec<String> = outputs
            .iter()
            .map(|o| format!("{} ({})", o.name, o.kind))
            .collect();
        return Err((
            format!(
                "stage `{}` ({}) has no output `{}`",
                node.name,
                node.stage.kind(),
                parts[1]
            ),
            format!("outputs: {}", list.join(", ")),
        ));
    };
    if parts[2] == "meta" {
        if parts.len() < 4 {
            return Err((
                "`meta` needs a key, e.g. `meta.summary.mean_chi`".into(),
                HELP_FORMS.into(),
            ));
        }
        return Ok(Source::Meta(
            parts[3..].iter().map(|s| s.to_string()).collect(),
        ));
    }
    table_source(port.kind, from, parts)
}

/// A table (`stage.port.table`) or one of its columns (`….column`) of a `kind` artefact.
fn table_source(
    kind: ArtefactKind,
    from: &str,
    parts: &[&str],
) -> Result<Source, (String, String)> {
    let tables = layout(kind);
    let Some(t) = tables.iter().find(|t| matches_layout(t.name, parts[2])) else {
        let list: Vec<&str> = tables.iter().map(|t| t.name).collect();
        return Err((
            format!("a `{}` artefact has no table `{}`", kind, parts[2]),
            format!("tables: {}; or `meta.KEY`", list.join(", ")),
        ));
    };
    match parts.len() {
        3 => Ok(Source::Table(parts[2].to_string())),
        4 => {
            if !t.columns.iter().any(|c| matches_layout(c.name, parts[3])) {
                let list: Vec<&str> = t.columns.iter().map(|c| c.name).collect();
                let help = match nearest(parts[3], list.iter().copied()) {
                    Some(n) => format!("did you mean `{n}`? columns: {}", list.join(", ")),
                    None => format!("columns: {}", list.join(", ")),
                };
                return Err((
                    format!(
                        "table `{}` of a `{}` artefact has no column `{}`",
                        parts[2], kind, parts[3]
                    ),
                    help,
                ));
            }
            Ok(Source::Column(parts[2].to_string(), parts[3].to_string()))
        }
        _ => Err((format!("`{from}` goes below a column"), HELP_FORMS.into())),
    }
}

fn check_plot(
    sweep: &SourcedSweep,
    i: usize,
    p: &PlotSpec,
    items: &[CollectItem],
    params: &[ParamPath],
    diags: &mut Vec<Diagnostic>,
) {
    let idx = i.to_string();
    let known = |c: &str| {
        items.iter().any(|it| {
            it.name == c
                || (matches!(it.source, Source::Table(_))
                    && c.starts_with(&format!("{}.", it.name)))
        })
    };
    let names: Vec<String> = items.iter().map(|it| it.name.clone()).collect();
    let is_param = |c: &str| params.iter().any(|q| q.text == c || q.short() == c);
    for (field, value) in [("column", Some(&p.column)), ("split", p.split.as_ref())] {
        let Some(v) = value else { continue };
        if !(known(v) || (field == "split" && is_param(v))) {
            diags.push(
                sweep
                    .at_value(
                        &["plots", &idx, field],
                        format!("`{v}` is not a collected column"),
                    )
                    .field(format!("plots.{i}.{field}"))
                    .help(if names.is_empty() {
                        "add it to `collect:` first".to_string()
                    } else {
                        format!("collected: {}", names.join(", "))
                    }),
            );
        }
    }
    if !is_param(&p.by) && !known(&p.by) {
        let list: Vec<&str> = params.iter().map(|q| q.text.as_str()).collect();
        diags.push(
            sweep
                .at_value(
                    &["plots", &idx, "by"],
                    format!(
                        "`{}` is neither a swept parameter nor a collected column",
                        p.by
                    ),
                )
                .field(format!("plots.{i}.by"))
                .help(format!("swept parameters: {}", list.join(", "))),
        );
    }
}

/// The result of `femu sweep collect`.
#[derive(Clone, Debug)]
pub struct Collected {
    /// The table.
    pub table: Table,
    /// The Parquet file.
    pub path: PathBuf,
    /// Content digest of the table (blake3 over names, types and values).
    pub digest: String,
    /// Points in the table.
    pub points: usize,
    /// Unique points not finished (not in the table).
    pub missing: Vec<String>,
    /// Figures written (PNG and SVG).
    pub plots: Vec<PathBuf>,
}

/// The content digest of a table: names, types and values in order, format-independent.
pub fn table_digest(t: &Table) -> String {
    let mut h = blake3::Hasher::new();
    let mut field = |b: &[u8]| {
        h.update(&(b.len() as u64).to_le_bytes());
        h.update(b);
    };
    field(b"femu-sweep-table-v1");
    for (name, c) in &t.columns {
        field(name.as_bytes());
        field(c.type_name().as_bytes());
        match c {
            Column::F64(v) => v.iter().for_each(|x| field(&x.to_le_bytes())),
            Column::I64(v) => v.iter().for_each(|x| field(&x.to_le_bytes())),
            Column::I32(v) => v.iter().for_each(|x| field(&x.to_le_bytes())),
            Column::Str(v) => v.iter().for_each(|x| field(x.as_bytes())),
        }
    }
    h.finalize().to_hex().to_string()
}

/// Values of one point for one item: a scalar, or a column.
enum Got {
    Scalar(Column),
    Rows(Vec<(String, Column)>),
}

fn json_cell(v: &Value) -> Column {
    match v {
        Value::Number(n) if n.is_i64() => Column::I64(vec![n.as_i64().unwrap_or(0)]),
        Value::Number(n) => Column::F64(vec![n.as_f64().unwrap_or(f64::NAN)]),
        Value::Bool(b) => Column::I64(vec![i64::from(*b)]),
        Value::String(s) => Column::Str(vec![s.clone()]),
        other => Column::Str(vec![other.to_string()]),
    }
}

fn reduce(c: &Column, r: Reduce, what: &str) -> Result<Column, SweepError> {
    let n = c.len();
    if r == Reduce::Count {
        return Ok(Column::I64(vec![n as i64]));
    }
    if matches!(r, Reduce::First | Reduce::Last) {
        if n == 0 {
            return Err(SweepError::Collect(format!("{what}: the column is empty")));
        }
        let i = if r == Reduce::First { 0 } else { n - 1 };
        return Ok(match c {
            Column::F64(v) => Column::F64(vec![v[i]]),
            Column::I64(v) => Column::I64(vec![v[i]]),
            Column::I32(v) => Column::I32(vec![v[i]]),
            Column::Str(v) => Column::Str(vec![v[i].clone()]),
        });
    }
    let v: Vec<f64> = match c {
        Column::F64(v) => v.clone(),
        Column::I64(v) => v.iter().map(|x| *x as f64).collect(),
        Column::I32(v) => v.iter().map(|x| f64::from(*x)).collect(),
        Column::Str(_) => {
            return Err(SweepError::Collect(format!(
                "{what}: `{r:?}` needs numbers but the column holds text"
            )));
        }
    };
    if v.is_empty() {
        return Err(SweepError::Collect(format!("{what}: the column is empty")));
    }
    let x = match r {
        Reduce::Mean => v.iter().sum::<f64>() / v.len() as f64,
        Reduce::Sum => v.iter().sum(),
        Reduce::Min => v.iter().copied().fold(f64::INFINITY, f64::min),
        Reduce::Max => v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        _ => f64::NAN,
    };
    Ok(Column::F64(vec![x]))
}

fn read_item(
    cache: &Cache,
    status: &super::PointStatus,
    item: &CollectItem,
) -> Result<Got, SweepError> {
    let what = format!("point `{}`, `{}`", status.point, item.name);
    let stage = status.stages.get(&item.stage).ok_or_else(|| {
        SweepError::Collect(format!("{what}: the point has no stage `{}`", item.stage))
    })?;
    let out = stage.outputs.get(&item.port).ok_or_else(|| {
        SweepError::Collect(format!(
            "{what}: stage `{}` has no output `{}`",
            item.stage, item.port
        ))
    })?;
    let kind = ArtefactKind::from_name(&out.kind).ok_or_else(|| {
        SweepError::Collect(format!("{what}: unknown artefact kind `{}`", out.kind))
    })?;
    let a = cache.read(&stage.key, &item.port, kind)?;
    match &item.source {
        Source::Meta(keys) => {
            let mut v = Value::Object(a.meta.clone());
            for k in keys {
                v = v.get(k).cloned().ok_or_else(|| {
                    SweepError::Collect(format!(
                        "{what}: the artefact's meta has no `{}`",
                        keys.join(".")
                    ))
                })?;
            }
            Ok(Got::Scalar(json_cell(&v)))
        }
        Source::Column(t, c) => {
            let table = &a
                .tables
                .get(t)
                .ok_or_else(|| {
                    SweepError::Collect(format!("{what}: the artefact has no table `{t}`"))
                })?
                .0;
            let col = table.column(c).ok_or_else(|| {
                SweepError::Collect(format!("{what}: table `{t}` has no column `{c}`"))
            })?;
            match item.reduce {
                Some(r) => Ok(Got::Scalar(reduce(col, r, &what)?)),
                None => Ok(Got::Rows(vec![(item.name.clone(), col.clone())])),
            }
        }
        Source::Table(t) => {
            let table = &a
                .tables
                .get(t)
                .ok_or_else(|| {
                    SweepError::Collect(format!("{what}: the artefact has no table `{t}`"))
                })?
                .0;
            Ok(Got::Rows(
                table
                    .columns
                    .iter()
                    .map(|(c, col)| (format!("{}.{c}", item.name), col.clone()))
                    .collect(),
            ))
        }
    }
}

fn repeat(c: &Column, n: usize) -> Column {
    match c {
        Column::F64(v) => Column::F64(vec![v[0]; n]),
        Column::I64(v) => Column::I64(vec![v[0]; n]),
        Column::I32(v) => Column::I32(vec![v[0]; n]),
        Column::Str(v) => Column::Str(vec![v[0].clone(); n]),
    }
}

/// Appends `add` to `acc`, promoting integers to floats when the points disagree.
fn append(acc: &mut Option<Column>, add: Column, name: &str) -> Result<(), SweepError> {
    let Some(cur) = acc.as_mut() else {
        *acc = Some(add);
        return Ok(());
    };
    // Integers of both widths are collected as 64-bit ones.
    let widen = |c: Column| match c {
        Column::I32(v) => Column::I64(v.into_iter().map(i64::from).collect()),
        c => c,
    };
    if matches!(cur, Column::I32(_)) {
        *cur = widen(std::mem::replace(cur, Column::I64(Vec::new())));
    }
    match (cur, widen(add)) {
        (Column::F64(a), Column::F64(b)) => a.extend(b),
        (Column::I64(a), Column::I64(b)) => a.extend(b),
        (Column::Str(a), Column::Str(b)) => a.extend(b),
        (Column::F64(a), Column::I64(b)) => a.extend(b.iter().map(|x| *x as f64)),
        (cur @ Column::I64(_), Column::F64(b)) => {
            let Column::I64(a) = &*cur else { return Ok(()) };
            let mut f: Vec<f64> = a.iter().map(|x| *x as f64).collect();
            f.extend(b);
            *cur = Column::F64(f);
        }
        (cur, add) => {
            return Err(SweepError::Collect(format!(
                "column `{name}` holds {} in some points and {} in others",
                cur.type_name(),
                add.type_name()
            )));
        }
    }
    Ok(())
}

fn param_column(values: &[&Value]) -> Column {
    if values.iter().all(|v| v.is_i64()) {
        Column::I64(values.iter().map(|v| v.as_i64().unwrap_or(0)).collect())
    } else if values.iter().all(|v| v.is_number()) {
        Column::F64(
            values
                .iter()
                .map(|v| v.as_f64().unwrap_or(f64::NAN))
                .collect(),
        )
    } else if values.iter().all(|v| v.is_string()) {
        Column::Str(
            values
                .iter()
                .map(|v| v.as_str().unwrap_or("").to_string())
                .collect(),
        )
    } else {
        Column::Str(values.iter().map(|v| v.to_string()).collect())
    }
}

/// Builds the collected table, writes it (`collected.parquet`, `collected.json`) and the plots
/// under `out`.
pub fn collect(
    resolved: &Resolved,
    state: &StateDir,
    cache: &Cache,
    out: &Path,
) -> Result<Collected, SweepError> {
    let sweep = &resolved.sweep;
    let Some(first) = resolved.unique.first() else {
        return Err(SweepError::Usage("the sweep has no point".into()));
    };
    let items = check_collect(sweep, &first.plan, &resolved.expansion.params)
        .map_err(|d| SweepError::Invalid(crate::pipeline::Diagnostics(d)))?;
    if items.is_empty() {
        return Err(SweepError::Usage(format!(
            "{}: nothing to collect; add a `collect:` block, e.g. `collect: {{mean_chi: correlation.correlation.meta.summary.mean_chi}}`",
            sweep.file
        )));
    }
    let has_rows = items
        .iter()
        .any(|i| i.reduce.is_none() && !matches!(i.source, Source::Meta(_)));
    let mut g = Gathered {
        point_col: Vec::new(),
        row_col: Vec::new(),
        param_vals: vec![Vec::new(); resolved.expansion.params.len()],
        cols: Vec::new(),
        has_rows,
    };
    let mut missing = Vec::new();
    let mut points = 0;
    for u in &resolved.unique {
        match state.status(&u.point.name) {
            Some(s) if s.state == PointState::Done && s.plan_hash == u.plan_hash => {
                points += 1;
                g.add_point(u, &s, cache, &items)?;
            }
            _ => missing.push(u.point.name.clone()),
        }
    }
    if points == 0 {
        return Err(SweepError::Collect(format!(
            "no point of {} is finished yet; run `femu sweep {}` first",
            sweep.name(),
            sweep.file
        )));
    }
    let table = g.into_table(&resolved.expansion.params)?;
    write_collected(resolved, table, out, points, missing)
}

/// The collected columns of the finished points, point by point: one row per point, or per
/// row of its collected table columns.
struct Gathered<'a> {
    point_col: Vec<String>,
    row_col: Vec<i64>,
    /// Each swept parameter's value on every row.
    param_vals: Vec<Vec<&'a Value>>,
    /// Collected columns in first-seen order; `None` until a point gives one.
    cols: Vec<(String, Option<Column>)>,
    /// Whether any item is a whole column, so the table gets a `row` column.
    has_rows: bool,
}

impl<'a> Gathered<'a> {
    /// Appends one finished point's rows: its items read from the cache, scalars repeated on
    /// each of its rows.
    fn add_point(
        &mut self,
        u: &'a PlannedPoint,
        status: &PointStatus,
        cache: &Cache,
        items: &[CollectItem],
    ) -> Result<(), SweepError> {
        let mut scalars: Vec<(String, Column)> = Vec::new();
        let mut rows: Vec<(String, Column)> = Vec::new();
        for item in items {
            match read_item(cache, status, item)? {
                Got::Scalar(c) => scalars.push((item.name.clone(), c)),
                Got::Rows(r) => rows.extend(r),
            }
        }
        let n = rows.first().map(|r| r.1.len()).unwrap_or(1);
        if let Some((name, c)) = rows.iter().find(|r| r.1.len() != n) {
            return Err(SweepError::Collect(format!(
                "point `{}`: column `{name}` has {} rows but `{}` has {n}; collect columns of one table, or reduce them",
                u.point.name,
                c.len(),
                rows[0].0
            )));
        }
        for _ in 0..n {
            self.point_col.push(u.point.name.clone());
        }
        if self.has_rows {
            self.row_col.extend(0..n as i64);
        }
        for (k, (_, v)) in u.point.values.iter().enumerate() {
            for _ in 0..n {
                self.param_vals[k].push(v);
            }
        }
        let scalars = scalars.into_iter().map(|(name, c)| (name, repeat(&c, n)));
        for (name, c) in scalars.chain(rows) {
            let slot = match self.cols.iter().position(|(c, _)| *c == name) {
                Some(i) => i,
                None => {
                    self.cols.push((name.clone(), None));
                    self.cols.len() - 1
                }
            };
            append(&mut self.cols[slot].1, c, &name)?;
        }
        Ok(())
    }

    /// The table: `point`, the swept parameters, `row` if any, then the collected columns,
    /// each present in every point.
    fn into_table(self, params: &[ParamPath]) -> Result<Table, SweepError> {
        let total_rows = self.point_col.len();
        let mut table = Table::new().with("point", Column::Str(self.point_col));
        for (p, vals) in params.iter().zip(&self.param_vals) {
            table = table.with(p.short(), param_column(vals));
        }
        if self.has_rows {
            table = table.with("row", Column::I64(self.row_col));
        }
        for (name, c) in self.cols {
            let c = c.unwrap_or(Column::F64(Vec::new()));
            if c.len() != total_rows {
                return Err(SweepError::Collect(format!(
                    "column `{name}` is missing in some points; every point must have the same collected columns"
                )));
            }
            table = table.with(name, c);
        }
        Ok(table)
    }
}

/// Writes `collected.parquet`, the plots and `collected.json` (the summary) into `out`.
fn write_collected(
    resolved: &Resolved,
    table: Table,
    out: &Path,
    points: usize,
    missing: Vec<String>,
) -> Result<Collected, SweepError> {
    let sweep = &resolved.sweep;
    std::fs::create_dir_all(out).map_err(|source| SweepError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let path = out.join("collected.parquet");
    write_parquet(&table, &path)?;
    let digest = table_digest(&table);
    let mut plots = Vec::new();
    for p in &sweep.spec.plots {
        plots.extend(write_plot(&table, p, &resolved.expansion.params, out)?);
    }
    let summary = serde_json::json!({
        "sweep": sweep.name(),
        "pipeline": sweep.spec.pipeline,
        "points": points,
        "rows": table.rows(),
        "columns": table.columns.iter().map(|(n, c)| serde_json::json!({"name": n, "type": c.type_name()})).collect::<Vec<_>>(),
        "digest": digest,
        "missing": missing,
    });
    write_atomic(
        &out.join("collected.json"),
        (serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n").as_bytes(),
    )?;
    Ok(Collected {
        table,
        path,
        digest,
        points,
        missing,
        plots,
    })
}

/// Text of a cell for grouping.
fn cell_label(c: &Column, i: usize) -> String {
    match c {
        Column::F64(v) => {
            let x = v[i];
            if x == x.trunc() && x.abs() < 1e15 {
                format!("{x:.1}")
            } else {
                format!("{x}")
            }
        }
        Column::I64(v) => v[i].to_string(),
        Column::I32(v) => v[i].to_string(),
        Column::Str(v) => v[i].clone(),
    }
}

/// Sort key of a group: numbers by value, text by text.
fn cell_key(c: &Column, i: usize) -> (f64, String) {
    match c {
        Column::F64(v) => (v[i], String::new()),
        Column::I64(v) => (v[i] as f64, String::new()),
        Column::I32(v) => (f64::from(v[i]), String::new()),
        Column::Str(v) => (0.0, v[i].clone()),
    }
}

fn write_plot(
    table: &Table,
    p: &PlotSpec,
    params: &[ParamPath],
    out: &Path,
) -> Result<Vec<PathBuf>, SweepError> {
    let column_of = |name: &str| {
        params
            .iter()
            .find(|q| q.text == name || q.short() == name)
            .map(|q| q.short())
            .unwrap_or_else(|| name.to_string())
    };
    let by = column_of(&p.by);
    let split_name = p.split.as_deref().map(column_of);
    let get = |name: &str| {
        table.column(name).ok_or_else(|| {
            SweepError::Collect(format!("plot: the collected table has no column `{name}`"))
        })
    };
    let ys: Vec<f64> = match get(&p.column)? {
        Column::F64(v) => v.clone(),
        Column::I64(v) => v.iter().map(|x| *x as f64).collect(),
        Column::I32(v) => v.iter().map(|x| f64::from(*x)).collect(),
        Column::Str(_) => {
            return Err(SweepError::Collect(format!(
                "plot: column `{}` holds text; a box plot needs numbers",
                p.column
            )));
        }
    };
    let xcol = get(&by)?;
    let split = split_name.as_deref().map(get).transpose()?;
    let mut xs: Vec<(f64, String, String)> = (0..ys.len())
        .map(|i| {
            let (k, s) = cell_key(xcol, i);
            (k, s, cell_label(xcol, i))
        })
        .collect();
    xs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    xs.dedup_by(|a, b| a.2 == b.2);
    let mut splits: Vec<String> = match split {
        Some(c) => {
            let mut v: Vec<String> = (0..ys.len()).map(|i| cell_label(c, i)).collect();
            v.sort();
            v.dedup();
            v
        }
        None => vec![String::new()],
    };
    if splits.is_empty() {
        splits.push(String::new());
    }
    let mut groups = Vec::new();
    for (_, _, xl) in &xs {
        let mut boxes = Vec::new();
        for s in &splits {
            let vals: Vec<f64> = (0..ys.len())
                .filter(|&i| {
                    cell_label(xcol, i) == *xl && split.is_none_or(|c| cell_label(c, i) == *s)
                })
                .map(|i| ys[i])
                .filter(|y| y.is_finite())
                .collect();
            boxes.push(vals);
        }
        groups.push((xl.clone(), boxes));
    }
    let title = p
        .title
        .clone()
        .unwrap_or_else(|| format!("{} by {by}", p.column));
    let fig = crate::report::box_plot::box_plot(&crate::report::box_plot::BoxPlotData {
        title,
        x_label: by.clone(),
        y_label: p.column.clone(),
        series: if split.is_some() {
            splits.clone()
        } else {
            Vec::new()
        },
        groups,
    })
    .map_err(|e| SweepError::Plot(e.to_string()))?;
    let stem: String = format!("box-{}-by-{by}", p.column)
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    let png = out.join(format!("{stem}.png"));
    let svg = out.join(format!("{stem}.svg"));
    write_atomic(&png, &fig.png)?;
    write_atomic(&svg, fig.svg.as_bytes())?;
    Ok(vec![png, svg])
}
