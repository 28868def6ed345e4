//! `burnish calibrate`: choose the prior's constants by leave-families-out cross-validation on
//! the database, never on the bench's held-out materials.

use crate::basis::BasisCache;
use crate::bench::calibrate::{CalibrateOptions, Grid, calibrate};
use crate::scene::PaintRange;

#[derive(clap::Args, Debug)]
#[command(
    after_help = "Splits the database's families into folds; each fold's basis is built from the other families \
(cached beside the default basis), and materials of the left-out families are painted by a perfect painter \
under one and three views of two light arrangements, in HDR and as 8-bit LDR (clipped highlights), and rebuilt \
under every candidate prior. Candidates are ranked by the geometric mean of the relative RMSE over every case. \
On the default 2,000-material database the four fold bases take about 5 minutes each on 2 cores and are cached; \
scoring then takes about 35 s a candidate (six candidates: 3.5 minutes). Build with --release."
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
    /// The localised prior's α values to score (default: 3,10,30).
    #[arg(long, value_delimiter = ',')]
    pub alphas: Option<Vec<f64>>,
    /// The global prior's α values to score; `none` scores no global prior (default: 1,3,10,30).
    #[arg(long, value_delimiter = ',')]
    pub global_alphas: Option<Vec<String>>,
    /// Band correlations ρ to score, each in (0, 1) (default: 0.8,0.9,0.97).
    #[arg(long, value_delimiter = ',')]
    pub band_correlations: Option<Vec<f64>>,
    /// Brightness weights to score as β:κ pairs (default: 0:1,0.5:0.3,1:0.3).
    #[arg(long, value_delimiter = ',')]
    pub brightness: Option<Vec<String>>,
    /// Knot spacings over θ_d to score: uniform, cosine, sine-squared, cosine-squared (default: uniform).
    #[arg(long, value_delimiter = ',')]
    pub knots: Option<Vec<crate::solver::KnotSpacing>>,
    /// Reaches ℓ ≥ 0 of the nearby sets' extra correlation to score (default: 0).
    #[arg(long, value_delimiter = ',')]
    pub band_lengths: Option<Vec<f64>>,
    /// Whether solves may choose a stronger ρ by evidence, to score: on, off or on,off (default: on).
    #[arg(long, value_delimiter = ',', value_parser = parse_switch)]
    pub evidence: Option<Vec<bool>>,
    /// How clipped LDR bins enter the solve, to score: bounds:N (majorise–minimise, at most N
    /// steps; 0 takes the clip as a value) or omit (default: bounds:200).
    #[arg(long, value_delimiter = ',')]
    pub censoring: Option<Vec<crate::solver::Censoring>>,
    /// Where the prior is centred, to score: database, fitted (Lambert + GGX fitted to the
    /// paint) or fitted:M (when the evidence gains more than M nats); a fitted one may add
    /// +beckmann (a Beckmann lobe where it fits better) or +beckmann:R (R times better),
    /// +coat[:R] (a clear coat over the lobe, likewise), +edge[:R] (a conductor's Fresnel with
    /// an edge tint, likewise), +dielectric[:R] (a dielectric's exact Fresnel, likewise),
    /// +phong[:R] (Ashikhmin and Shirley's normalisation of the lobe or Blinn–Phong's
    /// implicit masking, likewise), +gtr[:R] (GTR's tails, its exponent fitted, likewise),
    /// +haze[:R] (a metal's lobe over a broad glow, likewise),
    /// +rough[:R] (an Oren–Nayar diffuse, likewise), +grazing:S (the specular weight S where
    /// the paint cannot tell it from F0) and +closer:R (the fit also taken where it explains
    /// the paint R times as closely as the database's mean). Default: the reconstruction's.
    #[arg(long, value_delimiter = ',')]
    pub mean: Option<Vec<crate::solver::PriorMean>>,
    /// Paint to score the candidates on: hdr, ldr or hdr,ldr (default: both).
    #[arg(long, value_delimiter = ',', value_parser = <PaintRange as std::str::FromStr>::from_str)]
    pub paint: Option<Vec<PaintRange>>,
}

