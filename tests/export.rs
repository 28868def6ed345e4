//! Export to the renderers people use, and materials read back: real files on disk, the
//! reader evaluating them as the reference loaders do, and the real Mitsuba 3.

use burnish::export::exact::{ExactTable, isotropic_average};
use burnish::export::{BsdfSettings, RglBsdf, rgl};
use burnish::materials::Brdf;
use burnish::materials::models::{
    Distribution, Fresnel, Lambert, Microfacet, Mixture, Retroreflective,
};
use burnish::materials::tabulate;
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// A coloured plastic: Lambert plus an isotropic GGX lobe of roughness `alpha`.
fn plastic(alpha: f64) -> Mixture {
    Mixture {
        parts: vec![
            (
                1.0,
                Box::new(Lambert {
                    albedo: [0.55, 0.25, 0.08],
                }),
            ),
            (
                1.0,
                Box::new(Microfacet::isotropic(
                    Distribution::Ggx,
                    alpha,
                    Fresnel::Schlick { f0: [0.04; 3] },
                )),
            ),
        ],
    }
}

fn random_direction(rng: &mut Pcg64) -> DVec3 {
    // Uniform over the hemisphere.
    let z: f64 = rng.random_range(0.0..1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Median and 90th percentile of the relative error of the .bsdf's ρ against the table's at
/// random direction pairs (luminance, both above the horizon, ρ not negligible).
fn round_trip_errors(bsdf: &RglBsdf, exact: &ExactTable, seed: u64) -> (f64, f64) {
    round_trip_errors_at(bsdf, exact, seed, random_direction)
}

/// As [`round_trip_errors`], at directions drawn by `direction`.
fn round_trip_errors_at(
    bsdf: &RglBsdf,
    exact: &ExactTable,
    seed: u64,
    direction: impl Fn(&mut Pcg64) -> DVec3,
) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let lum = |c: [f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let mut errors = Vec::new();
    while errors.len() < 4000 {
        let (l, v) = (direction(&mut rng), direction(&mut rng));
        if l.z < 0.02 || v.z < 0.02 {
            continue;
        }
        let want = lum(exact.eval(l, v));
        let got = lum(bsdf.eval(l, v));
        if want > 1e-4 {
            errors.push((got - want).abs() / want);
        }
    }
    errors.sort_by(f64::total_cmp);
    (errors[errors.len() / 2], errors[errors.len() * 9 / 10])
}

#[test]
fn bsdf_round_trip_of_an_isotropic_material() {
    let dir = tempfile::tempdir().unwrap();
    for alpha in [0.5, 0.2, 0.08] {
        let table = tabulate(&plastic(alpha));
        let path = dir.path().join("plastic.bsdf");
        let start = std::time::Instant::now();
        let report = rgl::write_bsdf(&path, &table, &BsdfSettings::default()).unwrap();
        let written = start.elapsed();
        let bsdf = RglBsdf::read(&path).unwrap();
        let exact = ExactTable::isotropic(&table, isotropic_average(&table));
        let (median, p90) = round_trip_errors(&bsdf, &exact, 1);
        eprintln!("alpha {alpha}: {report:?} in {written:?}: median {median:.4}, p90 {p90:.4}");
        assert!(report.isotropic);
        assert!(median <= 0.05, "median relative error {median}");
    }
}

/// A brushed metal: an anisotropic GGX lobe turned 30° about the normal.
fn brushed(alpha_x: f64, alpha_y: f64) -> Microfacet {
    Microfacet {
        distribution: Distribution::Ggx,
        alpha_x,
        alpha_y,
        rotation: 30f64.to_radians(),
        fresnel: Fresnel::Schlick {
            f0: [0.9, 0.6, 0.3],
        },
        tint: [1.0; 3],
    }
}

#[test]
fn bsdf_round_trip_of_an_anisotropic_material() {
    let dir = tempfile::tempdir().unwrap();
    let table = tabulate(&brushed(0.4, 0.15));
    let path = dir.path().join("brushed.bsdf");
    let report = rgl::write_bsdf(&path, &table, &BsdfSettings::default()).unwrap();
    assert!(!report.isotropic, "{report:?}");
    assert_eq!((report.phi_slices, report.theta_slices), (36, 45));
    let bsdf = RglBsdf::read(&path).unwrap();
    assert!(!bsdf.is_isotropic());
    let exact = ExactTable::anisotropic(&table);
    // Between bins the table is a step function (10° azimuth bins) that the file's slices
    // interpolate smoothly, so compare where both are defined alike: at bin centres.
    let bin_centre = |rng: &mut Pcg64| {
        let d = rng.random_range(0..burnish::table::DIRECTIONS);
        burnish::table::bin_centre(d as burnish::table::DirIndex)
    };
    let (median, p90) = round_trip_errors_at(&bsdf, &exact, 2, bin_centre);
    let (anywhere, _) = round_trip_errors(&bsdf, &exact, 2);
    eprintln!(
        "anisotropic: {report:?}: at bin centres median {median:.4}, p90 {p90:.4}; \
         at random directions median {anywhere:.4}"
    );
    assert!(median <= 0.05, "median relative error {median}");
}

#[test]
fn spectral_bsdf_holds_the_rgb_it_was_made_from() {
    let table = tabulate(&plastic(0.3));
    let settings = BsdfSettings {
        spectral: true,
        ..BsdfSettings::default()
    };
    let (file, report) = rgl::bsdf_tensor(&table, &settings);
    assert!(report.spectral);
    let wavelengths = file.field("wavelengths").unwrap().as_f32().unwrap();
    assert!(wavelengths.windows(2).all(|w| w[0] < w[1]));
    assert!(wavelengths[0] <= 360.0 && *wavelengths.last().unwrap() >= 830.0);
    let with_rgb = RglBsdf::from_tensor(&file).unwrap();
    // pbrt-v4 reads only the spectra: evaluate those alone (converted back under D65).
    let mut spectral_only = file.clone();
    spectral_only.fields.retain(|f| f.name != "rgb");
    let from_spectra = RglBsdf::from_tensor(&spectral_only).unwrap();
    let mut rng = Pcg64::seed_from_u64(3);
    let mut errors = Vec::new();
    while errors.len() < 2000 {
        let (l, v) = (random_direction(&mut rng), random_direction(&mut rng));
        if l.z < 0.05 || v.z < 0.05 {
            continue;
        }
        let (a, b) = (with_rgb.eval(l, v), from_spectra.eval(l, v));
        for c in 0..3 {
            if a[c] > 1e-3 {
                errors.push((b[c] - a[c]).abs() / a[c]);
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    eprintln!("spectral vs RGB: median {median:.4}");
    assert!(median <= 0.03, "median relative error {median}");
}

#[test]
fn damaged_bsdf_files_are_refused_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plastic.bsdf");
    rgl::write_bsdf(&path, &tabulate(&plastic(0.3)), &BsdfSettings::default()).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let truncated = dir.path().join("truncated.bsdf");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let e = RglBsdf::read(&truncated).unwrap_err().to_string();
    assert!(e.contains("truncated.bsdf"), "{e}");
    let not_tensor = dir.path().join("text.bsdf");
    std::fs::write(&not_tensor, b"not a tensor file at all").unwrap();
    let e = RglBsdf::read(&not_tensor).unwrap_err().to_string();
    assert!(e.contains("text.bsdf"), "{e}");
    // A tensor file without the fields a material needs.
    let (mut file, _) = rgl::bsdf_tensor(&tabulate(&plastic(0.3)), &BsdfSettings::default());
    file.fields.retain(|f| f.name != "vndf");
    let e = RglBsdf::from_tensor(&file).unwrap_err();
    assert!(e.contains("vndf"), "{e}");
    assert!(RglBsdf::read(&dir.path().join("missing.bsdf")).is_err());
}

// ---------------------------------------------------------------------------------------
// The real readers and the command line.

use burnish::image_io::read_exr_rgb;
use burnish::scene::{GBuffer, LightSettings, Object, Scene, srgb_encode};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn burnish(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The Python with Mitsuba 3: `$BURNISH_PYTHON`, or `python3`. `.ci/run` installs it; a
/// machine without it fails here with what to do, never skips.
fn mitsuba_python() -> String {
    let python = std::env::var("BURNISH_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = Command::new(&python)
        .args(["-c", "import mitsuba; print(mitsuba.__version__)"])
        .output();
    match probe {
        Ok(o) if o.status.success() => python,
        other => panic!(
            "this test renders with Mitsuba 3 and needs it: `pip install mitsuba==3.9.1` \
             (in a virtual environment whose python BURNISH_PYTHON names; .ci/run does this). \
             {python} said: {}",
            other.map_or_else(|e| e.to_string(), |o| text(&o.stderr))
        ),
    }
}

/// Renders the sphere with Mitsuba 3 (`variant`) and the .bsdf, into `out` (EXR).
fn mitsuba_render(
    python: &str,
    variant: &str,
    bsdf: &Path,
    out: &Path,
    resolution: u32,
    light: (f64, f64),
) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/render_sphere.py");
    let o = Command::new(python)
        .arg(&script)
        .args([variant, path_str(bsdf), path_str(out)])
        .args([resolution.to_string(), "64".into()])
        .args([light.0.to_string(), light.1.to_string()])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "mitsuba: {}{}",
        text(&o.stdout),
        text(&o.stderr)
    );
}

fn scene_file(dir: &Path, resolution: u32, light: (f64, f64)) -> PathBuf {
    let scene = Scene {
        resolution,
        shadows: false,
        light: LightSettings {
            elevation_deg: light.0,
            azimuth_deg: light.1,
        },
        ..Scene::default()
    };
    let path = dir.join(format!("sphere_{}_{}.toml", light.0, light.1));
    scene.save(&path).unwrap();
    path
}

/// PSNR of sRGB-encoded, clipped images over the lit sphere pixels whose 3 × 3 neighbourhood
/// is all lit sphere (Mitsuba antialiases the silhouette and the terminator, `burnish render`
/// samples pixel centres).
fn sphere_psnr(scene: &Scene, a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let gbuffer = GBuffer::build(scene, &Object::load(&scene.object_source()).unwrap());
    let n = gbuffer.resolution();
    let lit = |x: usize, y: usize| {
        gbuffer
            .get(x, y)
            .is_some_and(|p| p.is_lit() && p.cos_light() > 0.02)
    };
    let (mut sum, mut count) = (0.0f64, 0usize);
    for y in 1..n - 1 {
        for x in 1..n - 1 {
            if !(y - 1..=y + 1).all(|yy| (x - 1..=x + 1).all(|xx| lit(xx, yy))) {
                continue;
            }
            let i = y * n + x;
            for c in 0..3 {
                let e = |v: f32| srgb_encode(v.clamp(0.0, 1.0)) as f64;
                sum += (e(a[i][c]) - e(b[i][c])).powi(2);
                count += 1;
            }
        }
    }
    assert!(count > 1000);
    10.0 * (count as f64 / sum.max(1e-30)).log10()
}

/// Mitsuba 3 renders the exported `.bsdf` as `burnish render` renders the table: sphere,
/// three lights (one a grazing back light), ≥ 30 dB each. The lobe is moderately glossy
/// (α = 0.25): `burnish render` looks the table up at its nearest bins, so a sharper lobe at
/// grazing angles shows 2° steps that Mitsuba's continuous lookup smooths (α = 0.15 measured
/// 45.9 / 40.4 / 28.2 dB, the loss all at those steps).
#[test]
fn mitsuba_renders_the_exported_bsdf_like_burnish() {
    let python = mitsuba_python();
    let dir = tempfile::tempdir().unwrap();
    let table_path = dir.path().join("plastic.exr");
    burnish::table::exr_file::write_table_exr(&table_path, &tabulate(&plastic(0.25))).unwrap();
    let bsdf = dir.path().join("plastic.bsdf");
    let o = burnish(&[
        "convert",
        "--in",
        path_str(&table_path),
        "--out",
        path_str(&bsdf),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("isotropic RGB .bsdf"),
        "{}",
        text(&o.stdout)
    );
    let resolution = 128;
    for light in [(45.0, 30.0), (70.0, -60.0), (20.0, 120.0)] {
        let scene_path = scene_file(dir.path(), resolution, light);
        let ours = dir.path().join("burnish.exr");
        let o = burnish(&[
            "render",
            "--scene",
            path_str(&scene_path),
            "--brdf",
            path_str(&table_path),
            "--out",
            path_str(&ours),
        ]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let theirs = dir.path().join("mitsuba.exr");
        mitsuba_render(&python, "scalar_rgb", &bsdf, &theirs, resolution, light);
        let (a, b) = (read_exr_rgb(&ours).unwrap(), read_exr_rgb(&theirs).unwrap());
        assert_eq!(
            (b.width, b.height),
            (resolution as usize, resolution as usize)
        );
        let psnr = sphere_psnr(&Scene::load(&scene_path).unwrap(), &a.pixels, &b.pixels);
        eprintln!("light {light:?}: PSNR {psnr:.1} dB");
        if std::env::var_os("BURNISH_KEEP").is_some() {
            let keep = PathBuf::from(std::env::var_os("BURNISH_KEEP").unwrap());
            std::fs::create_dir_all(&keep).unwrap();
            std::fs::copy(
                &ours,
                keep.join(format!("burnish_{}_{}.exr", light.0, light.1)),
            )
            .unwrap();
            std::fs::copy(
                &theirs,
                keep.join(format!("mitsuba_{}_{}.exr", light.0, light.1)),
            )
            .unwrap();
        }
        assert!(psnr >= 30.0, "light {light:?}: {psnr:.1} dB");
    }

    // The spectral flavour (pbrt-v4's): Mitsuba's spectral variant renders it alike.
    let spectral = dir.path().join("plastic_spectral.bsdf");
    let o = burnish(&[
        "convert",
        "--in",
        path_str(&table_path),
        "--out",
        path_str(&spectral),
        "--spectral",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("spectral + RGB"),
        "{}",
        text(&o.stdout)
    );
    let light = (45.0, 30.0);
    let scene_path = scene_file(dir.path(), resolution, light);
    let ours = dir.path().join("burnish.exr");
    let o = burnish(&[
        "render",
        "--scene",
        path_str(&scene_path),
        "--brdf",
        path_str(&table_path),
        "--out",
        path_str(&ours),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let theirs = dir.path().join("mitsuba_spectral.exr");
    mitsuba_render(
        &python,
        "scalar_spectral",
        &spectral,
        &theirs,
        resolution,
        light,
    );
    let (a, b) = (read_exr_rgb(&ours).unwrap(), read_exr_rgb(&theirs).unwrap());
    let psnr = sphere_psnr(&Scene::load(&scene_path).unwrap(), &a.pixels, &b.pixels);
    eprintln!("spectral, light {light:?}: PSNR {psnr:.1} dB");
    assert!(psnr >= 30.0, "spectral: {psnr:.1} dB");
}

#[test]
fn convert_chooses_formats_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    let original = tabulate(&plastic(0.3));
    let exr = dir.path().join("plastic.exr");
    burnish::table::exr_file::write_table_exr(&exr, &original).unwrap();
    let convert = |from: &Path, to: &Path| {
        let o = burnish(&["convert", "--in", path_str(from), "--out", path_str(to)]);
        assert!(
            o.status.success(),
            "{} -> {}: {}",
            from.display(),
            to.display(),
            text(&o.stderr)
        );
        text(&o.stdout)
    };
    // EXR → MERL → EXR, EXR → .bsdf → EXR: each back near the original.
    let lum = |c: [f32; 3]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
    let median_error = |back: &burnish::table::SymTable| {
        let mut rng = Pcg64::seed_from_u64(4);
        let mut errors = Vec::new();
        while errors.len() < 4000 {
            let d = burnish::table::DIRECTIONS as u32;
            let (a, b) = (rng.random_range(0..d), rng.random_range(0..d));
            let want = lum(original.get(a as _, b as _));
            if want > 1e-3 {
                errors.push((lum(back.get(a as _, b as _)) - want).abs() / want);
            }
        }
        errors.sort_by(f64::total_cmp);
        errors[errors.len() / 2]
    };
    let merl = dir.path().join("plastic.binary");
    convert(&exr, &merl);
    let from_merl = dir.path().join("from_merl.exr");
    convert(&merl, &from_merl);
    let e = median_error(&burnish::table::exr_file::read_table_exr(&from_merl).unwrap());
    eprintln!("EXR → MERL → EXR: median {e:.4}");
    assert!(e <= 0.05, "{e}");

    let bsdf = dir.path().join("plastic.bsdf");
    let said = convert(&exr, &bsdf);
    assert!(said.contains("isotropic RGB .bsdf"), "{said}");
    let from_bsdf = dir.path().join("from_bsdf.exr");
    convert(&bsdf, &from_bsdf);
    let e = median_error(&burnish::table::exr_file::read_table_exr(&from_bsdf).unwrap());
    eprintln!("EXR → .bsdf → EXR: median {e:.4}");
    assert!(e <= 0.05, "{e}");

    // The analytic formats: the fit's error is printed, and the files parse.
    let mtlx = dir.path().join("plastic.mtlx");
    let said = convert(&exr, &mtlx);
    assert!(said.contains("dB PSNR"), "{said}");
    let xml = std::fs::read_to_string(&mtlx).unwrap();
    assert!(
        xml.contains("<materialx") && xml.contains("standard_surface"),
        "{xml}"
    );
    let gltf = dir.path().join("plastic.gltf");
    let said = convert(&exr, &gltf);
    assert!(said.contains("dB PSNR"), "{said}");
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&gltf).unwrap()).unwrap();
    assert_eq!(doc["asset"]["version"], "2.0");
    let core = &doc["materials"][0]["pbrMetallicRoughness"];
    let base = core["baseColorFactor"].as_array().unwrap();
    // The plastic's diffuse albedo is orange: red above green above blue.
    let c = |i: usize| base[i].as_f64().unwrap();
    assert!(c(0) > c(1) && c(1) > c(2), "{base:?}");
    // The fit trades lobes against each other (a coat for the specular, say); what it must
    // keep is what renders show.
    let psnr: f64 = said
        .split("sphere renders ")
        .nth(1)
        .and_then(|rest| rest.split(" dB").next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no PSNR in {said}"));
    assert!(psnr >= 35.0, "{said}");

    // Bad requests: an unknown extension, an analytic file as input, a missing file.
    let o = burnish(&["convert", "--in", path_str(&exr), "--out", "plastic.png"]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("plastic.png"),
        "{}",
        text(&o.stderr)
    );
    let o = burnish(&[
        "convert",
        "--in",
        path_str(&mtlx),
        "--out",
        path_str(&from_bsdf),
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("plastic.mtlx"),
        "{}",
        text(&o.stderr)
    );
    let missing = dir.path().join("missing.exr");
    let o = burnish(&[
        "convert",
        "--in",
        path_str(&missing),
        "--out",
        path_str(&bsdf),
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("missing.exr"),
        "{}",
        text(&o.stderr)
    );
}

/// `burnish reconstruct` with the given extra arguments, a small basis cached in `cache`.
fn reconstruct(view: &str, out: &Path, cache: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["reconstruct", "--view", view, "--out", path_str(out)];
    args.extend(["--materials", "24", "--components", "8"]);
    args.extend(extra);
    Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(&args)
        .env("BURNISH_CACHE_DIR", cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

#[test]
fn reconstruct_starts_from_a_material() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    // The starting material, as a .bsdf (read back through the reader) and as a table: a
    // plastic with a retro-reflective glow, which one light 52° from the camera paints
    // nowhere (every pixel sees θ_d = 26°, where the glow is 500 times below its peak), so
    // that only the start can keep it. (The plastic alone the fitted reference explains
    // exactly from that view, with or without a start.)
    let material = tabulate(&Mixture {
        parts: vec![
            (1.0, Box::new(plastic(0.3))),
            (
                1.0,
                Box::new(Retroreflective {
                    color: [0.3, 0.3, 0.3],
                    exponent: 12.0,
                }),
            ),
        ],
    });
    let table = d.join("start.exr");
    burnish::table::exr_file::write_table_exr(&table, &material).unwrap();
    let bsdf = d.join("start.bsdf");
    rgl::write_bsdf(&bsdf, &material, &BsdfSettings::default()).unwrap();
    // A painting of it under one light: a single view leaves most of the table unobserved.
    let scene = scene_file(d, 64, (45.0, 30.0));
    let painting = d.join("paint.exr");
    let o = burnish(&[
        "render",
        "--scene",
        path_str(&scene),
        "--brdf",
        path_str(&table),
        "--out",
        path_str(&painting),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let view = format!("{}={}", scene.display(), painting.display());

    let plain = d.join("plain.exr");
    let o = reconstruct(&view, &plain, &cache, &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let started = d.join("started.exr");
    let o = reconstruct(&view, &started, &cache, &["--start", path_str(&bsdf)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains("start: ") && stdout.contains("start.bsdf"),
        "{stdout}"
    );

    // Where the painting says nothing, the start keeps the material: closer to it overall.
    let read = |p: &Path| burnish::table::exr_file::read_table_exr(p).unwrap();
    let score = |p: &Path| burnish::metrics::evaluate(&material, &read(p));
    let (without, with) = (score(&plain), score(&started));
    eprintln!(
        "without a start: {:.1} dB, {:.1}%, log {:.3}; from the .bsdf: {:.1} dB, {:.1}%, log {:.3}",
        without.median_psnr_db,
        100.0 * without.relative_rmse,
        without.log_rmse,
        with.median_psnr_db,
        100.0 * with.relative_rmse,
        with.log_rmse
    );
    // Measured: relative RMSE 0.730 → 0.359, log RMSE 0.700 → 0.420. (The renders' median
    // PSNR is not the measure here: without a start the fitted reference holds the plastic
    // exactly, where the start's projection onto the basis is lossier, and most lights see
    // the glow only faintly.)
    assert!(with.relative_rmse < 0.7 * without.relative_rmse);
    assert!(with.log_rmse < 0.8 * without.log_rmse);

    // A starting material that cannot be read fails at once, naming the file.
    let o = reconstruct(
        &view,
        &started,
        &cache,
        &["--start", "nowhere/missing.binary"],
    );
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("missing.binary"),
        "{}",
        text(&o.stderr)
    );
}
