//! The `posterior` kind: the Laplace posterior of an update's parameters (docs/theory.md §12)
//! as tables a user can plot without femu.
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `parameters` | `parameter, updated, mean, sd, lower, upper, relative_sd` |
//! | `covariance` | `parameter_i, parameter_j, covariance, correlation` |
//! | `directions` | `direction, sd_relative, parameter, component` |
//! | `noise` | `group, sigma` |
//! | `samples` | `sample, parameter, value` |
//! | `natural_frequencies` (optional) | `mode, freq_hz, sd_linear_hz, sd_sampled_hz` |
//! | `frf_band` (optional) | `freq_hz, pair, abs, sd_linear, sd_sampled` |
//! | `tmcmc_stages` (optional, `bayes.tmcmc`) | `stage, exponent, log_evidence, acceptance, distinct` |
//! | `mcmc_chains` (optional, `posterior.mala`) | `chain, step, acceptance, failed` |
//! | `mcmc_parameters` (optional, `posterior.mala`) | `parameter, r_hat, ess` |
//!
//! An update's posterior with FRF bands over two lines or more also carries the figure
//! `frf_band` (the predicted `|H|` with its band and the measurement). TMCMC posteriors carry `log_evidence` in the metadata,
//! MALA ones `sampler: mala`; figures (`marginals`, `pairs`)
//! are stored as `<name>.png` and `<name>.svg` blobs.

use super::{
    Kind, Layout, TableLayout, col, expect_kind, meta, meta_opt, meta_value, optional_meta, table,
};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::updating::mala::ChainReport;
use crate::updating::posterior::{Band, Direction, Marginal, Posterior, Refinement};
use crate::updating::tmcmc::TmcmcStage;

const K: ArtefactKind = ArtefactKind::Posterior;

/// A posterior as stored: the numbers and what they were computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct PosteriorRecord {
    /// The updating method whose result it refines (`pc`, `rfm`, …).
    pub method: String,
    /// The likelihood: `frf_modal`, `frf_direct`, `frf_damping` or `natural_frequencies`.
    pub likelihood: String,
    /// The noise model as the user gave it (`estimated`, `sigma`, `relative`, `snr_db`).
    pub noise: String,
    /// The posterior.
    pub posterior: Posterior,
    /// What a sampler adds (`bayes.tmcmc`); `None` for the Laplace posterior.
    pub sampling: Option<Sampling>,
    /// The Markov chains of a gradient-based sampler (`update`'s `posterior.mala`).
    pub mcmc: Option<Mcmc>,
}

/// The chains of a MALA posterior and their diagnostics.
#[derive(Clone, Debug, PartialEq)]
pub struct Mcmc {
    /// The sampler: `mala`.
    pub sampler: String,
    /// Every chain's step, acceptance and failed proposals.
    pub chains: Vec<ChainReport>,
    /// Split `R̂` per parameter.
    pub r_hat: Vec<f64>,
    /// Effective sample size per parameter.
    pub ess: Vec<f64>,
}

/// The evidence and the tempering stages of a TMCMC posterior.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampling {
    /// `ln p(y)`.
    pub log_evidence: f64,
    /// The stages in order.
    pub stages: Vec<TmcmcStage>,
}

/// The `posterior` kind.
pub struct PosteriorKind;

impl Kind for PosteriorKind {
    const KIND: ArtefactKind = K;
    const NAME: &'static str = "posterior";
    type Value = PosteriorRecord;

