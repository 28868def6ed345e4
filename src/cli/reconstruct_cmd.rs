//! `burnish reconstruct`: paintings of one or more views → a full BRDF table.

use super::scene_cmds::scene_gbuffer;
use crate::basis::OracleProjector;
use crate::basis::{Basis, BasisCache, BasisSpec, CacheOutcome};
use crate::export::load_table;
use crate::materials::database::DatabaseSpec;
use crate::metrics::evaluate;
use crate::paint::UnpaintedPixels;
use crate::scene::{Scene, read_painting, samples_from_file};
use crate::solver::{
    BinChange, Policy, PriorMean, PriorModel, Reconstruction, Regularization, Solver, SparseTable,
};
use crate::table::{exr_file::write_table_exr, merl::MerlBrdf};
use anyhow::bail;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Which basis to use; every option here keys the basis cache.
#[derive(clap::Args, Debug, Clone)]
pub struct BasisOptions {
    /// Number of principal components K (1..=100).
    #[arg(long, short = 'k', default_value_t = BasisSpec::DEFAULT_COMPONENTS as u16,
          value_parser = clap::value_parser!(u16).range(1..=100))]
    pub components: u16,
    /// Materials in the generated database the basis is learnt from.
    #[arg(long, default_value_t = DatabaseSpec::default().size as u32,
          value_parser = clap::value_parser!(u32).range(8..=2000))]
    pub materials: u32,
}

impl BasisOptions {
    pub fn spec(&self) -> BasisSpec {
        let mut spec = BasisSpec::default_for(self.components as usize);
        spec.database.size = self.materials as usize;
        spec
    }
}

/// One `--view SCENE=PAINTING` argument.
#[derive(Clone, Debug)]
pub struct ViewArg {
    pub scene: PathBuf,
    pub painting: PathBuf,
}

impl std::str::FromStr for ViewArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        // Split after ".toml=" when present, so a painting path may itself contain '='.
        let (scene, painting) = match s.find(".toml=") {
            Some(i) => (&s[..i + 5], &s[i + 6..]),
            None => s
                .split_once('=')
                .ok_or_else(|| format!("'{s}' is not SCENE.toml=PAINTING"))?,
        };
        if scene.is_empty() || painting.is_empty() {
            return Err(format!("'{s}' is not SCENE.toml=PAINTING"));
        }
        Ok(Self {
            scene: scene.into(),
            painting: painting.into(),
        })
    }
}

#[derive(clap::Args, Debug)]
pub struct ReconstructArgs {
    /// A view: its scene file and the painting of it (PNG, sRGB, or EXR, linear). Repeatable.
    #[arg(long = "view", required = true, value_name = "SCENE.toml=PAINTING")]
    pub views: Vec<ViewArg>,
    /// Where to write the reconstructed table (EXR, TABLE.md).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write a MERL binary (isotropic export for other renderers).
    #[arg(long)]
    pub merl: Option<PathBuf>,
    /// Also write the per-entry posterior standard deviation of ρ as an EXR table (TABLE.md
    /// layout): small where the paintings observe the table, large where it is guessed.
    #[arg(long)]
    pub uncertainty: Option<PathBuf>,
    #[command(flatten)]
    pub basis: BasisOptions,
    /// Regularisation: auto (the calibrated prior, α = 10), gcv, a number (the prior's α),
    /// prior:α or ridge:λ.
    #[arg(long, default_value = "auto")]
    pub lambda: Regularization,
    /// Where the prior is centred without --start: fitted:M (Lambert + GGX fitted to the
    /// paint, when it makes the paint e^M times more likely than the database's mean),
    /// fitted (always) or database (the database's mean material); a fitted one may add
    /// +beckmann (a Beckmann lobe where it fits both the paint and its bright bins better;
    /// the default, fitted:3+beckmann, as calibrated) or +beckmann:R (R times better).
    #[arg(long, default_value_t = PriorModel::CALIBRATED.mean)]
    pub prior_mean: PriorMean,
    /// How samples falling in one bin combine.
    #[arg(long, default_value = "mean")]
    pub policy: Policy,
    /// A starting material (EXR table, MERL .binary or .bsdf): its projection onto the basis
    /// becomes the prior mean, so the paintings edit it and unpainted parts keep it.
    #[arg(long, value_name = "FILE")]
    pub start: Option<PathBuf>,
    /// What the pixels the artist did not paint say, as in the app: `count` (every lit object
    /// pixel is a sample of what it shows) or `ignore` (only painted pixels are; needs a
    /// `--mask` per view).
    #[arg(long, default_value = "count")]
    pub unpainted: UnpaintedPixels,
    /// Which pixels of a view were painted (PNG or EXR of the painting's size; non-black:
    /// painted), e.g. the `-mask.png` the app exports beside a painting. One per `--view`, in
    /// the same order; used with `--unpainted ignore`.
    #[arg(long = "mask", value_name = "MASK")]
    pub masks: Vec<PathBuf>,
}

