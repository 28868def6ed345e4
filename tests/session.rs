//! Session files, autosave and recovery, on real files in temporary folders.

use burnish::paint::{BrushKind, BrushSettings};
use burnish::scene::{Object, PaintRange, Projection, Scene};
use burnish::session::{
    AUTOSAVE_DELAY, AUTOSAVE_MIN_GAP, AUTOSAVE_RETRY, Autosaver, BasisSettings, FORMAT_VERSION,
    Session, SessionView, pending_recovery, pending_recovery_at, recovery_path,
};
use burnish::solver::{Policy, Regularization};
use std::cell::Cell;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[path = "support/read_only.rs"]
mod read_only;

/// A tetrahedron: the smallest closed mesh.
const TETRAHEDRON: &str = "v 0 0 1\nv 0.94 0 -0.33\nv -0.47 0.82 -0.33\nv -0.47 -0.82 -0.33\n\
                           f 1 3 2\nf 1 4 3\nf 1 2 4\nf 2 3 4\n";

/// Writes the tetrahedron to `dir/meshes/tetra.obj` and returns `dir`.
fn write_mesh(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::write(dir.join("meshes/tetra.obj"), TETRAHEDRON).unwrap();
    dir.to_path_buf()
}

/// Paints a pattern with HDR values, fractional coverage and a subnormal into `view`.
fn paint(view: &mut SessionView, seed: u32) {
    let n = view.paint.coverage.len();
    for i in (seed as usize % 7..n).step_by(5) {
        let x = (i as u32).wrapping_mul(2_654_435_761).wrapping_add(seed) as f32 / u32::MAX as f32;
        view.paint.colour.pixels[i] = [x * 40.0, 1.0 + x, 1e-40];
        view.paint.coverage[i] = if i % 3 == 0 { 1.0 } else { x };
    }
}

/// Two views: a painted sphere and a muted, painted OBJ view with a relative object path and
/// non-default scene settings; non-default brush and basis; the second view active.
fn two_view_session(mesh_dir: &Path) -> Session {
    let mut sphere = SessionView::new(
        "Front",
        Scene {
            resolution: 32,
            ..Scene::default()
        },
    )
    .unwrap();
    paint(&mut sphere, 1);
    let mut scene = Scene {
        object: "meshes/tetra.obj".into(),
        resolution: 24,
        shadows: false,
        tangent_reference: [0.0, 1.0, 0.5],
        base_dir: mesh_dir.to_path_buf(),
        ..Scene::default()
    };
    scene.light.elevation_deg = 70.5;
    scene.light.azimuth_deg = -12.25;
    scene.camera.projection = Projection::Perspective;
    scene.camera.fov_deg = 40.0;
    scene.camera.yaw_deg = 33.3;
    scene.camera.pitch_deg = -10.0;
    let mut mesh = SessionView::new("Tetra · side", scene).unwrap();
    mesh.settings.muted = true;
    // Imported from an 8-bit file: its clipped channels stay bounds after a reopen.
    mesh.settings.paint_range = PaintRange::Ldr;
    paint(&mut mesh, 2);
    Session {
        views: vec![sphere, mesh],
        active_view: 1,
        brush: BrushSettings {
            kind: BrushKind::Airbrush,
            size: 12.5,
            hardness: 0.3,
            opacity: 0.7,
            flow: 0.1,
            spacing: 0.05,
            colour: [3.5, 0.25, 0.1],
            pressure_size: false,
            pressure_flow: true,
        },
        basis: BasisSettings {
            components: 12,
            materials: 120,
            regularization: Regularization::Prior { alpha: 0.37 },
            policy: Policy::Max,
        },
        start: None,
    }
}

fn bits(session: &Session) -> Vec<(Vec<[u32; 3]>, Vec<u32>)> {
    session
        .views
        .iter()
        .map(|v| {
            (
                v.paint
                    .colour
                    .pixels
                    .iter()
                    .map(|p| p.map(f32::to_bits))
                    .collect(),
                v.paint.coverage.iter().map(|c| c.to_bits()).collect(),
            )
        })
        .collect()
}

