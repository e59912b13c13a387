//! The `tmcmc_population` kind: the samples of one TMCMC tempering stage and their
//! log-likelihoods, kept in the run's cache as a part of a `bayes.tmcmc` stage so that a stopped
//! run resumes from its last finished stage (docs/theory.md §15) — or one batch of a stage's
//! chains, when processes share the stage (`workers`).
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `samples` | `sample`, `parameter`, `value` (long format, sample-major) |
//! | `chains` | `sample`, `log_likelihood` (`-inf`: the model could not be analysed there) |
//! | `tmcmc_stages` | the stages so far, as in a `posterior` |

use super::posterior::{
    read_samples, read_stages, samples_layout, samples_table, stages_layout, stages_table,
};
use super::{Kind, Layout, col, expect_kind, meta, meta_opt, meta_value, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::updating::tmcmc::Population;

/// A population with the names of its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct PopulationRecord {
    /// Parameter names, in the order of every sample.
    pub parameters: Vec<String>,
    /// The population (for a batch: its chains, no stages listed).
    pub population: Population,
    /// Set when the record is one batch of a stage's chains.
    pub batch: Option<ChainBatch>,
}

/// Which batch of which stage's chains a record holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ChainBatch {
    /// The tempering stage (0: the prior's samples).
    pub stage: usize,
    /// 0-based batch.
    pub index: usize,
    /// Batches of the stage.
    pub of: usize,
    /// Metropolis-Hastings proposals its chains accepted.
    pub accepted: usize,
}

/// The `tmcmc_population` kind.
pub struct TmcmcPopulationKind;

const K: ArtefactKind = ArtefactKind::TmcmcPopulation;

impl Kind for TmcmcPopulationKind {
    const KIND: ArtefactKind = K;
    const NAME: &'static str = "tmcmc_population";
    type Value = PopulationRecord;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        let mut stages = stages_layout();
        stages.required = true;
        Layout {
            tables: vec![
                samples_layout(),
                table(
                    "chains",
                    s,
                    true,
                    vec![
                        col("sample", "int64", "", "0-based sample number"),
                        col(
                            "log_likelihood",
                            "float64",
                            "",
                            "ln p(y|phi) (-inf: the model could not be analysed there)",
                        ),
                    ],
                ),
                stages,
            ],
            meta: vec![
                meta(
                    "stage",
                    "tempering stages finished (0: samples of the prior)",
                ),
                meta("exponent", "tempering exponent beta the samples follow"),
                meta("parameters", "parameter names, in sample order"),
                meta(
                    "failed",
                    "evaluations that failed so far (for a batch: in it)",
                ),
                meta_opt(
                    "batch",
                    "for one batch of a stage's chains: {stage, index, of, accepted}",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(r: &PopulationRecord) -> Artefact {
        let p = &r.population;
        let samples = samples_table(&r.parameters, &p.samples);
        let chains = Table::new()
            .with("sample", Column::I64((0..p.samples.len() as i64).collect()))
            .with("log_likelihood", Column::F64(p.log_likelihood.clone()));
        let a = Artefact::new(K)
            .with_table("samples", samples, Storage::Parquet)
            .with_table("chains", chains, Storage::Parquet)
            .with_table("tmcmc_stages", stages_table(&p.stages), Storage::Parquet)
            .with_meta("stage", p.stages.len().into())
            .with_meta("exponent", p.exponent().into())
            .with_meta("parameters", serde_json::json!(r.parameters))
            .with_meta("failed", p.failed.into());
        match &r.batch {
            Some(b) => a.with_meta("batch", serde_json::json!(b)),
            None => a,
        }
    }

    fn from_artefact(a: &Artefact) -> Result<PopulationRecord, ArtefactError> {
        expect_kind(a, K)?;
        let bad = |m: String| ArtefactError::schema(K, m);
        let parameters: Vec<String> = meta_value(a, "parameters")?;
        let n = parameters.len();
        let samples = read_samples(a.table("samples")?, n)?;
        let log_likelihood = a
            .table("chains")?
            .f64s("chains", "log_likelihood")?
            .to_vec();
        if n == 0 || samples.len() != log_likelihood.len() || samples.iter().any(|x| x.len() != n) {
            return Err(bad(format!(
                "{} samples of {n} parameters for {} log-likelihoods",
                samples.len(),
                log_likelihood.len()
            )));
        }
        let stages = read_stages(a.table("tmcmc_stages")?)?;
        if meta_value::<usize>(a, "stage")? != stages.len() {
            return Err(bad("`stage` is not the number of stages listed".into()));
        }
        let batch = match a.meta.get("batch") {
            None => None,
            Some(v) => Some(
                serde_json::from_value::<ChainBatch>(v.clone())
                    .map_err(|e| bad(format!("`batch`: {e}")))?,
            ),
        };
        Ok(PopulationRecord {
            batch,
            parameters,
            population: Population {
                samples,
                log_likelihood,
                stages,
                failed: meta_value(a, "failed")?,
            },
        })
    }
}
