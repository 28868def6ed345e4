//! The posterior of the coefficients given the painted bins: a Gaussian prior from the
//! database, localised in θ_d, and a likelihood that weighs bins by what renders see.
//!
//! **Model.** In the mapped domain a bin p says y_p = ψ_pᵀX + e_p, where X stacks the
//! [`BANDS`] coefficient sets X_j (K each) and ψ_p puts the basis row u_p on the two sets its
//! θ_d blends ([`super::bands`]). Each X_j has the database's component variances σ_k², and
//! X_i, X_j are correlated by ρ ([`PriorModel::band_correlation`]): a slice informs slices far
//! away in θ_d less than the database's components alone would say. The noise e_p has variance
//! α/(m_p·b_p): α in the mapped domain, m_p the pair's multiplicity (its entries in the full
//! table) and b_p = ((L_p + κL̄)/((1 + κ)L̄))^β the bin's brightness weight, L_p its luminance
//! times cos θ_l cos θ_v and L̄ their mean over the painted bins. The log-mapped fit treats a
//! dark and a bright bin alike, but a render (and the relative error of the table) is made
//! of the bright ones; b_p gives them their say, and κ keeps the dark ones in the fit.
//!
//! **Why, and how the constants were chosen.** With one set (the global prior of Nielsen et
//! al.), a second and third painted view made a third of the held-out materials worse: their
//! two slices set a trend the database continues into unobserved θ_d (measured in
//! ../shared/findings and docs/BENCHMARKS.md). `burnish calibrate` scores candidate constants by
//! leave-families-out cross-validation on the database itself: bases built without a group of
//! families, scored on materials of those families, one and three views. Its first run (4 folds,
//! 24 materials, 31 candidates) confirmed α = 10, β = 1, κ = 0.3. A finer run over ρ (0.5 to
//! 0.999), the knot spacing ([`super::KnotSpacing`]) and the reach ℓ of nearby sets'
//! correlation ([`PriorModel::band_length`]) prefers ρ = 0.97 with knots uniform in
//! 1 − cos θ_d (geometric-mean relative RMSE 0.260 against 0.285 for the default; ℓ changes
//! nothing measurable). The default stays ρ = 0.9 with uniform knots all the same, because a
//! view must never make the BRDF worse: under ρ 0.97 (either spacing) and under cosine knots
//! at ρ 0.9, a second view doubles a Minnaert material's error in tests/pipeline.rs (0.126 →
//! 0.18 to 0.26) and three views are worse than one on the cross-validation's own cases about
//! as often. At ρ = 0.5 three views are never more than 10% worse than one there (0 of 48 cases,
//! against 9), but one view's mean relative RMSE rises to 0.501 from 0.459.
//!
//! **ρ from the evidence.** No one ρ suits every material, but the painted bins can say which
//! fits them, once they reach three or more knots (views at several θ_d): the solve compares
//! the marginal likelihood of the bins under the calibrated ρ and under
//! [`super::prior::EVIDENCE_BAND_CORRELATIONS`], and takes a tighter coupling only when it
//! makes the bins at least e³ (about 20) times more likely (`Solver::effective_model`). One
//! view's bins sit between two knots, where the comparison would follow noise, so one view
//! keeps the calibrated ρ and its figures are unchanged. Measured: cross-validation 3-view mean
//! relative RMSE 0.373 → 0.366 (median 0.242 → 0.230, hurt 9 → 8 of 48); the bench's held-out
//! set, three views 0.419 → 0.395 (median 0.355 → 0.285), a suggested second view 0.238 →
//! 0.205. Choosing ρ from 0.5 to 0.99 by evidence alone, one view included, made one view worse
//! (0.459 → 0.477); offered 0.5 and 0.7 beside 0.9 with the same margin, it never took
//! them on the folds, so only tighter couplings are candidates.
//!
//! **The prior's mean** is the database's mean material (all coefficients 0), a starting
//! material's projection (`Solver::set_prior_mean`). Under [`PriorMean::Fitted`] the bins are
//! measured instead from Lambert + a GGX or Beckmann lobe fitted to them ([`super::fitted_mean`]): y_p =
//! map(ρ_p) − map(F_p), and the reconstruction adds the coefficients' part back onto map(F).
//! The fit is too slow for the live loop, so it is installed apart
//! (`Solver::install_fitted_mean`) and taken only when the evidence favours it by the model's
//! margin, or its misfit is below the database mean's by the closer margin (the evidence,
//! weighed at the noise α, cannot tell two small misfits apart); taking or dropping it
//! re-measures every bin and rebuilds the normal equations.
//!
//! **Updates.** N = Σ_p w_p ψ_pψ_pᵀ and r_c = Σ_p w_p ψ_p y_pc are kept up to date one bin change
//! at a time (O(K²) when a bin appears, empties or its weight changes, O(K) when only its value
//! does), in f64, with an exact rebuild every [`Solver::REBUILD_INTERVAL`] changes and whenever
//! L̄, rounded to half octaves, changes (the weights then depend on the set of painted bins
//! alone, never on the order they were painted in).
//!
//! **Censored bins** (clipped LDR paint) are bounds, solved for by majorise–minimise (at most
//! [`Censoring::CALIBRATED`] steps). A bound the prior's own prediction meets is held at that
//! prediction, not at the clip, so that neither the solve nor the evidence for a fitted
//! reference is pulled down to a value the paint never gave. An upper bound that maps to a
//! narrow interval (a black 8-bit pixel) counts as a value instead (`Solver::pin_narrow_bounds`).

use super::analytic_fit::PaintedBin;
use super::bands::{BANDS, BandWeights};
use super::condition::{CONDITION_LIMIT, bounded_condition, inverse_norm_1_estimate, norm_1};
use super::fitted_mean::{FittedMean, FittedReference, MeanFitRequest, fit_options};
pub use super::posterior::Posterior;
pub use super::prior::{Censoring, DEFAULT_ALPHA, PriorMean, PriorModel, Regularization};
use super::sparse::{BinChange, Bound, Bounds, EXACT};
use crate::basis::Basis;
use crate::table::{PairIndex, cos_theta_centre, pair_directions};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Mat, Side};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

mod bounds;
mod evidence;

/// L̄ enters the weights rounded to a power of this step (log2), so the weights are a function
/// of the painted bins alone, whatever the order they came in: the incremental state equals a
/// batch build, and N is rebuilt only when the rounded L̄ changes.
const BRIGHTNESS_REFERENCE_STEP_LOG2: f64 = 0.5;
/// Brightness weights are rounded to powers of this step, so that repainting a bin with a
/// similar value changes only the right-hand side.
const BRIGHTNESS_STEP_LOG2: f64 = 0.25;

/// Coefficients and diagnostics of one solve.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The coefficient sets, band-major: rows `j·K..(j+1)·K` are X_j, (R, G, B) each. One set
    /// (K rows) for the global prior.
    pub coefficients: Vec<[f64; 3]>,
    /// The prior's α (or ridge λ) used.
    pub alpha: f64,
    /// The band correlation ρ used: the model's, or a stronger one the painted bins chose.
    pub band_correlation: f64,
    /// Condition number of the regularised normal matrix that was factored, in the 1-norm,
    /// estimated from its factor (see `inverse_norm_1_estimate`); between 1 and 1/ε.
    pub condition_number: f64,
    /// Observed bins the solve saw.
    pub observed_bins: usize,
    /// The fitted reference the coefficients are measured from (`None`: the basis's mean).
    pub reference: Option<Arc<FittedReference>>,
}

impl Solution {
    /// The BRDF these coefficients describe on `basis` (the solver's), reference included.
    pub fn reconstruction(&self, basis: Arc<Basis>) -> super::Reconstruction {
        super::Reconstruction::new(basis, &self.coefficients).with_reference(self.reference.clone())
    }
}

#[derive(Clone, Debug)]
struct Observed {
    row: Box<[f64]>,
    band: BandWeights,
    y: [f64; 3],
    /// The bin's value (after `Solver::pin_narrow_bounds`), for the fit of the prior's mean.
    rho: [f64; 3],
    /// Luminance × cos θ_l cos θ_v of the bin's value: its brightness L_p.
    brightness: f64,
    /// Multiplicity × brightness weight.
    weight: f64,
    /// Channels whose `y` is only a bound (clipped LDR paint).
    bounds: Bounds,
    /// How finely 8-bit paint knows `rho` ([`BinChange::rounding`]), for the fit.
    rounding: f64,
}

/// The incremental solver. Deterministic: its state depends on the set of observed bins
/// and the order of changes only, never on hashing or threads.
#[derive(Clone, Debug)]
pub struct Solver {
    basis: Arc<Basis>,
    regularization: Regularization,
    model: PriorModel,
    /// The prior's mean coefficients (a starting material's projection, K rows), or zero.
    prior_mean: Option<Vec<[f64; 3]>>,
    /// The last fitted reference installed ([`PriorMean::Fitted`]), used when no start is set.
    fitted: Option<InstalledMean>,
    /// Counts the changes of the observed bins, so that a fit knows which bins it saw.
    generation: u64,
    observed: BTreeMap<PairIndex, Observed>,
    /// Observed pairs with at least one bounded channel, solved for at [`Solver::solve`].
    censored: BTreeSet<PairIndex>,
    /// N, D × D row-major with D = bands × K.
    normal: Vec<f64>,
    rhs: Vec<[f64; 3]>,
    yty: [f64; 3],
    weight_sum: f64,
    /// Σ L_p over the observed bins, and the L̄ the weights were computed with.
    brightness_sum: f64,
    brightness_reference: f64,
    changes_since_rebuild: usize,
}

