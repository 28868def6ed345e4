//! Error metrics between two tables, as `burnish eval` reports them.

use crate::basis::{MAP_EPSILON, cos_weight_polar};
use crate::scene::{
    BuiltinShape, GBuffer, LightSettings, Object, Scene, render_table, srgb_encode,
};
use crate::table::{PHI_BINS, SymTable, bin_centre, for_each_pair, theta_centre};

/// The eight lights (elevation, azimuth in degrees, SCENE.md) of the sphere renders.
pub const EVAL_LIGHTS: [(f64, f64); 8] = [
    (15.0, 0.0),
    (70.0, 0.0),
    (30.0, -30.0),
    (30.0, 30.0),
    (40.0, -60.0),
    (40.0, 60.0),
    (60.0, -90.0),
    (60.0, 90.0),
];
/// Resolution of the sphere renders.
const EVAL_RESOLUTION: u32 = 256;
/// PSNR reported for identical renders.
const PSNR_CAP_DB: f64 = 100.0;

/// Errors of an estimate against the truth over the whole table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableErrors {
    /// ‖(ρ̂ − ρ) cos θ_l cos θ_v‖ / ‖ρ cos θ_l cos θ_v‖ over every entry and channel.
    pub relative_rmse: f64,
    /// RMSE in the log-mapped domain: ln((ρ̂c + ε)/(ρc + ε)), c clamped as in the basis.
    pub log_rmse: f64,
}

/// Compares two tables entry by entry; off-diagonal pairs count twice, as in the full table.
pub fn table_errors(truth: &SymTable, estimate: &SymTable) -> TableErrors {
    let cos: Vec<f64> = (0..crate::table::THETA_BINS)
        .map(|t| theta_centre(t).cos())
        .collect();
    let (mut err2, mut ref2, mut log2, mut count) = (0f64, 0f64, 0f64, 0f64);
    let (t_vals, e_vals) = (truth.pairs(), estimate.pairs());
    for_each_pair(|pair, lo, hi| {
        let w = if lo == hi { 1.0 } else { 2.0 };
        let (t_l, t_v) = (lo as usize / PHI_BINS, hi as usize / PHI_BINS);
        let cc = cos[t_l] * cos[t_v];
        let c = cos_weight_polar(t_l, t_v);
        for ch in 0..3 {
            let (t, e) = (
                t_vals[pair.index()][ch] as f64,
                e_vals[pair.index()][ch] as f64,
            );
            err2 += w * ((e - t) * cc).powi(2);
            ref2 += w * (t * cc).powi(2);
            log2 += w * (((e * c + MAP_EPSILON) / (t * c + MAP_EPSILON)).ln()).powi(2);
            count += w;
        }
    });
    TableErrors {
        relative_rmse: if ref2 > 0.0 {
            (err2 / ref2).sqrt()
        } else {
            err2.sqrt()
        },
        log_rmse: (log2 / count).sqrt(),
    }
}

/// Edges (degrees) of the half-angle bands of [`ErrorByAngle`]: fine near the pole, where a
/// highlight's peak sits.
pub const HALF_ANGLE_EDGES_DEG: [f64; 7] = [0.0, 2.0, 5.0, 10.0, 20.0, 45.0, 90.0];
/// Edges (degrees) of the difference-angle bands of [`ErrorByAngle`].
pub const DIFFERENCE_ANGLE_EDGES_DEG: [f64; 7] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0];
const HALF_ANGLE_BANDS: usize = HALF_ANGLE_EDGES_DEG.len() - 1;
const DIFFERENCE_ANGLE_BANDS: usize = DIFFERENCE_ANGLE_EDGES_DEG.len() - 1;

/// Where the relative error of [`table_errors`] comes from, by the half angle θ_h (rows) and
/// the difference angle θ_d (columns) of each entry (Rusinkiewicz's angles, at the bins'
/// centres). A painting shows one θ_d per light, so a few bands hold what was painted and the
/// rest is extrapolated; a sharp lobe's grazing mirror entries (small θ_h, large θ_d), which
/// no light beside the camera paints, can hold most of the relative error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorByAngle {
    /// Each cell's share of the squared relative error: its Σ((ρ̂ − ρ) cos θ_l cos θ_v)² over
    /// the whole table's Σ(ρ cos θ_l cos θ_v)². The cells add up to the relative RMSE squared.
    pub error: [[f64; DIFFERENCE_ANGLE_BANDS]; HALF_ANGLE_BANDS],
    /// Each cell's share of the truth's Σ(ρ cos θ_l cos θ_v)²: where the reflectance is.
    pub truth: [[f64; DIFFERENCE_ANGLE_BANDS]; HALF_ANGLE_BANDS],
    /// Which way each cell errs, in [−1, 1]: the estimate's excess over the truth less its
    /// shortfall, over their sum (+1: above the truth throughout, −1: below; 0 with no error).
    pub direction: [[f64; DIFFERENCE_ANGLE_BANDS]; HALF_ANGLE_BANDS],
}

