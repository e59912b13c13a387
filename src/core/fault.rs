//! Whose fault an error is. The numerics' errors say whether the caller's input is wrong (a DOF
//! the model does not have, a set that is not defined, a material out of range) or a computation
//! failed on valid input; the engine turns the first into exit code 2 and the second into 1.

/// An error that knows whether the caller's input caused it.
pub trait InputFault: std::error::Error {
    /// Whether the input (a name, a DOF, a value, a model's definition) is at fault, as opposed
    /// to the computation.
    fn is_input(&self) -> bool;
}
