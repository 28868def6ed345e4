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
            // The mapped length of [0, b]; the map's reference cancels out.
            let width = map_value(rho[ch], c, 0.0) - map_value(0.0, c, 0.0);
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
