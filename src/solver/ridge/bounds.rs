//! Censored bins: clipped 8-bit paint says "at least this bright", black paint "at most this
//! dark". How such a bin enters the normal equations, and the bounded solve.

use super::{Observed, Solver};
use crate::basis::map_value;
use crate::solver::prior::Censoring;
use crate::solver::sparse::{Bound, Bounds, EXACT};
use crate::table::PairIndex;
use faer::Mat;

/// The widest mapped interval an upper bound may span and still count as a value (see
/// `Solver::pin_narrow_bounds`): a tenth of a log unit, far below the noise √α.
const NARROW_BOUND_WIDTH: f64 = 0.1;

/// A bounded channel's y moved to `prediction` where the bound allows it: max for "at
/// least", min for "at most"; exact channels keep theirs.
pub(super) fn at_prediction_where_allowed(
    y: [f64; 3],
    bounds: Bounds,
    prediction: [f64; 3],
) -> [f64; 3] {
    std::array::from_fn(|c| match bounds[c] {
        Bound::Exact => y[c],
        Bound::AtLeast => y[c].max(prediction[c]),
        Bound::AtMost => y[c].min(prediction[c]),
    })
}

impl Solver {
    /// y of a bin as the normal equations hold it: [`Self::centred`], except that a bound
    /// the prior's own prediction already meets counts at that prediction, not at
    /// the bound. Clipped paint says "at least this bright"; a reference that is brighter
    /// agrees with it, and measuring it at the clip level would pull every solve (and the
    /// evidence for the reference) down to a value the paint never said. The bounded solve
    /// starts from there and moves only where the bound is broken.
    pub(super) fn measured(&self, pair: PairIndex, rho: [f64; 3], bounds: Bounds) -> [f64; 3] {
        let y = self.centred(pair, rho);
        if bounds == EXACT {
            return y;
        }
        let prediction: [f64; 3] = match &self.prior_mean {
            None => [0.0; 3],
            Some(mean) => {
                let row = self.basis.row(pair);
                std::array::from_fn(|c| row.iter().zip(mean).map(|(&u, m)| u as f64 * m[c]).sum())
            }
        };
        at_prediction_where_allowed(y, bounds, prediction)
    }

    /// An upper bound whose whole interval [0, b] maps to less than [`NARROW_BOUND_WIDTH`]
    /// (a black 8-bit pixel: ρc far below the map's ε) says as much as a value: it becomes an
    /// exact observation at b/2. Left a bound, it lets the fit drive such bins far below the
    /// map's floor, which costs nothing there and frees the coefficients to overshoot
    /// elsewhere: on the calibration folds, one view of an 8-bit metal doubled its error so.
    pub(super) fn pin_narrow_bounds(
        &self,
        pair: PairIndex,
        rho: [f64; 3],
        bounds: Bounds,
    ) -> ([f64; 3], Bounds) {
        if bounds.iter().all(|&b| b != Bound::AtMost) {
            return (rho, bounds);
        }
        let c = crate::basis::cos_weight(pair);
        let (mut rho, mut bounds) = (rho, bounds);
        for ch in 0..3 {
            // The mapped length of [0, b]: with reference 0, 0 maps to ln 1 = 0 exactly, so
            // b's mapped value, ln(1 + bc/ε), is that length.
            let width = map_value(rho[ch], c, 0.0);
            if bounds[ch] == Bound::AtMost && width <= NARROW_BOUND_WIDTH {
                rho[ch] *= 0.5;
                bounds[ch] = Bound::Exact;
            }
        }
        (rho, bounds)
    }

