//! Expansion of a sweep into points, their stable names, their plans and the dedupe of points
//! whose plans are identical.
//!
//! Every `matrix:` entry is one axis; every `zip:` group is one axis whose values are tuples. The
//! points are the cartesian product of the axes in file order (matrix entries, then zip groups;
//! the first axis varies slowest), less the `exclude:` holes. A point is the pipeline with one
//! `--set stage.param=value` override per swept parameter, after the sweep's `set:` overrides.
//!
//! Names follow DVC's `stage@value`: one segment `stage.param@value` per swept parameter, sorted
//! by parameter so that reordering the file keeps them, joined by `,`
//! (`measured.level@0.05,measured.seed@3`). Text values keep their safe characters and gain a
//! short hash when any had to be replaced; lists and maps are named by a hash of their canonical
//! JSON, so inserting a value never renames the others.
//!
//! A point's plan hash is the blake3 of every node's kind, implementation version, key
//! parameters, format and wiring (recursively, so each node's hash covers its upstream): what
//! the cache key will be built from, without running anything. Points with equal plan hashes are
//! the same computation; only the first is kept. Nodes whose hash is the same in every point are
//! the sweep's common upstream, computed once before the points run.

use super::spec::SourcedSweep;
use crate::artefact::digest::{canonical_json, hash_bytes};
use crate::pipeline::diagnostic::{Diagnostic, Diagnostics, nearest};
use crate::pipeline::{Plan, SourcedSpec, plan, read_pipeline};
use crate::stages::registry;
use indexmap::IndexMap;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};

/// Most points one sweep may expand to.
pub const MAX_POINTS: usize = 1_000_000;

/// A swept parameter: `stage.with.param[.sub…]`.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct ParamPath {
    /// As written in the sweep file.
    pub text: String,
    /// The stage.
    pub stage: String,
    /// The path below `with`.
    pub rest: Vec<String>,
}

impl ParamPath {
    /// The path without `with`: `stage.param`, as `--set` takes it and columns are named.
    pub fn short(&self) -> String {
        format!("{}.{}", self.stage, self.rest.join("."))
    }

    /// The `--set` argument giving this parameter `value`.
    pub fn set_arg(&self, value: &Value) -> String {
        format!("{}={}", self.short(), value)
    }
}

/// One axis of the product: one or more parameters and their values, tuple by tuple.
#[derive(Clone, Debug)]
pub struct Axis {
    /// The parameters set together.
    pub params: Vec<ParamPath>,
    /// Tuples of values, one value per parameter.
    pub values: Vec<Vec<Value>>,
}

/// One point of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Position in the expansion (after exclusion).
    pub index: usize,
    /// Stable name.
    pub name: String,
    /// Swept parameter (as written) → value, in axis order.
    pub values: Vec<(String, Value)>,
    /// The `--set` arguments of the point: the sweep's `set:` then the swept values.
    pub overrides: Vec<String>,
}

/// The points of a sweep, before planning.
#[derive(Clone, Debug)]
pub struct Expansion {
    /// Swept parameters in axis order.
    pub params: Vec<ParamPath>,
    /// Points in expansion order.
    pub points: Vec<Point>,
    /// Points removed by `exclude:`.
    pub excluded: usize,
}

/// A point with its plan.
#[derive(Clone)]
pub struct PlannedPoint {
    /// The point.
    pub point: Point,
    /// Its checked plan.
    pub plan: Plan,
    /// Hash of the whole plan.
    pub plan_hash: String,
    /// Hash of each node, upstream included, in plan order.
    pub node_hashes: Vec<String>,
}

/// A sweep ready to run: unique planned points, the duplicates dropped, the common stages.
#[derive(Clone)]
pub struct Resolved {
    /// The sweep file.
    pub sweep: SourcedSweep,
    /// Its expansion.
    pub expansion: Expansion,
    /// Unique points in expansion order.
    pub unique: Vec<PlannedPoint>,
    /// Dropped point → the kept point with the same plan.
    pub duplicates: Vec<(String, String)>,
    /// Stages whose computation is the same in every point, in plan order.
    pub common: Vec<String>,
}

