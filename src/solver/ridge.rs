//! Ridge regression of the mapped sparse values onto the basis rows of the observed bins.
//!
//! The normal equations N = Σ_b w_b u_b u_bᵀ and r_c = Σ_b w_b u_b y_bc are kept up to date
//! one bin change at a time (O(K²) when a bin appears or empties, O(K) when its value changes),
//! in f64, with an exact rebuild every [`Solver::REBUILD_INTERVAL`] changes so that long
//! sessions cannot drift. w_b is the number of full-table entries the pair stands for.
//!
//! Regularisation is a Gaussian prior on the coefficients with the database's component
//! variances σ_k²: (N + α Σ⁻¹) x = r. α is the observation noise variance in the mapped (log)
//! domain, so it does not depend on the ρ scale. The default α = 3 was measured on held-out
//! materials painted on one sphere view (default basis, K = 20): the error is flat for α in
//! [1, 10] and grows fast below 0.3. It is far above the basis's own residual variance (≈ 0.01)
//! because what a held-out material has outside the basis is the same smooth error in every
//! bin of a slice, not independent noise. Generalised cross-validation sees only the painted
//! slice, fits it almost exactly and extrapolates wildly off it (mean relative RMSE 13.7 against
//! 0.39 for the default); a plain λI shrinks every component alike (2.5 at best).

use super::sparse::BinChange;
use crate::basis::Basis;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use std::collections::BTreeMap;
use std::sync::Arc;

/// How the solver regularises.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Regularization {
    /// Variance-weighted prior with the measured default α ([`DEFAULT_ALPHA`]).
    #[default]
    Auto,
    /// Variance-weighted prior with α chosen by generalised cross-validation on the samples.
    Gcv,
    /// Variance-weighted prior with a fixed noise variance α (mapped domain).
    Prior { alpha: f64 },
    /// Plain ridge λI on the coefficients (for comparison; not recommended).
    Ridge { lambda: f64 },
}

impl std::str::FromStr for Regularization {
    type Err = String;
    /// `auto`, `gcv`, a number (the prior's α), `prior:α` or `ridge:λ`.
    fn from_str(s: &str) -> Result<Self, String> {
        let number = |v: &str| -> Result<f64, String> {
            let x: f64 = v.parse().map_err(|_| format!("'{v}' is not a number"))?;
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(format!("'{v}' must be a positive number"))
            }
        };
        match s {
            "auto" => Ok(Self::Auto),
            "gcv" => Ok(Self::Gcv),
            _ => match s.split_once(':') {
                Some(("prior", v)) => Ok(Self::Prior { alpha: number(v)? }),
                Some(("ridge", v)) => Ok(Self::Ridge { lambda: number(v)? }),
                Some((kind, _)) => Err(format!(
                    "unknown regularisation '{kind}' (auto, prior:α, ridge:λ)"
                )),
                None => Ok(Self::Prior { alpha: number(s)? }),
            },
        }
    }
}

/// The text [`FromStr`](std::str::FromStr) reads back: `auto`, `gcv`, `prior:α` or `ridge:λ`.
impl std::fmt::Display for Regularization {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Auto => f.write_str("auto"),
            Self::Gcv => f.write_str("gcv"),
            Self::Prior { alpha } => write!(f, "prior:{}", Short(*alpha)),
            Self::Ridge { lambda } => write!(f, "ridge:{}", Short(*lambda)),
        }
    }
}

/// A number as a person writes it: plain between 10⁻³ and 10⁶, in exponent form outside
/// (`{}` alone spells 1e-300 with three hundred digits). Both forms parse back exactly.
struct Short(f64);

impl std::fmt::Display for Short {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// Coefficients and diagnostics of one solve.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// x_kc: K rows of (R, G, B) coefficients.
    pub coefficients: Vec<[f64; 3]>,
    /// The prior's α (or ridge λ) used.
    pub alpha: f64,
    /// Condition number of the regularised normal matrix that was factored.
    pub condition_number: f64,
    /// Observed bins the solve saw.
    pub observed_bins: usize,
}

#[derive(Clone, Debug)]
struct Observed {
    row: Box<[f64]>,
    y: [f64; 3],
    weight: f64,
}

/// Bounds of the α search (mapped-domain variance).
const ALPHA_MIN: f64 = 1e-5;
const ALPHA_MAX: f64 = 100.0;
/// The prior's default α (mapped-domain variance), measured on held-out materials; also what
/// cross-validation falls back to where it can't decide (fewer observations than components).
pub const DEFAULT_ALPHA: f64 = 3.0;

/// The incremental solver. Deterministic: its state depends on the set of observed bins
/// and the order of changes only, never on hashing or threads.
#[derive(Clone, Debug)]
pub struct Solver {
    basis: Arc<Basis>,
    regularization: Regularization,
    observed: BTreeMap<u32, Observed>,
    normal: Vec<f64>,
    rhs: Vec<[f64; 3]>,
    yty: [f64; 3],
    weight_sum: f64,
    changes_since_rebuild: usize,
}

