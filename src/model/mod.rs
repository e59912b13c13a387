//! Model descriptions: what the structure is, before any matrix is built.

pub mod export;
pub mod generate;
pub mod import;
pub mod laminates;
pub mod lumped;
pub mod parameters;
pub mod sections;
pub mod structure;

pub use lumped::{LumpedMass, LumpedModel, LumpedModelError, LumpedSpring};
pub use parameters::ParameterValueError;
pub use structure::{AnisotropicMaterial, SolidFamily, SolidKind, SolidProperty};
pub use structure::{
    BeamCentres, BeamEnds, BeamProperty, BeamSection, BeamStation, BeamTaper, Element, Material,
    Model, ModelError, MultipointConstraint, Parameter, ParameterKind, RodProperty, RodSection,
    ShellProperty, TubeTaper,
};