/// The pipeline of a sweep with the sweep's `set:` overrides applied.
pub fn base_pipeline(sweep: &SourcedSweep) -> Result<SourcedSpec, Diagnostics> {
    let path = sweep.pipeline_path();
    if !path.is_file() {
        return Err(Diagnostics(vec![
            sweep
                .at_value(
                    &["pipeline"],
                    format!("pipeline file `{}` does not exist", path.display()),
                )
                .field("pipeline")
                .help("give the pipeline's path relative to the sweep file, e.g. `../pipelines/four-dof.yaml`"),
        ]));
    }
    let mut src = read_pipeline(&path)?;
    let mut diags = Vec::new();
    let mut sets = Vec::new();
    for (key, value) in &sweep.spec.set {
        match param_path(sweep, &src, key, &["set", key]) {
            Ok(p) => {
                if value.is_null() {
                    diags.push(null_value(sweep, &["set", key], key));
                } else {
                    sets.push((p.set_arg(value), vec!["set".to_string(), key.clone()]));
                }
            }
            Err(d) => diags.push(d),
        }
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    for (arg, at) in &sets {
        if let Err(e) = src.apply_overrides(std::slice::from_ref(arg)) {
            let at: Vec<&str> = at.iter().map(String::as_str).collect();
            diags.extend(rehome(sweep, &at, &e, &at[1..].join(".")));
        }
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    plan(&src, &registry()).map_err(|e| {
        // Problems that only the overrides cause are the sweep's; report them there too.
        if sets.is_empty() {
            e
        } else {
            let mut d = e.0;
            d.push(
                Diagnostic::new(
                    &sweep.file,
                    "the pipeline with the sweep's `set:` overrides is not valid (see above)",
                )
                .at(sweep.locator.key(&["set"]))
                .field("set"),
            );
            Diagnostics(d)
        }
    })?;
    Ok(src)
}

fn null_value(sweep: &SourcedSweep, at: &[&str], key: &str) -> Diagnostic {
    sweep
        .at_value(at, format!("`{key}` has no value (null)"))
        .field(at.join("."))
        .help("give a value; to keep the pipeline's own value, leave the parameter out")
}

/// Parses `stage.with.param[.sub…]` against the pipeline's stages.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn param_path(
    sweep: &SourcedSweep,
    pipeline: &SourcedSpec,
    key: &str,
    at: &[&str],
) -> Result<ParamPath, Diagnostic> {
    let parts: Vec<&str> = key.split('.').collect();
    // Escaped: a key may hold a line break.
    let field = at.join(".").escape_debug().to_string();
    let stages: Vec<&str> = pipeline.spec.stages.keys().map(String::as_str).collect();
    let bad = |msg: String, help: String| sweep.at_key(at, msg).field(field.clone()).help(help);
    if parts.iter().any(|p| p.is_empty()) || parts.len() < 2 {
        return Err(bad(
            format!("`{key}` is not a parameter path"),
            "write `stage.with.param`, e.g. `measured.with.seed`".into(),
        ));
    }
    if !pipeline.spec.stages.contains_key(parts[0]) {
        let help = match nearest(parts[0], stages.iter().copied()) {
            Some(n) => format!("did you mean `{n}`? stages are: {}", stages.join(", ")),
            None => format!("stages are: {}", stages.join(", ")),
        };
        return Err(bad(
            format!(
                "no stage `{}` in the pipeline `{}`",
                parts[0], pipeline.spec.name
            ),
            help,
        ));
    }
    if parts[1] != "with" || parts.len() < 3 {
        let suggestion = if parts[1] == "with" {
            format!("{}.with.<param>", parts[0])
        } else {
            format!("{}.with.{}", parts[0], parts[1..].join("."))
        };
        return Err(bad(
            format!("`{key}` does not name a parameter below `with`"),
            format!("sweeps set stage parameters: write `{suggestion}`"),
        ));
    }
    // The path is part of every point's name, which names a directory and a task-list line.
    if let Some(bad_part) = parts[2..].iter().find(|p| {
        !p.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
    }) {
        return Err(bad(
            format!("{bad_part:?} in `{}` is not a usable parameter name", key.escape_debug()),
            "parameter names (and the deeper keys after them) are ASCII letters, digits, `_` and `-`, e.g. `measured.with.seed`".into(),
        ));
    }
    Ok(ParamPath {
        text: key.to_string(),
        stage: parts[0].to_string(),
        rest: parts[2..].iter().map(|s| s.to_string()).collect(),
    })
}

/// Re-reports pipeline diagnostics caused by a sweep value at that value.
fn rehome(sweep: &SourcedSweep, at: &[&str], e: &Diagnostics, what: &str) -> Vec<Diagnostic> {
    e.0.iter()
        .map(|d| {
            let mut where_ = String::new();
            if let Some(s) = &d.stage {
                where_ = format!(" stage `{s}`");
                if let Some(f) = &d.field {
                    where_.push_str(&format!(", field `{f}`"));
                }
                where_.push(':');
            }
            let mut out = sweep
                .at_value(
                    at,
                    format!("{what} makes the pipeline invalid:{where_} {}", d.message),
                )
                .field(at.join("."));
            out.help = d.help.clone();
            out
        })
        .collect()
}

/// Two values are the same sweep value: equal JSON, numbers compared by value.
pub fn same_value(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => x.as_f64() == y.as_f64(),
        _ => canonical_json(a) == canonical_json(b),
    }
}

fn show(v: &Value) -> String {
    v.to_string()
}

