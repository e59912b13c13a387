//! Sparse direct solvers behind one operator boundary, and the sparse products and
//! combinations their users need (docs/theory.md §1).
//!
//! - [`SpdFactor`]: `A = P L Lᵀ Pᵀ` of a symmetric positive definite `A` by our multifrontal
//!   Cholesky on a node-graph AMD ordering ([`factor`], [`multifrontal`], [`ordering`], with
//!   the AVX2 kernels of [`thin`]). It serves the shift-invert Lanczos process of `eigen`
//!   (through its two half sweeps, [`SymmetricFactor`]), the static constraint modes of
//!   `reduction` and the static correction of `sensitivity`.
//! - [`SymbolicLdlt`]: `A = P L D Lᵀ Pᵀ` of a complex symmetric `A` without pivoting, on the
//!   same ordering and supernodal structure, analysed once per pattern and factored per matrix
//!   in a caller's [`LdltWorkspace`]: the dynamic stiffness of the direct FRF at every line.
//! - [`Lu`]: the LU factor of a general sparse matrix (faer's supernodal LU on a shared
//!   [`SymbolicLu`]), the direct FRF's fallback where the `LDLᵀ` leaves a poor residual.
//!
//! - [`LowerPencil`]: `K` and `M` as lower triangles on one pattern, with the products `K X`,
//!   `M X` the eigensolver needs (half the memory of two full matrices).
//!
//! Both solve through [`SparseSolve`], which takes the parallelism of every call explicitly
//! (faer's [`Par`](faer::Par)): [`Par::Seq`](faer::Par::Seq) runs the call on the calling thread
//! alone; `Par::Rayon(n)` shares it among the current rayon pool's threads, dense kernels split
//! `n` ways. The arithmetic does not depend on the choice: results are identical.

mod combination;
mod factor;
mod layout;
mod ldlt;
mod lu;
mod multifrontal;
mod operator;
mod ordering;
mod pencil;
mod product;
mod thin;

pub use combination::lower_combination;
pub use factor::{FactorError, FactorInfo, FactorStructure, SOLVE_COLUMNS, SpdFactor};
pub(crate) use ldlt::{Isa, Level};
pub use ldlt::{LdltError, LdltScalar, LdltWorkspace, SymbolicLdlt};
pub use lu::{Lu, SymbolicLu};
pub use operator::{SparseSolve, SymmetricFactor};
pub use pencil::{FullPencil, IntegerIndex, LowerPencil, PencilError, SymmetricPencil};
pub use product::{sym_matvec, sym_matvec_pair};
