//! Stage kinds: the glue between numerical modules and the pipeline engine, one kind per file.
//! Each parses its typed parameters, calls the numerics and writes artefacts.

pub mod assemble;
pub mod bayes_tmcmc;
pub mod correlate_frf;
pub mod correlate_modes;
pub mod frf_import;
pub mod frf_synthesise;
pub mod localise_eigensensitivity;
pub mod localise_leverage;
pub mod mesh_export;
pub mod mesh_generate;
pub mod mesh_import;
pub mod mesh_parameters;
pub mod model_lumped;
pub mod model_partition;
pub mod modes;
pub mod modes_import;
pub mod noise_add;
pub mod params;
pub mod plot_convergence;
pub mod plot_frf;
pub mod reduce_common;
pub mod reduce_craig_bampton;
pub mod reduce_force_coupling;
pub mod reduce_free_interface;
pub mod test_export;
pub mod test_pair;
pub mod update;

use crate::pipeline::{Registry, Stage, Typed};

static MESH_IMPORT: Typed<mesh_import::MeshImport> = Typed::new();
static FRF_IMPORT: Typed<frf_import::FrfImport> = Typed::new();
static MODES_IMPORT: Typed<modes_import::ModesImport> = Typed::new();
static ASSEMBLE: Typed<assemble::Assemble> = Typed::new();
static MODEL_LUMPED: Typed<model_lumped::ModelLumped> = Typed::new();
static MODES: Typed<modes::ModesStage> = Typed::new();
static FRF_SYNTHESISE: Typed<frf_synthesise::FrfSynthesise> = Typed::new();
static NOISE_ADD: Typed<noise_add::NoiseAdd> = Typed::new();
static CORRELATE_FRF: Typed<correlate_frf::CorrelateFrf> = Typed::new();
static CORRELATE_MODES: Typed<correlate_modes::CorrelateModes> = Typed::new();
static MESH_GENERATE: Typed<mesh_generate::MeshGenerate> = Typed::new();
static MESH_PARAMETERS: Typed<mesh_parameters::MeshParameters> = Typed::new();
static MESH_EXPORT: Typed<mesh_export::MeshExport> = Typed::new();
static PLOT_FRF: Typed<plot_frf::PlotFrf> = Typed::new();
static PLOT_CONVERGENCE: Typed<plot_convergence::PlotConvergence> = Typed::new();
static UPDATE: Typed<update::Update> = Typed::new();
static MODEL_PARTITION: Typed<model_partition::ModelPartition> = Typed::new();
static REDUCE_CB: Typed<reduce_craig_bampton::ReduceCraigBampton> = Typed::new();
static REDUCE_FI: Typed<reduce_free_interface::ReduceFreeInterface> = Typed::new();
static REDUCE_FC: Typed<reduce_force_coupling::ReduceForceCoupling> = Typed::new();
static LOCALISE_LEVERAGE: Typed<localise_leverage::LocaliseLeverage> = Typed::new();
static LOCALISE_EIGEN: Typed<localise_eigensensitivity::LocaliseEigensensitivity> = Typed::new();
static TEST_PAIR: Typed<test_pair::TestPair> = Typed::new();
static TEST_EXPORT: Typed<test_export::TestExport> = Typed::new();
static BAYES_TMCMC: Typed<bayes_tmcmc::BayesTmcmc> = Typed::new();

/// Every stage kind femu knows.
pub fn registry() -> Registry {
    let all: Vec<&'static dyn Stage> = vec![
        &MESH_GENERATE,
        &MESH_IMPORT,
        &MESH_PARAMETERS,
        &MESH_EXPORT,
        &MODEL_LUMPED,
        &ASSEMBLE,
        &MODES,
        &FRF_SYNTHESISE,
        &FRF_IMPORT,
        &MODES_IMPORT,
        &TEST_PAIR,
        &TEST_EXPORT,
        &NOISE_ADD,
        &CORRELATE_FRF,
        &CORRELATE_MODES,
        &PLOT_FRF,
        &PLOT_CONVERGENCE,
        &UPDATE,
        &MODEL_PARTITION,
        &REDUCE_CB,
        &REDUCE_FI,
        &REDUCE_FC,
        &LOCALISE_LEVERAGE,
        &LOCALISE_EIGEN,
        &BAYES_TMCMC,
    ];
    Registry::new(all)
}