/// Values of one axis entry: a non-empty list or `{range: [first, last], step}`.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn axis_values(sweep: &SourcedSweep, at: &[&str], v: &Value) -> Result<Vec<Value>, Diagnostic> {
    let field = at.join(".");
    let err = |msg: String, help: &str| sweep.at_value(at, msg).field(field.clone()).help(help);
    let values = match v {
        Value::Array(items) => items.clone(),
        Value::Object(map) if map.contains_key("range") => range_values(sweep, at, map)?,
        _ => {
            return Err(err(
                format!(
                    "the values of `{}` must be a list or a range, not {}",
                    at[at.len() - 1],
                    kind_of(v)
                ),
                "write `[v1, v2, …]` or `{range: [first, last]}` (with `step: S` when not 1)",
            ));
        }
    };
    if values.is_empty() {
        return Err(err(
            "the axis has no values".into(),
            "give at least one value",
        ));
    }
    for (i, x) in values.iter().enumerate() {
        let mut p: Vec<&str> = at.to_vec();
        let idx = i.to_string();
        p.push(&idx);
        if x.is_null() {
            return Err(sweep
                .at_value(&p, "null is not a parameter value")
                .field(field.clone())
                .help("give a value, or leave the parameter out of the sweep"));
        }
        if let Some(j) = values[..i].iter().position(|y| same_value(x, y)) {
            return Err(sweep
                .at_value(
                    &p,
                    format!(
                        "value {} is listed twice (also at position {})",
                        show(x),
                        j + 1
                    ),
                )
                .field(field.clone())
                .help("list every value once"));
        }
    }
    Ok(values)
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "text",
        Value::Array(_) => "a list",
        Value::Object(_) => "a mapping",
    }
}

/// Largest number of values of one range.
const MAX_RANGE: usize = 1_000_000;

// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn range_values(
    sweep: &SourcedSweep,
    at: &[&str],
    map: &serde_json::Map<String, Value>,
) -> Result<Vec<Value>, Diagnostic> {
    let field = format!("{}.range", at.join("."));
    let mut p: Vec<&str> = at.to_vec();
    p.push("range");
    let help = "write `{range: [first, last]}` or `{range: [first, last], step: S}`: first and last included, step > 0";
    if let Some(k) = map.keys().find(|k| *k != "range" && *k != "step") {
        let mut kp = at.to_vec();
        kp.push(k);
        return Err(sweep
            .at_key(&kp, format!("unknown key `{k}` in a range"))
            .field(field)
            .help(help));
    }
    let bounds = match map.get("range") {
        Some(Value::Array(b)) if b.len() == 2 && b.iter().all(Value::is_number) => b,
        _ => {
            return Err(sweep
                .at_value(
                    &p,
                    "`range` must be two numbers, the first and the last value",
                )
                .field(field)
                .help(help));
        }
    };
    let step = map.get("step");
    if let Some(s) = step
        && !s.is_number()
    {
        let mut sp = at.to_vec();
        sp.push("step");
        return Err(sweep
            .at_value(&sp, "`step` must be a number")
            .field(format!("{}.step", at.join(".")))
            .help(help));
    }
    let ints = bounds.iter().chain(step).all(|v| v.is_i64());
    let values = if ints {
        int_range(
            bounds[0].as_i64().unwrap_or(0),
            bounds[1].as_i64().unwrap_or(0),
            step.and_then(Value::as_i64).unwrap_or(1),
        )
    } else {
        float_range(
            bounds[0].as_f64().unwrap_or(0.0),
            bounds[1].as_f64().unwrap_or(0.0),
            step.and_then(Value::as_f64).unwrap_or(1.0),
        )
    };
    values.map_err(|fault| {
        let (msg, help) = match fault {
            RangeFault::Empty(msg) => (msg, help),
            RangeFault::TooLong(msg) => (msg, "narrow the range or raise the step"),
        };
        sweep.at_value(&p, msg).field(field).help(help)
    })
}

/// Why a range gives no values.
enum RangeFault {
    /// Empty or backwards.
    Empty(String),
    /// More than [`MAX_RANGE`] values.
    TooLong(String),
}

/// `a, a + s, …` up to `b` in integers.
fn int_range(a: i64, b: i64, s: i64) -> Result<Vec<Value>, RangeFault> {
    if s <= 0 || b < a {
        return Err(RangeFault::Empty(format!(
            "the range [{a}, {b}] with step {s} is empty or runs backwards"
        )));
    }
    let n = b
        .checked_sub(a)
        .map_or(usize::MAX, |d| (d / s) as usize)
        .saturating_add(1);
    if n > MAX_RANGE {
        return Err(RangeFault::TooLong(format!(
            "the range has {n} values, more than {MAX_RANGE}"
        )));
    }
    Ok((0..n).map(|i| Value::from(a + s * i as i64)).collect())
}

/// `a, a + s, …` up to `b` (within rounding) in floating point, each rounded to 12
/// significant digits.
fn float_range(a: f64, b: f64, s: f64) -> Result<Vec<Value>, RangeFault> {
    if !(s > 0.0) || !(b >= a) || !a.is_finite() || !b.is_finite() {
        return Err(RangeFault::Empty(format!(
            "the range [{a}, {b}] with step {s} is empty or runs backwards"
        )));
    }
    let n = ((b - a) / s * (1.0 + 1e-12) + 1e-9).floor() + 1.0;
    if !(n <= MAX_RANGE as f64) {
        return Err(RangeFault::TooLong(format!(
            "the range has {n} values, more than {MAX_RANGE}"
        )));
    }
    Ok((0..n as usize)
        .map(|i| {
            // Rounded to 12 significant digits so that 0.1 * 3 is named and keyed as 0.3.
            let v = a + s * i as f64;
            let v: f64 = format!("{v:.11e}").parse().unwrap_or(v);
            serde_json::Number::from_f64(v)
                .map(Value::Number)
                .unwrap_or(Value::Null)
        })
        .collect())
}

