//! `burnish calibrate`: choose the prior's constants by leave-families-out cross-validation on
//! the database, never on the bench's held-out materials.

use crate::basis::BasisCache;
use crate::bench::calibrate::{CalibrateOptions, calibrate};

#[derive(clap::Args, Debug)]
#[command(
    after_help = "Splits the database's families into folds; each fold's basis is built from the other families \
(cached beside the default basis), and materials of the left-out families are painted by a perfect painter \
under one and three views of two light arrangements and rebuilt under every candidate prior. Candidates are \
ranked by the geometric mean of the relative RMSE. The default run takes about 15 minutes on 2 cores; \
build with --release."
)]
pub struct CalibrateArgs {
    /// Groups of families, each left out once.
    #[arg(long, default_value_t = 4)]
    pub folds: usize,
    /// Test materials per fold.
    #[arg(long, default_value_t = 6)]
    pub tests: usize,
    /// Materials in each fold's database (default: the default database's size).
    #[arg(long)]
    pub materials: Option<usize>,
    /// Print the ranking as one JSON array on the last line.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (2..=crate::materials::database::Family::ALL.len()).contains(&args.folds),
        "--folds must be between 2 and the number of families"
    );
    anyhow::ensure!(args.tests >= 1, "--tests must be at least 1");
    let mut options = CalibrateOptions::standard(BasisCache::default_location()?);
    options.folds = args.folds;
    options.tests_per_fold = args.tests;
    if let Some(materials) = args.materials {
        anyhow::ensure!(materials >= 20, "--materials must be at least 20");
        options.basis_materials = materials;
    }
    let result = calibrate(&options, &|line| eprintln!("calibrate: {line}"))?;
    for (fold, families, _) in &result.folds {
        println!("fold {fold} leaves out: {}", families.join(", "));
    }
    println!(
        "{:<42} {:>8} {:>13} {:>13} {:>8} {:>6}",
        "candidate", "geo rel", "1v mean/med", "3v mean/med", "log", "hurt"
    );
    for s in &result.scores {
        println!(
            "{:<42} {:>8.4} {:>6.3}/{:<6.3} {:>6.3}/{:<6.3} {:>8.4} {:>3}/{}",
            s.candidate.label(),
            s.geometric_mean_relative_rmse,
            s.mean_relative_rmse_1view,
            s.median_relative_rmse_1view,
            s.mean_relative_rmse_3view,
            s.median_relative_rmse_3view,
            s.mean_log_rmse,
            s.views_hurt,
            s.comparisons
        );
    }
    println!(
        "best: {} ({:.0} s)",
        result.scores[0].candidate.label(),
        result.seconds
    );
    if args.json {
        let rows: Vec<serde_json::Value> = result
            .scores
            .iter()
            .map(|s| {
                serde_json::json!({
                    "candidate": s.candidate.label(),
                    "alpha": s.candidate.alpha,
                    "bands": s.candidate.model.bands,
                    "band_correlation": s.candidate.model.band_correlation,
                    "brightness_exponent": s.candidate.model.brightness_exponent,
                    "brightness_floor": s.candidate.model.brightness_floor,
                    "geometric_mean_rel_rmse": s.geometric_mean_relative_rmse,
                    "rel_rmse_1view": s.mean_relative_rmse_1view,
                    "median_rel_rmse_1view": s.median_relative_rmse_1view,
                    "rel_rmse_3view": s.mean_relative_rmse_3view,
                    "median_rel_rmse_3view": s.median_relative_rmse_3view,
                    "log_rmse": s.mean_log_rmse,
                    "views_hurt": s.views_hurt,
                })
            })
            .collect();
        println!("{}", serde_json::Value::Array(rows));
    }
    Ok(())
}
