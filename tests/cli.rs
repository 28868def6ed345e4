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

/// Writes `contents` to `dir/name` and returns the path as a string.
fn write(dir: &Path, name: &str, contents: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path.to_str().unwrap().to_owned()
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

#[test]
fn nan_and_negative_paint_is_reported_and_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = write(d, "s.toml", b"resolution = 64\n");
    let mut painting = RgbImage {
        width: 64,
        height: 64,
        pixels: vec![[0.3, 0.2, 0.1]; 64 * 64],
    };
    for i in (0..64 * 64).step_by(7) {
        painting.pixels[i] = if i % 2 == 0 {
            [f32::NAN, 0.0, 0.0]
        } else {
            [-1.0, 0.5, 0.5]
        };
    }
    let exr = d.join("paint.exr");
    write_exr_rgb(&exr, &painting).unwrap();
    let table = d.join("t.exr");
    let view = format!("{scene}={}", exr.display());
    let mut args = vec!["reconstruct", "--view", &view, "--out", path_str(&table)];
    args.extend(SMALL_BASIS);
    let o = burnish(&args, &d.join("cache"));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("paint.exr") && stderr.contains("NaN, infinite or negative"),
        "{stderr}"
    );
    assert!(
        burnish::table::exr_file::read_table_exr(&table)
            .unwrap()
            .is_physical()
    );
}
