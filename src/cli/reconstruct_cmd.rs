//! `burnish reconstruct`: paintings of one or more views → a full BRDF table.

use super::eval_cmd::evaluate;
use super::scene_cmds::scene_gbuffer;
use crate::basis::{BasisCache, BasisSpec, CacheOutcome};
use crate::bench::oracle::OracleProjector;
use crate::export::load_table;
use crate::materials::database::DatabaseSpec;
use crate::scene::samples_from_file;
use crate::solver::{Policy, Reconstruction, Regularization, Solver, SparseTable};
use crate::table::{exr_file::write_table_exr, merl::MerlBrdf};
use anyhow::bail;
use std::path::PathBuf;
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
    #[command(flatten)]
    pub basis: BasisOptions,
    /// Regularisation: auto (variance prior, α = 3), gcv, a number (the prior's α),
    /// prior:α or ridge:λ.
    #[arg(long, default_value = "auto")]
    pub lambda: Regularization,
    /// How samples falling in one bin combine.
    #[arg(long, default_value = "mean")]
    pub policy: Policy,
    /// A starting material (EXR table, MERL .binary or .bsdf): its projection onto the basis
    /// becomes the prior mean, so the paintings edit it and unpainted parts keep it.
    #[arg(long, value_name = "FILE")]
    pub start: Option<PathBuf>,
}

pub fn run(args: &ReconstructArgs) -> anyhow::Result<()> {
    let total = Instant::now();
    // Read the starting material first: a bad file fails before any slow work.
    let start_material = match &args.start {
        Some(path) => Some((path, load_table(path)?)),
        None => None,
    };
    let mut table = SparseTable::new(args.policy);
    let mut changes = Vec::new();
    for (view, arg) in args.views.iter().enumerate() {
        let start = Instant::now();
        let (_, gbuffer) = scene_gbuffer(&arg.scene)?;
        let geometry_ms = start.elapsed().as_secs_f64() * 1e3;
        let set = samples_from_file(&gbuffer, &arg.painting)?;
        set.insert_into(view as u32, &mut table, &mut changes)
            .map_err(|(pixel, e)| {
                anyhow::anyhow!("{}: pixel {pixel}: {e}", arg.painting.display())
            })?;
        let c = set.counts;
        println!(
            "view {view}: {} = {}\n  samples used {}, skipped {} (background {}, shadow {}, grazing {}, invalid paint {})\n  geometry {geometry_ms:.0} ms, painting {:.0} ms",
            arg.scene.display(),
            arg.painting.display(),
            c.used,
            c.total() - c.used,
            c.background,
            c.shadow,
            c.grazing,
            c.invalid,
            start.elapsed().as_secs_f64() * 1e3 - geometry_ms
        );
        if c.invalid > 0 {
            eprintln!(
                "warning: {}: {} pixels are NaN, infinite or negative and were skipped",
                arg.painting.display(),
                c.invalid
            );
        }
    }
    if table.sample_count() == 0 {
        bail!(
            "no painted pixel gave a sample: every pixel is background, in shadow or at a grazing angle"
        );
    }

    let start = Instant::now();
    let spec = args.basis.spec();
    let cache = BasisCache::default_location()?;
    let (basis, outcome) = cache.load_or_build(&spec, false, &super::basis_progress_bar())?;
    let how = match outcome {
        CacheOutcome::Loaded => "loaded from cache".to_string(),
        CacheOutcome::Built => "built".to_string(),
        CacheOutcome::Rebuilt { reason } => format!("rebuilt ({reason})"),
    };
    println!(
        "basis: K = {}, {} materials, {how} in {:.0} ms",
        basis.components(),
        spec.database.size,
        start.elapsed().as_secs_f64() * 1e3
    );

    let mut solver = Solver::new(basis.clone(), args.lambda);
    if let Some((path, material)) = &start_material {
        let start = Instant::now();
        let coefficients = OracleProjector::new(basis.clone()).project(material);
        // How much of the material the basis can hold: the painting edits this projection.
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
        solver.set_prior_mean(Some(coefficients));
    }
    let start = Instant::now();
    solver.apply_all(&changes);
    let solution = solver.solve();
    println!(
        "solve: {} observed bins, {} inconsistent, α = {:.3e}, condition number {:.3e}, {:.1} ms",
        table.observed_count(),
        table.inconsistent_count(),
        solution.alpha,
        solution.condition_number,
        start.elapsed().as_secs_f64() * 1e3
    );

    let start = Instant::now();
    let full = Reconstruction::new(basis, &solution.coefficients).materialize();
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
    println!("total {:.2} s", total.elapsed().as_secs_f64());
    Ok(())
}
