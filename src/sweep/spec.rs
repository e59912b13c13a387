//! The sweep file: which pipeline, which parameters vary and how (`matrix:`, `zip:`,
//! `exclude:`), what to gather from every point (`collect:`, `plots:`) and the resources of a
//! Slurm job array (`slurm:`). Read with the same diagnostics as pipelines: every problem names
//! the file, line, column and field, and says what would be valid.
//!
//! Shapes that serde cannot check well (axis values, collect sources) are kept as JSON values
//! here and interpreted in [`super::expand`] and [`super::collect`], where each problem is
//! reported at its own node.

use crate::pipeline::diagnostic::{Diagnostic, Diagnostics};
use crate::pipeline::locate::{Locator, Pos};
use indexmap::IndexMap;
use std::path::{Path, PathBuf};

/// A sweep as written.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "femu sweep")]
pub struct SweepSpec {
    /// Sweep name: the state directory, the Slurm job name; default: the file name without `.yaml`.
    #[serde(default)]
    pub name: Option<String>,
    /// What the sweep shows.
    #[serde(default)]
    pub description: String,
    /// The pipeline file, relative to the sweep file.
    pub pipeline: String,
    /// Run only these stages and what they need (default: every stage), e.g. to skip plots.
    #[serde(default)]
    pub only: Vec<String>,
    /// Overrides applied to every point: `stage.with.param: value`.
    #[serde(default)]
    pub set: IndexMap<String, serde_json::Value>,
    /// One axis per parameter, `stage.with.param: [values]` or `{range: [first, last], step}`; the
    /// points are the cartesian product of all axes (first axis slowest).
    #[serde(default)]
    #[schemars(with = "IndexMap<String, AxisSchema>")]
    pub matrix: IndexMap<String, serde_json::Value>,
    /// Groups of parameters that vary together: each group is one axis whose i-th value sets the
    /// i-th value of every parameter in it (all lists of a group have the same length).
    #[serde(default)]
    #[schemars(with = "Vec<IndexMap<String, AxisSchema>>")]
    pub zip: Vec<IndexMap<String, serde_json::Value>>,
    /// Holes: a point is left out when it has every value of one entry.
    #[serde(default)]
    pub exclude: Vec<IndexMap<String, serde_json::Value>>,
    /// Columns gathered from every point: `name: stage.port.table.column`,
    /// `name: stage.port.meta.key[.sub]`, `name: stage.port.table` (all its columns), or
    /// `name: {from: SOURCE, reduce: mean|min|max|sum|first|last|count}`.
    #[serde(default)]
    #[schemars(with = "IndexMap<String, CollectSchema>")]
    pub collect: IndexMap<String, serde_json::Value>,
    /// Box plots of a collected column grouped by a swept parameter.
    #[serde(default)]
    pub plots: Vec<PlotSpec>,
    /// Resources of the Slurm job array.
    #[serde(default)]
    pub slurm: SlurmSpec,
}

/// The values of one axis: a list, or an inclusive range of numbers (for the schema).
#[derive(schemars::JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
pub enum AxisSchema {
    /// The values, in order.
    List(Vec<serde_json::Value>),
    /// An inclusive range of numbers.
    Range(RangeSchema),
}

/// `{range: [first, last], step}`: first and last included (for the schema).
#[derive(schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
pub struct RangeSchema {
    /// First and last value, both included.
    range: [f64; 2],
    /// Step (default 1); integers when first, last and step are integers.
    step: Option<f64>,
}

/// One collected column: a source path, or a source with a reduction (for the schema).
#[derive(schemars::JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
pub enum CollectSchema {
    /// `stage.port.table.column`, `stage.port.table` or `stage.port.meta.key[.sub]`.
    Source(String),
    /// A source with a reduction to one value per point.
    Reduced(ReducedSchema),
}

/// A source reduced to one value per point (for the schema).
#[derive(schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
pub struct ReducedSchema {
    /// `stage.port.table.column`.
    from: String,
    /// The reduction.
    reduce: Option<Reduce>,
}

