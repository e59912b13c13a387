//! Progress of long computations, for whoever runs them to show.
//!
//! The numerics report what they are doing — a factorisation done, Lanczos blocks, FRF lines,
//! iterations — through the free functions here, and never learn who listens. Whoever runs them
//! (the pipeline executor, for one stage) installs a [`Sink`] on its thread with [`scope`]; with
//! none installed every call is a cheap no-op, so library users, tests and benchmarks see
//! nothing. Progress never reaches an artefact.
//!
//! Why an ambient sink rather than a `&dyn Progress` argument: the kernels' signatures stay as
//! they are (callers in every layer, tests and benchmarks would otherwise pass a no-op), a stage
//! needs no plumbing to have its numerics report, and stages that run side by side in one wave
//! each have their own thread and so their own sink. Work fanned out with rayon captures a
//! [`Task`] on the calling thread and advances it from the workers (a `Task` is `Send + Sync`).
//! A computation that itself reports (an eigensolve inside a substructure's reduction) and runs
//! on a rayon worker takes the caller's sink along: [`carry`] on the calling thread, then
//! [`Carry::run`] around each job. `run` installs exactly the carried sink (or none) for the
//! job and restores the worker's own afterwards, so a worker that steals another stage's job
//! while it waits reports that job to that stage, never lines of two stages mixed in one.
//!
//! Carrying is opt-in, and a job that does not carry, run on a worker that is inside another
//! stage's carried job (stolen while that job waits in a `join`), would report to the wrong
//! stage. The executor therefore runs each stage in [`scope_with_pool`]: a rayon pool of the
//! stage's own whose workers all have the stage's sink installed, so every job of the stage
//! reports to it, carried or not, and no worker ever runs another stage's job.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// One thing a computation reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event<'a> {
    /// `done` of `total` units of the named task (`total` 0: unknown). Transient: a display
    /// shows the latest and may skip some.
    Step {
        /// What is being done (`FRF lines`, `Lanczos vectors`).
        task: &'a str,
        /// Units done.
        done: u64,
        /// Units in all (0 when unknown).
        total: u64,
    },
    /// A line worth keeping, such as an iteration's summary.
    Note(&'a str),
}

/// Receives the events of the computations running on the threads it was installed on.
pub trait Sink: Send + Sync {
    /// Handles one event; must be cheap (it is called from inner loops, rate-limit inside).
    fn event(&self, event: Event<'_>);
}

thread_local! {
    static CURRENT: RefCell<Option<Arc<dyn Sink>>> = const { RefCell::new(None) };
}

/// Restores the previous sink when a [`scope`] ends, also by a panic.
struct Restore(Option<Arc<dyn Sink>>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        CURRENT.with(|c| *c.borrow_mut() = previous);
    }
}

/// Runs `f` with `sink` receiving the progress reported on this thread.
pub fn scope<R>(sink: Arc<dyn Sink>, f: impl FnOnce() -> R) -> R {
    installed(Some(sink), f)
}

/// Runs `f` with `sink` receiving the progress reported on this thread and on every rayon job
/// `f` spawns: `f` runs in a rayon pool of its own (as many threads as the pool the caller
/// would use) whose workers have `sink` installed for their whole life, so jobs that do not
/// [`carry`] report to `sink` too, and the pool's workers run no one else's jobs. When the
/// pool cannot be built (the system refuses threads), `f` runs as [`scope`] would, on the
/// caller's pool. `name` labels the workers (`femu-<name>-<i>`) for profilers and debuggers.
pub fn scope_with_pool<R: Send>(
    name: &str,
    sink: Arc<dyn Sink>,
    f: impl FnOnce() -> R + Send,
) -> R {
    let worker_sink = sink.clone();
    let label = name.to_string();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(move |i| format!("femu-{label}-{i}"))
        .start_handler(move |_| {
            let s = worker_sink.clone();
            CURRENT.with(|c| *c.borrow_mut() = Some(s));
        })
        .build();
    match pool {
        Ok(pool) => pool.install(|| scope(sink, f)),
        Err(_) => scope(sink, f),
    }
}

