//! The executor: runs a plan in topological waves, independent stages of a wave in parallel,
//! consulting the cache for every stage. A stage whose key is in the cache is not run; because
//! keys hold input digests, not input keys, a re-run stage that reproduces its outputs exactly
//! leaves everything downstream cached (early cutoff).

use super::lock::{LockFile, OUT_LOCK_FILE};
use super::memo::{PartCache, PartCounts};
use super::plan::Plan;
use super::stage::{StageError, StageInputs};
use crate::artefact::{Artefact, ArtefactKind};
use crate::cache::{Cache, CacheError, Lookup, OutputRecord, cache_key};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::{IsTerminal, Write};
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
    /// Wall time: the stage's work and its outputs' digests.
    pub elapsed: Duration,
    /// Wall time of writing the stage's cache entry, which runs in the background beside the
    /// stages after it (`None` when the stage was served from the cache).
    pub cache_write: Option<Duration>,
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

/// How the executor shows a run: per stage a start and an end line, and in between what the
/// stage's numerics report through [`crate::core::progress`].
enum Display {
    /// Live bars on a terminal, one per running stage.
    Bars {
        multi: indicatif::MultiProgress,
        bars: Mutex<HashMap<String, StageBar>>,
    },
    /// Plain lines on standard error, rate-limited per stage.
    Plain(PlainLines),
    /// Nothing.
    Quiet,
}

/// A running stage's bar and whether it shows a count yet (a spinner until the first task
/// with a known total).
struct StageBar {
    bar: indicatif::ProgressBar,
    counted: bool,
}

/// The sink of one stage: its events go to the run's display, named by the stage.
struct StageSink {
    stage: String,
    display: Arc<Display>,
}

impl crate::core::progress::Sink for StageSink {
    fn event(&self, event: crate::core::progress::Event<'_>) {
        self.display.event(&self.stage, event);
    }
}

impl Display {
    fn new(mode: ProgressMode) -> Self {
        match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => Display::Bars {
                multi: indicatif::MultiProgress::new(),
                bars: Mutex::new(HashMap::new()),
            },
            ProgressMode::Auto | ProgressMode::Plain => Display::Plain(PlainLines::stderr()),
            ProgressMode::Quiet => Display::Quiet,
        }
    }

    fn quiet(&self) -> bool {
        matches!(self, Display::Quiet)
    }

    fn start(&self, name: &str, kind: &str) {
        match self {
            Display::Bars { multi, bars } => {
                let pb = multi.add(indicatif::ProgressBar::new_spinner());
                pb.set_prefix(format!("{name} ({kind})"));
                if let Ok(style) =
                    indicatif::ProgressStyle::with_template("{spinner} {prefix}: {msg}")
                {
                    pb.set_style(style);
                }
                pb.set_message("running");
                pb.enable_steady_tick(Duration::from_millis(120));
                if let Ok(mut b) = bars.lock() {
                    b.insert(
                        name.to_string(),
                        StageBar {
                            bar: pb,
                            counted: false,
                        },
                    );
                }
            }
            Display::Plain(p) => p.start(name, kind),
            Display::Quiet => {}
        }
    }

    fn event(&self, stage: &str, event: crate::core::progress::Event<'_>) {
        use crate::core::progress::Event;
        match self {
            Display::Bars { multi, bars } => match event {
                Event::Step { task, done, total } => {
                    let Ok(mut b) = bars.lock() else { return };
                    let Some(sb) = b.get_mut(stage) else { return };
                    if total > 0 {
                        if !sb.counted {
                            if let Ok(style) = indicatif::ProgressStyle::with_template(
                                "{spinner} {prefix}: {msg} [{bar:30}] {pos}/{len} ({eta} left)",
                            ) {
                                sb.bar.set_style(style.progress_chars("=> "));
                            }
                            sb.counted = true;
                        }
                        sb.bar.set_length(total);
                        sb.bar.set_position(done);
                        if sb.bar.message() != task {
                            sb.bar.set_message(task.to_string());
                        }
                    } else {
                        sb.bar.set_message(uncounted(task, done));
                    }
                }
                Event::Note(line) => {
                    let _ = multi.println(format!("{stage}: {line}"));
                }
            },
            Display::Plain(p) => p.event(stage, event),
            Display::Quiet => {}
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
            Display::Bars { multi, bars } => {
                let pb = bars.lock().ok().and_then(|mut b| b.remove(&r.name));
                match pb {
                    Some(sb) => {
                        if let Ok(style) = indicatif::ProgressStyle::with_template("{msg}") {
                            sb.bar.set_style(style);
                        }
                        sb.bar.finish_with_message(line)
                    }
                    None => {
                        let _ = multi.println(line);
                    }
                }
            }
            Display::Plain(p) => p.finish(&r.name, &line),
            Display::Quiet => {}
        }
        if let (Some(note), false) = (&r.note, self.quiet()) {
            eprintln!("warning: stage `{}`: {note}", r.name);
        }
    }
}