fn entry_names(path: &Path) -> Vec<String> {
    let archive = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut names: Vec<String> = archive
        .file_names()
        .map(|name| name.expect("entry name").into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn save_then_open_reproduces_the_session_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    assert!(
        session.views[0]
            .paint
            .colour
            .pixels
            .iter()
            .any(|p| p[0] > 1.0)
    );
    let path = dir.path().join("work.burnish");
    session.save(&path).unwrap();

    assert_eq!(
        entry_names(&path),
        [
            "session.toml",
            "views/1/colour.exr",
            "views/1/coverage.exr",
            "views/1/scene.toml",
            "views/2/colour.exr",
            "views/2/coverage.exr",
            "views/2/object.obj",
            "views/2/scene.toml",
        ]
    );
    let cache = dir.path().join("cache");
    let opened = Session::open_with_object_cache(&path, &cache).unwrap();
    assert_eq!(opened, session);
    assert_eq!(bits(&opened), bits(&session));
    // The original object is still there and unchanged: it is used, nothing is extracted.
    assert_eq!(opened.views[1].settings.scene.object, "meshes/tetra.obj");
    assert!(!cache.exists());

    // Saving what was opened writes the same session again.
    let again = dir.path().join("again.burnish");
    opened.save(&again).unwrap();
    assert_eq!(
        Session::open_with_object_cache(&again, &cache).unwrap(),
        session
    );
}

#[test]
fn new_views_and_the_default_session_are_unpainted() {
    let session = Session::default();
    assert_eq!(session.views.len(), 1);
    assert_eq!(session.active_view, 0);
    assert_eq!(session.basis.components, 20);
    assert_eq!(session.basis.materials, 2000);
    assert_eq!(session.basis.regularization, Regularization::Auto);
    assert_eq!(session.basis.policy, Policy::Mean);
    let view = &session.views[0];
    assert_eq!(view.settings.scene, Scene::default());
    assert!(!view.settings.muted);
    assert_eq!(
        (view.paint.colour.width, view.paint.colour.height),
        (512, 512)
    );
    assert_eq!(view.paint.painted_count(), 0);
    // The layer is the guide: lit sphere pixels differ from the background corner.
    assert_ne!(view.paint.colour.get(256, 256), view.paint.colour.get(0, 0));
    session.check().unwrap();
}

/// A copy of the zip at `from` in `to` with `edit` applied to each entry's (name, bytes):
/// `None` drops the entry.
fn rewrite_zip(from: &Path, to: &Path, edit: impl Fn(&str, Vec<u8>) -> Option<Vec<u8>>) {
    let mut archive = zip::ZipArchive::new(std::fs::File::open(from).unwrap()).unwrap();
    let mut out = zip::ZipWriter::new(std::fs::File::create(to).unwrap());
    for i in 0..archive.len() {
        let mut file = archive.by_index(i).unwrap();
        let name = file.name().expect("entry name").into_owned();
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes).unwrap();
        if let Some(bytes) = edit(&name, bytes) {
            out.start_file(name.as_str(), zip::write::SimpleFileOptions::default())
                .unwrap();
            out.write_all(&bytes).unwrap();
        }
    }
    out.finish().unwrap();
}

fn rgb_exr(side: usize, pixel: impl Fn(usize) -> (f32, f32, f32) + Sync) -> Vec<u8> {
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| pixel(p.y() * side + p.x()));
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_channels((side, side), channels)
        .write()
        .to_buffered(&mut bytes)
        .unwrap();
    bytes.into_inner()
}

fn coverage_exr(side: usize, value: impl Fn(usize) -> f32 + Sync) -> Vec<u8> {
    use exr::prelude::*;
    let channels = SpecificChannels::build()
        .with_channel("Y")
        .with_pixel_fn(|p: Vec2<usize>| (value(p.y() * side + p.x()),));
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_channels((side, side), channels)
        .write()
        .to_buffered(&mut bytes)
        .unwrap();
    bytes.into_inner()
}