/// Runs `f` with exactly `sink` (or none) installed on this thread, restoring the previous one.
fn installed<R>(sink: Option<Arc<dyn Sink>>, f: impl FnOnce() -> R) -> R {
    let previous = CURRENT.with(|c| std::mem::replace(&mut *c.borrow_mut(), sink));
    let _restore = Restore(previous);
    f()
}

/// This thread's sink, captured to be installed around jobs on other threads (rayon workers).
#[derive(Clone, Default)]
pub struct Carry(Option<Arc<dyn Sink>>);

/// Captures the sink installed on this thread (none: jobs run with it report nothing).
pub fn carry() -> Carry {
    Carry(current())
}

impl Carry {
    /// Runs `f` on the current thread with the carried sink installed (or none, when nothing
    /// was carried), whatever sink the thread had, and restores that one afterwards.
    pub fn run<R>(&self, f: impl FnOnce() -> R) -> R {
        installed(self.0.clone(), f)
    }
}

/// The sink installed on this thread, if any.
pub fn current() -> Option<Arc<dyn Sink>> {
    CURRENT.with(|c| c.borrow().clone())
}

/// Reports `done` of `total` units of `task` (the label is built only when someone listens).
pub fn step(task: impl FnOnce() -> String, done: u64, total: u64) {
    if let Some(s) = current() {
        s.event(Event::Step {
            task: &task(),
            done,
            total,
        });
    }
}

/// Reports a line worth keeping (built only when someone listens).
pub fn note(line: impl FnOnce() -> String) {
    if let Some(s) = current() {
        s.event(Event::Note(&line()));
    }
}

/// A count of units that may be advanced from any thread, e.g. from a rayon loop: created on
/// the thread that owns the sink, it reports to that sink wherever it is advanced.
pub struct Task {
    sink: Option<Arc<dyn Sink>>,
    label: String,
    total: u64,
    done: AtomicU64,
}

/// Starts a task of `total` units reporting to this thread's sink (the label is built only when
/// someone listens); reports 0 done.
pub fn task(label: impl FnOnce() -> String, total: u64) -> Task {
    let sink = current();
    let label = if sink.is_some() {
        label()
    } else {
        String::new()
    };
    let t = Task {
        sink,
        label,
        total,
        done: AtomicU64::new(0),
    };
    t.report(0);
    t
}

/// [`task`] when `long` holds, else a task that reports nothing (for work that is only
/// sometimes worth showing, e.g. a modal FRF sweep over many lines and modes).
pub fn task_when(long: bool, label: impl FnOnce() -> String, total: u64) -> Task {
    if long {
        task(label, total)
    } else {
        Task {
            sink: None,
            label: String::new(),
            total,
            done: AtomicU64::new(0),
        }
    }
}

impl Task {
    /// Counts `n` more units done.
    pub fn advance(&self, n: u64) {
        if self.sink.is_some() {
            let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
            self.report(done);
        }
    }