/// A clock for [`PlainLines`]: time since some fixed start.
type Clock = Box<dyn Fn() -> Duration + Send + Sync>;

/// A step without a total as shown: the task and its count, or the task alone when nothing is
/// counted (`done` 0: a status such as "K − σM factorised").
fn uncounted(task: &str, done: u64) -> String {
    if done == 0 {
        task.to_string()
    } else {
        format!("{task} {done}")
    }
}

/// Plain progress lines for logs: each stage's start and end, every note, and a stage's steps
/// at most once per `interval` (the first step of a stage at once).
pub(crate) struct PlainLines {
    out: Mutex<Box<dyn std::io::Write + Send>>,
    clock: Clock,
    interval: Duration,
    /// When each running stage last printed a step.
    last: Mutex<HashMap<String, Duration>>,
}

impl PlainLines {
    /// Lines on standard error, steps at most once a second per stage.
    fn stderr() -> Self {
        let t0 = Instant::now();
        Self::new(
            Box::new(std::io::stderr()),
            Box::new(move || t0.elapsed()),
            Duration::from_secs(1),
        )
    }

    /// Lines to `out`, timed by `clock`.
    pub(crate) fn new(
        out: Box<dyn std::io::Write + Send>,
        clock: Clock,
        interval: Duration,
    ) -> Self {
        PlainLines {
            out: Mutex::new(out),
            clock,
            interval,
            last: Mutex::new(HashMap::new()),
        }
    }

    fn line(&self, text: &str) {
        if let Ok(mut o) = self.out.lock() {
            let _ = writeln!(o, "[femu] {text}");
        }
    }

    pub(crate) fn start(&self, name: &str, kind: &str) {
        self.line(&format!("{name} ({kind}): running"));
    }

    pub(crate) fn event(&self, stage: &str, event: crate::core::progress::Event<'_>) {
        use crate::core::progress::Event;
        match event {
            Event::Step { task, done, total } => {
                let now = (self.clock)();
                let due = match self.last.lock() {
                    Ok(mut last) => {
                        let due = last
                            .get(stage)
                            .is_none_or(|t| now.saturating_sub(*t) >= self.interval);
                        if due {
                            last.insert(stage.to_string(), now);
                        }
                        due
                    }
                    Err(_) => false,
                };
                if due {
                    self.line(&if total > 0 {
                        format!(
                            "{stage}: {task} {done}/{total} ({:.0} %)",
                            100.0 * done as f64 / total as f64
                        )
                    } else {
                        format!("{stage}: {}", uncounted(task, done))
                    });
                }
            }
            Event::Note(text) => self.line(&format!("{stage}: {text}")),
        }
    }

