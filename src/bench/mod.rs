//! `burnish bench`: run time against error, and the live-loop timings.
//!
//! Held-out materials are tabulated and rendered from their table as `burnish render` does
//! ([`render_table`]: a perfect painter of the table the scores compare against), turned into
//! samples exactly as a painting is (LDR paint as clipped, censored 8-bit values), and
//! reconstructed under a sweep of configurations around the paper's (K = 20, default prior,
//! mean policy, one view; here at the scene default 512² with HDR paint). Each axis of the
//! sweep (K, regularisation, views, guide resolution, LDR/HDR paint, sample policy) is varied
//! alone from that configuration. Every reconstruction is scored with `burnish eval`'s metrics
//! against the tabulated truth, next to the oracle (the truth projected onto the basis) and an
//! analytic Lambert + anisotropic GGX fit of the same samples.

pub mod calibrate;
pub mod error_maps;
pub mod held_out;
pub mod live;
pub mod next_view_trial;
pub mod plot;
pub mod report;
pub mod scaling;
pub mod stability;

use crate::basis::OracleProjector;
use crate::basis::{Basis, BasisCache, BasisSpec, CacheOutcome};
use crate::error::Result;
use crate::image_io::RgbImage;
use crate::materials::tabulate;
use crate::metrics::{error_by_angle, evaluate};
use crate::scene::{
    CameraSettings, GBuffer, LightSettings, Object, PaintRange, SampleCounts, SampleSet, Scene,
    render_table, samples_from_image_in, srgb_decode, srgb_encode,
};
use crate::solver::analytic_fit::{FitOptions, Prepared, fit_lambert_microfacet};
use crate::solver::{Policy, PriorModel, Reconstruction, Regularization, Solver, SparseTable};
use crate::table::SymTable;
use held_out::HeldOut;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

pub use live::LiveLoop;
pub use report::{Aggregate, BenchReport, Machine};

/// How a painting's values reach the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Paint {
    /// Linear floats, unclipped (an EXR painting).
    Hdr,
    /// sRGB-encoded 8-bit, clipped at 1 (a PNG painting), then decoded.
    Ldr,
}

impl Paint {
    /// What the painting's values can express.
    pub fn range(self) -> PaintRange {
        match self {
            Paint::Hdr => PaintRange::Hdr,
            Paint::Ldr => PaintRange::Ldr,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Paint::Hdr => "hdr",
            Paint::Ldr => "ldr",
        }
    }
}

/// One light and camera of the views a painting session uses. View 0 is the SCENE.md default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSetup {
    pub light_elevation_deg: f64,
    pub light_azimuth_deg: f64,
    pub camera_yaw_deg: f64,
    pub camera_pitch_deg: f64,
}

/// The views, in the order they are added: 1 view uses the first, 2 the first two, …. The
/// first three are lights an artist moves around the default orthographic sphere; the fourth
/// also turns the camera.
pub const VIEWS: [ViewSetup; 4] = [
    ViewSetup {
        light_elevation_deg: 45.0,
        light_azimuth_deg: 30.0,
        camera_yaw_deg: 0.0,
        camera_pitch_deg: 0.0,
    },
    ViewSetup {
        light_elevation_deg: 60.0,
        light_azimuth_deg: 200.0,
        camera_yaw_deg: 0.0,
        camera_pitch_deg: 0.0,
    },
    ViewSetup {
        light_elevation_deg: 20.0,
        light_azimuth_deg: 120.0,
        camera_yaw_deg: 0.0,
        camera_pitch_deg: 0.0,
    },
    ViewSetup {
        light_elevation_deg: 10.0,
        light_azimuth_deg: 100.0,
        camera_yaw_deg: -40.0,
        camera_pitch_deg: -15.0,
    },
];

impl ViewSetup {
    /// The scene of this view: the default sphere with this light and camera.
    pub fn scene(&self, resolution: u32) -> Scene {
        Scene {
            resolution,
            light: LightSettings {
                elevation_deg: self.light_elevation_deg,
                azimuth_deg: self.light_azimuth_deg,
            },
            camera: CameraSettings {
                yaw_deg: self.camera_yaw_deg,
                pitch_deg: self.camera_pitch_deg,
                ..CameraSettings::default()
            },
            ..Scene::default()
        }
    }
}

