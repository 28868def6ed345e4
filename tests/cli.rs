//! The command line as a user runs it: the real binary, real files on disk.

use burnish::image_io::{RgbImage, write_exr_rgb};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXAMPLE_SCENE: &str = "assets/example/sphere.toml";
const EXAMPLE_PAINTING: &str = "assets/example/painting.png";
/// A small basis keeps the tests fast; every option still goes through the real cache.
const SMALL_BASIS: [&str; 4] = ["--materials", "24", "--components", "8"];

fn burnish(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(args)
        .env("BURNISH_CACHE_DIR", cache)
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

#[test]
fn the_example_reconstructs_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let out = |name: &str| -> PathBuf { dir.path().join("out").join(name) };

    let guide = out("guide.png");
    let o = burnish(
        &["guide", "--scene", EXAMPLE_SCENE, "--out", path_str(&guide)],
        &cache,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let image = image::open(&guide).unwrap();
    assert_eq!((image.width(), image.height()), (512, 512));

    let (table, merl) = (out("example.exr"), out("example.binary"));
    let view = format!("{EXAMPLE_SCENE}={EXAMPLE_PAINTING}");
    let mut args = vec![
        "reconstruct",
        "--view",
        &view,
        "--out",
        path_str(&table),
        "--merl",
        path_str(&merl),
    ];
    args.extend(SMALL_BASIS);
    let o = burnish(&args, &cache);
    let stdout = text(&o.stdout);
    assert!(o.status.success(), "{}\n{}", stdout, text(&o.stderr));
    for expected in [
        "samples used",
        "observed bins",
        "inconsistent",
        "condition number",
        "materialised",
    ] {
        assert!(
            stdout.contains(expected),
            "'{expected}' missing from:\n{stdout}"
        );
    }
    assert_eq!(
        std::fs::metadata(&merl).unwrap().len(),
        12 + 8 * 3 * 1_458_000
    );
    let read = burnish::table::exr_file::read_table_exr(&table).unwrap();
    assert!(read.is_physical());

    // A second run loads the basis from the cache.
    let o = burnish(&args, &cache);
    assert!(
        text(&o.stdout).contains("loaded from cache"),
        "{}",
        text(&o.stdout)
    );

    let render = out("render.exr");
    let o = burnish(
        &[
            "render",
            "--scene",
            EXAMPLE_SCENE,
            "--brdf",
            path_str(&table),
            "--out",
            path_str(&render),
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(burnish::image_io::read_exr_rgb(&render).unwrap().width, 512);

    let o = burnish(
        &[
            "eval",
            "--truth",
            path_str(&table),
            "--estimate",
            path_str(&table),
            "--json",
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&text(&o.stdout)).unwrap();
    assert_eq!(json["relative_rmse"].as_f64(), Some(0.0), "{json}");
    assert_eq!(json["median_psnr_db"].as_f64(), Some(100.0), "{json}");
    assert_eq!(json["psnr_db"].as_array().map(Vec::len), Some(8), "{json}");
}

/// `eval --by-angle` says where the error is: a glossy plastic scored against its diffuse
/// alone (the lobe left out) errs only below the truth, the cells add up to the relative RMSE
/// squared, and most of the error sits where the lobe peaks (θ_h under 10°).
#[test]
fn eval_by_angle_shows_where_the_error_is() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    // The plastic's own diffuse, without its lobe.
    let (truth, diffuse) = plastic_and_lambert(d, "diffuse", [0.05, 0.35, 0.08]);
    let args = [
        "eval",
        "--truth",
        path_str(&truth),
        "--estimate",
        path_str(&diffuse),
        "--by-angle",
    ];
    let o = burnish(&[&args[..], &["--json"]].concat(), &cache);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&text(&o.stdout)).unwrap();
    let grid = |key: &str| -> Vec<Vec<f64>> {
        json["by_angle"][key]
            .as_array()
            .unwrap()
            .iter()
            .map(|row| {
                row.as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect()
            })
            .collect()
    };
    let (error, truth_share, direction) = (grid("error"), grid("truth"), grid("direction"));
    let rows = json["by_angle"]["theta_h_edges_deg"]
        .as_array()
        .unwrap()
        .len()
        - 1;
    let columns = json["by_angle"]["theta_d_edges_deg"]
        .as_array()
        .unwrap()
        .len()
        - 1;
    assert_eq!((error.len(), error[0].len()), (rows, columns), "{json}");
    let total: f64 = error.iter().flatten().sum();
    let relative = json["relative_rmse"].as_f64().unwrap();
    assert!(
        (total - relative * relative).abs() < 1e-9 * relative * relative,
        "{total} against {relative}²"
    );
    assert!((truth_share.iter().flatten().sum::<f64>() - 1.0).abs() < 1e-9);
    assert!(
        direction.iter().flatten().all(|&d| d <= 0.0) && direction[0][0] == -1.0,
        "{direction:?}"
    );
    // θ_h edges 0, 2, 5, 10, …: the first three rows.
    let at_the_peak: f64 = error[..3].iter().flatten().sum();
    assert!(at_the_peak > 0.5 * total, "{error:?}");

    let o = burnish(&args, &cache);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("share of the squared relative error"), "{out}");
    let grid_rows: Vec<&str> = out
        .lines()
        .skip_while(|line| !line.contains("θ_h \\ θ_d"))
        .skip(1)
        .collect();
    assert_eq!(grid_rows.len(), rows, "{out}");
    assert!(grid_rows[0].trim_start().starts_with("0–2°"), "{out}");
    assert!(out.contains("75–90°"), "{out}");
    assert!(
        grid_rows.iter().all(|row| !row.contains('+')) && grid_rows[0].contains('−'),
        "{out}"
    );
}

/// Writes the hand-built Lambert + GGX plastic (a material the database never made) to
/// `dir/truth.exr` and a Lambertian table of `albedo` to `dir/{name}.exr`; returns both paths.
fn plastic_and_lambert(dir: &Path, name: &str, albedo: [f64; 3]) -> (PathBuf, PathBuf) {
    use burnish::materials::{models::Lambert, tabulate};
    use burnish::table::exr_file::write_table_exr;
    let material = burnish::bench::held_out::hand_built_materials(5)
        .into_iter()
        .find(|m| m.name == "hand-lambert-ggx")
        .unwrap();
    let (truth, lambert) = (dir.join("truth.exr"), dir.join(format!("{name}.exr")));
    write_table_exr(&truth, &tabulate(&*material.brdf)).unwrap();
    write_table_exr(&lambert, &tabulate(&Lambert { albedo })).unwrap();
    (truth, lambert)
}

/// Writes `contents` to `dir/name` and returns the path as a string.
fn write(dir: &Path, name: &str, contents: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path.to_str().unwrap().to_owned()
}

/// `render` against geometry worked out here from SCENE.md alone: a Lambertian table of albedo
/// a (ρ = a/π) on the unit sphere seen by the orthographic camera shows a · max(n·l, 0), with
/// n = (x, y, √(1 − x² − y²)) at image-plane point (x, y) and l from the light's angles.
#[test]
fn render_shows_a_lambertian_sphere_as_the_spec_says() {
    use burnish::materials::{models::Lambert, tabulate};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let albedo = [0.8, 0.5, 0.2];
    let table = d.join("lambert.exr");
    burnish::table::exr_file::write_table_exr(&table, &tabulate(&Lambert { albedo })).unwrap();
    let (elevation, azimuth) = (35f64, -50f64);
    let n = 128;
    let scene = write(
        d,
        "scene.toml",
        format!(
            "resolution = {n}\nshadows = false\n[light]\nelevation_deg = {elevation}\nazimuth_deg = {azimuth}\n"
        )
        .as_bytes(),
    );
    let render = d.join("render.exr");
    let o = burnish(
        &[
            "render",
            "--scene",
            &scene,
            "--brdf",
            path_str(&table),
            "--out",
            path_str(&render),
        ],
        &d.join("cache"),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let image = burnish::image_io::read_exr_rgb(&render).unwrap();
    let (el, az) = (elevation.to_radians(), azimuth.to_radians());
    let light = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
    let (mut checked, mut worst) = (0, 0f64);
    for row in 0..n {
        for col in 0..n {
            let x = -1.0 + (col as f64 + 0.5) * 2.0 / n as f64;
            let y = 1.0 - (row as f64 + 0.5) * 2.0 / n as f64;
            let r2 = x * x + y * y;
            // The rim's pixels straddle the silhouette; the tessellated sphere's normals there
            // are the least exact.
            if r2 > 0.95 * 0.95 {
                continue;
            }
            let normal = [x, y, (1.0 - r2).sqrt()];
            let cos = (0..3).map(|i| normal[i] * light[i]).sum::<f64>().max(0.0);
            let pixel = image.pixels[(row * n + col) as usize];
            for c in 0..3 {
                worst = worst.max((pixel[c] as f64 - albedo[c] * cos).abs());
            }
            checked += 1;
        }
    }
    assert!(checked > n * n / 2);
    assert!(
        worst < 0.02,
        "largest difference from a·max(n·l, 0): {worst}"
    );
}

/// The whole command line scored against a known truth: a material the database never made is
/// rendered by `render`, rebuilt by `reconstruct` from that painting, and scored by `eval`.
/// The reconstruction must land near what it measured when this test was written (0.8× to
/// 1.15×; a 15% regression fails) and well ahead of the guide's grey diffuse guess.
#[test]
fn a_reconstruction_from_a_render_scores_close_to_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    // The guide's grey diffuse guess.
    let (truth, grey) = plastic_and_lambert(d, "grey", [0.5, 0.5, 0.5]);
    let painting = d.join("painting.exr");
    let o = burnish(
        &[
            "render",
            "--scene",
            EXAMPLE_SCENE,
            "--brdf",
            path_str(&truth),
            "--out",
            path_str(&painting),
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let estimate = d.join("estimate.exr");
    let view = format!("{EXAMPLE_SCENE}={}", path_str(&painting));
    let mut args = vec!["reconstruct", "--view", &view, "--out", path_str(&estimate)];
    args.extend(SMALL_BASIS);
    let o = burnish(&args, &cache);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let score = |table: &Path| -> serde_json::Value {
        let o = burnish(
            &[
                "eval",
                "--truth",
                path_str(&truth),
                "--estimate",
                path_str(table),
                "--json",
            ],
            &cache,
        );
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_str(&text(&o.stdout)).unwrap()
    };
    let (ours, guess) = (score(&estimate), score(&grey));
    let rel = ours["relative_rmse"].as_f64().unwrap();
    let guess_rel = guess["relative_rmse"].as_f64().unwrap();
    println!("reconstruction {ours}\ngrey guess {guess}");
    // 0.0228 before the reference took one view's unseen specular weight toward 1.
    const MEASURED: f64 = 0.0136;
    assert!(
        (0.8 * MEASURED..=1.15 * MEASURED).contains(&rel),
        "relative RMSE {rel}, measured {MEASURED} when written"
    );
    assert!(
        rel < 0.5 * guess_rel,
        "{rel} against the grey guess {guess_rel}"
    );
    assert!(
        ours["median_psnr_db"].as_f64().unwrap() > guess["median_psnr_db"].as_f64().unwrap() + 6.0
    );

    // The default measures the paint from Lambert + GGX fitted to it; centred on the
    // database's mean instead, the fit's own family comes out further off.
    let database = d.join("database.exr");
    let mut args = vec![
        "reconstruct",
        "--view",
        &view,
        "--out",
        path_str(&database),
        "--prior-mean",
        "database",
    ];
    args.extend(SMALL_BASIS);
    let o = burnish(&args, &cache);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let database_rel = score(&database)["relative_rmse"].as_f64().unwrap();
    println!("on the database's mean: relative RMSE {database_rel}");
    assert!(rel < 0.95 * database_rel, "{rel} against {database_rel}");
    let fitted = d.join("fitted.exr");
    let mut args = vec!["reconstruct", "--view", &view, "--out", path_str(&fitted)];
    args.extend(["--prior-mean", "fitted:many"]);
    let o = burnish(&args, &cache);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("'many' is not a margin"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn bad_input_names_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    let out = d.join("out.png");
    let out = path_str(&out);
    let scene_with = |name: &str, body: &str| write(d, name, body.as_bytes());
    let good_scene = scene_with("good.toml", "resolution = 64\n");
    let png = std::fs::read(EXAMPLE_PAINTING).unwrap();

    let cases: Vec<(Vec<String>, Vec<&str>)> = vec![
        (
            vec![
                "guide".into(),
                "--scene".into(),
                d.join("nope.toml").display().to_string(),
                "--out".into(),
                out.into(),
            ],
            vec!["nope.toml"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                scene_with("unknown.toml", "colour = 1\n"),
                "--out".into(),
                out.into(),
            ],
            vec!["unknown.toml", "colour"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                scene_with("broken.toml", "object = \n"),
                "--out".into(),
                out.into(),
            ],
            vec!["broken.toml"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                scene_with("below.toml", "[light]\nelevation_deg = -10.0\n"),
                "--out".into(),
                out.into(),
            ],
            vec!["below.toml", "elevation"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                scene_with("zero.toml", "resolution = 0\n"),
                "--out".into(),
                out.into(),
            ],
            vec!["zero.toml", "resolution"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                scene_with("missing-obj.toml", "object = \"missing.obj\"\n"),
                "--out".into(),
                out.into(),
            ],
            vec!["missing.obj"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                {
                    write(d, "faceless.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n");
                    scene_with("faceless.toml", "object = \"faceless.obj\"\n")
                },
                "--out".into(),
                out.into(),
            ],
            vec!["faceless.obj"],
        ),
        (
            vec![
                "guide".into(),
                "--scene".into(),
                {
                    write(d, "range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
                    scene_with("range.toml", "object = \"range.obj\"\n")
                },
                "--out".into(),
                out.into(),
            ],
            vec!["range.obj"],
        ),
        (
            vec![
                "reconstruct".into(),
                "--view".into(),
                format!(
                    "{EXAMPLE_SCENE}={}",
                    write(d, "garbage.png", b"not a png at all")
                ),
                "--out".into(),
                d.join("t.exr").display().to_string(),
            ],
            vec!["garbage.png"],
        ),
        (
            vec![
                "reconstruct".into(),
                "--view".into(),
                format!("{EXAMPLE_SCENE}={}", write(d, "truncated.png", &png[..200])),
                "--out".into(),
                d.join("t.exr").display().to_string(),
            ],
            vec!["truncated.png"],
        ),
        (
            vec![
                "reconstruct".into(),
                "--view".into(),
                format!("{good_scene}={EXAMPLE_PAINTING}"),
                "--out".into(),
                d.join("t.exr").display().to_string(),
            ],
            vec!["painting.png", "512", "64"],
        ),
        (
            vec![
                "render".into(),
                "--scene".into(),
                good_scene.clone(),
                "--brdf".into(),
                d.join("none.exr").display().to_string(),
                "--out".into(),
                out.into(),
            ],
            vec!["none.exr"],
        ),
        (
            vec![
                "render".into(),
                "--scene".into(),
                good_scene.clone(),
                "--brdf".into(),
                write(d, "bad.exr", b"\x76\x2f\x31\x01garbage"),
                "--out".into(),
                out.into(),
            ],
            vec!["bad.exr"],
        ),
        (
            vec![
                "eval".into(),
                "--truth".into(),
                EXAMPLE_PAINTING.into(),
                "--estimate".into(),
                EXAMPLE_PAINTING.into(),
            ],
            vec!["painting.png"],
        ),
    ];
    for (args, expected) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = burnish(&args, &cache);
        let stderr = text(&o.stderr);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{args:?} should fail with exit code 1; stderr: {stderr}"
        );
        for e in expected {
            assert!(stderr.contains(e), "{args:?}: '{e}' missing from: {stderr}");
        }
        assert!(
            stderr.matches("(os error").count() <= 1,
            "{args:?}: the cause is said more than once: {stderr}"
        );
    }
    assert!(!Path::new(out).exists(), "no output from failed commands");

    // An output that can't be written: its folder is a file. Nothing is left behind.
    let blocker = write(d, "blocker", b"a file, not a folder");
    let target = format!("{blocker}/guide.png");
    let o = burnish(&["guide", "--scene", &good_scene, "--out", &target], &cache);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("blocker"), "{}", text(&o.stderr));
    assert_eq!(std::fs::read(&blocker).unwrap(), b"a file, not a folder");
}

/// Paint that is NaN, infinite or negative on the object refuses the painting, naming the
/// file, how many pixels and where the first is, as the app's import does; in the background
/// (which says nothing) it is ignored.
#[test]
fn nan_and_negative_paint_on_the_object_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = write(d, "s.toml", b"resolution = 64\n");
    let mut painting = RgbImage {
        width: 64,
        height: 64,
        pixels: vec![[0.3, 0.2, 0.1]; 64 * 64],
    };
    // The corners lie outside the default sphere.
    for i in [0, 63, 64 * 63, 64 * 64 - 1] {
        painting.pixels[i] = [f32::NAN, -1.0, f32::INFINITY];
    }
    let exr = d.join("paint.exr");
    write_exr_rgb(&exr, &painting).unwrap();
    let table = d.join("t.exr");
    let view = format!("{scene}={}", exr.display());
    let mut args = vec!["reconstruct", "--view", &view, "--out", path_str(&table)];
    args.extend(SMALL_BASIS);
    let o = burnish(&args, &d.join("cache"));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        burnish::table::exr_file::read_table_exr(&table)
            .unwrap()
            .is_physical()
    );
    std::fs::remove_file(&table).unwrap();

    // Two pixels on the object, the first at (20, 30).
    painting.pixels[30 * 64 + 20] = [f32::NAN, 0.0, 0.0];
    painting.pixels[32 * 64 + 32] = [-1.0, 0.5, 0.5];
    write_exr_rgb(&exr, &painting).unwrap();
    let o = burnish(&args, &d.join("cache"));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stdout));
    let stderr = text(&o.stderr);
    for expected in [
        "paint.exr",
        "2 pixels",
        "NaN, infinite or negative",
        "x = 20, y = 30",
    ] {
        assert!(
            stderr.contains(expected),
            "'{expected}' missing from: {stderr}"
        );
    }
    assert!(!table.exists(), "no table from a refused painting");
}