/// Expands the sweep's axes into points (no planning); at most
/// [`super::spec::MAX_REPORTED_ERRORS`] problems are listed.
pub fn expand(sweep: &SourcedSweep, pipeline: &SourcedSpec) -> Result<Expansion, Diagnostics> {
    expand_all(sweep, pipeline).map_err(|d| super::spec::capped(&sweep.file, d.0))
}

/// The phases of [`expand`]: the axes, their product's size, the exclusion rules, the points,
/// and the exclusions that matched nothing.
fn expand_all(sweep: &SourcedSweep, pipeline: &SourcedSpec) -> Result<Expansion, Diagnostics> {
    let axes = swept_axes(sweep, pipeline)?;
    let params: Vec<ParamPath> = axes.iter().flat_map(|a| a.params.clone()).collect();
    let total = point_count(sweep, &axes)?;
    let rules = exclusion_rules(sweep, &axes, &params)?;
    let product = product(sweep, &axes, &params, &rules, total);
    check_exclusions_hit(sweep, &product.hits, product.points.is_empty())?;
    Ok(Expansion {
        params,
        points: product.points,
        excluded: product.excluded,
    })
}

/// The axes in file order: one per `matrix:` entry, then one per `zip:` group.
fn swept_axes(sweep: &SourcedSweep, pipeline: &SourcedSpec) -> Result<Vec<Axis>, Diagnostics> {
    let mut r = AxisReader {
        sweep,
        pipeline,
        seen: BTreeMap::new(),
        diags: Vec::new(),
    };
    let mut axes: Vec<Axis> = Vec::new();
    for (key, v) in &sweep.spec.matrix {
        axes.extend(r.matrix_axis(key, v));
    }
    for (g, group) in sweep.spec.zip.iter().enumerate() {
        axes.extend(r.zip_axis(g, group));
    }
    if !r.diags.is_empty() {
        return Err(Diagnostics(r.diags));
    }
    Ok(axes)
}

/// Reads the axes, reporting every problem and each parameter swept in two places.
struct AxisReader<'a> {
    sweep: &'a SourcedSweep,
    pipeline: &'a SourcedSpec,
    /// Swept parameter (`stage.param`) → where it was first swept.
    seen: BTreeMap<String, Vec<String>>,
    diags: Vec<Diagnostic>,
}

