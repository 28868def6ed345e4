//! The stability probe: the solver on the hardest systems the stress tests (tests/stress.rs,
//! fuzz/) generate, each solved once with the bench's basis and its whole table materialised,
//! so the report can say what the worst condition number is and what the solver does there.

use crate::basis::Basis;
use crate::scene::GBuffer;
use crate::solver::{Policy, Reconstruction, Regularization, SampleKey, Solver, SparseTable};
use crate::table::{DirIndex, PHI_BINS};
use std::sync::Arc;

/// One probed system and what came out of it.
#[derive(Clone, Debug)]
pub struct StabilityCase {
    pub name: &'static str,
    pub regularization: Regularization,
    pub observed_bins: usize,
    /// Of the regularised normal matrix the solver factored (capped at 1/ε).
    pub condition_number: f64,
    /// The α (or λ) the solve used.
    pub alpha: f64,
    /// Largest |x| among the coefficients.
    pub max_coefficient: f64,
    /// Smallest and largest ρ of the materialised table.
    pub min_rho: f32,
    pub max_rho: f32,
    /// Every entry finite and ≥ 0.
    pub physical: bool,
    /// RMS of ln((ρ + ε) / (ρ_mean + ε)) against the mean material: how far the painting
    /// moved the reconstruction (0: the solver fell back to the mean material).
    pub log_distance_from_mean: f64,
}

/// Where the samples of a case go.
enum Bins {
    None,
    /// These (light, view) bins, one sample each.
    List(Vec<(DirIndex, DirIndex)>),
    /// Every lit pixel of the view the gbuffer describes.
    View,
}

fn direction(theta: usize, phi: usize) -> DirIndex {
    (theta * PHI_BINS + phi) as DirIndex
}

/// A 3 × 3 patch of neighbouring view bins under one light bin: nearly collinear basis rows.
fn collinear_patch() -> Vec<(DirIndex, DirIndex)> {
    (0..9)
        .map(|i| (direction(20, 4), direction(10 + i / 3, 7 + i % 3)))
        .collect()
}

/// Runs every case on `basis`; `view` is a painted view's gbuffer (the bench's first view).
pub fn probe(basis: &Arc<Basis>, view: &GBuffer) -> Vec<StabilityCase> {
    use Regularization::*;
    let spread = vec![
        (direction(5, 0), direction(30, 18)),
        (direction(12, 9), direction(12, 27)),
        (direction(40, 3), direction(2, 33)),
    ];
    let cases: Vec<(&'static str, Regularization, Bins, f64)> = vec![
        ("no sample", Auto, Bins::None, 0.0),
        (
            "one sample",
            Auto,
            Bins::List(vec![(direction(20, 4), direction(10, 7))]),
            0.2,
        ),
        ("three bins, K above them", Auto, Bins::List(spread), 0.2),
        (
            "3 × 3 neighbouring bins (collinear rows)",
            Auto,
            Bins::List(collinear_patch()),
            0.2,
        ),
        (
            "3 × 3 neighbouring bins, λ = 1e-300",
            Ridge { lambda: 1e-300 },
            Bins::List(collinear_patch()),
            0.2,
        ),
        (
            "3 × 3 neighbouring bins, α = 1e-12",
            Prior { alpha: 1e-12 },
            Bins::List(collinear_patch()),
            0.2,
        ),
        ("one view, ρ = 0.2", Auto, Bins::View, 0.2),
        ("one view, ρ = 0.2, GCV", Gcv, Bins::View, 0.2),
        (
            "one view, ρ = 0.2, α = 1e-12",
            Prior { alpha: 1e-12 },
            Bins::View,
            0.2,
        ),
        (
            "one view, ρ = 0.2, λ = 0",
            Ridge { lambda: 0.0 },
            Bins::View,
            0.2,
        ),
        (
            "one view, ρ = 0.2, α = 1e12",
            Prior { alpha: 1e12 },
            Bins::View,
            0.2,
        ),
        ("one view, all black (ρ = 0)", Auto, Bins::View, 0.0),
        ("one view, ρ = 1e-6", Auto, Bins::View, 1e-6),
        ("one view, saturated (ρ = 1e6)", Auto, Bins::View, 1e6),
    ];
    let mean = Reconstruction::mean_material(basis.clone()).materialize();
    cases
        .into_iter()
        .map(|(name, regularization, bins, rho)| {
            let mut table = SparseTable::new(Policy::Mean);
            let mut changes = Vec::new();
            let mut add = |pixel: u32, d_l: DirIndex, d_v: DirIndex| {
                let key = SampleKey { view: 0, pixel };
                table
                    .set_sample(key, d_l, d_v, [rho, 0.8 * rho, 0.6 * rho], &mut changes)
                    .expect("finite, non-negative samples");
            };
            match bins {
                Bins::None => {}
                Bins::List(list) => {
                    for (i, (d_l, d_v)) in list.into_iter().enumerate() {
                        add(i as u32, d_l, d_v);
                    }
                }
                Bins::View => {
                    for (pixel, point) in view.pixels().iter().enumerate() {
                        if let Some(p) = point
                            && let (Some(d_l), Some(d_v)) = (p.light_bin, p.view_bin)
                        {
                            add(pixel as u32, d_l, d_v);
                        }
                    }
                }
            }
            let mut solver = Solver::new(basis.clone(), regularization);
            solver.apply_all(&changes);
            solver.refit_prior_mean();
            let solution = solver.solve();
            let recon = solution.reconstruction(basis.clone()).materialize();
            let values = recon.pairs();
            let physical = recon.is_physical();
            let (min_rho, max_rho) = values
                .iter()
                .flatten()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                });
            const EPSILON: f64 = 1e-3;
            let log_sq: f64 = values
                .iter()
                .zip(mean.pairs())
                .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64, b[c] as f64)))
                .map(|(a, b)| ((a + EPSILON) / (b + EPSILON)).ln().powi(2))
                .sum();
            StabilityCase {
                name,
                regularization,
                observed_bins: solution.observed_bins,
                condition_number: solution.condition_number,
                alpha: solution.alpha,
                max_coefficient: solution
                    .coefficients
                    .iter()
                    .flatten()
                    .fold(0.0, |m, x| m.max(x.abs())),
                min_rho,
                max_rho,
                physical,
                log_distance_from_mean: (log_sq / (3 * values.len()) as f64).sqrt(),
            }
        })
        .collect()
}