/// A sparse reconstruction's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub components: usize,
    pub regularization: Regularization,
    pub model: PriorModel,
    pub views: usize,
    pub resolution: u32,
    pub paint: Paint,
    pub policy: Policy,
}

impl Config {
    /// The paper's configuration (K = 20, mean, one view), at the scene default resolution
    /// with HDR paint and the default prior.
    pub fn paper() -> Self {
        Self {
            components: 20,
            regularization: Regularization::Auto,
            model: PriorModel::CALIBRATED,
            views: 1,
            resolution: 512,
            paint: Paint::Hdr,
            policy: Policy::Mean,
        }
    }

    /// A short stable label, e.g. `K20 auto 1v 512 hdr mean` (`global` after K for the
    /// global prior of Nielsen et al., any other prior model spelled out).
    pub fn label(&self) -> String {
        format!(
            "K{}{} {} {}v {} {} {}",
            self.components,
            model_name(self.model),
            regularization_name(self.regularization),
            self.views,
            self.resolution,
            self.paint.name(),
            policy_name(self.policy)
        )
    }

    fn samples_key(&self) -> SamplesKey {
        (self.views, self.resolution, self.paint)
    }
}

/// The calibrated prior on the database's mean material, without the fitted reference:
/// measured beside the default on every run, so that what the fit brings stays on record.
pub const DATABASE_MEAN: PriorModel = PriorModel {
    mean: crate::solver::PriorMean::Database,
    ..PriorModel::CALIBRATED
};

/// "" for the calibrated prior, " global" for Nielsen et al.'s, else its constants.
pub fn model_name(m: PriorModel) -> String {
    if m == PriorModel::CALIBRATED {
        String::new()
    } else if m == PriorModel::GLOBAL {
        " global".into()
    } else {
        format!(
            " bands{}/ρ{}/β{}/κ{}/{}",
            m.bands,
            m.band_correlation,
            m.brightness_exponent,
            m.brightness_floor,
            m.mean.name()
        )
    }
}

/// `auto`, `gcv`, `prior:α` or `ridge:λ`, as `--lambda` takes them.
pub fn regularization_name(r: Regularization) -> String {
    r.to_string()
}

pub fn policy_name(p: Policy) -> &'static str {
    match p {
        Policy::Mean => "mean",
        Policy::Min => "min",
        Policy::Max => "max",
    }
}

/// What produced a table.
// A bench holds a few dozen methods, copied as labels and keys: the solver's configuration
// inline keeps them `Copy`, and its size costs nothing there.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// The sparse solver from painted samples.
    Sparse(Config),
    /// The truth projected onto the K-component basis.
    Oracle { components: usize },
    /// Lambert + anisotropic GGX fitted by Levenberg–Marquardt to the samples of `views`.
    Analytic {
        views: usize,
        resolution: u32,
        paint: Paint,
    },
}

impl Method {
    pub fn label(&self) -> String {
        match self {
            Method::Sparse(c) => c.label(),
            Method::Oracle { components } => format!("oracle K{components}"),
            Method::Analytic {
                views,
                resolution,
                paint,
            } => format!("analytic {views}v {resolution} {}", paint.name()),
        }
    }

    pub fn kind(&self) -> &'static str {
        match self {
            Method::Sparse(_) => "sparse",
            Method::Oracle { .. } => "oracle",
            Method::Analytic { .. } => "analytic",
        }
    }
}

