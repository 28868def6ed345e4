//! The GPU preview against the engine, on a real adapter (Mesa lavapipe where there is no GPU).
//! A missing adapter fails these tests; it never skips them.

mod common;

use burnish::image_io::RgbImage;
use burnish::materials::models::{Distribution, Fresnel, Microfacet};
use burnish::materials::tabulate;
use burnish::preview::{
    DirectionalLight, ENVIRONMENT_DIRECTIONS, Environment, EnvironmentLight, PreviewError,
    PreviewFrame, PreviewMode, PreviewRenderer, TargetLayout, UNOBSERVED, headless_gpu, install_in,
    material_test_object, paint_callback,
};
use burnish::scene::{
    GBuffer, Object, Projection, SHADOW, Scene, SurfacePoint, render_brdf, render_table,
    srgb_encode,
};
use burnish::solver::{BinChange, EXACT, Reconstruction};
use burnish::table::direction_index;
use burnish::table::{PAIRS, PairIndex, SymTable, pair_index};
use glam::DVec3;
use std::path::Path;

struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
}

fn gpu() -> Gpu {
    let (device, queue, info) = headless_gpu().unwrap_or_else(|e| {
        panic!("the preview tests need a GPU adapter (Mesa lavapipe will do): {e}")
    });
    eprintln!("adapter: {} ({:?})", info.name, info.backend);
    Gpu { device, queue }
}

fn renderer(gpu: &Gpu) -> PreviewRenderer {
    PreviewRenderer::new(&gpu.device, &gpu.queue, wgpu::TextureFormat::Rgba8Unorm)
        .expect("preview renderer")
}

fn render(gpu: &Gpu, r: &mut PreviewRenderer, frame: &PreviewFrame, size: u32) -> RgbImage {
    r.render_to_image(&gpu.device, &gpu.queue, frame, size, size)
        .expect("render")
}

/// A table whose neighbouring bins hold unrelated values (0.05 to 0.35 per channel), so that a
/// pixel looking up any bin but the right one shows it.
fn scrambled_table() -> SymTable {
    SymTable::from_fn(|lo, hi| {
        let mut h = (lo as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (hi as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        let channel = |shift: u32| 0.05 + 0.3 * ((h >> shift) & 0xFFFF) as f32 / 65535.0;
        [channel(0), channel(16), channel(32)]
    })
}

fn scene(object: &str, resolution: u32, edit: impl FnOnce(&mut Scene)) -> (Scene, Object) {
    let mut scene = Scene {
        object: object.into(),
        resolution,
        base_dir: Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf(),
        ..Scene::default()
    };
    edit(&mut scene);
    scene.check().expect("valid scene");
    let object = Object::load(&scene.object_source()).expect("object");
    (scene, object)
}

/// |a − b| ≤ 2% of b (plus 10⁻⁴ for black) in every channel.
fn within_2_percent(a: [f32; 3], b: [f32; 3]) -> bool {
    (0..3).all(|c| (a[c] - b[c]).abs() <= 0.02 * b[c].abs() + 1e-4)
}

fn max_abs_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
}

/// The GPU image against the CPU one over the pixels the CPU sees covered.
struct Comparison {
    covered: usize,
    median_abs: f32,
    within: f64,
    /// Mismatched pixels with no silhouette, bin change or shadow edge within 2 pixels.
    unexplained: Vec<(usize, usize)>,
}

/// Whether something changes within `reach` pixels of (x, y) in the geometry buffer: the
/// silhouette, the light or view bin, or the shadow: the places where single precision on the
/// GPU and double precision on the CPU may legitimately disagree.
fn near_an_edge(gbuffer: &GBuffer, x: usize, y: usize, reach: usize) -> bool {
    let n = gbuffer.resolution();
    let key = |p: &SurfacePoint| (p.light_bin, p.view_bin, p.is_lit());
    let centre = gbuffer.get(x, y).map(key);
    for yy in y.saturating_sub(reach)..=(y + reach).min(n - 1) {
        for xx in x.saturating_sub(reach)..=(x + reach).min(n - 1) {
            if gbuffer.get(xx, yy).map(key) != centre {
                return true;
            }
        }
    }
    // The image border counts as an edge too.
    x < reach || y < reach || x + reach >= n || y + reach >= n
}

fn compare(gpu: &RgbImage, cpu: &RgbImage, gbuffer: &GBuffer) -> Comparison {
    let n = gbuffer.resolution();
    assert_eq!((gpu.width, gpu.height), (n, n));
    let mut diffs = Vec::new();
    let mut within = 0;
    let mut unexplained = Vec::new();
    for y in 0..n {
        for x in 0..n {
            if gbuffer.get(x, y).is_none() {
                continue;
            }
            let (a, b) = (gpu.get(x, y), cpu.get(x, y));
            diffs.push(max_abs_diff(a, b));
            if within_2_percent(a, b) {
                within += 1;
            } else if !near_an_edge(gbuffer, x, y, 2) {
                unexplained.push((x, y));
            }
        }
    }
    let covered = diffs.len();
    diffs.sort_by(f32::total_cmp);
    Comparison {
        covered,
        median_abs: diffs[covered / 2],
        within: within as f64 / covered as f64,
        unexplained,
    }
}

/// Table mode, nearest bins, in the scene's own camera: the GPU reproduces `render_table`.
/// Tolerance: median absolute difference over covered pixels < 10⁻³, at least 98% of them
/// within 2%, and every pixel outside 2% within 2 pixels of a silhouette, a bin change or a
/// shadow edge (where f32 on the GPU and f64 on the CPU may pick different bins or sides).
#[test]
fn table_mode_reproduces_render_table() {
    let gpu = gpu();
    let mut r = renderer(&gpu);
    let table = scrambled_table();
    r.set_table(&table).unwrap();
    let cases = [
        scene("sphere", 256, |_| {}),
        scene("sphere", 200, |s| {
            s.camera.projection = Projection::Perspective;
            s.camera.fov_deg = 35.0;
            s.camera.yaw_deg = 40.0;
            s.camera.pitch_deg = 25.0;
            s.light.elevation_deg = 60.0;
            s.light.azimuth_deg = -70.0;
            s.tangent_reference = [0.3, 1.0, 0.2];
        }),
        scene("assets/meshes/bowl.obj", 256, |s| {
            s.camera.yaw_deg = 20.0;
            s.camera.pitch_deg = 35.0;
            s.light.elevation_deg = 40.0;
            s.light.azimuth_deg = 120.0;
        }),
        scene("torus", 240, |s| {
            s.camera.projection = Projection::Perspective;
            s.camera.fov_deg = 30.0;
            s.camera.yaw_deg = -25.0;
            s.light.elevation_deg = 70.0;
            s.light.azimuth_deg = 200.0;
        }),
        // The material-test object (convex, concave and flat parts, cast shadows), under a
        // scene that names the sphere: the geometry buffer takes the object it is given.
        {
            let (scene, _) = scene("sphere", 256, |s| {
                s.camera.pitch_deg = 15.0;
                s.light.elevation_deg = 50.0;
                s.light.azimuth_deg = -40.0;
            });
            (scene, material_test_object())
        },
    ];
    for (scene, object) in &cases {
        r.set_object(object).unwrap();
        let gbuffer = GBuffer::build(scene, object);
        let cpu = render_table(&gbuffer, &table);
        let mut frame = PreviewFrame::from_scene(scene);
        frame.mode = PreviewMode::Table;
        let image = render(&gpu, &mut r, &frame, scene.resolution);
        let c = compare(&image, &cpu, &gbuffer);
        let name = if object.mesh().is_some() && scene.object == "sphere" {
            "material test".to_owned()
        } else {
            scene.object.clone()
        };
        eprintln!(
            "{} {:?}: {} covered, median |Δ| {:.2e}, {:.3}% within 2%, {} unexplained",
            name,
            scene.camera.projection,
            c.covered,
            c.median_abs,
            100.0 * c.within,
            c.unexplained.len()
        );
        assert!(c.covered > 10_000);
        assert!(c.median_abs < 1e-3, "median |Δ| {}", c.median_abs);
        // The rest lie at bin edges and silhouettes, where a pixel centre may fall on either side.
        assert!(c.within >= 0.98, "{:.4} within 2%", c.within);
        assert!(
            c.unexplained.is_empty(),
            "{name}: mismatches away from any edge at {:?}",
            &c.unexplained[..c.unexplained.len().min(10)]
        );
        // Off the object: the background, untouched.
        let corner = image.get(0, 0);
        assert_eq!(corner, frame.background, "{name}");
    }
}

/// Coefficients of typical size: ±σ_k, with a different pattern per channel.
fn coefficients(basis: &burnish::basis::Basis, seed: usize) -> Vec<[f64; 3]> {
    basis
        .variances()
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let s = v.sqrt();
            let sign = |c: usize| {
                if (k + c + seed).is_multiple_of(3) {
                    -1.0
                } else {
                    1.0
                }
            };
            [0.9 * s * sign(0), 0.6 * s * sign(1), 0.3 * s * sign(2)]
        })
        .collect()
}

