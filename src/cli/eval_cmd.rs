//! `burnish eval`: how far an estimated table is from the truth.

use crate::metrics::{EVAL_LIGHTS, evaluate};
use crate::table::exr_file::read_table_exr;
use std::path::PathBuf;

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

pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    let truth = read_table_exr(&args.truth)?;
    let estimate = read_table_exr(&args.estimate)?;
    let e = evaluate(&truth, &estimate);
    if args.json {
        let json = serde_json::json!({
            "relative_rmse": e.relative_rmse,
            "log_rmse": e.log_rmse,
            "median_psnr_db": e.median_psnr_db,
            "psnr_db": e.psnr_db,
        });
        outln!("{json}");
    } else {
        outln!("relative RMSE of ρ·cos θ_l·cos θ_v: {:.4}", e.relative_rmse);
        outln!("RMSE in the log-mapped domain:     {:.4}", e.log_rmse);
        outln!(
            "median sphere-render PSNR:         {:.2} dB",
            e.median_psnr_db
        );
        for ((el, az), p) in EVAL_LIGHTS.iter().zip(&e.psnr_db) {
            outln!("  light elevation {el:>4}°, azimuth {az:>4}°: {p:.2} dB");
        }
    }
    Ok(())
}
