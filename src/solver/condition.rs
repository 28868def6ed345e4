//! The condition number of the regularised normal matrix, estimated from its factor.

use faer::Mat;

/// What f64 can resolve: the condition number reported for a singular matrix, so the figure
/// stays printable and finite.
pub(super) const CONDITION_LIMIT: f64 = 1.0 / f64::EPSILON;

pub(super) fn bounded_condition(c: f64) -> f64 {
    if c.is_finite() {
        c.clamp(1.0, CONDITION_LIMIT)
    } else {
        CONDITION_LIMIT
    }
}

/// ‖M‖₁: the largest column sum of |m_ij|.
pub(super) fn norm_1(m: &Mat<f64>) -> f64 {
    (0..m.ncols())
        .map(|j| (0..m.nrows()).map(|i| m[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// An estimate of ‖M⁻¹‖₁ for a symmetric M from a few solves with its factor (Hager's
/// method with Higham's safeguard, as LAPACK's `dpocon`): O(D²) where the eigenvalues that
/// gave the exact 2-norm condition number cost O(D³) and most of a dab's time at D = 5K. The
/// estimate is a lower bound of ‖M⁻¹‖₁, in practice within a factor 3; for symmetric M,
/// ‖M‖₁‖M⁻¹‖₁ is at least the 2-norm condition number.
pub(super) fn inverse_norm_1_estimate(d: usize, solve: impl Fn(&Mat<f64>) -> Mat<f64>) -> f64 {
    const ITERATIONS: usize = 5;
    if d == 0 {
        return 0.0;
    }
    let norm = |y: &Mat<f64>| (0..d).map(|i| y[(i, 0)].abs()).sum::<f64>();
    let mut x = Mat::<f64>::from_fn(d, 1, |_, _| 1.0 / d as f64);
    let mut estimate = 0.0;
    let mut last_j = usize::MAX;
    for iteration in 0..ITERATIONS {
        let y = solve(&x);
        let candidate = norm(&y);
        if !candidate.is_finite() {
            return f64::INFINITY;
        }
        if iteration > 0 && candidate <= estimate {
            break;
        }
        estimate = candidate;
        let sign = Mat::<f64>::from_fn(d, 1, |i, _| if y[(i, 0)] >= 0.0 { 1.0 } else { -1.0 });
        // M is symmetric: M⁻ᵀ = M⁻¹.
        let z = solve(&sign);
        let (j, z_max) = (0..d)
            .map(|i| (i, z[(i, 0)].abs()))
            .fold((0, -1.0), |best, c| if c.1 > best.1 { c } else { best });
        let z_dot_x = (0..d).map(|i| z[(i, 0)] * x[(i, 0)]).sum::<f64>();
        if (iteration > 0 && z_max <= z_dot_x) || j == last_j {
            break;
        }
        last_j = j;
        x = Mat::<f64>::zeros(d, 1);
        x[(j, 0)] = 1.0;
    }
    // Higham's alternating vector catches what the unit vectors miss.
    let alternating = Mat::<f64>::from_fn(d, 1, |i, _| {
        let magnitude = 1.0 + i as f64 / (d.max(2) - 1) as f64;
        if i % 2 == 0 { magnitude } else { -magnitude }
    });
    let extra = 2.0 * norm(&solve(&alternating)) / (3.0 * d as f64);
    estimate.max(extra)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Side;
    use faer::linalg::solvers::{DenseSolveCore, Solve};

    /// The estimate against the exact 2-norm condition number (eigenvalues) and the exact
    /// 1-norm one (the inverse), on SPD matrices from well to badly conditioned.
    #[test]
    fn the_condition_estimate_tracks_the_exact_one() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        for (d, spread) in [(5, 1.0f64), (40, 1e3), (100, 1e6), (100, 1e10)] {
            let a = Mat::<f64>::from_fn(d, d, |_, _| rng.random::<f64>() - 0.5);
            // Q from a QR of a random matrix, eigenvalues spread log-uniformly.
            let q = a.qr().compute_Q();
            let lambda: Vec<f64> = (0..d)
                .map(|i| spread.powf(i as f64 / (d - 1).max(1) as f64))
                .collect();
            let m = Mat::<f64>::from_fn(d, d, |i, j| {
                (0..d)
                    .map(|k| q[(i, k)] * lambda[k] * q[(j, k)])
                    .sum::<f64>()
            });
            let llt = m.llt(Side::Lower).unwrap();
            let estimate = norm_1(&m) * inverse_norm_1_estimate(d, |b| llt.solve(b));
            let exact_1 = norm_1(&m) * norm_1(&llt.inverse());
            let exact_2 = spread;
            assert!(
                estimate <= exact_1 * (1.0 + 1e-6) && estimate >= exact_1 / 3.0,
                "d {d}: estimate {estimate:e}, exact 1-norm {exact_1:e}"
            );
            assert!(
                estimate >= exact_2 / 3.0,
                "d {d}: estimate {estimate:e}, 2-norm {exact_2:e}"
            );
        }
    }

    /// The edges: the bound on the reported figure, an empty system, a solve that
    /// overflows, and matrices whose inverse norm the estimate must hit exactly.
    #[test]
    fn the_condition_estimate_is_exact_where_it_can_be_and_bounded_everywhere() {
        assert_eq!(CONDITION_LIMIT, 1.0 / f64::EPSILON);
        assert_eq!(bounded_condition(f64::NAN), CONDITION_LIMIT);
        assert_eq!(bounded_condition(f64::INFINITY), CONDITION_LIMIT);
        assert_eq!(bounded_condition(1e300), CONDITION_LIMIT);
        assert_eq!(bounded_condition(0.25), 1.0);
        assert_eq!(bounded_condition(42.0), 42.0);

        assert_eq!(inverse_norm_1_estimate(0, |b| b.clone()), 0.0);
        let overflow = |b: &Mat<f64>| Mat::<f64>::from_fn(b.nrows(), 1, |_, _| f64::INFINITY);
        assert_eq!(inverse_norm_1_estimate(3, overflow), f64::INFINITY);

        // Diagonal: ‖M⁻¹‖₁ is the largest 1/m_ii, wherever it sits.
        for d in [1, 2, 7] {
            for big in 0..d {
                let m = Mat::<f64>::from_fn(d, d, |i, j| {
                    if i != j {
                        0.0
                    } else if i == big {
                        0.01
                    } else {
                        1.0 + i as f64
                    }
                });
                let solve = |b: &Mat<f64>| Mat::<f64>::from_fn(d, 1, |i, _| b[(i, 0)] / m[(i, i)]);
                let estimate = inverse_norm_1_estimate(d, solve);
                assert!((estimate - 100.0).abs() < 1e-9, "d {d}, {big}: {estimate}");
                let largest = (0..d).filter(|&i| i != big).map(|i| 1.0 + i as f64);
                assert_eq!(norm_1(&m), largest.fold(0.01, f64::max));
            }
        }
        // A dense SPD matrix whose inverse has one dominant column: [[2, 1], [1, 1]]⁻¹ =
        // [[1, −1], [−1, 2]], ‖·‖₁ = 3, and ‖M‖₁ = 3.
        let m = Mat::<f64>::from_fn(2, 2, |i, j| if i == 0 && j == 0 { 2.0 } else { 1.0 });
        let inverse = |b: &Mat<f64>| {
            Mat::<f64>::from_fn(2, 1, |i, _| {
                if i == 0 {
                    b[(0, 0)] - b[(1, 0)]
                } else {
                    2.0 * b[(1, 0)] - b[(0, 0)]
                }
            })
        };
        assert_eq!(norm_1(&m), 3.0);
        assert!((inverse_norm_1_estimate(2, inverse) - 3.0).abs() < 1e-12);
    }
}
