//! Which view to paint next: candidate lights and cameras ranked by how much of the table's
//! uncertainty, weighted by what renders see, painting them would remove.
//!
//! After a solve the coefficients have a Gaussian posterior with precision Λ = (N + αP₀)/α
//! (`solver::Posterior`). A candidate view observes a set of bins; painting them adds
//! Σ_p w_p ψ_pψ_pᵀ/α to Λ, with w_p the weight the solver would give the bin if it were painted
//! as the current reconstruction predicts. The score of a view is the drop it brings to
//! tr(Λ⁻¹A), the posterior variance of ρ·cos θ_l·cos θ_v summed over the table: A =
//! Σ_p ((ρ̂_p c_p + ε)·cos θ_l cos θ_v)² ψ_pψ_pᵀ, the delta method through the log map, over a
//! fixed subsample of pairs. Bins a view shares with the painted ones score too (more samples
//! of them), but less.

use crate::scene::{CameraSettings, GBuffer, LightSettings, MIN_COS, Object, Scene};
use crate::solver::{Posterior, Reconstruction, Solver};
use crate::table::{PairIndex, cos_theta_centre, pair_directions, pair_index};
use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, Side};
use rayon::prelude::*;
use std::collections::BTreeSet;

/// Every this many pairs enter the importance matrix A (a fixed, even subsample).
const IMPORTANCE_STRIDE: usize = 13;
/// Guide resolution the candidates' bins are found at.
pub const CANDIDATE_RESOLUTION: u32 = 96;

/// A candidate and its score.
#[derive(Clone, Debug, PartialEq)]
pub struct RankedView {
    pub scene: Scene,
    /// The drop in render-weighted posterior variance painting this view would bring.
    pub score: f64,
    /// Bins it observes that no painted view does.
    pub new_bins: usize,
    /// Bins it observes in all.
    pub bins: usize,
}

/// `count` candidate views of `base`'s object: lights spread evenly over the sky (a
/// Fibonacci spiral from 10° to 80° above the horizon), with the base camera, and a third of
/// them with the camera turned 35° to one side and 20° up, so that both the light–view angle and
/// the part of the object seen change.
pub fn candidate_scenes(base: &Scene, count: usize) -> Vec<Scene> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count.max(1))
        .map(|i| {
            let t = (i as f64 + 0.5) / count.max(1) as f64;
            let elevation_deg = (10.0 + 70.0 * t).clamp(5.0, 85.0);
            let azimuth_deg = ((i as f64 * golden).to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
            let mut camera = base.camera.clone();
            if i % 3 == 2 {
                camera = CameraSettings {
                    yaw_deg: base.camera.yaw_deg + if i % 2 == 0 { 35.0 } else { -35.0 },
                    pitch_deg: (base.camera.pitch_deg + 20.0).min(80.0),
                    ..base.camera.clone()
                };
            }
            Scene {
                resolution: base.resolution,
                light: LightSettings {
                    elevation_deg,
                    azimuth_deg,
                },
                camera,
                ..base.clone()
            }
        })
        .collect()
}

/// The bins a view of `object` under `scene` observes (lit, usable pixels), in pair order.
pub fn observed_pairs(scene: &Scene, object: &Object, resolution: u32) -> Vec<PairIndex> {
    let scene = Scene {
        resolution,
        ..scene.clone()
    };
    let gbuffer = GBuffer::build(&scene, object);
    let pairs: BTreeSet<PairIndex> = gbuffer
        .pixels()
        .iter()
        .flatten()
        .filter(|p| p.is_lit() && p.cos_light() as f64 >= MIN_COS && p.cos_view() as f64 >= MIN_COS)
        .filter_map(|p| Some(pair_index(p.light_bin?, p.view_bin?)))
        .collect();
    pairs.into_iter().collect()
}