/// Opening `path` fails naming the file and each of `expected`, and leaves the folder as it was.
fn assert_refused(path: &Path, expected: &[&str]) {
    let dir = path.parent().unwrap();
    let listing = |d: &Path| {
        let mut names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    let before = (std::fs::read(path).unwrap(), listing(dir));
    let cache = dir.join("cache");
    let err = Session::open_with_object_cache(path, &cache)
        .unwrap_err()
        .to_string();
    assert!(err.contains(&*path.to_string_lossy()), "{err}");
    for needle in expected {
        assert!(err.contains(needle), "expected {needle:?} in: {err}");
    }
    assert_eq!(
        (std::fs::read(path).unwrap(), listing(dir)),
        before,
        "{err}"
    );
    assert!(!cache.exists());
}

#[test]
fn bad_files_are_refused_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let good = dir.path().join("good.burnish");
    session.save(&good).unwrap();
    let bad = |name: &str| dir.path().join(name);

    // Not a zip at all, and a file cut short (its central directory is at the end).
    std::fs::write(bad("text.burnish"), "resolution = 512\n").unwrap();
    assert_refused(&bad("text.burnish"), &["not a Burnish session file"]);
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(bad("cut.burnish"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    assert_refused(&bad("cut.burnish"), &["not a Burnish session file"]);

    // Damage inside an entry's compressed data: the CRC (or the inflater) catches it.
    let offset = {
        let mut archive = zip::ZipArchive::new(std::fs::File::open(&good).unwrap()).unwrap();
        let file = archive.by_name("views/1/colour.exr").unwrap();
        (file.data_start().unwrap() + file.compressed_size() / 2) as usize
    };
    let mut damaged = bytes.clone();
    for b in &mut damaged[offset..offset + 64] {
        *b ^= 0x5a;
    }
    std::fs::write(bad("damaged.burnish"), &damaged).unwrap();
    assert_refused(&bad("damaged.burnish"), &["views/1/colour.exr", "damaged"]);

    rewrite_zip(&good, &bad("missing.burnish"), |name, b| {
        (name != "views/2/coverage.exr").then_some(b)
    });
    assert_refused(
        &bad("missing.burnish"),
        &["views/2/coverage.exr", "missing"],
    );

    rewrite_zip(&good, &bad("no-object.burnish"), |name, b| {
        (name != "views/2/object.obj").then_some(b)
    });
    assert_refused(
        &bad("no-object.burnish"),
        &["views/2/object.obj", "missing"],
    );

    rewrite_zip(&good, &bad("small.burnish"), |name, b| {
        Some(if name == "views/1/colour.exr" {
            rgb_exr(16, |_| (0.5, 0.5, 0.5))
        } else {
            b
        })
    });
    assert_refused(
        &bad("small.burnish"),
        &["views/1/colour.exr", "16 × 16", "32"],
    );

    rewrite_zip(&good, &bad("nan.burnish"), |name, b| {
        Some(if name == "views/2/colour.exr" {
            rgb_exr(24, |i| {
                if i == 24 * 5 + 3 {
                    (0.1, f32::NAN, 0.2)
                } else {
                    (0.5, 0.5, 0.5)
                }
            })
        } else {
            b
        })
    });
    assert_refused(
        &bad("nan.burnish"),
        &["views/2/colour.exr", "(3, 5)", "finite"],
    );

    rewrite_zip(&good, &bad("coverage.burnish"), |name, b| {
        Some(if name == "views/1/coverage.exr" {
            coverage_exr(32, |i| if i == 40 { 1.5 } else { 0.0 })
        } else {
            b
        })
    });
    assert_refused(
        &bad("coverage.burnish"),
        &["views/1/coverage.exr", "[0, 1]"],
    );

    rewrite_zip(&good, &bad("scene.burnish"), |name, b| {
        Some(if name == "views/1/scene.toml" {
            b"resolution = 32\n[light]\nelevation_deg = -5.0\n".to_vec()
        } else {
            b
        })
    });
    assert_refused(
        &bad("scene.burnish"),
        &["views/1/scene.toml", "elevation_deg"],
    );

    rewrite_zip(&good, &bad("syntax.burnish"), |name, b| {
        Some(if name == "views/2/scene.toml" {
            b"resolution = [".to_vec()
        } else {
            b
        })
    });
    assert_refused(
        &bad("syntax.burnish"),
        &["views/2/scene.toml", "not a valid scene file"],
    );

    let edit_manifest = |from: &'static str, to: &'static str| {
        move |name: &str, b: Vec<u8>| {
            Some(if name == "session.toml" {
                let text = String::from_utf8(b).unwrap();
                assert!(text.contains(from), "{text}");
                text.replacen(from, to, 1).into_bytes()
            } else {
                b
            })
        }
    };
    rewrite_zip(
        &good,
        &bad("newer.burnish"),
        edit_manifest("format_version = 1", "format_version = 2"),
    );
    assert_eq!(FORMAT_VERSION, 1);
    assert_refused(&bad("newer.burnish"), &["session.toml", "newer"]);
    rewrite_zip(
        &good,
        &bad("active.burnish"),
        edit_manifest("active_view = 1", "active_view = 2"),
    );
    assert_refused(&bad("active.burnish"), &["session.toml", "active_view = 2"]);
    rewrite_zip(
        &good,
        &bad("policy.burnish"),
        edit_manifest("policy = \"max\"", "policy = \"median\""),
    );
    assert_refused(&bad("policy.burnish"), &["session.toml", "median"]);
    rewrite_zip(
        &good,
        &bad("brush.burnish"),
        edit_manifest("opacity = 0.7", "opacity = 7.0"),
    );
    assert_refused(&bad("brush.burnish"), &["session.toml", "opacity"]);
    rewrite_zip(
        &good,
        &bad("range.burnish"),
        edit_manifest("paint_range = \"ldr\"", "paint_range = \"12-bit\""),
    );
    assert_refused(
        &bad("range.burnish"),
        &["session.toml", "views[1].paint_range", "12-bit"],
    );

    // The good file still opens: the rewriting itself is sound.
    assert_eq!(
        Session::open_with_object_cache(&good, dir.path().join("c")).unwrap(),
        session
    );
}

#[test]
fn a_failed_save_leaves_the_old_file_intact() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_dir = write_mesh(&dir.path().join("m"));
    let session = two_view_session(&mesh_dir);
    let path = dir.path().join("work.burnish");
    session.save(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    let files = || std::fs::read_dir(dir.path()).unwrap().count();
    let count = files();

    // An invalid session (NaN paint, wrong layer size) is refused before anything is written.
    let mut nan = session.clone();
    nan.views[1].paint.colour.pixels[7][2] = f32::NAN;
    let err = nan.save(&path).unwrap_err().to_string();
    assert!(
        err.contains("work.burnish") && err.contains("finite"),
        "{err}"
    );
    let mut wrong = session.clone();
    wrong.views[0].paint.coverage.pop();
    let err = wrong.save(&path).unwrap_err().to_string();
    assert!(err.contains("coverage"), "{err}");

    // The object can't be embedded once it is gone.
    std::fs::rename(mesh_dir.join("meshes"), mesh_dir.join("gone")).unwrap();
    let err = session.save(&path).unwrap_err().to_string();
    assert!(err.contains("tetra.obj"), "{err}");
    std::fs::rename(mesh_dir.join("gone"), mesh_dir.join("meshes")).unwrap();

    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(files(), count, "no temporary file is left behind");

    // Over a folder, and into a folder that does not exist: the disk refuses.
    let folder = dir.path().join("folder.burnish");
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("inside"), b"x").unwrap();
    let err = session.save(&folder).unwrap_err().to_string();
    assert!(err.contains("folder.burnish"), "{err}");
    assert!(folder.is_dir() && folder.join("inside").exists());
    let err = session
        .save(dir.path().join("no/such/dir/x.burnish"))
        .unwrap_err();
    assert!(err.to_string().contains("x.burnish"), "{err}");
    assert_eq!(files(), count + 1);

    // A good save replaces the file.
    let mut changed = session.clone();
    changed.views[0].settings.name = "Renamed".into();
    changed.save(&path).unwrap();
    assert_eq!(Session::open(&path).unwrap(), changed);
}

#[test]
fn the_embedded_object_is_used_when_the_original_is_gone_or_changed() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_dir = write_mesh(&dir.path().join("machine-a"));
    let session = two_view_session(&mesh_dir);
    let path = dir.path().join("work.burnish");
    session.save(&path).unwrap();
    let cache = dir.path().join("cache");

    // The mesh changed on disk after the painting was made: the embedded copy wins.
    std::fs::write(mesh_dir.join("meshes/tetra.obj"), "v 0 0 0\n").unwrap();
    let changed = Session::open_with_object_cache(&path, &cache).unwrap();
    // The mesh is gone altogether (the session moved to another machine).
    std::fs::remove_dir_all(&mesh_dir).unwrap();
    let moved = Session::open_with_object_cache(&path, &cache).unwrap();

    for opened in [&changed, &moved] {
        let scene = &opened.views[1].settings.scene;
        let object = PathBuf::from(&scene.object);
        assert!(object.is_absolute() && object.starts_with(std::path::absolute(&cache).unwrap()));
        assert_eq!(object.file_name().unwrap(), "tetra.obj");
        assert_eq!(std::fs::read_to_string(&object).unwrap(), TETRAHEDRON);
        // Everything but the object's path is as saved, and the scene's object loads.
        let mut expected = session.clone();
        expected.views[1].settings.scene.object = scene.object.clone();
        assert_eq!(opened, &expected);
        Object::load(&scene.object_source()).unwrap();
    }
    assert_eq!(
        changed.views[1].settings.scene.object,
        moved.views[1].settings.scene.object
    );

    // The guide of the reopened view is the one the painting was made over.
    let reopened = SessionView::new("again", moved.views[1].settings.scene.clone()).unwrap();
    let unpainted = SessionView::new("first", {
        let mut scene = session.views[1].settings.scene.clone();
        scene.object = moved.views[1].settings.scene.object.clone();
        scene
    })
    .unwrap();
    assert_eq!(reopened.paint, unpainted.paint);
}