/// Runs the binary with a stdout whose reader has gone: the pipe's read end is closed before
/// the binary starts, so its first write to stdout always fails (`burnish … | head -1`).
fn burnish_with_closed_stdout(args: &[&str], cache: &Path) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(args)
        .env("BURNISH_CACHE_DIR", cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(writer)
        .output()
        .expect("the binary runs")
}

/// When stderr has gone too, an error still ends the verb with its own exit status (1),
/// not a panic's (101): `eprintln!` panicked there.
#[test]
fn a_closed_stderr_keeps_the_exit_status() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.exr");
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let status = Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args([
            "eval",
            "--truth",
            path_str(&missing),
            "--estimate",
            path_str(&missing),
        ])
        .env("BURNISH_CACHE_DIR", dir.path().join("cache"))
        .stderr(writer)
        .status()
        .expect("the binary runs");
    assert_eq!(status.code(), Some(1), "{status:?}");
}

/// When the reader of stdout has gone, a verb drops the rest of its output and goes on
/// (`println!` panicked there): `eval` ends quietly, and `reconstruct`, which reports each
/// view on stdout before it solves, still writes the table it was asked for.
#[test]
fn a_closed_stdout_drops_the_output_and_not_the_work() {
    use burnish::materials::{models::Lambert, tabulate};
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let lambert = dir.path().join("lambert.exr");
    let albedo = [0.5, 0.4, 0.3];
    burnish::table::exr_file::write_table_exr(&lambert, &tabulate(&Lambert { albedo })).unwrap();
    let o = burnish_with_closed_stdout(
        &[
            "eval",
            "--truth",
            path_str(&lambert),
            "--estimate",
            path_str(&lambert),
        ],
        &cache,
    );
    let stderr = text(&o.stderr);
    assert!(o.status.success(), "{:?}: {stderr}", o.status);
    assert!(stderr.is_empty(), "nothing on stderr, got: {stderr}");

    let table = dir.path().join("out").join("example.exr");
    let view = format!("{EXAMPLE_SCENE}={EXAMPLE_PAINTING}");
    let mut args = vec!["reconstruct", "--view", &view, "--out", path_str(&table)];
    args.extend(SMALL_BASIS);
    let o = burnish_with_closed_stdout(&args, &cache);
    assert!(o.status.success(), "{:?}: {}", o.status, text(&o.stderr));
    let written = burnish::table::exr_file::read_table_exr(&table).expect("the table is written");
    assert!(written.is_physical());
}
