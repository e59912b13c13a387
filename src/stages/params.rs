//! The shared vocabulary of stage parameters: bounded numbers (their ranges checked when the
//! `with:` block is read and published in the JSON Schema), the modal basis (`modes: {count}`
//! or `modes: {max_freq_hz}`), a frequency band, modal damping, and the deprecation notices of
//! old spellings (kept for one release).

use crate::eigen::ModeSelection;
use crate::frf::{DirectDamping, FrfSet, ModalDamping};
use crate::pipeline::{ParamIssue, StageError};
use std::borrow::Cow;

/// Defines a bounded `f64` newtype: read from a number, refused outside its range with a message
/// giving the range, written back as the number, its range in the schema.
macro_rules! bounded_f64 {
    ($(#[$doc:meta])* $name:ident, $range:literal, $ok:expr, $schema:tt) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, PartialOrd, serde::Serialize, serde::Deserialize)]
        #[serde(try_from = "f64", into = "f64")]
        pub struct $name(f64);

        impl $name {
            /// The range, as written in messages.
            pub const RANGE: &'static str = $range;

            /// The value, if it lies in the range.
            pub fn new(v: f64) -> Result<Self, String> {
                let ok: fn(f64) -> bool = $ok;
                if ok(v) {
                    Ok($name(v))
                } else {
                    Err(format!("{v} is out of range: give a number in {}", Self::RANGE))
                }
            }

            /// The number.
            pub fn get(self) -> f64 {
                self.0
            }

            /// A default taken from the numerics (in range: the stages' round-trip tests read
            /// every default back through [`Self::new`]).
            pub(crate) fn of_default(v: f64) -> Self {
                debug_assert!(Self::new(v).is_ok(), "default {v} outside {}", Self::RANGE);
                $name(v)
            }
        }

        impl TryFrom<f64> for $name {
            type Error = String;
            fn try_from(v: f64) -> Result<Self, String> {
                $name::new(v)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                self.0.fmt(f)
            }
        }

        impl From<$name> for f64 {
            fn from(v: $name) -> f64 {
                v.0
            }
        }

        impl schemars::JsonSchema for $name {
            fn schema_name() -> Cow<'static, str> {
                stringify!($name).into()
            }
            fn inline_schema() -> bool {
                true
            }
            fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
                schemars::json_schema!($schema)
            }
        }
    };
}

bounded_f64!(
    /// A finite number > 0 (a frequency, a step, a scale).
    Positive,
    "(0, ∞)",
    |v| v.is_finite() && v > 0.0,
    {"type": "number", "exclusiveMinimum": 0}
);
bounded_f64!(
    /// A finite number ≥ 0.
    NonNegative,
    "[0, ∞)",
    |v| v.is_finite() && v >= 0.0,
    {"type": "number", "minimum": 0}
);
bounded_f64!(
    /// A fraction in (0, 1] (a correlation threshold, a loss factor added for smoothing).
    Fraction,
    "(0, 1]",
    |v| v > 0.0 && v <= 1.0,
    {"type": "number", "exclusiveMinimum": 0, "maximum": 1}
);
bounded_f64!(
    /// A fraction in (0, 1), both ends excluded (a relative tolerance).
    OpenFraction,
    "(0, 1)",
    |v| v > 0.0 && v < 1.0,
    {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1}
);
bounded_f64!(
    /// A finite number ≥ 1 (the `κ` of the subset selection (5.14)).
    AtLeastOne,
    "[1, ∞)",
    |v| v.is_finite() && v >= 1.0,
    {"type": "number", "minimum": 1}
);

/// A count ≥ 1 (of modes, points, iterations of a scan), or a 1-based mode number.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(try_from = "u64", into = "u64")]
pub struct Count(usize);

impl Count {
    /// The count, if at least 1.
    pub fn new(n: usize) -> Result<Self, String> {
        if n >= 1 {
            Ok(Count(n))
        } else {
            Err(format!("{n} is out of range: give a whole number >= 1"))
        }
    }

