//! The `femu` command line. `anyhow` lives here only. Exit codes: 0 success (or no difference),
//! 1 failure or difference found, 2 bad input or usage.

use crate::artefact::codec::{read_dir, read_meta};
use crate::artefact::compare::{Tol, Tolerances, compare};
use crate::artefact::{Artefact, ArtefactKind};
use crate::cache::Cache;
use crate::pipeline::executor::RunError;
use crate::pipeline::lock::LockFile;
use crate::pipeline::schema::{artefact_schema, pipeline_schema};
use crate::pipeline::{
    Diagnostic, Diagnostics, Plan, ProgressMode, RunOptions, SourcedSpec, StageError, Status,
    execute, plan, read_pipeline,
};
use crate::stages::registry;
use anyhow::Context;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod sweep;

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

impl PipelineArgs {
    /// Sets the process-wide policy for reading the files a pipeline names.
    fn set_read_policy(&self) -> Result<(), Diagnostics> {
        use crate::core::input::{InputPolicy, parse_byte_count, set_policy};
        let fail = |m: String| Diagnostics(vec![Diagnostic::new("femu", m)]);
        let mut policy = InputPolicy::from_env().map_err(|e| fail(e.to_string()))?;
        if let Some(text) = &self.max_input_bytes {
            policy.max_bytes = parse_byte_count(text).ok_or_else(|| {
                fail(format!(
                    "--max-input-bytes {text}: give a positive byte count such as 500M or 4G"
                ))
            })?;
        }
        if self.confine_reads {
            let dir = match self.pipeline.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            policy = policy
                .confined_to(&dir)
                .map_err(|e| fail(format!("--confine-reads: {e}")))?;
        }
        set_policy(policy);
        Ok(())
    }
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
        /// No progress lines.
        #[arg(long, short)]
        quiet: bool,
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
    /// Describe an artefact directory: kind, digest, units, tables and a preview.
    Show {
        /// Artefact directory (holding meta.json).
        artefact: PathBuf,
        /// Rows of each table to print.
        #[arg(long, default_value_t = 8)]
        rows: usize,
    },
    /// Compare two artefacts, or two directories of artefacts (e.g. two --out trees).
    Diff {
        /// New artefact or tree.
        a: PathBuf,
        /// Reference artefact or tree.
        b: PathBuf,
        /// Relative tolerance.
        #[arg(long, default_value_t = 1e-9)]
        rtol: f64,
        /// Absolute tolerance.
        #[arg(long, default_value_t = 0.0)]
        atol: f64,
        /// YAML file of per-column tolerances (overrides --rtol/--atol).
        #[arg(long, value_name = "FILE")]
        tolerances: Option<PathBuf>,
    },
    /// Inspect or clean the cache.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
    },
    /// Benchmark assembly, factorisation and the lowest modes of a shell plate or the muffler box.
    Bench {
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
    },
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

/// A failure with its exit code.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        let error = e.into();
        Failure {
            code: exit_code(&error),
            error,
        }
    }
}

impl Failure {
    /// Bad input or usage (exit 2), whatever the error's type.
    fn bad_input(e: impl Into<anyhow::Error>) -> Self {
        Failure {
            code: 2,
            error: e.into(),
        }
    }
}

/// The exit code for an error: 2 when anything in its chain says the user's input is at fault
/// (a located diagnostic, an unknown `--only` stage, a stage's bad input), 1 otherwise.
fn exit_code(error: &anyhow::Error) -> u8 {
    let input = error.chain().any(|cause| {
        cause.downcast_ref::<Diagnostics>().is_some()
            || cause
                .downcast_ref::<StageError>()
                .is_some_and(|e| e.is_input())
            || cause
                .downcast_ref::<RunError>()
                .is_some_and(|e| e.is_input())
    });
    if input { 2 } else { 1 }
}

