//! Guide scenes end to end: scene files, objects, the geometry buffer, the guide, painted
//! samples and renders, against the conventions of SCENE.md and TABLE.md.

use burnish::image_io::{RgbImage, read_exr_rgb};
use burnish::materials::Brdf;
use burnish::scene::*;
use burnish::table::{DirIndex, SymTable, direction_index};
use glam::{DMat3, DVec3};
use std::f64::consts::{FRAC_1_PI, PI, TAU};
use std::path::{Path, PathBuf};

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/meshes")
}

fn scene(resolution: u32) -> Scene {
    Scene {
        resolution,
        ..Scene::default()
    }
}

fn sphere() -> Object {
    Object::builtin(BuiltinShape::Sphere)
}

/// The image-plane coordinates of a pixel centre of the orthographic camera, in [-1, 1].
fn plane(x: usize, y: usize, n: usize) -> (f64, f64) {
    let s = (x as f64 + 0.5) / n as f64 * 2.0 - 1.0;
    let t = 1.0 - (y as f64 + 0.5) / n as f64 * 2.0;
    (s, t)
}

fn assert_error_names(err: burnish::Error, path: &Path, words: &[&str]) {
    let text = err.to_string();
    assert!(text.contains(&*path.to_string_lossy()), "{text}");
    for word in words {
        assert!(text.contains(word), "{text} (wanted {word:?})");
    }
}

/// A UV sphere of unit radius with exact normals and single-vertex poles.
fn uv_sphere(rings: usize, segments: usize, radius: impl Fn(DVec3) -> f64) -> Mesh {
    let mut positions = vec![DVec3::Y * radius(DVec3::Y)];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            let u = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            positions.push(u * radius(u));
        }
    }
    positions.push(-DVec3::Y * radius(-DVec3::Y));
    let bottom = positions.len() as u32 - 1;
    let ring = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([bottom, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            triangles.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    let normals = positions.iter().map(|p| p.normalize()).collect();
    Mesh::new(positions, Some(normals), triangles).unwrap()
}

#[derive(Debug)]
struct Lambert([f64; 3]);
impl Brdf for Lambert {
    fn eval(&self, _: DVec3, _: DVec3) -> [f64; 3] {
        self.0.map(|a| a * FRAC_1_PI)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

// ---------------------------------------------------------------------------------------
// Scene files

#[test]
fn scene_file_resolves_obj_paths_and_saves_where_they_still_resolve() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("scenes/meshes")).unwrap();
    let obj = dir.path().join("scenes/meshes/ball.obj");
    uv_sphere(8, 16, |_| 1.0).write_obj(&obj, false).unwrap();
    let path = dir.path().join("scenes/ball.toml");
    std::fs::write(&path, "object = \"meshes/ball.obj\"\nresolution = 32\n").unwrap();

    let loaded = Scene::load(&path).unwrap();
    assert_eq!(
        loaded.object_source(),
        ObjectSource::Obj(dir.path().join("scenes/meshes/ball.obj"))
    );
    assert!(Object::load(&loaded.object_source()).is_ok());

    // Saved beside the original, the path stays relative; elsewhere it becomes absolute.
    let beside = dir.path().join("scenes/copy.toml");
    loaded.save(&beside).unwrap();
    assert!(
        std::fs::read_to_string(&beside)
            .unwrap()
            .contains("object = \"meshes/ball.obj\"")
    );
    let elsewhere = dir.path().join("other.toml");
    loaded.save(&elsewhere).unwrap();
    let moved = Scene::load(&elsewhere).unwrap();
    assert!(Path::new(&moved.object).is_absolute());
    assert!(Object::load(&moved.object_source()).is_ok());
    assert_eq!(
        Scene {
            object: loaded.object.clone(),
            base_dir: loaded.base_dir.clone(),
            ..moved
        },
        loaded
    );
}

#[test]
fn bad_scene_files_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    assert_error_names(Scene::load(&missing).unwrap_err(), &missing, &[]);
    let cases: &[(&str, &[&str])] = &[
        ("object = \"sphere\"\ncolour = 3\n", &["colour"]),
        (
            "[light]\nelevation_deg = 0\n",
            &["elevation_deg", "horizon"],
        ),
        (
            "[light]\nelevation_deg = -30\n",
            &["elevation_deg", "horizon"],
        ),
        ("resolution = 0\n", &["resolution"]),
        ("resolution = 100000\n", &["resolution"]),
        ("[camera]\nfov_deg = 180\n", &["fov_deg"]),
        ("[camera]\nfov_deg = -5\n", &["fov_deg"]),
        ("tangent_reference = [0, 0, 0]\n", &["tangent_reference"]),
        ("tangent_reference = [nan, 1, 0]\n", &["tangent_reference"]),
        ("resolution = \"big\"\n", &["resolution"]),
        ("object = \n", &[]),
    ];
    for (i, (text, words)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{i}.toml"));
        std::fs::write(&path, text).unwrap();
        assert_error_names(Scene::load(&path).unwrap_err(), &path, words);
    }
    // A scene naming a missing mesh loads; the mesh's own error names the resolved path.
    let path = dir.path().join("ghost.toml");
    std::fs::write(&path, "object = \"ghost.obj\"\n").unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_error_names(
        Object::load(&scene.object_source()).unwrap_err(),
        &dir.path().join("ghost.obj"),
        &[],
    );
}