/// The grazing mirror of [`ErrorByAngle::grazing_mirror_share`]: half angles below this…
const GRAZING_MIRROR_HALF_ANGLE_DEG: f64 = 5.0;
/// …and difference angles above this.
const GRAZING_MIRROR_DIFFERENCE_ANGLE_DEG: f64 = 60.0;

impl ErrorByAngle {
    /// The share of the squared error at the grazing mirror (θ_h under 5°, θ_d over 60°):
    /// where a sharp lobe's Fresnel and masking peak and one light beside the camera never
    /// paints. 0 with no error.
    pub fn grazing_mirror_share(&self) -> f64 {
        let total: f64 = self.error.iter().flatten().sum();
        if total <= 0.0 {
            return 0.0;
        }
        let mut mirror = 0.0;
        for (i, row) in self.error.iter().enumerate() {
            for (j, error) in row.iter().enumerate() {
                if HALF_ANGLE_EDGES_DEG[i + 1] <= GRAZING_MIRROR_HALF_ANGLE_DEG
                    && DIFFERENCE_ANGLE_EDGES_DEG[j] >= GRAZING_MIRROR_DIFFERENCE_ANGLE_DEG
                {
                    mirror += error;
                }
            }
        }
        mirror / total
    }
}

/// The band of an angle given by its cosine, between edges given by theirs (descending): a
/// table's 1.3 million pairs are banded without an arccosine each. An angle on an edge falls
/// in the band above it.
fn band_of_cos(cos: f64, cos_edges: &[f64]) -> usize {
    let last = cos_edges.len() - 2;
    cos_edges[1..=last]
        .iter()
        .position(|&edge| cos > edge)
        .unwrap_or(last)
}

/// [`ErrorByAngle`] of an estimate against the truth, weighted as [`table_errors`] weighs them.
pub fn error_by_angle(truth: &SymTable, estimate: &SymTable) -> ErrorByAngle {
    let cos: Vec<f64> = (0..crate::table::THETA_BINS)
        .map(|t| theta_centre(t).cos())
        .collect();
    let centres: Vec<glam::DVec3> = (0..crate::table::DIRECTIONS)
        .map(|d| bin_centre(d as crate::table::DirIndex))
        .collect();
    let cos_edges =
        |edges: &[f64]| -> Vec<f64> { edges.iter().map(|e| e.to_radians().cos()).collect() };
    let (half_cos_edges, difference_cos_edges) = (
        cos_edges(&HALF_ANGLE_EDGES_DEG),
        cos_edges(&DIFFERENCE_ANGLE_EDGES_DEG),
    );
    let zero = [[0f64; DIFFERENCE_ANGLE_BANDS]; HALF_ANGLE_BANDS];
    let (mut err2, mut ref2, mut over, mut under) = (zero, zero, zero, zero);
    let (t_vals, e_vals) = (truth.pairs(), estimate.pairs());
    for_each_pair(|pair, lo, hi| {
        let w = if lo == hi { 1.0 } else { 2.0 };
        let (t_l, t_v) = (lo as usize / PHI_BINS, hi as usize / PHI_BINS);
        let cc = cos[t_l] * cos[t_v];
        let (l, v) = (centres[lo as usize], centres[hi as usize]);
        let h = (l + v).normalize_or(glam::DVec3::Z);
        let (i, j) = (
            band_of_cos(h.z, &half_cos_edges),
            band_of_cos(l.dot(h), &difference_cos_edges),
        );
        for ch in 0..3 {
            let (t, e) = (
                t_vals[pair.index()][ch] as f64,
                e_vals[pair.index()][ch] as f64,
            );
            let difference = (e - t) * cc;
            err2[i][j] += w * difference * difference;
            ref2[i][j] += w * (t * cc).powi(2);
            if difference > 0.0 {
                over[i][j] += w * difference;
            } else {
                under[i][j] -= w * difference;
            }
        }
    });
    let total_ref2: f64 = ref2.iter().flatten().sum();
    // As `table_errors`: an all-zero truth leaves the error absolute.
    let scale = if total_ref2 > 0.0 { total_ref2 } else { 1.0 };
    let mut breakdown = ErrorByAngle {
        error: zero,
        truth: zero,
        direction: zero,
    };
    for i in 0..HALF_ANGLE_BANDS {
        for j in 0..DIFFERENCE_ANGLE_BANDS {
            breakdown.error[i][j] = err2[i][j] / scale;
            breakdown.truth[i][j] = if total_ref2 > 0.0 {
                ref2[i][j] / total_ref2
            } else {
                0.0
            };
            let sum = over[i][j] + under[i][j];
            breakdown.direction[i][j] = if sum > 0.0 {
                (over[i][j] - under[i][j]) / sum
            } else {
                0.0
            };
        }
    }
    breakdown
}