/// Paintings of views, binned: the sparse table, the bin changes that built it, the scenes.
pub(crate) struct PaintedViews {
    pub table: SparseTable,
    pub changes: Vec<BinChange>,
    pub scenes: Vec<Scene>,
}

/// Reads every `--view`, every lit object pixel a sample, reporting what each gave; an error
/// names the file and the problem.
pub(crate) fn read_views(views: &[ViewArg], policy: Policy) -> anyhow::Result<PaintedViews> {
    read_views_masked(views, policy, UnpaintedPixels::CountAsShown, &[])
}

/// [`read_views`] under the rule `unpainted`, `masks[i]` saying which pixels of view i were
/// painted (needed for every view under [`UnpaintedPixels::Ignore`]).
pub(crate) fn read_views_masked(
    views: &[ViewArg],
    policy: Policy,
    unpainted: UnpaintedPixels,
    masks: &[PathBuf],
) -> anyhow::Result<PaintedViews> {
    if unpainted == UnpaintedPixels::Ignore && masks.len() != views.len() {
        bail!(
            "--unpainted ignore needs one --mask per --view saying what was painted ({} views, {} masks)",
            views.len(),
            masks.len()
        );
    }
    let mut table = SparseTable::new(policy);
    let mut changes = Vec::new();
    let mut scenes = Vec::new();
    for (view, arg) in views.iter().enumerate() {
        let start = Instant::now();
        let (scene, gbuffer) = scene_gbuffer(&arg.scene)?;
        let geometry_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut set = samples_from_file(&gbuffer, &arg.painting)?;
        if unpainted == UnpaintedPixels::Ignore {
            let mask = read_painting(&masks[view], gbuffer.resolution())?;
            let before = set.samples.len();
            set.samples.retain(|s| {
                let p = mask.pixels[s.pixel as usize];
                p.iter().any(|&c| c > 0.0)
            });
            let unpainted = before - set.samples.len();
            set.counts.used -= unpainted;
            println!(
                "  {unpainted} unpainted pixels ignored ({})",
                masks[view].display()
            );
        }
        set.insert_into(view as u32, &mut table, &mut changes)
            .map_err(|(pixel, e)| {
                anyhow::anyhow!("{}: pixel {pixel}: {e}", arg.painting.display())
            })?;
        let c = set.counts;
        let bounded = set
            .samples
            .iter()
            .filter(|s| s.bounds != crate::solver::EXACT)
            .count();
        println!(
            "view {view}: {} = {}\n  samples used {}, skipped {} (background {}, shadow {}, grazing {}, invalid paint {}){}\n  geometry {geometry_ms:.0} ms, painting {:.0} ms",
            arg.scene.display(),
            arg.painting.display(),
            c.used,
            c.total() - c.used,
            c.background,
            c.shadow,
            c.grazing,
            c.invalid,
            if bounded > 0 {
                format!("; {bounded} clipped (used as bounds)")
            } else {
                String::new()
            },
            start.elapsed().as_secs_f64() * 1e3 - geometry_ms
        );
        if c.invalid > 0 {
            eprintln!(
                "warning: {}: {} pixels are NaN, infinite or negative and were skipped",
                arg.painting.display(),
                c.invalid
            );
        }
        scenes.push(scene);
    }
    if table.sample_count() == 0 {
        bail!(
            "no painted pixel gave a sample: every pixel is background, in shadow or at a grazing angle"
        );
    }
    Ok(PaintedViews {
        table,
        changes,
        scenes,
    })
}