#[test]
fn autosave_writes_finished_edits_at_once_and_long_ones_within_the_delay() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let recovery = dir.path().join("data/recovery.burnish");
    let user_file = dir.path().join("mine.burnish");
    assert_eq!(pending_recovery_at(&recovery).unwrap(), None);

    let mut autosaver = Autosaver::new(&recovery);
    autosaver.set_session_path(Some(user_file.clone()));
    let snapshots = Cell::new(0);
    let snapshot = |name: &str| {
        let mut s = session.clone();
        s.views[0].settings.name = name.into();
        snapshots.set(snapshots.get() + 1);
        s
    };
    let t0 = Instant::now();
    let at = |secs: f64| t0 + Duration::from_secs_f64(secs);
    let saved_name = || {
        pending_recovery_at(&recovery)
            .unwrap()
            .expect("a recovery file")
            .open()
            .unwrap()
            .views[0]
            .settings
            .name
            .clone()
    };
    assert_eq!(AUTOSAVE_DELAY, Duration::from_secs(2));
    assert_eq!(AUTOSAVE_MIN_GAP, Duration::from_secs(1));

    // Nothing changed yet: nothing to write, and no reason to be woken.
    assert!(!autosaver.maybe_save(at(0.0), false, false, || snapshot("never")));
    assert_eq!(autosaver.wake_in(at(0.0)), None);

    // A long stroke: its changes wait at most the delay, counted from the first one.
    assert!(!autosaver.maybe_save(at(1.0), true, true, || snapshot("too soon")));
    assert_eq!(autosaver.wake_in(at(1.0)), Some(AUTOSAVE_DELAY));
    assert!(!autosaver.maybe_save(at(2.5), true, true, || snapshot("too soon")));
    assert_eq!(autosaver.wake_in(at(2.5)), Some(Duration::from_millis(500)));
    // Due even without a new change in this call (the pointer rests, the window idles).
    assert!(autosaver.maybe_save(at(3.0), false, true, || snapshot("mid-stroke")));
    autosaver.flush().unwrap();
    let info = pending_recovery_at(&recovery)
        .unwrap()
        .expect("a recovery file");
    assert_eq!(info.path, recovery);
    assert_eq!(info.views, 2);
    assert_eq!(info.session_path.as_deref(), Some(user_file.as_path()));
    assert!(info.modified.elapsed().unwrap() < Duration::from_secs(600));
    assert_eq!(saved_name(), "mid-stroke");

    // The stroke goes on, then ends: written at once, but not sooner than the least gap
    // after the previous write.
    assert!(!autosaver.maybe_save(at(3.2), true, true, || snapshot("too soon")));
    assert!(!autosaver.maybe_save(at(3.5), false, false, || snapshot("too soon")));
    assert_eq!(autosaver.wake_in(at(3.5)), Some(Duration::from_millis(500)));
    assert!(autosaver.maybe_save(at(4.0), false, false, || snapshot("stroke done")));
    autosaver.flush().unwrap();
    assert_eq!(saved_name(), "stroke done");

    // Nothing changed since: no write however long it waits, and no wake-up.
    assert!(!autosaver.maybe_save(at(500.0), false, false, || snapshot("never")));
    assert_eq!(autosaver.wake_in(at(500.0)), None);
    assert!(!autosaver.has_unwritten());
    // A finished edit long after: written at once.
    assert!(autosaver.maybe_save(at(501.0), true, false, || snapshot("later")));
    autosaver.flush().unwrap();
    assert_eq!(snapshots.get(), 3);
    let mut expected = session.clone();
    expected.views[0].settings.name = "later".into();
    assert_eq!(info.open().unwrap(), expected);

    autosaver.discard().unwrap();
    assert!(!recovery.exists());
    assert_eq!(pending_recovery_at(&recovery).unwrap(), None);
    // A change after a discard is written again, once the least gap has passed.
    assert!(!autosaver.maybe_save(at(501.5), true, false, || snapshot("too soon")));
    assert!(autosaver.maybe_save(at(502.0), false, false, || snapshot("after")));
    drop(autosaver);
    assert_eq!(saved_name(), "after");
}