/// A sparse bin's change to `value` (`None`: no longer observed), as the worker reports it.
fn sparse_bin(pair: PairIndex, value: Option<[f32; 3]>) -> BinChange {
    BinChange {
        pair,
        before: None,
        after: value.map(|v| v.map(f64::from)),
        bounds: EXACT,
        rounding: 0.0,
        inconsistent: false,
    }
}

/// Relative errors of `a` against `b` over every pair: (max, mean), with 10⁻⁴ added to the
/// denominator for black entries.
fn table_errors(a: &SymTable, b: &SymTable) -> (f64, f64) {
    let mut max = 0f64;
    let mut sum = 0f64;
    for (x, y) in a.pairs().iter().zip(b.pairs()) {
        for c in 0..3 {
            // Relative, but absolute below ρ = 10⁻³, where (e^m (r + ε) − ε) cancels and f16
            // rounding of the components is a large fraction of a tiny value.
            let e = ((x[c] - y[c]).abs() / (y[c].abs() + 1e-3)) as f64;
            max = max.max(e);
            sum += e;
        }
    }
    (max, sum / (3 * PAIRS) as f64)
}

/// Reconstruction mode evaluates the basis on the GPU as `Reconstruction::eval_pair` does
/// (components rounded to f16), and a new set of coefficients changes the picture to what the
/// engine's table for them shows.
#[test]
fn reconstruction_mode_matches_the_materialised_table() {
    let gpu = gpu();
    let basis = common::small_basis(8);
    let mut r = renderer(&gpu);
    r.set_basis(&basis).unwrap();
    let (scene, object) = scene("sphere", 192, |s| {
        s.light.elevation_deg = 35.0;
        s.light.azimuth_deg = 50.0;
    });
    r.set_object(&object).unwrap();
    let gbuffer = GBuffer::build(&scene, &object);
    let mut images = Vec::new();
    for seed in 0..2 {
        let x = coefficients(&basis, seed);
        r.set_coefficients(&x).unwrap();
        let engine = Reconstruction::new(basis.clone(), &x).materialize();
        // Entry by entry.
        let on_gpu = r.reconstruction_table(&gpu.device, &gpu.queue).unwrap();
        let (max, mean) = table_errors(&on_gpu, &engine);
        eprintln!("coefficients {seed}: GPU table vs engine: max rel {max:.2e}, mean {mean:.2e}");
        assert!(max < 3e-2 && mean < 1e-3, "max {max}, mean {mean}");
        // Picture by picture: Reconstruction mode against Table mode of the engine's table.
        let mut frame = PreviewFrame::from_scene(&scene);
        frame.mode = PreviewMode::Reconstruction;
        let reconstruction = render(&gpu, &mut r, &frame, 192);
        r.set_table(&engine).unwrap();
        frame.mode = PreviewMode::Table;
        let table = render(&gpu, &mut r, &frame, 192);
        let c = compare(&reconstruction, &table, &gbuffer);
        eprintln!(
            "coefficients {seed}: median |Δ| {:.2e}, {:.3}% within 2%",
            c.median_abs,
            100.0 * c.within
        );
        assert!(c.median_abs < 1e-3 && c.within >= 0.999);
        images.push(reconstruction);
    }
    // New coefficients, new picture: the evaluation reran.
    let changed = images[0]
        .pixels
        .iter()
        .zip(&images[1].pixels)
        .filter(|(a, b)| !within_2_percent(**a, **b))
        .count();
    assert!(
        changed > gbuffer.covered_count() / 4,
        "only {changed} pixels changed"
    );
}