/// Every figure `eval` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    pub relative_rmse: f64,
    pub log_rmse: f64,
    pub psnr_db: Vec<f64>,
    pub median_psnr_db: f64,
}

/// Scores `estimate` against `truth`: table errors and sphere-render PSNRs.
pub fn evaluate(truth: &SymTable, estimate: &SymTable) -> Evaluation {
    let errors = table_errors(truth, estimate);
    let object = Object::builtin(BuiltinShape::Sphere);
    let psnr_db: Vec<f64> = EVAL_LIGHTS
        .iter()
        .map(|&(elevation_deg, azimuth_deg)| {
            let scene = Scene {
                resolution: EVAL_RESOLUTION,
                shadows: false,
                light: LightSettings {
                    elevation_deg,
                    azimuth_deg,
                },
                ..Scene::default()
            };
            let gbuffer = GBuffer::build(&scene, &object);
            let (a, b) = (
                render_table(&gbuffer, truth),
                render_table(&gbuffer, estimate),
            );
            let (mut sum, mut count) = (0f64, 0usize);
            for (i, point) in gbuffer.pixels().iter().enumerate() {
                if point.is_some() {
                    for c in 0..3 {
                        let encode = |v: f32| srgb_encode(v.clamp(0.0, 1.0)) as f64;
                        sum += (encode(a.pixels[i][c]) - encode(b.pixels[i][c])).powi(2);
                        count += 1;
                    }
                }
            }
            let mse = sum / count.max(1) as f64;
            if mse > 0.0 {
                (10.0 * (1.0 / mse).log10()).min(PSNR_CAP_DB)
            } else {
                PSNR_CAP_DB
            }
        })
        .collect();
    let mut sorted = psnr_db.clone();
    sorted.sort_by(f64::total_cmp);
    let median_psnr_db = 0.5 * (sorted[3] + sorted[4]);
    Evaluation {
        relative_rmse: errors.relative_rmse,
        log_rmse: errors.log_rmse,
        psnr_db,
        median_psnr_db,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::DirIndex;

    /// Direction bin of polar bin `t` and azimuth bin `p` (TABLE.md: d = 36 t + p).
    fn direction(t: usize, p: usize) -> DirIndex {
        (t * PHI_BINS + p) as DirIndex
    }

    /// A glossy truth: a constant diffuse under a lobe about the half vector.
    fn glossy() -> SymTable {
        SymTable::from_fn(|d_l, d_v| {
            let h = (bin_centre(d_l) + bin_centre(d_v)).normalize();
            let rho = 0.1 + 5.0 * h.z.powi(200);
            [rho as f32, 0.5 * rho as f32, 0.25 * rho as f32]
        })
    }

    /// The cells split the relative RMSE without remainder, and the truth's share adds to one.
    #[test]
    fn the_cells_add_up_to_the_relative_rmse() {
        let truth = glossy();
        let estimate = SymTable::from_fn(|d_l, d_v| {
            let value = truth.get(d_l, d_v);
            let scale = if bin_centre(d_l).z < 0.5 { 1.3 } else { 0.9 };
            value.map(|v| v * scale)
        });
        let by_angle = error_by_angle(&truth, &estimate);
        let total: f64 = by_angle.error.iter().flatten().sum();
        let relative = table_errors(&truth, &estimate).relative_rmse;
        assert!(
            (total - relative * relative).abs() <= 1e-9 * relative * relative,
            "cells {total}, relative RMSE² {}",
            relative * relative
        );
        let truth_total: f64 = by_angle.truth.iter().flatten().sum();
        assert!((truth_total - 1.0).abs() < 1e-9, "{truth_total}");
        // The lobe's energy sits at small half angles.
        let near_pole: f64 = by_angle.truth[..3].iter().flatten().sum();
        assert!(near_pole > 0.3, "{:?}", by_angle.truth);
        assert!(
            by_angle
                .direction
                .iter()
                .flatten()
                .all(|d| (-1.0..=1.0).contains(d)),
            "{:?}",
            by_angle.direction
        );
        let same = error_by_angle(&truth, &truth);
        assert!(same.error.iter().flatten().all(|&e| e == 0.0));
        assert!(same.direction.iter().flatten().all(|&d| d == 0.0));
    }

    /// An error at the back-scattering pole and one at the grazing mirror land in their own
    /// cells, with the way each errs.
    #[test]
    fn an_error_lands_in_the_cell_of_its_angles() {
        let truth = glossy();
        let mut estimate = truth.clone();
        // θ_l = θ_v = 1°, same azimuth: θ_h = 1°, θ_d = 0°.
        let pole = direction(0, 0);
        estimate.set(pole, pole, truth.get(pole, pole).map(|v| v + 1.0));
        // θ_l = θ_v = 89° at opposite azimuths: the mirror at grazing, θ_h ≈ 0°, θ_d ≈ 89°.
        let (l, v) = (direction(44, 0), direction(44, 18));
        estimate.set(l, v, truth.get(l, v).map(|v| 0.5 * v));
        let by_angle = error_by_angle(&truth, &estimate);
        let last = DIFFERENCE_ANGLE_BANDS - 1;
        for i in 0..HALF_ANGLE_BANDS {
            for j in 0..DIFFERENCE_ANGLE_BANDS {
                let (error, direction) = (by_angle.error[i][j], by_angle.direction[i][j]);
                match (i, j) {
                    (0, 0) => assert!(error > 0.0 && direction == 1.0, "{error} {direction}"),
                    (0, j) if j == last => {
                        assert!(error > 0.0 && direction == -1.0, "{error} {direction}")
                    }
                    _ => assert!(error == 0.0 && direction == 0.0, "cell {i}, {j}"),
                }
            }
        }
        let mirror = by_angle.error[0][last] / by_angle.error.iter().flatten().sum::<f64>();
        assert!(mirror > 0.0 && mirror < 1.0);
        assert_eq!(by_angle.grazing_mirror_share(), mirror);
        assert_eq!(error_by_angle(&truth, &truth).grazing_mirror_share(), 0.0);
    }

    /// The band of an angle in degrees: the reference [`band_of_cos`] must agree with.
    fn band_of(angle_deg: f64, edges: &[f64]) -> usize {
        let last = edges.len() - 2;
        edges[1..=last]
            .iter()
            .position(|&edge| angle_deg < edge)
            .unwrap_or(last)
    }

    fn cos_of(edges: &[f64]) -> Vec<f64> {
        edges.iter().map(|e| e.to_radians().cos()).collect()
    }

    /// Banding by cosine agrees with banding by angle, off the edges themselves.
    #[test]
    fn banding_by_cosine_is_banding_by_angle() {
        for edges in [&HALF_ANGLE_EDGES_DEG[..], &DIFFERENCE_ANGLE_EDGES_DEG[..]] {
            let cos_edges = cos_of(edges);
            for tenth in 0..=900 {
                let angle = tenth as f64 * 0.1 + 0.05;
                assert_eq!(
                    band_of_cos(angle.to_radians().cos(), &cos_edges),
                    band_of(angle.min(90.0), edges),
                    "{angle}°"
                );
            }
        }
    }

    #[test]
    fn angles_on_an_edge_fall_in_the_band_above_it() {
        let (half, difference) = (
            cos_of(&HALF_ANGLE_EDGES_DEG),
            cos_of(&DIFFERENCE_ANGLE_EDGES_DEG),
        );
        let band = |angle: f64, edges: &[f64]| band_of_cos(angle.to_radians().cos(), edges);
        assert_eq!(band(0.0, &half), 0);
        assert_eq!(band(1.99, &half), 0);
        assert_eq!(band(2.0, &half), 1);
        assert_eq!(band(89.9, &half), HALF_ANGLE_BANDS - 1);
        assert_eq!(band(90.0, &difference), DIFFERENCE_ANGLE_BANDS - 1);
        assert_eq!(band(15.0, &difference), 1);
    }
}