    /// The number.
    pub fn get(self) -> usize {
        self.0
    }

    /// A default (at least 1).
    pub(crate) fn of_default(n: usize) -> Self {
        debug_assert!(n >= 1);
        Count(n)
    }
}

impl TryFrom<u64> for Count {
    type Error = String;
    fn try_from(n: u64) -> Result<Self, String> {
        let n = usize::try_from(n).map_err(|_| format!("{n} is too large"))?;
        Count::new(n)
    }
}

impl From<Count> for u64 {
    fn from(c: Count) -> u64 {
        c.0 as u64
    }
}

impl schemars::JsonSchema for Count {
    fn schema_name() -> Cow<'static, str> {
        "Count".into()
    }
    fn inline_schema() -> bool {
        true
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({"type": "integer", "minimum": 1})
    }
}

/// A frequency band `[lo, hi]` in Hz, `0 <= lo <= hi`, both finite.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "[f64; 2]", into = "[f64; 2]")]
pub struct Band {
    /// Lower end, Hz.
    pub lo: f64,
    /// Upper end, Hz.
    pub hi: f64,
}

impl TryFrom<[f64; 2]> for Band {
    type Error = String;
    fn try_from([lo, hi]: [f64; 2]) -> Result<Self, String> {
        if lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi >= lo {
            Ok(Band { lo, hi })
        } else {
            Err(format!(
                "[{lo}, {hi}] is not a band: give [start, stop] in Hz with 0 <= start <= stop"
            ))
        }
    }
}

impl Band {
    /// Whether `f_hz` lies in the band (ends included).
    pub fn contains(&self, f_hz: f64) -> bool {
        self.lo <= f_hz && f_hz <= self.hi
    }
}

/// The lines of `set` a stage uses: those inside `band` (all when `None`) and outside every
/// band of `exclude`. Measured and predicted sets given the same selection keep the same lines.
/// An empty selection is an error that names the fields and the lines there are.
pub fn select_lines(
    set: &FrfSet,
    band: Option<Band>,
    exclude: &[Band],
) -> Result<FrfSet, StageError> {
    let kept = set.select_lines(|f| {
        band.is_none_or(|b| b.contains(f)) && !exclude.iter().any(|b| b.contains(f))
    });
    if kept.freqs_hz.is_empty() {
        let range = match (set.freqs_hz.first(), set.freqs_hz.last()) {
            (Some(a), Some(b)) => format!("the lines run {a} to {b} Hz"),
            _ => "there are no lines".to_string(),
        };
        let field = if band.is_some() {
            "band_hz"
        } else {
            "exclude_hz"
        };
        return Err(StageError::input(
            field,
            format!("no line is left by band_hz and exclude_hz; {range}"),
        ));
    }
    Ok(kept)
}

impl From<Band> for [f64; 2] {
    fn from(b: Band) -> [f64; 2] {
        [b.lo, b.hi]
    }
}

impl schemars::JsonSchema for Band {
    fn schema_name() -> Cow<'static, str> {
        "Band".into()
    }
    fn inline_schema() -> bool {
        true
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "type": "array",
            "items": {"type": "number", "minimum": 0},
            "minItems": 2,
            "maxItems": 2,
            "description": "`[start, stop]` in Hz, 0 <= start <= stop"
        })
    }
}

/// The modal basis: the lowest `count` modes, or every mode up to `max_freq_hz` (the spelling of
/// the `modes` stage and of the reductions' component modes).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct Modes {
    /// The lowest this many modes …
    #[serde(default)]
    pub count: Option<Count>,
    /// … or every mode up to this frequency, Hz.
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
}

impl Modes {
    /// The lowest `n` modes.
    pub fn count(n: Count) -> Self {
        Modes {
            count: Some(n),
            max_freq_hz: None,
        }
    }

    /// Every mode up to `f` Hz.
    pub fn below(f: Positive) -> Self {
        Modes {
            count: None,
            max_freq_hz: Some(f),
        }
    }

    /// Whether either is given.
    pub fn is_given(&self) -> bool {
        self.count.is_some() || self.max_freq_hz.is_some()
    }