/// A = Σ_p imp_p ψ_pψ_pᵀ over the subsample, imp_p the squared slope of ρ·cos θ_l cos θ_v in the
/// mapped value at the reconstruction.
fn importance(posterior: &Posterior, reconstruction: &Reconstruction) -> Mat<f64> {
    let basis = reconstruction.basis();
    let d = posterior.precision().nrows();
    let sampled: Vec<PairIndex> = PairIndex::all().step_by(IMPORTANCE_STRIDE).collect();
    let partials: Vec<Mat<f64>> = sampled
        .par_chunks(2048)
        .map(|chunk| {
            let mut a = Mat::<f64>::zeros(d, d);
            for &pair in chunk {
                let (lo, hi) = pair_directions(pair);
                let cc = cos_theta_centre(lo) * cos_theta_centre(hi);
                let c = crate::basis::cos_weight(pair);
                let rho = reconstruction.eval_pair(pair);
                let luminance = 0.2126 * rho[0] + 0.7152 * rho[1] + 0.0722 * rho[2];
                let slope = (luminance as f64 * c + crate::basis::MAP_EPSILON) / c * cc;
                let psi = posterior.design_row(pair, basis.row(pair));
                let nonzero: Vec<usize> = (0..d).filter(|&i| psi[i] != 0.0).collect();
                let weight = slope * slope * crate::table::pair_multiplicity(pair);
                for &i in &nonzero {
                    for &j in &nonzero {
                        a[(i, j)] += weight * psi[i] * psi[j];
                    }
                }
            }
            a
        })
        .collect();
    let mut a = Mat::<f64>::zeros(d, d);
    for p in &partials {
        a += p;
    }
    a
}

/// tr(Λ⁻¹A) for a posterior precision Λ (∞ when it does not factor).
fn weighted_variance(precision: &Mat<f64>, a: &Mat<f64>) -> f64 {
    match precision.llt(Side::Lower) {
        Ok(llt) => {
            let inverse = llt.inverse();
            (0..a.nrows())
                .map(|i| {
                    (0..a.ncols())
                        .map(|j| inverse[(i, j)] * a[(j, i)])
                        .sum::<f64>()
                })
                .sum()
        }
        Err(_) => f64::INFINITY,
    }
}

/// Ranks `candidates` (views of `object`) for the solver's current state, best first.
/// `painted` lists the bins already observed.
pub fn rank_views(
    solver: &Solver,
    object: &Object,
    candidates: &[Scene],
    painted: &BTreeSet<PairIndex>,
) -> Vec<RankedView> {
    let solution = solver.solve();
    let basis = solver.basis().clone();
    let reconstruction = solution.reconstruction(basis.clone());
    let posterior = solver.posterior();
    let a = importance(&posterior, &reconstruction);
    let before = weighted_variance(posterior.precision(), &a);
    let alpha = posterior.alpha();
    let d = posterior.precision().nrows();
    let mut ranked: Vec<RankedView> = candidates
        .par_iter()
        .map(|scene| {
            let pairs = observed_pairs(scene, object, CANDIDATE_RESOLUTION);
            let mut precision = posterior.precision().clone();
            for &pair in &pairs {
                let rho = reconstruction.eval_pair(pair).map(f64::from);
                let w = solver.prospective_weight(pair, rho) / alpha;
                let psi = posterior.design_row(pair, basis.row(pair));
                let nonzero: Vec<usize> = (0..d).filter(|&i| psi[i] != 0.0).collect();
                for &i in &nonzero {
                    for &j in &nonzero {
                        precision[(i, j)] += w * psi[i] * psi[j];
                    }
                }
            }
            let after = weighted_variance(&precision, &a);
            RankedView {
                scene: scene.clone(),
                score: if before.is_finite() && after.is_finite() {
                    (before - after).max(0.0)
                } else {
                    0.0
                },
                new_bins: pairs.iter().filter(|p| !painted.contains(p)).count(),
                bins: pairs.len(),
            }
        })
        .collect();
    ranked.sort_by(|x, y| y.score.total_cmp(&x.score));
    ranked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_cover_the_sky_and_turn_some_cameras() {
        let base = Scene::default();
        let c = candidate_scenes(&base, 24);
        assert_eq!(c.len(), 24);
        assert!(
            c.iter()
                .all(|s| (5.0..=85.0).contains(&s.light.elevation_deg))
        );
        let azimuths: Vec<f64> = c.iter().map(|s| s.light.azimuth_deg).collect();
        assert!(azimuths.iter().any(|&a| a < -90.0) && azimuths.iter().any(|&a| a > 90.0));
        assert_eq!(c.iter().filter(|s| s.camera != base.camera).count(), 8);
        assert!(c.iter().all(|s| s.object_source() == base.object_source()));
    }
}
