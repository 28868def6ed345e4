//! From painted samples to a full table: the sparse table, the incremental ridge solver on
//! cached basis rows, and the lazy reconstruction.

pub mod bands;
pub mod reconstruction;
pub mod ridge;
pub mod sparse;

pub use bands::{BANDS, BandWeights, pair_bands};
pub use reconstruction::Reconstruction;
pub use ridge::{DEFAULT_ALPHA, Posterior, PriorModel, Regularization, Solution, Solver};
pub use sparse::{BinChange, Bound, Bounds, EXACT, Policy, SampleKey, SampleRejected, SparseTable};