    /// Both given is an issue at `at` (`modes`, `component_modes`, …).
    pub fn issues(&self, at: &str) -> Vec<ParamIssue> {
        if self.count.is_some() && self.max_freq_hz.is_some() {
            vec![ParamIssue::at(
                &format!("{at}.count"),
                format!("give `{at}.count` or `{at}.max_freq_hz`, not both"),
            )]
        } else {
            Vec::new()
        }
    }

    /// The selection, `default` when neither is given.
    pub fn selection_or(&self, default: ModeSelection) -> ModeSelection {
        match (self.count, self.max_freq_hz) {
            (Some(c), _) => ModeSelection::Count(c.get()),
            (_, Some(f)) => ModeSelection::BelowHz(f.get()),
            _ => default,
        }
    }
}

/// An old spelling met in a `with:` block, and the one that replaces it.
#[derive(Clone, Debug, PartialEq)]
pub struct Deprecation {
    /// The old path below `with` (`mode_count`).
    pub old: &'static str,
    /// The new path (`modes.count`).
    pub new: &'static str,
}

impl std::fmt::Display for Deprecation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "`with.{}` is deprecated and will be removed in the next release: write `with.{}`",
            self.old, self.new
        )
    }
}

/// Reports deprecations as warnings (printed by `femu validate` and `femu run`, as the other
/// warnings of stages: through `tracing`, shown at the default level).
pub fn warn_deprecated(kind: &str, found: &[Deprecation]) {
    for d in found {
        tracing::warn!("stage kind `{kind}`: {d}");
    }
}

/// Moves the old spellings `mode_count` and `modes_max_hz` into `modes`, recording each as
/// deprecated; an issue when the old and the new spelling are both given.
pub fn migrate_mode_fields(
    modes: &mut Modes,
    mode_count: Option<Count>,
    modes_max_hz: Option<Positive>,
    found: &mut Vec<Deprecation>,
) -> Vec<ParamIssue> {
    let mut issues = Vec::new();
    if mode_count.is_none() && modes_max_hz.is_none() {
        return issues;
    }
    if modes.is_given() {
        issues.push(ParamIssue::at(
            "modes",
            "give `modes` alone: `mode_count` and `modes_max_hz` are its old spellings",
        ));
    }
    if let Some(c) = mode_count {
        found.push(Deprecation {
            old: "mode_count",
            new: "modes.count",
        });
        modes.count = Some(c);
    }
    if let Some(f) = modes_max_hz {
        found.push(Deprecation {
            old: "modes_max_hz",
            new: "modes.max_freq_hz",
        });
        modes.max_freq_hz = Some(f);
    }
    issues
}

/// One value for every mode, or one per mode.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum PerMode {
    /// The same value for every mode.
    Uniform(f64),
    /// One value per mode, in mode order.
    PerMode(Vec<f64>),
    /// One value for every mode except those listed by 1-based mode number (rigid-body
    /// modes counted), e.g. `{all: 0.01, modes: {7: 0.03, 8: 0.025}}`.
    Modes {
        /// The value of every mode not listed.
        all: f64,
        /// Values by 1-based mode number (keys are numbers: YAML `7:` or JSON `"7"`).
        modes: std::collections::BTreeMap<String, f64>,
    },
}

impl PerMode {
    /// The values: one (uniform) or one per mode; listed modes set over a uniform value.
    pub fn values(&self) -> Vec<f64> {
        match self {
            PerMode::Uniform(v) => vec![*v],
            PerMode::PerMode(v) => v.clone(),
            PerMode::Modes { all, modes } => {
                let listed: Vec<(usize, f64)> = modes
                    .iter()
                    .filter_map(|(r, &x)| r.parse::<usize>().ok().map(|r| (r, x)))
                    .collect();
                let n = listed.iter().map(|l| l.0).max().unwrap_or(1).max(1);
                let mut v = vec![*all; n];
                for (r, x) in listed {
                    if r >= 1 {
                        v[r - 1] = x;
                    }
                }
                v
            }
        }
    }