/// How a column becomes one value per point.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Reduce {
    /// Arithmetic mean.
    Mean,
    /// Smallest value.
    Min,
    /// Largest value.
    Max,
    /// Sum.
    Sum,
    /// First row.
    First,
    /// Last row.
    Last,
    /// Number of rows.
    Count,
}

impl Reduce {
    /// All reductions, for messages.
    pub const NAMES: &'static str = "mean, min, max, sum, first, last, count";

    /// The reduction by name.
    pub fn from_name(s: &str) -> Option<Reduce> {
        Some(match s {
            "mean" => Reduce::Mean,
            "min" => Reduce::Min,
            "max" => Reduce::Max,
            "sum" => Reduce::Sum,
            "first" => Reduce::First,
            "last" => Reduce::Last,
            "count" => Reduce::Count,
            _ => return None,
        })
    }
}

/// One box plot.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// The collected column whose distribution is drawn (numbers).
    pub column: String,
    /// A swept parameter (`stage.with.param`) or collected column: one group of boxes per value.
    pub by: String,
    /// A swept parameter or collected column splitting each group into coloured boxes.
    #[serde(default)]
    pub split: Option<String>,
    /// Figure title (default: `COLUMN by BY`).
    #[serde(default)]
    pub title: Option<String>,
}

/// Resources of the Slurm job array; each becomes an `#SBATCH` line when given.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SlurmSpec {
    /// Partition (`--partition`).
    #[serde(default)]
    pub partition: Option<String>,
    /// Wall-time limit per task (`--time`): `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM` or `D-HH:MM:SS`.
    #[serde(default)]
    pub time: Option<String>,
    /// Memory per node (`--mem`): a whole number with an optional unit K, M, G or T, e.g. `2G`.
    #[serde(default)]
    pub mem: Option<String>,
    /// CPUs per task (`--cpus-per-task`); also the threads femu uses in a task.
    #[serde(default)]
    pub cpus_per_task: Option<u32>,
    /// Most tasks of the array running at once (`--array=0-N%LIMIT`).
    #[serde(default)]
    pub array_limit: Option<u32>,
    /// Largest array the cluster accepts (its `MaxArraySize` less one); more points are packed
    /// several to a task. Default 1000.
    #[serde(default)]
    pub max_array_size: Option<u32>,
    /// Points run one after another by each task (default 1, raised to fit `max_array_size`).
    #[serde(default)]
    pub points_per_task: Option<u32>,
    /// Account to charge (`--account`).
    #[serde(default)]
    pub account: Option<String>,
    /// Further `#SBATCH` options, each starting with `--`, e.g. `--qos=short`.
    #[serde(default)]
    pub extra: Vec<String>,
    /// Path of the femu binary on the compute nodes (default: the one submitting).
    #[serde(default)]
    pub femu: Option<String>,
}

/// A parsed sweep file with the positions of its nodes.
#[derive(Clone, Debug)]
pub struct SourcedSweep {
    /// File name for messages.
    pub file: String,
    /// The file's path.
    pub path: PathBuf,
    /// The spec.
    pub spec: SweepSpec,
    /// Node positions.
    pub locator: Locator,
    /// `--set` overrides applied to the file, passed on to every worker.
    pub overrides: Vec<String>,
}

impl SourcedSweep {
    /// Applies `--set stage.with.param=VALUE` overrides (`VALUE` is YAML): a swept parameter gets
    /// new values (a list or a range, in the matrix or its zip group), any other becomes a fixed
    /// override like `set:`. Names depend on values only, so points shared by the file and the
    /// overridden sweep are the same points, finished once.
    pub fn apply_overrides(&mut self, sets: &[String]) -> Result<(), Diagnostics> {
        let mut diags = Vec::new();
        for s in sets {
            let d = |m: String| {
                Diagnostic::new("--set", m).help(
                    "write --set STAGE.with.PARAM=VALUE, e.g. --set 'measured.with.seed={range: [1, 100]}'",
                )
            };
            let Some((key, text)) = s.split_once('=') else {
                diags.push(d(format!("`{s}` has no `=`")));
                continue;
            };
            let key = key.trim().to_string();
            let value: serde_json::Value = match serde_yaml::from_str(text) {
                Ok(v) => v,
                Err(e) => {
                    diags.push(d(format!("value `{text}` is not valid YAML: {e}")));
                    continue;
                }
            };
            if let Some(v) = self.spec.matrix.get_mut(&key) {
                *v = value;
            } else if let Some(group) = self.spec.zip.iter_mut().find(|g| g.contains_key(&key)) {
                group.insert(key, value);
            } else {
                self.spec.set.insert(key, value);
            }
            self.overrides.push(s.clone());
        }
        if diags.is_empty() {
            Ok(())
        } else {
            Err(Diagnostics(diags))
        }
    }