#[test]
fn a_failed_autosave_is_reported_retried_and_its_changes_kept() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    // The recovery file's folder is taken by a file: every write fails.
    let blocker = dir.path().join("data");
    std::fs::write(&blocker, b"not a folder").unwrap();
    let mut autosaver = Autosaver::new(blocker.join("recovery.burnish"));
    let t0 = Instant::now();
    assert!(autosaver.maybe_save(t0, true, false, || session.clone()));
    let err = autosaver.flush().unwrap_err().to_string();
    assert!(err.contains("data"), "{err}");
    assert!(autosaver.is_failing());
    // The changes are still unwritten: tried again after the retry delay, without new edits.
    assert!(autosaver.has_unwritten());
    std::fs::remove_file(&blocker).unwrap();
    // Not at the least gap after the failed write, but after the retry delay.
    let wait = autosaver.wake_in(t0).expect("a retry is scheduled");
    assert!(wait > AUTOSAVE_MIN_GAP, "{wait:?}");
    assert!(
        !autosaver.maybe_save(t0 + Duration::from_secs(1), false, false, || session
            .clone())
    );
    let later = Instant::now() + AUTOSAVE_RETRY;
    assert!(autosaver.maybe_save(later, false, false, || session.clone()));
    autosaver.flush().unwrap();
    assert!(!autosaver.is_failing());
    let info = pending_recovery_at(autosaver.path()).unwrap().unwrap();
    assert_eq!(info.open().unwrap(), session);
}

