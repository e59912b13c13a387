//! The executor: runs a plan in topological waves, independent stages of a wave in parallel,
//! consulting the cache for every stage. A stage whose key is in the cache is not run; because
//! keys hold input digests, not input keys, a re-run stage that reproduces its outputs exactly
//! leaves everything downstream cached (early cutoff).

use super::memo::{PartCache, PartCounts};
use super::plan::Plan;
use super::stage::{StageError, StageInputs};
use crate::artefact::{Artefact, ArtefactKind};
use crate::cache::{Cache, CacheError, Lookup, OutputRecord, cache_key};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::IsTerminal;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ProgressMode {
    /// Live spinners on a terminal, plain lines otherwise.
    #[default]
    Auto,
    /// Plain lines on standard error.
    Plain,
    /// Nothing.
    Quiet,
}

/// Options of one run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Recompute every selected stage even when cached.
    pub force: bool,
    /// Run only these stages and their upstream (all when empty).
    pub only: Vec<String>,
    /// Progress display.
    pub progress: ProgressMode,
}

/// What happened to a stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Computed.
    Ran,
    /// Taken from the cache.
    Cached,
    /// Its cache entry was corrupt; evicted and computed again.
    Recovered,
}

impl Status {
    /// Short label.
    pub fn label(self) -> &'static str {
        match self {
            Status::Ran => "ran",
            Status::Cached => "cached",
            Status::Recovered => "recomputed (corrupt cache entry)",
        }
    }
}

/// The outcome of one stage.
#[derive(Clone, Debug)]
pub struct StageReport {
    /// Stage name.
    pub name: String,
    /// Kind.
    pub kind: String,
    /// Cache key.
    pub key: String,
    /// Ran or cached.
    pub status: Status,
    /// Wall time.
    pub elapsed: Duration,
    /// Outputs by port.
    pub outputs: BTreeMap<String, OutputRecord>,
    /// A warning to show (e.g. why an entry was recomputed).
    pub note: Option<String>,
    /// Parts cached on their own: how many were reused and computed in this run, and their keys
    /// (for a cached stage, the keys its entry records).
    pub parts: PartCounts,
}

/// The outcome of a run, in plan order.
#[derive(Clone, Debug)]
pub struct RunReport {
    /// Per stage, for the stages that were selected.
    pub stages: Vec<StageReport>,
}