// ---------------------------------------------------------------------------------------
// Objects

#[test]
fn bad_obj_files_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let three = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "corrupt.obj",
            "v 0 0 zero\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            &["OBJ"],
        ),
        ("faceless.obj", three, &["no faces"]),
        (
            "out_of_range.obj",
            &format!("{three}f 1 2 9\n"),
            &["out of bounds"],
        ),
        (
            "negative_index.obj",
            &format!("{three}f 1 2 -7\n"),
            &["out of bounds"],
        ),
        (
            "flat.obj",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
            &["zero area"],
        ),
        ("binary.obj", "\u{0}\u{1}garbage\u{2}", &[]),
    ];
    for (name, text, words) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        assert_error_names(Object::from_obj(&path).unwrap_err(), &path, words);
    }
    let missing = dir.path().join("missing.obj");
    assert_error_names(Object::from_obj(&missing).unwrap_err(), &missing, &[]);
}

#[test]
fn objects_are_centred_and_fit_the_unit_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("offset.obj");
    let mut mesh = uv_sphere(12, 24, |_| 1.0);
    for p in &mut mesh.positions {
        *p = *p * DVec3::new(3.0, 1.0, 2.0) + DVec3::new(10.0, -4.0, 7.0);
    }
    mesh.write_obj(&path, false).unwrap();
    let object = Object::from_obj(&path).unwrap();
    let mesh = object.mesh().unwrap();
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    assert!(
        ((lo + hi) * 0.5).length() < 1e-6,
        "bounding-box centre at the origin"
    );
    let radius = mesh
        .positions
        .iter()
        .map(|p| p.length())
        .fold(0.0, f64::max);
    assert!((radius - 1.0).abs() < 1e-9);
    for shape in BuiltinShape::ALL {
        let gbuffer = GBuffer::build(&scene(48), &Object::builtin(shape));
        let covered = gbuffer.covered_count();
        assert!(covered > 48 * 48 / 4, "{shape:?} covers {covered}");
        for p in gbuffer.pixels().iter().flatten() {
            assert!(p.position.length() <= 1.0 + 1e-5, "{shape:?}");
            assert!(p.normal.is_finite() && p.light.is_finite() && p.view.is_finite());
        }
    }
}

