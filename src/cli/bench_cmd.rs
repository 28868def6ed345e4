//! `burnish bench`: run time against error, and the live loop's timings.

use crate::basis::BasisCache;
use crate::bench::scaling::{self, ScalingOptions};
use crate::bench::{BenchOptions, run_bench};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(
    after_help = "The full run sweeps K (5 to 80), the regularisation, the prior model, 1 to 4 views, guide \
resolution 256 to 1024, LDR against HDR paint and the sample policy on the held-out materials, next to the \
oracle and an analytic Lambert + GGX fit, and times the live loop; it builds the bases it lacks. --quick keeps \
the default basis, a few materials and the key configurations (one and three views, LDR paint). With --out, \
error maps of every material (truth, estimate, log error, observed bins) go to DIR/error_maps. Build with \
--release for meaningful times."
)]
pub struct BenchArgs {
    /// The short run: one basis (K = 20), a few materials, one and three views, LDR paint.
    #[arg(long, conflicts_with = "scaling")]
    pub quick: bool,
    /// Only the scaling sweep: the oracle's and one view's error against the database's size
    /// (100 to 2,000 materials) and K (10 to 40), with the dab and full-table cost at each K.
    #[arg(long, conflicts_with = "materials")]
    pub scaling: bool,
    /// Print the key figures as one JSON object on the last line.
    #[arg(long)]
    pub json: bool,
    /// Write bench.csv, bench_pareto.png, BENCHMARKS.md and error_maps/ into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Materials in the database the bases are learnt from (the default basis's when unset).
    #[arg(long)]
    pub materials: Option<u32>,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let cache = BasisCache::default_location()?;
    if args.scaling {
        return run_scaling(args, cache);
    }
    let mut options = if args.quick {
        BenchOptions::quick(cache)
    } else {
        BenchOptions::full(cache)
    };
    if let Some(materials) = args.materials {
        anyhow::ensure!(
            (1..=crate::basis::BasisSpec::MAX_MATERIALS).contains(&(materials as usize)),
            "--materials must be in 1..={}",
            crate::basis::BasisSpec::MAX_MATERIALS
        );
        options.basis_materials = materials as usize;
    }
    options.error_maps = args.out.as_ref().map(|dir| dir.join("error_maps"));
    let report = run_bench(&options, &|line| errln!("bench: {line}"))?;
    if let Some(dir) = &args.out {
        let mut command = String::from("cargo run --release -- bench");
        if args.quick {
            command.push_str(" --quick");
        }
        if args.json {
            command.push_str(" --json");
        }
        if let Some(materials) = args.materials {
            command.push_str(&format!(" --materials {materials}"));
        }
        command.push_str(&format!(" --out {}", dir.display()));
        report.write_outputs(dir, &command)?;
        errln!(
            "bench: wrote bench.csv, bench_pareto.png and BENCHMARKS.md to {}",
            dir.display()
        );
    }
    for a in &report.aggregates {
        outln!(
            "{:<34} rel. RMSE mean {:.3} median {:.3}, log RMSE {:.3}, {:.1} ms",
            a.method.label(),
            a.mean_relative_rmse,
            a.median_relative_rmse,
            a.mean_log_rmse,
            a.mean_time_ms
        );
    }
    for (key, value) in report.key_figures() {
        outln!("{key}: {value:.4}");
    }
    if args.json {
        outln!("{}", report.json());
    }
    Ok(())
}

fn run_scaling(args: &BenchArgs, cache: BasisCache) -> anyhow::Result<()> {
    let options = ScalingOptions::standard(cache);
    let report = scaling::run_scaling(&options, &|line| errln!("bench: {line}"))?;
    if let Some(dir) = &args.out {
        report.write_outputs(dir)?;
        errln!(
            "bench: wrote bench_scaling.csv, bench_scaling.png and SCALING.md to {}",
            dir.display()
        );
    }
    out!("{}", report.markdown());
    if args.json {
        let points: Vec<serde_json::Value> = report
            .points
            .iter()
            .map(|p| {
                serde_json::json!({
                    "materials": p.materials,
                    "components": p.components,
                    "rel_rmse_oracle": p.oracle_mean,
                    "median_rel_rmse_oracle": p.oracle_median,
                    "rel_rmse_1view": p.one_view_mean,
                    "median_rel_rmse_1view": p.one_view_median,
                    "log_rmse_1view": p.one_view_log,
                    "dab_solve_ms_p95": p.dab_p95_ms,
                    "full_table_ms": p.full_table_ms,
                })
            })
            .collect();
        outln!("{}", serde_json::Value::Array(points));
    }
    Ok(())
}
