//! `burnish reconstruct`: paintings of one or more views → a full BRDF table.

use crate::basis::{Basis, BasisCache, BasisSpec, CacheOutcome};
use crate::document::{BasisSource, Document, DocumentConfig, ImportMask};
use crate::export::load_table;
use crate::materials::database::DatabaseSpec;
use crate::metrics::evaluate;
use crate::paint::UnpaintedPixels;
use crate::scene::Scene;
use crate::session::{BasisSettings, StartMaterial};
use crate::solver::{Policy, PriorMean, PriorModel, Reconstruction, Regularization};
use crate::table::SymTable;
use crate::table::{exr_file::write_table_exr, merl::MerlBrdf};
use crate::worker::Snapshot;
use anyhow::{Context, bail};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

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

    /// The document's settings for this basis, solved with `regularization` and `policy`.
    pub fn settings(&self, regularization: Regularization, policy: Policy) -> BasisSettings {
        BasisSettings {
            components: self.components as usize,
            materials: self.materials as usize,
            regularization,
            policy,
        }
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
    /// +beckmann (a Beckmann lobe where it fits both the paint and its bright bins better)
    /// or +beckmann:R (R times better), +coat or +coat:R (a clear coat over the lobe where it
    /// fits better by the factor R; not the default: on the calibration's single-lobe
    /// materials it fitted a coat that extrapolated worse), +edge or +edge:R (a metal's
    /// exact Fresnel with an edge tint per channel instead of Schlick's, tried where the fit
    /// has no more diffuse than specular, kept where it fits better by the factor R, or from
    /// one 8-bit view, which hides the tint, where it fits better at all with the tint held
    /// near the conductor closest to the Schlick fit as far as the paint's scatter hides
    /// it), and
    /// +haze or +haze:R (a metal's lobe split into a sharp peak and a broad glow of one
    /// Fresnel, tried where the fit has almost no diffuse, kept where it fits better by the
    /// factor R), +dielectric or +dielectric:R (a dielectric's exact Fresnel instead of
    /// Schlick's, tried where the fit has more diffuse than specular and the views span
    /// θ_d over 10°, kept where it fits better by the factor R), +phong or +phong:R
    /// (Phong-like lobes: Ashikhmin and Shirley's normalisation, whose rise toward grazing is
    /// gentler than a microfacet lobe's, and Blinn–Phong's implicit masking, which rises only
    /// with the Fresnel, tried where the views span θ_d over 10°, the better kept where it
    /// fits better by the factor R), +gtr or +gtr:R (GTR's tails: Burley's generalised
    /// Trowbridge–Reitz lobe with its exponent fitted, from long tails through GGX's to a
    /// core tighter than Beckmann's, tried from the GGX and Beckmann fits, kept where it fits
    /// better by the factor R), +cavity or +cavity:R (Cook and Torrance's V-cavity masking
    /// instead of Smith's, which part most at the grazing mirror no view paints, tried where
    /// the fit's lobe is GGX's, Beckmann's or GTR's and the views span θ_d over 10°, kept
    /// where it fits better by the factor R), and
    /// +rough or +rough:R (an Oren–Nayar diffuse of fitted slope under the chosen lobe,
    /// kept where it fits better by the factor R), and +grazing:S (the lobe's specular
    /// weight, its reflectance at grazing incidence, raised toward S where the paint cannot
    /// tell it from F0, as from one view, by no more than the paint could show: physics says 1, Phong lobes say F0, and one light
    /// cannot tell which a painting means), and +closer:R (the fit also taken, whatever the
    /// evidence, where it explains the paint R times as closely as the database's mean
    /// does). The default,
    /// fitted:3+beckmann+edge:1.5+haze:1.5+rough:1.2+grazing:0.98+dielectric:1.1+phong:1.1+gtr:1.5+cavity:1.5+closer:3, is
    /// what `burnish calibrate` and the bench chose (the dielectric's margin on hand-built
    /// materials: the calibration's dielectrics all have Schlick's Fresnel).
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

/// How long the command line waits for the worker to solve what it was given (a solve and
/// a fit of the prior's mean take seconds at most; this only guards against a hang).
pub(crate) const SOLVE_TIMEOUT: Duration = Duration::from_secs(600);

/// How `reconstruct` and `suggest` turn paintings into a BRDF: the same document the app
/// edits, without a window.
pub(crate) struct PaintingSettings {
    pub basis: BasisSettings,
    pub prior_mean: PriorMean,
    pub unpainted: UnpaintedPixels,
}

/// A headless document with a view of each `--view`'s scene, its painting imported as the
/// app imports one (every object pixel paint, or under `--unpainted ignore` those `masks`
/// marks), reporting what each gave. Files are read before the basis loads, so a bad one
/// fails at once; an error names the file and the problem.
pub(crate) fn paint_views(
    views: &[ViewArg],
    masks: &[PathBuf],
    settings: &PaintingSettings,
) -> anyhow::Result<Document> {
    if settings.unpainted == UnpaintedPixels::Ignore && masks.len() != views.len() {
        bail!(
            "--unpainted ignore needs one --mask per --view saying what was painted ({} views, {} masks)",
            views.len(),
            masks.len()
        );
    }
    let mut doc = Document::new(DocumentConfig {
        basis: BasisSource::Later,
        basis_cache: None,
        basis_settings: settings.basis,
        autosave: false,
        recovery_file: None,
    });
    doc.set_prior_mean(settings.prior_mean);
    let mut used = 0;
    for (view, arg) in views.iter().enumerate() {
        let start = Instant::now();
        let scene = Scene::load(&arg.scene)?;
        doc.add_view(scene)
            .with_context(|| format!("loading the object of scene {}", arg.scene.display()))?;
        doc.set_unpainted(view, settings.unpainted);
        let geometry_ms = start.elapsed().as_secs_f64() * 1e3;
        let mask = match settings.unpainted {
            UnpaintedPixels::Ignore => ImportMask::File(masks[view].clone()),
            UnpaintedPixels::CountAsShown => ImportMask::Whole,
        };
        let report = doc.import_painting_with(&arg.painting, &mask)?;
        let c = report.counts;
        used += c.used;
        if let Some(mask) = &report.mask {
            outln!(
                "  {} unpainted pixels ignored ({})",
                report.unpainted,
                mask.display()
            );
        }
        outln!(
            "view {view}: {} = {}\n  samples used {}, skipped {} (background {}, shadow {}, grazing {}){}\n  geometry {geometry_ms:.0} ms, painting {:.0} ms",
            arg.scene.display(),
            arg.painting.display(),
            c.used,
            c.total() - c.used,
            c.background,
            c.shadow,
            c.grazing,
            if report.clipped > 0 {
                format!("; {} clipped (used as bounds)", report.clipped)
            } else {
                String::new()
            },
            start.elapsed().as_secs_f64() * 1e3 - geometry_ms
        );
    }
    if used == 0 {
        bail!(
            "no painted pixel gave a sample: every pixel is background, in shadow or at a grazing angle"
        );
    }
    Ok(doc)
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
    outln!(
        "basis: K = {}, {} materials, {how} in {:.0} ms",
        basis.components(),
        spec.database.size,
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(basis)
}

/// Hands `doc` its basis and waits for the worker to solve every view, reported.
pub(crate) fn solve_document(
    doc: &mut Document,
    basis: Arc<Basis>,
) -> anyhow::Result<Arc<Snapshot>> {
    let start = Instant::now();
    doc.set_basis(basis);
    let snapshot = doc
        .settle(SOLVE_TIMEOUT)
        .context("the solver did not answer")?;
    let stats = snapshot.stats;
    outln!(
        "solve: {} observed bins, {} inconsistent, α = {:.3e}, condition number {:.3e}, {:.1} ms",
        stats.observed_bins,
        stats.inconsistent_bins,
        stats.alpha,
        stats.condition_number,
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(snapshot)
}

/// Says how much of the starting material the basis holds: the prior's mean is its
/// projection, which the paintings edit.
fn report_start(
    path: &std::path::Path,
    material: &SymTable,
    snapshot: &Snapshot,
) -> anyhow::Result<()> {
    let (Some(basis), Some(mean)) = (&snapshot.basis, &snapshot.prior_mean) else {
        return Ok(());
    };
    let projected = Reconstruction::new(basis.clone(), mean).materialize();
    let fidelity = evaluate(material, &projected);
    outln!(
        "start: {} projected onto the basis (sphere renders {:.1} dB PSNR, relative RMSE {:.1}%)",
        path.display(),
        fidelity.median_psnr_db,
        100.0 * fidelity.relative_rmse
    );
    Ok(())
}

impl ReconstructArgs {
    fn painting_settings(&self) -> PaintingSettings {
        PaintingSettings {
            basis: self.basis.settings(self.lambda, self.policy),
            prior_mean: self.prior_mean,
            unpainted: self.unpainted,
        }
    }
}

pub fn run(args: &ReconstructArgs) -> anyhow::Result<()> {
    let total = Instant::now();
    // Read the starting material first: a bad file fails before any slow work.
    let start_material = match &args.start {
        Some(path) => Some((path, Arc::new(load_table(path)?))),
        None => None,
    };
    let mut doc = paint_views(&args.views, &args.masks, &args.painting_settings())?;
    if let Some((path, table)) = &start_material {
        doc.set_start_material(StartMaterial {
            name: path.display().to_string(),
            source: Some(path.to_path_buf()),
            table: table.clone(),
        })?;
    }
    let basis = load_basis(&args.basis)?;
    let snapshot = solve_document(&mut doc, basis)?;
    if let Some((path, table)) = &start_material {
        report_start(path, table, &snapshot)?;
    }

    let start = Instant::now();
    let reconstruction = snapshot
        .reconstruction()
        .context("the solver has no basis to reconstruct with")?;
    let full = reconstruction.materialize();
    let materialize_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    super::ensure_parent(&args.out)?;
    write_table_exr(&args.out, &full)?;
    outln!(
        "table: materialised in {materialize_ms:.0} ms, written to {} in {:.0} ms",
        args.out.display(),
        start.elapsed().as_secs_f64() * 1e3
    );
    if let Some(merl) = &args.merl {
        let start = Instant::now();
        super::ensure_parent(merl)?;
        MerlBrdf::from_table(&full).write(merl)?;
        outln!(
            "MERL binary written to {} in {:.0} ms",
            merl.display(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    if let Some(path) = &args.uncertainty {
        let start = Instant::now();
        let sd = doc
            .settled_uncertainty(SOLVE_TIMEOUT)
            .context("the uncertainty estimate did not arrive")?;
        super::ensure_parent(path)?;
        write_table_exr(path, &sd)?;
        outln!(
            "uncertainty (posterior standard deviation of ρ) written to {} in {:.0} ms",
            path.display(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    outln!("total {:.2} s", total.elapsed().as_secs_f64());
    Ok(())
}