    fn layout() -> Layout {
        Layout {
            tables: tables(),
            meta: vec![
                meta(
                    "method",
                    "the updating method whose result the posterior refines",
                ),
                meta(
                    "likelihood",
                    "frf_modal, frf_direct, frf_damping or natural_frequencies",
                ),
                meta(
                    "noise",
                    "the noise model: estimated, sigma, relative or snr_db",
                ),
                meta(
                    "sigma_estimated",
                    "whether the noise sigma was estimated from the residuals at the mode",
                ),
                meta(
                    "credible_level",
                    "probability of the central credible intervals",
                ),
                meta(
                    "rows",
                    "data in the likelihood (real and imaginary parts count apart)",
                ),
                meta(
                    "neg_log_likelihood",
                    "-log p(y|mode) with the noise as used",
                ),
                meta(
                    "refine_steps",
                    "Gauss-Newton steps from the update's result to the mode",
                ),
                meta("refine_converged", "whether the refinement converged"),
                meta("objective_start", "Q at the update's result"),
                meta("objective_mode", "Q at the mode"),
                meta("samples", "parameter samples drawn"),
                meta(
                    "predictive_samples",
                    "samples evaluated through the model for the sampled bands",
                ),
                meta("seed", "seed of the samples"),
                meta(
                    "unidentified",
                    "parameters with an infinite standard deviation (in an unidentified direction)",
                ),
                meta_opt(
                    "log_evidence",
                    "ln p(y), the log model evidence (sampled posteriors)",
                ),
                meta_opt(
                    "sampler",
                    "the Markov-chain sampler that drew the samples (mala)",
                ),
                meta_opt(
                    "posterior_warnings",
                    "what the user should know about the posterior (e.g. a noise estimated at round-off)",
                ),
            ],
            blobs: vec!["{name}.png", "{name}.svg"],
        }
    }

    fn to_artefact(r: &PosteriorRecord) -> Artefact {
        write(r)
    }

    fn from_artefact(a: &Artefact) -> Result<PosteriorRecord, ArtefactError> {
        read(a)
    }
}

fn tables() -> Vec<TableLayout> {
    let s = Storage::Parquet;
    vec![
        table(
            "parameters",
            s,
            true,
            vec![
                col("parameter", "string", "", "parameter name"),
                col("updated", "float64", "SI", "the update's result"),
                col(
                    "mean",
                    "float64",
                    "SI",
                    "posterior mean (the likelihood's mode)",
                ),
                col(
                    "sd",
                    "float64",
                    "SI",
                    "posterior standard deviation (inf: unidentified)",
                ),
                col(
                    "lower",
                    "float64",
                    "SI",
                    "lower end of the central credible interval",
                ),
                col(
                    "upper",
                    "float64",
                    "SI",
                    "upper end of the central credible interval",
                ),
                col("relative_sd", "float64", "", "sd / |mean|"),
            ],
        ),
        table(
            "covariance",
            s,
            true,
            vec![
                col("parameter_i", "string", "", "row parameter"),
                col("parameter_j", "string", "", "column parameter"),
                col("covariance", "float64", "SI^2", "posterior covariance"),
                col(
                    "correlation",
                    "float64",
                    "",
                    "rho_ij over every direction above round-off, ridges included (NaN for a parameter the data do not see)",
                ),
            ],
        ),
        table(
            "directions",
            s,
            true,
            vec![
                col("direction", "int64", "", "1 = largest variance"),
                col(
                    "sd_relative",
                    "float64",
                    "",
                    "standard deviation along it, relative (inf: unidentified)",
                ),
                col("parameter", "string", "", "parameter"),
                col(
                    "component",
                    "float64",
                    "",
                    "component of the unit direction (unity coordinates)",
                ),
            ],
        ),
        table(
            "noise",
            s,
            true,
            vec![
                col(
                    "group",
                    "string",
                    "",
                    "noise group: an FRF (response/excitation) or a mode",
                ),
                col(
                    "sigma",
                    "float64",
                    "",
                    "standard deviation of each real and imaginary part (FRF units), or relative frequency error",
                ),
            ],
        ),
        samples_layout(),
        table(
            "natural_frequencies",
            s,
            false,
            vec![
                col("mode", "int64", "", "1-based elastic mode"),
                col("freq_hz", "float64", "Hz", "natural frequency at the mode"),
                col(
                    "sd_linear_hz",
                    "float64",
                    "Hz",
                    "first-order standard deviation",
                ),
                col(
                    "sd_sampled_hz",
                    "float64",
                    "Hz",
                    "standard deviation over the samples",
                ),
            ],
        ),
        table(
            "frf_band",
            s,
            false,
            vec![
                col("freq_hz", "float64", "Hz", "line"),
                col("pair", "string", "", "response/excitation"),
                col(
                    "abs",
                    "float64",
                    "",
                    "|H| at the mode, in the measured quantity",
                ),
                col(
                    "sd_linear",
                    "float64",
                    "",
                    "first-order standard deviation of |H|",
                ),
                col(
                    "sd_sampled",
                    "float64",
                    "",
                    "standard deviation of |H| over the samples",
                ),
            ],
        ),
        stages_layout(),
        table(
            "mcmc_chains",
            s,
            false,
            vec![
                col("chain", "int64", "", "0-based chain"),
                col("step", "float64", "", "step epsilon after the warm-up"),
                col(
                    "acceptance",
                    "float64",
                    "",
                    "fraction of the kept steps' proposals accepted",
                ),
                col(
                    "failed",
                    "int64",
                    "",
                    "proposals the model could not be analysed at",
                ),
            ],
        ),
        table(
            "mcmc_parameters",
            s,
            false,
            vec![
                col("parameter", "string", "", "parameter name"),
                col(
                    "r_hat",
                    "float64",
                    "",
                    "split potential scale reduction (near 1 when the chains mixed)",
                ),
                col("ess", "float64", "", "effective sample size"),
            ],
        ),
    ]
}

