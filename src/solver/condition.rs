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

    /// Hager's steps themselves, on symmetric operators chosen so that each step moves the
    /// estimate (from 7 to 15 to 21 = ‖B‖₁, reached at the second unit vector) and so that
    /// Higham's alternating vector is what finds the larger figure on a second one. The
    /// solves are recorded: a change to the stopping tests, the sign vector or the choice of
    /// column shows as a different sequence, even where the estimate would survive it.
    #[test]
    fn the_condition_estimate_takes_hagers_steps() {
        use std::cell::RefCell;
        // Applies the symmetric b in place of a solve, recording what it was asked to solve.
        fn run<const D: usize>(b: &[[f64; D]; D]) -> (f64, Vec<Vec<f64>>) {
            let solves = RefCell::new(Vec::new());
            let estimate = inverse_norm_1_estimate(D, |x| {
                solves
                    .borrow_mut()
                    .push((0..D).map(|i| x[(i, 0)]).collect());
                Mat::<f64>::from_fn(D, 1, |i, _| (0..D).map(|j| b[i][j] * x[(j, 0)]).sum())
            });
            (estimate, solves.into_inner())
        }
        fn assert_solves<const D: usize>(solves: &[Vec<f64>], expected: &[[f64; D]]) {
            assert_eq!(solves.len(), expected.len(), "{solves:?}");
            for (got, want) in solves.iter().zip(expected) {
                let close = got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12);
                assert!(close, "solved {got:?}, expected {want:?}");
            }
        }
        // Column sums of |b|: 16, 21, 15, 16.
        let b = [
            [-8.0, -3.0, -3.0, 2.0],
            [-3.0, 8.0, 5.0, -5.0],
            [-3.0, 5.0, 6.0, -1.0],
            [2.0, -5.0, -1.0, 8.0],
        ];
        let (estimate, solves) = run(&b);
        assert_eq!(estimate, 21.0);
        let expected: [[f64; 4]; 7] = [
            [0.25; 4],
            // ‖B x‖₁ = 7; the sign of B x, whose solve points at column 2.
            [-1.0, 1.0, 1.0, 1.0],
            [0.0, 0.0, 1.0, 0.0],
            // Column 2 gives 15, and points at column 1.
            [-1.0, 1.0, 1.0, -1.0],
            [0.0, 1.0, 0.0, 0.0],
            // Column 1 gives 21, and its sign vector's solve gains nothing: stop.
            [-1.0, 1.0, 1.0, -1.0],
            // Higham's vector, (−1)^i (1 + i/(d − 1)).
            [1.0, -4.0 / 3.0, 5.0 / 3.0, -2.0],
        ];
        assert_solves(&solves, &expected);

        // Hager stops at 7 (column 0) while ‖B‖₁ is 16; the alternating vector
        // (1, −1.25, 1.5, −1.75, 2) gives 2 ‖B v‖₁ / 3d = 2 · 60.5 / 15. The second sign
        // vector is all ones because column 0 has zeros: a zero entry counts as positive.
        let b = [
            [6.0, 0.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0, 4.0, 1.0],
            [0.0, -1.0, 2.0, -1.0, -1.0],
            [0.0, 4.0, -1.0, 6.0, -5.0],
            [1.0, 1.0, -1.0, -5.0, 4.0],
        ];
        let (estimate, solves) = run(&b);
        assert!((estimate - 121.0 / 15.0).abs() < 1e-12, "{estimate}");
        let expected: [[f64; 5]; 5] = [
            [0.2; 5],
            [1.0, 1.0, -1.0, 1.0, 1.0],
            [1.0, 0.0, 0.0, 0.0, 0.0],
            [1.0; 5],
            [1.0, -1.25, 1.5, -1.75, 2.0],
        ];
        assert_solves(&solves, &expected);

        // The uniform start lies in this b's null space, so the first figure is 0 and the
        // sign vector (all ones) also solves to 0: column 0 is chosen. Column 0 gives 0.5 and
        // points at column 2; column 2 gives 1 and its sign vector's solve (0, −1, 1) points
        // at column 1, but gains nothing over column 2 (max |z| = zᵀx = 1): the other
        // stopping test. Every |z| is at most 1, so the largest is sought from below.
        let b = [[0.25, -0.25, 0.0], [-0.25, -0.25, 0.5], [0.0, 0.5, -0.5]];
        let (estimate, solves) = run(&b);
        assert_eq!(estimate, 1.0);
        let third = 1.0 / 3.0;
        let expected: [[f64; 3]; 7] = [
            [third; 3],
            [1.0; 3],
            [1.0, 0.0, 0.0],
            [1.0, -1.0, 1.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, -1.0],
            [1.0, -1.5, 2.0],
        ];
        assert_solves(&solves, &expected);

        // A zero operator: the second figure (0) is no gain over the first, so it stops there.
        let (estimate, solves) = run(&[[0.0; 3]; 3]);
        assert_eq!(estimate, 0.0);
        let expected: [[f64; 3]; 4] = [[third; 3], [1.0; 3], [1.0, 0.0, 0.0], [1.0, -1.5, 2.0]];
        assert_solves(&solves, &expected);
    }
}
