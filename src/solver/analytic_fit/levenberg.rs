//! Levenberg–Marquardt over the fit's parameters: the residuals, a forward-difference
//! Jacobian summed in deterministic chunks, and damped steps from several starts.

use super::model::{LambertMicrofacet, Prepared};
use super::params::{COAT_SHAPE, P, Params, SHAPE, Shape, model_of};
use super::{FitOptions, Observation};
use crate::basis::MAP_EPSILON;
use crate::materials::models::{Fresnel, Microfacet, above, cos_half_difference};
use crate::solver::sparse::Bound;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

/// The best fit of one lobe shape.
#[derive(Clone)]
pub(super) struct ShapeFit {
    pub(super) theta: Params,
    /// ½‖r‖² at `theta`.
    pub(super) cost: f64,
    /// LM iterations run over every start.
    pub(super) iterations: usize,
    pub(super) shape: Shape,
}

impl ShapeFit {
    pub(super) fn model(&self) -> LambertMicrofacet {
        model_of(&self.theta, self.shape)
    }
}

/// The best parameters for one lobe shape from `starts`: every start scouted for a few
/// iterations, the best finalists run to convergence.
pub(super) fn fit_shape(
    observations: &[Observation],
    starts: &[Params],
    shape: Shape,
    options: &FitOptions,
) -> ShapeFit {
    let mut iterations = 0;
    let mut scouted: Vec<(Params, f64)> = starts
        .iter()
        .map(|start| {
            let (theta, cost, it) =
                levenberg_marquardt(observations, *start, shape, options.scout_iterations);
            iterations += it;
            (theta, cost)
        })
        .collect();
    scouted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (mut best, mut best_cost) = (scouted[0].0, scouted[0].1);
    for &(theta, _) in scouted.iter().take(options.finalists.max(1)) {
        let (theta, cost, it) =
            levenberg_marquardt(observations, theta, shape, options.max_iterations);
        iterations += it;
        if cost < best_cost {
            (best, best_cost) = (theta, cost);
        }
    }
    ShapeFit {
        theta: best,
        cost: best_cost,
        iterations,
        shape,
    }
}

/// Bins per deterministic partial sum.
pub(super) const CHUNK: usize = 512;

/// Weighted log residuals of one observation under `model`; a bounded channel's is zero on
/// the side its bound allows.
#[inline]
pub(super) fn residuals(model: &Prepared, o: &Observation) -> [f64; 3] {
    residuals_of(model.eval(o.l, o.v), o)
}

/// [`residuals`] of a given ρ.
#[inline]
pub(super) fn residuals_of(rho: [f64; 3], o: &Observation) -> [f64; 3] {
    std::array::from_fn(|ch| {
        let r = (rho[ch] * o.c + MAP_EPSILON).ln() - o.target[ch];
        let r = match o.bounds[ch] {
            Bound::Exact => r,
            Bound::AtLeast => r.min(0.0),
            Bound::AtMost => r.max(0.0),
        };
        o.sqrt_weight * r
    })
}

/// ½‖r‖² at `theta`.
pub(super) fn cost(observations: &[Observation], theta: &Params, shape: Shape) -> f64 {
    let model = Prepared::new(model_of(theta, shape));
    let partials: Vec<f64> = observations
        .par_chunks(CHUNK)
        .map(|chunk| {
            chunk
                .iter()
                .map(|o| residuals(&model, o).iter().map(|r| r * r).sum::<f64>())
                .sum()
        })
        .collect();
    0.5 * partials.iter().sum::<f64>()
}

/// One parameter stepped for the forward-difference Jacobian: the stepped model and its
/// first lobe's Fresnel, the stepped lobe when the step changes a lobe's D·G (first,
/// second), and the step taken.
pub(super) struct Stepped {
    pub(super) model: LambertMicrofacet,
    pub(super) fresnel: Fresnel,
    pub(super) lobe: Option<Microfacet>,
    pub(super) second: Option<Microfacet>,
    pub(super) h: f64,
}