/// A fitted reference's offsets reach the GPU's evaluation: with one, the GPU's table is the
/// engine's reconstruction measured from it (a narrow anisotropic lobe the components alone
/// could not hold); set back to none, the plain one again.
#[test]
fn a_fitted_reference_moves_the_gpu_evaluation_as_it_moves_the_engine() {
    use burnish::solver::FittedReference;
    use burnish::solver::analytic_fit::{Distribution, LambertMicrofacet, Masking};
    let gpu = gpu();
    let basis = common::small_basis(8);
    let mut r = renderer(&gpu);
    r.set_basis(&basis).unwrap();
    let x = coefficients(&basis, 1);
    r.set_coefficients(&x).unwrap();
    let model = LambertMicrofacet {
        albedo: [0.3, 0.2, 0.1],
        sigma: 0.0,
        f0: [0.9, 0.6, 0.3],
        specular: 1.0,
        distribution: Distribution::Ggx,
        alpha_x: 0.08,
        alpha_y: 0.2,
        rotation: 0.4,
        coat: None,
        haze: None,
        edge: None,
        masking: Masking::Smith,
    };
    let reference = std::sync::Arc::new(FittedReference::new(basis.clone(), model));
    let plain = Reconstruction::new(basis.clone(), &x).materialize();
    let measured = Reconstruction::new(basis.clone(), &x)
        .with_reference(Some(reference.clone()))
        .materialize();
    let (_, apart) = table_errors(&plain, &measured);
    assert!(
        apart > 0.1,
        "the reference must change the table: mean rel {apart}"
    );

    r.set_fitted_reference(Some(&reference)).unwrap();
    let on_gpu = r.reconstruction_table(&gpu.device, &gpu.queue).unwrap();
    let (max, mean) = table_errors(&on_gpu, &measured);
    eprintln!("with a fitted reference: GPU table vs engine: max rel {max:.2e}, mean {mean:.2e}");
    assert!(max < 3e-2 && mean < 1e-3, "max {max}, mean {mean}");

    r.set_fitted_reference(None).unwrap();
    let on_gpu = r.reconstruction_table(&gpu.device, &gpu.queue).unwrap();
    let (max, mean) = table_errors(&on_gpu, &plain);
    assert!(max < 3e-2 && mean < 1e-3, "without: max {max}, mean {mean}");
}

/// A glossy GGX table rendered with nearest bins bands at the 2° × 10° bin edges; bilinear
/// interpolation in θ and φ of light and view follows the continuous BRDF much more closely.
/// Measured against the exact per-pixel render of the same BRDF: the relative RMS error, and
/// the banding itself as the mean jump of the error between neighbouring pixels.
#[test]
fn interpolation_reduces_banding() {
    let gpu = gpu();
    let brdf = Microfacet::isotropic(
        Distribution::Ggx,
        0.25,
        Fresnel::Schlick {
            f0: [0.9, 0.7, 0.5],
        },
    );
    let table = tabulate(&brdf);
    let (scene, object) = scene("sphere", 256, |_| {});
    let gbuffer = GBuffer::build(&scene, &object);
    let exact = render_brdf(&gbuffer, &brdf);
    let mut r = renderer(&gpu);
    r.set_table(&table).unwrap();
    r.set_object(&object).unwrap();
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.mode = PreviewMode::Table;
    let nearest = render(&gpu, &mut r, &frame, 256);
    frame.interpolate = true;
    let smooth = render(&gpu, &mut r, &frame, 256);

    let n = 256;
    // Lit pixels whose 4-neighbourhood is lit and clear of grazing angles.
    let usable = |x: usize, y: usize| {
        gbuffer
            .get(x, y)
            .is_some_and(|p| p.is_lit() && p.cos_light() > 0.1 && p.cos_view() > 0.1)
    };
    let luminance = |c: [f32; 3]| (c[0] + c[1] + c[2]) as f64 / 3.0;
    let error = |image: &RgbImage, x: usize, y: usize| {
        luminance(image.get(x, y)) - luminance(exact.get(x, y))
    };
    let measure = |image: &RgbImage| {
        let (mut sq, mut ref_sq, mut jumps, mut count) = (0.0, 0.0, 0.0, 0usize);
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                if !(usable(x, y) && usable(x + 1, y) && usable(x, y + 1)) {
                    continue;
                }
                let e = error(image, x, y);
                sq += e * e;
                ref_sq += luminance(exact.get(x, y)).powi(2);
                jumps += (error(image, x + 1, y) - e).abs() + (error(image, x, y + 1) - e).abs();
                count += 1;
            }
        }
        ((sq / ref_sq).sqrt(), jumps / (2 * count) as f64)
    };
    let (nearest_rms, nearest_jump) = measure(&nearest);
    let (smooth_rms, smooth_jump) = measure(&smooth);
    eprintln!(
        "relative RMS error: nearest {nearest_rms:.4}, interpolated {smooth_rms:.4}; \
         mean error jump: nearest {nearest_jump:.2e}, interpolated {smooth_jump:.2e}"
    );
    assert!(smooth_rms < 0.5 * nearest_rms);
    assert!(smooth_jump < 0.5 * nearest_jump);
}

