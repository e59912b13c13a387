//! Stage kinds: the glue between numerical modules and the pipeline engine, one kind per file.
//! Each parses its typed parameters, calls the numerics and writes artefacts.

pub mod assemble;
pub mod correlate_frf;
pub mod frf_import;
pub mod frf_synthesise;
pub mod mesh_generate;
pub mod mesh_import;
pub mod mesh_parameters;
pub mod model_lumped;
pub mod modes;
pub mod noise_add;
pub mod plot_frf;
pub mod update;

use crate::pipeline::{Registry, Stage, Typed};

static MESH_IMPORT: Typed<mesh_import::MeshImport> = Typed::new();
static FRF_IMPORT: Typed<frf_import::FrfImport> = Typed::new();
static ASSEMBLE: Typed<assemble::Assemble> = Typed::new();
static MODEL_LUMPED: Typed<model_lumped::ModelLumped> = Typed::new();
static MODES: Typed<modes::ModesStage> = Typed::new();
static FRF_SYNTHESISE: Typed<frf_synthesise::FrfSynthesise> = Typed::new();
static NOISE_ADD: Typed<noise_add::NoiseAdd> = Typed::new();
static CORRELATE_FRF: Typed<correlate_frf::CorrelateFrf> = Typed::new();
static MESH_GENERATE: Typed<mesh_generate::MeshGenerate> = Typed::new();
static MESH_PARAMETERS: Typed<mesh_parameters::MeshParameters> = Typed::new();
static PLOT_FRF: Typed<plot_frf::PlotFrf> = Typed::new();
static UPDATE: Typed<update::Update> = Typed::new();

/// Every stage kind femu knows.
pub fn registry() -> Registry {
    let all: Vec<&'static dyn Stage> = vec![
        &MESH_GENERATE,
        &MESH_IMPORT,
        &MESH_PARAMETERS,
        &MODEL_LUMPED,
        &ASSEMBLE,
        &MODES,
        &FRF_SYNTHESISE,
        &FRF_IMPORT,
        &NOISE_ADD,
        &CORRELATE_FRF,
        &PLOT_FRF,
        &UPDATE,
    ];
    Registry::new(all)
}
