//! Conventions shared by every element kernel.
//!
//! A kernel maps node coordinates (basic Cartesian system, metres) and section/material values
//! (SI) to dense element matrices in the basic system, with DOFs node-major and six per node in
//! the order `ux uy uz rx ry rz`. Derivatives with respect to the element's parameters are exact
//! (analytic) and returned beside the matrices, so assembly of `∂K/∂φ`, `∂M/∂φ` never rebuilds the
//! model (docs/theory.md §2).

use faer::Mat;

/// Consistent or lumped mass.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// Consistent mass from the element's shape functions.
    #[default]
    Consistent,
    /// Diagonal (lumped) mass conserving total mass and, where stated, rotary inertia.
    Lumped,
}

/// Stiffness and mass of one element.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementMatrices {
    /// Stiffness, `6n × 6n`.
    pub k: Mat<f64>,
    /// Mass, `6n × 6n`.
    pub m: Mat<f64>,
}

/// An element's derivative with respect to one parameter: `∂K/∂φ`, `∂M/∂φ`.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementDerivative {
    /// `∂K/∂φ`.
    pub dk: Mat<f64>,
    /// `∂M/∂φ`.
    pub dm: Mat<f64>,
}

/// Why an element could not be formed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ElementError {
    /// Degenerate geometry (coincident nodes, zero area or length, collinear corners).
    #[error("degenerate geometry: {0}")]
    Degenerate(String),
    /// A section or material value is out of range.
    #[error("{field} = {value} is out of range: {hint}")]
    BadValue {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What would be valid.
        hint: &'static str,
    },
    /// The orientation vector of a beam is parallel to its axis.
    #[error(
        "the orientation vector {v:?} is parallel to the beam axis {axis:?}; give a vector in the beam's x-y plane that is not along the axis"
    )]
    Orientation {
        /// The vector given.
        v: [f64; 3],
        /// The beam axis.
        axis: [f64; 3],
    },
    /// The parameter is not one of this element's (or its section's) parameters.
    #[error("parameter `{parameter}` does not apply to {element}; its parameters are: {valid}")]
    UnknownParameter {
        /// The parameter asked for.
        parameter: &'static str,
        /// The element (and section) it was asked of.
        element: &'static str,
        /// The parameters that element has.
        valid: &'static str,
    },
}

impl crate::core::InputFault for ElementError {
    fn is_input(&self) -> bool {
        // Every way an element cannot be formed comes from its definition: geometry, values,
        // orientation, a parameter name.
        true
    }
}

/// Checks a value is finite and positive (or non-negative when `allow_zero`).
pub fn positive(field: &'static str, value: f64, allow_zero: bool) -> Result<f64, ElementError> {
    let ok = value.is_finite() && (value > 0.0 || (allow_zero && value == 0.0));
    if ok {
        Ok(value)
    } else {
        Err(ElementError::BadValue {
            field,
            value,
            hint: if allow_zero {
                "must be finite and >= 0"
            } else {
                "must be finite and > 0"
            },
        })
    }
}
