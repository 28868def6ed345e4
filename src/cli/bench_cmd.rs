//! `burnish bench`: run time against error, and the live loop's timings.

use crate::basis::BasisCache;
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
    #[arg(long)]
    pub quick: bool,
    /// Print the key figures as one JSON object on the last line.
    #[arg(long)]
    pub json: bool,
    /// Write bench.csv, bench_pareto.png, BENCHMARKS.md and error_maps/ into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let cache = BasisCache::default_location()?;
    let mut options = if args.quick {
        BenchOptions::quick(cache)
    } else {
        BenchOptions::full(cache)
    };
    options.error_maps = args.out.as_ref().map(|dir| dir.join("error_maps"));
    let report = run_bench(&options, &|line| eprintln!("bench: {line}"))?;
    if let Some(dir) = &args.out {
        let mut command = String::from("cargo run --release -- bench");
        if args.quick {
            command.push_str(" --quick");
        }
        if args.json {
            command.push_str(" --json");
        }
        command.push_str(&format!(" --out {}", dir.display()));
        report.write_outputs(dir, &command)?;
        eprintln!(
            "bench: wrote bench.csv, bench_pareto.png and BENCHMARKS.md to {}",
            dir.display()
        );
    }
    for a in &report.aggregates {
        println!(
            "{:<34} rel. RMSE mean {:.3} median {:.3}, log RMSE {:.3}, {:.1} ms",
            a.method.label(),
            a.mean_relative_rmse,
            a.median_relative_rmse,
            a.mean_log_rmse,
            a.mean_time_ms
        );
    }
    for (key, value) in report.key_figures() {
        println!("{key}: {value:.4}");
    }
    if args.json {
        println!("{}", report.json());
    }
    Ok(())
}
