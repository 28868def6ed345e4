//! Error metrics between two tables, as `burnish eval` reports them.

use crate::basis::{MAP_EPSILON, cos_weight_polar};
use crate::scene::{
    BuiltinShape, GBuffer, LightSettings, Object, Scene, render_table, srgb_encode,
};
use crate::table::{PHI_BINS, SymTable, for_each_pair, theta_centre};

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