#[test]
fn a_full_disk_fails_the_autosave_and_keeps_the_previous_recovery_file() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let recovery = dir.path().join("data/recovery.burnish");
    let mut autosaver = Autosaver::new(&recovery);
    let t0 = Instant::now();
    assert!(autosaver.maybe_save(t0, true, false, || session.clone()));
    autosaver.flush().unwrap();
    let before = std::fs::read(&recovery).unwrap();

    let full = burnish::fs_atomic::simulate_full_disk(&dir.path().join("data"), 1000);
    let mut changed = session.clone();
    changed.views[0].paint.coverage[3] = 0.5;
    let later = Instant::now() + AUTOSAVE_MIN_GAP;
    assert!(autosaver.maybe_save(later, true, false, || changed.clone()));
    let err = autosaver.flush().unwrap_err().to_string();
    assert!(
        err.contains("recovery.burnish") && err.contains("No space left"),
        "{err}"
    );
    assert_eq!(std::fs::read(&recovery).unwrap(), before);
    assert_eq!(
        std::fs::read_dir(dir.path().join("data")).unwrap().count(),
        1,
        "no temporary file is left behind"
    );
    drop(full);
    let retry = Instant::now() + AUTOSAVE_RETRY;
    assert!(autosaver.maybe_save(retry, false, false, || changed.clone()));
    autosaver.flush().unwrap();
    let info = pending_recovery_at(&recovery).unwrap().unwrap();
    assert_eq!(info.open().unwrap(), changed);
}

#[test]
fn an_autosave_wakes_its_caller_when_it_ends() {
    let dir = tempfile::tempdir().unwrap();
    let mut autosaver = Autosaver::new(dir.path().join("recovery.burnish"));
    let (woken, wakes) = std::sync::mpsc::channel();
    autosaver.set_waker(move || {
        let _ = woken.send(());
    });
    let now = Instant::now();
    assert!(autosaver.maybe_save(now, true, false, Session::default));
    // While it writes, the waker will call: no polling.
    if autosaver.is_writing() {
        assert_eq!(autosaver.wake_in(now), None);
    }
    wakes
        .recv_timeout(Duration::from_secs(60))
        .expect("the writer wakes the caller");
    autosaver.flush().unwrap();
    assert!(dir.path().join("recovery.burnish").exists());
}