impl RunReport {
    /// Number of stages that were computed.
    pub fn executed(&self) -> usize {
        self.stages
            .iter()
            .filter(|s| s.status != Status::Cached)
            .count()
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A stage failed.
    #[error("stage `{stage}` ({kind}) failed: {source}")]
    Stage {
        /// Stage name.
        stage: String,
        /// Its kind.
        kind: String,
        /// The cause.
        source: StageError,
    },
    /// The store failed.
    #[error("stage `{stage}`: {source}")]
    Cache {
        /// Stage name.
        stage: String,
        /// The cause.
        source: CacheError,
    },
    /// `--only` named an unknown stage.
    #[error("--only {0}: no such stage (stages: {1})")]
    UnknownOnly(String, String),
    /// Writing `--out` failed.
    #[error("--out {path}: {source}")]
    Out {
        /// Path.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
}

impl RunError {
    /// Whether the user's input is at fault: an unknown `--only` stage, or a stage's bad input.
    pub fn is_input(&self) -> bool {
        match self {
            RunError::UnknownOnly(..) => true,
            RunError::Stage { source, .. } => source.is_input(),
            RunError::Cache { .. } | RunError::Out { .. } => false,
        }
    }
}

enum Progress {
    Bars(
        indicatif::MultiProgress,
        Mutex<HashMap<String, indicatif::ProgressBar>>,
    ),
    Plain,
    Quiet,
}

impl Progress {
    fn new(mode: ProgressMode) -> Self {
        match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => {
                Progress::Bars(indicatif::MultiProgress::new(), Mutex::new(HashMap::new()))
            }
            ProgressMode::Auto | ProgressMode::Plain => Progress::Plain,
            ProgressMode::Quiet => Progress::Quiet,
        }
    }

    fn start(&self, name: &str, kind: &str) {
        match self {
            Progress::Bars(mp, bars) => {
                let pb = mp.add(indicatif::ProgressBar::new_spinner());
                pb.set_message(format!("{name} ({kind}) running"));
                pb.enable_steady_tick(Duration::from_millis(120));
                if let Ok(mut b) = bars.lock() {
                    b.insert(name.to_string(), pb);
                }
            }
            Progress::Plain => eprintln!("[femu] {name} ({kind}): running"),
            Progress::Quiet => {}
        }
    }

    fn finish(&self, r: &StageReport) {
        let mut line = format!(
            "{} ({}): {} in {:.3} s",
            r.name,
            r.kind,
            r.status.label(),
            r.elapsed.as_secs_f64()
        );
        if r.parts.reused + r.parts.computed > 0 {
            line += &format!(
                " (parts: {} from the cache, {} computed)",
                r.parts.reused, r.parts.computed
            );
        }
        match self {
            Progress::Bars(mp, bars) => {
                let pb = bars.lock().ok().and_then(|mut b| b.remove(&r.name));
                match pb {
                    Some(pb) => pb.finish_with_message(line),
                    None => {
                        let _ = mp.println(line);
                    }
                }
            }
            Progress::Plain => eprintln!("[femu] {line}"),
            Progress::Quiet => {}
        }
        if let (Some(note), false) = (&r.note, matches!(self, Progress::Quiet)) {
            eprintln!("warning: stage `{}`: {note}", r.name);
        }
    }
}

/// Runs `plan` against `cache`.
pub fn execute(plan: &Plan, cache: &Cache, opts: &RunOptions) -> Result<RunReport, RunError> {
    let selected: BTreeSet<usize> = if opts.only.is_empty() {
        (0..plan.nodes.len()).collect()
    } else {
        let mut targets = Vec::new();
        for name in &opts.only {
            let i = plan.index(name).ok_or_else(|| {
                RunError::UnknownOnly(
                    name.clone(),
                    plan.nodes
                        .iter()
                        .map(|n| n.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                )
            })?;
            targets.push(i);
        }
        plan.upstream_closure(&targets)
    };
    let progress = Progress::new(opts.progress);
    let mut reports: Vec<Option<StageReport>> = vec![None; plan.nodes.len()];
    let produced: Mutex<HashMap<(usize, String), Arc<Artefact>>> = Mutex::new(HashMap::new());
    loop {
        let wave: Vec<usize> = selected
            .iter()
            .copied()
            .filter(|&i| {
                reports[i].is_none()
                    && plan.nodes[i]
                        .inputs
                        .values()
                        .all(|r| reports[r.node].is_some())
            })
            .collect();
        if wave.is_empty() {
            break;
        }
        let results: Vec<Result<StageReport, RunError>> = std::thread::scope(|s| {
            let handles: Vec<_> = wave
                .iter()
                .map(|&i| {
                    let reports = &reports;
                    let produced = &produced;
                    let progress = &progress;
                    s.spawn(move || {
                        run_node(plan, i, reports, produced, cache, opts.force, progress)
                    })
                })
                .collect();
            handles
                .into_iter()
                .zip(&wave)
                .map(|(h, &i)| {
                    h.join().unwrap_or_else(|_| {
                        Err(RunError::Stage {
                            stage: plan.nodes[i].name.clone(),
                            kind: plan.nodes[i].stage.kind().to_string(),
                            source: StageError::Failed("internal error: the stage thread panicked (a femu bug; please report it)".into()),
                        })
                    })
                })
                .collect()
        });
        for (i, r) in wave.iter().zip(results) {
            reports[*i] = Some(r?);
        }
    }
    Ok(RunReport {
        stages: reports.into_iter().flatten().collect(),
    })
}

fn run_node(
    plan: &Plan,
    i: usize,
    reports: &[Option<StageReport>],
    produced: &Mutex<HashMap<(usize, String), Arc<Artefact>>>,
    cache: &Cache,
    force: bool,
    progress: &Progress,
) -> Result<StageReport, RunError> {
    let node = &plan.nodes[i];
    let kind = node.stage.kind();
    let t0 = Instant::now();
    let cache_err = |source| RunError::Cache {
        stage: node.name.clone(),
        source,
    };
    let upstream = |port: &str| -> (&StageReport, &OutputRecord) {
        let r = &node.inputs[port];
        let rep = reports[r.node].as_ref().expect("waves run upstream first");
        (rep, &rep.outputs[&r.port])
    };
    let digests: BTreeMap<String, String> = node
        .inputs
        .keys()
        .map(|p| (p.clone(), upstream(p).1.digest.clone()))
        .collect();
    let key = cache_key(
        kind,
        node.stage.impl_version(),
        &node.stage.key_params(&node.params),
        node.format,
        &digests,
    );
    let mut note = None;
    if !force {
        match cache.lookup(&key) {
            Lookup::Hit(m) => {
                let r = StageReport {
                    name: node.name.clone(),
                    kind: kind.into(),
                    key,
                    status: Status::Cached,
                    elapsed: t0.elapsed(),
                    parts: PartCounts {
                        keys: m.parts.clone(),
                        ..Default::default()
                    },
                    outputs: m.outputs,
                    note: None,
                };
                progress.finish(&r);
                return Ok(r);
            }
            Lookup::Corrupt(reason) => {
                note = Some(format!(
                    "cache entry {key} was corrupt ({reason}); evicted and recomputed"
                ))
            }
            Lookup::Miss => {}
        }
    }
    progress.start(&node.name, kind);
    let parts = Arc::new(PartCache::new(cache.clone(), node.format, force));
    let mut inputs = StageInputs {
        base_dir: plan.base_dir.clone(),
        parts: Some(parts.clone()),
        ..Default::default()
    };
    for (port, r) in &node.inputs {
        let cached = produced
            .lock()
            .ok()
            .and_then(|m| m.get(&(r.node, r.port.clone())).cloned());
        let a = match cached {
            Some(a) => a,
            None => {
                let (rep, out) = upstream(port);
                let k = ArtefactKind::from_name(&out.kind).ok_or_else(|| {
                    cache_err(CacheError::Corrupt {
                        key: rep.key.clone(),
                        reason: format!("unknown kind {}", out.kind),
                    })
                })?;
                Arc::new(cache.read(&rep.key, &r.port, k).map_err(cache_err)?)
            }
        };
        inputs.artefacts.insert(port.clone(), a);
    }
    let outputs = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        node.stage.run(&node.params, &inputs)
    }))
    .unwrap_or_else(|_| {
        Err(StageError::Failed(
            "internal error: the stage panicked (a femu bug; please report it with the pipeline)"
                .into(),
        ))
    })
    .map_err(|source| RunError::Stage {
        stage: node.name.clone(),
        kind: kind.into(),
        source,
    })?;
    for p in node.stage.outputs() {
        if !outputs.contains_key(p.name) {
            return Err(RunError::Stage {
                stage: node.name.clone(),
                kind: kind.into(),
                source: StageError::Failed(format!(
                    "internal error: output `{}` was not produced",
                    p.name
                )),
            });
        }
    }
    let parts = parts.counts();
    let version = node.stage.impl_version();
    let manifest = if force {
        cache.recommit(&key, kind, version, &outputs, node.format, &parts.keys)
    } else {
        cache.commit_with_parts(&key, kind, version, &outputs, node.format, &parts.keys)
    }
    .map_err(cache_err)?;
    if let Ok(mut m) = produced.lock() {
        for (port, a) in outputs {
            m.insert((i, port), Arc::new(a));
        }
    }
    let status = if note.is_some() {
        Status::Recovered
    } else {
        Status::Ran
    };
    let r = StageReport {
        name: node.name.clone(),
        kind: kind.into(),
        key,
        status,
        elapsed: t0.elapsed(),
        outputs: manifest.outputs,
        note,
        parts,
    };
    progress.finish(&r);
    Ok(r)
}

/// Copies every output of the run to `out/<stage>/<port>/` as plain files.
pub fn materialise(report: &RunReport, cache: &Cache, out: &Path) -> Result<(), RunError> {
    let err = |path: &Path| {
        let path = path.display().to_string();
        move |source| RunError::Out { path, source }
    };
    for s in &report.stages {
        for port in s.outputs.keys() {
            let dest = out.join(&s.name).join(port);
            if dest.exists() {
                std::fs::remove_dir_all(&dest).map_err(err(&dest))?;
            }
            std::fs::create_dir_all(&dest).map_err(err(&dest))?;
            let src = cache.artefact_dir(&s.key, port);
            for e in std::fs::read_dir(&src).map_err(err(&src))? {
                let e = e.map_err(err(&src))?;
                std::fs::copy(e.path(), dest.join(e.file_name())).map_err(err(&dest))?;
            }
        }
    }
    Ok(())
}
