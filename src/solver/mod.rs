//! From painted samples to a full table: the sparse table, the incremental ridge solver on
//! cached basis rows, and the lazy reconstruction.

pub mod reconstruction;
pub mod ridge;
pub mod sparse;

pub use reconstruction::Reconstruction;
pub use ridge::{Regularization, Solution, Solver};
pub use sparse::{BinChange, Policy, SampleKey, SampleRejected, SparseTable};