#[test]
fn an_unreadable_recovery_file_is_reported_and_kept_aside() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let recovery = dir.path().join("recovery.burnish");
    let aside = dir.path().join("recovery-unreadable.burnish");

    // Truncated, as a disk that lost the end of it would leave it.
    let good = dir.path().join("good.burnish");
    session.save(&good).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(&recovery, &bytes[..bytes.len() / 2]).unwrap();
    let err = pending_recovery_at(&recovery).unwrap_err().to_string();
    assert!(
        err.contains("recovery.burnish") && err.contains("not a Burnish session file"),
        "{err}"
    );
    assert!(err.contains("recovery-unreadable.burnish"), "{err}");
    assert!(!recovery.exists());
    assert_eq!(std::fs::read(&aside).unwrap(), &bytes[..bytes.len() / 2]);
    assert_eq!(pending_recovery_at(&recovery).unwrap(), None);

    // From a newer Burnish: refused with a message that says so.
    rewrite_zip(&good, &recovery, |name, b| {
        Some(if name == "session.toml" {
            String::from_utf8(b)
                .unwrap()
                .replacen("format_version = 1", "format_version = 7", 1)
                .into_bytes()
        } else {
            b
        })
    });
    let err = pending_recovery_at(&recovery).unwrap_err().to_string();
    assert!(err.contains("made by a newer Burnish"), "{err}");
}

#[test]
fn the_recovery_file_lives_in_burnish_data_dir() {
    let dir = tempfile::tempdir().unwrap();
    // SAFETY: no other test in this binary reads or writes BURNISH_DATA_DIR, and Rust's own
    // environment accesses are serialised.
    unsafe { std::env::set_var("BURNISH_DATA_DIR", dir.path()) };
    let expected = dir.path().join("recovery.burnish");
    assert_eq!(recovery_path(), Some(expected.clone()));
    assert_eq!(pending_recovery().unwrap(), None);

    let mut autosaver = Autosaver::at_default_location().unwrap();
    assert_eq!(autosaver.path(), expected);
    let session = Session::default();
    assert!(autosaver.maybe_save(Instant::now(), true, false, || session.clone()));
    autosaver.flush().unwrap();
    let info = pending_recovery()
        .unwrap()
        .expect("the crash left a recovery file");
    assert_eq!(
        (info.path.clone(), info.views, info.session_path.clone()),
        (expected.clone(), 1, None)
    );
    assert_eq!(info.open().unwrap(), session);
    autosaver.discard().unwrap();
    assert_eq!(pending_recovery().unwrap(), None);
    assert!(!expected.exists());
}

#[test]
fn a_read_only_folder_refuses_the_save_and_keeps_the_old_file() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let folder = dir.path().join("locked");
    std::fs::create_dir(&folder).unwrap();
    let path = folder.join("work.burnish");
    session.save(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    let mut changed = session.clone();
    changed.views[0].settings.name = "Changed".into();

    let (save, autosave) = read_only::with_read_only_dir(&folder, || {
        let save = changed.save(&path).unwrap_err().to_string();
        let mut autosaver = Autosaver::new(folder.join("recovery.burnish"));
        assert!(autosaver.maybe_save(Instant::now(), true, false, || changed.clone()));
        (save, autosaver.flush().unwrap_err().to_string())
    });
    assert!(
        save.contains("work.burnish") && save.contains("Permission denied"),
        "{save}"
    );
    assert!(
        autosave.contains("recovery.burnish") && autosave.contains("Permission denied"),
        "{autosave}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 1);
    // Writable again: the same save goes through.
    changed.save(&path).unwrap();
    assert_eq!(Session::open(&path).unwrap(), changed);
}

#[test]
fn a_session_is_read_from_bytes_as_from_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let session = two_view_session(&write_mesh(dir.path()));
    let path = dir.path().join("s.burnish");
    session.save(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let cache = dir.path().join("cache");
    assert_eq!(Session::from_bytes(&bytes, &path, &cache).unwrap(), session);
    let err = Session::from_bytes(&bytes[..100], &path, &cache)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("s.burnish") && err.contains("not a Burnish session"),
        "{err}"
    );
}