/// An error and its causes joined by `: `, leaving out a cause whose text the message already
/// holds (errors that print their source themselves would otherwise say it twice).
fn error_chain(error: &anyhow::Error) -> String {
    let mut message = error.to_string();
    for cause in error.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    message
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let filter = tracing_subscriber::EnvFilter::try_from_env("FEMU_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
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

fn load_plan(p: &PipelineArgs) -> Result<Plan, Diagnostics> {
    load_sourced_plan(p).map(|(_, plan)| plan)
}

/// The plan with the file it came from, to locate errors found while running.
fn load_sourced_plan(p: &PipelineArgs) -> Result<(SourcedSpec, Plan), Diagnostics> {
    let file = p.pipeline.display().to_string();
    let cap = |d: Diagnostics| Diagnostics::capped(&file, d.0);
    p.set_read_policy()?;
    let mut src = read_pipeline(&p.pipeline).map_err(cap)?;
    src.apply_overrides(&p.sets).map_err(cap)?;
    let plan = plan(&src, &registry()).map_err(cap)?;
    Ok((src, plan))
}

/// A stage's bad input found while running, located in the pipeline file like the errors
/// `validate` finds (stage, field, line); other run errors unchanged.
fn locate_run_error(src: &SourcedSpec, error: RunError) -> anyhow::Error {
    let RunError::Stage {
        stage,
        source: StageError::Input { field, message, .. },
        ..
    } = &error
    else {
        return error.into();
    };
    let mut path = vec!["stages", stage.as_str()];
    if !field.is_empty() {
        path.push("with");
        path.extend(field.split('.'));
    }
    let pos = src.locator.value(&path);
    let mut d = Diagnostic::new(&src.file, message.clone())
        .at(pos)
        .stage(stage);
    if !field.is_empty() {
        d = d.field(format!("with.{field}"));
    }
    Diagnostics(vec![d]).into()
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
        } => {
            let (src, plan) = load_sourced_plan(&p)?;
            let cache = Cache::open(&c.dir())?;
            let opts = RunOptions {
                force,
                only,
                progress: if quiet {
                    ProgressMode::Quiet
                } else {
                    ProgressMode::Auto
                },
            };
            let report = execute(&plan, &cache, &opts).map_err(|e| locate_run_error(&src, e))?;
            let lock = LockFile::from_run(&plan, &report);
            if opts.only.is_empty() {
                let recorded = lock.record_in(&cache, &plan.name);
                if let Some(warning) = recorded.context("writing the lock file")? {
                    eprintln!("warning: {warning}");
                }
            }
            if let Some(out) = &out {
                crate::pipeline::executor::materialise_with_lock(
                    &report,
                    &cache,
                    out,
                    Some(&lock),
                )?;
            }
            println!(
                "pipeline {}: {} stages, {} ran, {} cached",
                plan.name,
                report.stages.len(),
                report.executed(),
                report
                    .stages
                    .iter()
                    .filter(|s| s.status == Status::Cached)
                    .count()
            );
            println!(
                "{:<20} {:<18} {:<34} {:>9}  outputs",
                "stage", "kind", "status", "time (s)"
            );
            for s in &report.stages {
                let outs: Vec<String> = s
                    .outputs
                    .iter()
                    .map(|(p, r)| format!("{p}={}", &r.digest[..12]))
                    .collect();
                println!(
                    "{:<20} {:<18} {:<34} {:>9.3}  {}",
                    s.name,
                    s.kind,
                    s.status.label(),
                    s.elapsed.as_secs_f64(),
                    outs.join(" ")
                );
            }
            if let Some(out) = out {
                println!("artefacts in {}", out.display());
            }
            Ok(0)
        }
        Command::Validate { p } => {
            let plan = load_plan(&p)?;
            println!(
                "{}: valid pipeline `{}` with {} stages",
                p.pipeline.display(),
                plan.name,
                plan.nodes.len()
            );
            Ok(0)
        }
        Command::Explain { p, c } => {
            let plan = load_plan(&p)?;
            explain(&plan, &c.dir());
            Ok(0)
        }
        Command::List { kind } => list(kind.as_deref()),
        Command::Show { artefact, rows } => {
            if !artefact.join(crate::artefact::codec::META_FILE).is_file() {
                return Err(Failure::bad_input(anyhow::anyhow!(
                    "{} is not a femu artefact: a directory holding meta.json (e.g. out/<stage>/<port>)",
                    artefact.display()
                )));
            }
            show(&artefact, rows)?;
            Ok(0)
        }
        Command::Diff {
            a,
            b,
            rtol,
            atol,
            tolerances,
        } => {
            let tol: Tolerances = match &tolerances {
                Some(f) => {
                    let text =
                        crate::pipeline::spec::read_bounded_text(f, 1 << 20).map_err(|e| {
                            Failure::bad_input(anyhow::anyhow!("reading {}: {e}", f.display()))
                        })?;
                    serde_yaml::from_str(&text)
                        .map_err(|e| Failure::bad_input(anyhow::anyhow!("{}: {e}", f.display())))?
                }
                None => Tolerances {
                    default: Tol {
                        rtol,
                        atol,
                        max: None,
                    },
                    ..Default::default()
                },
            };
            tol.check().map_err(|e| {
                Failure::bad_input(anyhow::anyhow!(
                    "{}{e}",
                    match &tolerances {
                        Some(f) => format!("{}: ", f.display()),
                        None => "--rtol/--atol: ".to_string(),
                    }
                ))
            })?;
            diff(&a, &b, &tol)
        }
        Command::Cache { action } => {
            match action {
                CacheAction::Ls { c } => {
                    let cache = Cache::open(&c.dir())?;
                    let entries = cache.entries()?;
                    let total: u64 = entries.iter().map(|e| e.bytes).sum();
                    for e in &entries {
                        let outs: Vec<String> =
                            e.outputs.iter().map(|(p, k)| format!("{p}:{k}")).collect();
                        println!(
                            "{}  {:<18} {:>10} B  {}",
                            &e.key[..16],
                            e.stage_kind,
                            e.bytes,
                            outs.join(" ")
                        );
                    }
                    println!(
                        "{} entries, {} bytes in {}",
                        entries.len(),
                        total,
                        c.dir().display()
                    );
                }
                CacheAction::Gc { c, all } => {
                    let cache = Cache::open(&c.dir())?;
                    let keep = if all {
                        Default::default()
                    } else {
                        cache.locked_keys()
                    };
                    let (n, bytes) = cache.gc(&keep)?;
                    println!("removed {n} entries ({bytes} bytes); kept {}", keep.len());
                }
            }
            Ok(0)
        }
        Command::Bench {
            dofs,
            modes,
            json,
            cms: true,
            parts,
            ..
        } => {
            let dofs = if dofs.is_empty() { vec![100_000] } else { dofs };
            let parts = if parts.is_empty() { vec![8, 64] } else { parts };
            let count = modes.first().copied().unwrap_or(50);
            let mut all = Vec::new();
            for n in dofs {
                let b =
                    crate::bench::cms_bench(n, &parts, count).map_err(|e| anyhow::anyhow!(e))?;
                println!(
                    "muffler {} DOFs, lowest {} modes: assembly {:.2} s, direct eigen {:.2} s (peak {:.0} MiB); Craig-Bampton, component and interface modes to {:.0} Hz",
                    b.dofs,
                    b.modes,
                    b.assembly_seconds,
                    b.direct_seconds,
                    b.direct_peak_rss_mib.unwrap_or(f64::NAN),
                    b.component_cut_off_hz
                );
                println!(
                    "{:>6} {:>9} {:>10} {:>12} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>11} {:>8} {:>9}",
                    "parts",
                    "junction",
                    "max part",
                    "iface+modal",
                    "partition",
                    "condense",
                    "interface",
                    "reduce",
                    "modes",
                    "max err",
                    "re-analyse",
                    "speed-up",
                    "peak MiB"
                );
                for s in &b.splits {
                    println!(
                        "{:>6} {:>9} {:>10} {:>12} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>10.1e} {:>11.2} {:>7.1}x {:>9.0}",
                        s.parts,
                        s.junction_dofs,
                        s.largest_part_dofs,
                        format!(
                            "{}+{}",
                            s.interface_modes,
                            s.reduced_size.1 - s.interface_modes
                        ),
                        s.partition_seconds,
                        s.condensation_seconds,
                        s.interface_seconds,
                        s.reduce_seconds,
                        s.reduced_modes_seconds,
                        s.max_eigenvalue_error,
                        s.reanalysis_seconds,
                        s.speed_up,
                        s.peak_rss_mib.unwrap_or(f64::NAN)
                    );
                }
                all.push(b);
            }
            if let Some(path) = json {
                std::fs::write(&path, serde_json::to_string_pretty(&all)?)?;
            }
            Ok(0)
        }
        Command::Bench {
            dofs,
            modes,
            json,
            pc_iteration: true,
            ..
        } => {
            let dofs = if dofs.is_empty() { vec![100_000] } else { dofs };
            let basis = modes.first().copied().unwrap_or(100);
            let mut all = Vec::new();
            for n in dofs {
                let b = crate::bench::pc_iteration_bench(n, 50, 10, 1000, basis)
                    .map_err(|e| anyhow::anyhow!(e))?;
                println!(
                    "P-C iteration, muffler {} DOFs, {} parameters, {} FRFs, {} lines, {} modes:\n  assembly + derivatives {:.2} s, eigen {:.2} s (factor {:.1} s, {} solves {:.1} s, orthogonalisation {:.1} s, M products {:.1} s, refinement {:.1} s),\n  projections {:.2} s, static correction {:.2} s ({}),\n  prediction {:.3} s, sensitivity sweep {:.3} s ({:.0} GFLOP/s direct-sum equivalent), solve {:.3} s;\n  iteration {:.2} s, peak memory {:.0} MiB",
                    b.dofs,
                    b.parameters,
                    b.frfs,
                    b.lines,
                    b.modes,
                    b.assembly_seconds,
                    b.eigen_seconds,
                    b.eigen.factor_seconds,
                    b.eigen.solves,
                    b.eigen.solve_seconds,
                    b.eigen.orthogonalisation_seconds,
                    b.eigen.mass_product_seconds,
                    b.eigen.refinement_seconds,
                    b.projection_seconds,
                    b.static_correction_seconds,
                    match b.static_shift_steps {
                        Some(k) => format!("the eigensolver's factor, {k} shift steps"),
                        None => "a second factorisation".to_string(),
                    },
                    b.prediction_seconds,
                    b.sweep_seconds,
                    b.sweep_gflops,
                    b.solve_seconds,
                    b.iteration_seconds,
                    b.peak_rss_mib.unwrap_or(f64::NAN)
                );
                all.push(b);
            }
            if let Some(path) = json {
                std::fs::write(&path, serde_json::to_string_pretty(&all)?)?;
            }
            Ok(0)
        }
        Command::Bench {
            dofs,
            modes,
            json,
            muffler,
            ..
        } => {
            let which = if muffler {
                crate::bench::BenchModel::Muffler
            } else {
                crate::bench::BenchModel::Plate
            };
            let dofs = if dofs.is_empty() {
                vec![10_000, 100_000]
            } else {
                dofs
            };
            let modes = if modes.is_empty() {
                vec![50, 100]
            } else {
                modes
            };
            let threads = rayon::current_num_threads();
            println!(
                "{}, four-node shells, {threads} threads",
                if muffler {
                    "free-free muffler-like box"
                } else {
                    "clamped steel plate"
                }
            );
            println!(
                "{:>9} {:>11} {:>9} {:>9} {:>6} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>12} {:>10}",
                "dofs",
                "nnz(K)",
                "assemble",
                "peak MiB",
                "modes",
                "total",
                "factor",
                "solves",
                "orthog",
                "M*x",
                "refine",
                "nnz(L)",
                "peak MiB"
            );
            let mut all = Vec::new();
            for n in dofs {
                let b =
                    crate::bench::model_bench(which, n, &modes).map_err(|e| anyhow::anyhow!(e))?;
                for m in &b.modes {
                    println!(
                        "{:>9} {:>11} {:>9.2} {:>9.0} {:>6} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>12} {:>10.0}",
                        b.dofs,
                        b.nnz,
                        b.assembly_seconds,
                        b.peak_rss_mib.unwrap_or(f64::NAN),
                        m.count,
                        m.seconds,
                        m.info.factor_seconds,
                        m.info.solve_seconds,
                        m.info.orthogonalisation_seconds,
                        m.info.mass_product_seconds,
                        m.info.refinement_seconds,
                        m.info.factor.factor_entries,
                        m.peak_rss_mib.unwrap_or(f64::NAN)
                    );
                }
                all.push(b);
            }
            if let Some(f) = json {
                std::fs::write(&f, serde_json::to_string_pretty(&all)?)?;
            }
            Ok(0)
        }
        Command::Sweep(args) => sweep::dispatch(*args),
        Command::Schema { out } => {
            write_schemas(&out)?;
            println!("schemas written to {}", out.display());
            Ok(0)
        }
    }
}

