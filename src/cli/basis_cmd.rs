//! `burnish basis`: build or load the cached basis.

use crate::basis::{BasisCache, CacheOutcome};
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct BasisArgs {
    #[command(flatten)]
    pub basis: super::reconstruct_cmd::BasisOptions,
    /// Rebuild even if a valid cached basis exists.
    #[arg(long)]
    pub rebuild: bool,
}

pub fn run(args: &BasisArgs) -> anyhow::Result<()> {
    let spec = args.basis.spec();
    let cache = BasisCache::default_location()?;
    let start = Instant::now();
    let (basis, outcome) =
        cache.load_or_build(&spec, args.rebuild, &super::basis_progress_bar())?;
    let elapsed = start.elapsed();
    match outcome {
        CacheOutcome::Loaded => outln!(
            "loaded cached basis in {:.1} ms",
            elapsed.as_secs_f64() * 1e3
        ),
        CacheOutcome::Built => outln!("built basis in {:.1} s", elapsed.as_secs_f64()),
        CacheOutcome::NotStored { reason } => errln!(
            "built basis in {:.1} s, but it could not be cached, so the next run builds it \
             again: {reason}",
            elapsed.as_secs_f64()
        ),
        CacheOutcome::Rebuilt { reason } => {
            outln!(
                "rebuilt basis in {:.1} s (cache was not usable: {reason})",
                elapsed.as_secs_f64()
            )
        }
    }
    outln!("file: {}", cache.path_for(&spec).display());
    outln!(
        "database: {} materials (seed {}), {} observations; K = {}",
        spec.database.size,
        spec.database.seed,
        basis.observations(),
        basis.components()
    );
    let total: f64 = basis.variances().iter().sum();
    outln!(
        "residual variance per entry (mapped domain): {:.4}",
        basis.residual_variance()
    );
    let shown: Vec<String> = basis
        .variances()
        .iter()
        .take(8)
        .map(|v| format!("{:.3}", v / total))
        .collect();
    outln!(
        "share of kept variance, first components: {}",
        shown.join(" ")
    );
    Ok(())
}