/// Once the view has been drawn, new coefficients are evaluated only for the pairs it reads
/// (a list the scene pass marks): the picture is bit for bit the one an evaluation of every
/// pair gives. Turning the camera toward pairs that hold older values re-evaluates them, and
/// the table read back is always complete.
#[test]
fn new_coefficients_are_evaluated_only_where_the_view_reads() {
    let gpu = gpu();
    let basis = common::small_basis(8);
    let (scene, object) = scene("sphere", 160, |_| {});
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.mode = PreviewMode::Reconstruction;
    let mut turned = frame.clone();
    turned.camera.yaw_deg += 50.0;
    turned.camera.pitch_deg += 20.0;
    let (x0, x1) = (coefficients(&basis, 0), coefficients(&basis, 1));
    let everything = |x: &[[f64; 3]], frame: &PreviewFrame| {
        let mut r = renderer(&gpu);
        r.set_basis(&basis).unwrap();
        r.set_object(&object).unwrap();
        r.set_coefficients(x).unwrap();
        render(&gpu, &mut r, frame, 160).pixels
    };

    let mut r = renderer(&gpu);
    r.set_basis(&basis).unwrap();
    r.set_object(&object).unwrap();
    assert_eq!(r.view_pair_count().unwrap(), None);
    r.set_coefficients(&x0).unwrap();
    render(&gpu, &mut r, &frame, 160);
    let listed = r
        .view_pair_count()
        .unwrap()
        .expect("the frame listed its pairs");
    eprintln!("the view reads {listed} of {PAIRS} pairs");
    assert!(
        listed > 1000 && (listed as usize) < PAIRS / 10,
        "{listed} pairs"
    );

    r.set_coefficients(&x1).unwrap();
    assert_eq!(
        render(&gpu, &mut r, &frame, 160).pixels,
        everything(&x1, &frame)
    );
    assert_eq!(
        render(&gpu, &mut r, &turned, 160).pixels,
        everything(&x1, &turned),
        "pairs the first view did not read are brought up to date"
    );
    r.set_coefficients(&x0).unwrap();
    render(&gpu, &mut r, &turned, 160);
    let on_gpu = r.reconstruction_table(&gpu.device, &gpu.queue).unwrap();
    let engine = Reconstruction::new(basis.clone(), &x0).materialize();
    let (max, mean) = table_errors(&on_gpu, &engine);
    assert!(max < 3e-2 && mean < 1e-3, "max {max}, mean {mean}");
}

/// Sparse mode: observed bins show π ρ cos θ_l (ρ stored as f16), every other lit pixel the
/// neutral checker; forgetting a bin or clearing all brings the checker back.
#[test]
fn sparse_mode_shows_the_updated_bins() {
    // Large enough that bins span several pixels (at 128² every pixel is next to a bin edge).
    const SIDE: usize = 384;
    let gpu = gpu();
    let (scene, object) = scene("sphere", SIDE as u32, |_| {});
    let gbuffer = GBuffer::build(&scene, &object);
    let mut r = renderer(&gpu);
    r.set_object(&object).unwrap();
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.mode = PreviewMode::SparseOnly;

    let pair_of = |p: &SurfacePoint| Some(pair_index(p.light_bin?, p.view_bin?));
    // The pairs of four lit pixels spread over the lit part of the sphere, away from bin edges.
    let inside: Vec<(usize, usize)> = (0..SIDE * SIDE)
        .map(|i| (i % SIDE, i / SIDE))
        .filter(|&(x, y)| {
            gbuffer.get(x, y).is_some_and(|p| p.is_lit()) && !near_an_edge(&gbuffer, x, y, 1)
        })
        .collect();
    assert!(
        inside.len() > 100,
        "{} lit pixels inside bins",
        inside.len()
    );
    let mut chosen: Vec<((usize, usize), PairIndex)> = Vec::new();
    for quarter in 0..4 {
        let found = inside[(2 * quarter + 1) * inside.len() / 8];
        let pair = pair_of(gbuffer.get(found.0, found.1).unwrap()).unwrap();
        if chosen.iter().all(|&(_, p)| p != pair) {
            chosen.push((found, pair));
        }
    }
    assert_eq!(chosen.len(), 4);
    let value = |i: usize| [0.1 + 0.05 * i as f32, 0.2, 0.3 - 0.04 * i as f32];
    let changes: Vec<BinChange> = chosen
        .iter()
        .enumerate()
        .map(|(i, &(_, pair))| sparse_bin(pair, Some(value(i))))
        .collect();
    r.update_sparse(&changes).unwrap();
    let image = render(&gpu, &mut r, &frame, SIDE as u32);

    let mut observed = 0;
    for y in 0..SIDE {
        for x in 0..SIDE {
            let Some(p) = gbuffer.get(x, y) else {
                continue;
            };
            if near_an_edge(&gbuffer, x, y, 1) {
                continue;
            }
            let shown = image.get(x, y);
            if !p.is_lit() {
                assert_eq!(shown, SHADOW);
            } else if let Some(i) = chosen.iter().position(|&(_, c)| Some(c) == pair_of(p)) {
                let expected = value(i).map(|v| std::f32::consts::PI * v * p.cos_light());
                assert!(
                    (0..3).all(|c| (shown[c] - expected[c]).abs() <= 2e-3 * expected[c]),
                    "({x}, {y}): {shown:?} vs {expected:?}"
                );
                observed += 1;
            } else {
                assert!(UNOBSERVED.contains(&shown), "({x}, {y}): {shown:?}");
            }
        }
    }
    assert!(observed >= chosen.len(), "{observed} observed pixels");

    // Forget the first bin: its pixels go back to the checker; the others stay.
    r.update_sparse(&[sparse_bin(chosen[0].1, None)]).unwrap();
    let image = render(&gpu, &mut r, &frame, SIDE as u32);
    let at = |image: &RgbImage, (x, y): (usize, usize)| image.get(x, y);
    assert!(UNOBSERVED.contains(&at(&image, chosen[0].0)));
    for &(pixel, _) in &chosen[1..] {
        assert!(!UNOBSERVED.contains(&at(&image, pixel)));
    }
    r.clear_sparse();
    let image = render(&gpu, &mut r, &frame, SIDE as u32);
    for &(pixel, _) in &chosen {
        assert!(UNOBSERVED.contains(&at(&image, pixel)));
    }
}