/// The basis of `options`, from the cache or built (with a progress bar), reported.
pub(crate) fn load_basis(options: &BasisOptions) -> anyhow::Result<Arc<Basis>> {
    let start = Instant::now();
    let spec = options.spec();
    let cache = BasisCache::default_location()?;
    let (basis, outcome) = cache.load_or_build(&spec, false, &super::basis_progress_bar())?;
    let how = match outcome {
        CacheOutcome::Loaded => "loaded from cache".to_string(),
        CacheOutcome::Built => "built".to_string(),
        CacheOutcome::Rebuilt { reason } => format!("rebuilt ({reason})"),
        CacheOutcome::NotStored { reason } => format!("built, not cached ({reason})"),
    };
    println!(
        "basis: K = {}, {} materials, {how} in {:.0} ms",
        basis.components(),
        spec.database.size,
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(basis)
}

/// The projection of a starting material onto the basis, reported with how much of it the
/// basis can hold: the paintings edit this projection.
pub(crate) fn start_coefficients(
    basis: &Arc<Basis>,
    path: &std::path::Path,
    material: &crate::table::SymTable,
) -> Vec<[f64; 3]> {
    let start = Instant::now();
    let coefficients = OracleProjector::new(basis.clone()).project(material);
    let projected = Reconstruction::new(basis.clone(), &coefficients).materialize();
    let fidelity = evaluate(material, &projected);
    println!(
        "start: {} projected onto the basis in {:.0} ms (sphere renders {:.1} dB PSNR, \
         relative RMSE {:.1}%)",
        path.display(),
        start.elapsed().as_secs_f64() * 1e3,
        fidelity.median_psnr_db,
        100.0 * fidelity.relative_rmse
    );
    coefficients
}

/// The solver with every painted bin applied, on the prior mean `start` when one is given.
pub(crate) fn solve_views(
    basis: Arc<Basis>,
    regularization: Regularization,
    mean: PriorMean,
    start_mean: Option<Vec<[f64; 3]>>,
    painted: &PaintedViews,
) -> Solver {
    let start = Instant::now();
    let model = PriorModel {
        mean,
        ..PriorModel::CALIBRATED
    };
    let mut solver = Solver::with_model(basis, regularization, model);
    solver.set_prior_mean(start_mean);
    solver.apply_all(&painted.changes);
    solver.refit_prior_mean();
    let solution = solver.solve();
    println!(
        "solve: {} observed bins, {} inconsistent, α = {:.3e}, condition number {:.3e}, {:.1} ms",
        painted.table.observed_count(),
        painted.table.inconsistent_count(),
        solution.alpha,
        solution.condition_number,
        start.elapsed().as_secs_f64() * 1e3
    );
    solver
}

pub fn run(args: &ReconstructArgs) -> anyhow::Result<()> {
    let total = Instant::now();
    // Read the starting material first: a bad file fails before any slow work.
    let start_material = match &args.start {
        Some(path) => Some((path, load_table(path)?)),
        None => None,
    };
    let painted = read_views_masked(&args.views, args.policy, args.unpainted, &args.masks)?;
    let basis = load_basis(&args.basis)?;
    let start_mean = start_material
        .as_ref()
        .map(|(path, material)| start_coefficients(&basis, path, material));
    let solver = solve_views(
        basis.clone(),
        args.lambda,
        args.prior_mean,
        start_mean,
        &painted,
    );
    let solution = solver.solve();

    let start = Instant::now();
    let reconstruction = solution.reconstruction(basis);
    let full = reconstruction.materialize();
    let materialize_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    super::ensure_parent(&args.out)?;
    write_table_exr(&args.out, &full)?;
    println!(
        "table: materialised in {materialize_ms:.0} ms, written to {} in {:.0} ms",
        args.out.display(),
        start.elapsed().as_secs_f64() * 1e3
    );
    if let Some(merl) = &args.merl {
        let start = Instant::now();
        super::ensure_parent(merl)?;
        MerlBrdf::from_table(&full).write(merl)?;
        println!(
            "MERL binary written to {} in {:.0} ms",
            merl.display(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    if let Some(path) = &args.uncertainty {
        let start = Instant::now();
        let sd = solver.posterior().table_std_dev(&reconstruction);
        super::ensure_parent(path)?;
        write_table_exr(path, &sd)?;
        println!(
            "uncertainty (posterior standard deviation of ρ) written to {} in {:.0} ms",
            path.display(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    println!("total {:.2} s", total.elapsed().as_secs_f64());
    Ok(())
}
