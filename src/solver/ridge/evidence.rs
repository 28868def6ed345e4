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

/// One ρ's evidence and the misfit in it.
#[derive(Clone, Copy, Debug)]
pub(super) struct EvidenceTerms {
    pub(super) rho: f64,
    /// Log marginal likelihood, up to a constant shared by every reference and ρ.
    pub(super) log_evidence: f64,
    /// Σ_c (y_cᵀWy_c − r_cᵀM⁻¹r_c): the painted bins' weighted squared residual after the
    /// correction, plus the correction's cost under the prior, in mapped units.
    pub(super) misfit: f64,
}

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

    /// The evidence of the painted bins measured from `reference` (`None`: the basis's mean)
    /// with the prior centred on zero, for each of `correlations`, with its misfit.
    pub(super) fn evidence_terms_from(
        &self,
        alpha: f64,
        reference: Option<&FittedReference>,
        correlations: impl IntoIterator<Item = f64>,
    ) -> Vec<EvidenceTerms> {
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
            .into_iter()
            .map(|t| (t.rho, t.log_evidence))
            .collect()
    }

    /// The evidence for right-hand side `r` and yᵀWy `yty` (see [`Self::evidence`]).
    fn evidence_of(
        &self,
        alpha: f64,
        r: Mat<f64>,
        yty: [f64; 3],
        correlations: impl IntoIterator<Item = f64>,
    ) -> Vec<EvidenceTerms> {
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
                scored.push(EvidenceTerms {
                    rho,
                    log_evidence: -0.5 * minus_twice,
                    misfit,
                });
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

#[cfg(test)]
mod tests {
    use super::super::Observed;
    use super::*;
    use crate::basis::build::small_test_basis;
    use crate::solver::bands::{BandWeights, pair_bands};
    use crate::solver::prior::PriorMean;
    use crate::solver::reconstruction::Reconstruction;
    use crate::solver::sparse::{BinChange, Bound, EXACT};
    use crate::table::PairIndex;

    /// The calibrated prior centred on the database's mean: not the default model, so that a
    /// model made up rather than kept is told apart.
    const MODEL: PriorModel = PriorModel {
        mean: PriorMean::Database,
        ..PriorModel::CALIBRATED
    };

    /// One coefficient set for every θ_d: a material whose knots move together exactly.
    fn agreeing() -> Reconstruction {
        let basis = small_test_basis();
        let x: Vec<[f64; 3]> = basis
            .variances()
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let s = v.sqrt() * if i % 2 == 0 { 0.8 } else { -0.6 };
                [s, 0.7 * s, 0.4 * s]
            })
            .collect();
        Reconstruction::new(basis, &x)
    }

    /// A solver of `model` under `regularization` with `truth` painted on `pairs`.
    fn painted(
        model: PriorModel,
        regularization: Regularization,
        truth: &Reconstruction,
        pairs: &[PairIndex],
    ) -> Solver {
        let mut solver = Solver::with_model(small_test_basis(), regularization, model);
        for &pair in pairs {
            let rho = truth.eval_pair(pair).map(f64::from);
            solver.apply(&BinChange::observed(pair, rho, EXACT));
        }
        solver
    }

    /// Bins spread over every θ_d.
    fn spread() -> Vec<PairIndex> {
        PairIndex::all().step_by(997).collect()
    }

    /// Bins between the knots at 22.5° and 45° only, as one view's slice would be.
    fn one_span() -> Vec<PairIndex> {
        let bands = pair_bands();
        PairIndex::all()
            .step_by(97)
            .filter(|p| bands[p.index()].lower == 1)
            .collect()
    }

    /// (configured ρ's evidence, the tighter candidate's) at `alpha`.
    fn scores(solver: &Solver, alpha: f64) -> (f64, f64) {
        let scored = solver.band_correlation_evidence(alpha);
        let rhos: Vec<f64> = scored.iter().map(|s| s.0).collect();
        assert_eq!(
            rhos,
            [MODEL.band_correlation, EVIDENCE_BAND_CORRELATIONS[0]]
        );
        (scored[0].1, scored[1].1)
    }

    #[test]
    fn bins_within_one_knot_span_keep_the_configured_model() {
        let solver = painted(MODEL, Regularization::Auto, &agreeing(), &one_span());
        assert!(solver.observed_bins() > 100);
        assert!(!solver.spans_knots());
        // The evidence alone would take the tighter ρ: the span, not the score, keeps it out.
        let (configured, tighter) = scores(&solver, DEFAULT_ALPHA);
        assert!(tighter - configured > EVIDENCE_MARGIN_NATS);
        assert_eq!(solver.effective_model(), MODEL);
        assert_eq!(solver.solve().band_correlation, MODEL.band_correlation);
    }

    #[test]
    fn agreeing_bins_over_several_knots_take_the_tighter_correlation() {
        let tighter = PriorModel {
            band_correlation: EVIDENCE_BAND_CORRELATIONS[0],
            ..MODEL
        };
        for regularization in [Regularization::Auto, Regularization::Prior { alpha: 3.0 }] {
            let solver = painted(MODEL, regularization, &agreeing(), &spread());
            assert!(solver.spans_knots());
            assert_eq!(solver.effective_model(), tighter, "{regularization}");
            assert_eq!(solver.solve().band_correlation, tighter.band_correlation);
        }
    }

    /// The same bins keep the configured model whenever the evidence may not choose: it is
    /// switched off, there is one set, α is fitted (GCV) or there is no prior (ridge), or no
    /// candidate is tighter than the configured ρ.
    #[test]
    fn the_configured_model_stays_where_the_evidence_may_not_choose() {
        let (truth, pairs) = (agreeing(), spread());
        let keeps = |model: PriorModel, regularization: Regularization| {
            let solver = painted(model, regularization, &truth, &pairs);
            assert_eq!(
                solver.effective_model(),
                model,
                "{model:?}, {regularization}"
            );
        };
        let off = PriorModel {
            correlation_by_evidence: false,
            ..MODEL
        };
        keeps(off, Regularization::Auto);
        let global = PriorModel {
            correlation_by_evidence: true,
            ..PriorModel::GLOBAL
        };
        keeps(global, Regularization::Auto);
        keeps(MODEL, Regularization::Gcv);
        keeps(MODEL, Regularization::Ridge { lambda: 1.0 });
        let tightest = PriorModel {
            band_correlation: 0.995,
            ..MODEL
        };
        keeps(tightest, Regularization::Auto);
    }

    /// Over α from little to much noise, the tighter ρ's gain shrinks through the margin: the
    /// solve takes the candidate exactly when its evidence beats the configured ρ's by more
    /// than the margin, and keeps the configured ρ when it is better by less.
    #[test]
    fn the_tighter_correlation_is_taken_only_past_the_margin() {
        let (truth, pairs) = (agreeing(), spread());
        let (mut taken, mut short) = (0, 0);
        for step in 0..24 {
            let alpha = 10f64.powf(-1.0 + 0.25 * step as f64);
            let solver = painted(MODEL, Regularization::Prior { alpha }, &truth, &pairs);
            let (configured, tighter) = scores(&solver, alpha);
            let gain = tighter - configured;
            let expected = if gain > EVIDENCE_MARGIN_NATS {
                taken += 1;
                EVIDENCE_BAND_CORRELATIONS[0]
            } else {
                short += usize::from(gain > 0.0);
                MODEL.band_correlation
            };
            let model = solver.effective_model();
            assert_eq!(model.band_correlation, expected, "α {alpha}, gain {gain}");
        }
        assert!(
            taken > 0 && short > 0,
            "{taken} taken, {short} short of the margin"
        );
    }

    /// A solver whose painted bins hold `weights` at knots and blends of knots (only what
    /// `spans_knots` reads: the normal equations are left empty).
    fn with_knot_weights(weights: &[(BandWeights, f64)]) -> Solver {
        let mut solver = Solver::with_model(small_test_basis(), Regularization::Auto, MODEL);
        for (i, &(band, weight)) in weights.iter().enumerate() {
            let obs = Observed {
                row: Box::new([]),
                band,
                y: [0.0; 3],
                rho: [0.0; 3],
                brightness: 0.0,
                weight,
                bounds: EXACT,
                rounding: 0.0,
            };
            solver.observed.insert(PairIndex::from_index(i), obs);
        }
        solver
    }

    /// Weight `w` at knot `j`.
    fn at(j: u8, w: f64) -> (BandWeights, f64) {
        let band = match j {
            4 => BandWeights {
                lower: 3,
                frac: 1.0,
            },
            j => BandWeights {
                lower: j,
                frac: 0.0,
            },
        };
        (band, w)
    }

    /// Weight `w` halfway between knots `j` and `j + 1`.
    fn between(j: u8, w: f64) -> (BandWeights, f64) {
        (
            BandWeights {
                lower: j,
                frac: 0.5,
            },
            w,
        )
    }

    #[test]
    fn spans_knots_needs_three_knots_with_five_percent_of_the_weight_each() {
        let spans = |weights: &[(BandWeights, f64)]| with_knot_weights(weights).spans_knots();
        assert!(!spans(&[]));
        assert!(spans(&[at(0, 1.0), at(2, 1.0), at(4, 1.0)]));
        assert!(spans(&[at(0, 1.0), at(1, 1.0), at(2, 1.0), at(3, 1.0)]));
        assert!(!spans(&[at(1, 5.0), at(3, 5.0)]));
        // One view's slice blends two knots, however much is painted.
        assert!(!spans(&[between(1, 10.0), between(1, 30.0)]));
        assert!(spans(&[between(0, 1.0), between(2, 1.0)]));
        // Exactly 5% counts; 4.9% does not.
        assert!(spans(&[at(0, 1.0), at(2, 9.5), at(4, 9.5)]));
        assert!(!spans(&[at(0, 0.98), at(2, 9.51), at(4, 9.51)]));
        // Half a bin's weight is what reaches each knot it blends: 2 × 0.5 of 20 is 5%.
        assert!(spans(&[between(0, 2.0), at(1, 8.0), at(2, 10.0)]));
        assert!(!spans(&[between(0, 1.9), at(1, 8.1), at(2, 10.0)]));
    }

    /// ψ_p, the bin's row of Ψ (D entries): the basis row u_p on the sets its θ_d blends.
    fn design_row(solver: &Solver, obs: &Observed) -> Vec<f64> {
        let k = solver.basis.components();
        let mut psi = vec![0.0; solver.dimension()];
        for (j, phi) in obs.band.pairs() {
            if phi != 0.0 {
                for (i, u) in obs.row.iter().enumerate() {
                    psi[j * k + i] += phi * u;
                }
            }
        }
        psi
    }

    /// log p of the painted bins (as the normal equations hold them), written out bin by bin:
    /// each channel's y ~ N(Ψ(1 ⊗ x₀), S) with S = αW⁻¹ + ΨΣΨᵀ, Σ the prior's covariance
    /// (σ_i² C(ρ)_ab between component i of sets a and b, none between components).
    fn marginal_likelihood(solver: &Solver, alpha: f64, rho: f64) -> f64 {
        let model = PriorModel {
            band_correlation: rho,
            ..solver.model
        };
        let (k, d) = (solver.basis.components(), solver.dimension());
        let sigma = super::super::prior_scales(solver.basis.variances());
        let bins: Vec<&Observed> = solver.observed.values().collect();
        let psi: Vec<Vec<f64>> = bins.iter().map(|obs| design_row(solver, obs)).collect();
        let n = bins.len();
        let covariance = Mat::<f64>::from_fn(d, d, |a, b| {
            if a % k == b % k {
                sigma[a % k].powi(2) * model.band_correlation_between(a / k, b / k)
            } else {
                0.0
            }
        });
        let psi_mat = Mat::<f64>::from_fn(n, d, |p, a| psi[p][a]);
        let mut s = &psi_mat * &covariance * psi_mat.transpose();
        for (p, obs) in bins.iter().enumerate() {
            s[(p, p)] += alpha / obs.weight;
        }
        let llt = s.llt(Side::Lower).expect("S is positive definite");
        let log_det: f64 = (0..n).map(|p| 2.0 * llt.L()[(p, p)].ln()).sum();
        let mut minus_twice = 3.0 * (log_det + n as f64 * (2.0 * std::f64::consts::PI).ln());
        for c in 0..3 {
            let e = Mat::<f64>::from_fn(n, 1, |p, _| {
                let prior: f64 = solver
                    .prior_mean()
                    .map_or(0.0, |m| (0..d).map(|a| psi[p][a] * m[a % k][c]).sum());
                bins[p].y[c] - prior
            });
            let z = llt.solve(&e);
            minus_twice += (0..n).map(|p| e[(p, 0)] * z[(p, 0)]).sum::<f64>();
        }
        -0.5 * minus_twice
    }

    /// What the evidence leaves out of log p, alike for every ρ: the noise's normalisation
    /// (n log 2πα − log det W), D log α and the σ_k's part of log det P₀.
    fn terms_shared_by_every_rho(solver: &Solver, alpha: f64) -> f64 {
        let n = solver.observed.len() as f64;
        let d = solver.dimension() as f64;
        let sigma = super::super::prior_scales(solver.basis.variances());
        let log_sigma2: f64 = sigma.iter().map(|s| (s * s).ln()).sum();
        let log_w: f64 = solver.observed.values().map(|o| o.weight.ln()).sum();
        let two_pi = 2.0 * std::f64::consts::PI;
        -1.5 * (solver.model.bands as f64 * log_sigma2 + n * two_pi.ln() + (n - d) * alpha.ln()
            - log_w)
    }

    /// Bins at every 40th of the table: few enough to write S out, spread over θ_d.
    fn sparse() -> Vec<PairIndex> {
        PairIndex::all()
            .step_by(PairIndex::all().len() / 40)
            .collect()
    }

    #[test]
    fn the_evidence_is_the_gaussian_marginal_likelihood_of_the_bins() {
        let truth = agreeing();
        let k = truth.basis().components();
        let start: Vec<[f64; 3]> = small_test_basis().variances()[..k]
            .iter()
            .map(|v| [0.5 * v.sqrt(), -0.3 * v.sqrt(), 0.2 * v.sqrt()])
            .collect();
        let global = PriorModel::GLOBAL;
        for (model, mean) in [(MODEL, None), (MODEL, Some(start.clone())), (global, None)] {
            let mut solver = painted(model, Regularization::Auto, &truth, &sparse());
            solver.set_prior_mean(mean.clone());
            for alpha in [0.3, DEFAULT_ALPHA] {
                let scored = solver.band_correlation_evidence(alpha);
                assert_eq!(scored.len(), 1 + usize::from(model.bands > 1));
                let shared = terms_shared_by_every_rho(&solver, alpha);
                for (rho, evidence) in scored {
                    let direct = marginal_likelihood(&solver, alpha, rho);
                    assert!(
                        (evidence + shared - direct).abs() <= 1e-9 * direct.abs(),
                        "ρ {rho}, α {alpha}, mean {}: {} vs {direct}",
                        mean.is_some(),
                        evidence + shared
                    );
                }
            }
        }
    }

    /// Measured from the basis's mean, the evidence of the bins re-measured for a reference is
    /// that of the normal equations: censored bins count at their bound, or at the prior's
    /// prediction where that meets it, alike in both.
    #[test]
    fn evidence_from_the_basis_mean_is_the_evidence_of_the_normal_equations() {
        let truth = agreeing();
        let mut solver = Solver::with_model(small_test_basis(), Regularization::Auto, MODEL);
        for (i, pair) in sparse().into_iter().enumerate() {
            // Clipped paint on every third bin: a bound well below the truth on some, above
            // it on others.
            let (scale, bounds) = match i % 6 {
                0 => (0.5, [Bound::AtLeast, Bound::Exact, Bound::AtLeast]),
                3 => (2.0, [Bound::AtLeast, Bound::Exact, Bound::AtLeast]),
                _ => (1.0, EXACT),
            };
            let rho = truth.eval_pair(pair).map(|v| scale * f64::from(v));
            solver.apply(&BinChange::observed(pair, rho, bounds));
        }
        assert!(!solver.censored.is_empty());
        let rho = MODEL.band_correlation;
        let from: Vec<(f64, f64)> = solver
            .evidence_terms_from(DEFAULT_ALPHA, None, [rho])
            .into_iter()
            .map(|t| (t.rho, t.log_evidence))
            .collect();
        let of_normal = solver.band_correlation_evidence(DEFAULT_ALPHA);
        assert_eq!(from.len(), 1);
        assert!((from[0].1 - of_normal[0].1).abs() <= 1e-9 * from[0].1.abs());
        let direct = marginal_likelihood(&solver, DEFAULT_ALPHA, rho);
        let shared = terms_shared_by_every_rho(&solver, DEFAULT_ALPHA);
        assert!((from[0].1 + shared - direct).abs() <= 1e-9 * direct.abs());
    }

    #[test]
    fn the_evidence_scores_the_configured_correlation_and_the_candidates_above_it() {
        let (truth, pairs) = (agreeing(), sparse());
        for configured in [0.5, MODEL.band_correlation, 0.99, 0.995] {
            let model = PriorModel {
                band_correlation: configured,
                ..MODEL
            };
            let solver = painted(model, Regularization::Auto, &truth, &pairs);
            let rhos: Vec<f64> = solver
                .band_correlation_evidence(DEFAULT_ALPHA)
                .iter()
                .map(|s| s.0)
                .collect();
            let mut expected = vec![configured];
            expected.extend(
                EVIDENCE_BAND_CORRELATIONS
                    .iter()
                    .filter(|&&c| c > configured),
            );
            assert_eq!(rhos, expected);
        }
    }

    /// `truth` painted on `pairs` with a deterministic multiplicative noise of ±15% per channel.
    fn noisy(model: PriorModel, truth: &Reconstruction, pairs: &[PairIndex]) -> Solver {
        let mut solver = Solver::with_model(small_test_basis(), Regularization::Gcv, model);
        for &pair in pairs {
            let rho: [f64; 3] = std::array::from_fn(|c| {
                let u = ((pair.index() * (3 + c)) as f64 * 0.618_034).fract() - 0.5;
                f64::from(truth.eval_pair(pair)[c]) * (0.3 * u).exp()
            });
            solver.apply(&BinChange::observed(pair, rho, EXACT));
        }
        solver
    }

    /// The GCV score at α from the solution itself: n·RSS/(n − df)², n the painted bins'
    /// weight three times over (R, G, B), RSS = Σ_p w_p‖y_p − ψ_pᵀX(α)‖² and df the trace of
    /// the hat matrix, 3 tr((N + αP₀)⁻¹N).
    fn gcv_score(solver: &Solver, p0: &Mat<f64>, alpha: f64) -> f64 {
        let d = solver.dimension();
        let n = Mat::<f64>::from_fn(d, d, |i, j| solver.normal[i * d + j]);
        let r = Mat::<f64>::from_fn(d, 3, |i, c| solver.rhs[i][c]);
        let m = &n + p0 * alpha;
        let llt = m.llt(Side::Lower).expect("N + αP₀ is positive definite");
        let x = llt.solve(&r);
        let hat = llt.solve(&n);
        let df = 3.0 * (0..d).map(|i| hat[(i, i)]).sum::<f64>();
        let (mut rss, mut count) = (0.0, 0.0);
        for obs in solver.observed.values() {
            let psi = design_row(solver, obs);
            for c in 0..3 {
                let fit: f64 = (0..d).map(|a| psi[a] * x[(a, c)]).sum();
                rss += obs.weight * (obs.y[c] - fit).powi(2);
            }
            count += 3.0 * obs.weight;
        }
        count * rss / (count - df).powi(2)
    }

    /// GCV's α is the minimiser of the score, found by brute force, over the whole search
    /// range: a prior s times as tight (sP₀) asks for α/s, since only αP₀ enters the fit.
    #[test]
    fn gcv_alpha_minimises_the_gcv_score() {
        let solver = noisy(MODEL, &agreeing(), &spread());
        let p0 = solver.prior_precision_of(&MODEL);
        let calibrated = solver.gcv_alpha(&p0).expect("enough bins for GCV");
        assert_eq!(solver.solve().alpha, calibrated);
        for scale in [1.0, 0.1, 0.01, 0.001] {
            let p0 = &p0 * scale;
            let alpha = solver.gcv_alpha(&p0).expect("enough bins for GCV");
            // Brute force: the best of 400 steps over the search range, then twice more
            // around it.
            let (mut lo, mut hi) = (ALPHA_MIN.ln(), ALPHA_MAX.ln());
            let mut best = (f64::INFINITY, lo);
            for _ in 0..3 {
                let step = (hi - lo) / 400.0;
                for i in 0..=400 {
                    let t = lo + step * i as f64;
                    let s = gcv_score(&solver, &p0, t.exp());
                    if s < best.0 {
                        best = (s, t);
                    }
                }
                lo = (best.1 - step).max(ALPHA_MIN.ln());
                hi = (best.1 + step).min(ALPHA_MAX.ln());
            }
            let brute = best.1.exp();
            assert!(
                2.0 * ALPHA_MIN < brute && brute < ALPHA_MAX / 2.0,
                "prior × {scale}: the minimum is inside the range: {brute}"
            );
            // The score is flat about its minimum (1e-10 higher 0.1% away): GCV's α must
            // score as well as the scan's best, to rounding, and lie within 0.01% of it.
            let excess = gcv_score(&solver, &p0, alpha) / best.0 - 1.0;
            assert!(
                excess <= 1e-12,
                "prior × {scale}: GCV's α {alpha} scores {excess} above the scan's best"
            );
            assert!(
                (alpha / brute).ln().abs() < 1e-4,
                "prior × {scale}: GCV's α {alpha} vs the scan's {brute}"
            );
            assert!(
                (alpha * scale / calibrated).ln().abs() < 1e-4,
                "prior × {scale}: α {alpha} vs {calibrated}"
            );
        }
    }

    /// One set (D = K) and multiplicities 1 and 2 for weights: GCV needs the weight of D + 2
    /// observations; with D + 1 it leaves the solve the calibrated α.
    #[test]
    fn gcv_needs_a_weight_of_two_more_than_the_coefficients() {
        let global = PriorModel::GLOBAL;
        let truth = agreeing();
        let d = global.rows(truth.basis().components());
        let of_multiplicity = |m: f64| {
            PairIndex::all()
                .filter(move |&p| crate::table::pair_multiplicity(p) == m)
                .step_by(211)
        };
        for weight in [d + 1, d + 2] {
            let pairs: Vec<PairIndex> = of_multiplicity(2.0)
                .take(weight / 2)
                .chain(of_multiplicity(1.0).take(weight % 2))
                .collect();
            let solver = painted(global, Regularization::Gcv, &truth, &pairs);
            assert_eq!(solver.weight_sum, weight as f64);
            let p0 = solver.prior_precision_of(&global);
            let alpha = solver.gcv_alpha(&p0);
            assert_eq!(alpha.is_some(), weight == d + 2, "weight {weight}");
            let expected = alpha.unwrap_or(DEFAULT_ALPHA);
            assert_eq!(solver.solve().alpha, expected);
        }
    }

    /// The evidence for a fitted reference is weighed at the α the solve uses where the prior
    /// sets it, and at the calibrated α where the solve fits α itself (GCV) or has no prior.
    #[test]
    fn the_evidence_for_a_reference_takes_the_alpha_of_the_prior() {
        let (truth, pairs) = (agreeing(), sparse());
        for (regularization, expected) in [
            (Regularization::Prior { alpha: 3.0 }, 3.0),
            (Regularization::Auto, DEFAULT_ALPHA),
            (Regularization::Gcv, DEFAULT_ALPHA),
            (Regularization::Ridge { lambda: 0.5 }, DEFAULT_ALPHA),
        ] {
            let solver = painted(MODEL, regularization, &truth, &pairs);
            assert_eq!(solver.evidence_alpha(), expected, "{regularization}");
            if matches!(
                regularization,
                Regularization::Prior { .. } | Regularization::Auto
            ) {
                assert_eq!(solver.solve().alpha, expected, "{regularization}");
            }
        }
    }
}