/// One method on one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub method: Method,
    /// Which sweep axis this row varies from the paper's configuration ("paper" for it).
    pub axis: &'static str,
    pub material: String,
    pub family: &'static str,
    pub lambert_ggx: bool,
    pub relative_rmse: f64,
    pub log_rmse: f64,
    pub median_psnr_db: f64,
    /// The share of its squared relative error at the grazing mirror (θ_h under 5°, θ_d over
    /// 60°), which no light beside the camera paints.
    pub grazing_mirror_share: f64,
    /// Samples to full table: sample extraction, binning, solve (or fit) and materialisation.
    pub time_ms: f64,
    pub samples_used: usize,
    pub observed_bins: usize,
    /// Pixels of the paintings, by what became of them.
    pub counts: SampleCounts,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// "quick" or "full": named in the outputs.
    pub mode: &'static str,
    /// Where bases are cached (and built into when missing).
    pub cache: BasisCache,
    /// Materials of the basis database (its seed is the default one).
    pub basis_materials: usize,
    /// Held-out database materials (from [`held_out::HELD_OUT_SEED`]).
    pub database_materials: usize,
    /// Hand-built materials (at most [`held_out::HAND_BUILT`]).
    pub hand_built: usize,
    /// The centre of the sweep.
    pub paper: Config,
    pub components: Vec<usize>,
    pub regularizations: Vec<Regularization>,
    /// Prior models besides the calibrated one.
    pub models: Vec<PriorModel>,
    pub view_counts: Vec<usize>,
    pub resolutions: Vec<u32>,
    pub paints: Vec<Paint>,
    pub policies: Vec<Policy>,
    /// View counts the analytic fit is run on (at the paper's resolution and paint).
    pub analytic_views: Vec<usize>,
    pub fit: FitOptions,
    pub live: live::LiveOptions,
    /// Where to write an error map per material for the paper's configuration and every view
    /// count (none when `None`).
    pub error_maps: Option<std::path::PathBuf>,
    /// The suggested-against-random next view trial, on every held-out material (none when
    /// `None`).
    pub next_view: Option<next_view_trial::TrialOptions>,
}

impl BenchOptions {
    /// The full sweep of the issue.
    pub fn full(cache: BasisCache) -> Self {
        Self {
            mode: "full",
            cache,
            basis_materials: crate::materials::database::DatabaseSpec::default().size,
            database_materials: 20,
            hand_built: held_out::HAND_BUILT,
            paper: Config::paper(),
            components: vec![5, 10, 20, 40, 80],
            regularizations: vec![
                Regularization::Auto,
                Regularization::Gcv,
                Regularization::Prior { alpha: 0.3 },
                Regularization::Prior { alpha: 1.0 },
                Regularization::Prior { alpha: 10.0 },
                Regularization::Prior { alpha: 30.0 },
                Regularization::Ridge { lambda: 0.01 },
            ],
            models: vec![PriorModel::GLOBAL, DATABASE_MEAN],
            view_counts: vec![1, 2, 3, 4],
            resolutions: vec![256, 512, 1024],
            paints: vec![Paint::Hdr, Paint::Ldr],
            policies: vec![Policy::Mean, Policy::Min, Policy::Max],
            analytic_views: vec![1, 4],
            fit: FitOptions::default(),
            live: live::LiveOptions::full(),
            error_maps: None,
            next_view: Some(next_view_trial::TrialOptions {
                candidates: 48,
                random_picks: 3,
                resolution: 512,
            }),
        }
    }

    /// The short run: the default basis (K = 20) only, ten held-out materials (four from the
    /// database's held-out seed, six hand-built), the paper's configuration, three views, LDR
    /// paint, and the global prior and the database's mean for comparison.
    pub fn quick(cache: BasisCache) -> Self {
        Self {
            mode: "quick",
            database_materials: 4,
            hand_built: 6,
            components: vec![20],
            regularizations: vec![Regularization::Auto],
            models: vec![PriorModel::GLOBAL, DATABASE_MEAN],
            view_counts: vec![1, 3],
            resolutions: vec![512],
            paints: vec![Paint::Hdr, Paint::Ldr],
            policies: vec![Policy::Mean],
            analytic_views: vec![1],
            live: live::LiveOptions::quick(),
            ..Self::full(cache)
        }
    }

