//! The prior's mean from the paint itself: Lambert + GGX fitted to the painted bins
//! ([`super::analytic_fit`]) and projected onto the basis.
//!
//! **Why.** Centred on the database's mean material, the prior fills the unpainted part of
//! the table with that mean plus whatever the components' correlations carry over from the
//! painted part; on materials unlike the database's mean that carried-over part overshoots,
//! and it is where almost all of the error lives (../shared/findings). A physically shaped
//! model fitted to the same bins extrapolates the way materials do (a lobe keeps its width
//! and its Fresnel rise), so the solve then only paints the differences on top of it.
//! Everything stays K coefficients per set: the preview, the exports and the incremental
//! updates do not change. It is measured on every bench run but is not the default yet,
//! because a second view can make a two-lobe metal worse under it ([`super::PriorMean::FITTED`]).
//!
//! **Cost.** A fit takes a few hundred milliseconds, too slow for the live loop's solve, so
//! it is a separate step: [`super::Solver::mean_fit_request`] copies what the fit needs,
//! [`MeanFitRequest::run`] runs anywhere (the worker runs it on its own thread while paint
//! settles), and [`super::Solver::install_fitted_mean`] takes the answer back, deciding by
//! the evidence whether the prior is centred on it. The command line does the three at once
//! ([`super::Solver::refit_prior_mean`]). Everything is deterministic, so the app and the
//! command line reach the same mean from the same bins.

use super::analytic_fit::{FitOptions, LambertGgx, fit_lambert_ggx_bounded};
use super::sparse::Bounds;
use crate::basis::OracleProjector;
use crate::materials::tabulate;
use crate::table::PairIndex;
use std::sync::{Arc, OnceLock};

/// A projector shared by a solver and its clones, built on first use (its Gram matrix is a
/// pass over the whole table, so it is built by the first fit, off the live loop).
pub(super) type SharedProjector = Arc<OnceLock<OracleProjector>>;

/// What a fit of the prior's mean needs, copied out of a solver.
#[derive(Clone, Debug)]
pub struct MeanFitRequest {
    /// The solver's generation of painted bins this request was made for.
    pub generation: u64,
    pub(super) bins: Vec<(PairIndex, [f64; 3], Bounds)>,
    pub(super) basis: Arc<crate::basis::Basis>,
    pub(super) projector: SharedProjector,
}

/// A fitted mean, ready to install.
#[derive(Clone, Debug)]
pub struct FittedMean {
    /// The generation of painted bins it was fitted to.
    pub generation: u64,
    /// The basis it was projected onto: a solver on another basis ignores it.
    pub basis: Arc<crate::basis::Basis>,
    /// The fitted model's projection onto the basis (K rows of R, G, B).
    pub coefficients: Vec<[f64; 3]>,
    pub model: LambertGgx,
}

impl MeanFitRequest {
    /// Painted bins the fit sees.
    pub fn bins(&self) -> usize {
        self.bins.len()
    }

    /// Fits the model and projects it. Deterministic for given bins, whatever the threads.
    pub fn run(self) -> FittedMean {
        let fit = fit_lambert_ggx_bounded(&self.bins, &FitOptions::default());
        let model = fit.model;
        let projector = self
            .projector
            .get_or_init(|| OracleProjector::new(self.basis.clone()));
        let coefficients = projector.project(&tabulate(&model));
        FittedMean {
            generation: self.generation,
            basis: self.basis,
            coefficients,
            model,
        }
    }
}