#[test]
fn obj_with_and_without_normals_give_nearly_the_same_gbuffer() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = uv_sphere(48, 96, |_| 1.0);
    let (with, without) = (dir.path().join("with.obj"), dir.path().join("without.obj"));
    mesh.write_obj(&with, true).unwrap();
    mesh.write_obj(&without, false).unwrap();
    let scene = scene(96);
    let a = GBuffer::build(&scene, &Object::from_obj(&with).unwrap());
    let b = GBuffer::build(&scene, &Object::from_obj(&without).unwrap());
    let (mut compared, mut same_bins, mut worst) = (0, 0, 0.0f32);
    for (pa, pb) in a.pixels().iter().zip(b.pixels()) {
        assert_eq!(pa.is_some(), pb.is_some(), "same geometry, same coverage");
        if let (Some(pa), Some(pb)) = (pa, pb) {
            compared += 1;
            worst = worst.max(pa.normal.angle_between(pb.normal));
            same_bins += usize::from(pa.light_bin == pb.light_bin && pa.view_bin == pb.view_bin);
        }
    }
    assert!(worst < 0.01, "largest normal difference {worst} rad");
    assert!(
        same_bins as f64 > 0.97 * compared as f64,
        "{same_bins} of {compared}"
    );
}

#[test]
fn shipped_meshes_are_small_concave_and_shadow_themselves() {
    for name in ["l-block.obj", "bowl.obj"] {
        let path = assets().join(name);
        assert!(std::fs::metadata(&path).unwrap().len() < 200_000, "{name}");
        let object = Object::from_obj(&path).unwrap();
        let gbuffer = GBuffer::build(&scene(128), &object);
        let facing_light = gbuffer
            .pixels()
            .iter()
            .flatten()
            .filter(|p| p.cos_light() > 0.2);
        let (facing, shadowed) =
            facing_light.fold((0, 0), |(f, s), p| (f + 1, s + usize::from(p.in_shadow)));
        assert!(
            shadowed * 100 > facing,
            "{name}: {shadowed} of {facing} lit-facing pixels in shadow"
        );
        // The guide shows those pixels as shadow.
        let guide = guide_image(&gbuffer);
        for (p, g) in gbuffer.pixels().iter().zip(&guide.pixels) {
            if p.is_some_and(|p| p.in_shadow) {
                assert_eq!(*g, SHADOW);
            }
        }
        let unshadowed = GBuffer::build(
            &Scene {
                shadows: false,
                ..scene(128)
            },
            &object,
        );
        assert!(unshadowed.pixels().iter().flatten().all(|p| !p.in_shadow));
    }
}

// ---------------------------------------------------------------------------------------
// Geometry buffer and guide

#[test]
fn head_on_sphere_guide_is_the_analytic_diffuse_shading() {
    // Light and camera both at the zenith (elevation 90, pitch 90): cos θ_l = n · y.
    let mut s = scene(128);
    s.light.elevation_deg = 90.0;
    s.camera.pitch_deg = 90.0;
    let gbuffer = GBuffer::build(&s, &sphere());
    let guide = guide_image(&gbuffer);
    let n = 128;
    let mut covered = 0;
    for y in 0..n {
        for x in 0..n {
            let (u, v) = plane(x, y, n);
            let r2 = u * u + v * v;
            let got = guide.get(x, y);
            if r2 < 1.0 {
                covered += 1;
                let want = 0.5 * (1.0 - r2).sqrt();
                for c in got {
                    // f32 storage of cos θ_l: within a few ulps.
                    assert!((c as f64 - want).abs() < 1e-6, "({x}, {y}): {c} vs {want}");
                }
            } else {
                assert_eq!(got, BACKGROUND, "({x}, {y})");
            }
        }
    }
    assert_eq!(covered, gbuffer.covered_count());
}

