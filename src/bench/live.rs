//! The live loop: what a dab costs against its changed pixels and K, rebuilding the normal
//! equations, lazy evaluation for a preview against the full table, loading the basis, and
//! what the scene lets the loop skip.

use super::{Bases, BenchOptions, Geometry, HeldOut, ms_since};
use crate::error::Result;
use crate::scene::{
    BuiltinShape, GBuffer, Object, SampleCounts, Scene, SkipReason, guide_image, render_brdf,
    sample_pixel, samples_from_image,
};
use crate::solver::{SampleKey, Solver, SparseTable};
use crate::table::{PAIRS, PairIndex, pair_index};
use rand::{RngExt, SeedableRng};
use std::time::Instant;

/// What the live-loop part measures.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveOptions {
    /// Changed pixels per timed dab.
    pub dab_pixels: Vec<usize>,
    /// K of the timed dabs (and of the full-table and rebuild timings).
    pub dab_components: Vec<usize>,
    /// Dabs timed per (pixels, K).
    pub dab_repeats: usize,
    /// Repeats of the other timings (median reported).
    pub repeats: usize,
}

impl LiveOptions {
    pub fn full() -> Self {
        Self {
            dab_pixels: vec![50, 500, 5000],
            dab_components: vec![10, 20, 40],
            dab_repeats: 200,
            repeats: 9,
        }
    }

    pub fn quick() -> Self {
        Self {
            dab_pixels: vec![50, 500, 5000],
            dab_components: vec![20],
            dab_repeats: 100,
            repeats: 5,
        }
    }
}

/// Timings of dabs of one size at one K.
#[derive(Clone, Debug, PartialEq)]
pub struct DabTiming {
    pub components: usize,
    pub changed_pixels: usize,
    pub repeats: usize,
    /// Mean bin-value updates the solver applied per dab (one per changed sample).
    pub bin_updates: f64,
    /// Mean distinct bins a dab touched.
    pub distinct_bins: f64,
    /// Set the samples, update the normal equations, solve: median and 95th percentile.
    pub p50_ms: f64,
    pub p95_ms: f64,
}

/// Timings that depend on K only.
#[derive(Clone, Debug, PartialEq)]
pub struct PerComponents {
    pub components: usize,
    pub observed_bins: usize,
    /// The full table from coefficients (median).
    pub full_table_ms: f64,
    /// The normal equations rebuilt from every observed bin (median).
    pub rebuild_ms: f64,
}

/// A brush stroke across the guide: what each dab's pixels turned out to be.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StrokeCounts {
    pub dabs: usize,
    pub brush_radius_px: f64,
    /// Pixels under the brush over the whole stroke.
    pub pixels: usize,
    pub background: usize,
    pub shadow: usize,
    /// Below the horizon or too grazing (cos θ under the sampling threshold).
    pub grazing: usize,
    /// Painted to the value they already had (the overlap with the previous dab).
    pub unchanged: usize,
    /// Samples set.
    pub changed: usize,
    /// Bin-value updates the solver applied (one per changed sample).
    pub bin_updates: usize,
    /// Distinct bins the stroke touched.
    pub distinct_bins: usize,
    /// Median time per dab, sample setting to solve.
    pub p50_ms_per_dab: f64,
}

/// Everything the live-loop part measured.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveLoop {
    pub material: String,
    pub resolution: u32,
    pub dabs: Vec<DabTiming>,
    pub per_components: Vec<PerComponents>,
    /// Entries one view's preview needs, and their lazy evaluation time (median, paper K).
    pub lazy_entries: usize,
    pub lazy_ms: f64,
    /// The whole table's entries and its materialisation time (median, paper K).
    pub full_entries: usize,
    pub full_ms: f64,
    /// Loading the paper-K basis from its cache file: map, checksum, check (median).
    pub basis_load_ms: f64,
    /// Pixels of each built-in object's default guide (512²), by what the scene makes of them.
    pub scene_skips: Vec<(String, SampleCounts)>,
    pub stroke: StrokeCounts,
}

fn median(v: &mut [f64]) -> f64 {
    percentile(v, 0.5)
}

/// The `q` quantile (nearest rank); 0 for no values.
pub fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

