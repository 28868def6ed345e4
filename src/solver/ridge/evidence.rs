//! How much the painted bins say about the prior itself: the marginal likelihood (evidence)
//! that chooses the band correlation ρ and decides whether a fitted reference is taken, and
//! generalised cross-validation for α under `--lambda gcv`.

use super::bounds::at_prediction_where_allowed;
use super::{Solver, accumulate_measurement, centred_from};
use crate::solver::fitted_mean::FittedReference;
use crate::solver::prior::{
    DEFAULT_ALPHA, EVIDENCE_BAND_CORRELATIONS, EVIDENCE_MARGIN_NATS, PriorModel, Regularization,
};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Mat, Side};

/// The knots that must each hold [`EVIDENCE_MIN_KNOT_SHARE`] of the painted bins' weight
/// before the evidence may choose ρ (see `Solver::effective_model`).
const EVIDENCE_MIN_KNOTS: usize = 3;
const EVIDENCE_MIN_KNOT_SHARE: f64 = 0.05;

/// Bounds of the α search (mapped-domain variance).
const ALPHA_MIN: f64 = 1e-5;
const ALPHA_MAX: f64 = 100.0;

impl Solver {
    /// The model the next solve uses: the configured one, with a stronger band correlation
    /// when the painted bins ask for it ([`PriorModel::correlation_by_evidence`]). Only data at
    /// three or more knots can tell how tightly distant sets move together: one view sits at
    /// one θ_d, between two knots, and there the choice would only follow noise.
    pub(super) fn effective_model(&self) -> PriorModel {
        let base = self.model;
        let alpha = match self.regularization {
            Regularization::Prior { alpha } => alpha,
            Regularization::Auto => DEFAULT_ALPHA,
            // GCV fits α for the configured ρ, and plain ridge has no bands to correlate.
            Regularization::Gcv | Regularization::Ridge { .. } => return base,
        };
        if base.bands == 1 || !base.correlation_by_evidence || !self.spans_knots() {
            return base;
        }
        let scored = self.band_correlation_evidence(alpha);
        let Some(&(_, anchor)) = scored.first().filter(|s| s.0 == base.band_correlation) else {
            return base;
        };
        let (rho, best) = scored
            .iter()
            .copied()
            .fold((base.band_correlation, anchor), |a, b| {
                if b.1 > a.1 { b } else { a }
            });
        if best - anchor <= EVIDENCE_MARGIN_NATS {
            return base;
        }
        PriorModel {
            band_correlation: rho,
            ..base
        }
    }

    /// Whether at least [`EVIDENCE_MIN_KNOTS`] knots each hold [`EVIDENCE_MIN_KNOT_SHARE`] of
    /// the painted bins' weight.
    fn spans_knots(&self) -> bool {
        let mut per_knot = vec![0.0f64; self.model.bands];
        for obs in self.observed.values() {
            for (j, phi) in obs.band.pairs() {
                per_knot[j] += obs.weight * phi;
            }
        }
        let total: f64 = per_knot.iter().sum();
        total > 0.0
            && per_knot
                .iter()
                .filter(|&&w| w >= EVIDENCE_MIN_KNOT_SHARE * total)
                .count()
                >= EVIDENCE_MIN_KNOTS
    }

    /// The log marginal likelihood of the painted bins (up to a constant shared by all ρ) for
    /// the configured ρ, then each of [`EVIDENCE_BAND_CORRELATIONS`] above it, at noise α:
    /// −2 log p = Σ_c (y_cᵀWy_c − r_cᵀ M⁻¹ r_c)/α + 3 (log det M − log det P₀) + const, with
    /// M = N + αP₀ and y, r measured from the prior's mean. Censored bins count at their bound.
    pub fn band_correlation_evidence(&self, alpha: f64) -> Vec<(f64, f64)> {
        let configured = self.model.band_correlation;
        let candidates = std::iter::once(configured).chain(
            EVIDENCE_BAND_CORRELATIONS
                .into_iter()
                .filter(move |&rho| rho > configured),
        );
        self.evidence(alpha, self.prior_mean(), candidates)
    }

    /// α for the evidence: the prior's, or the calibrated one where the solve fits α itself
    /// or uses plain ridge.
    pub(super) fn evidence_alpha(&self) -> f64 {
        match self.regularization {
            Regularization::Prior { alpha } => alpha,
            _ => DEFAULT_ALPHA,
        }
    }

    /// (ρ, log marginal likelihood) of the painted bins, measured from `reference` (`None`:
    /// the basis's mean) with the prior centred on zero, for each of `correlations`.
    pub(super) fn evidence_from(
        &self,
        alpha: f64,
        reference: Option<&FittedReference>,
        correlations: impl IntoIterator<Item = f64>,
    ) -> Vec<(f64, f64)> {
        let d = self.dimension();
        let mut rhs = vec![[0.0; 3]; d];
        let mut yty = [0.0; 3];
        for (&pair, obs) in &self.observed {
            let y = centred_from(&self.basis, reference, pair, obs.rho);
            let y = at_prediction_where_allowed(y, obs.bounds, [0.0; 3]);
            accumulate_measurement(&mut rhs, &mut yty, obs, y, obs.weight);
        }
        let r = Mat::<f64>::from_fn(d, 3, |i, c| rhs[i][c]);
        self.evidence_of(alpha, r, yty, correlations)
    }