#[test]
fn sphere_guide_is_the_analytic_shading_for_the_default_light() {
    let n = 96;
    let gbuffer = GBuffer::build(&scene(n as u32), &sphere());
    let light = gbuffer.light_direction();
    let guide = guide_image(&gbuffer);
    for y in 0..n {
        for x in 0..n {
            let (u, v) = plane(x, y, n);
            let r2 = u * u + v * v;
            if r2 >= 1.0 {
                continue;
            }
            let normal = DVec3::new(u, v, (1.0 - r2).sqrt());
            let cos = normal.dot(light);
            let want = if cos > 0.0 {
                [0.5 * cos as f32; 3]
            } else {
                SHADOW
            };
            let got = guide.get(x, y);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-6,
                    "({x}, {y}): {got:?} vs {want:?}"
                );
            }
            // A convex object casts no shadow on itself.
            assert!(!gbuffer.get(x, y).unwrap().in_shadow);
        }
    }
}

#[test]
fn default_light_and_view_follow_scene_md() {
    let gbuffer = GBuffer::build(&scene(16), &sphere());
    let (el, az) = (45f64.to_radians(), 30f64.to_radians());
    let want = DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
    assert!((gbuffer.light_direction() - want).length() < 1e-15);
    assert_eq!(gbuffer.camera().toward_camera, DVec3::Z);
    // Every pixel's local directions are the world ones in (tangent, bitangent, normal).
    for p in gbuffer.pixels().iter().flatten() {
        let frame = DMat3::from_cols(
            p.tangent.as_dvec3(),
            p.bitangent().as_dvec3(),
            p.normal.as_dvec3(),
        );
        let light_world = frame * p.light.as_dvec3();
        let view_world = frame * p.view.as_dvec3();
        assert!((light_world - want).length() < 1e-6);
        assert!((view_world - DVec3::Z).length() < 1e-6);
    }
    // Image up is world up: the top rows see the upper half of the sphere.
    assert!(gbuffer.get(8, 1).unwrap().position.y > 0.5);
    assert!(gbuffer.get(14, 8).unwrap().position.x > 0.5);
}

#[test]
fn tangent_frames_are_right_handed_and_follow_the_reference() {
    let mut s = scene(64);
    s.tangent_reference = [0.2, 1.0, -0.3];
    let r = DVec3::from_array(s.tangent_reference).normalize();
    let gbuffer = GBuffer::build(&s, &Object::builtin(BuiltinShape::Blob));
    for p in gbuffer.pixels().iter().flatten() {
        let (n, t, b) = (
            p.normal.as_dvec3(),
            p.tangent.as_dvec3(),
            p.bitangent().as_dvec3(),
        );
        assert!((t.length() - 1.0).abs() < 1e-6 && t.dot(n).abs() < 1e-6);
        assert!((t.cross(b) - n).length() < 1e-5, "x × y = n");
        let projected = (r - r.dot(n) * n).normalize();
        assert!((t - projected).length() < 1e-5);
    }
}

#[test]
fn sphere_bins_are_those_of_the_table_md_frame() {
    // Independent reconstruction of every pixel's bins from the analytic sphere normal.
    let n = 64;
    let s = scene(n as u32);
    let gbuffer = GBuffer::build(&s, &sphere());
    let light = gbuffer.light_direction();
    let mut checked = 0;
    for y in 0..n {
        for x in 0..n {
            let Some(p) = gbuffer.get(x, y) else { continue };
            let (u, v) = plane(x, y, n);
            let normal = DVec3::new(u, v, (1.0 - u * u - v * v).sqrt());
            let tangent = (DVec3::X - normal.x * normal).normalize();
            let bitangent = normal.cross(tangent);
            let local = |w: DVec3| DVec3::new(w.dot(tangent), w.dot(bitangent), w.dot(normal));
            assert_eq!(p.light_bin, direction_index(local(light)), "({x}, {y})");
            assert_eq!(p.view_bin, direction_index(local(DVec3::Z)), "({x}, {y})");
            checked += 1;
        }
    }
    assert!(checked > 3000);
}

