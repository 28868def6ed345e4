//! `burnish eval`: how far an estimated table is from the truth.

use crate::metrics::table_errors;
use crate::scene::{
    BuiltinShape, GBuffer, LightSettings, Object, Scene, render_table, srgb_encode,
};
use crate::table::{SymTable, exr_file::read_table_exr};
use std::path::PathBuf;

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

#[derive(clap::Args, Debug)]
#[command(
    after_help = "PSNR: orthographic 256² sphere renders (as `burnish render` makes them), sRGB-encoded and \
clipped, over the pixels on the sphere, under 8 lights given as (elevation°, azimuth°) per SCENE.md: \
(15, 0), (70, 0), (30, -30), (30, 30), (40, -60), (40, 60), (60, -90), (60, 90). The median of the 8 is reported."
)]
pub struct EvalArgs {
    /// The reference table (EXR).
    #[arg(long)]
    pub truth: PathBuf,
    /// The table to score (EXR).
    #[arg(long)]
    pub estimate: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
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

pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    let truth = read_table_exr(&args.truth)?;
    let estimate = read_table_exr(&args.estimate)?;
    let e = evaluate(&truth, &estimate);
    if args.json {
        let psnr: Vec<String> = e.psnr_db.iter().map(|p| format!("{p:.4}")).collect();
        println!(
            "{{\"relative_rmse\": {:.6}, \"log_rmse\": {:.6}, \"median_psnr_db\": {:.4}, \"psnr_db\": [{}]}}",
            e.relative_rmse,
            e.log_rmse,
            e.median_psnr_db,
            psnr.join(", ")
        );
    } else {
        println!("relative RMSE of ρ·cos θ_l·cos θ_v: {:.4}", e.relative_rmse);
        println!("RMSE in the log-mapped domain:     {:.4}", e.log_rmse);
        println!(
            "median sphere-render PSNR:         {:.2} dB",
            e.median_psnr_db
        );
        for ((el, az), p) in EVAL_LIGHTS.iter().zip(&e.psnr_db) {
            println!("  light elevation {el:>4}°, azimuth {az:>4}°: {p:.2} dB");
        }
    }
    Ok(())
}