    /// (ρ, log marginal likelihood) of the painted bins for each of `correlations`, with the
    /// prior centred on `mean` (K rows; `None`: zero).
    fn evidence(
        &self,
        alpha: f64,
        mean: Option<&[[f64; 3]]>,
        correlations: impl IntoIterator<Item = f64>,
    ) -> Vec<(f64, f64)> {
        let d = self.dimension();
        let k = self.basis.components();
        let n = Mat::<f64>::from_fn(d, d, |i, j| self.normal[i * d + j]);
        let mut r = Mat::<f64>::from_fn(d, 3, |i, c| self.rhs[i][c]);
        let mut yty = self.yty;
        if let Some(mean) = mean {
            // y − Ψx₀: r − Nx₀ and yᵀWy − 2x₀ᵀr + x₀ᵀNx₀.
            let x0 = Mat::<f64>::from_fn(d, 3, |i, c| mean[i % k][c]);
            let nx0 = &n * &x0;
            for c in 0..3 {
                let (mut xr, mut xnx) = (0.0, 0.0);
                for i in 0..d {
                    xr += x0[(i, c)] * r[(i, c)];
                    xnx += x0[(i, c)] * nx0[(i, c)];
                }
                yty[c] += xnx - 2.0 * xr;
            }
            r -= &nx0;
        }
        self.evidence_of(alpha, r, yty, correlations)
    }

    /// The evidence for right-hand side `r` and yᵀWy `yty` (see [`Self::evidence`]).
    fn evidence_of(
        &self,
        alpha: f64,
        r: Mat<f64>,
        yty: [f64; 3],
        correlations: impl IntoIterator<Item = f64>,
    ) -> Vec<(f64, f64)> {
        let d = self.dimension();
        let k = self.basis.components();
        let n = Mat::<f64>::from_fn(d, d, |i, j| self.normal[i * d + j]);
        let log_det = |l: faer::MatRef<'_, f64>| -> f64 {
            (0..l.nrows()).map(|i| 2.0 * l[(i, i)].ln()).sum()
        };
        let mut scored = Vec::new();
        for rho in correlations {
            let model = PriorModel {
                band_correlation: rho,
                ..self.model
            };
            let p0 = self.prior_precision_of(&model);
            let m = &n + &p0 * alpha;
            let correlation = model.band_correlation_matrix();
            let (Ok(m_llt), Ok(c_llt)) = (m.llt(Side::Lower), correlation.llt(Side::Lower)) else {
                continue;
            };
            let x = m_llt.solve(&r);
            let misfit: f64 = (0..3)
                .map(|c| yty[c] - (0..d).map(|i| r[(i, c)] * x[(i, c)]).sum::<f64>())
                .sum();
            // log det P₀ = −K log det C(ρ) + (terms of the σ_k alone).
            let log_det_p0 = -(k as f64) * log_det(c_llt.L());
            let minus_twice = misfit / alpha + 3.0 * (log_det(m_llt.L()) - log_det_p0);
            if minus_twice.is_finite() {
                scored.push((rho, -0.5 * minus_twice));
            }
        }
        scored
    }

    /// α minimising the generalised cross-validation score, shared by R, G and B.
    /// `None` when there are too few observations for cross-validation to mean anything.
    pub(super) fn gcv_alpha(&self, p0: &Mat<f64>) -> Option<f64> {
        let d = self.dimension();
        if self.weight_sum < (d + 2) as f64 {
            return None;
        }
        // Whitened by the prior: P₀ = LLᵀ, A = L⁻¹NL⁻ᵀ = QEQᵀ, g_c = QᵀL⁻¹r_c.
        let l = p0.llt(Side::Lower).ok()?;
        let l_inv = l.L().to_owned().partial_piv_lu().inverse();
        let n = Mat::<f64>::from_fn(d, d, |i, j| self.normal[i * d + j]);
        let a = &l_inv * &n * l_inv.transpose();
        let eigen = a.self_adjoint_eigen(Side::Lower).ok()?;
        let (q, e) = (eigen.U(), eigen.S().column_vector());
        let e: Vec<f64> = (0..d).map(|i| e[i].max(0.0)).collect();
        let r = Mat::<f64>::from_fn(d, 3, |i, c| self.rhs[i][c]);
        let g = q.transpose() * (&l_inv * &r);
        let count = 3.0 * self.weight_sum;
        let yty: f64 = self.yty.iter().sum();
        let score = |log_alpha: f64| -> f64 {
            let alpha = log_alpha.exp();
            let (mut rss, mut df) = (yty, 0.0);
            for i in 0..d {
                let den = e[i] + alpha;
                let g2: f64 = (0..3).map(|c| g[(i, c)] * g[(i, c)]).sum();
                rss -= g2 * (e[i] + 2.0 * alpha) / (den * den);
                df += 3.0 * e[i] / den;
            }
            let dof = count - df;
            if dof <= 1e-9 * count {
                f64::INFINITY
            } else {
                count * rss.max(0.0) / (dof * dof)
            }
        };
        let (lo, hi) = (ALPHA_MIN.ln(), ALPHA_MAX.ln());
        const GRID: usize = 48;
        let step = (hi - lo) / GRID as f64;
        let mut best = (f64::INFINITY, lo);
        for i in 0..=GRID {
            let t = lo + step * i as f64;
            let s = score(t);
            if s < best.0 {
                best = (s, t);
            }
        }
        if !best.0.is_finite() {
            return None;
        }
        // Golden-section refinement inside the best grid cell's neighbours.
        let (mut a, mut b) = ((best.1 - step).max(lo), (best.1 + step).min(hi));
        let ratio = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..30 {
            let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
            if score(c) < score(d) { b = d } else { a = c }
        }
        let t = 0.5 * (a + b);
        let t = if score(t) <= best.0 { t } else { best.1 };
        Some(t.exp())
    }
}
