//! The `femu` command line, one file per command; this module holds the arguments and the
//! dispatch table. `anyhow` lives here only. Exit codes: 0 success (or no difference), 1 failure
//! or difference found, 2 bad input or usage (`error.rs`).

use crate::pipeline::Diagnostics;
use clap::{Parser, Subcommand};
use error::{Failure, error_chain};
use std::path::PathBuf;
use std::process::ExitCode;

mod bench;
mod cache;
mod diff;
mod error;
mod explain;
mod list;
mod load;
mod report;
mod run;
mod schema;
mod show;
mod summary;
mod sweep;
mod validate;

pub use schema::write_schemas;

/// femu: finite-element model updating from measured FRFs, as cached pipelines.
#[derive(Parser, Debug)]
#[command(name = "femu", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args, Debug, Clone)]
struct PipelineArgs {
    /// The pipeline YAML file.
    pipeline: PathBuf,
    /// Override a parameter: STAGE.PARAM=VALUE (VALUE is YAML); repeatable.
    #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
    sets: Vec<String>,
    /// Read files named in the pipeline (`path:`, INCLUDEs) only from the pipeline's own
    /// directory tree (for shared services; by default `../` reads are allowed).
    #[arg(long)]
    confine_reads: bool,
    /// Most bytes read for one imported file with its INCLUDEs (e.g. 4G; default 2G, or
    /// $FEMU_MAX_INPUT_BYTES).
    #[arg(long, value_name = "SIZE")]
    max_input_bytes: Option<String>,
}

#[derive(clap::Args, Debug, Clone)]
struct CacheArgs {
    /// Cache directory (default: $FEMU_CACHE_DIR or .femu/cache).
    #[arg(long, value_name = "DIR")]
    cache_dir: Option<PathBuf>,
}