    /// One value per mode for a basis of `m` modes, or what is wrong.
    pub fn values_for(&self, m: usize) -> Result<Vec<f64>, String> {
        match self {
            PerMode::Uniform(v) => Ok(vec![*v; m]),
            PerMode::PerMode(v) if v.len() == m => Ok(v.clone()),
            PerMode::PerMode(v) => Err(format!(
                "{} per-mode values for {m} modes: give one value per mode, or `{{all: …, modes: {{…}}}}`",
                v.len()
            )),
            PerMode::Modes { all, modes } => {
                let mut v = vec![*all; m];
                for (key, &x) in modes {
                    let r: usize = key.parse().map_err(|_| {
                        format!("`{key}` is not a mode number: keys are 1-based mode numbers")
                    })?;
                    if r == 0 || r > m {
                        return Err(format!(
                            "mode {r} is not among the {m} modes (numbers count from 1)"
                        ));
                    }
                    v[r - 1] = x;
                }
                Ok(v)
            }
        }
    }
}

/// Damping of a prediction (`frf.synthesise`, `update`, `localise.leverage`).
#[derive(
    Clone, Debug, Default, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Damping {
    /// Undamped (the model's own C and D still apply to `direct`).
    #[default]
    None,
    /// Structural loss factor `η` (modal: per mode allowed; direct: uniform, `D += η K`).
    Structural(PerMode),
    /// Viscous damping ratio `ζ` per mode (modal only).
    Viscous(PerMode),
    /// Rayleigh viscous damping `C += α M + β K` (direct only).
    Rayleigh {
        /// Mass-proportional coefficient α in 1/s.
        alpha: f64,
        /// Stiffness-proportional coefficient β in s.
        beta: f64,
    },
}

impl Damping {
    /// The modal damping it describes (Rayleigh, a direct-only model, gives none).
    pub fn modal(&self) -> ModalDamping {
        match self {
            Damping::None | Damping::Rayleigh { .. } => ModalDamping::None,
            Damping::Structural(v) => ModalDamping::Structural(v.values()),
            Damping::Viscous(v) => ModalDamping::Viscous(v.values()),
        }
    }

    /// The modal damping of a basis of `m` modes, per-mode lists checked against `m`.
    pub fn modal_for(&self, m: usize) -> Result<ModalDamping, String> {
        Ok(match self {
            Damping::None | Damping::Rayleigh { .. } => ModalDamping::None,
            Damping::Structural(v) => ModalDamping::Structural(v.values_for(m)?),
            Damping::Viscous(v) => ModalDamping::Viscous(v.values_for(m)?),
        })
    }

    /// Whether values are given per mode (a list or by mode number).
    pub fn is_per_mode(&self) -> bool {
        matches!(
            self,
            Damping::Structural(PerMode::PerMode(_) | PerMode::Modes { .. })
                | Damping::Viscous(PerMode::PerMode(_) | PerMode::Modes { .. })
        )
    }

    /// The damping added to a direct solution (a per-mode or viscous value is modal-only).
    pub fn direct(&self) -> DirectDamping {
        match self {
            Damping::Structural(v) => DirectDamping {
                structural_eta: v.values().first().copied().unwrap_or(0.0),
                rayleigh: None,
            },
            Damping::Rayleigh { alpha, beta } => DirectDamping {
                structural_eta: 0.0,
                rayleigh: Some((*alpha, *beta)),
            },
            _ => DirectDamping::default(),
        }
    }
}

