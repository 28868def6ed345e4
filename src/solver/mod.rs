//! From painted samples to a full table: the sparse table, the incremental ridge solver on
//! cached basis rows, and the lazy reconstruction.

pub mod analytic_fit;
pub mod bands;
mod condition;
pub mod fitted_mean;
pub mod posterior;
pub mod prior;
pub mod reconstruction;
pub mod ridge;
pub mod sparse;

pub use bands::{BANDS, BandWeights, DEFAULT_KNOTS, KnotSpacing, pair_bands, pair_bands_spaced};
pub use fitted_mean::{FittedMean, FittedReference, MeanFitRequest};
pub use prior::{
    Censoring, DEFAULT_ALPHA, EVIDENCE_BAND_CORRELATIONS, PriorMean, PriorModel, Regularization,
};
pub use reconstruction::Reconstruction;
pub use ridge::{Posterior, Solution, Solver};
pub use sparse::{
    BinChange, Bound, Bounds, EXACT, Policy, Reading, SampleKey, SampleRejected, SparseTable,
};

/// Runs faer's dense algorithms (the solver's factorisations and eigenvalues, the basis
/// build's small SVD) on the calling thread, once per process. Its default, rayon with
/// spinning workers, gains nothing on matrices of a few hundred rows and left those workers
/// competing with every later rayon loop: the full table took 450 ms after a solve instead of
/// 70 ms on 2 cores, and a dab's solve paid thread hand-offs.
pub fn sequential_dense_algebra() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| faer::set_global_parallelism(faer::Par::Seq));
}