#[test]
fn perspective_camera_frames_the_sphere_and_views_from_the_eye() {
    let mut s = scene(64);
    s.camera.projection = Projection::Perspective;
    s.camera.fov_deg = 40.0;
    s.camera.yaw_deg = 30.0;
    let gbuffer = GBuffer::build(&s, &sphere());
    let eye = gbuffer.camera().eye;
    assert!((eye.length() - 1.0 / 20f64.to_radians().sin()).abs() < 1e-12);
    // The silhouette touches the image edges: the middle of each edge is covered or nearly.
    assert!(gbuffer.get(32, 1).is_some() && gbuffer.get(1, 32).is_some());
    assert!(gbuffer.get(0, 0).is_none());
    for p in gbuffer.pixels().iter().flatten() {
        let frame = DMat3::from_cols(
            p.tangent.as_dvec3(),
            p.bitangent().as_dvec3(),
            p.normal.as_dvec3(),
        );
        let view_world = frame * p.view.as_dvec3();
        let want = (eye - p.position.as_dvec3()).normalize();
        assert!((view_world - want).length() < 1e-5);
    }
}

#[test]
fn guide_png_is_srgb_and_background_is_distinct() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("guide.png");
    let gbuffer = GBuffer::build(&scene(32), &sphere());
    let guide = guide_image(&gbuffer);
    write_png(&path, &guide).unwrap();
    let back = read_png_linear(&path).unwrap();
    for (a, b) in guide.pixels.iter().zip(&back.pixels) {
        for c in 0..3 {
            // 8-bit sRGB quantisation: half a step, relative to the encoded value.
            assert!((srgb_encode(a[c]) - srgb_encode(b[c])).abs() <= 0.5 / 255.0 + 1e-6);
        }
    }
    assert_ne!(BACKGROUND, SHADOW);
    const { assert!(BACKGROUND[2] > BACKGROUND[0], "blue-grey") };
}

// ---------------------------------------------------------------------------------------
// Renders and samples

#[test]
fn lambertian_table_render_is_the_guide_scaled_by_albedo() {
    let albedo = [0.2f32, 0.5, 0.9];
    let table = SymTable::filled(albedo.map(|a| a / std::f32::consts::PI));
    let gbuffer = GBuffer::build(&scene(96), &Object::builtin(BuiltinShape::Blob));
    let render = render_table(&gbuffer, &table);
    let guide = guide_image(&gbuffer);
    let mut lit = 0;
    for ((p, r), g) in gbuffer
        .pixels()
        .iter()
        .zip(&render.pixels)
        .zip(&guide.pixels)
    {
        if p.is_some_and(|p| p.is_lit()) {
            lit += 1;
            for c in 0..3 {
                let want = g[c] / GUIDE_ALBEDO * albedo[c];
                assert!(
                    (r[c] - want).abs() <= 1e-6 * want.max(1e-3),
                    "{r:?} vs {want}"
                );
            }
        } else {
            assert_eq!(r, g, "shadow and background as in the guide");
        }
    }
    assert!(lit > 1000);
    // The analytic Lambertian gives the same image.
    let analytic = render_brdf(&gbuffer, &Lambert(albedo.map(f64::from)));
    for (a, b) in analytic.pixels.iter().zip(&render.pixels) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-6);
        }
    }
}