/// The second light, the environment and the exposure add up as TABLE.md's π ρ cos θ_l says,
/// here with the guide's Lambertian material (ρ = 0.5 / π).
#[test]
fn extra_lights_and_exposure() {
    let gpu = gpu();
    let (scene, object) = scene("sphere", 96, |_| {});
    let gbuffer = GBuffer::build(&scene, &object);
    let mut r = renderer(&gpu);
    r.set_object(&object).unwrap();
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.mode = PreviewMode::GuideMaterial;
    let guide = render(&gpu, &mut r, &frame, 96);
    let guide_cpu = burnish::scene::guide_image(&gbuffer);
    assert!(compare(&guide, &guide_cpu, &gbuffer).within > 0.999);

    frame.exposure_stops = 1.0;
    let brighter = render(&gpu, &mut r, &frame, 96);
    for (a, b) in brighter.pixels.iter().zip(&guide.pixels).take(96 * 48) {
        if *b != frame.background {
            assert!((0..3).all(|c| (a[c] - 2.0 * b[c]).abs() <= 1e-6 * b[c].max(1.0)));
        }
    }

    // Main light off, a fill light and a uniform sky on: L = Σ (0.5 / π) · cos · irradiance,
    // the sky's through the directions the renderer samples it at.
    frame.exposure_stops = 0.0;
    frame.light.intensity = 0.0;
    let fill = DirectionalLight {
        elevation_deg: 20.0,
        azimuth_deg: -60.0,
        intensity: 0.7,
    };
    let sky = Environment::uniform_sky(0.4);
    r.set_environment(&sky);
    frame.second_light = Some(fill);
    frame.environment = Some(EnvironmentLight {
        intensity: 1.0,
        rotation_deg: 0.0,
    });
    let lit = render(&gpu, &mut r, &frame, 96);
    let samples = sky.samples(ENVIRONMENT_DIRECTIONS);
    let mut checked = 0;
    for y in 0..96 {
        for x in 0..96 {
            let Some(p) = gbuffer.get(x, y) else {
                continue;
            };
            let n = p.normal.as_dvec3();
            let mut expected = 0.5 * fill.intensity * n.dot(fill.direction()).max(0.0);
            for s in &samples {
                expected += 0.5 / std::f64::consts::PI * s.weight[0] * n.dot(s.direction).max(0.0);
            }
            // The main light adds nothing but leaves its shadow colour where it does not reach.
            if !p.is_lit() {
                expected += SHADOW[0] as f64;
            }
            let shown = lit.get(x, y)[0] as f64;
            assert!(
                (shown - expected).abs() <= 1e-3 * expected.max(0.05),
                "({x}, {y}): {shown} vs {expected}"
            );
            checked += 1;
        }
    }
    assert!(checked > 5000);
}

/// What the renderer refuses, and how it says so.
#[test]
fn errors_are_clear() {
    let gpu = gpu();
    let mut r = renderer(&gpu);
    let (scene, object) = scene("sphere", 32, |_| {});
    r.set_object(&object).unwrap();
    let mut frame = PreviewFrame::from_scene(&scene);

    // Modes without their data.
    frame.mode = PreviewMode::Reconstruction;
    let e = r.render_to_image(&gpu.device, &gpu.queue, &frame, 32, 32);
    assert!(matches!(e, Err(PreviewError::Missing(m)) if m.contains("basis")));
    frame.mode = PreviewMode::Table;
    let e = r.render_to_image(&gpu.device, &gpu.queue, &frame, 32, 32);
    assert!(matches!(e, Err(PreviewError::Missing(m)) if m.contains("table")));
    assert!(matches!(
        r.set_coefficients(&[[0.0; 3]]),
        Err(PreviewError::Missing(_))
    ));

    // Bad frames and sizes.
    frame.mode = PreviewMode::GuideMaterial;
    let e = r.render_to_image(&gpu.device, &gpu.queue, &frame, 0, 32);
    assert!(matches!(e, Err(PreviewError::Invalid(m)) if m.contains("out of range")));
    let mut bad = frame.clone();
    bad.camera.projection = Projection::Perspective;
    bad.camera.distance = 0.5;
    let e = r.render_to_image(&gpu.device, &gpu.queue, &bad, 32, 32);
    assert!(matches!(e, Err(PreviewError::Invalid(m)) if m.contains("distance")));
    let mut bad = frame.clone();
    bad.camera.yaw_deg = f64::NAN;
    assert!(
        r.render_to_image(&gpu.device, &gpu.queue, &bad, 32, 32)
            .is_err()
    );
    // The renderer still works after refusing.
    assert!(
        r.render_to_image(&gpu.device, &gpu.queue, &frame, 32, 32)
            .is_ok()
    );

    // An unphysical sparse bin: nothing of the batch is applied. (A pair index is in range
    // by construction.)
    let e = r.update_sparse(&[
        sparse_bin(PairIndex::from_index(0), Some([0.1; 3])),
        sparse_bin(PairIndex::from_index(5), Some([0.1, -1.0, 0.1])),
    ]);
    assert!(matches!(e, Err(PreviewError::Invalid(m)) if m.contains("≥ 0")));
    frame.mode = PreviewMode::SparseOnly;
    let image = r
        .render_to_image(&gpu.device, &gpu.queue, &frame, 32, 32)
        .unwrap();
    assert!(
        image
            .pixels
            .iter()
            .all(|p| *p == frame.background || *p == SHADOW || UNOBSERVED.contains(p))
    );

    // Unphysical tables.
    let mut table = SymTable::filled([0.1; 3]);
    table.set(3, 7, [0.1, f32::NAN, 0.1]);
    assert!(matches!(r.set_table(&table), Err(PreviewError::Invalid(_))));

    // Coefficients that do not fit the basis.
    let basis = common::small_basis(8);
    r.set_basis(&basis).unwrap();
    let e = r.set_coefficients(&[[0.0; 3]; 3]);
    assert!(matches!(e, Err(PreviewError::Invalid(m)) if m.contains("3 coefficient rows")));
    let mut x = vec![[0.0; 3]; 8];
    x[2][1] = f64::INFINITY;
    assert!(matches!(
        r.set_coefficients(&x),
        Err(PreviewError::Invalid(_))
    ));
}