impl AxisReader<'_> {
    /// Notes `p` swept at `at`; false (with the problem reported) when it was swept before.
    fn note_param(&mut self, p: &ParamPath, at: &[&str]) -> bool {
        if let Some(first) = self.seen.get(&p.short()) {
            self.diags.push(
                self.sweep
                    .at_key(
                        at,
                        format!(
                            "`{}` is swept twice (also at `{}`)",
                            p.text,
                            first.join(".")
                        ),
                    )
                    .field(at.join("."))
                    .help("sweep each parameter in one place: the matrix or one zip group"),
            );
            false
        } else {
            self.seen
                .insert(p.short(), at.iter().map(|s| s.to_string()).collect());
            true
        }
    }

    /// The axis of one `matrix:` entry.
    fn matrix_axis(&mut self, key: &str, v: &Value) -> Option<Axis> {
        let sweep = self.sweep;
        let at = ["matrix", key];
        let p = match param_path(sweep, self.pipeline, key, &at) {
            Ok(p) => p,
            Err(d) => {
                self.diags.push(d);
                return None;
            }
        };
        if sweep.spec.set.keys().any(|s| s == key) {
            self.diags.push(
                sweep
                    .at_key(&at, format!("`{key}` is both set and swept"))
                    .field(at.join("."))
                    .help("remove it from `set:` or from the matrix"),
            );
            return None;
        }
        if !self.note_param(&p, &at) {
            return None;
        }
        match axis_values(sweep, &at, v) {
            Ok(values) => Some(Axis {
                params: vec![p],
                values: values.into_iter().map(|v| vec![v]).collect(),
            }),
            Err(d) => {
                self.diags.push(d);
                None
            }
        }
    }

    /// The axis of zip group `g`: its lists read, then joined position by position.
    fn zip_axis(&mut self, g: usize, group: &IndexMap<String, Value>) -> Option<Axis> {
        let gi = g.to_string();
        if group.is_empty() {
            self.diags.push(
                self.sweep
                    .at_value(&["zip", &gi], "a zip group needs at least one parameter")
                    .field(format!("zip.{g}"))
                    .help("write `- {stage.with.a: [..], stage.with.b: [..]}` with lists of equal length"),
            );
            return None;
        }
        let (params, lists) = self.zip_lists(&gi, group)?;
        let values = self.zip_tuples(g, group, &lists)?;
        Some(Axis { params, values })
    }

    /// The parameters and value lists of a zip group; `None` when any is wrong.
    fn zip_lists(
        &mut self,
        gi: &str,
        group: &IndexMap<String, Value>,
    ) -> Option<(Vec<ParamPath>, Vec<Vec<Value>>)> {
        let sweep = self.sweep;
        let mut params = Vec::new();
        let mut lists: Vec<Vec<Value>> = Vec::new();
        let mut ok = true;
        for (key, v) in group {
            let at = ["zip", gi, key.as_str()];
            let p = match param_path(sweep, self.pipeline, key, &at) {
                Ok(p) => p,
                Err(d) => {
                    self.diags.push(d);
                    ok = false;
                    continue;
                }
            };
            if !self.note_param(&p, &at) {
                ok = false;
                continue;
            }
            // Duplicates within one list are allowed in a zip: only the tuples must differ.
            let values = match v {
                Value::Array(items) if !items.is_empty() => Ok(items.clone()),
                Value::Object(map) if map.contains_key("range") => range_values(sweep, &at, map),
                _ => Err(sweep
                    .at_value(&at, "a zip entry needs a non-empty list or a range")
                    .field(at.join("."))
                    .help("write `[v1, v2, …]` or `{range: [first, last]}`")),
            };
            match values {
                Ok(vals) => {
                    if let Some(i) = vals.iter().position(Value::is_null) {
                        let idx = i.to_string();
                        self.diags.push(
                            sweep
                                .at_value(&["zip", gi, key, &idx], "null is not a parameter value")
                                .field(at.join("."))
                                .help("give a value"),
                        );
                        ok = false;
                    }
                    params.push(p);
                    lists.push(vals);
                }
                Err(d) => {
                    self.diags.push(d);
                    ok = false;
                }
            }
        }
        ok.then_some((params, lists))
    }

    /// The tuples of a zip group: its lists of equal length, no two positions the same.
    fn zip_tuples(
        &mut self,
        g: usize,
        group: &IndexMap<String, Value>,
        lists: &[Vec<Value>],
    ) -> Option<Vec<Vec<Value>>> {
        let gi = g.to_string();
        let n = lists[0].len();
        if let Some((k, l)) = group.keys().zip(lists).find(|(_, l)| l.len() != n) {
            let first = group.keys().next().map(String::as_str).unwrap_or("");
            self.diags.push(
                self.sweep
                    .at_value(&["zip", &gi, k], format!("`{k}` has {} values but `{first}` has {n}", l.len()))
                    .field(format!("zip.{g}.{k}"))
                    .help("every list of a zip group gives one value per point: make them the same length"),
            );
            return None;
        }
        let tuples: Vec<Vec<Value>> = (0..n)
            .map(|i| lists.iter().map(|l| l[i].clone()).collect())
            .collect();
        if let Some((i, j)) = (0..n).find_map(|i| {
            (0..i)
                .find(|&j| {
                    tuples[i]
                        .iter()
                        .zip(&tuples[j])
                        .all(|(a, b)| same_value(a, b))
                })
                .map(|j| (i, j))
        }) {
            self.diags.push(
                self.sweep
                    .at_value(
                        &["zip", &gi],
                        format!(
                            "entries {} and {} of the zip group are the same values",
                            j + 1,
                            i + 1
                        ),
                    )
                    .field(format!("zip.{g}"))
                    .help("every position of a zip group must give a different combination"),
            );
            return None;
        }
        Some(tuples)
    }
}

/// The number of points before exclusion, at most [`MAX_POINTS`].
fn point_count(sweep: &SourcedSweep, axes: &[Axis]) -> Result<usize, Diagnostics> {
    let total = axes
        .iter()
        .try_fold(1usize, |acc, a| acc.checked_mul(a.values.len()))
        .filter(|n| *n <= MAX_POINTS);
    total.ok_or_else(|| {
        Diagnostics(vec![
            Diagnostic::new(
                &sweep.file,
                format!("the sweep expands to more than {MAX_POINTS} points"),
            )
            .at(sweep.locator.key(&["matrix"]))
            .field("matrix")
            .help("split it into several sweeps or use fewer values"),
        ])
    })
}

/// An exclusion: (index into the swept parameters, value) pairs that must all hold.
type Rule = Vec<(usize, Value)>;