/// The `samples` table: parameter samples in long format, sample-major (also kept with each
/// stored TMCMC population).
pub(crate) fn samples_layout() -> TableLayout {
    table(
        "samples",
        Storage::Parquet,
        true,
        vec![
            col("sample", "int64", "", "0-based sample number"),
            col("parameter", "string", "", "parameter"),
            col("value", "float64", "SI", "sampled value"),
        ],
    )
}

/// `samples` (each of `names.len()` values) as the `samples` table.
pub(crate) fn samples_table(names: &[String], samples: &[Vec<f64>]) -> Table {
    let n = names.len();
    let sm = || (0..samples.len()).flat_map(move |k| (0..n).map(move |i| (k, i)));
    Table::new()
        .with("sample", Column::I64(sm().map(|(k, _)| k as i64).collect()))
        .with("parameter", strs(sm().map(|(_, i)| &names[i])))
        .with("value", f64s(sm().map(|(k, i)| samples[k][i])))
}

/// The values of the `samples` table, `n` per sample.
pub(crate) fn read_samples(t: &Table, n: usize) -> Result<Vec<Vec<f64>>, ArtefactError> {
    let values = t.f64s("samples", "value")?;
    Ok(values.chunks(n.max(1)).map(<[f64]>::to_vec).collect())
}

/// The `tmcmc_stages` table of a TMCMC run (also kept with each stored population).
pub(crate) fn stages_layout() -> TableLayout {
    table(
        "tmcmc_stages",
        Storage::Parquet,
        false,
        vec![
            col("stage", "int64", "", "1-based tempering stage"),
            col("exponent", "float64", "", "tempering exponent beta reached"),
            col(
                "log_evidence",
                "float64",
                "",
                "ln S_j, the stage's share of ln p(y)",
            ),
            col(
                "acceptance",
                "float64",
                "",
                "fraction of Metropolis-Hastings proposals accepted",
            ),
            col(
                "distinct",
                "int64",
                "",
                "distinct samples kept by the resampling",
            ),
        ],
    )
}

/// The stages as the `tmcmc_stages` table.
pub(crate) fn stages_table(st: &[TmcmcStage]) -> Table {
    Table::new()
        .with("stage", Column::I64((1..=st.len() as i64).collect()))
        .with("exponent", f64s(st.iter().map(|x| x.exponent)))
        .with("log_evidence", f64s(st.iter().map(|x| x.log_evidence)))
        .with("acceptance", f64s(st.iter().map(|x| x.acceptance)))
        .with(
            "distinct",
            Column::I64(st.iter().map(|x| x.distinct as i64).collect()),
        )
}