/// Writes `pipeline.schema.json`, `sweep.schema.json` and `artefacts/<kind>.schema.json` under `out`.
pub fn write_schemas(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out.join("artefacts"))?;
    let text = serde_json::to_string_pretty(&pipeline_schema(&registry()))? + "\n";
    std::fs::write(out.join("pipeline.schema.json"), text)?;
    let text = serde_json::to_string_pretty(&crate::sweep::schema::sweep_schema())? + "\n";
    std::fs::write(out.join("sweep.schema.json"), text)?;
    for kind in ArtefactKind::ALL {
        let text = serde_json::to_string_pretty(&artefact_schema(kind))? + "\n";
        std::fs::write(
            out.join("artefacts")
                .join(format!("{}.schema.json", kind.name())),
            text,
        )?;
    }
    Ok(())
}

fn explain(plan: &Plan, cache_dir: &Path) {
    println!("pipeline `{}`: {}", plan.name, plan.description.trim());
    let cache = Cache::open(cache_dir).ok();
    for (i, n) in plan.nodes.iter().enumerate() {
        println!(
            "\n{}. {} ({}) — {}",
            i + 1,
            n.name,
            n.stage.kind(),
            n.stage.summary()
        );
        if !n.description.is_empty() {
            println!("   {}", n.description.trim());
        }
        for (port, r) in &n.inputs {
            println!("   in  {port} <- {}.{}", plan.nodes[r.node].name, r.port);
        }
        for p in n.stage.outputs() {
            println!("   out {} ({})", p.name, p.kind);
        }
        let params = serde_yaml::to_string(&n.params).unwrap_or_default();
        for line in params.lines() {
            println!("   | {line}");
        }
        if let Some(lock) = cache
            .as_ref()
            .and_then(|c| c.lock_path(&plan.name).ok())
            .and_then(|p| std::fs::read_to_string(p).ok())
        {
            if let Ok(lock) = serde_json::from_str::<LockFile>(&lock) {
                if let Some(s) = lock.stages.get(&n.name) {
                    println!(
                        "   last run: key {} (params {})",
                        &s.key[..16],
                        if s.params == n.params {
                            "unchanged"
                        } else {
                            "changed since"
                        }
                    );
                }
            }
        }
    }
}