    /// The sweep's name: `name:` or the file stem.
    pub fn name(&self) -> String {
        self.spec.name.clone().unwrap_or_else(|| {
            self.path
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_else(|| "sweep".into())
        })
    }

    /// The pipeline file, resolved against the sweep file's directory.
    pub fn pipeline_path(&self) -> PathBuf {
        let base = self.path.parent().unwrap_or(Path::new(""));
        base.join(&self.spec.pipeline)
    }

    /// A diagnostic at the value of `path`.
    pub fn at_value(&self, path: &[&str], message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(&self.file, message).at(self.locator.value(path))
    }

    /// A diagnostic at the key of `path`.
    pub fn at_key(&self, path: &[&str], message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(&self.file, message).at(self.locator.key(path))
    }
}

/// Largest sweep file read by default (16 MiB); `FEMU_SWEEP_MAX_BYTES` raises or lowers it.
pub const DEFAULT_MAX_SWEEP_BYTES: u64 = 16 * 1024 * 1024;

/// The environment variable that sets the largest sweep file read, in bytes.
pub const MAX_SWEEP_BYTES_ENV: &str = "FEMU_SWEEP_MAX_BYTES";

/// Most problems reported for one sweep; the rest are counted in a last line.
pub const MAX_REPORTED_ERRORS: usize = crate::pipeline::diagnostic::MAX_REPORTED;

/// Longest sweep name.
pub const MAX_NAME_LEN: usize = 100;

/// What a valid sweep name is, for messages.
pub const SWEEP_NAME_HELP: &str = "a sweep name is 1 to 100 ASCII letters, digits, `.`, `_` and `-`, starting with a letter or digit, e.g. `four-dof-noise`: it names the state directory CACHE/sweeps/NAME and the Slurm job, so it cannot contain `/`, `..`, spaces or line breaks";

/// Whether `s` is a usable sweep name: a single path component of ASCII letters, digits, `.`,
/// `_` and `-`, starting with a letter or digit (so never `.`, `..`, hidden or option-like).
pub fn valid_sweep_name(s: &str) -> bool {
    s.len() <= MAX_NAME_LEN
        && s.starts_with(|c: char| c.is_ascii_alphanumeric())
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
}

/// Whether `s` is a Slurm partition list or account: words of ASCII letters, digits, `.`, `_`,
/// `-`, separated by commas when `list`.
pub fn valid_slurm_word(s: &str, list: bool) -> bool {
    let word = |w: &str| {
        !w.is_empty()
            && w.chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
    };
    s.len() <= 200
        && if list {
            s.split(',').all(word)
        } else {
            word(s)
        }
}

/// Whether `s` can stand in an `#SBATCH` directive line unquoted: printable ASCII without
/// spaces, quotes, backslashes or `#` (directives cannot be shell-quoted; sbatch splits them at
/// spaces and strips quotes, and a line break would end the comment).
pub fn valid_directive_value(s: &str) -> bool {
    s.len() <= 1000
        && s.chars()
            .all(|c| c.is_ascii_graphic() && !"'\"\\#".contains(c))
}

/// Whether `s` is a usable executable path: non-empty, without control characters (it is
/// shell-quoted in the scripts, so spaces and quotes are fine).
pub fn valid_executable(s: &str) -> bool {
    !s.is_empty() && s.len() <= 4096 && !s.chars().any(char::is_control)
}