/// The stages from the `tmcmc_stages` table.
pub(crate) fn read_stages(t: &Table) -> Result<Vec<TmcmcStage>, ArtefactError> {
    let n = "tmcmc_stages";
    let (e, l, acc, d) = (
        t.f64s(n, "exponent")?,
        t.f64s(n, "log_evidence")?,
        t.f64s(n, "acceptance")?,
        t.i64s(n, "distinct")?,
    );
    Ok((0..e.len())
        .map(|k| TmcmcStage {
            exponent: e[k],
            log_evidence: l[k],
            acceptance: acc[k],
            distinct: d[k].max(0) as usize,
        })
        .collect())
}

fn f64s(v: impl Iterator<Item = f64>) -> Column {
    Column::F64(v.collect())
}

fn strs<'a>(v: impl Iterator<Item = &'a String>) -> Column {
    Column::Str(v.cloned().collect())
}

fn write(r: &PosteriorRecord) -> Artefact {
    let p = &r.posterior;
    let m = &p.marginals;
    let n = m.len();
    let names: Vec<String> = m.iter().map(|x| x.name.clone()).collect();
    let parameters = Table::new()
        .with("parameter", strs(names.iter()))
        .with("updated", f64s(m.iter().map(|x| x.updated)))
        .with("mean", f64s(m.iter().map(|x| x.mean)))
        .with("sd", f64s(m.iter().map(|x| x.sd)))
        .with("lower", f64s(m.iter().map(|x| x.lower)))
        .with("upper", f64s(m.iter().map(|x| x.upper)))
        .with("relative_sd", f64s(m.iter().map(|x| x.sd / x.mean.abs())));
    let pairs = || (0..n).flat_map(move |i| (0..n).map(move |j| (i, j)));
    let covariance = Table::new()
        .with("parameter_i", strs(pairs().map(|(i, _)| &names[i])))
        .with("parameter_j", strs(pairs().map(|(_, j)| &names[j])))
        .with("covariance", f64s(pairs().map(|(i, j)| p.covariance[i][j])))
        .with(
            "correlation",
            f64s(pairs().map(|(i, j)| p.correlation[i][j])),
        );
    let d = &p.directions;
    let dirs = || (0..d.len()).flat_map(move |k| (0..n).map(move |i| (k, i)));
    let directions = Table::new()
        .with(
            "direction",
            Column::I64(dirs().map(|(k, _)| k as i64 + 1).collect()),
        )
        .with("sd_relative", f64s(dirs().map(|(k, _)| d[k].sd)))
        .with("parameter", strs(dirs().map(|(_, i)| &names[i])))
        .with("component", f64s(dirs().map(|(k, i)| d[k].vector[i])));
    let noise = Table::new()
        .with("group", strs(p.groups.iter()))
        .with("sigma", f64s(p.sigma.iter().copied()));
    let s = &p.samples;
    let samples = samples_table(&names, s);
    let unidentified: Vec<&String> = m
        .iter()
        .filter(|x| x.sd.is_infinite())
        .map(|x| &x.name)
        .collect();
    let mut a = Artefact::new(K)
        .with_table("parameters", parameters, Storage::Parquet)
        .with_table("covariance", covariance, Storage::Parquet)
        .with_table("directions", directions, Storage::Parquet)
        .with_table("noise", noise, Storage::Parquet)
        .with_table("samples", samples, Storage::Parquet)
        .with_meta("method", r.method.clone().into())
        .with_meta("likelihood", r.likelihood.clone().into())
        .with_meta("noise", r.noise.clone().into())
        .with_meta("sigma_estimated", p.sigma_estimated.into())
        .with_meta("credible_level", p.credible_level.into())
        .with_meta("rows", p.rows.into())
        .with_meta("neg_log_likelihood", p.neg_log_likelihood.into())
        .with_meta("refine_steps", p.refinement.steps.into())
        .with_meta("refine_converged", p.refinement.converged.into())
        .with_meta("objective_start", p.refinement.objective_start.into())
        .with_meta("objective_mode", p.refinement.objective_mode.into())
        .with_meta("samples", s.len().into())
        .with_meta("predictive_samples", p.predictive_samples.into())
        .with_meta("seed", p.seed.into())
        .with_meta("unidentified", serde_json::json!(unidentified));
    if !p.warnings.is_empty() {
        a = a.with_meta("posterior_warnings", p.warnings.clone().into());
    }
    if !p.natural_frequencies.is_empty() {
        let b = &p.natural_frequencies;
        a = a.with_table(
            "natural_frequencies",
            Table::new()
                .with("mode", Column::I64((1..=b.len() as i64).collect()))
                .with("freq_hz", f64s(b.iter().map(|x| x.freq_hz)))
                .with("sd_linear_hz", f64s(b.iter().map(|x| x.sd_linear)))
                .with("sd_sampled_hz", f64s(b.iter().map(|x| x.sd_sampled))),
            Storage::Parquet,
        );
    }
    if !p.frf.is_empty() {
        let b = &p.frf;
        a = a.with_table(
            "frf_band",
            Table::new()
                .with("freq_hz", f64s(b.iter().map(|x| x.freq_hz)))
                .with("pair", strs(b.iter().map(|x| &x.label)))
                .with("abs", f64s(b.iter().map(|x| x.value)))
                .with("sd_linear", f64s(b.iter().map(|x| x.sd_linear)))
                .with("sd_sampled", f64s(b.iter().map(|x| x.sd_sampled))),
            Storage::Parquet,
        );
    }
    if let Some(smp) = &r.sampling {
        a = a
            .with_meta("log_evidence", smp.log_evidence.into())
            .with_table("tmcmc_stages", stages_table(&smp.stages), Storage::Parquet);
    }
    if let Some(m) = &r.mcmc {
        let c = &m.chains;
        a = a
            .with_meta("sampler", m.sampler.clone().into())
            .with_table(
                "mcmc_chains",
                Table::new()
                    .with("chain", Column::I64((0..c.len() as i64).collect()))
                    .with("step", f64s(c.iter().map(|x| x.step)))
                    .with("acceptance", f64s(c.iter().map(|x| x.acceptance)))
                    .with(
                        "failed",
                        Column::I64(c.iter().map(|x| x.failed as i64).collect()),
                    ),
                Storage::Parquet,
            )
            .with_table(
                "mcmc_parameters",
                Table::new()
                    .with("parameter", strs(p.marginals.iter().map(|m| &m.name)))
                    .with("r_hat", f64s(m.r_hat.iter().copied()))
                    .with("ess", f64s(m.ess.iter().copied())),
                Storage::Parquet,
            );
    }
    a
}