fn list(kind: Option<&str>) -> Result<u8, Failure> {
    let reg = registry();
    match kind {
        None => {
            for s in reg.all() {
                println!("{:<18} {}", s.kind(), s.summary());
            }
            Ok(0)
        }
        Some(k) => {
            let Some(s) = reg.get(k) else {
                let names: Vec<&str> = reg.all().iter().map(|s| s.kind()).collect();
                return Err(Failure {
                    code: 2,
                    error: anyhow::anyhow!("unknown stage kind `{k}`; kinds: {}", names.join(", ")),
                });
            };
            println!(
                "{} (impl version {}): {}",
                s.kind(),
                s.impl_version(),
                s.summary()
            );
            for p in s.inputs() {
                println!(
                    "  input  {:<12} {:<12} {}{}",
                    p.name,
                    p.kind.name(),
                    p.doc,
                    if p.required { " (required)" } else { "" }
                );
            }
            for p in s.outputs() {
                println!("  output {:<12} {:<12} {}", p.name, p.kind.name(), p.doc);
            }
            println!("  parameters (JSON Schema):");
            let schema = serde_json::to_string_pretty(&s.params_schema()).unwrap_or_default();
            for line in schema.lines() {
                println!("    {line}");
            }
            Ok(0)
        }
    }
}