pub(crate) fn measure(
    options: &BenchOptions,
    bases: &mut Bases,
    geometry: &mut Geometry,
    materials: &[HeldOut],
    log: &dyn Fn(&str),
) -> Result<LiveLoop> {
    let lo = &options.live;
    let resolution = options.paper.resolution;
    let gbuffer = geometry.get(0, resolution);
    let material = materials
        .first()
        .map_or_else(|| "none".to_string(), |m| m.name.clone());
    // The painting every timing starts from: one held-out material, fully painted, HDR.
    let painting = match materials.first() {
        Some(m) => render_brdf(&gbuffer, &*m.brdf),
        None => guide_image(&gbuffer),
    };
    let set = samples_from_image(&gbuffer, &painting);
    let n = gbuffer.resolution();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(0xda6);

    let mut dabs = Vec::new();
    let mut per_components = Vec::new();
    let mut paper_recon = None;
    let mut ks = lo.dab_components.clone();
    if !ks.contains(&options.paper.components) {
        ks.push(options.paper.components);
    }
    for &k in &ks {
        let basis = bases.get(k, log)?;
        let mut table = SparseTable::new(options.paper.policy);
        let mut solver = Solver::new(basis.clone(), options.paper.regularization);
        let mut changes = Vec::new();
        set.insert_into(0, &mut table, &mut changes)
            .expect("rendered samples are valid");
        solver.apply_all(&changes);
        changes.clear();

        if lo.dab_components.contains(&k) {
            for &size in &lo.dab_pixels {
                let size = size.min(set.samples.len());
                let mut times = Vec::with_capacity(lo.dab_repeats);
                let (mut updates, mut distinct) = (0usize, 0usize);
                for _ in 0..lo.dab_repeats {
                    let centre = set.samples[rng.random_range(0..set.samples.len().max(1))].pixel;
                    let dab = nearest_samples(&set.samples, centre as usize, n, size);
                    let factor = 0.6 + 0.8 * rng.random::<f64>();
                    let start = Instant::now();
                    for &i in &dab {
                        let s = &set.samples[i];
                        let key = SampleKey {
                            view: 0,
                            pixel: s.pixel,
                        };
                        table
                            .set_sample(
                                key,
                                s.light_bin,
                                s.view_bin,
                                s.rho.map(|c| c * factor),
                                &mut changes,
                            )
                            .expect("scaled samples are valid");
                    }
                    solver.apply_all(&changes);
                    std::hint::black_box(solver.solve());
                    times.push(ms_since(start));
                    updates += changes.len();
                    distinct += distinct_pairs(&changes);
                    changes.clear();
                }
                let p50_ms = percentile(&mut times, 0.5);
                let p95_ms = percentile(&mut times, 0.95);
                log(&format!(
                    "dab K = {k}, {size} pixels: p50 {p50_ms:.3} ms, p95 {p95_ms:.3} ms"
                ));
                dabs.push(DabTiming {
                    components: k,
                    changed_pixels: size,
                    repeats: lo.dab_repeats,
                    bin_updates: updates as f64 / lo.dab_repeats.max(1) as f64,
                    distinct_bins: distinct as f64 / lo.dab_repeats.max(1) as f64,
                    p50_ms,
                    p95_ms,
                });
            }
        }

        let solution = solver.solve();
        let recon = solution.reconstruction(basis.clone());
        let mut full = Vec::new();
        let mut rebuild = Vec::new();
        for _ in 0..lo.repeats {
            let start = Instant::now();
            std::hint::black_box(recon.materialize());
            full.push(ms_since(start));
            let start = Instant::now();
            solver.rebuild();
            rebuild.push(ms_since(start));
        }
        per_components.push(PerComponents {
            components: k,
            observed_bins: solver.observed_bins(),
            full_table_ms: median(&mut full),
            rebuild_ms: median(&mut rebuild),
        });
        if k == options.paper.components {
            paper_recon = Some(recon);
        }
    }

    // A preview needs the entries of the pixels it shows, not the table.
    let mut pairs: Vec<PairIndex> = gbuffer
        .pixels()
        .iter()
        .flatten()
        .filter(|p| p.is_lit())
        .filter_map(|p| Some(pair_index(p.light_bin?, p.view_bin?)))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    let recon = paper_recon.expect("the paper's K is timed");
    let (mut lazy, mut full) = (Vec::new(), Vec::new());
    let mut out = Vec::new();
    for _ in 0..lo.repeats {
        let start = Instant::now();
        recon.eval_pairs(&pairs, &mut out);
        lazy.push(ms_since(start));
        let start = Instant::now();
        std::hint::black_box(recon.materialize());
        full.push(ms_since(start));
    }

    let spec = options.basis_spec(options.paper.components);
    let mut loads = Vec::new();
    for _ in 0..lo.repeats {
        let start = Instant::now();
        let basis = options.cache.load(&spec)?;
        loads.push(ms_since(start));
        std::hint::black_box(basis);
    }

    let stroke = stroke_counts(
        &gbuffer,
        &painting,
        &set,
        bases.get(options.paper.components, log)?,
        options,
    );
    Ok(LiveLoop {
        material,
        resolution,
        dabs,
        per_components,
        lazy_entries: pairs.len(),
        lazy_ms: median(&mut lazy),
        full_entries: PAIRS,
        full_ms: median(&mut full),
        basis_load_ms: median(&mut loads),
        scene_skips: scene_skips(resolution),
        stroke,
    })
}