impl CacheArgs {
    fn dir(&self) -> PathBuf {
        self.cache_dir
            .clone()
            .or_else(|| std::env::var_os("FEMU_CACHE_DIR").map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from(".femu/cache"))
    }
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a pipeline: every stage not already cached.
    Run {
        #[command(flatten)]
        p: PipelineArgs,
        #[command(flatten)]
        c: CacheArgs,
        /// Copy every stage's artefacts to DIR/<stage>/<port>/ and write DIR/femu.lock.json.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Run only this stage and what it needs; repeatable.
        #[arg(long, value_name = "STAGE")]
        only: Vec<String>,
        /// Recompute even cached stages.
        #[arg(long)]
        force: bool,
        /// No progress (bars or lines); the summary and the stages' warnings still print.
        #[arg(long, short)]
        quiet: bool,
        /// Also write the run report, DIR/report.html (needs --out).
        #[arg(long, requires = "out")]
        report: bool,
    },
    /// Check a pipeline without running it.
    Validate {
        #[command(flatten)]
        p: PipelineArgs,
    },
    /// Show the resolved plan: order, wiring, parameters with defaults, cache state.
    Explain {
        #[command(flatten)]
        p: PipelineArgs,
        #[command(flatten)]
        c: CacheArgs,
    },
    /// List stage kinds, or describe one.
    List {
        /// A stage kind to describe in full.
        kind: Option<String>,
    },
    /// Describe an artefact directory (kind, digest, units, tables and a preview), or summarise
    /// a run's --out directory (stages, status, times, key results, warnings).
    Show {
        /// Artefact directory (holding meta.json) or run output (holding femu.lock.json).
        artefact: PathBuf,
        /// Rows of each table to print.
        #[arg(long, default_value_t = 8)]
        rows: usize,
    },
    /// Compare two artefacts, or two directories of artefacts (e.g. two --out trees): a
    /// summary, then each difference with its row named by its key columns.
    Diff {
        /// New artefact or tree.
        a: PathBuf,
        /// Reference artefact or tree.
        b: PathBuf,
        /// Relative tolerance for every number (default: femu's tolerances per artefact kind,
        /// which ignore round-off; printed with the result).
        #[arg(long)]
        rtol: Option<f64>,
        /// Absolute tolerance for every number (with --rtol, default 1e-9 then).
        #[arg(long)]
        atol: Option<f64>,
        /// YAML file of per-column tolerances (overrides --rtol/--atol).
        #[arg(long, value_name = "FILE")]
        tolerances: Option<PathBuf>,
        /// List every differing value (by default at most 5 a column).
        #[arg(long)]
        full: bool,
    },
    /// Write the run report: one self-contained HTML page (graph, FRFs, MAC, history, mesh).
    Report {
        /// A run's output directory (the one `femu run --out DIR` wrote).
        out: PathBuf,
        /// Where to write the page (default OUT/report.html).
        #[arg(long, short, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Inspect or clean the cache.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
    },
    /// Benchmark assembly, factorisation and the lowest modes of a shell plate or the muffler box.
    Bench(BenchArgs),
    /// Run a parameter sweep over a pipeline locally or on Slurm; `status`, `collect`.
    Sweep(Box<sweep::SweepArgs>),
    /// Write the JSON Schemas of pipelines, sweeps and artefacts.
    Schema {
        /// Output directory.
        #[arg(long, default_value = "schemas")]
        out: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
enum CacheAction {
    /// List entries.
    Ls {
        #[command(flatten)]
        c: CacheArgs,
    },
    /// Remove entries no lock file refers to, and stale temporary files.
    Gc {
        #[command(flatten)]
        c: CacheArgs,
        /// Remove every entry.
        #[arg(long)]
        all: bool,
    },
}

#[derive(clap::Args, Debug)]
struct BenchArgs {
    /// Model sizes in DOFs (repeatable); default 10000 and 100000.
    #[arg(long = "dofs", value_name = "N")]
    dofs: Vec<usize>,
    /// Mode counts to time at each size (repeatable); default 50 and 100.
    #[arg(long = "modes", value_name = "M")]
    modes: Vec<usize>,
    /// Write the figures as JSON to this file as well.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Benchmark the muffler-like box (CASES.md C5) instead of the plate.
    #[arg(long)]
    muffler: bool,
    /// Time one P-C iteration on the muffler instead (50 thickness parameters, 10 FRFs,
    /// 1000 lines, a basis of the first `--modes` modes, default 100).
    #[arg(long)]
    pc_iteration: bool,
    /// Benchmark component mode synthesis on the muffler instead: the direct solve of the
    /// lowest `--modes` modes (default 50), then per `--parts` (default 8 and 64) the
    /// Craig-Bampton reduction, the reduced modes and the re-analysis after one
    /// substructure changed.
    #[arg(long)]
    cms: bool,
    /// Substructure counts for `--cms` (repeatable).
    #[arg(long = "parts", value_name = "K")]
    parts: Vec<usize>,
    /// Time the Nastran import instead: the plate of each `--dofs` size (default 100000 and
    /// 1000000) written as a deck and read back.
    #[arg(long)]
    import: bool,
    /// Time the direct FRF instead: the plate of each `--dofs` size (default 3900 at 801
    /// lines and 100000 at 100 lines), 10 responses to one excitation, 0–800 Hz, by `LDLᵀ` per
    /// line and by the plain pivoted LU on a subset of the lines, with the speed-up.
    #[arg(long)]
    frf: bool,
    /// Frequency lines for `--frf` (default: 801 up to 10000 DOFs, 100 above).
    #[arg(long, value_name = "L")]
    lines: Option<usize>,
    /// Run the plate pipeline instead (`mesh.generate` → `assemble` → `modes`, as `femu run`
    /// runs it, on a fresh cache) at each `--dofs` size (default 300000) for the first
    /// `--modes` mode count (default 50), beside the same steps by the kernels.
    #[arg(long)]
    pipeline: bool,
    /// Run a study pipeline (e.g. `pipelines/s123-update.yaml`) through the executor on a
    /// fresh cache at each `--dofs` size (set as `nominal.dofs`, default the pipeline's own):
    /// seconds per stage, peak memory, each update's iterations and component mode synthesis
    /// reuse.
    #[arg(long, value_name = "PIPELINE")]
    study: Option<PathBuf>,
    /// With `--study`: run only these stages and what they need (repeatable).
    #[arg(long = "only", value_name = "STAGE")]
    only: Vec<String>,
    /// With `--study`: further parameter overrides, `STAGE.PARAM=VALUE` (repeatable).
    #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
    set: Vec<String>,
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let filter = tracing_subscriber::EnvFilter::try_from_env("FEMU_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    // Colour only on a terminal: a log redirected to a file gets no escape codes.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr)
        .try_init();
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(code) => ExitCode::from(code),
        Err(f) => {
            if f.error.downcast_ref::<Diagnostics>().is_some() {
                eprintln!("{}", f.error);
            } else {
                eprintln!("error: {}", error_chain(&f.error));
            }
            ExitCode::from(f.code)
        }
    }
}

fn dispatch(cli: Cli) -> Result<u8, Failure> {
    match cli.command {
        Command::Run {
            p,
            c,
            out,
            only,
            force,
            quiet,
            report,
        } => run::run(
            &p,
            &c,
            run::RunFlags {
                out,
                only,
                force,
                quiet,
                report,
            },
        ),
        Command::Report { out, output } => report::run(&out, output.as_deref()),
        Command::Validate { p } => validate::run(&p),
        Command::Explain { p, c } => explain::run(&p, &c),
        Command::List { kind } => list::run(kind.as_deref()),
        Command::Show { artefact, rows } => show::run(&artefact, rows),
        Command::Diff {
            a,
            b,
            rtol,
            atol,
            tolerances,
            full,
        } => diff::run(
            &a,
            &b,
            &diff::DiffTolerances {
                rtol,
                atol,
                file: tolerances,
            },
            full,
        ),
        Command::Cache { action } => cache::run(action),
        Command::Bench(args) => bench::run(args),
        Command::Sweep(args) => sweep::dispatch(*args),
        Command::Schema { out } => schema::run(&out),
    }
}