/// Keeps the first [`MAX_REPORTED_ERRORS`] problems and counts the rest in a last line.
pub fn capped(file: &str, diags: Vec<Diagnostic>) -> Diagnostics {
    Diagnostics::capped(file, diags)
}

/// The largest sweep file read: `FEMU_SWEEP_MAX_BYTES` if set, else 16 MiB.
pub fn max_sweep_bytes() -> Result<u64, String> {
    match std::env::var(MAX_SWEEP_BYTES_ENV) {
        Err(_) => Ok(DEFAULT_MAX_SWEEP_BYTES),
        Ok(v) => v
            .trim()
            .parse::<u64>()
            .ok()
            .filter(|n| *n > 0)
            .ok_or_else(|| {
                format!("{MAX_SWEEP_BYTES_ENV}=`{v}` is not a positive whole number of bytes")
            }),
    }
}

fn too_large(file: &str, limit: u64) -> Diagnostics {
    Diagnostics(vec![
        Diagnostic::new(
            file,
            format!(
                "the sweep file is larger than the limit of {} ({limit} bytes)",
                show_bytes(limit)
            ),
        )
        .help(format!(
            "sweep files are a few kilobytes; if this one really is larger, raise the limit with {MAX_SWEEP_BYTES_ENV}=BYTES"
        )),
    ])
}

fn show_bytes(n: u64) -> String {
    if n >= 1 << 20 && n.is_multiple_of(1 << 20) {
        format!("{} MiB", n >> 20)
    } else if n >= 1 << 10 && n.is_multiple_of(1 << 10) {
        format!("{} KiB", n >> 10)
    } else {
        format!("{n} bytes")
    }
}

/// Reads a sweep file, up to [`max_sweep_bytes`].
pub fn read_sweep(path: &Path) -> Result<SourcedSweep, Diagnostics> {
    let file = path.display().to_string();
    let limit = max_sweep_bytes().map_err(|m| {
        Diagnostics(vec![
            Diagnostic::new(&file, m).help("give the limit in bytes, e.g. 33554432 for 32 MiB"),
        ])
    })?;
    read_sweep_limited(path, limit)
}

/// Reads a sweep file of at most `max_bytes` bytes.
pub fn read_sweep_limited(path: &Path, max_bytes: u64) -> Result<SourcedSweep, Diagnostics> {
    use std::io::Read;
    let file = path.display().to_string();
    let cannot = |e: std::io::Error| {
        Diagnostics(vec![Diagnostic::new(
            &file,
            format!("cannot read the sweep file: {e}"),
        )])
    };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(cannot)?
        .take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(&file, max_bytes));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|b| **b == b'\n').count() + 1;
        Diagnostics(vec![
            Diagnostic::new(
                &file,
                format!("the sweep file is not UTF-8 text (byte {at})"),
            )
            .at(Some(Pos { line, col: 1 }))
            .help("save the file as UTF-8"),
        ])
    })?;
    parse_sweep_limited(path, &text, max_bytes)
}

/// Parses sweep text; `path` names it in messages and anchors the pipeline path. A leading
/// byte-order mark is skipped; text over the default limit of 16 MiB is refused.
pub fn parse_sweep(path: &Path, text: &str) -> Result<SourcedSweep, Diagnostics> {
    parse_sweep_limited(path, text, DEFAULT_MAX_SWEEP_BYTES)
}