#[test]
fn distinct_table_render_uses_the_bins_the_gbuffer_names() {
    // ρ(lo, hi) = (lo + 1, hi + 1, 1): each pixel's ratios name the pair it was read from.
    let table = SymTable::from_fn(|lo, hi| [lo as f32 + 1.0, hi as f32 + 1.0, 1.0]);
    let mut s = scene(96);
    s.light.azimuth_deg = -70.0;
    s.light.elevation_deg = 25.0;
    s.camera.pitch_deg = 20.0;
    let gbuffer = GBuffer::build(&s, &Object::builtin(BuiltinShape::Torus));
    let render = render_table(&gbuffer, &table);
    let mut checked = 0;
    for (p, rgb) in gbuffer.pixels().iter().zip(&render.pixels) {
        let Some(p) = p.filter(|p| p.is_lit()) else {
            continue;
        };
        let (Some(d_l), Some(d_v)) = (p.light_bin, p.view_bin) else {
            continue;
        };
        let lo = (rgb[0] / rgb[2]).round() as DirIndex - 1;
        let hi = (rgb[1] / rgb[2]).round() as DirIndex - 1;
        assert_eq!((lo, hi), (d_l.min(d_v), d_l.max(d_v)));
        let want = std::f32::consts::PI * p.cos_light();
        assert!(
            (rgb[2] - want).abs() <= 1e-6 * want,
            "cos θ_l of the pixel's own direction"
        );
        checked += 1;
    }
    assert!(checked > 1000, "{checked}");
}

#[test]
fn a_perfect_painting_gives_back_the_table() {
    let table = SymTable::from_fn(|lo, hi| {
        let x = (lo as f32 * 0.37 + hi as f32 * 0.11).sin().abs();
        [0.05 + x, 0.3 * x, 0.8 - 0.5 * x]
    });
    let gbuffer = GBuffer::build(&scene(80), &Object::builtin(BuiltinShape::RoundedCube));
    let render = render_table(&gbuffer, &table);
    let set = samples_from_image(&gbuffer, &render);
    assert_eq!(set.counts.total(), 80 * 80);
    assert_eq!(set.counts.used, set.samples.len());
    assert_eq!(set.counts.invalid, 0);
    assert!(set.counts.used > 1500 && set.counts.background > 0 && set.counts.grazing > 0);
    for s in &set.samples {
        let want = table.get(s.light_bin, s.view_bin);
        for c in 0..3 {
            let w = want[c] as f64;
            assert!(
                (s.rho[c] - w).abs() <= 1e-6 * w.max(1e-3),
                "{:?} vs {want:?}",
                s.rho
            );
        }
        let p = gbuffer.at(s.pixel as usize).unwrap();
        assert!(p.cos_light() as f64 >= MIN_COS && p.cos_view() as f64 >= MIN_COS && p.is_lit());
        // The one-pixel path gives the same sample.
        assert_eq!(
            sample_pixel(&gbuffer, s.pixel as usize, render.pixels[s.pixel as usize]),
            Ok(*s)
        );
    }
}

#[test]
fn samples_skip_background_shadow_grazing_and_invalid_paint() {
    let n = 64;
    let gbuffer = GBuffer::build(
        &scene(n as u32),
        &Object::from_obj(assets().join("bowl.obj")).unwrap(),
    );
    let mut painting = RgbImage::filled(n, n, [0.25; 3]);
    let clean = samples_from_image(&gbuffer, &painting);
    assert!(clean.counts.shadow > 0 && clean.counts.background > 0 && clean.counts.grazing > 0);
    assert_eq!(clean.counts.invalid, 0);
    // Spoil some usable pixels and some background ones.
    let usable: Vec<u32> = clean.samples.iter().map(|s| s.pixel).take(5).collect();
    let bad = [f32::NAN, f32::INFINITY, -0.5, f32::NEG_INFINITY, f32::NAN];
    for (&i, &v) in usable.iter().zip(&bad) {
        painting.pixels[i as usize] = [0.25, v, 0.25];
    }
    let background = gbuffer.pixels().iter().position(Option::is_none).unwrap();
    painting.pixels[background] = [f32::NAN; 3];
    let spoilt = samples_from_image(&gbuffer, &painting);
    assert_eq!(spoilt.counts.invalid, 5);
    assert_eq!(spoilt.counts.used, clean.counts.used - 5);
    assert_eq!(spoilt.counts.background, clean.counts.background);
    assert_eq!(spoilt.counts.total(), n * n);
    assert!(
        spoilt
            .samples
            .iter()
            .all(|s| s.rho.iter().all(|c| c.is_finite() && *c >= 0.0))
    );
    assert!(spoilt.samples.iter().all(|s| !usable.contains(&s.pixel)));
    assert_eq!(
        sample_pixel(&gbuffer, usable[0] as usize, [f32::NAN; 3]),
        Err(SkipReason::Invalid)
    );
    assert_eq!(
        sample_pixel(&gbuffer, background, [0.5; 3]),
        Err(SkipReason::Background)
    );
    assert_eq!(
        sample_pixel(&gbuffer, n * n + 3, [0.5; 3]),
        Err(SkipReason::Background)
    );
}