/// A device whose storage bindings hold 20 MB cannot take the K = 8 basis (21 MB of f16
/// components); the renderer says so instead of failing inside wgpu.
#[test]
fn a_basis_too_large_for_the_device_is_refused() {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("the preview tests need a GPU adapter (Mesa lavapipe will do)");
    let limit = 20_000_000;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: wgpu::Limits {
            max_storage_buffer_binding_size: limit,
            ..Default::default()
        },
        ..Default::default()
    }))
    .expect("device");
    let mut r = PreviewRenderer::new(&device, &queue, wgpu::TextureFormat::Rgba8Unorm).unwrap();
    let basis = common::small_basis(8);
    let e = r.set_basis(&basis).unwrap_err();
    let message = e.to_string();
    eprintln!("{message}");
    assert!(
        matches!(e, PreviewError::TooLarge { bytes, limit: l, .. } if bytes == (PAIRS * 16) as u64 && l == limit)
    );
    assert!(message.contains("K = 8") && message.contains("20000000"));
    // Nothing was set: reconstruction mode still asks for a basis.
    let frame = PreviewFrame::default();
    assert!(matches!(
        r.render_to_image(&device, &queue, &frame, 8, 8),
        Err(PreviewError::Missing(_))
    ));
}

/// Painting changes only ρ: once a view is drawn, new coefficients re-run the evaluation of
/// the pairs it reads and the gather, never the geometry; an unchanged frame draws nothing;
/// the exposure re-gathers; turning the camera or the light, resizing or a new object sets
/// the geometry up again. And the cached frame is the frame: bit for bit what a fresh
/// renderer draws.
#[test]
fn painting_reruns_only_the_gather() {
    let gpu = gpu();
    let basis = common::small_basis(8);
    let (scene, object) = scene("assets/meshes/bowl.obj", 128, |s| s.shadows = true);
    let mut r = renderer(&gpu);
    r.set_basis(&basis).unwrap();
    r.set_object(&object).unwrap();
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.interpolate = true;
    r.set_coefficients(&coefficients(&basis, 0)).unwrap();
    render(&gpu, &mut r, &frame, 128);
    let first = r.pass_counts();
    assert_eq!((first.geometry, first.gathers), (1, 1));

    // Nothing changed: nothing is drawn, the picture stays.
    let again = render(&gpu, &mut r, &frame, 128);
    assert_eq!(r.pass_counts(), first);

    // A stroke's worth of new coefficients: evaluation and gather only.
    r.set_coefficients(&coefficients(&basis, 1)).unwrap();
    let painted = render(&gpu, &mut r, &frame, 128);
    let counts = r.pass_counts();
    assert_eq!(counts.geometry, first.geometry);
    assert_eq!(counts.evaluations, first.evaluations + 1);
    assert_eq!(counts.gathers, first.gathers + 1);
    assert_ne!(painted.pixels, again.pixels, "the new ρ shows");
    let fresh = {
        let mut fresh = renderer(&gpu);
        fresh.set_basis(&basis).unwrap();
        fresh.set_object(&object).unwrap();
        fresh.set_coefficients(&coefficients(&basis, 1)).unwrap();
        render(&gpu, &mut fresh, &frame, 128)
    };
    assert_eq!(painted.pixels, fresh.pixels);

    // Sparse bins re-gather; the exposure too; neither sets the geometry up again.
    r.update_sparse(&[sparse_bin(PairIndex::from_index(17), Some([0.1; 3]))])
        .unwrap();
    render(&gpu, &mut r, &frame, 128);
    frame.exposure_stops = 1.0;
    let brighter = render(&gpu, &mut r, &frame, 128);
    let counts = r.pass_counts();
    assert_eq!(counts.geometry, first.geometry);
    assert_eq!(counts.gathers, first.gathers + 3);
    for (a, b) in brighter.pixels.iter().zip(&painted.pixels) {
        if *b != frame.background {
            assert!((0..3).all(|c| (a[c] - 2.0 * b[c]).abs() <= 1e-6 * b[c].max(1.0)));
        }
    }

    // A draft (while a stroke is painted) shades one pixel per 2 × 2 block for the block, at
    // the bins nearest its directions (one table read where interpolation takes up to
    // sixteen): what the full frame without interpolation shows at that pixel. The full
    // frame after it is the full frame again, without new geometry.
    frame.exposure_stops = 0.0;
    let full = render(&gpu, &mut r, &frame, 128);
    let nearest = {
        let mut fresh = renderer(&gpu);
        fresh.set_basis(&basis).unwrap();
        fresh.set_object(&object).unwrap();
        fresh.set_coefficients(&coefficients(&basis, 1)).unwrap();
        fresh
            .update_sparse(&[sparse_bin(PairIndex::from_index(17), Some([0.1; 3]))])
            .unwrap();
        let mut frame = frame.clone();
        frame.interpolate = false;
        render(&gpu, &mut fresh, &frame, 128)
    };
    frame.draft = true;
    let draft = render(&gpu, &mut r, &frame, 128);
    let (mut blocks, mut other_bin) = (0, 0);
    for by in (0..128).step_by(2) {
        for bx in (0..128).step_by(2) {
            let block = [(bx, by), (bx + 1, by), (bx, by + 1), (bx + 1, by + 1)];
            let first = block
                .iter()
                .find(|&&(x, y)| full.get(x, y) != frame.background);
            let Some(&(fx, fy)) = first else {
                assert!(
                    block
                        .iter()
                        .all(|&(x, y)| draft.get(x, y) == frame.background)
                );
                continue;
            };
            blocks += 1;
            let shown = draft.get(fx, fy);
            // Where a direction lies on a bin boundary, rounding may pick the neighbour.
            other_bin += usize::from(shown != nearest.get(fx, fy));
            for &(x, y) in &block {
                let expected = if full.get(x, y) == frame.background {
                    frame.background
                } else {
                    shown
                };
                assert_eq!(draft.get(x, y), expected, "({x}, {y})");
            }
        }
    }
    eprintln!("draft: {other_bin} of {blocks} blocks at a neighbouring bin");
    assert!(
        other_bin * 100 <= blocks,
        "{other_bin} of {blocks} draft blocks are not the nearest bins' value"
    );
    assert_ne!(draft.pixels, full.pixels);
    frame.draft = false;
    assert_eq!(render(&gpu, &mut r, &frame, 128).pixels, full.pixels);
    assert_eq!(r.pass_counts().geometry, counts.geometry);

    // Camera, light, size and object each set the geometry up again.
    let mut geometry = counts.geometry;
    frame.camera.yaw_deg += 10.0;
    render(&gpu, &mut r, &frame, 128);
    frame.light.azimuth_deg += 10.0;
    render(&gpu, &mut r, &frame, 128);
    render(&gpu, &mut r, &frame, 96);
    r.set_object(&Object::builtin(burnish::scene::BuiltinShape::Sphere))
        .unwrap();
    render(&gpu, &mut r, &frame, 96);
    geometry += 4;
    assert_eq!(r.pass_counts().geometry, geometry);
}