/// [`parse_sweep`] with a size limit in bytes.
pub fn parse_sweep_limited(
    path: &Path,
    text: &str,
    max_bytes: u64,
) -> Result<SourcedSweep, Diagnostics> {
    let file = path.display().to_string();
    if text.len() as u64 > max_bytes {
        return Err(too_large(&file, max_bytes));
    }
    // A byte-order mark is legal YAML, but neither parser takes it.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let locator = Locator::scan(text).map_err(|(pos, msg)| {
        Diagnostics(vec![
            Diagnostic::new(&file, format!("YAML syntax error: {msg}")).at(Some(pos)),
        ])
    })?;
    if !locator.duplicates.is_empty() {
        return Err(capped(
            &file,
            locator
                .duplicates
                .iter()
                .map(|(p, first, second)| {
                    Diagnostic::new(
                        &file,
                        format!(
                            "key `{}` appears twice in one mapping (first at line {})",
                            p.last().map(String::as_str).unwrap_or(""),
                            first.line
                        ),
                    )
                    .at(Some(*second))
                    .help("every key of a mapping must be unique; list the values of one parameter in one entry")
                })
                .collect(),
        ));
    }
    let spec: SweepSpec = serde_yaml::from_str(text).map_err(|e| {
        let pos = e.location().map(|l| Pos {
            line: l.line(),
            col: l.column(),
        });
        let mut msg = e.to_string();
        if let Some(i) = msg.find(" at line ") {
            msg.truncate(i);
        }
        let mut d = Diagnostic::new(&file, msg.clone()).at(pos);
        if msg.contains("unknown field") {
            d = d.help("a sweep has `name`, `description`, `pipeline`, `only`, `set`, `matrix`, `zip`, `exclude`, `collect`, `plots`, `slurm`; `slurm` has `partition`, `time`, `mem`, `cpus_per_task`, `array_limit`, `max_array_size`, `points_per_task`, `account`, `extra`, `femu`; a plot has `column`, `by`, `split`, `title`");
        } else if msg.contains("missing field `pipeline`") {
            d = d.help("name the pipeline file, relative to the sweep file: `pipeline: ../pipelines/four-dof.yaml`");
        }
        Diagnostics(vec![d])
    })?;
    let sweep = SourcedSweep {
        file,
        path: path.to_path_buf(),
        spec,
        locator,
        overrides: Vec::new(),
    };
    let mut diags = check_name(&sweep);
    diags.extend(check_slurm(&sweep));
    if diags.is_empty() {
        Ok(sweep)
    } else {
        Err(capped(&sweep.file, diags))
    }
}

/// Checks the sweep's name (`name:` or the file name): it becomes a directory and a job name.
fn check_name(s: &SourcedSweep) -> Vec<Diagnostic> {
    let name = s.name();
    if valid_sweep_name(&name) {
        return Vec::new();
    }
    let d = match &s.spec.name {
        Some(n) => s
            .at_value(&["name"], format!("{n:?} is not a usable sweep name"))
            .field("name")
            .help(SWEEP_NAME_HELP),
        None => Diagnostic::new(
            &s.file,
            format!("the sweep is named after its file, and {name:?} is not a usable sweep name"),
        )
        .field("name")
        .help(format!("give the sweep a `name:`; {SWEEP_NAME_HELP}")),
    };
    vec![d]
}