fn parse_switch(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{s}' is neither on nor off")),
    }
}

/// The candidate grid: the standard one, with each list the command line gives replaced.
fn grid(args: &CalibrateArgs) -> anyhow::Result<Grid> {
    let positive = |name: &str, v: &[f64]| -> anyhow::Result<()> {
        anyhow::ensure!(
            v.iter().all(|x| x.is_finite() && *x > 0.0),
            "--{name} takes positive numbers"
        );
        Ok(())
    };
    let mut grid = Grid::standard();
    if let Some(alphas) = &args.alphas {
        positive("alphas", alphas)?;
        grid.alphas = alphas.clone();
    }
    if let Some(list) = &args.global_alphas {
        grid.global_alphas = if list.iter().any(|s| s == "none") {
            Vec::new()
        } else {
            let values = list
                .iter()
                .map(|s| s.parse::<f64>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| anyhow::anyhow!("--global-alphas: {e}"))?;
            positive("global-alphas", &values)?;
            values
        };
    }
    if let Some(rhos) = &args.band_correlations {
        anyhow::ensure!(
            rhos.iter().all(|r| *r > 0.0 && *r < 1.0),
            "--band-correlations takes numbers strictly between 0 and 1"
        );
        grid.band_correlations = rhos.clone();
    }
    if let Some(pairs) = &args.brightness {
        grid.brightness = pairs
            .iter()
            .map(|p| {
                let (b, k) = p
                    .split_once(':')
                    .ok_or_else(|| anyhow::anyhow!("--brightness takes β:κ pairs, not '{p}'"))?;
                let (b, k): (f64, f64) = (b.parse()?, k.parse()?);
                anyhow::ensure!(
                    b.is_finite() && b >= 0.0 && k.is_finite() && k > 0.0,
                    "--brightness '{p}': β ≥ 0 and κ > 0"
                );
                Ok((b, k))
            })
            .collect::<anyhow::Result<_>>()?;
    }
    if let Some(knots) = &args.knots {
        grid.knots = knots.clone();
    }
    if let Some(lengths) = &args.band_lengths {
        anyhow::ensure!(
            lengths.iter().all(|l| l.is_finite() && *l >= 0.0),
            "--band-lengths takes numbers ≥ 0"
        );
        grid.band_lengths = lengths.clone();
    }
    if let Some(evidence) = &args.evidence {
        grid.correlation_by_evidence = evidence.clone();
    }
    if let Some(censoring) = &args.censoring {
        grid.censoring = censoring.clone();
    }
    if let Some(means) = &args.mean {
        grid.means = means.clone();
    }
    anyhow::ensure!(
        !grid.candidates().is_empty(),
        "the grid has no candidate to score"
    );
    Ok(grid)
}

pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (2..=crate::materials::database::Family::ALL.len()).contains(&args.folds),
        "--folds must be between 2 and the number of families"
    );
    anyhow::ensure!(args.tests >= 1, "--tests must be at least 1");
    let mut options = CalibrateOptions::standard(BasisCache::default_location()?);
    options.candidates = grid(args)?.candidates();
    options.folds = args.folds;
    options.tests_per_fold = args.tests;
    if let Some(paints) = &args.paint {
        anyhow::ensure!(!paints.is_empty(), "--paint needs hdr, ldr or both");
        options.paints = paints.clone();
        options.paints.dedup();
    }
    if let Some(materials) = args.materials {
        anyhow::ensure!(materials >= 20, "--materials must be at least 20");
        options.basis_materials = materials;
    }
    let result = calibrate(&options, &|line| errln!("calibrate: {line}"))?;
    for (fold, families, _) in &result.folds {
        outln!("fold {fold} leaves out: {}", families.join(", "));
    }
    outln!(
        "{:<54} {:>8} {:>13} {:>13} {:>13} {:>13} {:>8} {:>6}",
        "candidate",
        "geo rel",
        "1v mean/med",
        "3v mean/med",
        "LDR 1v",
        "LDR 3v",
        "log",
        "hurt"
    );
    for s in &result.scores {
        outln!(
            "{:<54} {:>8.4} {:>6.3}/{:<6.3} {:>6.3}/{:<6.3} {:>6.3}/{:<6.3} {:>6.3}/{:<6.3} {:>8.4} {:>3}/{}",
            s.candidate.label(),
            s.geometric_mean_relative_rmse,
            s.mean_relative_rmse_1view,
            s.median_relative_rmse_1view,
            s.mean_relative_rmse_3view,
            s.median_relative_rmse_3view,
            s.mean_relative_rmse_1view_ldr,
            s.median_relative_rmse_1view_ldr,
            s.mean_relative_rmse_3view_ldr,
            s.median_relative_rmse_3view_ldr,
            s.mean_log_rmse,
            s.views_hurt,
            s.comparisons
        );
    }
    outln!(
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
                    "knots": s.candidate.model.knots.name(),
                    "band_length": s.candidate.model.band_length,
                    "correlation_by_evidence": s.candidate.model.correlation_by_evidence,
                    "censoring": s.candidate.model.censoring.name(),
                    "geometric_mean_rel_rmse": s.geometric_mean_relative_rmse,
                    "rel_rmse_1view": s.mean_relative_rmse_1view,
                    "median_rel_rmse_1view": s.median_relative_rmse_1view,
                    "rel_rmse_3view": s.mean_relative_rmse_3view,
                    "median_rel_rmse_3view": s.median_relative_rmse_3view,
                    "rel_rmse_1view_ldr": s.mean_relative_rmse_1view_ldr,
                    "median_rel_rmse_1view_ldr": s.median_relative_rmse_1view_ldr,
                    "rel_rmse_3view_ldr": s.mean_relative_rmse_3view_ldr,
                    "median_rel_rmse_3view_ldr": s.median_relative_rmse_3view_ldr,
                    "log_rmse": s.mean_log_rmse,
                    "views_hurt": s.views_hurt,
                })
            })
            .collect();
        outln!("{}", serde_json::Value::Array(rows));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::KnotSpacing;

    fn args() -> CalibrateArgs {
        CalibrateArgs {
            folds: 4,
            tests: 6,
            materials: None,
            json: false,
            alphas: None,
            global_alphas: None,
            band_correlations: None,
            brightness: None,
            knots: None,
            band_lengths: None,
            evidence: None,
            censoring: None,
            mean: None,
            paint: None,
        }
    }

    #[test]
    fn the_grid_is_the_standard_one_with_each_given_list_replaced() {
        assert_eq!(grid(&args()).unwrap(), Grid::standard());
        let g = grid(&CalibrateArgs {
            alphas: Some(vec![10.0]),
            global_alphas: Some(vec!["none".into()]),
            band_correlations: Some(vec![0.97, 0.99]),
            brightness: Some(vec!["1:0.3".into()]),
            knots: Some(vec![KnotSpacing::Uniform, KnotSpacing::Cosine]),
            evidence: Some(vec![true, false]),
            ..args()
        })
        .unwrap();
        let candidates = g.candidates();
        assert_eq!(candidates.len(), 8);
        assert_eq!(
            candidates
                .iter()
                .filter(|c| c.model.correlation_by_evidence)
                .count(),
            4
        );
        assert!(candidates.iter().all(|c| c.alpha == 10.0
            && c.model.brightness_exponent == 1.0
            && c.model.brightness_floor == 0.3));
        assert!(
            candidates
                .iter()
                .any(|c| c.model.knots == KnotSpacing::Cosine && c.model.band_correlation == 0.99)
        );
    }

    #[test]
    fn a_grid_with_bad_values_or_no_candidate_is_refused() {
        for bad in [
            CalibrateArgs {
                band_correlations: Some(vec![1.0]),
                ..args()
            },
            CalibrateArgs {
                alphas: Some(vec![-1.0]),
                ..args()
            },
            CalibrateArgs {
                brightness: Some(vec!["1".into()]),
                ..args()
            },
            CalibrateArgs {
                global_alphas: Some(vec!["none".into()]),
                knots: Some(vec![]),
                ..args()
            },
        ] {
            assert!(grid(&bad).is_err(), "{bad:?}");
        }
    }
}