/// The environment light goes through the table: each sampled direction, turned into the
/// pixel's shading frame, reads ρ(its nearest light bin, the view's nearest bin), and
/// contributes ρ · weight · cos θ. Checked pixel by pixel against the same sum on the CPU in
/// double precision (a few directions may fall on the other side of a bin edge in f32).
#[test]
fn the_environment_light_reads_the_table() {
    let gpu = gpu();
    let (scene, object) = scene("sphere", 128, |s| {
        s.light.elevation_deg = 40.0;
    });
    let gbuffer = GBuffer::build(&scene, &object);
    let table = scrambled_table();
    let mut r = renderer(&gpu);
    r.set_table(&table).unwrap();
    r.set_object(&object).unwrap();
    let studio = Environment::studio();
    let rotation: f64 = 30.0;
    let intensity = 0.5;
    let mut frame = PreviewFrame::from_scene(&scene);
    frame.mode = PreviewMode::Table;
    frame.light.intensity = 0.0;
    frame.environment = Some(EnvironmentLight {
        intensity,
        rotation_deg: rotation,
    });
    let image = render(&gpu, &mut r, &frame, 128);
    let (sin, cos) = rotation.to_radians().sin_cos();
    let samples: Vec<(DVec3, [f64; 3])> = studio
        .samples(ENVIRONMENT_DIRECTIONS)
        .iter()
        .map(|s| {
            let d = s.direction;
            (
                DVec3::new(d.x * cos + d.z * sin, d.y, d.z * cos - d.x * sin),
                s.weight.map(|w| w * intensity),
            )
        })
        .collect();
    // The CPU's sum at pixel (x, y) over the first `used` samples, each standing for
    // `share` of them.
    let cpu_sum = |x: usize, y: usize, used: usize, share: f64| -> Option<[f32; 3]> {
        let p = gbuffer.get(x, y)?;
        let view_bin = p.view_bin?;
        let (n, t, b) = (
            p.normal.as_dvec3(),
            p.tangent.as_dvec3(),
            p.bitangent().as_dvec3(),
        );
        let mut sum = [0.0f64; 3];
        for (d, w) in &samples[..used] {
            let l = DVec3::new(d.dot(t), d.dot(b), d.dot(n));
            if l.z > 0.0 {
                let rho = table.get(direction_index(l.normalize()).unwrap(), view_bin);
                for c in 0..3 {
                    sum[c] += rho[c] as f64 * w[c] * l.z * share;
                }
            }
        }
        let shadow = if p.is_lit() { [0.0; 3] } else { SHADOW };
        Some([0, 1, 2].map(|c| (shadow[c] as f64 + sum[c]) as f32))
    };
    let mut checked = 0;
    let mut close = 0;
    for y in 0..128 {
        for x in 0..128 {
            let Some(expected) = cpu_sum(x, y, samples.len(), 1.0) else {
                continue;
            };
            checked += 1;
            if within_2_percent(image.get(x, y), expected) {
                close += 1;
            }
        }
    }
    eprintln!("{close} of {checked} pixels within 2% of the CPU's sum");
    assert!(checked > 8000);
    assert!(
        close as f64 >= 0.97 * checked as f64,
        "{close} of {checked}"
    );

    // A draft (while a stroke is painted) reads the first quarter of the directions, each
    // for four, at the pixel that stands for its 2 × 2 block.
    frame.draft = true;
    let draft = render(&gpu, &mut r, &frame, 128);
    let (mut checked, mut close) = (0, 0);
    for by in (0..128).step_by(2) {
        for bx in (0..128).step_by(2) {
            let block = [(bx, by), (bx + 1, by), (bx, by + 1), (bx + 1, by + 1)];
            let Some(&(x, y)) = block
                .iter()
                .find(|&&(x, y)| image.get(x, y) != frame.background)
            else {
                continue;
            };
            let Some(expected) = cpu_sum(x, y, ENVIRONMENT_DIRECTIONS / 4, 4.0) else {
                continue;
            };
            checked += 1;
            if within_2_percent(draft.get(x, y), expected) {
                close += 1;
            }
        }
    }
    eprintln!("draft: {close} of {checked} blocks within 2% of the CPU's sum");
    assert!(checked > 2000);
    assert!(
        close as f64 >= 0.97 * checked as f64,
        "{close} of {checked}"
    );
    // The studio is far from uniform: its key light shows on the side it comes from.
    let key_side = image.get(100, 40);
    let far_side = image.get(28, 90);
    assert!(
        key_side[1] > 2.0 * far_side[1],
        "{key_side:?} vs {far_side:?}"
    );
}