/// JᵀJ, Jᵀr and ½‖r‖² at `theta`, with a forward-difference Jacobian, summed in chunk order.
/// Only a lobe's shape (the first's two roughnesses and turn, the second's roughness) changes
/// its D·G, so a bin evaluates each lobe once at `theta` and once per shape step rather than
/// once per parameter; every stepped ρ is still the bits [`Brdf::eval`] would give.
pub(super) fn normal_equations(
    observations: &[Observation],
    theta: &Params,
    shape: Shape,
) -> ([f64; P * P], Params, f64) {
    const STEP: f64 = 1e-6;
    let (active, n) = shape.active();
    let base = model_of(theta, shape);
    let lobe = base.parts().1;
    let second = base.second_part();
    let stepped: Vec<Stepped> = active[..n]
        .iter()
        .map(|&i| {
            let mut t = *theta;
            let h = STEP * theta[i].abs().max(1.0);
            t[i] += h;
            let model = model_of(&t, shape);
            Stepped {
                lobe: SHAPE.contains(&i).then(|| model.parts().1),
                // A haze's lobe carries the first's Fresnel, which its D·G does not use.
                second: (i == COAT_SHAPE).then(|| model.second_part()).flatten(),
                fresnel: model.fresnel(),
                model,
                h: t[i] - theta[i],
            }
        })
        .collect();
    let partials: Vec<([f64; P * P], Params, f64)> = observations
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut jtj = [0.0; P * P];
            let mut jtr = [0.0; P];
            let mut sum = 0.0;
            for o in chunk {
                let visible = above(o.l, o.v);
                let cos_d = cos_half_difference(o.l, o.v);
                let dg = lobe.eval_unit_fresnel(o.l, o.v);
                let dg_second = second
                    .as_ref()
                    .map_or(0.0, |s| s.eval_unit_fresnel(o.l, o.v));
                let rho = base.eval_from_lobes(&lobe.fresnel, visible, dg, dg_second, cos_d);
                let r = residuals_of(rho, o);
                let mut jac = [[0.0; P]; 3];
                for (j, step) in stepped.iter().enumerate() {
                    let dg = step
                        .lobe
                        .as_ref()
                        .map_or(dg, |moved| moved.eval_unit_fresnel(o.l, o.v));
                    let dg_second = step
                        .second
                        .as_ref()
                        .map_or(dg_second, |moved| moved.eval_unit_fresnel(o.l, o.v));
                    let rho =
                        step.model
                            .eval_from_lobes(&step.fresnel, visible, dg, dg_second, cos_d);
                    let rp = residuals_of(rho, o);
                    for ch in 0..3 {
                        jac[ch][j] = (rp[ch] - r[ch]) / step.h;
                    }
                }
                for ch in 0..3 {
                    sum += r[ch] * r[ch];
                    for a in 0..n {
                        jtr[a] += jac[ch][a] * r[ch];
                        for b in a..n {
                            jtj[a * P + b] += jac[ch][a] * jac[ch][b];
                        }
                    }
                }
            }
            (jtj, jtr, sum)
        })
        .collect();
    let mut jtj = [0.0; P * P];
    let mut jtr = [0.0; P];
    let mut sum = 0.0;
    for (a, b, s) in &partials {
        for i in 0..P * P {
            jtj[i] += a[i];
        }
        for i in 0..P {
            jtr[i] += b[i];
        }
        sum += s;
    }
    for a in 0..n {
        for b in 0..a {
            jtj[a * P + b] = jtj[b * P + a];
        }
    }
    (jtj, jtr, 0.5 * sum)
}

/// Solves (JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr over the first `n` parameters; `None` when the damped
/// matrix is not positive definite.
pub(super) fn damped_step(
    jtj: &[f64; P * P],
    jtr: &Params,
    lambda: f64,
    n: usize,
) -> Option<Params> {
    let mut m = Mat::<f64>::from_fn(n, n, |i, j| jtj[i * P + j]);
    for i in 0..n {
        m[(i, i)] += lambda * jtj[i * P + i].max(1e-12);
    }
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| -jtr[i]);
    m.llt(Side::Lower).ok()?.solve_in_place(x.as_mut());
    let step: Params = std::array::from_fn(|i| if i < n { x[(i, 0)] } else { 0.0 });
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// Runs at most `max_iterations` LM iterations from `theta`; returns the parameters, their
/// cost and the iterations run.
pub(super) fn levenberg_marquardt(
    observations: &[Observation],
    mut theta: Params,
    shape: Shape,
    max_iterations: usize,
) -> (Params, f64, usize) {
    let (active, n) = shape.active();
    let mut lambda = 1e-3;
    let (mut jtj, mut jtr, mut current) = normal_equations(observations, &theta, shape);
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let mut accepted = false;
        // Raise the damping until a step lowers the cost (or the damping is hopeless).
        while lambda < 1e10 {
            if let Some(step) = damped_step(&jtj, &jtr, lambda, n) {
                let mut trial = theta;
                for (j, &i) in active[..n].iter().enumerate() {
                    trial[i] += step[j];
                }
                let trial_cost = cost(observations, &trial, shape);
                if trial_cost.is_finite() && trial_cost < current {
                    let gain = (current - trial_cost) / current.max(f64::MIN_POSITIVE);
                    theta = trial;
                    lambda = (lambda / 3.0).max(1e-9);
                    accepted = true;
                    if gain < 1e-9 {
                        return (theta, trial_cost, iterations);
                    }
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
        (jtj, jtr, current) = normal_equations(observations, &theta, shape);
    }
    (theta, current, iterations)
}