#[test]
fn painted_files_round_trip_and_wrong_sizes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let gbuffer = GBuffer::build(&scene(48), &sphere());
    // ρ ≤ 0.3 keeps π · ρ · cos θ_l below 1, where PNG does not clip.
    let table = SymTable::from_fn(|lo, hi| {
        [
            0.02 + (lo % 7) as f32 * 0.04,
            0.1,
            0.05 + (hi % 5) as f32 * 0.06,
        ]
    });
    let render = render_table(&gbuffer, &table);
    // EXR is linear and exact.
    let exr = dir.path().join("painting.exr");
    write_image(&exr, &render).unwrap();
    assert_eq!(read_exr_rgb(&exr).unwrap(), render);
    let from_file = samples_from_file(&gbuffer, &exr).unwrap();
    assert_eq!(from_file, samples_from_image(&gbuffer, &render));
    // PNG is sRGB: decoded back to linear within 8-bit quantisation.
    let png = dir.path().join("painting.png");
    write_image(&png, &render).unwrap();
    let from_png = samples_from_file(&gbuffer, &png).unwrap();
    assert_eq!(from_png.counts, from_file.counts);
    for (a, b) in from_png.samples.iter().zip(&from_file.samples) {
        for c in 0..3 {
            assert!(
                (a.rho[c] - b.rho[c]).abs() <= 0.02 * b.rho[c] + 0.01,
                "{a:?} {b:?}"
            );
        }
    }
    // Wrong size.
    let small = dir.path().join("small.png");
    write_png(&small, &RgbImage::filled(32, 40, [0.5; 3])).unwrap();
    assert_error_names(
        samples_from_file(&gbuffer, &small).unwrap_err(),
        &small,
        &["32 × 40", "48 × 48"],
    );
    let missing = dir.path().join("missing.exr");
    assert_error_names(
        samples_from_file(&gbuffer, &missing).unwrap_err(),
        &missing,
        &[],
    );
}

// ---------------------------------------------------------------------------------------
// Example meshes (timings are in benches/scene.rs)

/// The shipped example meshes are exactly what their generators below make (compared byte
/// for byte), so they can be regenerated and reviewed. To regenerate them after changing a
/// generator, run `BURNISH_WRITE_EXAMPLE_MESHES=1 cargo test --test scene example_meshes`:
/// with the variable set to 1 the test writes assets/meshes first, then checks them.
#[test]
fn example_meshes_are_what_the_generators_make() {
    let meshes = [
        ("l-block.obj", l_block(), true),
        ("bowl.obj", bowl(), false),
    ];
    if std::env::var_os("BURNISH_WRITE_EXAMPLE_MESHES").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(assets()).unwrap();
        for (name, mesh, with_normals) in &meshes {
            mesh.write_obj(assets().join(name), *with_normals).unwrap();
        }
    }
    let dir = tempfile::tempdir().unwrap();
    for (name, mesh, with_normals) in &meshes {
        let fresh = dir.path().join(name);
        mesh.write_obj(&fresh, *with_normals).unwrap();
        let shipped = std::fs::read(assets().join(name)).unwrap();
        assert!(
            std::fs::read(&fresh).unwrap() == shipped,
            "assets/meshes/{name} differs from its generator"
        );
    }
}