/// The `exclude:` entries, each parameter checked to be swept and to take the value.
fn exclusion_rules(
    sweep: &SourcedSweep,
    axes: &[Axis],
    params: &[ParamPath],
) -> Result<Vec<Rule>, Diagnostics> {
    let mut diags = Vec::new();
    let mut rules: Vec<Rule> = Vec::new();
    for (e, entry) in sweep.spec.exclude.iter().enumerate() {
        let ei = e.to_string();
        if entry.is_empty() {
            diags.push(
                sweep
                    .at_value(
                        &["exclude", &ei],
                        "an empty exclusion would remove every point",
                    )
                    .field(format!("exclude.{e}"))
                    .help("write `- {stage.with.param: value, …}`"),
            );
            continue;
        }
        let mut rule = Vec::new();
        for (key, v) in entry {
            match exclusion_term(sweep, axes, params, e, key, v) {
                Ok(pi) => rule.push((pi, v.clone())),
                Err(d) => diags.push(d),
            }
        }
        rules.push(rule);
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    Ok(rules)
}

/// The swept parameter `key` of exclusion `e` (its index), checked to take the value `v`.
// A diagnostic is built on the error path only, where its size costs nothing.
#[allow(clippy::result_large_err)]
fn exclusion_term(
    sweep: &SourcedSweep,
    axes: &[Axis],
    params: &[ParamPath],
    e: usize,
    key: &str,
    v: &Value,
) -> Result<usize, Diagnostic> {
    let ei = e.to_string();
    let at = ["exclude", ei.as_str(), key];
    let Some(pi) = params
        .iter()
        .position(|p| p.text == *key || p.short() == *key)
    else {
        let names: Vec<&str> = params.iter().map(|p| p.text.as_str()).collect();
        let help = match nearest(key, names.iter().copied()) {
            Some(n) => format!("did you mean `{n}`?"),
            None if names.is_empty() => "the sweep has no swept parameter".to_string(),
            None => format!("swept parameters: {}", names.join(", ")),
        };
        return Err(sweep
            .at_key(&at, format!("`{key}` is not a swept parameter"))
            .field(format!("exclude.{e}.{key}"))
            .help(help));
    };
    // The values parameter `pi` takes, over every axis it is on.
    let taken = || {
        axes.iter()
            .flat_map(|a| {
                let col = a.params.iter().position(|p| *p == params[pi]);
                col.map(|c| a.values.iter().map(move |t| &t[c]))
            })
            .flatten()
    };
    if !taken().any(|x| same_value(x, v)) {
        let values: Vec<String> = taken().map(show).take(12).collect();
        return Err(sweep
            .at_value(&at, format!("`{key}` never takes the value {}", show(v)))
            .field(format!("exclude.{e}.{key}"))
            .help(format!("its values are: {}", values.join(", "))));
    }
    Ok(pi)
}

/// The points of the product, how many were excluded, and how many each rule removed.
struct Product {
    points: Vec<Point>,
    excluded: usize,
    hits: Vec<usize>,
}

/// Walks the product of the axes (the last axis fastest), dropping excluded points and
/// naming the others with their `--set` overrides (the sweep's `set:` first).
fn product(
    sweep: &SourcedSweep,
    axes: &[Axis],
    params: &[ParamPath],
    rules: &[Rule],
    total: usize,
) -> Product {
    let mut hits = vec![0usize; rules.len()];
    let mut points = Vec::new();
    let base_sets: Vec<String> = sweep
        .spec
        .set
        .iter()
        .filter_map(|(k, v)| {
            let parts: Vec<&str> = k.split('.').collect();
            (parts.len() >= 3).then(|| format!("{}.{}={}", parts[0], parts[2..].join("."), v))
        })
        .collect();
    let mut excluded = 0;
    let mut idx = vec![0usize; axes.len()];
    for _ in 0..total {
        let values: Vec<Value> = axes
            .iter()
            .zip(&idx)
            .flat_map(|(a, &i)| a.values[i].clone())
            .collect();
        let mut out = false;
        for (r, rule) in rules.iter().enumerate() {
            if rule.iter().all(|(pi, v)| same_value(&values[*pi], v)) {
                hits[r] += 1;
                out = true;
            }
        }
        if out {
            excluded += 1;
        } else {
            let mut overrides = base_sets.clone();
            overrides.extend(params.iter().zip(&values).map(|(p, v)| p.set_arg(v)));
            points.push(Point {
                index: points.len(),
                name: point_name(params, &values),
                values: params.iter().map(|p| p.text.clone()).zip(values).collect(),
                overrides,
            });
        }
        // Odometer: the last axis varies fastest.
        for k in (0..axes.len()).rev() {
            idx[k] += 1;
            if idx[k] < axes[k].values.len() {
                break;
            }
            idx[k] = 0;
        }
    }
    Product {
        points,
        excluded,
        hits,
    }
}

/// Every exclusion removed a point, and some point is left.
fn check_exclusions_hit(
    sweep: &SourcedSweep,
    hits: &[usize],
    no_points: bool,
) -> Result<(), Diagnostics> {
    let mut diags = Vec::new();
    for (r, h) in hits.iter().enumerate() {
        if *h == 0 {
            let ri = r.to_string();
            diags.push(
                sweep
                    .at_value(&["exclude", &ri], "this exclusion matches no point")
                    .field(format!("exclude.{r}"))
                    .help("parameters of one zip group only occur together at the same position; check the values"),
            );
        }
    }
    if no_points && diags.is_empty() {
        diags.push(
            Diagnostic::new(&sweep.file, "every point is excluded")
                .at(sweep.locator.key(&["exclude"]))
                .field("exclude")
                .help("remove an exclusion"),
        );
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    Ok(())
}

/// A value as a name segment: numbers and booleans as written, safe text as is, other text
/// with a short hash, lists and maps by hash.
pub fn value_label(v: &Value) -> String {
    let short_hash = |s: &str| hash_bytes(s.as_bytes())[..8].to_string();
    match v {
        Value::Number(_) | Value::Bool(_) => v.to_string(),
        Value::String(s) => {
            let safe: String = s
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || "._-".contains(c) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            if safe == *s && !s.is_empty() {
                safe
            } else {
                format!("{safe}~{}", short_hash(s))
            }
        }
        _ => format!("h{}", short_hash(&canonical_json(v))),
    }
}

/// The stable name of a point.
pub fn point_name(params: &[ParamPath], values: &[Value]) -> String {
    if params.is_empty() {
        return "base".to_string();
    }
    let mut segs: Vec<(String, String)> = params
        .iter()
        .zip(values)
        .map(|(p, v)| (p.short().replace(['/', '\\'], "_"), value_label(v)))
        .collect();
    segs.sort();
    let name = segs
        .iter()
        .map(|(p, v)| format!("{p}@{v}"))
        .collect::<Vec<_>>()
        .join(",");
    if name.len() <= 160 {
        name
    } else {
        let cut = (0..=120)
            .rev()
            .find(|i| name.is_char_boundary(*i))
            .unwrap_or(0);
        format!("{}~{}", &name[..cut], &hash_bytes(name.as_bytes())[..12])
    }
}

/// Hashes of every node (upstream included) and of the whole plan.
pub fn plan_hashes(plan: &Plan) -> (Vec<String>, String) {
    let mut nodes: Vec<String> = Vec::with_capacity(plan.nodes.len());
    for n in &plan.nodes {
        let inputs: BTreeMap<&str, (String, &str)> = n
            .inputs
            .iter()
            .map(|(port, r)| (port.as_str(), (nodes[r.node].clone(), r.port.as_str())))
            .collect();
        let doc = serde_json::json!({
            "kind": n.stage.kind(),
            "impl_version": n.stage.impl_version(),
            "params": n.stage.key_params(&n.params),
            "format": n.format,
            "inputs": inputs,
        });
        nodes.push(hash_bytes(canonical_json(&doc).as_bytes()));
    }
    let all: BTreeMap<&str, &str> = plan
        .nodes
        .iter()
        .zip(&nodes)
        .map(|(n, h)| (n.name.as_str(), h.as_str()))
        .collect();
    let whole = hash_bytes(canonical_json(&serde_json::json!(all)).as_bytes());
    (nodes, whole)
}

/// The plan restricted to the `only` stages and their upstream (all when `only` is empty or
/// names no stage of the plan).
pub fn prune(plan: Plan, only: &[String]) -> Plan {
    let targets: Vec<usize> = only.iter().filter_map(|n| plan.index(n)).collect();
    if targets.is_empty() {
        return plan;
    }
    let keep = plan.upstream_closure(&targets);
    let remap: BTreeMap<usize, usize> = keep
        .iter()
        .enumerate()
        .map(|(new, old)| (*old, new))
        .collect();
    let nodes = plan
        .nodes
        .iter()
        .enumerate()
        .filter(|(i, _)| keep.contains(i))
        .map(|(_, n)| {
            let mut n = n.clone();
            for r in n.inputs.values_mut() {
                r.node = remap.get(&r.node).copied().unwrap_or(r.node);
            }
            n
        })
        .collect();
    Plan { nodes, ..plan }
}

/// Checks `only:` against the pipeline's stages.
fn check_only(sweep: &SourcedSweep, pipeline: &SourcedSpec) -> Vec<Diagnostic> {
    let names: Vec<&str> = pipeline.spec.stages.keys().map(String::as_str).collect();
    sweep
        .spec
        .only
        .iter()
        .enumerate()
        .filter(|(_, s)| !pipeline.spec.stages.contains_key(s.as_str()))
        .map(|(i, s)| {
            let help = match nearest(s, names.iter().copied()) {
                Some(n) => format!("did you mean `{n}`?"),
                None => format!("stages are: {}", names.join(", ")),
            };
            sweep
                .at_value(
                    &["only", &i.to_string()],
                    format!("no stage `{s}` in the pipeline"),
                )
                .field(format!("only.{i}"))
                .help(help)
        })
        .collect()
}

/// Plans one point.
pub fn plan_point(
    base: &SourcedSpec,
    point: &Point,
    only: &[String],
) -> Result<PlannedPoint, Diagnostics> {
    let mut src = base.clone();
    // The base carries the sweep's `set:` already; applying it again changes nothing.
    src.apply_overrides(&point.overrides)?;
    let plan = prune(plan(&src, &registry())?, only);
    let (node_hashes, plan_hash) = plan_hashes(&plan);
    Ok(PlannedPoint {
        point: point.clone(),
        plan,
        plan_hash,
        node_hashes,
    })
}

/// Reads, expands, checks and plans a sweep, dropping duplicate points; at most
/// [`super::spec::MAX_REPORTED_ERRORS`] problems are listed.
pub fn resolve(sweep: &SourcedSweep) -> Result<Resolved, Diagnostics> {
    resolve_all(sweep).map_err(|d| super::spec::capped(&sweep.file, d.0))
}

fn resolve_all(sweep: &SourcedSweep) -> Result<Resolved, Diagnostics> {
    let base = base_pipeline(sweep)?;
    let only = check_only(sweep, &base);
    if !only.is_empty() {
        return Err(Diagnostics(only));
    }
    let expansion = expand_all(sweep, &base)?;
    // Each value alone first, so that a bad value is reported once, at its own position.
    let mut diags = Vec::new();
    let mut checked: BTreeSet<(String, String)> = BTreeSet::new();
    for (k, v) in &sweep.spec.matrix {
        check_axis_values(
            sweep,
            &base,
            &["matrix", k],
            k,
            v,
            &expansion,
            &mut checked,
            &mut diags,
        );
    }
    for (g, group) in sweep.spec.zip.iter().enumerate() {
        let gi = g.to_string();
        for (k, v) in group {
            check_axis_values(
                sweep,
                &base,
                &["zip", &gi, k],
                k,
                v,
                &expansion,
                &mut checked,
                &mut diags,
            );
        }
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    let mut unique: Vec<PlannedPoint> = Vec::new();
    let mut by_hash: BTreeMap<String, String> = BTreeMap::new();
    let mut duplicates = Vec::new();
    for p in &expansion.points {
        match plan_point(&base, p, &sweep.spec.only) {
            Ok(pp) => match by_hash.get(&pp.plan_hash) {
                Some(kept) => duplicates.push((p.name.clone(), kept.clone())),
                None => {
                    by_hash.insert(pp.plan_hash.clone(), p.name.clone());
                    unique.push(pp);
                }
            },
            Err(e) => {
                let what = p
                    .values
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", show(v)))
                    .collect::<Vec<_>>()
                    .join(", ");
                diags.extend(rehome(sweep, &["matrix"], &e, &format!("the point {what}")));
                if diags.len() > 20 {
                    break;
                }
            }
        }
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    if let Some(first) = unique.first() {
        super::collect::check_collect(sweep, &first.plan, &expansion.params)
            .map_err(Diagnostics)?;
    }
    let common = match unique.first() {
        Some(first) => first
            .plan
            .nodes
            .iter()
            .enumerate()
            .filter(|(i, _)| {
                unique
                    .iter()
                    .all(|u| u.node_hashes.get(*i) == first.node_hashes.get(*i))
            })
            .map(|(_, n)| n.name.clone())
            .collect(),
        None => Vec::new(),
    };
    Ok(Resolved {
        sweep: sweep.clone(),
        expansion,
        unique,
        duplicates,
        common,
    })
}

/// Plans the pipeline with each value of one swept parameter alone, reporting failures at the
/// value's position.
#[allow(clippy::too_many_arguments)]
fn check_axis_values(
    sweep: &SourcedSweep,
    base: &SourcedSpec,
    at: &[&str],
    key: &str,
    raw: &Value,
    expansion: &Expansion,
    checked: &mut BTreeSet<(String, String)>,
    diags: &mut Vec<Diagnostic>,
) {
    let Some(param) = expansion.params.iter().find(|p| p.text == key) else {
        return;
    };
    let values: Vec<&Value> = expansion
        .points
        .iter()
        .filter_map(|p| p.values.iter().find(|(k, _)| k == key).map(|(_, v)| v))
        .collect();
    for v in values {
        if !checked.insert((key.to_string(), canonical_json(v))) {
            continue;
        }
        let mut src = base.clone();
        let result = src
            .apply_overrides(&[param.set_arg(v)])
            .and_then(|_| plan(&src, &registry()).map(|_| ()));
        if let Err(e) = result {
            // A parameter the stage does not have is wrong whatever its value: say so once.
            if let Some(d) = e.0.iter().find(|d| d.message.starts_with("unknown field")) {
                let stage = d.stage.as_deref().unwrap_or(&param.stage);
                let mut out = sweep
                    .at_key(
                        at,
                        format!(
                            "stage `{stage}` has no parameter `{}`: {}",
                            param.rest.join("."),
                            d.message
                        ),
                    )
                    .field(at.join("."));
                out.help = d.help.clone();
                diags.push(out);
                return;
            }
            // Point at the value in a list, or at the range.
            let pos = match raw {
                Value::Array(items) => items.iter().position(|x| same_value(x, v)),
                _ => None,
            };
            let idx = pos.map(|i| i.to_string());
            let mut path: Vec<&str> = at.to_vec();
            if let Some(i) = &idx {
                path.push(i);
            }
            diags.extend(rehome(sweep, &path, &e, &format!("`{key}` = {}", show(v))));
            if diags.len() > 20 {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn labels_are_safe_and_distinct() {
        assert_eq!(value_label(&json!(0.05)), "0.05");
        assert_eq!(value_label(&json!(3)), "3");
        assert_eq!(value_label(&json!("thesis")), "thesis");
        let a = value_label(&json!("1:ux"));
        let b = value_label(&json!("1_ux"));
        assert!(a.starts_with("1_ux~") && b == "1_ux", "{a} {b}");
        assert_ne!(value_label(&json!(["1:ux"])), value_label(&json!(["2:ux"])));
    }

    #[test]
    fn names_ignore_axis_order() {
        let p = |s: &str, r: &str| ParamPath {
            text: format!("{s}.with.{r}"),
            stage: s.into(),
            rest: vec![r.into()],
        };
        let a = point_name(&[p("n", "seed"), p("n", "level")], &[json!(3), json!(0.1)]);
        let b = point_name(&[p("n", "level"), p("n", "seed")], &[json!(0.1), json!(3)]);
        assert_eq!(a, b);
        assert_eq!(a, "n.level@0.1,n.seed@3");
    }
}