/// The measured DOFs (responses and excitations) of `set` that are not free DOFs of `model`, as
/// one preflight issue naming the input port, the first few with the reason, and what would be
/// valid: a grid or scalar point the model lacks, or a constrained DOF. `None` when all are
/// DOFs of the model.
pub fn measured_dofs_issue(
    model: &crate::model::Model,
    set: &FrfSet,
    port: &str,
) -> Option<ParamIssue> {
    use crate::core::Component;
    let constrained: std::collections::BTreeSet<_> = model.constraints.iter().copied().collect();
    let mut seen = std::collections::BTreeSet::new();
    let mut bad: Vec<String> = Vec::new();
    for p in &set.pairs {
        for (dof, role) in [(p.response, "response"), (p.excitation, "excitation")] {
            if !seen.insert(dof) {
                continue;
            }
            let scalar = dof.comp == Component::Scalar;
            let why = if scalar && !model.scalar_points.contains(&dof.node) {
                format!("no scalar point {}", dof.node)
            } else if !scalar && !model.nodes.contains_key(&dof.node) {
                format!("no grid {}", dof.node)
            } else if constrained.contains(&dof) {
                "constrained (SPC)".to_string()
            } else {
                continue;
            };
            bad.push(format!("{dof} ({role}: {why})"));
        }
    }
    if bad.is_empty() {
        return None;
    }
    Some(ParamIssue {
        path: Vec::new(),
        message: format!(
            "input `{port}`: {} measured DOF(s) are not DOFs of the model: {}. Measured DOFs must be model DOFs: pair the test to the model with `test.pair` and connect its `map`, or measure at model DOFs",
            bad.len(),
            crate::core::first_of(bad.iter(), 5)
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::stage::parse_params;

    #[derive(Debug, serde::Deserialize, schemars::JsonSchema)]
    #[allow(dead_code)]
    struct P {
        #[serde(default)]
        kappa_f: Option<Fraction>,
        #[serde(default)]
        count: Option<Count>,
        #[serde(default)]
        step_hz: Option<Positive>,
        #[serde(default)]
        band_hz: Option<Band>,
    }

    #[test]
    fn bounded_numbers_name_the_field_and_the_range() {
        let e = parse_params::<P>(&serde_json::json!({"kappa_f": 1.5})).unwrap_err();
        assert_eq!(e.path, vec!["kappa_f"]);
        assert!(e.message.contains("(0, 1]"), "{}", e.message);
        let e = parse_params::<P>(&serde_json::json!({"count": 0})).unwrap_err();
        assert_eq!(e.path, vec!["count"]);
        assert!(e.message.contains(">= 1"), "{}", e.message);
        let e = parse_params::<P>(&serde_json::json!({"step_hz": -1.0})).unwrap_err();
        assert_eq!(e.path, vec!["step_hz"]);
        assert!(e.message.contains("(0, ∞)"), "{}", e.message);
        let e = parse_params::<P>(&serde_json::json!({"band_hz": [10, 1]})).unwrap_err();
        assert_eq!(e.path, vec!["band_hz"]);
        assert!(e.message.contains("start <= stop"), "{}", e.message);
        let ok = parse_params::<P>(&serde_json::json!({"kappa_f": 1, "count": 3})).unwrap();
        assert_eq!(ok.kappa_f.unwrap().get(), 1.0);
        assert_eq!(ok.count.unwrap().get(), 3);
    }

    #[test]
    fn bounded_numbers_publish_their_range() {
        let s = schemars::schema_for!(P).to_value().to_string();
        assert!(
            s.contains(r#""exclusiveMinimum":0"#) && s.contains(r#""maximum":1"#),
            "{s}"
        );
        assert!(s.contains(r#""minimum":1"#), "{s}");
    }

    #[test]
    fn old_mode_spellings_move_into_modes_with_a_deprecation() {
        let mut modes = Modes::default();
        let mut found = Vec::new();
        let issues = migrate_mode_fields(&mut modes, Count::new(3).ok(), None, &mut found);
        assert!(issues.is_empty());
        assert_eq!(modes, Modes::count(Count::new(3).unwrap()));
        assert_eq!(found[0].new, "modes.count");
        assert!(found[0].to_string().contains("write `with.modes.count`"));
        let mut found = Vec::new();
        let issues = migrate_mode_fields(&mut modes, None, Positive::new(5.0).ok(), &mut found);
        assert_eq!(issues[0].path, vec!["modes"]);
        assert_eq!(found[0].old, "modes_max_hz");
    }
}