/// Distinct pairs among a batch of bin changes.
fn distinct_pairs(changes: &[crate::solver::BinChange]) -> usize {
    let mut pairs: Vec<PairIndex> = changes.iter().map(|c| c.pair).collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs.len()
}

/// Indices of the `count` samples nearest (in pixels) to pixel `centre`: a round dab.
fn nearest_samples(
    samples: &[crate::scene::Sample],
    centre: usize,
    n: usize,
    count: usize,
) -> Vec<usize> {
    let (cx, cy) = ((centre % n) as i64, (centre / n) as i64);
    let mut by_distance: Vec<(i64, usize)> = samples
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let (x, y) = ((s.pixel as usize % n) as i64, (s.pixel as usize / n) as i64);
            ((x - cx).pow(2) + (y - cy).pow(2), i)
        })
        .collect();
    if count < by_distance.len() {
        by_distance.select_nth_unstable(count);
        by_distance.truncate(count);
    }
    by_distance.into_iter().map(|(_, i)| i).collect()
}

/// What each built-in object's default guide makes of its pixels.
fn scene_skips(resolution: u32) -> Vec<(String, SampleCounts)> {
    BuiltinShape::ALL
        .iter()
        .map(|&shape| {
            let scene = Scene {
                object: shape.name().to_string(),
                resolution,
                ..Scene::default()
            };
            let gbuffer = GBuffer::build(&scene, &Object::builtin(shape));
            let counts = samples_from_image(&gbuffer, &guide_image(&gbuffer)).counts;
            (shape.name().to_string(), counts)
        })
        .collect()
}

/// A stroke of round dabs (≈ 500 pixels each, spaced half a radius) from corner to corner
/// of the guide in one colour, each dab applied and solved as the live loop would.
fn stroke_counts(
    gbuffer: &GBuffer,
    painting: &crate::image_io::RgbImage,
    set: &crate::scene::SampleSet,
    basis: std::sync::Arc<crate::basis::Basis>,
    options: &BenchOptions,
) -> StrokeCounts {
    let n = gbuffer.resolution();
    let radius = (500.0 / std::f64::consts::PI).sqrt();
    let colour = [0.35f32, 0.2, 0.1];
    let mut paint = painting.pixels.clone();
    let mut table = SparseTable::new(options.paper.policy);
    let mut solver = Solver::new(basis, options.paper.regularization);
    let mut changes = Vec::new();
    set.insert_into(0, &mut table, &mut changes)
        .expect("rendered samples are valid");
    solver.apply_all(&changes);
    changes.clear();
    let mut counts = StrokeCounts {
        brush_radius_px: radius,
        ..StrokeCounts::default()
    };
    let mut times = Vec::new();
    let mut touched = std::collections::BTreeSet::new();
    // Corner to corner: over background, lit and shadowed surface and the silhouette.
    let step = 0.5 * radius / std::f64::consts::SQRT_2;
    let mut t = 0.0;
    while t <= n as f64 {
        let (x, y) = (t, t);
        counts.dabs += 1;
        let start = Instant::now();
        let r = radius.ceil() as i64;
        for dy in -r..=r {
            for dx in -r..=r {
                let (px, py) = ((x as i64 + dx), (y as i64 + dy));
                if (dx * dx + dy * dy) as f64 > radius * radius
                    || px < 0
                    || py < 0
                    || px >= n as i64
                    || py >= n as i64
                {
                    continue;
                }
                counts.pixels += 1;
                let pixel = py as usize * n + px as usize;
                match sample_pixel(gbuffer, pixel, colour) {
                    Err(SkipReason::Background) => counts.background += 1,
                    Err(SkipReason::Shadow) => counts.shadow += 1,
                    Err(SkipReason::Grazing) | Err(SkipReason::Invalid) => counts.grazing += 1,
                    Ok(_) if paint[pixel] == colour => counts.unchanged += 1,
                    Ok(s) => {
                        paint[pixel] = colour;
                        counts.changed += 1;
                        let key = SampleKey {
                            view: 0,
                            pixel: s.pixel,
                        };
                        table
                            .set_sample(key, s.light_bin, s.view_bin, s.rho, &mut changes)
                            .expect("a valid colour gives a valid sample");
                    }
                }
            }
        }
        solver.apply_all(&changes);
        std::hint::black_box(solver.solve());
        times.push(ms_since(start));
        counts.bin_updates += changes.len();
        touched.extend(changes.iter().map(|c| c.pair));
        changes.clear();
        t += step;
    }
    counts.distinct_bins = touched.len();
    counts.p50_ms_per_dab = median(&mut times);
    counts
}