/// A preview far larger than the device allows is refused with the sizes, not a wgpu panic.
#[test]
fn an_oversized_preview_is_refused() {
    let gpu = gpu();
    let mut r = renderer(&gpu);
    let frame = PreviewFrame {
        mode: PreviewMode::GuideMaterial,
        ..PreviewFrame::default()
    };
    let max = gpu.device.limits().max_texture_dimension_2d;
    let e = r
        .render_to_image(&gpu.device, &gpu.queue, &frame, max + 1, 8)
        .unwrap_err();
    assert!(
        matches!(e, PreviewError::Invalid(ref m) if m.contains("out of range")),
        "{e}"
    );
    assert!(
        r.render_to_image(&gpu.device, &gpu.queue, &frame, 16, 16)
            .is_ok()
    );
}

/// Reads an 8-bit RGBA texture back.
fn read_rgba8(gpu: &Gpu, texture: &wgpu::Texture) -> Vec<[u8; 4]> {
    let (w, h) = (texture.width(), texture.height());
    let padded = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (padded * h) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: None,
            },
        },
        texture.size(),
    );
    gpu.queue.submit([encoder.finish()]);
    buffer.map_async(wgpu::MapMode::Read, .., |r| r.expect("map"));
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    let bytes = buffer.get_mapped_range(..).expect("mapped").to_vec();
    bytes
        .chunks_exact(padded as usize)
        .flat_map(|row| {
            row[..(w * 4) as usize]
                .chunks_exact(4)
                .map(|p| [p[0], p[1], p[2], p[3]])
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Through egui: a paint callback in a real egui frame, rendered by egui-wgpu into an 8-bit
/// target, shows the preview where the callback's rectangle is, clamped and sRGB-encoded by the
/// preview (Rgba8Unorm) or by the hardware (Rgba8UnormSrgb), within one 8-bit step.
#[test]
fn egui_callback_paints_the_preview() {
    let gpu = gpu();
    let (scene, object) = scene("sphere", 64, |_| {});
    for format in [
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureFormat::Rgba8UnormSrgb,
    ] {
        let mut egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        install_in(
            &mut egui_renderer,
            &gpu.device,
            &gpu.queue,
            TargetLayout::plain(format),
        )
        .unwrap();
        let preview = egui_renderer
            .callback_resources
            .get_mut::<PreviewRenderer>()
            .unwrap();
        preview.set_object(&object).unwrap();
        let mut frame = PreviewFrame::from_scene(&scene);
        frame.mode = PreviewMode::GuideMaterial;
        // Bright enough that some pixels clamp.
        frame.exposure_stops = 2.0;
        let linear = preview
            .render_to_image(&gpu.device, &gpu.queue, &frame, 64, 64)
            .unwrap();

        // The callback covers points (16, 8) to (80, 72) of a 96 × 80 screen at 1 pixel/point.
        let rect = egui::Rect::from_min_size(egui::pos2(16.0, 8.0), egui::vec2(64.0, 64.0));
        let ctx = egui::Context::default();
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(96.0, 80.0),
            )),
            ..Default::default()
        };
        let mut output = ctx.run_ui(input, |ui| {
            ui.painter().add(paint_callback(rect, 1.0, frame.clone()));
        });
        let jobs = ctx.tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [96, 80],
            pixels_per_point: 1.0,
        };
        for (id, deltas) in output.textures_delta.set.drain() {
            for delta in &deltas {
                egui_renderer.update_texture(&gpu.device, &gpu.queue, id, delta);
            }
        }
        let target = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: 96,
                height: 80,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = target.create_view(&Default::default());
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let extra =
            egui_renderer.update_buffers(&gpu.device, &gpu.queue, &mut encoder, &jobs, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: None,
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        resolve_target: None,
                        depth_slice: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            egui_renderer.render(&mut pass, &jobs, &screen);
        }
        gpu.queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        let shown = read_rgba8(&gpu, &target);
        let preview = egui_renderer
            .callback_resources
            .get::<PreviewRenderer>()
            .unwrap();
        assert_eq!(preview.last_error(), None);

        let mut clamped = 0;
        for y in 0..64 {
            for x in 0..64 {
                let expected = linear.get(x, y).map(|c| (srgb_encode(c) * 255.0).round());
                let got = shown[(y + 8) * 96 + x + 16];
                for c in 0..3 {
                    assert!(
                        (got[c] as f32 - expected[c]).abs() <= 1.0,
                        "{format:?} ({x}, {y}): {got:?} vs {expected:?}"
                    );
                }
                clamped += usize::from(linear.get(x, y)[1] > 1.0);
            }
        }
        assert!(clamped > 0, "the exposure should clamp some pixels");
        // Outside the rectangle, egui's black clear.
        assert_eq!(shown[5 * 96 + 5], [0, 0, 0, 255]);
    }
}