    pub(crate) fn finish(&self, stage: &str, line: &str) {
        if let Ok(mut last) = self.last.lock() {
            last.remove(stage);
        }
        self.line(line);
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
    let display = Arc::new(Display::new(opts.progress));
    let mut reports: Vec<Option<StageReport>> = vec![None; plan.nodes.len()];
    let produced = Produced::new(selected.iter().flat_map(|&i| {
        plan.nodes[i]
            .inputs
            .values()
            .map(|r| (r.node, r.port.clone()))
    }));
    // Cache entries being written in the background, joined before the run returns, whether
    // it succeeded or not (no writer outlives the run).
    let commits = Mutex::new(Vec::new());
    let mut written = Vec::new();
    let waves = run_waves(
        plan,
        &selected,
        &mut reports,
        &produced,
        cache,
        opts,
        &display,
        &commits,
        &mut written,
    );
    let running = commits.into_inner().unwrap_or_else(|e| e.into_inner());
    let joined = join_commits(plan, running, &mut written);
    waves?;
    joined?;
    for (i, seconds) in written {
        if let Some(r) = reports[i].as_mut() {
            r.cache_write = Some(seconds);
        }
    }
    Ok(RunReport {
        stages: reports.into_iter().flatten().collect(),
    })
}

/// Runs the selected nodes wave by wave (a wave: every node whose inputs are ready, run side by
/// side), filling `reports`; stops at the first failure.
#[allow(clippy::too_many_arguments)]
fn run_waves(
    plan: &Plan,
    selected: &BTreeSet<usize>,
    reports: &mut [Option<StageReport>],
    produced: &Produced,
    cache: &Cache,
    opts: &RunOptions,
    display: &Arc<Display>,
    commits: &Mutex<Vec<PendingCommit>>,
    written: &mut Vec<(usize, Duration)>,
) -> Result<(), RunError> {
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
                    let reports = &*reports;
                    s.spawn(move || {
                        run_node(
                            plan, i, reports, produced, cache, opts.force, display, commits,
                        )
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
        // A cache entry that could not be written stops the run here, not after it.
        let finished: Vec<PendingCommit> = {
            let mut c = commits.lock().unwrap_or_else(|e| e.into_inner());
            let (done, running) = c.drain(..).partition(|p| p.handle.is_finished());
            *c = running;
            done
        };
        join_commits(plan, finished, written)?;
    }
    Ok(())
}

/// A stage's cache entry being written on a thread of its own.
struct PendingCommit {
    node: usize,
    key: String,
    handle: std::thread::JoinHandle<Result<Duration, CacheError>>,
}

/// Waits for `commits`, adding the write time of each that succeeded to `written`; the first
/// failure (in plan order) names its stage.
fn join_commits(
    plan: &Plan,
    mut commits: Vec<PendingCommit>,
    written: &mut Vec<(usize, Duration)>,
) -> Result<(), RunError> {
    commits.sort_by_key(|c| c.node);
    let mut first_error = None;
    for c in commits {
        let outcome = c.handle.join().unwrap_or_else(|_| {
            Err(CacheError::Corrupt {
                key: c.key.clone(),
                reason: "internal error: its writer panicked (a femu bug; please report it)".into(),
            })
        });
        match outcome {
            Ok(seconds) => written.push((c.node, seconds)),
            Err(source) => {
                first_error.get_or_insert(RunError::Cache {
                    stage: plan.nodes[c.node].name.clone(),
                    source,
                });
            }
        }
    }
    first_error.map_or(Ok(()), Err)
}

/// Lowers the calling thread's scheduling priority (on Linux, `nice` 10 for this thread
/// only): a background cache write then takes the cores mostly when the stages running
/// meanwhile leave them idle, instead of an equal share (on two cores the 1M plate's `modes`
/// stage ran 1.7–2.1 s over its kernel with it, 1.8–2.4 s without). Elsewhere it does nothing.
fn yield_to_the_stages() {
    #[cfg(target_os = "linux")]
    // SAFETY: `setpriority` with this thread's own id changes only its nice value; a failure
    // (returned, not raised) leaves the priority as it was.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t, 10);
    }
}

/// Starts writing node `node`'s `(port, artefact, digest)` outputs into the cache under `key`
/// on a thread of its own (with a rayon pool of its own, so the stages running meanwhile do
/// not hold up its jobs, nor it theirs).
fn commit_in_background(
    plan: &Plan,
    node: usize,
    cache: &Cache,
    key: &str,
    outputs: Vec<(String, Arc<Artefact>, String)>,
    parts: &[String],
    force: bool,
) -> Result<PendingCommit, RunError> {
    let n = &plan.nodes[node];
    let root = cache.root().to_path_buf();
    let entry = key.to_string();
    let (cache, key, parts) = (cache.clone(), key.to_string(), parts.to_vec());
    let (kind, version, format) = (n.stage.kind(), n.stage.impl_version(), n.format);
    let write = move || -> Result<Duration, CacheError> {
        let t = Instant::now();
        let outputs: Vec<(&str, &Artefact, &str)> = outputs
            .iter()
            .map(|(port, a, digest)| (port.as_str(), &**a, digest.as_str()))
            .collect();
        // `--force`: the entry is replaced.
        let commit = || {
            if force {
                cache.evict(&key)?;
            }
            cache.commit_digested(&key, kind, version, &outputs, format, &parts)
        };
        match rayon::ThreadPoolBuilder::new()
            .num_threads(rayon::current_num_threads())
            .thread_name(|i| format!("femu-cache-write-{i}"))
            .start_handler(|_| yield_to_the_stages())
            .build()
        {
            Ok(pool) => pool.install(commit),
            Err(_) => commit(),
        }?;
        Ok(t.elapsed())
    };
    let handle = std::thread::Builder::new()
        .name(format!("femu-cache-write-{}", n.name))
        .spawn(write)
        .map_err(|e| RunError::Cache {
            stage: n.name.clone(),
            source: CacheError::Io {
                path: root,
                source: e,
            },
        })?;
    Ok(PendingCommit {
        node,
        key: entry,
        handle,
    })
}

/// Artefacts produced in this run, by (node, output port), each held in memory until the last
/// node of the run that reads it has taken it (and its cache entry is written, which takes a
/// second or two at 10⁶ DOFs): a model's matrices (gigabytes at 10⁶ DOFs) are not kept beside
/// the eigensolver's factor, nor for the rest of the run.
struct Produced(Mutex<HashMap<(usize, String), Held>>);

/// An output of this run and the number of its readers still to run.
struct Held {
    artefact: Option<Arc<Artefact>>,
    readers: usize,
}

impl Produced {
    /// Counts the readers of every output: one per `(node, port)` an input of a selected node
    /// reads.
    fn new(reads: impl IntoIterator<Item = (usize, String)>) -> Self {
        let mut held: HashMap<(usize, String), Held> = HashMap::new();
        for read in reads {
            held.entry(read)
                .or_insert(Held {
                    artefact: None,
                    readers: 0,
                })
                .readers += 1;
        }
        Self(Mutex::new(held))
    }

