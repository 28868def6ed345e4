//! `burnish eval`: how far an estimated table is from the truth.

use crate::metrics::{
    DIFFERENCE_ANGLE_EDGES_DEG, EVAL_LIGHTS, ErrorByAngle, HALF_ANGLE_EDGES_DEG, error_by_angle,
    evaluate,
};
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
    /// Also show where the relative error comes from: its share by half angle θ_h and
    /// difference angle θ_d, and whether the estimate is above or below the truth there.
    #[arg(long)]
    pub by_angle: bool,
}

pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    let truth = read_table_exr(&args.truth)?;
    let estimate = read_table_exr(&args.estimate)?;
    let e = evaluate(&truth, &estimate);
    let by_angle = args.by_angle.then(|| error_by_angle(&truth, &estimate));
    if args.json {
        let mut json = serde_json::json!({
            "relative_rmse": e.relative_rmse,
            "log_rmse": e.log_rmse,
            "median_psnr_db": e.median_psnr_db,
            "psnr_db": e.psnr_db,
        });
        if let Some(b) = &by_angle {
            json["by_angle"] = serde_json::json!({
                "theta_h_edges_deg": HALF_ANGLE_EDGES_DEG,
                "theta_d_edges_deg": DIFFERENCE_ANGLE_EDGES_DEG,
                "error": b.error,
                "truth": b.truth,
                "direction": b.direction,
            });
        }
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
        if let Some(b) = &by_angle {
            print_by_angle(b)?;
        }
    }
    Ok(())
}

/// The breakdown as a grid: each cell's percentage of the squared relative error, then `+`
/// where the estimate is mostly above the truth, `−` where below.
fn print_by_angle(b: &ErrorByAngle) -> anyhow::Result<()> {
    let total: f64 = b.error.iter().flatten().sum();
    outln!(
        "share of the squared relative error by half angle θ_h (rows) and difference angle θ_d \
         (columns), %; + estimate above the truth there, − below:"
    );
    let mut header = format!("{:>10}", "θ_h \\ θ_d");
    for edges in DIFFERENCE_ANGLE_EDGES_DEG.windows(2) {
        header += &format!("{:>9}", format!("{}–{}°", edges[0], edges[1]));
    }
    outln!("{header}");
    for (i, edges) in HALF_ANGLE_EDGES_DEG.windows(2).enumerate() {
        let mut row = format!("{:>10}", format!("{}–{}°", edges[0], edges[1]));
        for (error, direction) in b.error[i].iter().zip(&b.direction[i]) {
            let share = if total > 0.0 {
                100.0 * error / total
            } else {
                0.0
            };
            let sign = match direction {
                d if *d > 0.0 => '+',
                d if *d < 0.0 => '−',
                _ => ' ',
            };
            row += &format!("{:>8.1}{sign}", share);
        }
        outln!("{row}");
    }
    Ok(())
}
