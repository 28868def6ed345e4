//! A reference fitted to the paint itself: Lambert + a microfacet lobe (GGX, or Beckmann where
//! [`super::PriorMean::Fitted`] asks for it) fitted to the painted bins
//! ([`super::analytic_fit`]), tabulated, and used as the table the basis then corrects.
//!
//! **Why.** Centred on the database's mean material, the prior fills the unpainted part of
//! the table with that mean plus whatever the components' correlations carry over from the
//! painted part; on materials unlike the database's mean that carried-over part overshoots,
//! and it is where almost all of the error lives (../shared/findings). A physically shaped
//! model fitted to the same bins extrapolates the way materials do (a lobe keeps its width
//! and its Fresnel rise), so the solve then only paints the differences on top of it.
//!
//! **Why not its projection.** The first version projected the fit onto the K components
//! and centred the prior there. K components cannot hold a narrow lobe or a dark diffuse
//! floor: the projection smeared the fit exactly where it was meant to help, and a second
//! view could make a two-lobe metal worse. Kept as a per-entry reference instead,
//! ρ̂ = unmap(map(F) + Σ_k u_k x_k), the fit keeps its shape and the K coefficients describe
//! only how the paint departs from it (measured in `PriorMean::FITTED`'s notes).
//!
//! **Cost.** A fit takes a few hundred milliseconds, too slow for the live loop's solve, so
//! it is a separate step: [`super::Solver::mean_fit_request`] copies what the fit needs,
//! [`MeanFitRequest::run`] runs anywhere (the worker runs it on its own thread while paint
//! settles), and [`super::Solver::install_fitted_mean`] takes the answer back, deciding by
//! the evidence whether the solve measures the paint from it. The command line does the three
//! at once ([`super::Solver::refit_prior_mean`]). Everything is deterministic, so the app and
//! the command line reach the same reference from the same bins.

use super::analytic_fit::{FitOptions, LambertMicrofacet, fit_lambert_microfacet_bounded};
use super::prior::PriorMean;
use super::sparse::Bounds;
use crate::basis::Basis;
use crate::materials::tabulate;
use crate::table::{PAIRS, PairIndex};
use rayon::prelude::*;
use std::sync::Arc;

/// How far (in nats of the mapped domain) a fitted reference may lie from the database's
/// mean: e^40 is far beyond any material, and keeps every later exp finite in f32. (Bounding
/// it to the database's range plus 1 nat changed no figure of the pipeline tests: the fits'
/// lobes stay inside what the database spans.)
const OFFSET_LIMIT: f32 = 40.0;

/// What a fit of the reference needs, copied out of a solver.
#[derive(Clone, Debug)]
pub struct MeanFitRequest {
    /// The solver's generation of painted bins this request was made for.
    pub generation: u64,
    pub(super) bins: Vec<(PairIndex, [f64; 3], Bounds)>,
    pub(super) basis: Arc<Basis>,
    /// The lobe shapes the fit tries ([`super::PriorMean::Fitted`]'s choice).
    pub(super) options: FitOptions,
}

/// A fitted reference, ready to install.
#[derive(Clone, Debug)]
pub struct FittedMean {
    /// The generation of painted bins it was fitted to.
    pub generation: u64,
    pub reference: Arc<FittedReference>,
}

/// A fitted model as a table of offsets from the basis's mean in the mapped domain: per pair
/// and channel, map(F_p) − mean_p. The reconstruction adds it to what the coefficients give;
/// the solver subtracts it from each painted bin.
pub struct FittedReference {
    model: LambertMicrofacet,
    /// The basis whose map and mean the offsets are measured in.
    basis: Arc<Basis>,
    offsets: Vec<[f32; 3]>,
}

impl std::fmt::Debug for FittedReference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FittedReference")
            .field("model", &self.model)
            .finish_non_exhaustive()
    }
}

/// Two references are the same when they tabulate the same model on the same basis.
impl PartialEq for FittedReference {
    fn eq(&self, other: &Self) -> bool {
        self.model == other.model && Arc::ptr_eq(&self.basis, &other.basis)
    }
}

impl FittedReference {
    /// Tabulates `model` on `basis`'s map.
    pub fn new(basis: Arc<Basis>, model: LambertMicrofacet) -> Self {
        let table = tabulate(&model);
        let offsets = table
            .pairs()
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .map(|(p, rho)| {
                let pair = PairIndex::from_index(p);
                rho.map(|v| {
                    // Unclamped to the database's range: the fit may leave it, which is the
                    // point of keeping it per entry.
                    let offset = basis.mapped_from_mean(pair, v as f64) as f32;
                    if offset.is_finite() {
                        offset.clamp(-OFFSET_LIMIT, OFFSET_LIMIT)
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Self {
            model,
            basis,
            offsets,
        }
    }

    pub fn model(&self) -> &LambertMicrofacet {
        &self.model
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    /// map(F_p) − mean_p for each channel.
    #[inline]
    pub fn offset(&self, pair: PairIndex) -> [f32; 3] {
        self.offsets[pair.index()]
    }

    /// Every pair's offsets, in pair order ([`PAIRS`] entries).
    pub fn offsets(&self) -> &[[f32; 3]] {
        debug_assert_eq!(self.offsets.len(), PAIRS);
        &self.offsets
    }
}

impl MeanFitRequest {
    /// Painted bins the fit sees.
    pub fn bins(&self) -> usize {
        self.bins.len()
    }

    /// Fits the model and tabulates it. Deterministic for given bins, whatever the threads.
    pub fn run(self) -> FittedMean {
        let fit = fit_lambert_microfacet_bounded(&self.bins, &self.options);
        FittedMean {
            generation: self.generation,
            reference: Arc::new(FittedReference::new(self.basis, fit.model)),
        }
    }
}

/// The fit's options for the prior's mean `mean`: which lobe shapes it tries.
pub(super) fn fit_options(mean: PriorMean) -> FitOptions {
    match mean {
        PriorMean::Fitted {
            beckmann_margin,
            coat_margin,
            ..
        } => FitOptions {
            beckmann_margin,
            coat_margin,
            ..Default::default()
        },
        PriorMean::Database => FitOptions::default(),
    }
}