    /// Keeps an output of node `node` for its readers (an output nobody reads is not kept).
    fn put(&self, node: usize, port: String, a: Arc<Artefact>) {
        if let Ok(mut m) = self.0.lock()
            && let Some(h) = m.get_mut(&(node, port)).filter(|h| h.readers > 0)
        {
            h.artefact = Some(a);
        }
    }

    /// One reader's share of output `port` of node `node`: the artefact, when this run produced
    /// it, released from memory here once the last reader has taken it. Every reader calls
    /// this once per input, whether it runs or is served from the cache.
    fn take(&self, node: usize, port: &str) -> Option<Arc<Artefact>> {
        let mut m = self.0.lock().ok()?;
        let h = m.get_mut(&(node, port.to_string()))?;
        h.readers = h.readers.saturating_sub(1);
        if h.readers == 0 {
            h.artefact.take()
        } else {
            h.artefact.clone()
        }
    }
}

/// Node `i`: served by the cache when its key is there (unless `force`), else its stage run
/// on its inputs, its outputs digested (the keys downstream need the digests) and handed to
/// the stages downstream, and their commit started in the background (added to `commits`).
#[allow(clippy::too_many_arguments)]
fn run_node(
    plan: &Plan,
    i: usize,
    reports: &[Option<StageReport>],
    produced: &Produced,
    cache: &Cache,
    force: bool,
    display: &Arc<Display>,
    commits: &Mutex<Vec<PendingCommit>>,
) -> Result<StageReport, RunError> {
    let node = &plan.nodes[i];
    let kind = node.stage.kind();
    let t0 = Instant::now();
    let cache_err = |source| RunError::Cache {
        stage: node.name.clone(),
        source,
    };
    let key = node_key(plan, i, reports);
    let mut note = None;
    if !force {
        match cache.lookup(&key) {
            Lookup::Hit(m) => {
                for r in node.inputs.values() {
                    produced.take(r.node, &r.port);
                }
                let r = StageReport {
                    name: node.name.clone(),
                    kind: kind.into(),
                    key,
                    status: Status::Cached,
                    elapsed: t0.elapsed(),
                    cache_write: None,
                    parts: PartCounts {
                        keys: m.parts.clone(),
                        ..Default::default()
                    },
                    outputs: m.outputs,
                    note: None,
                };
                display.finish(&r);
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
    // A cache that cannot take the entry fails the stage before it runs, not after the run.
    cache.writable().map_err(cache_err)?;
    display.start(&node.name, kind);
    let parts = Arc::new(PartCache::new(cache.clone(), node.format, force));
    let inputs = node_inputs(plan, i, reports, produced, cache, parts.clone())?;
    let outputs = if display.quiet() {
        run_stage(plan, i, inputs)?
    } else {
        let sink = Arc::new(StageSink {
            stage: node.name.clone(),
            display: display.clone(),
        });
        crate::core::progress::scope_with_pool(&node.name, sink, || run_stage(plan, i, inputs))?
    };
    let parts = parts.counts();
    let outputs: BTreeMap<String, Arc<Artefact>> = outputs
        .into_iter()
        .map(|(port, a)| (port, Arc::new(a)))
        .collect();
    let records: BTreeMap<String, OutputRecord> = {
        use rayon::prelude::*;
        outputs
            .par_iter()
            .map(|(port, a)| {
                let record = OutputRecord {
                    kind: a.kind.name().to_string(),
                    digest: a.digest(),
                };
                (port.clone(), record)
            })
            .collect()
    };
    let digested = outputs
        .iter()
        .map(|(port, a)| (port.clone(), a.clone(), records[port].digest.clone()))
        .collect();
    let pending = commit_in_background(plan, i, cache, &key, digested, &parts.keys, force)?;
    commits
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(pending);
    for (port, a) in outputs {
        produced.put(i, port, a);
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
        cache_write: None,
        outputs: records,
        note,
        parts,
    };
    display.finish(&r);
    Ok(r)
}

/// The upstream report and output record that input `port` of node `i` reads.
fn upstream<'r>(
    plan: &Plan,
    i: usize,
    reports: &'r [Option<StageReport>],
    port: &str,
) -> (&'r StageReport, &'r OutputRecord) {
    let r = &plan.nodes[i].inputs[port];
    let rep = reports[r.node].as_ref().expect("waves run upstream first");
    (rep, &rep.outputs[&r.port])
}

/// Node `i`'s cache key: its kind, implementation version, key parameters, format and the
/// digests of its inputs.
fn node_key(plan: &Plan, i: usize, reports: &[Option<StageReport>]) -> String {
    let node = &plan.nodes[i];
    let digests: BTreeMap<String, String> = node
        .inputs
        .keys()
        .map(|p| (p.clone(), upstream(plan, i, reports, p).1.digest.clone()))
        .collect();
    cache_key(
        node.stage.kind(),
        node.stage.impl_version(),
        &node.stage.key_params(&node.params),
        node.format,
        &digests,
    )
}

/// Node `i`'s input artefacts: from this run's memory when produced here, else from the cache.
fn node_inputs(
    plan: &Plan,
    i: usize,
    reports: &[Option<StageReport>],
    produced: &Produced,
    cache: &Cache,
    parts: Arc<PartCache>,
) -> Result<StageInputs, RunError> {
    let node = &plan.nodes[i];
    let cache_err = |source| RunError::Cache {
        stage: node.name.clone(),
        source,
    };
    let mut inputs = StageInputs {
        base_dir: plan.base_dir.clone(),
        parts: Some(parts),
        ..Default::default()
    };
    for (port, r) in &node.inputs {
        inputs.digests.insert(
            port.clone(),
            upstream(plan, i, reports, port).1.digest.clone(),
        );
        let a = match produced.take(r.node, &r.port) {
            Some(a) => a,
            None => {
                let (rep, out) = upstream(plan, i, reports, port);
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
    Ok(inputs)
}

/// Runs node `i`'s stage, a panic reported as its failure, and checks every declared output
/// was produced.
fn run_stage(
    plan: &Plan,
    i: usize,
    inputs: StageInputs,
) -> Result<super::stage::StageOutputs, RunError> {
    let node = &plan.nodes[i];
    let kind = node.stage.kind();
    let outputs = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        node.stage.run_owned(&node.params, inputs)
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
    Ok(outputs)
}

/// Copies every output of the run to `out/<stage>/<port>/` as plain files (see
/// [`materialise_with_lock`]).
pub fn materialise(report: &RunReport, cache: &Cache, out: &Path) -> Result<(), RunError> {
    materialise_with_lock(report, cache, out, None)
}

/// Copies every output of the run to `out/<stage>/<port>/` as plain files, with `lock` as
/// `out/femu.lock.json`.
///
/// `out` must be missing, an empty directory, or an earlier femu output (it holds
/// `femu.lock.json`); it must not be, or hold, a symbolic link: femu never deletes or writes
/// through a link. The new tree is written into a fresh directory beside `out` (names created
/// exclusively, so nothing planted is followed) and swapped in by renames; an earlier output is
/// deleted without following links. When the parent cannot be written, the tree is staged
/// inside `out` and moved into place entry by entry (not atomic then).
pub fn materialise_with_lock(
    report: &RunReport,
    cache: &Cache,
    out: &Path,
    lock: Option<&LockFile>,
) -> Result<(), RunError> {
    materialise_run(report, cache, out, lock, &[])
}

/// [`materialise_with_lock`], with `files` (name, content) written beside the lock file (the
/// run record of `femu run`: statuses, times, warnings — never part of an artefact).
pub fn materialise_run(
    report: &RunReport,
    cache: &Cache,
    out: &Path,
    lock: Option<&LockFile>,
    files: &[(&str, &[u8])],
) -> Result<(), RunError> {
    let out = out_path(out)?;
    let exists = check_out(&out)?;
    let (parent, name) = match (out.parent(), out.file_name()) {
        (Some(p), Some(n)) => (
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            },
            n.to_string_lossy().to_string(),
        ),
        _ => return Err(out_err(&out, "is not a directory femu can replace")),
    };
    if !exists {
        std::fs::create_dir_all(parent).map_err(out_io(parent))?;
    }
    remove_dead_staging(parent, &name);
    let tag = unique_tag();
    let sibling = parent.join(format!(".{name}.femu-staging.{tag}"));
    let (staging, in_place) = match std::fs::create_dir(&sibling) {
        Ok(()) => (sibling, false),
        Err(e)
            if exists
                && matches!(
                    e.kind(),
                    std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
                ) =>
        {
            let inside = out.join(format!(".femu-staging.{tag}"));
            std::fs::create_dir(&inside).map_err(out_io(&inside))?;
            (inside, true)
        }
        Err(e) => return Err(out_io(&sibling)(e)),
    };
    let filled = fill_staging(report, cache, &staging, lock, files);
    let done = filled.and_then(|()| {
        if in_place {
            replace_contents(&out, &staging)
        } else {
            swap_in(&staging, &out, parent, &name, exists)
        }
    });
    if done.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    done
}

/// `<n>.<pid>@<host>`: unique in this process, and tells a dead owner's leftovers (see
/// [`crate::cache::owner`]).
fn unique_tag() -> String {
    static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!(
        "{n}.{}",
        crate::cache::owner::owner_suffix(std::process::id())
    )
}

fn out_err(path: &Path, what: &str) -> RunError {
    RunError::Out {
        path: path.display().to_string(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, what.to_string()),
    }
}

fn out_io(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |source| RunError::Out {
        path: path.display().to_string(),
        source,
    }
}

/// `out` with a last component to rename (`.` and `..` are resolved; they must exist).
fn out_path(out: &Path) -> Result<std::path::PathBuf, RunError> {
    if out.file_name().is_some() {
        return Ok(out.to_path_buf());
    }
    let real = std::fs::canonicalize(out).map_err(out_io(out))?;
    match real.file_name() {
        Some(_) => Ok(real),
        None => Err(out_err(
            out,
            "is the root directory; choose a directory of its own",
        )),
    }
}

/// Whether `out` exists, after checking that femu may replace it.
fn check_out(out: &Path) -> Result<bool, RunError> {
    let meta = match std::fs::symlink_metadata(out) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(out_io(out)(e)),
    };
    if meta.file_type().is_symlink() {
        return Err(out_err(
            out,
            "is a symbolic link; femu writes only into a directory it owns (a new directory, an empty one, or an earlier --out), never through a link",
        ));
    }
    if !meta.is_dir() {
        return Err(out_err(
            out,
            "exists and is not a directory; choose a new or empty directory, or an earlier --out",
        ));
    }
    let mut children = std::fs::read_dir(out).map_err(out_io(out))?;
    if children.next().is_none() {
        return Ok(true);
    }
    let lock = out.join(OUT_LOCK_FILE);
    let is_femu = std::fs::symlink_metadata(&lock).is_ok_and(|m| m.is_file());
    if !is_femu {
        return Err(out_err(
            out,
            "is not empty and holds no femu.lock.json, so it is not an earlier femu output; femu replaces only a new or empty directory or its own earlier output",
        ));
    }
    refuse_links(out)?;
    Ok(true)
}

/// Refuses a tree that holds a symbolic link anywhere: femu writes none, so one was planted.
fn refuse_links(dir: &Path) -> Result<(), RunError> {
    for e in std::fs::read_dir(dir).map_err(out_io(dir))? {
        let path = e.map_err(out_io(dir))?.path();
        let meta = std::fs::symlink_metadata(&path).map_err(out_io(&path))?;
        if meta.file_type().is_symlink() {
            return Err(out_err(
                &path,
                "is a symbolic link inside an earlier femu output; femu writes none, so it refuses to delete or write through it: remove the link, or choose another --out",
            ));
        }
        if meta.is_dir() {
            refuse_links(&path)?;
        }
    }
    Ok(())
}

/// Removes staging and replaced trees that dead processes of this host left beside `out`.
fn remove_dead_staging(parent: &Path, name: &str) {
    let prefixes = [
        format!(".{name}.femu-staging."),
        format!(".{name}.femu-old."),
    ];
    for e in std::fs::read_dir(parent).into_iter().flatten().flatten() {
        let file = e.file_name().to_string_lossy().to_string();
        let ours = prefixes.iter().any(|p| file.starts_with(p.as_str()));
        let dir = std::fs::symlink_metadata(e.path()).is_ok_and(|m| m.is_dir());
        if ours && dir && crate::cache::owner::is_stale(&file) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Creates a directory that must be new (an existing name, link or not, is an error).
fn create_new_dir(path: &Path) -> Result<(), RunError> {
    std::fs::create_dir(path).map_err(out_io(path))
}

/// Creates a file that must be new and writes `from` into it (never through a link).
fn create_new_file(path: &Path, from: &mut dyn std::io::Read) -> Result<(), RunError> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(out_io(path))?;
    std::io::copy(from, &mut f).map_err(out_io(path))?;
    Ok(())
}

fn fill_staging(
    report: &RunReport,
    cache: &Cache,
    staging: &Path,
    lock: Option<&LockFile>,
    files: &[(&str, &[u8])],
) -> Result<(), RunError> {
    let checked =
        |base: &Path, what: &str, name: &str| match crate::cache::names::unsafe_reason(name) {
            None => Ok(base.join(name)),
            Some(why) => Err(out_err(
                base,
                &format!(
                    "{what} `{name}` cannot name a directory here: {why}; a valid name is {}",
                    crate::cache::names::VALID_NAME
                ),
            )),
        };
    for s in &report.stages {
        let stage_dir = checked(staging, "stage", &s.name)?;
        if s.outputs.is_empty() {
            continue;
        }
        create_new_dir(&stage_dir)?;
        for port in s.outputs.keys() {
            let dest = checked(&stage_dir, "output port", port)?;
            create_new_dir(&dest)?;
            let src = cache
                .artefact_dir(&s.key, port)
                .map_err(|e| out_err(&dest, &e.to_string()))?;
            for e in std::fs::read_dir(&src).map_err(out_io(&src))? {
                let e = e.map_err(out_io(&src))?;
                let from = e.path();
                let meta = std::fs::symlink_metadata(&from).map_err(out_io(&from))?;
                if !meta.is_file() {
                    return Err(out_err(
                        &from,
                        "is not a regular file in a cache entry; femu copies only regular files",
                    ));
                }
                let mut f = std::fs::File::open(&from).map_err(out_io(&from))?;
                create_new_file(&dest.join(e.file_name()), &mut f)?;
            }
        }
    }
    if let Some(lock) = lock {
        let text = lock
            .to_text()
            .map_err(out_io(&staging.join(OUT_LOCK_FILE)))?;
        create_new_file(&staging.join(OUT_LOCK_FILE), &mut text.as_bytes())?;
    }
    for (name, mut content) in files.iter().copied() {
        let path = checked(staging, "file", name)?;
        create_new_file(&path, &mut content)?;
    }
    Ok(())
}

/// Renames `staging` to `out`, moving an earlier `out` aside first and deleting it after.
fn swap_in(
    staging: &Path,
    out: &Path,
    parent: &Path,
    name: &str,
    exists: bool,
) -> Result<(), RunError> {
    if !exists {
        return std::fs::rename(staging, out).map_err(out_io(out));
    }
    let old = parent.join(format!(".{name}.femu-old.{}", unique_tag()));
    std::fs::rename(out, &old).map_err(out_io(out))?;
    if let Err(e) = std::fs::rename(staging, out) {
        let _ = std::fs::rename(&old, out);
        return Err(out_io(out)(e));
    }
    // `remove_dir_all` deletes links, never what they point to.
    std::fs::remove_dir_all(&old).map_err(out_io(&old))
}

/// Replaces the contents of `out` by those of `staging` (a directory inside it).
fn replace_contents(out: &Path, staging: &Path) -> Result<(), RunError> {
    let keep = staging.file_name();
    for e in std::fs::read_dir(out).map_err(out_io(out))? {
        let e = e.map_err(out_io(out))?;
        if Some(e.file_name().as_os_str()) == keep {
            continue;
        }
        let path = e.path();
        let meta = std::fs::symlink_metadata(&path).map_err(out_io(&path))?;
        if meta.is_dir() {
            std::fs::remove_dir_all(&path).map_err(out_io(&path))?;
        } else {
            std::fs::remove_file(&path).map_err(out_io(&path))?;
        }
    }
    for e in std::fs::read_dir(staging).map_err(out_io(staging))? {
        let e = e.map_err(out_io(staging))?;
        let to = out.join(e.file_name());
        std::fs::rename(e.path(), &to).map_err(out_io(&to))?;
    }
    std::fs::remove_dir(staging).map_err(out_io(staging))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::progress::Event;

    /// An output is held for exactly its readers: each reader but the last gets a shared
    /// copy, the last takes it out of the run's memory, and an output nobody reads is never
    /// kept. A reader of an output produced elsewhere (the cache) gets nothing.
    #[test]
    fn produced_outputs_are_released_by_their_last_reader() {
        let port = |p: &str| p.to_string();
        let produced = Produced::new([(0, port("model")), (0, port("model")), (1, port("modes"))]);
        produced.put(
            0,
            port("model"),
            Arc::new(Artefact::new(ArtefactKind::Matrices)),
        );
        produced.put(
            2,
            port("unread"),
            Arc::new(Artefact::new(ArtefactKind::Modes)),
        );
        let first = produced
            .take(0, "model")
            .expect("held for its second reader");
        assert_eq!(Arc::strong_count(&first), 2);
        let last = produced.take(0, "model").expect("the last reader gets it");
        drop(first);
        assert_eq!(
            Arc::strong_count(&last),
            1,
            "released from the run's memory"
        );
        assert!(produced.take(0, "model").is_none());
        assert!(
            produced.take(1, "modes").is_none(),
            "not produced in this run"
        );
        assert!(produced.take(2, "unread").is_none(), "never kept");
    }

    /// A writer the test reads back.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl std::io::Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A step without a total shows its count, or only its task when it counts nothing (a
    /// status line ended in a stray " 0").
    #[test]
    fn an_uncounted_step_shows_its_count_or_its_task_alone() {
        let out = Shared::default();
        let plain = PlainLines::new(
            Box::new(out.clone()),
            Box::new(|| Duration::ZERO),
            Duration::ZERO,
        );
        for (task, done) in [
            ("modes: K − σM factorised (8 DOFs, 0.0 s)", 0),
            ("samples", 3),
        ] {
            plain.event(
                "modes",
                Event::Step {
                    task,
                    done,
                    total: 0,
                },
            );
        }
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert_eq!(
            text,
            "[femu] modes: modes: K − σM factorised (8 DOFs, 0.0 s)\n[femu] modes: samples 3\n"
        );
    }

    /// Plain lines keep every start, end and note, and show a stage's steps at most once per
    /// interval of the (here hand-driven) clock, each stage on its own.
    #[test]
    fn plain_lines_are_rate_limited_per_stage() {
        let out = Shared::default();
        let now = Arc::new(Mutex::new(Duration::ZERO));
        let clock = {
            let now = now.clone();
            Box::new(move || *now.lock().unwrap())
        };
        let plain = PlainLines::new(Box::new(out.clone()), clock, Duration::from_secs(1));
        let at = |s: f64| *now.lock().unwrap() = Duration::from_secs_f64(s);
        let step = |stage: &str, done| {
            plain.event(
                stage,
                Event::Step {
                    task: "FRF lines",
                    done,
                    total: 10,
                },
            )
        };
        plain.start("frf", "frf.synthesise");
        step("frf", 0);
        at(0.5);
        step("frf", 4);
        step("other", 1);
        plain.event("frf", Event::Note("iteration 1: mean chi_s 0.9"));
        at(1.0);
        step("frf", 6);
        at(1.9);
        step("frf", 9);
        plain.event(
            "frf",
            Event::Step {
                task: "modes",
                done: 3,
                total: 0,
            },
        );
        at(2.1);
        step("frf", 10);
        plain.finish("frf", "frf (frf.synthesise): ran in 2.100 s");
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert_eq!(
            text,
            "[femu] frf (frf.synthesise): running\n\
             [femu] frf: FRF lines 0/10 (0 %)\n\
             [femu] other: FRF lines 1/10 (10 %)\n\
             [femu] frf: iteration 1: mean chi_s 0.9\n\
             [femu] frf: FRF lines 6/10 (60 %)\n\
             [femu] frf: FRF lines 10/10 (100 %)\n\
             [femu] frf (frf.synthesise): ran in 2.100 s\n"
        );
    }
}