impl Solver {
    /// Changes applied between exact rebuilds of the normal equations.
    pub const REBUILD_INTERVAL: usize = 1 << 16;

    pub fn new(basis: Arc<Basis>, regularization: Regularization) -> Self {
        let k = basis.components();
        Self {
            basis,
            regularization,
            observed: BTreeMap::new(),
            normal: vec![0.0; k * k],
            rhs: vec![[0.0; 3]; k],
            yty: [0.0; 3],
            weight_sum: 0.0,
            changes_since_rebuild: 0,
        }
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    pub fn regularization(&self) -> Regularization {
        self.regularization
    }

    pub fn set_regularization(&mut self, regularization: Regularization) {
        self.regularization = regularization;
    }

    pub fn observed_bins(&self) -> usize {
        self.observed.len()
    }

    /// N (K × K, row-major) and r (K rows of R, G, B), for inspection and tests.
    pub fn normal_equations(&self) -> (&[f64], &[[f64; 3]]) {
        (&self.normal, &self.rhs)
    }

    fn centred(&self, pair: u32, rho: [f64; 3]) -> [f64; 3] {
        rho.map(|v| self.basis.centred_observation(pair as usize, v))
    }

    /// Applies one bin change to the normal equations.
    pub fn apply(&mut self, change: &BinChange) {
        let k = self.basis.components();
        let pair = change.pair;
        match (change.before.is_some(), change.after) {
            (_, Some(rho)) => {
                let y = self.centred(pair, rho);
                if let Some(obs) = self.observed.get_mut(&pair) {
                    for c in 0..3 {
                        let dy = y[c] - obs.y[c];
                        for (i, u) in obs.row.iter().enumerate() {
                            self.rhs[i][c] += obs.weight * u * dy;
                        }
                        self.yty[c] += obs.weight * (y[c] * y[c] - obs.y[c] * obs.y[c]);
                    }
                    obs.y = y;
                } else {
                    let row: Box<[f64]> = self
                        .basis
                        .row(pair as usize)
                        .iter()
                        .map(|&u| u as f64)
                        .collect();
                    let weight = crate::table::pair_multiplicity(pair as usize);
                    let obs = Observed { row, y, weight };
                    accumulate(&mut self.normal, &mut self.rhs, &mut self.yty, &obs, 1.0, k);
                    self.weight_sum += weight;
                    self.observed.insert(pair, obs);
                }
            }
            (_, None) => {
                if let Some(obs) = self.observed.remove(&pair) {
                    accumulate(
                        &mut self.normal,
                        &mut self.rhs,
                        &mut self.yty,
                        &obs,
                        -1.0,
                        k,
                    );
                    self.weight_sum -= obs.weight;
                }
            }
        }
        self.changes_since_rebuild += 1;
        // With no bin left, exact zeros cost nothing and keep rounding residue from giving
        // an empty painting anything but the mean material.
        if self.changes_since_rebuild >= Self::REBUILD_INTERVAL || self.observed.is_empty() {
            self.rebuild();
        }
    }

    /// Applies a batch of changes in order.
    pub fn apply_all(&mut self, changes: &[BinChange]) {
        for change in changes {
            self.apply(change);
        }
    }

    /// Recomputes the normal equations exactly from the observed bins.
    pub fn rebuild(&mut self) {
        let k = self.basis.components();
        self.normal.iter_mut().for_each(|v| *v = 0.0);
        self.rhs.iter_mut().for_each(|v| *v = [0.0; 3]);
        self.yty = [0.0; 3];
        self.weight_sum = 0.0;
        for obs in self.observed.values() {
            accumulate(&mut self.normal, &mut self.rhs, &mut self.yty, obs, 1.0, k);
            self.weight_sum += obs.weight;
        }
        self.changes_since_rebuild = 0;
    }

    /// Solves for the coefficients. Always finite: with no observation it returns the mean
    /// material (all coefficients 0).
    pub fn solve(&self) -> Solution {
        let k = self.basis.components();
        let sigma: Vec<f64> = prior_scales(self.basis.variances());
        let (alpha, penalty): (f64, Vec<f64>) = match self.regularization {
            Regularization::Ridge { lambda } => (lambda, vec![lambda; k]),
            Regularization::Prior { alpha } => {
                (alpha, sigma.iter().map(|s| alpha / (s * s)).collect())
            }
            Regularization::Auto => (
                DEFAULT_ALPHA,
                sigma.iter().map(|s| DEFAULT_ALPHA / (s * s)).collect(),
            ),
            Regularization::Gcv => {
                let alpha = self.gcv_alpha(&sigma).unwrap_or(DEFAULT_ALPHA);
                (alpha, sigma.iter().map(|s| alpha / (s * s)).collect())
            }
        };
        let mut m = Mat::<f64>::from_fn(k, k, |i, j| self.normal[i * k + j]);
        for i in 0..k {
            m[(i, i)] += penalty[i];
        }
        let condition_number = condition_number(&m);
        let mut x = Mat::<f64>::from_fn(k, 3, |i, c| self.rhs[i][c]);
        match m.llt(Side::Lower) {
            Ok(llt) => llt.solve_in_place(x.as_mut()),
            // N + Λ is positive definite for any positive penalty; this guards rounding.
            Err(_) => {
                let jitter = m.norm_max() * 1e-12 + 1e-300;
                for i in 0..k {
                    m[(i, i)] += jitter;
                }
                match m.llt(Side::Lower) {
                    Ok(llt) => llt.solve_in_place(x.as_mut()),
                    Err(_) => x.fill(0.0),
                }
            }
        }
        let coefficients = (0..k)
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
            condition_number,
            observed_bins: self.observed.len(),
        }
    }