fn show(dir: &Path, rows: usize) -> anyhow::Result<()> {
    let meta = read_meta(dir)?;
    let a = read_dir(dir)?;
    let digest = a.digest();
    println!(
        "{}: `{}` artefact, schema version {}, format {:?}",
        dir.display(),
        a.kind,
        a.kind.schema_version(),
        meta.format
    );
    println!(
        "digest {} ({})",
        digest,
        if digest == meta.digest {
            "verified"
        } else {
            "DOES NOT MATCH meta.json: the files were changed"
        }
    );
    if let Some(p) = meta.raw.get("producer") {
        println!("made by {p}");
    }
    println!(
        "meta: {}",
        serde_json::to_string_pretty(&serde_json::Value::Object(a.meta.clone()))?
    );
    let units = a.meta.get("units").and_then(|u| u.as_object());
    for (name, (t, storage)) in &a.tables {
        println!("\ntable `{name}` ({storage:?}, {} rows)", t.rows());
        for (c, col) in &t.columns {
            let unit = units
                .and_then(|u| u.get(c))
                .and_then(|u| u.as_str())
                .map(|u| format!(" [{u}]"))
                .unwrap_or_default();
            println!("  {c}: {}{unit}", col.type_name());
        }
        print!("{}", t.preview(rows));
    }
    for (name, bytes) in &a.blobs {
        println!("\nfile `{name}` ({} bytes)", bytes.len());
    }
    Ok(())
}