    /// Every sparse configuration and the sweep axis it belongs to, the paper's first.
    pub fn sparse_configs(&self) -> Vec<(&'static str, Config)> {
        let p = self.paper;
        let mut out = vec![("paper", p)];
        let mut add = |axis: &'static str, c: Config| {
            if c != p {
                out.push((axis, c));
            }
        };
        for &components in &self.components {
            add("K", Config { components, ..p });
        }
        for &regularization in &self.regularizations {
            add(
                "regularisation",
                Config {
                    regularization,
                    ..p
                },
            );
        }
        for &model in &self.models {
            add("prior", Config { model, ..p });
            // The global prior with three views too: what the localised one is measured against.
            if self.view_counts.contains(&3) {
                add(
                    "prior",
                    Config {
                        model,
                        views: 3,
                        ..p
                    },
                );
            }
        }
        for &views in &self.view_counts {
            add("views", Config { views, ..p });
        }
        for &resolution in &self.resolutions {
            add("resolution", Config { resolution, ..p });
        }
        for &paint in &self.paints {
            add("paint", Config { paint, ..p });
        }
        for &policy in &self.policies {
            add("policy", Config { policy, ..p });
        }
        out
    }

    fn basis_spec(&self, components: usize) -> BasisSpec {
        let mut spec = BasisSpec::default_for(components);
        spec.database.size = self.basis_materials;
        spec
    }
}

/// (views, resolution, paint): what fixes a set of samples.
type SamplesKey = (usize, u32, Paint);

/// Bases by K, loaded or built once, with how each came.
pub(crate) struct Bases<'a> {
    options: &'a BenchOptions,
    loaded: BTreeMap<usize, Arc<Basis>>,
    /// (K, outcome, seconds) for every basis this run loaded or built.
    pub(crate) history: Vec<(usize, String, f64)>,
}

impl<'a> Bases<'a> {
    fn new(options: &'a BenchOptions) -> Self {
        Self {
            options,
            loaded: BTreeMap::new(),
            history: Vec::new(),
        }
    }

    pub(crate) fn get(&mut self, components: usize, log: &dyn Fn(&str)) -> Result<Arc<Basis>> {
        if let Some(b) = self.loaded.get(&components) {
            return Ok(b.clone());
        }
        let spec = self.options.basis_spec(components);
        let start = Instant::now();
        let (basis, outcome) = self.options.cache.load_or_build(&spec, false, &|_| {})?;
        let seconds = start.elapsed().as_secs_f64();
        let how = match outcome {
            CacheOutcome::Loaded => "loaded".to_string(),
            CacheOutcome::Built => "built".to_string(),
            CacheOutcome::Rebuilt { reason } => format!("rebuilt ({reason})"),
            CacheOutcome::NotStored { reason } => format!("built, not cached ({reason})"),
        };
        log(&format!(
            "basis K = {components} ({} materials): {how} in {seconds:.1} s",
            spec.database.size
        ));
        self.history.push((components, how, seconds));
        self.loaded.insert(components, basis.clone());
        Ok(basis)
    }
}

/// Geometry buffers by (view, resolution), built once.
#[derive(Default)]
pub(crate) struct Geometry {
    buffers: BTreeMap<(usize, u32), Arc<GBuffer>>,
}

impl Geometry {
    pub(crate) fn get(&mut self, view: usize, resolution: u32) -> Arc<GBuffer> {
        self.buffers
            .entry((view, resolution))
            .or_insert_with(|| {
                let scene = VIEWS[view].scene(resolution);
                let object = Object::load(&scene.object_source())
                    .expect("the built-in sphere needs no file");
                Arc::new(GBuffer::build(&scene, &object))
            })
            .clone()
    }
}

/// An 8-bit sRGB painting, clipped at 1, decoded back to linear: what a PNG holds.
pub fn ldr_round_trip(image: &RgbImage) -> RgbImage {
    let decode: Vec<f32> = (0..=255u8).map(|v| srgb_decode(v as f32 / 255.0)).collect();
    RgbImage {
        width: image.width,
        height: image.height,
        pixels: image
            .pixels
            .iter()
            .map(|rgb| rgb.map(|c| decode[(srgb_encode(c) * 255.0).round() as usize]))
            .collect(),
    }
}

/// The samples of one material under one (views, resolution, paint), and what they cost.
struct PaintedViews {
    sets: Vec<SampleSet>,
    /// Sample extraction time, all views.
    samples_ms: f64,
}

impl PaintedViews {
    fn counts(&self) -> SampleCounts {
        let mut total = SampleCounts::default();
        for s in &self.sets {
            total.used += s.counts.used;
            total.background += s.counts.background;
            total.shadow += s.counts.shadow;
            total.grazing += s.counts.grazing;
            total.invalid += s.counts.invalid;
        }
        total
    }