    /// α minimising the generalised cross-validation score, shared by R, G and B.
    /// `None` when there are too few observations for cross-validation to mean anything.
    fn gcv_alpha(&self, sigma: &[f64]) -> Option<f64> {
        let k = sigma.len();
        if self.weight_sum < (k + 2) as f64 {
            return None;
        }
        // Whitened normal matrix A = S N S = Q E Qᵀ, and g_c = Qᵀ S r_c.
        let a = Mat::<f64>::from_fn(k, k, |i, j| sigma[i] * self.normal[i * k + j] * sigma[j]);
        let eigen = a.self_adjoint_eigen(Side::Lower).ok()?;
        let (q, e) = (eigen.U(), eigen.S().column_vector());
        let e: Vec<f64> = (0..k).map(|i| e[i].max(0.0)).collect();
        let g: Vec<[f64; 3]> = (0..k)
            .map(|i| {
                std::array::from_fn(|c| (0..k).map(|j| q[(j, i)] * sigma[j] * self.rhs[j][c]).sum())
            })
            .collect();
        let n = 3.0 * self.weight_sum;
        let yty: f64 = self.yty.iter().sum();
        let score = |log_alpha: f64| -> f64 {
            let alpha = log_alpha.exp();
            let (mut rss, mut df) = (yty, 0.0);
            for i in 0..k {
                let d = e[i] + alpha;
                let g2: f64 = g[i].iter().map(|v| v * v).sum();
                rss -= g2 * (e[i] + 2.0 * alpha) / (d * d);
                df += 3.0 * e[i] / d;
            }
            let dof = n - df;
            if dof <= 1e-9 * n {
                f64::INFINITY
            } else {
                n * rss.max(0.0) / (dof * dof)
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

fn accumulate(
    normal: &mut [f64],
    rhs: &mut [[f64; 3]],
    yty: &mut [f64; 3],
    obs: &Observed,
    sign: f64,
    k: usize,
) {
    let w = sign * obs.weight;
    for i in 0..k {
        let wu = w * obs.row[i];
        let row = &mut normal[i * k..(i + 1) * k];
        for (n, u) in row.iter_mut().zip(obs.row.iter()) {
            *n += wu * u;
        }
        for c in 0..3 {
            rhs[i][c] += wu * obs.y[c];
        }
    }
    for c in 0..3 {
        yty[c] += w * obs.y[c] * obs.y[c];
    }
}

/// max/min eigenvalue of a symmetric positive semi-definite matrix. A singular matrix reports
/// 1/ε (what f64 can resolve) rather than infinity, so the figure stays printable and finite.
fn condition_number(m: &Mat<f64>) -> f64 {
    let limit = 1.0 / f64::EPSILON;
    match m.self_adjoint_eigenvalues(Side::Lower) {
        Ok(values) if !values.is_empty() => {
            let max = values.iter().copied().fold(0.0, f64::max);
            let min = values.iter().copied().fold(f64::INFINITY, f64::min);
            if max.is_nan() || max <= 0.0 || !max.is_finite() {
                limit
            } else {
                (max / min.max(max / limit)).min(limit)
            }
        }
        _ => limit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regularization_parses() {
        assert_eq!("auto".parse::<Regularization>(), Ok(Regularization::Auto));
        assert_eq!("gcv".parse::<Regularization>(), Ok(Regularization::Gcv));
        assert_eq!(
            "0.5".parse::<Regularization>(),
            Ok(Regularization::Prior { alpha: 0.5 })
        );
        assert_eq!(
            "ridge:2".parse::<Regularization>(),
            Ok(Regularization::Ridge { lambda: 2.0 })
        );
        assert!("-1".parse::<Regularization>().is_err());
        assert!("nan".parse::<Regularization>().is_err());
        assert!("foo:1".parse::<Regularization>().is_err());
        for r in [
            Regularization::Ridge { lambda: 1e-300 },
            Regularization::Prior { alpha: 1e12 },
            Regularization::Prior { alpha: 0.5 },
        ] {
            let text = r.to_string();
            assert!(text.len() < 16, "{text}");
            assert_eq!(text.parse::<Regularization>(), Ok(r));
        }
    }
}