/// Checks the `slurm:` block's formats.
fn check_slurm(s: &SourcedSweep) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let sl = &s.spec.slurm;
    let field = |name: &str| format!("slurm.{name}");
    if let Some(t) = &sl.time
        && !valid_time(t)
    {
        out.push(
                s.at_value(&["slurm", "time"], format!("{t:?} is not a Slurm time limit"))
                    .field(field("time"))
                    .help("write minutes `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM` or `D-HH:MM:SS`, e.g. `00:30:00`"),
            );
    }
    if let Some(m) = &sl.mem
        && !valid_mem(m)
    {
        out.push(
            s.at_value(
                &["slurm", "mem"],
                format!("{m:?} is not a Slurm memory size"),
            )
            .field(field("mem"))
            .help("write a whole number with an optional unit K, M, G or T, e.g. `2G` or `500M`"),
        );
    }
    for (name, v) in [
        ("cpus_per_task", sl.cpus_per_task),
        ("array_limit", sl.array_limit),
        ("max_array_size", sl.max_array_size),
        ("points_per_task", sl.points_per_task),
    ] {
        if v == Some(0) {
            out.push(
                s.at_value(&["slurm", name], "must be at least 1")
                    .field(field(name))
                    .help("give a positive whole number"),
            );
        }
    }
    for (name, v, list) in [
        ("partition", &sl.partition, true),
        ("account", &sl.account, false),
    ] {
        if let Some(v) = v
            && !valid_slurm_word(v, list)
        {
            out.push(
                    s.at_value(&["slurm", name], format!("{v:?} is not a usable Slurm {name}"))
                        .field(field(name))
                        .help(if list {
                            "give partition names of ASCII letters, digits, `.`, `_` and `-`, separated by commas, e.g. `short` or `short,long`"
                        } else {
                            "give an account name of ASCII letters, digits, `.`, `_` and `-`, e.g. `proj-42`"
                        }),
                );
        }
    }
    if let Some(v) = &sl.femu
        && !valid_executable(v)
    {
        out.push(
                s.at_value(&["slurm", "femu"], format!("{v:?} is not a usable path of the femu executable"))
                    .field(field("femu"))
                    .help("give the path of femu on the compute nodes: not empty, without line breaks or other control characters"),
            );
    }
    for (i, e) in sl.extra.iter().enumerate() {
        let idx = i.to_string();
        let at = |m: String| {
            s.at_value(&["slurm", "extra", &idx], m)
                .field(format!("slurm.extra.{i}"))
        };
        let option = e
            .strip_prefix("--")
            .map(|o| o.split_once('=').map_or(o, |(n, _)| n));
        match option {
            Some(o) if !o.is_empty()
                && o.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
                && valid_directive_value(e) =>
            {
                if femu_sets(o) {
                    out.push(at(format!("`{e}` is set by femu")).help(
                        "femu writes --array and --output itself; use `array_limit` to bound the running tasks",
                    ));
                }
            }
            _ => out.push(at(format!("{e:?} is not an sbatch option")).help(
                "write one long option per entry, `--NAME` or `--NAME=VALUE`, in printable ASCII without spaces, quotes, backslashes or `#` (an #SBATCH line cannot be quoted), e.g. `--qos=short` or `--constraint=avx2`",
            )),
        }
    }
    out
}

/// Whether the long option `o` (without `--`) is, or abbreviates, one femu writes itself
/// (sbatch takes unambiguous prefixes of long options).
fn femu_sets(o: &str) -> bool {
    ["array", "output"]
        .iter()
        .any(|f| o.starts_with(f) || (o.len() >= 2 && f.starts_with(o)))
}

/// Whether `t` is one of Slurm's time formats.
pub fn valid_time(t: &str) -> bool {
    let num = |s: &str| !s.is_empty() && s.len() <= 6 && s.chars().all(|c| c.is_ascii_digit());
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    if let Some(d) = days
        && !num(d)
    {
        return false;
    }
    let parts: Vec<&str> = rest.split(':').collect();
    if !parts.iter().all(|p| num(p)) {
        return false;
    }
    match days {
        Some(_) => (1..=3).contains(&parts.len()),
        None => (1..=3).contains(&parts.len()),
    }
}

/// Whether `m` is a Slurm memory size.
pub fn valid_mem(m: &str) -> bool {
    let digits = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    let unit_len = m.len() - digits.len();
    unit_len <= 1 && !digits.is_empty() && digits.chars().all(|c| c.is_ascii_digit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_formats() {
        for t in ["30", "30:00", "01:30:00", "1-0", "1-12:00", "2-00:00:00"] {
            assert!(valid_time(t), "{t}");
        }
        for t in ["", "1h", "1-", "1:2:3:4", "a-1"] {
            assert!(!valid_time(t), "{t}");
        }
        for m in ["2G", "500M", "1024", "4g"] {
            assert!(valid_mem(m), "{m}");
        }
        for m in ["", "G", "2GB", "1.5G", "-1G"] {
            assert!(!valid_mem(m), "{m}");
        }
    }

    #[test]
    fn unknown_keys_are_located() {
        let e = parse_sweep(
            Path::new("s.yaml"),
            "pipeline: p.yaml\nmatrix: {}\nslurm:\n  partiton: x\n",
        )
        .unwrap_err();
        assert_eq!(e.0[0].pos.map(|p| p.line), Some(4), "{e}");
        assert!(e.to_string().contains("partiton"), "{e}");
    }
}