    /// The sparse table of these samples under `policy`, and the bin changes that built it.
    fn sparse_table(&self, policy: Policy) -> (SparseTable, Vec<crate::solver::BinChange>) {
        let mut table = SparseTable::new(policy);
        let mut changes = Vec::new();
        for (view, set) in self.sets.iter().enumerate() {
            set.insert_into(view as u32, &mut table, &mut changes)
                .expect("samples from an image are finite and non-negative");
        }
        (table, changes)
    }
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Runs the benchmark; `log` gets one line per step (for stderr).
pub fn run_bench(options: &BenchOptions, log: &dyn Fn(&str)) -> Result<BenchReport> {
    let started = Instant::now();
    let machine_before = Machine::probe();
    let mut bases = Bases::new(options);
    let mut geometry = Geometry::default();
    let configs = options.sparse_configs();
    let mut oracle_ks: Vec<usize> = options.components.clone();
    if !oracle_ks.contains(&options.paper.components) {
        oracle_ks.push(options.paper.components);
    }
    oracle_ks.sort_unstable();
    // Bases first: a cold build is the long part and is reported on its own.
    let mut projectors = BTreeMap::new();
    for &k in &oracle_ks {
        let basis = bases.get(k, log)?;
        projectors.insert(k, OracleProjector::new(basis));
    }

    let mut materials = held_out::database_materials(options.database_materials);
    materials.extend(held_out::hand_built_materials(options.hand_built));
    let mut keys: Vec<SamplesKey> = configs.iter().map(|(_, c)| c.samples_key()).collect();
    let p = options.paper;
    keys.extend(
        options
            .analytic_views
            .iter()
            .map(|&v| (v, p.resolution, p.paint)),
    );
    keys.sort_unstable();
    keys.dedup();

    let mut rows = Vec::new();
    let mut next_view = Vec::new();
    for (i, m) in materials.iter().enumerate() {
        let material_start = Instant::now();
        let truth = tabulate(&*m.brdf);
        let mut renders: BTreeMap<(usize, u32), RgbImage> = BTreeMap::new();
        for &key in &keys {
            let (views, resolution, paint) = key;
            let mut sets = Vec::with_capacity(views);
            let mut samples_ms = 0.0;
            for view in 0..views {
                let gbuffer = geometry.get(view, resolution);
                let render = renders
                    .entry((view, resolution))
                    .or_insert_with(|| render_table(&gbuffer, &truth));
                let painting = match paint {
                    Paint::Hdr => render.clone(),
                    Paint::Ldr => ldr_round_trip(render),
                };
                let start = Instant::now();
                sets.push(samples_from_image_in(&gbuffer, &painting, paint.range()));
                samples_ms += ms_since(start);
            }
            let painted = PaintedViews { sets, samples_ms };
            for &(axis, config) in configs.iter().filter(|(_, c)| c.samples_key() == key) {
                let basis = bases.get(config.components, log)?;
                let map = options
                    .error_maps
                    .as_ref()
                    .filter(|_| matches!(axis, "paper" | "views" | "paint" | "prior"))
                    .map(|dir| {
                        dir.join(format!(
                            "{}-{}.png",
                            m.name,
                            config.label().replace(['/', ' '], "_")
                        ))
                    });
                rows.push(sparse_row(
                    m,
                    &truth,
                    &painted,
                    basis,
                    axis,
                    config,
                    map.as_deref(),
                )?);
            }
            if resolution == p.resolution
                && paint == p.paint
                && options.analytic_views.contains(&views)
            {
                rows.push(analytic_row(m, &truth, &painted, key, &options.fit));
            }
        }
        for (&k, projector) in &projectors {
            rows.push(oracle_row(m, &truth, projector, k));
        }
        if let Some(trial) = options.next_view {
            let basis = bases.get(p.components, log)?;
            next_view.push(next_view_trial::trial(
                &m.name, &truth, &basis, trial, i as u64,
            ));
        }
        log(&format!(
            "material {}/{} {}: {:.1} s",
            i + 1,
            materials.len(),
            m.name,
            material_start.elapsed().as_secs_f64()
        ));
    }

    let live = live::measure(options, &mut bases, &mut geometry, &materials, log)?;
    log("stability probe");
    let stability = stability::probe(
        &bases.get(options.paper.components, log)?,
        &geometry.get(0, options.paper.resolution),
    );
    let basis_history = bases.history.clone();
    Ok(BenchReport::new(
        options,
        machine_before,
        rows,
        report::Measured {
            live,
            stability,
            next_view,
        },
        basis_history,
        started.elapsed().as_secs_f64(),
    ))
}

fn sparse_row(
    m: &HeldOut,
    truth: &SymTable,
    painted: &PaintedViews,
    basis: Arc<Basis>,
    axis: &'static str,
    config: Config,
    error_map: Option<&std::path::Path>,
) -> Result<Row> {
    let start = Instant::now();
    let (table, changes) = painted.sparse_table(config.policy);
    let mut solver = Solver::with_model(basis.clone(), config.regularization, config.model);
    solver.apply_all(&changes);
    solver.refit_prior_mean();
    let solution = solver.solve();
    let estimate = solution.reconstruction(basis).materialize();
    let time_ms = painted.samples_ms + ms_since(start);
    let e = evaluate(truth, &estimate);
    if let Some(path) = error_map {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| crate::Error::io(dir, e))?;
        }
        let observed = table.observed().map(|(pair, _)| pair).collect();
        error_maps::write_error_map(path, truth, &estimate, &observed)?;
    }
    Ok(Row {
        method: Method::Sparse(config),
        axis,
        material: m.name.clone(),
        family: m.family,
        lambert_ggx: m.lambert_ggx,
        relative_rmse: e.relative_rmse,
        log_rmse: e.log_rmse,
        median_psnr_db: e.median_psnr_db,
        grazing_mirror_share: error_by_angle(truth, &estimate).grazing_mirror_share(),
        time_ms,
        samples_used: table.sample_count(),
        observed_bins: table.observed_count(),
        counts: painted.counts(),
    })
}