/// An L-shaped block with flat faces (normals in the file, one per face), turned so that the
/// default camera sees its top faces and the inside corner where the arm shadows the base.
fn l_block() -> Mesh {
    let outline = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 2.0),
        (1.0, 2.0),
        (1.0, 1.0),
        (0.0, 1.0),
    ];
    let pose =
        DMat3::from_rotation_x(25f64.to_radians()) * DMat3::from_rotation_y(30f64.to_radians());
    let at = |x: f64, y: f64, z: f64| pose * DVec3::new(x - 1.0, y - 1.0, z);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let mut quad = |corners: [DVec3; 4], outward: DVec3| {
        let base = positions.len() as u32;
        positions.extend(corners);
        normals.extend([pose * outward; 4]);
        let face = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        if face.dot(pose * outward) > 0.0 {
            triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        } else {
            triangles.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
        }
    };
    // Front and back: the L as two rectangles.
    for (z, outward) in [(0.5, DVec3::Z), (-0.5, -DVec3::Z)] {
        quad(
            [
                at(0.0, 0.0, z),
                at(2.0, 0.0, z),
                at(2.0, 1.0, z),
                at(0.0, 1.0, z),
            ],
            outward,
        );
        quad(
            [
                at(1.0, 1.0, z),
                at(2.0, 1.0, z),
                at(2.0, 2.0, z),
                at(1.0, 2.0, z),
            ],
            outward,
        );
    }
    for i in 0..outline.len() {
        let (x0, y0) = outline[i];
        let (x1, y1) = outline[(i + 1) % outline.len()];
        // The outline runs counter-clockwise, so outward is the edge turned clockwise.
        let outward = DVec3::new(y1 - y0, x0 - x1, 0.0).normalize();
        quad(
            [
                at(x0, y0, 0.5),
                at(x0, y0, -0.5),
                at(x1, y1, -0.5),
                at(x1, y1, 0.5),
            ],
            outward,
        );
    }
    let mut mesh = Mesh::new(positions, Some(normals), triangles).unwrap();
    mesh.normalize();
    mesh
}

/// A thick hemispherical bowl with a rounded lip, opening tipped toward the camera; smooth,
/// written without normals so that loading it computes them.
fn bowl() -> Mesh {
    let (outer, inner, segments) = (1.0, 0.82, 48);
    let lip_centre = (outer + inner) / 2.0;
    let lip_radius = (outer - inner) / 2.0;
    // Profile (radius from the axis, height) from the outer pole to the inner pole.
    let mut profile = Vec::new();
    for i in 1..=16 {
        let a = i as f64 / 16.0 * PI / 2.0;
        profile.push((outer * a.sin(), -outer * a.cos()));
    }
    for i in 1..6 {
        let a = i as f64 / 6.0 * PI;
        profile.push((lip_centre + lip_radius * a.cos(), lip_radius * a.sin()));
    }
    for i in (1..=16).rev() {
        let a = i as f64 / 16.0 * PI / 2.0;
        profile.push((inner * a.sin(), -inner * a.cos()));
    }
    let pose = DMat3::from_rotation_x(40f64.to_radians());
    let mut positions = vec![pose * DVec3::new(0.0, -outer, 0.0)];
    for &(r, y) in &profile {
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            positions.push(pose * DVec3::new(r * phi.cos(), y, -r * phi.sin()));
        }
    }
    positions.push(pose * DVec3::new(0.0, -inner, 0.0));
    let last = positions.len() as u32 - 1;
    let ring = |i: usize, j: usize| (1 + i * segments + j % segments) as u32;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(0, j + 1), ring(0, j)]);
        triangles.push([
            last,
            ring(profile.len() - 1, j),
            ring(profile.len() - 1, j + 1),
        ]);
    }
    for i in 0..profile.len() - 1 {
        for j in 0..segments {
            triangles.push([ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)]);
            triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)]);
        }
    }
    let mut mesh = Mesh::new(positions, None, triangles).unwrap();
    mesh.normalize();
    mesh
}