/// A fitted reference and whether the evidence took it.
#[derive(Clone, Debug)]
struct InstalledMean {
    generation: u64,
    /// `None` when the bins are not clearly more likely measured from it than from the
    /// database's mean.
    reference: Option<Arc<FittedReference>>,
}

/// Rec. 709 luminance × cos θ_l cos θ_v of a bin value: what it adds to a render.
fn bin_brightness(pair: PairIndex, rho: [f64; 3]) -> f64 {
    let (lo, hi) = pair_directions(pair);
    let luminance = 0.2126 * rho[0] + 0.7152 * rho[1] + 0.0722 * rho[2];
    (luminance * cos_theta_centre(lo) * cos_theta_centre(hi)).max(0.0)
}

impl Solver {
    /// Changes applied between exact rebuilds of the normal equations.
    pub const REBUILD_INTERVAL: usize = 1 << 16;

    /// A solver with the calibrated prior ([`PriorModel::CALIBRATED`]).
    pub fn new(basis: Arc<Basis>, regularization: Regularization) -> Self {
        Self::with_model(basis, regularization, PriorModel::CALIBRATED)
    }

    pub fn with_model(
        basis: Arc<Basis>,
        regularization: Regularization,
        model: PriorModel,
    ) -> Self {
        assert!(
            model.bands == 1 || model.bands == BANDS,
            "1 or {BANDS} coefficient sets"
        );
        assert!(model.bands == 1 || (0.0..1.0).contains(&model.band_correlation));
        super::sequential_dense_algebra();
        let d = model.rows(basis.components());
        Self {
            basis,
            regularization,
            model,
            prior_mean: None,
            fitted: None,
            generation: 0,
            observed: BTreeMap::new(),
            censored: BTreeSet::new(),
            normal: vec![0.0; d * d],
            rhs: vec![[0.0; 3]; d],
            yty: [0.0; 3],
            weight_sum: 0.0,
            brightness_sum: 0.0,
            brightness_reference: 0.0,
            changes_since_rebuild: 0,
        }
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    pub fn model(&self) -> PriorModel {
        self.model
    }

    pub fn regularization(&self) -> Regularization {
        self.regularization
    }

    pub fn set_regularization(&mut self, regularization: Regularization) {
        self.regularization = regularization;
    }

    /// Centres the prior on `mean` (K rows of R, G, B: a starting material's projection onto
    /// the basis), so that unpainted parts of the table keep that material; `None` centres it
    /// on the database's mean material. Rows past K are ignored, missing ones are zero.
    pub fn set_prior_mean(&mut self, mean: Option<Vec<[f64; 3]>>) {
        let k = self.basis.components();
        let before = self.reference_ptr();
        self.prior_mean = mean.map(|m| {
            (0..k)
                .map(|i| {
                    m.get(i)
                        .copied()
                        .unwrap_or([0.0; 3])
                        .map(|v| if v.is_finite() { v } else { 0.0 })
                })
                .collect()
        });
        if self.reference_ptr() != before {
            self.recentre();
        }
    }

    /// Where the prior is centred without a start ([`PriorModel::mean`]); a fitted mean
    /// installed for another rule is dropped.
    pub fn set_mean_kind(&mut self, mean: PriorMean) {
        if self.model.mean != mean {
            let before = self.reference_ptr();
            self.model.mean = mean;
            self.fitted = None;
            if self.reference_ptr() != before {
                self.recentre();
            }
        }
    }

    /// The prior's mean coefficients a starting material set, if any.
    pub fn prior_mean(&self) -> Option<&[[f64; 3]]> {
        self.prior_mean.as_deref()
    }

    /// The fitted reference the bins are measured from, when the model asks for one, no start
    /// is set and the evidence took it; `None`: the basis's mean. A reconstruction of this
    /// solver's coefficients must add it back ([`super::Solution::reconstruction`]).
    pub fn reference(&self) -> Option<&Arc<FittedReference>> {
        if self.prior_mean.is_some() {
            return None;
        }
        match self.model.mean {
            PriorMean::Database => None,
            PriorMean::Fitted { .. } => self.fitted.as_ref()?.reference.as_ref(),
        }
    }

    fn reference_ptr(&self) -> Option<*const FittedReference> {
        self.reference().map(Arc::as_ptr)
    }

    /// Re-measures every bin from the current reference and rebuilds the normal equations.
    fn recentre(&mut self) {
        let mut observed = std::mem::take(&mut self.observed);
        for (&pair, obs) in observed.iter_mut() {
            obs.y = self.measured(pair, obs.rho, obs.bounds);
        }
        self.observed = observed;
        self.rebuild();
    }

    /// What a fit of the prior's mean to the bins painted now needs, or `None` when the mean
    /// is current: the model centres on the database, a start is set, nothing is painted or
    /// the installed fit saw these very bins.
    pub fn mean_fit_request(&self) -> Option<MeanFitRequest> {
        if self.prior_mean_is_current() {
            return None;
        }
        Some(MeanFitRequest {
            generation: self.generation,
            bins: self
                .observed
                .iter()
                .map(|(&pair, obs)| PaintedBin {
                    pair,
                    rho: obs.rho,
                    bounds: obs.bounds,
                    rounding: obs.rounding,
                })
                .collect(),
            basis: self.basis.clone(),
            options: fit_options(self.model.mean),
        })
    }

    /// Installs a fitted mean, even one fitted to earlier bins (the best guess until the
    /// current fit arrives), and decides by the evidence whether the prior centres on it.
    /// Returns whether the mean the solve uses changed.
    pub fn install_fitted_mean(&mut self, fitted: FittedMean) -> bool {
        let newer = self
            .fitted
            .as_ref()
            .is_none_or(|f| f.generation < fitted.generation);
        if self.observed.is_empty()
            || !newer
            || fitted.generation > self.generation
            || !Arc::ptr_eq(fitted.reference.basis(), &self.basis)
        {
            return false;
        }
        let before = self.reference_ptr();
        let (margin, closer) = match self.model.mean {
            PriorMean::Fitted {
                margin_nats,
                closer_margin,
                ..
            } => (margin_nats, closer_margin),
            PriorMean::Database => (f64::INFINITY, None),
        };
        let reference = fitted.reference;
        let accepted = margin == f64::NEG_INFINITY || {
            let alpha = self.evidence_alpha();
            let rho = [self.model.band_correlation];
            let with = self.evidence_terms_from(alpha, Some(&reference), rho);
            let without = self.evidence_terms_from(alpha, None, rho);
            match (with.first(), without.first()) {
                (Some(with), Some(without)) => {
                    with.log_evidence - without.log_evidence > margin
                        || closer.is_some_and(|r| with.misfit * r * r <= without.misfit)
                }
                _ => false,
            }
        };
        self.fitted = Some(InstalledMean {
            generation: fitted.generation,
            reference: accepted.then_some(reference),
        });
        let changed = self.reference_ptr() != before;
        if changed {
            self.recentre();
        }
        changed
    }

    /// Fits, projects and installs the prior's mean for the bins painted now, if it is not
    /// current (see [`Self::mean_fit_request`]): what a one-shot solve calls before solving.
    pub fn refit_prior_mean(&mut self) {
        if let Some(request) = self.mean_fit_request() {
            let fitted = request.run();
            self.install_fitted_mean(fitted);
        }
    }

    /// Whether the prior's mean belongs to the bins painted now (no fit is due); O(1).
    pub fn prior_mean_is_current(&self) -> bool {
        self.model.mean == PriorMean::Database
            || self.prior_mean.is_some()
            || self.observed.is_empty()
            || self.fitted.as_ref().map(|f| f.generation) == Some(self.generation)
    }

    pub fn observed_bins(&self) -> usize {
        self.observed.len()
    }

    /// N (D × D, row-major, D = bands × K) and r (D rows of R, G, B), for inspection and tests.
    pub fn normal_equations(&self) -> (&[f64], &[[f64; 3]]) {
        (&self.normal, &self.rhs)
    }

    fn dimension(&self) -> usize {
        self.model.rows(self.basis.components())
    }

    /// y of a bin: its value mapped and measured from the reference (the basis's mean, or
    /// the fitted reference the bins are measured from).
    fn centred(&self, pair: PairIndex, rho: [f64; 3]) -> [f64; 3] {
        centred_from(&self.basis, self.reference().map(|r| &**r), pair, rho)
    }

    /// Multiplicity × the rounded brightness weight of a bin of brightness `brightness`.
    fn weight_of(&self, pair: PairIndex, brightness: f64) -> f64 {
        let m = crate::table::pair_multiplicity(pair);
        let (beta, kappa, mean) = (
            self.model.brightness_exponent,
            self.model.brightness_floor,
            self.brightness_reference,
        );
        if beta == 0.0 || mean.is_nan() || mean <= 0.0 {
            return m;
        }
        let b = ((brightness + kappa * mean) / ((1.0 + kappa) * mean)).powf(beta);
        let step = BRIGHTNESS_STEP_LOG2;
        m * ((b.log2() / step).round() * step).exp2()
    }

    /// Applies one bin change to the normal equations.
    pub fn apply(&mut self, change: &BinChange) {
        let pair = change.pair;
        let d = self.dimension();
        let clipped = change.bounds.contains(&Bound::AtLeast);
        let (after, bounds) = match change.after {
            Some(_) if clipped && self.model.censoring == Censoring::OmitClipped => (None, EXACT),
            Some(rho) => {
                let (rho, bounds) = self.pin_narrow_bounds(pair, rho, change.bounds);
                (Some(rho), bounds)
            }
            None => (None, EXACT),
        };
        if after.is_some() || self.observed.contains_key(&pair) {
            self.generation += 1;
        }
        match after {
            Some(rho) => {
                let y = self.measured(pair, rho, bounds);
                let brightness = bin_brightness(pair, rho);
                let weight = self.weight_of(pair, brightness);
                if let Some(mut obs) = self.observed.remove(&pair) {
                    self.brightness_sum += brightness - obs.brightness;
                    if weight == obs.weight {
                        // Same weight: only the right-hand side moves, O(K).
                        for (j, phi) in obs.band.pairs() {
                            if phi == 0.0 {
                                continue;
                            }
                            for c in 0..3 {
                                let dy = obs.weight * phi * (y[c] - obs.y[c]);
                                for (i, u) in obs.row.iter().enumerate() {
                                    self.rhs[j * obs.row.len() + i][c] += u * dy;
                                }
                            }
                        }
                        for c in 0..3 {
                            self.yty[c] += obs.weight * (y[c] * y[c] - obs.y[c] * obs.y[c]);
                        }
                    } else {
                        self.accumulate(&obs, -1.0, d);
                        obs.weight = weight;
                        obs.y = y;
                        self.accumulate(&obs, 1.0, d);
                    }
                    obs.y = y;
                    obs.rho = rho;
                    obs.brightness = brightness;
                    obs.bounds = bounds;
                    obs.rounding = change.rounding;
                    self.observed.insert(pair, obs);
                } else {
                    let row: Box<[f64]> = self.basis.row(pair).iter().map(|&u| u as f64).collect();
                    let obs = Observed {
                        row,
                        band: self.model.band_weights(pair),
                        y,
                        rho,
                        brightness,
                        weight,
                        bounds,
                        rounding: change.rounding,
                    };
                    self.accumulate(&obs, 1.0, d);
                    self.brightness_sum += brightness;
                    self.observed.insert(pair, obs);
                }
            }
            None => {
                if let Some(obs) = self.observed.remove(&pair) {
                    self.accumulate(&obs, -1.0, d);
                    self.brightness_sum -= obs.brightness;
                }
            }
        }
        if after.is_some() && bounds != EXACT {
            self.censored.insert(pair);
        } else {
            self.censored.remove(&pair);
        }
        self.changes_since_rebuild += 1;
        // With no bin left, exact zeros cost nothing and keep rounding residue from giving
        // an empty painting anything but the mean material.
        if self.changes_since_rebuild >= Self::REBUILD_INTERVAL
            || self.observed.is_empty()
            || self.brightness_drifted()
        {
            self.rebuild();
        }
        if self.observed.is_empty() {
            // An empty painting is the database's mean material (or the start), as ever.
            self.fitted = None;
        }
    }

    /// Applies a batch of changes in order.
    pub fn apply_all(&mut self, changes: &[BinChange]) {
        for change in changes {
            self.apply(change);
        }
    }

    /// L̄ of the painted bins, rounded to a power of 2^[`BRIGHTNESS_REFERENCE_STEP_LOG2`]
    /// (0 when nothing bright is painted).
    fn brightness_reference_now(&self) -> f64 {
        if self.observed.is_empty() {
            return 0.0;
        }
        let mean = self.brightness_sum / self.observed.len() as f64;
        if mean.is_nan() || mean <= 1e-12 {
            return 0.0;
        }
        let step = BRIGHTNESS_REFERENCE_STEP_LOG2;
        ((mean.log2() / step).round() * step).exp2()
    }

    /// True when the rounded L̄ is no longer the one the weights were computed with.
    fn brightness_drifted(&self) -> bool {
        self.model.brightness_exponent != 0.0
            && self.brightness_reference_now() != self.brightness_reference
    }

    /// Recomputes L̄, every weight and the normal equations exactly from the observed bins.
    pub fn rebuild(&mut self) {
        let d = self.dimension();
        self.normal.iter_mut().for_each(|v| *v = 0.0);
        self.rhs.iter_mut().for_each(|v| *v = [0.0; 3]);
        self.yty = [0.0; 3];
        self.weight_sum = 0.0;
        self.brightness_sum = self.observed.values().map(|o| o.brightness).sum();
        self.brightness_reference = self.brightness_reference_now();
        let mut observed = std::mem::take(&mut self.observed);
        for (&pair, obs) in observed.iter_mut() {
            obs.weight = self.weight_of(pair, obs.brightness);
            accumulate(
                &mut self.normal,
                &mut self.rhs,
                &mut self.yty,
                &mut self.weight_sum,
                obs,
                1.0,
                d,
            );
        }
        self.observed = observed;
        self.changes_since_rebuild = 0;
    }

    /// Adds (`sign` = 1) or removes (−1) one observation's terms.
    fn accumulate(&mut self, obs: &Observed, sign: f64, d: usize) {
        accumulate(
            &mut self.normal,
            &mut self.rhs,
            &mut self.yty,
            &mut self.weight_sum,
            obs,
            sign,
            d,
        );
    }

    /// P₀: the prior precision for unit α, D × D: 1/σ_k² times the band precision, between
    /// the same component of any two sets.
    /// P₀ for `model`'s band correlation.
    fn prior_precision_of(&self, model: &PriorModel) -> Mat<f64> {
        let k = self.basis.components();
        let d = self.dimension();
        let sigma = prior_scales(self.basis.variances());
        let mut p = Mat::<f64>::zeros(d, d);
        let bands = model.bands;
        let precision = model.band_precision();
        for a in 0..bands {
            for b in 0..bands {
                let t = precision[a * bands + b];
                for i in 0..k {
                    p[(a * k + i, b * k + i)] = t / (sigma[i] * sigma[i]);
                }
            }
        }
        p
    }

    /// The regularised normal matrix N + αP₀ (or N + λI), its right-hand side with the prior
    /// mean's pull, the α used and the model (its ρ as the evidence chose it).
    fn system(&self) -> (Mat<f64>, Mat<f64>, f64, PriorModel) {
        let d = self.dimension();
        let k = self.basis.components();
        let model = self.effective_model();
        let p0 = self.prior_precision_of(&model);
        let (alpha, prior): (f64, Mat<f64>) = match self.regularization {
            Regularization::Ridge { lambda } => (lambda, Mat::<f64>::identity(d, d) * lambda),
            Regularization::Prior { alpha } => (alpha, &p0 * alpha),
            Regularization::Auto => (DEFAULT_ALPHA, &p0 * DEFAULT_ALPHA),
            Regularization::Gcv => {
                let alpha = self.gcv_alpha(&p0).unwrap_or(DEFAULT_ALPHA);
                (alpha, &p0 * alpha)
            }
        };
        let mut m = Mat::<f64>::from_fn(d, d, |i, j| self.normal[i * d + j]);
        m += &prior;
        let mut rhs = Mat::<f64>::from_fn(d, 3, |i, c| self.rhs[i][c]);
        if let Some(mean) = self.prior_mean() {
            // A prior N(x₀, ·) on every set adds (αP₀)(1 ⊗ x₀) to the right-hand side.
            let x0 = Mat::<f64>::from_fn(d, 3, |i, c| mean[i % k][c]);
            rhs += &prior * &x0;
        }
        (m, rhs, alpha, model)
    }

    /// Solves for the coefficients. Always finite: with no observation it returns the prior's
    /// mean (the database's mean material, all coefficients 0, unless a start was set).
    pub fn solve(&self) -> Solution {
        let d = self.dimension();
        let (mut m, rhs, alpha, model) = self.system();
        let norm_1 = norm_1(&m);
        let llt = match m.llt(Side::Lower) {
            Ok(llt) => Some(llt),
            // N + αP₀ is positive definite for any positive α; this guards rounding.
            Err(_) => {
                let jitter = m.norm_max() * 1e-12 + 1e-300;
                for i in 0..d {
                    m[(i, i)] += jitter;
                }
                m.llt(Side::Lower).ok()
            }
        };
        let (x, condition_number) = match llt {
            Some(llt) => {
                let mut x = llt.solve(&rhs);
                self.enforce_bounds(&mut x, &rhs, |b| llt.solve(b));
                let inverse_norm_1 = inverse_norm_1_estimate(d, |b| llt.solve(b));
                (x, bounded_condition(norm_1 * inverse_norm_1))
            }
            None => (Mat::zeros(d, 3), CONDITION_LIMIT),
        };
        let coefficients = (0..d)
            .map(|i| {
                std::array::from_fn(|c| {
                    if x[(i, c)].is_finite() {
                        x[(i, c)]
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Solution {
            coefficients,
            alpha,
            band_correlation: model.band_correlation,
            condition_number,
            observed_bins: self.observed.len(),
            reference: self.reference().cloned(),
        }
    }

    /// The posterior of the coefficients: covariance α(N + αP₀)⁻¹ (the likelihood's precision
    /// is N/α, the prior's P₀). For the uncertainty of the table and the choice of a next view.
    pub fn posterior(&self) -> Posterior {
        let d = self.dimension();
        let (m, _, alpha, model) = self.system();
        let covariance = match m.llt(Side::Lower) {
            Ok(llt) => llt.inverse() * alpha,
            Err(_) => Mat::<f64>::zeros(d, d),
        };
        Posterior {
            model,
            components: self.basis.components(),
            alpha,
            precision: m * (1.0 / alpha),
            covariance,
        }
    }

    /// Observations a new view would add, as the solver would weigh them: (pair, weight)
    /// with `predicted` values (the current reconstruction's) standing in for the paint.
    pub fn prospective_weight(&self, pair: PairIndex, predicted: [f64; 3]) -> f64 {
        self.weight_of(pair, bin_brightness(pair, predicted))
    }
}

/// y of a bin of value `rho`, measured from `reference` (`None`: the basis's mean).
fn centred_from(
    basis: &Basis,
    reference: Option<&FittedReference>,
    pair: PairIndex,
    rho: [f64; 3],
) -> [f64; 3] {
    match reference {
        None => rho.map(|v| basis.centred_observation(pair, v)),
        Some(reference) => {
            let offset = reference.offset(pair);
            std::array::from_fn(|c| basis.centred_residual(pair, rho[c], offset[c] as f64))
        }
    }
}

/// Adds (`sign` = 1) or removes (−1) one observation's terms w·ψψᵀ, w·ψy and w·y².
fn accumulate(
    normal: &mut [f64],
    rhs: &mut [[f64; 3]],
    yty: &mut [f64; 3],
    weight_sum: &mut f64,
    obs: &Observed,
    sign: f64,
    d: usize,
) {
    let k = obs.row.len();
    let w = sign * obs.weight;
    let blocks = obs.band.pairs();
    for &(ja, pa) in &blocks {
        if pa == 0.0 {
            continue;
        }
        for &(jb, pb) in &blocks {
            if pb == 0.0 {
                continue;
            }
            let s = w * pa * pb;
            for i in 0..k {
                let su = s * obs.row[i];
                let base = (ja * k + i) * d + jb * k;
                for (n, u) in normal[base..base + k].iter_mut().zip(obs.row.iter()) {
                    *n += su * u;
                }
            }
        }
    }
    accumulate_measurement(rhs, yty, obs, obs.y, w);
    *weight_sum += w;
}

/// Adds one observation's w·ψy and w·y² for the measurement `y` (its own `y`, or the same bin
/// measured from another reference).
fn accumulate_measurement(
    rhs: &mut [[f64; 3]],
    yty: &mut [f64; 3],
    obs: &Observed,
    y: [f64; 3],
    w: f64,
) {
    let k = obs.row.len();
    for (ja, pa) in obs.band.pairs() {
        if pa == 0.0 {
            continue;
        }
        for i in 0..k {
            let wu = w * pa * obs.row[i];
            for c in 0..3 {
                rhs[ja * k + i][c] += wu * y[c];
            }
        }
    }
    for c in 0..3 {
        yty[c] += w * y[c] * y[c];
    }
}

/// Prior standard deviation per component, floored so that a degenerate component
/// gets a huge but finite penalty.
fn prior_scales(variances: &[f64]) -> Vec<f64> {
    let top = variances
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    variances
        .iter()
        .map(|v| v.max(top * 1e-12).sqrt())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::small_test_basis;
    use crate::materials::tabulate;
    use crate::solver::analytic_fit::{Distribution, LambertMicrofacet, Masking};
    use crate::table::{DIRECTIONS, PAIRS, bin_centre, pair_multiplicity};
    use std::sync::OnceLock;

    /// The calibrated prior centred on the database's mean, with ρ kept as configured: no fit
    /// is due and the evidence chooses nothing, so the solve's system is the model's own.
    const MODEL: PriorModel = PriorModel {
        mean: PriorMean::Database,
        correlation_by_evidence: false,
        ..PriorModel::CALIBRATED
    };

    /// The product of the cosines of a pair's two bin centres, from the centres themselves.
    fn cosines(pair: PairIndex) -> f64 {
        let (lo, hi) = pair_directions(pair);
        bin_centre(lo).z * bin_centre(hi).z
    }

    /// w_p written out from the module's formula: m_p × ((L_p + κL̄)/((1 + κ)L̄))^β rounded to a
    /// quarter octave, L̄ the painted bins' mean L_p rounded to a half octave (no weighting when
    /// β = 0 or nothing bright is painted).
    fn expected_weight(model: &PriorModel, pair: PairIndex, brightness: f64, mean: f64) -> f64 {
        let m = pair_multiplicity(pair);
        if model.brightness_exponent == 0.0 || mean <= 1e-12 {
            return m;
        }
        let reference = 2f64.powf((2.0 * mean.log2()).round() / 2.0);
        let kappa = model.brightness_floor;
        let b = ((brightness + kappa * reference) / ((1.0 + kappa) * reference))
            .powf(model.brightness_exponent);
        m * 2f64.powf((4.0 * b.log2()).round() / 4.0)
    }

    /// ψ_p: the basis row u_p on the sets the pair's θ_d blends.
    fn design_row(model: &PriorModel, basis: &Basis, pair: PairIndex) -> Vec<f64> {
        let k = basis.components();
        let mut psi = vec![0.0; model.rows(k)];
        for (j, phi) in model.band_weights(pair).pairs() {
            // One set's second weight is zero, and names no set.
            if phi == 0.0 {
                continue;
            }
            for (i, &u) in basis.row(pair).iter().enumerate() {
                psi[j * k + i] += phi * u as f64;
            }
        }
        psi
    }

    /// N, r, yᵀWy and Σw summed bin by bin.
    struct Expected {
        normal: Vec<f64>,
        rhs: Vec<[f64; 3]>,
        yty: [f64; 3],
        weight_sum: f64,
    }

    /// The sums over `bins` (value and bounds per pair), each bin measured from `reference`
    /// (`None`: the basis's mean), a bounded channel at the prior's zero where that meets
    /// the bound.
    fn expected_from(
        model: &PriorModel,
        basis: &Basis,
        reference: Option<&FittedReference>,
        bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>,
    ) -> Expected {
        let d = model.rows(basis.components());
        let brightness = |pair: PairIndex, rho: [f64; 3]| {
            ((0.2126 * rho[0] + 0.7152 * rho[1] + 0.0722 * rho[2]) * cosines(pair)).max(0.0)
        };
        let mean = bins
            .iter()
            .map(|(&pair, &(rho, _))| brightness(pair, rho))
            .sum::<f64>()
            / bins.len().max(1) as f64;
        let mut e = Expected {
            normal: vec![0.0; d * d],
            rhs: vec![[0.0; 3]; d],
            yty: [0.0; 3],
            weight_sum: 0.0,
        };
        for (&pair, &(rho, bounds)) in bins {
            let w = expected_weight(model, pair, brightness(pair, rho), mean);
            let psi = design_row(model, basis, pair);
            let y: [f64; 3] = std::array::from_fn(|c| {
                let y = match reference {
                    None => basis.centred_observation(pair, rho[c]),
                    Some(r) => basis.centred_residual(pair, rho[c], r.offset(pair)[c] as f64),
                };
                match bounds[c] {
                    Bound::Exact => y,
                    Bound::AtLeast => y.max(0.0),
                    Bound::AtMost => y.min(0.0),
                }
            });
            for a in 0..d {
                for b in 0..d {
                    e.normal[a * d + b] += w * psi[a] * psi[b];
                }
                for c in 0..3 {
                    e.rhs[a][c] += w * psi[a] * y[c];
                }
            }
            for c in 0..3 {
                e.yty[c] += w * y[c] * y[c];
            }
            e.weight_sum += w;
        }
        e
    }

    /// The largest difference of two lists against the larger's largest magnitude (at least
    /// `floor`).
    fn relative_gap(a: &[f64], b: &[f64], floor: f64) -> f64 {
        assert_eq!(a.len(), b.len());
        let scale = a.iter().chain(b).fold(floor, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
            / scale
    }

    /// The solver's N, r, yᵀWy and Σw against the bin-by-bin sums of `bins`.
    fn assert_holds(solver: &Solver, bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>, at: &str) {
        assert_holds_from(solver, None, bins, at);
    }

    /// As [`assert_holds`], each bin measured from `reference`.
    fn assert_holds_from(
        solver: &Solver,
        reference: Option<&FittedReference>,
        bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>,
        at: &str,
    ) {
        let e = expected_from(&solver.model, &solver.basis, reference, bins);
        let (normal, rhs) = solver.normal_equations();
        let gap = relative_gap(normal, &e.normal, 1e-300);
        assert!(gap < 1e-10, "{at}: N off by {gap:e}");
        let flat = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
        let gap = relative_gap(&flat(rhs), &flat(&e.rhs), 1e-300);
        assert!(gap < 1e-10, "{at}: r off by {gap:e}");
        let gap = relative_gap(&solver.yty, &e.yty, 1e-300);
        assert!(gap < 1e-10, "{at}: yᵀWy off by {gap:e}");
        let gap = relative_gap(&[solver.weight_sum], &[e.weight_sum], 1e-300);
        assert!(gap < 1e-12, "{at}: Σw off by {gap:e}");
        let censored: BTreeSet<PairIndex> = bins
            .iter()
            .filter(|(_, (_, bounds))| *bounds != EXACT)
            .map(|(&pair, _)| pair)
            .collect();
        assert_eq!(solver.censored, censored, "{at}: censored bins");
        assert_eq!(solver.observed_bins(), bins.len(), "{at}");
    }

    /// L_p is the Rec. 709 luminance of the value times cos θ_l cos θ_v of the pair's bin
    /// centres: linear in the value, and nothing for a value darker than black.
    #[test]
    fn a_bins_brightness_is_its_luminance_lit_and_seen_at_its_angles() {
        for pair in [12_345, 777_777, PAIRS - 1].map(PairIndex::from_index) {
            let c = cosines(pair);
            assert!(c > 0.0 && c < 1.0, "{pair}: {c}");
            for (rho, luminance) in [
                ([1.0, 0.0, 0.0], 0.2126),
                ([0.0, 1.0, 0.0], 0.7152),
                ([0.0, 0.0, 1.0], 0.0722),
                ([0.5, 2.0, 4.0], 0.1063 + 1.4304 + 0.2888),
            ] {
                let l = bin_brightness(pair, rho);
                assert!(
                    (l - luminance * c).abs() <= 1e-12 * l,
                    "{pair} {rho:?}: {l}"
                );
            }
            assert_eq!(bin_brightness(pair, [-1.0, -1.0, -1.0]), 0.0);
        }
    }

    /// Paint, repaint at the same and at another brightness, clipped paint and erasure, in
    /// an order that moves L̄ across several half octaves and back: after every change the
    /// normal equations are the bin-by-bin sums over the bins painted now, each weighted by
    /// m_p b_p with L̄ of those bins alone, whatever the order of the changes.
    #[test]
    fn every_change_leaves_the_normal_equations_of_the_bins_painted_now() {
        let basis = small_test_basis();
        let mut solver = Solver::with_model(basis.clone(), Regularization::Auto, MODEL);
        let pairs: Vec<PairIndex> = (0..24)
            .map(|i| PairIndex::from_index((i * 1_299_709 + 4_321) % PAIRS))
            .collect();
        let mut bins = BTreeMap::new();
        let colour = |i: usize| [0.3, 0.5, 0.2].map(|v| v * (1.0 + 0.1 * (i % 3) as f64));
        for step in 0..240 {
            let i = step * 7 % pairs.len();
            let pair = pairs[i];
            // Brightness swings by orders of magnitude in slow waves, so L̄ drifts both ways.
            let scale = [0.02, 0.2, 2.0, 20.0][(step / 30) % 4] * (1.0 + 0.001 * (step % 5) as f64);
            let change = match step % 9 {
                0 => BinChange {
                    pair,
                    before: None,
                    after: None,
                    bounds: EXACT,
                    rounding: 0.0,
                    inconsistent: false,
                },
                4 => {
                    let bounds = [Bound::AtLeast, Bound::Exact, Bound::AtLeast];
                    BinChange::observed(pair, colour(i).map(|v| v * scale), bounds)
                }
                _ => BinChange::observed(pair, colour(i).map(|v| v * scale), EXACT),
            };
            match change.after {
                Some(rho) => bins.insert(pair, (rho, change.bounds)),
                None => bins.remove(&pair),
            };
            solver.apply(&change);
            assert_holds(&solver, &bins, &format!("step {step}"));
        }
        // The same value again, a value within the same quarter octave of weight, and a much
        // brighter one: the first two move only the right-hand side.
        let pair = *bins.keys().next().expect("bins are painted");
        let rho = bins[&pair].0;
        for factor in [1.0, 1.0001, 50.0] {
            let after = rho.map(|v| v * factor);
            bins.insert(pair, (after, EXACT));
            solver.apply(&BinChange::observed(pair, after, EXACT));
            assert_holds(&solver, &bins, &format!("× {factor}"));
        }
        // Erasing everything leaves exact zeros, not rounding residue.
        for pair in bins.keys().copied().collect::<Vec<_>>() {
            bins.remove(&pair);
            solver.apply(&BinChange {
                pair,
                before: None,
                after: None,
                bounds: EXACT,
                rounding: 0.0,
                inconsistent: false,
            });
            assert_holds(&solver, &bins, &format!("erasing {pair}"));
        }
        let (normal, rhs) = solver.normal_equations();
        assert!(normal.iter().all(|&v| v == 0.0));
        assert!(rhs.iter().flatten().all(|&v| v == 0.0));
        assert_eq!((solver.yty, solver.weight_sum), ([0.0; 3], 0.0));
    }

    /// The sums over `bins`, each measured from the basis's mean.
    fn expected(
        model: &PriorModel,
        basis: &Basis,
        bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>,
    ) -> Expected {
        expected_from(model, basis, None, bins)
    }

    /// A model's P₀ written out: the inverse of the equicorrelated (1 − ρ)I + ρ11ᵀ across the
    /// B sets, (I − ρ/(1 − ρ + Bρ)·11ᵀ)/(1 − ρ), over σ_k² between the same component of two sets.
    fn closed_form_precision(model: &PriorModel, basis: &Basis) -> Mat<f64> {
        assert_eq!(model.band_length, 0.0, "the equicorrelated prior");
        let (k, b, rho) = (basis.components(), model.bands, model.band_correlation);
        let variances = basis.variances();
        Mat::<f64>::from_fn(b * k, b * k, |p, q| {
            if p % k != q % k {
                return 0.0;
            }
            let diagonal = if p / k == q / k { 1.0 } else { 0.0 };
            // One set has no correlation to invert (ρ is 1 there by convention).
            let inverse = if b == 1 {
                1.0
            } else {
                (diagonal - rho / (1.0 - rho + b as f64 * rho)) / (1.0 - rho)
            };
            inverse / variances[p % k]
        })
    }

    /// Bins spread over every θ_d with values of a few colours and brightnesses.
    fn painted_bins(count: usize) -> BTreeMap<PairIndex, ([f64; 3], Bounds)> {
        (0..count)
            .map(|i| {
                let pair = PairIndex::from_index((i * 7_919 * 131 + 17) % PAIRS);
                let rho = [0.2, 0.4, 0.1].map(|v| v * (1.0 + (i % 7) as f64));
                (pair, (rho, EXACT))
            })
            .collect()
    }

    fn solver_with(
        model: PriorModel,
        regularization: Regularization,
        bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>,
    ) -> Solver {
        let mut solver = Solver::with_model(small_test_basis(), regularization, model);
        for (&pair, &(rho, bounds)) in bins {
            solver.apply(&BinChange::observed(pair, rho, bounds));
        }
        solver
    }

    /// The solve is the dense solution of (N + αP₀)x = r + αP₀(1 ⊗ x₀) for the prior, of
    /// (N + λI)x = r + λ(1 ⊗ x₀) for plain ridge, with N and r summed bin by bin, P₀ in
    /// closed form and x₀ a start; its condition number is that of the matrix it factored
    /// (the estimate never exceeds it and, for these, comes within a factor of 3).
    #[test]
    fn the_solve_is_the_dense_solution_of_the_regularised_system() {
        let basis = small_test_basis();
        let k = basis.components();
        let bins = painted_bins(60);
        let start: Vec<[f64; 3]> = basis
            .variances()
            .iter()
            .map(|v| [0.4 * v.sqrt(), -0.2 * v.sqrt(), 0.1 * v.sqrt()])
            .collect();
        for model in [MODEL, PriorModel::GLOBAL] {
            let d = model.rows(k);
            let e = expected(&model, &basis, &bins);
            let n = Mat::<f64>::from_fn(d, d, |i, j| e.normal[i * d + j]);
            let r = Mat::<f64>::from_fn(d, 3, |i, c| e.rhs[i][c]);
            let x0 = Mat::<f64>::from_fn(d, 3, |i, c| start[i % k][c]);
            let p0 = closed_form_precision(&model, &basis);
            for (regularization, alpha, prior) in [
                (Regularization::Prior { alpha: 0.7 }, 0.7, &p0 * 0.7),
                (Regularization::Auto, DEFAULT_ALPHA, &p0 * DEFAULT_ALPHA),
                (
                    Regularization::Ridge { lambda: 0.05 },
                    0.05,
                    Mat::<f64>::identity(d, d) * 0.05,
                ),
            ] {
                for mean in [None, Some(&x0)] {
                    let mut solver = solver_with(model, regularization, &bins);
                    solver.set_prior_mean(mean.map(|_| start.clone()));
                    let m = &n + &prior;
                    let rhs = match mean {
                        Some(x0) => &r + &prior * x0,
                        None => r.clone(),
                    };
                    let lu = m.partial_piv_lu();
                    let want = lu.solve(&rhs);
                    let solution = solver.solve();
                    let at = format!("{model:?} {regularization} start {}", mean.is_some());
                    let got: Vec<f64> = solution.coefficients.iter().flatten().copied().collect();
                    let want: Vec<f64> = (0..d)
                        .flat_map(|i| (0..3).map(move |c| (i, c)))
                        .map(|(i, c)| want[(i, c)])
                        .collect();
                    let gap = relative_gap(&got, &want, 1e-300);
                    assert!(gap < 1e-9, "{at}: x off by {gap:e}");
                    assert_eq!(solution.alpha, alpha, "{at}");
                    assert_eq!(solution.band_correlation, model.band_correlation, "{at}");
                    assert_eq!(solution.observed_bins, bins.len(), "{at}");
                    assert!(solution.reference.is_none(), "{at}");
                    let inverse = lu.inverse();
                    let norm = |a: &Mat<f64>| {
                        (0..d)
                            .map(|j| (0..d).map(|i| a[(i, j)].abs()).sum::<f64>())
                            .fold(0.0, f64::max)
                    };
                    let condition = norm(&m) * norm(&inverse);
                    assert!(
                        solution.condition_number <= condition * (1.0 + 1e-9)
                            && solution.condition_number >= condition / 3.0,
                        "{at}: condition {} vs {condition}",
                        solution.condition_number
                    );
                }
            }
        }
    }

    /// With nothing painted the solve is the prior's mean exactly: every set the start.
    #[test]
    fn an_empty_painting_solves_to_the_start_in_every_set() {
        let basis = small_test_basis();
        let k = basis.components();
        let start: Vec<[f64; 3]> = (0..k)
            .map(|i| [0.3 / (i + 1) as f64, -0.2, 0.1 * i as f64])
            .collect();
        let mut solver = Solver::with_model(basis, Regularization::Auto, MODEL);
        solver.set_prior_mean(Some(start.clone()));
        let solution = solver.solve();
        assert_eq!(solution.coefficients.len(), MODEL.rows(k));
        for (i, x) in solution.coefficients.iter().enumerate() {
            for c in 0..3 {
                assert!((x[c] - start[i % k][c]).abs() < 1e-12, "row {i}: {x:?}");
            }
        }
    }

    /// A start is kept as K rows: rows past K are dropped, missing ones and non-finite
    /// values are zero; `None` centres the prior on the database's mean again.
    #[test]
    fn a_start_is_kept_as_k_finite_rows() {
        let mut solver = Solver::with_model(small_test_basis(), Regularization::Auto, MODEL);
        assert_eq!(solver.prior_mean(), None);
        let k = solver.basis().components();
        assert_eq!(k, 4);
        solver.set_prior_mean(Some(vec![[1.0, f64::NAN, 2.0], [f64::INFINITY, 3.0, -4.0]]));
        let want = [[1.0, 0.0, 2.0], [0.0, 3.0, -4.0], [0.0; 3], [0.0; 3]];
        assert_eq!(solver.prior_mean(), Some(&want[..]));
        solver.set_prior_mean(Some(vec![[0.5; 3]; 6]));
        assert_eq!(solver.prior_mean(), Some(&[[0.5; 3]; 4][..]));
        solver.set_prior_mean(None);
        assert_eq!(solver.prior_mean(), None);
    }

    /// Plain ridge with λ = 0 leaves the unobserved sets singular: the factorisation fails
    /// and the solve adds a jitter of 1e-12 of the matrix's largest entry, so the observed set
    /// is the least-squares fit of its bins and the others stay zero. With nothing painted at
    /// all the matrix is zero, and the jitter's floor alone makes it factorable.
    #[test]
    fn a_singular_system_is_solved_with_a_jitter_of_its_rounding() {
        let basis = small_test_basis();
        let k = basis.components();
        let bands = |p: PairIndex| MODEL.band_weights(p);
        // Pairs of one direction with itself: θ_d = 0, on the first knot alone.
        let on_first_knot: BTreeMap<PairIndex, ([f64; 3], Bounds)> = (0..DIRECTIONS)
            .step_by(DIRECTIONS / 12)
            .map(|d| PairIndex::from_index(d * (d + 1) / 2 + d))
            .inspect(|p| assert_eq!((bands(*p).lower, bands(*p).frac), (0, 0.0)))
            .enumerate()
            .map(|(i, p)| (p, ([0.1, 0.3, 0.2].map(|v| v * (1 + i % 4) as f64), EXACT)))
            .collect();
        let ridge = Regularization::Ridge { lambda: 0.0 };
        let solver = solver_with(MODEL, ridge, &on_first_knot);
        let e = expected(&MODEL, &basis, &on_first_knot);
        let d = MODEL.rows(k);
        let n = Mat::<f64>::from_fn(k, k, |i, j| e.normal[i * d + j]);
        let r = Mat::<f64>::from_fn(k, 3, |i, c| e.rhs[i][c]);
        let want = n.partial_piv_lu().solve(&r);
        let solution = solver.solve();
        let x = &solution.coefficients;
        for i in 0..k {
            for c in 0..3 {
                let gap = (x[i][c] - want[(i, c)]).abs();
                assert!(gap < 1e-6 * want[(i, c)].abs().max(1.0), "{i} {c}: {x:?}");
            }
        }
        assert!(x[k..].iter().flatten().all(|&v| v == 0.0), "{x:?}");
        assert!(solution.condition_number < CONDITION_LIMIT);

        let empty = Solver::with_model(basis, ridge, MODEL).solve();
        assert!(empty.coefficients.iter().flatten().all(|&v| v == 0.0));
        assert_eq!(empty.condition_number, 1.0);
    }

    /// Where the prior has a degenerate component, its scale is floored at 1e-6 of the
    /// largest (a variance 1e-12 of the largest): a huge but finite penalty.
    #[test]
    fn a_degenerate_component_gets_a_floored_prior_scale() {
        let close = |got: Vec<f64>, want: &[f64]| {
            assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() <= 1e-12 * w, "{got:?} vs {want:?}");
            }
        };
        close(prior_scales(&[4.0, 0.0, 1.0]), &[2.0, 2e-6, 1.0]);
        close(prior_scales(&[9.0, 1e-20, 0.25]), &[3.0, 3e-6, 0.5]);
        let none = prior_scales(&[0.0, 0.0]);
        assert!(none.iter().all(|&s| s > 0.0 && s.is_finite()), "{none:?}");
    }

    /// An orange plastic, and one rougher: models the fitted mean's own family can hold.
    fn plastic(roughness: f64) -> LambertMicrofacet {
        LambertMicrofacet {
            albedo: [0.6, 0.3, 0.1],
            sigma: 0.0,
            f0: [0.04; 3],
            specular: 1.0,
            distribution: Distribution::Ggx,
            alpha_x: roughness,
            alpha_y: roughness,
            rotation: 0.0,
            coat: None,
            haze: None,
            edge: None,
            masking: Masking::Smith,
        }
    }

    /// The references of the smooth and the rough plastic on the test basis, built once.
    fn references() -> &'static [Arc<FittedReference>; 2] {
        static REFERENCES: OnceLock<[Arc<FittedReference>; 2]> = OnceLock::new();
        REFERENCES.get_or_init(|| {
            [0.2, 0.5].map(|a| Arc::new(FittedReference::new(small_test_basis(), plastic(a))))
        })
    }

    /// Every 997th bin of the smooth plastic's table.
    fn plastic_bins() -> BTreeMap<PairIndex, ([f64; 3], Bounds)> {
        let table = tabulate(&plastic(0.2));
        (0..PAIRS)
            .step_by(997)
            .map(|p| {
                (
                    PairIndex::from_index(p),
                    (table.pairs()[p].map(f64::from), EXACT),
                )
            })
            .collect()
    }

    /// The calibrated prior centred on a fitted mean taken past `margin_nats`.
    fn fitted_model(margin_nats: f64) -> PriorModel {
        PriorModel {
            mean: PriorMean::Fitted {
                margin_nats,
                beckmann_margin: None,
                coat_margin: None,
                edge_margin: None,
                haze_margin: None,
                rough_margin: None,
                grazing_weight: None,
                dielectric_margin: None,
                phong_margin: None,
                gtr_margin: None,
                closer_margin: None,
                cavity_margin: None,
            },
            ..MODEL
        }
    }

    /// A fit is installed only when it is newer than the installed one, no newer than the
    /// bins and for a painting at all; once installed (taken or not) no fit is due until
    /// the bins change. Taken, it re-measures every bin from the reference.
    #[test]
    fn a_fitted_mean_is_installed_only_when_it_is_the_newest_fit_of_these_bins() {
        let [smooth, rough] = references();
        let bins = plastic_bins();
        let fit = |generation: u64, reference: &Arc<FittedReference>| FittedMean {
            generation,
            reference: reference.clone(),
        };
        let always = fitted_model(f64::NEG_INFINITY);
        let mut empty = Solver::with_model(small_test_basis(), Regularization::Auto, always);
        assert!(empty.prior_mean_is_current() && empty.mean_fit_request().is_none());
        assert!(!empty.install_fitted_mean(fit(0, smooth)));
        assert!(empty.reference().is_none());

        let mut solver = solver_with(always, Regularization::Auto, &bins);
        // Each painted bin is one change of the painting.
        let generation = bins.len() as u64;
        assert_eq!(solver.generation, generation);
        assert!(!solver.prior_mean_is_current());
        let request = solver.mean_fit_request().expect("a fit is due");
        assert_eq!(
            (request.generation, request.bins()),
            (generation, bins.len())
        );
        // A fit of bins not yet painted is refused.
        assert!(!solver.install_fitted_mean(fit(generation + 1, smooth)));
        assert!(solver.reference().is_none() && !solver.prior_mean_is_current());
        assert_holds_from(&solver, None, &bins, "refused");

        assert!(solver.install_fitted_mean(fit(generation, smooth)));
        assert!(Arc::ptr_eq(solver.reference().expect("taken"), smooth));
        assert!(solver.prior_mean_is_current() && solver.mean_fit_request().is_none());
        assert_holds_from(&solver, Some(&**smooth), &bins, "taken");
        let solution = solver.solve();
        assert!(Arc::ptr_eq(
            solution.reference.as_ref().expect("taken"),
            smooth
        ));
        // A second fit of the same bins is not newer.
        assert!(!solver.install_fitted_mean(fit(generation, rough)));
        assert!(Arc::ptr_eq(solver.reference().expect("kept"), smooth));

        // A repaint makes a fit due again; an older fit is still the best guess until then.
        let (&pair, &(rho, _)) = bins.iter().next().expect("bins are painted");
        let mut repainted = bins.clone();
        repainted.insert(pair, (rho.map(|v| 2.0 * v), EXACT));
        solver.apply(&BinChange::observed(pair, rho.map(|v| 2.0 * v), EXACT));
        assert_eq!(solver.generation, generation + 1);
        assert!(!solver.prior_mean_is_current());
        assert_eq!(
            solver.mean_fit_request().map(|r| r.generation),
            Some(generation + 1)
        );
        assert_holds_from(&solver, Some(&**smooth), &repainted, "repainted");
        assert!(solver.install_fitted_mean(fit(generation + 1, rough)));
        assert!(Arc::ptr_eq(solver.reference().expect("taken"), rough));
        assert_holds_from(&solver, Some(&**rough), &repainted, "refitted");

        // Erasing every bin drops the fit: the next painting starts from the database's mean.
        for &pair in repainted.keys() {
            solver.apply(&BinChange {
                pair,
                before: None,
                after: None,
                bounds: EXACT,
                rounding: 0.0,
                inconsistent: false,
            });
        }
        solver.apply(&BinChange::observed(pair, rho, EXACT));
        assert!(solver.reference().is_none() && !solver.prior_mean_is_current());
    }

    /// A solver of `model` over `bins` given the fit `reference`: whether it takes it must be
    /// `taken`, and either way the fit is installed and the bins are held from what is taken.
    fn assert_installs_taken(
        model: PriorModel,
        reference: &Arc<FittedReference>,
        bins: &BTreeMap<PairIndex, ([f64; 3], Bounds)>,
        taken: bool,
        label: &str,
    ) {
        let mut solver = solver_with(model, Regularization::Auto, bins);
        let fitted = FittedMean {
            generation: solver.generation,
            reference: reference.clone(),
        };
        assert_eq!(solver.install_fitted_mean(fitted), taken, "{label}");
        assert_eq!(solver.reference().is_some(), taken, "{label}");
        assert!(solver.prior_mean_is_current(), "{label}");
        assert_holds_from(&solver, taken.then_some(&**reference), bins, label);
    }

    /// The evidence's terms for the plastic's bins, measured from `reference` and from the
    /// database's mean, at the calibrated prior's α and ρ.
    fn plastic_evidence_with_and_without(
        reference: &FittedReference,
    ) -> (evidence::EvidenceTerms, evidence::EvidenceTerms) {
        let probe = solver_with(fitted_model(0.0), Regularization::Auto, &plastic_bins());
        let alpha = probe.evidence_alpha();
        let rho = [MODEL.band_correlation];
        (
            probe.evidence_terms_from(alpha, Some(reference), rho)[0],
            probe.evidence_terms_from(alpha, None, rho)[0],
        )
    }

    /// The fitted reference is taken exactly when it makes the bins more than e^margin times
    /// as likely as the database's mean does (the evidence is checked against the marginal
    /// likelihood in `evidence`); under the database's mean it never is. Either way the fit
    /// is installed, and none is due until the bins change.
    #[test]
    fn a_fitted_mean_is_taken_only_past_the_evidence_margin() {
        let [smooth, _] = references();
        let bins = plastic_bins();
        let (with, without) = plastic_evidence_with_and_without(smooth);
        let gain = with.log_evidence - without.log_evidence;
        assert!(
            gain > 10.0,
            "the plastic's own reference explains its bins: {gain}"
        );
        for (model, taken) in [
            (fitted_model(gain - 1.0), true),
            (fitted_model(gain + 1.0), false),
            (MODEL, false),
        ] {
            assert_installs_taken(model, smooth, &bins, taken, &format!("{:?}", model.mean));
        }
    }

    /// Past the evidence, a fit is taken where the painted bins' misfit under it is below the
    /// database mean's by the closer margin squared (the margin is in root): a fit that
    /// explains the bins that much more closely, however little the evidence gains.
    #[test]
    fn a_fitted_mean_that_explains_the_bins_more_closely_is_taken_past_its_margin() {
        let [smooth, _] = references();
        let bins = plastic_bins();
        let (with, without) = plastic_evidence_with_and_without(smooth);
        assert!(with.misfit >= 0.0 && without.misfit > 0.0);
        let closer = (without.misfit / with.misfit.max(1e-300)).sqrt();
        assert!(
            closer > 2.0,
            "the plastic's own reference explains its bins: {closer}"
        );
        // No evidence gain takes the fit here: only the misfit can.
        let never_by_evidence = |margin: Option<f64>| {
            let mut model = fitted_model(f64::INFINITY);
            if let PriorMean::Fitted { closer_margin, .. } = &mut model.mean {
                *closer_margin = margin;
            }
            model
        };
        for (closer_margin, taken) in [
            (Some(closer / 1.1), true),
            (Some(closer * 1.1), false),
            (None, false),
        ] {
            let label = format!("{closer_margin:?}");
            assert_installs_taken(
                never_by_evidence(closer_margin),
                smooth,
                &bins,
                taken,
                &label,
            );
        }
    }

    /// A start makes a fit needless while it is set. A start, or centring on the database's
    /// mean, puts the fitted reference aside and re-measures every bin from the basis's mean;
    /// dropping the start takes the installed reference back. Asking again for the kind the
    /// model has changes nothing, and a change of kind drops the installed fit.
    #[test]
    fn a_start_or_another_mean_kind_re_measures_the_bins() {
        let [smooth, _] = references();
        let bins = plastic_bins();
        let always = fitted_model(f64::NEG_INFINITY);
        let mut solver = solver_with(always, Regularization::Auto, &bins);
        let k = solver.basis().components();
        // With a start set no fit is due, though none was ever installed.
        assert!(!solver.prior_mean_is_current());
        solver.set_prior_mean(Some(vec![[0.1, 0.2, 0.3]; k]));
        assert!(solver.prior_mean_is_current() && solver.mean_fit_request().is_none());
        solver.set_prior_mean(None);
        assert!(!solver.prior_mean_is_current());
        let generation = solver.generation;
        assert!(solver.install_fitted_mean(FittedMean {
            generation,
            reference: smooth.clone(),
        }));
        solver.set_prior_mean(Some(vec![[0.1, 0.2, 0.3]; k]));
        assert!(solver.reference().is_none());
        assert_holds_from(&solver, None, &bins, "a start");
        solver.set_prior_mean(None);
        assert!(Arc::ptr_eq(solver.reference().expect("back"), smooth));
        assert_holds_from(&solver, Some(&**smooth), &bins, "no start");

        solver.set_mean_kind(always.mean);
        assert!(Arc::ptr_eq(solver.reference().expect("kept"), smooth));
        assert!(solver.prior_mean_is_current());
        solver.set_mean_kind(PriorMean::Database);
        assert_eq!(solver.model().mean, PriorMean::Database);
        assert!(solver.reference().is_none());
        assert_holds_from(&solver, None, &bins, "the database's mean");
        solver.set_mean_kind(always.mean);
        assert!(solver.reference().is_none() && !solver.prior_mean_is_current());
        assert_holds_from(&solver, None, &bins, "no fit yet");
    }

    /// With nothing bright painted (L̄ at most 1e-12, black paint included) there is no
    /// brightness to weigh by: every bin weighs its multiplicity, and so does a bin a view
    /// would add to an empty painting. Once L̄ is set, a prospective bin weighs what the
    /// same bin painted would.
    #[test]
    fn without_bright_paint_a_bin_weighs_its_multiplicity() {
        let bins = painted_bins(12);
        for scale in [0.0, 1e-13, 1e-15] {
            // Two brightnesses a decade apart, both too dark to set L̄.
            let dark: BTreeMap<PairIndex, ([f64; 3], Bounds)> = bins
                .iter()
                .enumerate()
                .map(|(i, (&pair, &(rho, _)))| {
                    let s = if i % 2 == 0 { scale } else { 10.0 * scale };
                    (pair, (rho.map(|v| v * s), EXACT))
                })
                .collect();
            let solver = solver_with(MODEL, Regularization::Auto, &dark);
            for (&pair, obs) in &solver.observed {
                assert_eq!(obs.weight, pair_multiplicity(pair), "× {scale}: {pair}");
            }
            assert_holds(&solver, &dark, &format!("× {scale}"));
        }
        let empty = Solver::with_model(small_test_basis(), Regularization::Auto, MODEL);
        let pair = PairIndex::from_index(654_321);
        assert_eq!(pair_multiplicity(pair), 2.0);
        assert_eq!(empty.prospective_weight(pair, [0.5; 3]), 2.0);

        let solver = solver_with(MODEL, Regularization::Auto, &bins);
        let l =
            |rho: [f64; 3]| (0.2126 * rho[0] + 0.7152 * rho[1] + 0.0722 * rho[2]) * cosines(pair);
        let mean = bins
            .iter()
            .map(|(&p, &(rho, _))| {
                (0.2126 * rho[0] + 0.7152 * rho[1] + 0.0722 * rho[2]) * cosines(p)
            })
            .sum::<f64>()
            / bins.len() as f64;
        for rho in [[0.01; 3], [0.5; 3], [40.0; 3]] {
            let want = expected_weight(&MODEL, pair, l(rho), mean);
            assert_eq!(solver.prospective_weight(pair, rho), want, "{rho:?}");
        }
    }

    /// Under [`Censoring::OmitClipped`] clipped paint says nothing: it adds no bin and
    /// erases what the bin held; paint only "at most" this dark, or exact, still counts.
    #[test]
    fn omitted_clipped_paint_erases_the_bin() {
        let model = PriorModel {
            censoring: Censoring::OmitClipped,
            ..MODEL
        };
        let mut bins = painted_bins(10);
        let mut solver = solver_with(model, Regularization::Auto, &bins);
        assert_holds(&solver, &bins, "painted");
        let clipped = [Bound::AtLeast, Bound::Exact, Bound::Exact];
        let pairs: Vec<PairIndex> = bins.keys().copied().take(3).collect();
        for &pair in &pairs {
            let rho = bins[&pair].0;
            solver.apply(&BinChange::observed(pair, rho, clipped));
            bins.remove(&pair);
            assert_holds(&solver, &bins, &format!("clipped {pair}"));
        }
        let pair = PairIndex::from_index(424_242);
        solver.apply(&BinChange::observed(pair, [0.9; 3], clipped));
        assert_holds(&solver, &bins, "a clipped new bin");
        let dark = [Bound::AtMost, Bound::Exact, Bound::Exact];
        solver.apply(&BinChange::observed(pair, [0.9; 3], dark));
        bins.insert(pair, ([0.9; 3], dark));
        assert_holds(&solver, &bins, "an upper bound");
    }

    /// The posterior's covariance is α(N + αP₀)⁻¹ and its precision (N + αP₀)/α, at the α
    /// the solver is set to.
    #[test]
    fn the_posterior_is_the_inverse_of_the_regularised_system() {
        let basis = small_test_basis();
        let bins = painted_bins(40);
        let d = MODEL.rows(basis.components());
        let e = expected(&MODEL, &basis, &bins);
        let n = Mat::<f64>::from_fn(d, d, |i, j| e.normal[i * d + j]);
        let p0 = closed_form_precision(&MODEL, &basis);
        let mut solver = solver_with(MODEL, Regularization::Auto, &bins);
        assert_eq!(solver.regularization(), Regularization::Auto);
        let alpha = 0.3;
        solver.set_regularization(Regularization::Prior { alpha });
        assert_eq!(solver.regularization(), Regularization::Prior { alpha });
        let m = &n + &p0 * alpha;
        let covariance = m.partial_piv_lu().inverse() * alpha;
        let posterior = solver.posterior();
        assert_eq!(posterior.alpha(), alpha);
        let flat = |a: &Mat<f64>| (0..d * d).map(|i| a[(i / d, i % d)]).collect::<Vec<f64>>();
        let gap = relative_gap(&flat(posterior.covariance()), &flat(&covariance), 1e-300);
        assert!(gap < 1e-9, "covariance off by {gap:e}");
        let precision = &m * (1.0 / alpha);
        let gap = relative_gap(&flat(posterior.precision()), &flat(&precision), 1e-300);
        assert!(gap < 1e-12, "precision off by {gap:e}");
    }

    /// A one-shot refit fits, installs and (at margin −∞) takes the mean of the bins painted
    /// now, after which no fit is due; asked again, it changes nothing.
    #[test]
    fn a_refit_installs_the_mean_of_the_bins_painted_now() {
        let table = tabulate(&plastic(0.2));
        let bins: BTreeMap<PairIndex, ([f64; 3], Bounds)> = (0..PAIRS)
            .step_by(4_999)
            .map(|p| {
                (
                    PairIndex::from_index(p),
                    (table.pairs()[p].map(f64::from), EXACT),
                )
            })
            .collect();
        let mut solver = solver_with(fitted_model(f64::NEG_INFINITY), Regularization::Auto, &bins);
        assert!(!solver.prior_mean_is_current());
        solver.refit_prior_mean();
        assert!(solver.prior_mean_is_current());
        let reference = solver.reference().expect("taken at margin −∞").clone();
        assert_holds_from(&solver, Some(&*reference), &bins, "refitted");
        solver.refit_prior_mean();
        assert!(Arc::ptr_eq(solver.reference().expect("kept"), &reference));
    }

    /// The incremental updates leave rounding residue, which an exact rebuild clears every
    /// [`Solver::REBUILD_INTERVAL`] changes: until then the sums drift from the rebuilt ones
    /// in the last bits; on the interval's last change they are the rebuilt sums, bit for bit.
    #[test]
    fn the_normal_equations_are_rebuilt_exactly_once_every_interval() {
        let basis = small_test_basis();
        let mut solver = Solver::with_model(basis, Regularization::Auto, MODEL);
        for i in 0..6 {
            let pair = PairIndex::from_index(i * 211_111 + 4_321);
            solver.apply(&BinChange::observed(pair, [0.3, 0.4, 0.5], EXACT));
        }
        // Repainting within a quarter octave keeps every weight and L̄: only r and yᵀWy move.
        let pair = PairIndex::from_index(4_321);
        // Three values in turn: their differences do not cancel in floating point as a pair's do.
        let values = [
            [0.3, 0.4, 0.5],
            [0.300_113, 0.400_317, 0.500_719],
            [0.299_929, 0.400_231, 0.499_873],
        ];
        let bits = |solver: &Solver| {
            let (normal, rhs) = solver.normal_equations();
            let mut bits: Vec<u64> = normal.iter().map(|v| v.to_bits()).collect();
            bits.extend(rhs.iter().flatten().map(|v| v.to_bits()));
            bits.extend(solver.yty.map(f64::to_bits));
            bits
        };
        let start = solver.changes_since_rebuild;
        let steps = Solver::REBUILD_INTERVAL - 1 - start;
        for step in 0..steps {
            solver.apply(&BinChange::observed(pair, values[step % 3], EXACT));
            assert_eq!(
                solver.changes_since_rebuild,
                start + step + 1,
                "rebuilt early"
            );
        }
        assert_eq!(solver.changes_since_rebuild, Solver::REBUILD_INTERVAL - 1);
        let mut rebuilt = solver.clone();
        rebuilt.rebuild();
        assert_ne!(
            bits(&solver),
            bits(&rebuilt),
            "no residue to clear after {steps} changes"
        );
        solver.apply(&BinChange::observed(pair, values[steps % 3], EXACT));
        assert_eq!(solver.changes_since_rebuild, 0);
        let mut rebuilt = solver.clone();
        rebuilt.rebuild();
        assert_eq!(bits(&solver), bits(&rebuilt));
    }
}