fn analytic_row(
    m: &HeldOut,
    truth: &SymTable,
    painted: &PaintedViews,
    key: SamplesKey,
    fit: &FitOptions,
) -> Row {
    let (views, resolution, paint) = key;
    let start = Instant::now();
    let (table, _) = painted.sparse_table(Policy::Mean);
    let bins: Vec<(crate::table::PairIndex, [f64; 3])> = table.observed().collect();
    let result = fit_lambert_microfacet(&bins, fit);
    let estimate = tabulate(&Prepared::new(result.model));
    let time_ms = painted.samples_ms + ms_since(start);
    let e = evaluate(truth, &estimate);
    Row {
        method: Method::Analytic {
            views,
            resolution,
            paint,
        },
        axis: "analytic",
        material: m.name.clone(),
        family: m.family,
        lambert_ggx: m.lambert_ggx,
        relative_rmse: e.relative_rmse,
        log_rmse: e.log_rmse,
        median_psnr_db: e.median_psnr_db,
        grazing_mirror_share: error_by_angle(truth, &estimate).grazing_mirror_share(),
        time_ms,
        samples_used: table.sample_count(),
        observed_bins: bins.len(),
        counts: painted.counts(),
    }
}

fn oracle_row(m: &HeldOut, truth: &SymTable, projector: &OracleProjector, k: usize) -> Row {
    let start = Instant::now();
    let x = projector.project(truth);
    let estimate = Reconstruction::new(projector.basis().clone(), &x).materialize();
    let time_ms = ms_since(start);
    let e = evaluate(truth, &estimate);
    Row {
        method: Method::Oracle { components: k },
        axis: "oracle",
        material: m.name.clone(),
        family: m.family,
        lambert_ggx: m.lambert_ggx,
        relative_rmse: e.relative_rmse,
        log_rmse: e.log_rmse,
        median_psnr_db: e.median_psnr_db,
        grazing_mirror_share: error_by_angle(truth, &estimate).grazing_mirror_share(),
        time_ms,
        samples_used: 0,
        observed_bins: crate::table::PAIRS,
        counts: SampleCounts::default(),
    }
}