    fn report(&self, done: u64) {
        if let Some(s) = &self.sink {
            s.event(Event::Step {
                task: &self.label,
                done,
                total: self.total,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Record(Mutex<Vec<String>>);

    impl Sink for Record {
        fn event(&self, event: Event<'_>) {
            let line = match event {
                Event::Step { task, done, total } => format!("{task} {done}/{total}"),
                Event::Note(n) => n.to_string(),
            };
            self.0.lock().unwrap().push(line);
        }
    }

    #[test]
    fn events_reach_the_scoped_sink_only() {
        let record = Arc::new(Record::default());
        note(|| "unseen".into());
        scope(record.clone(), || {
            step(|| "lines".into(), 1, 4);
            let t = task(|| "blocks".into(), 3);
            std::thread::scope(|s| {
                s.spawn(|| t.advance(2));
            });
            t.advance(1);
            note(|| "iteration 1".into());
            // Another thread has no sink of its own.
            std::thread::scope(|s| {
                s.spawn(|| note(|| "elsewhere".into()));
            });
        });
        note(|| "after".into());
        assert!(current().is_none());
        let got = record.0.lock().unwrap().clone();
        assert_eq!(
            got,
            [
                "lines 1/4",
                "blocks 0/3",
                "blocks 2/3",
                "blocks 3/3",
                "iteration 1"
            ]
        );
    }

    /// Two "stages" on their own threads fan out on the shared rayon pool: every job's notes
    /// reach its own stage's sink, none is lost and none lands in the other's.
    #[test]
    fn carried_sinks_reach_rayon_workers_without_mixing() {
        use rayon::prelude::*;
        let stage = |name: &'static str| {
            let record = Arc::new(Record::default());
            let r = record.clone();
            let handle = std::thread::spawn(move || {
                scope(r, || {
                    let carried = carry();
                    (0..64u32).into_par_iter().for_each(|k| {
                        carried.run(|| {
                            // A nested fan-out carries again.
                            let inner = carry();
                            rayon::join(
                                || inner.run(|| note(|| format!("{name} {k} a"))),
                                || inner.run(|| note(|| format!("{name} {k} b"))),
                            );
                        })
                    });
                })
            });
            (record, handle)
        };
        let (a, ha) = stage("A");
        let (b, hb) = stage("B");
        ha.join().unwrap();
        hb.join().unwrap();
        for (record, name) in [(a, "A"), (b, "B")] {
            let mut got = record.0.lock().unwrap().clone();
            got.sort();
            let mut want: Vec<String> = (0..64)
                .flat_map(|k| [format!("{name} {k} a"), format!("{name} {k} b")])
                .collect();
            want.sort();
            assert_eq!(got, want);
        }
        // A carried "none" clears a worker's sink for the job.
        let outer = Arc::new(Record::default());
        let nothing = carry();
        scope(outer.clone(), || nothing.run(|| note(|| "hidden".into())));
        assert!(outer.0.lock().unwrap().is_empty());
    }

    /// Two "stages" each in a pool of their own fan out with jobs that do not carry: every
    /// job reports to its own stage (on the shared pool without carrying they would report
    /// nowhere, or to a stage whose carried job a worker was inside), and nothing leaks out.
    #[test]
    fn pooled_stages_receive_their_uncarried_jobs() {
        use rayon::prelude::*;
        let stage = |name: &'static str| {
            let record = Arc::new(Record::default());
            let r = record.clone();
            let handle = std::thread::spawn(move || {
                scope_with_pool(name, r, || {
                    let t = task(|| format!("{name} jobs"), 64);
                    (0..64u32).into_par_iter().for_each(|k| {
                        rayon::join(
                            || note(|| format!("{name} {k} a")),
                            || note(|| format!("{name} {k} b")),
                        );
                        t.advance(1);
                    });
                    // The workers' names say whose they are.
                    let names: Vec<String> = (0..4u32)
                        .into_par_iter()
                        .map(|_| std::thread::current().name().unwrap_or("").to_string())
                        .collect();
                    assert!(
                        names
                            .iter()
                            .all(|n| n.starts_with(&format!("femu-{name}-")))
                    );
                })
            });
            (record, handle)
        };
        let (a, ha) = stage("A");
        let (b, hb) = stage("B");
        ha.join().unwrap();
        hb.join().unwrap();
        for (record, name) in [(a, "A"), (b, "B")] {
            let got = record.0.lock().unwrap().clone();
            let mut notes: Vec<&String> = got.iter().filter(|l| !l.contains("jobs")).collect();
            notes.sort();
            let mut want: Vec<String> = (0..64)
                .flat_map(|k| [format!("{name} {k} a"), format!("{name} {k} b")])
                .collect();
            want.sort();
            assert_eq!(notes, want.iter().collect::<Vec<_>>());
            let steps = got.iter().filter(|l| l.contains("jobs")).count();
            assert_eq!(steps, 65, "task 0/64 and 64 advances of {name}");
        }
        assert!(current().is_none());
    }

    #[test]
    fn a_panic_restores_the_previous_sink() {
        let outer = Arc::new(Record::default());
        scope(outer.clone(), || {
            let inner = Arc::new(Record::default());
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                scope(inner, || panic!("inside"))
            }));
            assert!(r.is_err());
            note(|| "outer again".into());
        });
        assert_eq!(outer.0.lock().unwrap().as_slice(), ["outer again"]);
    }
}