/// Artefact directories below `root`, by relative path.
fn artefact_dirs(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(d) = todo.pop() {
        if d.join(crate::artefact::codec::META_FILE).is_file() {
            out.push(d.strip_prefix(root).unwrap_or(&d).to_path_buf());
            continue;
        }
        if let Ok(rd) = std::fs::read_dir(&d) {
            todo.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
        }
    }
    out.sort();
    out
}

fn diff(a: &Path, b: &Path, tol: &Tolerances) -> Result<u8, Failure> {
    let read = |p: &Path| -> Result<Artefact, Failure> {
        read_dir(p).map_err(|e| Failure {
            code: 2,
            error: e.into(),
        })
    };
    for p in [a, b] {
        if !p.exists() {
            return Err(Failure {
                code: 2,
                error: anyhow::anyhow!("{} does not exist", p.display()),
            });
        }
    }
    let (da, db) = (artefact_dirs(a), artefact_dirs(b));
    if da.is_empty() || db.is_empty() {
        return Err(Failure {
            code: 2,
            error: anyhow::anyhow!(
                "no femu artefact (a directory with meta.json) under {}",
                if da.is_empty() { a } else { b }.display()
            ),
        });
    }
    let mut different = 0;
    let all: std::collections::BTreeSet<&PathBuf> = da.iter().chain(&db).collect();
    for rel in all {
        let label = if rel.as_os_str().is_empty() {
            ".".to_string()
        } else {
            rel.display().to_string()
        };
        match (da.contains(rel), db.contains(rel)) {
            (true, true) => {
                let c = compare(&read(&a.join(rel))?, &read(&b.join(rel))?, tol);
                if c.same() {
                    println!("same      {label}");
                } else {
                    different += 1;
                    println!("DIFFERENT {label}: {} values", c.count);
                    for d in &c.differences {
                        println!("    {}: {}", d.location, d.detail);
                    }
                }
            }
            (true, false) => {
                different += 1;
                println!("ONLY IN   {}: {label}", a.display());
            }
            _ => {
                different += 1;
                println!("ONLY IN   {}: {label}", b.display());
            }
        }
    }
    Ok(if different == 0 { 0 } else { 1 })
}