fn meta_f64(a: &Artefact, key: &str) -> Result<f64, ArtefactError> {
    // Non-finite numbers are written as null.
    Ok(meta_value::<Option<f64>>(a, key)?.unwrap_or(f64::NAN))
}

fn read(a: &Artefact) -> Result<PosteriorRecord, ArtefactError> {
    expect_kind(a, K)?;
    let t = a.table("parameters")?;
    let names = t.strs("parameters", "parameter")?.to_vec();
    let n = names.len();
    let g = |c: &str| t.f64s("parameters", c);
    let (updated, mean, sd, lower, upper) = (
        g("updated")?,
        g("mean")?,
        g("sd")?,
        g("lower")?,
        g("upper")?,
    );
    let marginals = (0..n)
        .map(|i| Marginal {
            name: names[i].clone(),
            updated: updated[i],
            mean: mean[i],
            sd: sd[i],
            lower: lower[i],
            upper: upper[i],
        })
        .collect();
    let square = |v: &[f64]| -> Result<Vec<Vec<f64>>, ArtefactError> {
        if v.len() != n * n {
            return Err(ArtefactError::schema(K, "covariance is not n x n"));
        }
        Ok((0..n).map(|i| v[i * n..(i + 1) * n].to_vec()).collect())
    };
    let c = a.table("covariance")?;
    let covariance = square(c.f64s("covariance", "covariance")?)?;
    let correlation = square(c.f64s("covariance", "correlation")?)?;
    let d = a.table("directions")?;
    let (dsd, comp) = (
        d.f64s("directions", "sd_relative")?,
        d.f64s("directions", "component")?,
    );
    let directions = (0..comp.len() / n.max(1))
        .map(|k| Direction {
            sd: dsd[k * n],
            vector: comp[k * n..(k + 1) * n].to_vec(),
        })
        .collect();
    let nt = a.table("noise")?;
    let samples = read_samples(a.table("samples")?, n)?;
    let band = |name: &str,
                label: &dyn Fn(&Table, usize) -> Result<String, ArtefactError>,
                cols: [&str; 4]|
     -> Result<Vec<Band>, ArtefactError> {
        let Ok(b) = a.table(name) else {
            return Ok(Vec::new());
        };
        let f = b.f64s(name, cols[0])?;
        let v = if cols[1].is_empty() {
            f
        } else {
            b.f64s(name, cols[1])?
        };
        let (l, s) = (b.f64s(name, cols[2])?, b.f64s(name, cols[3])?);
        (0..f.len())
            .map(|i| {
                Ok(Band {
                    label: label(b, i)?,
                    freq_hz: f[i],
                    value: v[i],
                    sd_linear: l[i],
                    sd_sampled: s[i],
                })
            })
            .collect()
    };
    let natural_frequencies = band(
        "natural_frequencies",
        &|_, i| Ok(format!("mode {}", i + 1)),
        ["freq_hz", "", "sd_linear_hz", "sd_sampled_hz"],
    )?;
    let frf = band(
        "frf_band",
        &|b, i| Ok(b.strs("frf_band", "pair")?[i].clone()),
        ["freq_hz", "abs", "sd_linear", "sd_sampled"],
    )?;
    let sampling = match a.table("tmcmc_stages") {
        Err(_) => None,
        Ok(t) => Some(Sampling {
            log_evidence: meta_f64(a, "log_evidence")?,
            stages: read_stages(t)?,
        }),
    };
    let mcmc = match (a.table("mcmc_chains"), a.table("mcmc_parameters")) {
        (Ok(c), Ok(q)) => {
            let n = "mcmc_chains";
            let (step, acc, failed) = (
                c.f64s(n, "step")?,
                c.f64s(n, "acceptance")?,
                c.i64s(n, "failed")?,
            );
            Some(Mcmc {
                sampler: a.meta_str("sampler")?.to_string(),
                chains: (0..step.len())
                    .map(|k| ChainReport {
                        step: step[k],
                        acceptance: acc[k],
                        failed: failed[k].max(0) as usize,
                    })
                    .collect(),
                r_hat: q.f64s("mcmc_parameters", "r_hat")?.to_vec(),
                ess: q.f64s("mcmc_parameters", "ess")?.to_vec(),
            })
        }
        _ => None,
    };
    Ok(PosteriorRecord {
        sampling,
        mcmc,
        method: a.meta_str("method")?.to_string(),
        likelihood: a.meta_str("likelihood")?.to_string(),
        noise: a.meta_str("noise")?.to_string(),
        posterior: Posterior {
            marginals,
            covariance,
            correlation,
            directions,
            sigma: nt.f64s("noise", "sigma")?.to_vec(),
            groups: nt.strs("noise", "group")?.to_vec(),
            sigma_estimated: meta_value::<bool>(a, "sigma_estimated")?,
            rows: meta_value::<usize>(a, "rows")?,
            neg_log_likelihood: meta_f64(a, "neg_log_likelihood")?,
            refinement: Refinement {
                steps: meta_value::<usize>(a, "refine_steps")?,
                objective_start: meta_f64(a, "objective_start")?,
                objective_mode: meta_f64(a, "objective_mode")?,
                converged: meta_value::<bool>(a, "refine_converged")?,
            },
            credible_level: meta_f64(a, "credible_level")?,
            samples,
            predictive_samples: meta_value::<usize>(a, "predictive_samples")?,
            natural_frequencies,
            frf,
            seed: meta_value::<u64>(a, "seed")?,
            warnings: optional_meta(a, "posterior_warnings")?,
        },
    })
}