    /// Bounded channels (clipped paint) by majorise–minimise: each bounded observation is
    /// refitted to the bound or to the current prediction, whichever the bound allows
    /// (max for "at least", min for "at most"), and the system solved again. The normal
    /// matrix already holds every observed row, so only the right-hand side changes, and each
    /// step lowers the one-sided squared loss; it stops when the coefficients settle.
    pub(super) fn enforce_bounds(
        &self,
        x: &mut Mat<f64>,
        rhs: &Mat<f64>,
        solve: impl Fn(&Mat<f64>) -> Mat<f64>,
    ) {
        const TOLERANCE: f64 = 1e-10;
        let Censoring::Bounds { steps } = self.model.censoring else {
            return;
        };
        if self.censored.is_empty() {
            return;
        }
        let k = self.basis.components();
        // The bounds themselves; the normal equations hold each bin at its prior's prediction
        // where that meets the bound (`Self::measured`).
        let censored: Vec<(&Observed, [f64; 3])> = self
            .censored
            .iter()
            .map(|pair| {
                (
                    &self.observed[pair],
                    self.centred(*pair, self.observed[pair].rho),
                )
            })
            .collect();
        for _ in 0..steps {
            let mut shifted = rhs.clone();
            for &(obs, bound_y) in &censored {
                let blocks = obs.band.pairs();
                for c in 0..3 {
                    let bound = obs.bounds[c];
                    if bound == Bound::Exact {
                        continue;
                    }
                    let mut predicted = 0.0;
                    for &(j, phi) in &blocks {
                        if phi != 0.0 {
                            predicted +=
                                phi * (0..k).map(|i| obs.row[i] * x[(j * k + i, c)]).sum::<f64>();
                        }
                    }
                    let target = match bound {
                        Bound::AtLeast => predicted.max(bound_y[c]),
                        Bound::AtMost => predicted.min(bound_y[c]),
                        Bound::Exact => obs.y[c],
                    };
                    let shift = obs.weight * (target - obs.y[c]);
                    for &(j, phi) in &blocks {
                        if phi != 0.0 {
                            for i in 0..k {
                                shifted[(j * k + i, c)] += shift * phi * obs.row[i];
                            }
                        }
                    }
                }
            }
            let next = solve(&shifted);
            let change = (&next - &*x).norm_max();
            let scale = next.norm_max().max(1.0);
            *x = next;
            if change.is_nan() || change <= TOLERANCE * scale {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::small_test_basis;
    use crate::basis::{Basis, cos_weight};
    use crate::solver::prior::PriorModel;
    use crate::solver::{BinChange, Regularization};
    use crate::table::PAIRS;
    use Bound::{AtLeast, AtMost, Exact};
    use std::sync::Arc;

    fn basis() -> Arc<Basis> {
        small_test_basis()
    }

    fn solver(censoring: Censoring) -> Solver {
        let model = PriorModel {
            censoring,
            ..PriorModel::CALIBRATED
        };
        Solver::with_model(basis(), Regularization::Auto, model)
    }

    #[test]
    fn a_bound_moves_to_the_prediction_only_where_it_allows_it() {
        let y = [1.0, 1.0, 1.0];
        let bounds = [Exact, AtLeast, AtMost];
        assert_eq!(
            at_prediction_where_allowed(y, bounds, [5.0; 3]),
            [1.0, 5.0, 1.0]
        );
        assert_eq!(
            at_prediction_where_allowed(y, bounds, [-5.0; 3]),
            [1.0, 1.0, -5.0]
        );
    }

    /// A bounded bin is measured at the prior's own prediction (ψ·x₀ for a start x₀) where
    /// that meets the bound, at the bound elsewhere; an exact bin at its value.
    #[test]
    fn a_bound_the_prior_meets_counts_at_the_prior() {
        let mut solver = solver(Censoring::Bounds { steps: 200 });
        let k = solver.basis.components();
        let mean: Vec<[f64; 3]> = (0..k)
            .map(|i| [0.3 / (i + 1) as f64, -0.2, 0.1 * i as f64])
            .collect();
        solver.set_prior_mean(Some(mean.clone()));
        let pair = PairIndex::from_index(654_321);
        let row = solver.basis.row(pair);
        let prediction: [f64; 3] =
            std::array::from_fn(|c| (0..k).map(|i| row[i] as f64 * mean[i][c]).sum());
        for rho in [[1e-4; 3], [0.05; 3], [20.0; 3]] {
            let y = solver.centred(pair, rho);
            assert_eq!(solver.measured(pair, rho, EXACT), y);
            let at_least = solver.measured(pair, rho, [AtLeast; 3]);
            let at_most = solver.measured(pair, rho, [AtMost; 3]);
            for c in 0..3 {
                assert!((at_least[c] - y[c].max(prediction[c])).abs() < 1e-12);
                assert!((at_most[c] - y[c].min(prediction[c])).abs() < 1e-12);
            }
        }
        // The values above straddle the prediction, so both sides were tried.
        let (low, high) = (
            solver.centred(pair, [1e-4; 3]),
            solver.centred(pair, [20.0; 3]),
        );
        assert!((0..3).all(|c| low[c] < prediction[c] && prediction[c] < high[c]));
    }

    /// A black 8-bit pixel's "at most" becomes a value at half the bound; a wide "at most",
    /// an "at least" and an exact channel stay as they are, however dark.
    #[test]
    fn only_a_narrow_upper_bound_is_pinned_to_a_value() {
        let solver = solver(Censoring::Bounds { steps: 200 });
        let pair = PairIndex::from_index(777_777);
        let black = 1e-6;
        // ln(1 + ρc/ε), written out apart from the code's map_value.
        let width = |rho: f64| (1.0 + rho * cos_weight(pair) / crate::basis::MAP_EPSILON).ln();
        assert!(width(black) < 0.01 * NARROW_BOUND_WIDTH && width(0.5) > NARROW_BOUND_WIDTH);

        let (rho, bounds) = solver.pin_narrow_bounds(pair, [black; 3], [AtMost; 3]);
        assert_eq!((rho, bounds), ([black / 2.0; 3], EXACT));
        let mixed = [AtMost, Exact, AtLeast];
        assert_eq!(
            solver.pin_narrow_bounds(pair, [black; 3], mixed),
            ([black / 2.0, black, black], [Exact, Exact, AtLeast])
        );
        assert_eq!(
            solver.pin_narrow_bounds(pair, [0.5, black, black], mixed),
            ([0.5, black, black], mixed)
        );
        assert_eq!(
            solver.pin_narrow_bounds(pair, [black; 3], [AtLeast; 3]),
            ([black; 3], [AtLeast; 3])
        );
    }

    /// The bounded solve ends at a stationary point of the one-sided loss: the prior plus,
    /// per observed channel, w·(y − ŷ)² for a value and w·(b − ŷ)² only where ŷ breaks the
    /// bound b. Its gradient, (N + αP₀)x − Σ w·ψ·target with target y, max(ŷ, b) or
    /// min(ŷ, b), vanishes there; the plain solve that holds every bound at its measured
    /// value does not reach it.
    #[test]
    fn the_bounded_solve_is_stationary_for_the_one_sided_loss() {
        let build = |steps: usize| {
            let mut solver = solver(Censoring::Bounds { steps });
            for i in 0..400 {
                let pair = PairIndex::from_index(i * 1_299_709 % PAIRS);
                let rho = [0.1, 0.2, 0.3].map(|v| v * (1.0 + 0.05 * (i % 5) as f64));
                solver.apply(&BinChange::observed(pair, rho, EXACT));
            }
            for i in 0..60 {
                let pair = PairIndex::from_index((i * 7_919 + 11) * 97 % PAIRS);
                // Clipped highlights far above the rest, and bounds far below the prior.
                let (rho, bound) = match i % 3 {
                    0 => ([3.0; 3], [AtLeast; 3]),
                    1 => ([1e-3; 3], [AtLeast; 3]),
                    _ => ([0.02; 3], [AtMost, Exact, AtMost]),
                };
                solver.apply(&BinChange::observed(pair, rho, bound));
            }
            solver
        };
        let gradient = |solver: &Solver, x: &[[f64; 3]]| -> f64 {
            let (m, _, _, _) = solver.system();
            let (d, k) = (m.nrows(), solver.basis.components());
            let mut g: Vec<[f64; 3]> = (0..d)
                .map(|i| std::array::from_fn(|c| (0..d).map(|j| m[(i, j)] * x[j][c]).sum()))
                .collect();
            let mut scale = 0.0f64;
            for (&pair, obs) in &solver.observed {
                let blocks = obs.band.pairs();
                let bound = solver.centred(pair, obs.rho);
                for c in 0..3 {
                    let predicted: f64 = blocks
                        .iter()
                        .filter(|(_, phi)| *phi != 0.0)
                        .map(|&(j, phi)| {
                            phi * (0..k).map(|i| obs.row[i] * x[j * k + i][c]).sum::<f64>()
                        })
                        .sum();
                    let target = match obs.bounds[c] {
                        Exact => obs.y[c],
                        AtLeast => predicted.max(bound[c]),
                        AtMost => predicted.min(bound[c]),
                    };
                    for &(j, phi) in blocks.iter().filter(|(_, phi)| *phi != 0.0) {
                        for i in 0..k {
                            let term = obs.weight * phi * obs.row[i] * target;
                            g[j * k + i][c] -= term;
                            scale = scale.max(term.abs());
                        }
                    }
                }
            }
            g.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs())) / scale
        };
        let bounded = build(100_000);
        assert_eq!(bounded.censored.len(), 60);
        let x = bounded.solve().coefficients;
        let stationary = gradient(&bounded, &x);
        let plain = build(0);
        let unmoved = gradient(&plain, &plain.solve().coefficients);
        assert!(stationary < 1e-7, "relative gradient {stationary:e}");
        assert!(
            unmoved > 1e-3,
            "the plain solve is already stationary: {unmoved:e}"
        );
    }
}
