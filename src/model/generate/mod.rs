//! Generators of the case-study geometries (CASES.md) with a mesh-density knob.

pub mod bent_plate;
pub mod flat_plate;
pub mod scale;
pub mod three_beam;

pub use bent_plate::{BentPlate, bent_plate};
pub use flat_plate::{FlatPlate, PlateSupport, flat_plate};
pub use three_beam::{ThreeBeam, three_beam};

use super::Material;

/// Steel, CASES.md defaults: `E = 210 GPa`, `ν = 0.3`, `ρ = 7850 kg/m³`.
pub fn steel() -> Material {
    Material {
        e: 210e9,
        nu: 0.3,
        rho: 7850.0,
    }
}

/// Aluminium, CASES.md defaults: `E = 70 GPa`, `ν = 0.33`, `ρ = 2700 kg/m³`.
pub fn aluminium() -> Material {
    Material {
        e: 70e9,
        nu: 0.33,
        rho: 2700.0,
    }
}
