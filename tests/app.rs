//! The real app, driven by egui_kittest on the real wgpu renderer (Mesa's lavapipe in CI):
//! strokes made with pointer events reach the sparse table, the solver and the preview;
//! undo restores paint bit for bit; views add samples; sessions round-trip.
//! No adapter is a failure here, never a skip.

mod common;

use burnish::app::{Action, AppConfig, BurnishApp, PreviewTab, UiCommand};
use burnish::inspect::LobeScale;
use burnish::paint::UnpaintedPixels;
use burnish::preview::{EnvironmentLight, PreviewObject};
use burnish::scene::Scene;
use egui::{Event, Key, KeyboardShortcut, Modifiers, PointerButton, Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::path::PathBuf;
use std::time::Duration;

const WINDOW: Vec2 = Vec2::new(1400.0, 860.0);

fn config() -> AppConfig {
    AppConfig {
        basis: Some(common::small_basis(8)),
        brushes_dir: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("brushes"),
        autosave: false,
        scene: Scene {
            resolution: 256,
            ..Scene::default()
        },
        ..AppConfig::default()
    }
}

fn open_app(config: AppConfig) -> Harness<'static, BurnishApp> {
    let mut harness = Harness::builder()
        .with_size(WINDOW)
        .wgpu()
        .build_eframe(move |cc| BurnishApp::new(cc, config));
    settle(&mut harness);
    harness
}

/// Lets the worker finish (and a new view get its prediction) and the UI draw what it
/// published.
fn settle(harness: &mut Harness<'static, BurnishApp>) {
    harness.run_steps(2);
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    while harness.state().document().predictions_pending()
        || harness.state().document().file_jobs_pending()
    {
        assert!(
            std::time::Instant::now() < deadline,
            "no prediction arrived, or an export or start did not finish"
        );
        std::thread::sleep(Duration::from_millis(20));
        harness.step();
    }
    harness
        .state()
        .document()
        .worker()
        .sync(Duration::from_secs(60))
        .expect("the worker answers");
    harness.run_steps(3);
}

/// A stroke across the canvas from `from` to `to` (fractions of the canvas side).
fn stroke(harness: &mut Harness<'static, BurnishApp>, from: (f32, f32), to: (f32, f32)) {
    let (rect, _) = harness
        .state()
        .canvas_layout()
        .expect("the canvas was laid out");
    let at = |(u, v): (f32, f32)| {
        Pos2::new(
            rect.min.x + u * rect.width(),
            rect.min.y + v * rect.height(),
        )
    };
    let start = at(from);
    harness.event(Event::PointerMoved(start));
    harness.step();
    harness.event(Event::PointerButton {
        pos: start,
        button: PointerButton::Primary,
        pressed: true,
        modifiers: Modifiers::NONE,
    });
    harness.step();
    let steps = 12;
    for i in 1..=steps {
        let t = i as f32 / steps as f32;
        let p = at((from.0 + (to.0 - from.0) * t, from.1 + (to.1 - from.1) * t));
        harness.event(Event::PointerMoved(p));
        harness.step();
    }
    harness.event(Event::PointerButton {
        pos: at(to),
        button: PointerButton::Primary,
        pressed: false,
        modifiers: Modifiers::NONE,
    });
    harness.step();
    settle(harness);
}

fn preview_pixels(harness: &mut Harness<'static, BurnishApp>) -> Vec<[u8; 4]> {
    let rect = harness
        .state()
        .preview_rect()
        .expect("the preview was laid out");
    let image = harness
        .render()
        .expect("the wgpu renderer draws the window");
    let ppp = 1.0;
    let mut out = Vec::new();
    for y in (rect.min.y * ppp) as u32..(rect.max.y * ppp) as u32 {
        for x in (rect.min.x * ppp) as u32..(rect.max.x * ppp) as u32 {
            if x < image.width() && y < image.height() {
                out.push(image.get_pixel(x, y).0);
            }
        }
    }
    out
}

fn differing(a: &[[u8; 4]], b: &[[u8; 4]]) -> usize {
    a.iter().zip(b).filter(|(p, q)| p != q).count()
}

#[test]
fn a_stroke_reaches_the_table_the_solver_and_the_preview() {
    let mut harness = open_app(config());
    let before = harness.state().document().snapshot().clone();
    // The fresh canvas counts as shown: the guide's pixels are samples of grey diffuse.
    let guide_samples = before.stats.samples;
    assert!(guide_samples > 10_000, "{guide_samples} guide samples");
    assert!(before.basis.is_some(), "the given basis is installed");
    let preview_before = preview_pixels(&mut harness);

    {
        let app = harness.state_mut();
        app.brush_mut().kind = burnish::paint::BrushKind::Round;
        app.brush_mut().colour = [0.9, 0.2, 0.1];
        app.brush_mut().size = 30.0;
        app.brush_mut().opacity = 1.0;
        app.brush_mut().flow = 1.0;
    }
    stroke(&mut harness, (0.3, 0.35), (0.7, 0.45));
    let app = harness.state();
    let after = app.document().snapshot().clone();
    assert!(after.version > before.version);
    assert!(
        after.stats.samples > 200,
        "samples: {}",
        after.stats.samples
    );
    assert!(after.stats.observed_bins > 20);
    assert!(
        app.document().observed().next().is_some(),
        "the UI knows the sparse table's bins"
    );
    let moved: f64 = after
        .coefficients
        .iter()
        .zip(before.coefficients.iter())
        .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f64>())
        .sum();
    assert!(moved > 1e-3, "the coefficients change ({moved})");
    let preview_after = preview_pixels(&mut harness);
    let changed = differing(&preview_before, &preview_after);
    assert!(
        changed > 500,
        "the preview draws the new BRDF ({changed} pixels changed)"
    );
}

#[test]
fn undo_restores_the_paint_bit_for_bit_and_redo_reapplies_it() {
    let mut harness = open_app(config());
    let original = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    let guide_samples = harness.state().document().snapshot().stats.samples;
    harness.state_mut().brush_mut().colour = [2.5, 2.0, 1.5];
    stroke(&mut harness, (0.2, 0.5), (0.8, 0.5));
    let painted = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    assert!(painted != original, "the stroke painted");
    assert!(harness.state().document().snapshot().stats.samples > 0);

    assert!(harness.state().document().views()[0].canvas().can_undo());
    assert!(UiCommand::Undo.is_enabled(harness.state()));
    assert!(
        !UiCommand::Redo.is_enabled(harness.state()),
        "nothing to redo yet"
    );
    assert_eq!(
        UiCommand::Undo.shortcut(),
        Some(KeyboardShortcut::new(Modifiers::COMMAND, Key::Z))
    );
    harness.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    settle(&mut harness);
    assert!(UiCommand::Redo.is_enabled(harness.state()));
    let undone = harness.state().document().views()[0].canvas().layers();
    let differing = (0..undone.coverage.len())
        .filter(|&i| {
            undone.coverage[i].to_bits() != original.coverage[i].to_bits()
                || undone.colour.pixels[i].map(f32::to_bits)
                    != original.colour.pixels[i].map(f32::to_bits)
        })
        .count();
    assert_eq!(
        differing,
        0,
        "undo restores colour and coverage bit for bit ({} painted pixels left)",
        undone.painted_count()
    );
    assert_eq!(
        harness.state().document().snapshot().stats.samples,
        guide_samples,
        "and the painted samples give way to the guide's again"
    );

    harness.key_press_modifiers(Modifiers::COMMAND.plus(Modifiers::SHIFT), Key::Z);
    settle(&mut harness);
    assert!(
        harness.state().document().views()[0].canvas().layers() == &painted,
        "redo reapplies the stroke"
    );
    assert!(harness.state().document().snapshot().stats.samples > 0);
}

#[test]
fn a_second_view_contributes_samples() {
    let mut harness = open_app(config());
    stroke(&mut harness, (0.3, 0.3), (0.6, 0.6));
    let one_view = harness.state().document().snapshot().stats;

    harness.state_mut().perform(Action::AddView);
    {
        let app = harness.state_mut();
        assert_eq!(app.document().views().len(), 2);
        assert_eq!(app.document().active(), 1);
        let mut scene = app.document().views()[1].scene().clone();
        scene.light.azimuth_deg = -60.0;
        scene.light.elevation_deg = 25.0;
        app.document_mut()
            .set_scene(1, scene)
            .expect("the new light applies");
    }
    settle(&mut harness);
    stroke(&mut harness, (0.3, 0.3), (0.6, 0.6));
    let two_views = harness.state().document().snapshot().stats;
    assert!(two_views.samples > one_view.samples);
    assert!(
        two_views.observed_bins > one_view.observed_bins,
        "another light reaches other bins ({} → {})",
        one_view.observed_bins,
        two_views.observed_bins
    );

    // Muting the second view takes exactly its samples out.
    harness.state_mut().document_mut().set_muted(1, true);
    settle(&mut harness);
    assert_eq!(
        harness.state().document().snapshot().stats.samples,
        one_view.samples
    );
}

#[test]
fn save_then_open_reproduces_the_session() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("painted.burnish");
    let mut harness = open_app(config());
    harness.state_mut().brush_mut().colour = [0.1, 0.4, 3.0];
    stroke(&mut harness, (0.25, 0.6), (0.75, 0.3));
    harness.state_mut().perform(Action::AddView);
    settle(&mut harness);
    stroke(&mut harness, (0.4, 0.2), (0.4, 0.8));
    harness.state_mut().document_mut().set_muted(0, true);
    settle(&mut harness);
    harness
        .state_mut()
        .perform(Action::SaveSession(path.clone()));
    assert!(harness.state().notices().iter().all(|n| !n.is_error));
    let saved = harness.state().to_session();
    let stats = harness.state().document().snapshot().stats;

    let mut reopened = open_app(AppConfig {
        session: Some(path.clone()),
        ..config()
    });
    settle(&mut reopened);
    assert_eq!(reopened.state().to_session(), saved);
    assert_eq!(
        reopened.state().document().snapshot().stats.samples,
        stats.samples
    );
    assert_eq!(
        reopened.state().document().snapshot().stats.observed_bins,
        stats.observed_bins
    );
    // The same samples, added in another order: equal up to rounding of the sums.
    let (a, b) = (
        &reopened.state().document().snapshot().coefficients,
        &harness.state().document().snapshot().coefficients,
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b.iter()) {
        for c in 0..3 {
            assert!(
                (x[c] - y[c]).abs() <= 1e-9 * (1.0 + y[c].abs()),
                "the same samples give the same solution: {x:?} vs {y:?}"
            );
        }
    }
}

#[test]
fn a_bad_session_says_why_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.burnish");
    std::fs::write(&path, b"not a zip archive").unwrap();
    let mut harness = open_app(config());
    let before = harness.state().to_session();
    harness
        .state_mut()
        .perform(Action::OpenSession(path.clone()));
    let app = harness.state();
    let error = app
        .notices()
        .iter()
        .find(|n| n.is_error)
        .expect("an error is shown");
    assert!(error.text.contains("broken.burnish"), "{}", error.text);
    assert_eq!(app.to_session(), before);
    assert_eq!(std::fs::read(&path).unwrap(), b"not a zip archive");
}

/// Compares the window with `tests/snapshots/<name>.png` (`UPDATE_SNAPSHOTS=1` rewrites it).
/// The figures that change from run to run, the solve time and the latency, end the status
/// bar; from the solve time to the window's edge is masked.
fn window_snapshot(harness: &mut Harness<'static, BurnishApp>, name: &str) {
    harness.remove_cursor();
    harness.run_steps(2);
    let timings = harness.get_by_label_contains("solve ").rect();
    harness.mask(egui::Rect::from_min_max(
        timings.min,
        egui::pos2(WINDOW.x, timings.max.y),
    ));
    harness.snapshot(name);
}

#[test]
fn main_window_snapshots() {
    let mut harness = open_app(config());
    window_snapshot(&mut harness, "main_window_fresh");

    harness.state_mut().brush_mut().colour = [1.6, 0.5, 0.2];
    stroke(&mut harness, (0.25, 0.4), (0.75, 0.4));
    window_snapshot(&mut harness, "main_window_painted");

    harness.get_by_label("Lobe").click();
    settle(&mut harness);
    window_snapshot(&mut harness, "main_window_lobe");

    harness.get_by_label("Table").click();
    settle(&mut harness);
    window_snapshot(&mut harness, "main_window_table");

    harness.state_mut().set_preview_tab(PreviewTab::Object);
    harness.state_mut().perform(Action::AddView);
    {
        let app = harness.state_mut();
        let mut scene = app.document().views()[1].scene().clone();
        scene.light.azimuth_deg = -60.0;
        scene.light.elevation_deg = 25.0;
        app.document_mut()
            .set_scene(1, scene)
            .expect("the new light applies");
        app.brush_mut().colour = [0.2, 0.5, 1.4];
    }
    settle(&mut harness);
    stroke(&mut harness, (0.5, 0.2), (0.5, 0.8));
    harness.state_mut().set_show_overlay(true);
    settle(&mut harness);
    window_snapshot(&mut harness, "main_window_two_views_overlay");
}

fn click_at(harness: &mut Harness<'static, BurnishApp>, pos: Pos2) {
    harness.event(Event::PointerMoved(pos));
    harness.step();
    for pressed in [true, false] {
        harness.event(Event::PointerButton {
            pos,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::NONE,
        });
        harness.step();
    }
    harness.run_steps(2);
}

#[test]
fn the_eyedropper_picks_the_colour_the_preview_shows() {
    let mut harness = open_app(config());
    harness.state_mut().brush_mut().colour = [0.8, 0.3, 0.1];
    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    harness.get_by_label("Pick").click();
    harness.run_steps(2);
    assert_eq!(
        harness.state().brush().kind,
        burnish::paint::BrushKind::Eyedropper
    );
    let rect = harness
        .state()
        .preview_rect()
        .expect("the preview is laid out");
    let window = harness.render().expect("the window renders");

    harness.state_mut().brush_mut().colour = [9.0, 9.0, 9.0];
    let centre = rect.center();
    click_at(&mut harness, centre);
    let picked = harness.state().brush().colour;
    assert_ne!(picked, [9.0, 9.0, 9.0], "a click on the object picks");
    assert!(
        picked.iter().all(|c| c.is_finite() && *c >= 0.0),
        "{picked:?}"
    );
    // What was picked is what the window shows there, before the display's sRGB encoding.
    let shown = window.get_pixel(centre.x as u32, centre.y as u32).0;
    for c in 0..3 {
        let encoded = burnish::scene::srgb_encode(picked[c].min(1.0)) * 255.0;
        assert!(
            (encoded - shown[c] as f32).abs() <= 3.0,
            "channel {c}: picked {picked:?} encodes to {encoded}, the window shows {shown:?}"
        );
    }

    // The background has no colour to pick.
    harness.state_mut().brush_mut().colour = [9.0, 9.0, 9.0];
    click_at(&mut harness, rect.min + Vec2::splat(3.0));
    assert_eq!(harness.state().brush().colour, [9.0, 9.0, 9.0]);
}

#[test]
fn an_imported_painting_is_one_edit_that_undo_takes_back() {
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    let original = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    let guide_samples = harness.state().document().snapshot().stats.samples;
    // The exported guide, brightened in an "external editor", comes back as a painting.
    let painting = edited_guide(&mut harness, dir.path(), [1.5, 0.8, 0.5]);
    harness
        .state_mut()
        .perform(Action::ImportPainting(painting.clone()));
    settle(&mut harness);
    assert!(
        harness.state().notices().iter().all(|n| !n.is_error),
        "{:?}",
        harness
            .state()
            .notices()
            .iter()
            .map(|n| &n.text)
            .collect::<Vec<_>>()
    );
    let imported = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    assert!(
        imported.painted_count() > 10_000,
        "{}",
        imported.painted_count()
    );
    let samples = harness.state().document().snapshot().stats.samples;
    assert!(samples > 10_000, "{samples} samples");

    harness.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    settle(&mut harness);
    assert!(
        harness.state().document().views()[0].canvas().layers() == &original,
        "undo takes the import back"
    );
    assert_eq!(
        harness.state().document().snapshot().stats.samples,
        guide_samples
    );
    harness.key_press_modifiers(Modifiers::COMMAND.plus(Modifiers::SHIFT), Key::Z);
    settle(&mut harness);
    assert!(harness.state().document().views()[0].canvas().layers() == &imported);
    assert_eq!(harness.state().document().snapshot().stats.samples, samples);

    // A painting of the wrong size is refused, naming the file; the canvas keeps its paint.
    let small = dir.path().join("small.png");
    burnish::scene::write_png(
        &small,
        &burnish::image_io::RgbImage {
            width: 64,
            height: 64,
            pixels: vec![[0.5; 3]; 64 * 64],
        },
    )
    .unwrap();
    harness
        .state_mut()
        .perform(Action::ImportPainting(small.clone()));
    let error = harness
        .state()
        .notices()
        .iter()
        .find(|n| n.is_error)
        .expect("an error is shown");
    assert!(error.text.contains("small.png"), "{}", error.text);
    assert!(harness.state().document().views()[0].canvas().layers() == &imported);
}

/// A glossy reference material written as an EXR table, as File ▸ Load reference reads it.
fn reference_table(dir: &std::path::Path) -> PathBuf {
    use burnish::materials::models::{Distribution, Fresnel, Microfacet};
    let glossy = Microfacet::isotropic(
        Distribution::Ggx,
        0.2,
        Fresnel::Schlick {
            f0: [0.9, 0.6, 0.3],
        },
    );
    let path = dir.join("reference.exr");
    burnish::table::exr_file::write_table_exr(&path, &burnish::materials::tabulate(&glossy))
        .unwrap();
    path
}

/// The preview's object is chosen apart from the painted view: the canvas keeps painting the
/// sphere while the preview shows the torus, the material-test object or an OBJ; the preview
/// changes with the choice and a missing OBJ says so and goes back to the painted view's.
#[test]
fn the_preview_object_is_chosen_apart_from_the_painted_view() {
    let mut harness = open_app(config());
    stroke(&mut harness, (0.3, 0.4), (0.7, 0.5));
    let sphere = preview_pixels(&mut harness);
    let mut seen = vec![sphere];
    for object in [
        PreviewObject::Builtin(burnish::scene::BuiltinShape::Torus),
        PreviewObject::MaterialTest,
        PreviewObject::Obj(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/meshes/bowl.obj"),
        ),
    ] {
        harness.state_mut().set_preview_object(object.clone());
        settle(&mut harness);
        let pixels = preview_pixels(&mut harness);
        for earlier in &seen {
            assert!(
                differing(earlier, &pixels) > 2000,
                "{object:?} looks like an earlier object"
            );
        }
        seen.push(pixels);
        // The painted view is untouched: still the sphere, still its samples.
        assert_eq!(
            harness.state().document().views()[0].scene().object,
            "sphere"
        );
    }
    assert!(harness.state().notices().iter().all(|n| !n.is_error));

    harness
        .state_mut()
        .perform(Action::OpenPreviewObject(PathBuf::from(
            "/nonexistent/vase.obj",
        )));
    settle(&mut harness);
    let error = harness
        .state()
        .notices()
        .iter()
        .find(|n| n.is_error)
        .expect("an error is shown");
    assert!(error.text.contains("vase.obj"), "{}", error.text);
    assert_eq!(
        *harness.state().preview_object(),
        PreviewObject::PaintedView
    );
}

/// A reference material loads from an EXR table or a MERL binary; a broken file says which
/// and what, and keeps what was loaded.
#[test]
fn a_reference_material_loads_and_a_bad_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    let exr = reference_table(dir.path());
    harness.state_mut().perform(Action::LoadReference(exr));
    assert!(harness.state().notices().iter().all(|n| !n.is_error));
    let loaded = harness
        .state()
        .preview_state()
        .reference
        .clone()
        .expect("loaded");
    assert_eq!(loaded.name, "reference.exr");

    let merl = dir.path().join("reference.binary");
    burnish::table::merl::MerlBrdf::from_table(&loaded.table)
        .write(&merl)
        .unwrap();
    harness.state_mut().perform(Action::LoadReference(merl));
    assert_eq!(
        harness
            .state()
            .preview_state()
            .reference
            .as_ref()
            .unwrap()
            .name,
        "reference.binary"
    );

    let bad = dir.path().join("broken.binary");
    std::fs::write(&bad, [0u8; 40]).unwrap();
    harness.state_mut().perform(Action::LoadReference(bad));
    let error = harness
        .state()
        .notices()
        .iter()
        .find(|n| n.is_error)
        .expect("an error is shown");
    assert!(error.text.contains("broken.binary"), "{}", error.text);
    assert_eq!(
        harness
            .state()
            .preview_state()
            .reference
            .as_ref()
            .unwrap()
            .name,
        "reference.binary"
    );
}

/// The table tab's readout names the bins under the pointer and ρ there.
#[test]
fn the_table_readout_follows_the_pointer() {
    let mut harness = open_app(config());
    stroke(&mut harness, (0.3, 0.4), (0.7, 0.5));
    harness.get_by_label("Table").click();
    settle(&mut harness);
    let plot = harness
        .state()
        .preview_state()
        .table_rect
        .expect("the table was laid out");
    let at = plot.min + (plot.max - plot.min) * 0.25;
    harness.event(Event::PointerMoved(at));
    harness.run_steps(2);
    let readout = harness
        .state()
        .preview_state()
        .table_readout
        .clone()
        .expect("a readout under the pointer");
    assert!(
        readout.contains("light θ") && readout.contains("view θ") && readout.contains("ρ ("),
        "{readout}"
    );
}

#[test]
fn inspection_view_snapshots() {
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    harness.state_mut().brush_mut().colour = [1.6, 0.5, 0.2];
    stroke(&mut harness, (0.25, 0.4), (0.75, 0.4));
    harness
        .state_mut()
        .perform(Action::LoadReference(reference_table(dir.path())));

    // The material-test object in the studio environment, beside the main light.
    {
        let app = harness.state_mut();
        app.set_preview_object(PreviewObject::MaterialTest);
        app.preview_frame_mut().environment = Some(EnvironmentLight::default());
    }
    settle(&mut harness);
    window_snapshot(&mut harness, "preview_material_test_environment");

    // Several incidence angles on a log scale, with the reference dashed.
    harness.get_by_label("Lobe").click();
    {
        let state = harness.state_mut().preview_state_mut();
        state.lobe_angles = vec![20.0, 70.0];
        state.lobe_scale = LobeScale::Log { decades: 3 };
    }
    settle(&mut harness);
    window_snapshot(&mut harness, "lobe_angles_log_reference");

    // The table: viridis with its colour bar, observed and inconsistent bins marked.
    harness.get_by_label("Table").click();
    {
        let state = harness.state_mut().preview_state_mut();
        state.table_overlays.observed = true;
        state.table_overlays.inconsistent = true;
    }
    settle(&mut harness);
    window_snapshot(&mut harness, "table_viridis_overlays");
}

#[path = "support/read_only.rs"]
mod read_only;

/// The app autosaving to `recovery` (in a test's own folder).
fn autosaving(recovery: &std::path::Path) -> AppConfig {
    AppConfig {
        autosave: true,
        recovery_file: Some(recovery.to_path_buf()),
        ..config()
    }
}

/// The canvas position of a fraction (`u`, `v`) of the canvas side, in points.
fn canvas_point(harness: &Harness<'static, BurnishApp>, (u, v): (f32, f32)) -> Pos2 {
    let (rect, _) = harness
        .state()
        .canvas_layout()
        .expect("the canvas is laid out");
    Pos2::new(
        rect.min.x + u * rect.width(),
        rect.min.y + v * rect.height(),
    )
}

fn press(harness: &mut Harness<'static, BurnishApp>, pos: Pos2, pressed: bool) {
    harness.event(Event::PointerButton {
        pos,
        button: PointerButton::Primary,
        pressed,
        modifiers: Modifiers::NONE,
    });
}

fn error_texts(harness: &Harness<'static, BurnishApp>) -> Vec<String> {
    let notices = &harness.state().notices();
    notices
        .iter()
        .filter(|n| n.is_error)
        .map(|n| n.text.clone())
        .collect()
}

/// An idle window draws no frames: the app must ask for one when its autosave falls due.
/// A stroke is held (the pointer rests, nothing moves, no input comes); the frame the app
/// asked for, and only it, writes the recovery file.
#[test]
fn autosave_happens_while_idle_with_no_input() {
    let dir = tempfile::tempdir().unwrap();
    let recovery = dir.path().join("recovery.burnish");
    let mut harness = open_app(autosaving(&recovery));
    harness.run_steps(3);
    assert!(
        !recovery.exists(),
        "an untouched session has nothing to recover"
    );

    let requests = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let seen = requests.clone();
    harness
        .ctx
        .set_repaint_observer(move |info| seen.lock().unwrap().push(info.delay));
    harness.state_mut().brush_mut().size = 20.0;
    let start = canvas_point(&harness, (0.3, 0.5));
    harness.event(Event::PointerMoved(start));
    harness.step();
    press(&mut harness, start, true);
    harness.step();
    for i in 1..=6 {
        harness.event(Event::PointerMoved(canvas_point(
            &harness,
            (0.3 + 0.05 * i as f32, 0.5),
        )));
        harness.step();
    }
    // The last frame with input: what it asks for is what the event loop will do next.
    requests.lock().unwrap().clear();
    let painted_at = std::time::Instant::now();
    harness.step();
    let painted = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    assert!(painted.painted_count() > 100, "{}", painted.painted_count());
    assert!(!recovery.exists(), "a stroke under way waits for the delay");

    // The app asked for a frame at the time its write falls due (immediate requests are
    // the worker's and egui's own).
    let delay = requests
        .lock()
        .unwrap()
        .iter()
        .copied()
        .filter(|d| *d > Duration::ZERO)
        .min()
        .expect("a repaint is requested for the autosave");
    assert!(
        delay <= burnish::session::AUTOSAVE_DELAY,
        "the write is due within the delay, asked for in {delay:?}"
    );
    // The event loop, idle: it draws a frame only when the last one asked for it, at the
    // time asked (egui keeps the earliest request of the last frame only), with no input.
    // Other requests (the worker's fit, every 100 ms while it runs) come first; the app must
    // keep asking for its write in each of those frames, or the write never happens.
    let mut next = Some(delay);
    let mut info = None;
    while let Some(delay) = next {
        requests.lock().unwrap().clear();
        std::thread::sleep(delay + Duration::from_millis(5));
        harness.step();
        harness.state_mut().document_mut().flush_autosave().unwrap();
        info = burnish::session::pending_recovery_at(&recovery).unwrap();
        if info.is_some() {
            break;
        }
        assert!(
            painted_at.elapsed() < burnish::session::AUTOSAVE_DELAY + Duration::from_secs(10),
            "no write in {:?} of idle frames",
            painted_at.elapsed()
        );
        next = requests
            .lock()
            .unwrap()
            .iter()
            .copied()
            .filter(|d| *d > Duration::ZERO)
            .min();
    }
    let info = info.expect("the idle frames wrote the recovery file");
    let recovered = info.open().unwrap();
    assert!(
        recovered.views[0].paint == painted,
        "the recovery file holds the stroke as painted so far"
    );

    // Released: the finished stroke is written (no later than the least gap).
    let end = canvas_point(&harness, (0.7, 0.5));
    press(&mut harness, end, false);
    harness.step();
    std::thread::sleep(burnish::session::AUTOSAVE_MIN_GAP);
    harness.step();
    harness.state_mut().document_mut().flush_autosave().unwrap();
    let finished = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    assert!(info.open().unwrap().views[0].paint == finished);
}

/// A fast stroke brings its press, every move and its release within one frame: it paints
/// exactly what the same events spread over many frames paint, from where the button went
/// down.
#[test]
fn a_stroke_faster_than_the_frames_loses_no_dab() {
    let path: Vec<(f32, f32)> = (0..=24)
        .map(|i| {
            let t = i as f32 / 24.0;
            (0.25 + 0.5 * t, 0.4 + 0.2 * (t * 6.0).sin())
        })
        .collect();
    let paint = |one_frame: bool| {
        let mut harness = open_app(config());
        harness.state_mut().brush_mut().size = 6.0;
        let points: Vec<Pos2> = path.iter().map(|&p| canvas_point(&harness, p)).collect();
        harness.event(Event::PointerMoved(points[0]));
        harness.step();
        let button = |pos, pressed| Event::PointerButton {
            pos,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::NONE,
        };
        let mut events = vec![button(points[0], true)];
        events.extend(points[1..].iter().map(|&p| Event::PointerMoved(p)));
        events.push(button(*points.last().unwrap(), false));
        if one_frame {
            // Straight into the next frame's input: the harness's own event queue may give
            // each event a frame of its own.
            harness.input_mut().events.extend(events);
            harness.step();
        } else {
            for event in events {
                harness.input_mut().events.push(event);
                harness.step();
            }
        }
        settle(&mut harness);
        harness.state().document().views()[0]
            .canvas()
            .layers()
            .clone()
    };
    let slow = paint(false);
    let fast = paint(true);
    assert!(slow.painted_count() > 500, "{}", slow.painted_count());
    assert!(
        fast == slow,
        "one frame of events paints what many frames do"
    );
    // The first dab sits where the button went down.
    let resolution = 256usize;
    let pixel = |(u, v): (f32, f32)| {
        (v * resolution as f32) as usize * resolution + (u * resolution as f32) as usize
    };
    assert!(
        fast.coverage[pixel(path[0])] > 0.0,
        "the stroke starts at the press"
    );
    assert!(fast.coverage[pixel(path[12])] > 0.0);
    assert!(fast.coverage[pixel(*path.last().unwrap())] > 0.0);
}

/// A save that the disk refuses (full, or a read-only folder) says why; the file saved
/// before is intact, and the painting and its undo history stay in the app.
#[test]
fn a_refused_save_says_why_and_keeps_the_painting() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("sessions");
    std::fs::create_dir(&folder).unwrap();
    let path = folder.join("work.burnish");

    let check = |harness: &mut Harness<'static, BurnishApp>, expected: &str| {
        let before = std::fs::read(&path).unwrap();
        let session = harness.state().to_session();
        harness.state_mut().clear_notices();
        harness
            .state_mut()
            .perform(Action::SaveSession(path.clone()));
        let errors = error_texts(harness);
        assert!(
            errors
                .iter()
                .any(|e| e.contains("work.burnish") && e.contains(expected)),
            "{errors:?}"
        );
        assert_eq!(
            std::fs::read(&path).unwrap(),
            before,
            "the old file is intact"
        );
        assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 1);
        let app = harness.state();
        assert!(app.document().is_dirty(), "the changes are still unsaved");
        assert_eq!(app.to_session(), session, "the painting is kept");
        assert!(
            app.document().views()[0].canvas().can_undo(),
            "and so is its undo history"
        );
    };

    let mut harness = open_app(config());
    harness
        .state_mut()
        .perform(Action::SaveSession(path.clone()));
    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    {
        let _full = burnish::fs_atomic::simulate_full_disk(&folder, 4096);
        check(&mut harness, "No space left on device");
    }
    drop(harness);

    read_only::with_read_only_dir(&folder, || {
        let mut harness = open_app(config());
        stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
        check(&mut harness, "Permission denied");
    });

    // Saving works again once the disk does; the undo history survives the save.
    let mut harness = open_app(config());
    let guide_samples = harness.state().document().snapshot().stats.samples;
    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    let painted = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    harness
        .state_mut()
        .perform(Action::SaveSession(path.clone()));
    assert!(error_texts(&harness).is_empty());
    assert!(!harness.state().document().is_dirty());
    assert!(harness.state().document().views()[0].canvas().can_undo());
    harness.state_mut().perform(Action::Undo);
    settle(&mut harness);
    assert!(harness.state().document().views()[0].canvas().layers() != &painted);
    assert_eq!(
        harness.state().document().snapshot().stats.samples,
        guide_samples,
        "undo after a save"
    );
}

/// A crash leaves a recovery file; the next start offers it and writes nothing over it
/// until the user answers; Recover brings the stroke back and says that undo history was
/// not kept.
#[test]
fn recovery_brings_back_the_painting_and_is_never_overwritten_before_the_answer() {
    let dir = tempfile::tempdir().unwrap();
    let recovery = dir.path().join("recovery.burnish");
    let crashed = {
        let mut harness = open_app(autosaving(&recovery));
        harness.state_mut().brush_mut().colour = [3.0, 0.5, 0.25];
        stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
        harness.step();
        harness.state_mut().document_mut().flush_autosave().unwrap();
        // No clean exit: dropped as a killed process would leave it (the recovery file stays).
        harness.state().to_session()
    };
    let written = std::fs::read(&recovery).expect("the stroke was autosaved");

    let mut harness = open_app(autosaving(&recovery));
    assert!(
        harness.state().document().recovery_offer().is_some(),
        "recovery is offered"
    );
    harness.get_by_label("Recover");
    // Painting before answering (beside the dialog) writes nothing over the offered file.
    stroke(&mut harness, (0.3, 0.3), (0.3, 0.7));
    assert!(
        harness.state().document().views()[0]
            .canvas()
            .layers()
            .painted_count()
            > 0
    );
    std::thread::sleep(burnish::session::AUTOSAVE_MIN_GAP);
    harness.run_steps(2);
    harness.state_mut().document_mut().flush_autosave().unwrap();
    assert_eq!(std::fs::read(&recovery).unwrap(), written);

    harness.get_by_label("Recover").click();
    harness.run_steps(2);
    settle(&mut harness);
    let app = harness.state();
    assert!(app.document().recovery_offer().is_none());
    assert_eq!(app.to_session().views, crashed.views);
    assert!(
        app.document().snapshot().stats.samples > 0,
        "the recovered paint gives samples"
    );
    assert!(!app.document().views()[0].canvas().can_undo());
    assert!(
        app.notices()
            .iter()
            .any(|n| !n.is_error && n.text.contains("Undo history is not kept")),
        "the app says that undo history did not survive"
    );
}

/// A recovery file that can't be read is reported, naming it, and moved aside; the app
/// starts with its default session.
#[test]
fn an_unreadable_recovery_file_is_reported_at_start() {
    let dir = tempfile::tempdir().unwrap();
    let recovery = dir.path().join("recovery.burnish");
    std::fs::write(&recovery, b"PK\x03\x04 cut short").unwrap();
    let harness = open_app(autosaving(&recovery));
    let errors = error_texts(&harness);
    assert!(
        errors
            .iter()
            .any(|e| e.contains("recovery.burnish") && e.contains("can't be recovered")),
        "{errors:?}"
    );
    assert!(harness.state().document().recovery_offer().is_none());
    assert!(dir.path().join("recovery-unreadable.burnish").exists());
    assert_eq!(harness.state().document().views().len(), 1);
}

/// Bad files the app reads (an object, a painting, a brush preset) say what is wrong with
/// which file, and the open session loses nothing.
#[test]
fn bad_files_the_app_reads_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let brushes = dir.path().join("brushes");
    std::fs::create_dir(&brushes).unwrap();
    std::fs::write(
        brushes.join("good.toml"),
        "name = \"Good\"\n[brush]\nkind = \"round\"\nsize = 12.0\n",
    )
    .unwrap();
    std::fs::write(brushes.join("cut.toml"), "name = \"Cut\"\n[brush]\nsize = ").unwrap();
    let mut harness = open_app(AppConfig {
        brushes_dir: brushes,
        ..config()
    });
    let errors = error_texts(&harness);
    assert!(errors.iter().any(|e| e.contains("cut.toml")), "{errors:?}");
    assert_eq!(
        harness.state().presets().len(),
        1,
        "the good preset is still offered"
    );

    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    let session = harness.state().to_session();
    let obj = dir.path().join("broken.obj");
    // Cut short before its faces.
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
    let exr = dir.path().join("cut.exr");
    burnish::image_io::write_exr_rgb(
        &exr,
        &burnish::image_io::RgbImage::filled(256, 256, [0.5; 3]),
    )
    .unwrap();
    let bytes = std::fs::read(&exr).unwrap();
    std::fs::write(&exr, &bytes[..bytes.len() / 2]).unwrap();

    harness.state_mut().clear_notices();
    let mut scene = session.views[0].settings.scene.clone();
    scene.object = obj.to_string_lossy().into_owned();
    let err = harness
        .state_mut()
        .document_mut()
        .set_scene(0, scene)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("broken.obj") && err.contains("no faces"),
        "{err}"
    );
    harness
        .state_mut()
        .perform(Action::ImportPainting(exr.clone()));
    let errors = error_texts(&harness);
    assert!(errors.iter().any(|e| e.contains("cut.exr")), "{errors:?}");
    settle(&mut harness);
    assert_eq!(harness.state().to_session(), session);
}

/// A basis cache folder that can't be written: the basis is built and used from memory, and
/// the app says that it could not be cached.
#[test]
fn a_read_only_basis_cache_still_gives_a_basis_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    std::fs::create_dir(&cache).unwrap();
    read_only::with_read_only_dir(&cache, || {
        let mut harness = open_app(AppConfig {
            basis: None,
            basis_cache: Some(cache.clone()),
            basis_settings: burnish::session::BasisSettings {
                components: 4,
                materials: 8,
                ..Default::default()
            },
            ..config()
        });
        let deadline = std::time::Instant::now() + Duration::from_secs(300);
        while harness.state().document().basis().is_none() {
            assert!(
                std::time::Instant::now() < deadline,
                "the basis was never built"
            );
            std::thread::sleep(Duration::from_millis(100));
            harness.step();
        }
        settle(&mut harness);
        let app = harness.state();
        assert!(
            app.document().snapshot().basis.is_some(),
            "the worker solves with it"
        );
        assert!(
            app.notices().iter().any(|n| n.text.contains("warning")
                && n.text.contains("could not be cached")
                && n.text.contains("Permission denied")),
            "{:?}",
            app.notices().iter().map(|n| &n.text).collect::<Vec<_>>()
        );
        harness.get_by_label_contains("basis ready, not cached");
    });
    assert_eq!(std::fs::read_dir(&cache).unwrap().count(), 0);
}

/// An autosave the disk refuses is reported once, however often it is retried; the painting
/// stays in the app, and once the disk takes writes again the app says so and the recovery
/// file holds the painting.
#[test]
fn a_failing_autosave_is_reported_once_and_recovers_with_the_disk() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let recovery = data.join("recovery.burnish");
    let full = burnish::fs_atomic::simulate_full_disk(&data, 100);
    let mut harness = open_app(autosaving(&recovery));
    let step_until = |harness: &mut Harness<'static, BurnishApp>, what: &str| {
        let deadline = std::time::Instant::now() + Duration::from_secs(60);
        loop {
            harness.step();
            if harness
                .state()
                .notices()
                .iter()
                .any(|n| n.text.contains(what))
            {
                break;
            }
            assert!(std::time::Instant::now() < deadline, "no notice {what:?}");
            std::thread::sleep(Duration::from_millis(50));
        }
    };
    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    step_until(&mut harness, "autosave failed");
    stroke(&mut harness, (0.5, 0.3), (0.5, 0.7));
    std::thread::sleep(burnish::session::AUTOSAVE_RETRY + Duration::from_millis(500));
    harness.run_steps(3);
    let errors = error_texts(&harness);
    assert_eq!(
        errors.len(),
        1,
        "one notice for the failing disk: {errors:?}"
    );
    assert!(
        errors[0].contains("recovery.burnish") && errors[0].contains("No space left on device"),
        "{errors:?}"
    );
    assert!(!recovery.exists());
    let painted = harness.state().document().views()[0]
        .canvas()
        .layers()
        .clone();
    assert!(painted.painted_count() > 500, "the painting is kept");

    drop(full);
    step_until(&mut harness, "autosave works again");
    harness.state_mut().document_mut().flush_autosave().unwrap();
    let info = burnish::session::pending_recovery_at(&recovery)
        .unwrap()
        .expect("written once the disk takes it");
    assert!(info.open().unwrap().views[0].paint == painted);
}

/// File ▸ Start from a material: the material's projection onto the basis becomes the prior
/// mean (an unpainted session shows it), it is the preview's reference, and a new session
/// drops it; File ▸ Export writes the formats other renderers read.
#[test]
fn a_session_starts_from_a_material_and_exports_for_other_renderers() {
    use burnish::basis::OracleProjector;
    use burnish::export::{BsdfSettings, RglBsdf, load_table, rgl};
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    let mean = harness.state().document().snapshot().coefficients.clone();
    let table = burnish::table::exr_file::read_table_exr(reference_table(dir.path())).unwrap();
    let bsdf = dir.path().join("start.bsdf");
    rgl::write_bsdf(&bsdf, &table, &BsdfSettings::default()).unwrap();

    harness.state_mut().perform(Action::StartFrom(bsdf.clone()));
    settle(&mut harness);
    let app = harness.state();
    assert!(app.notices().iter().all(|n| !n.is_error));
    assert_eq!(app.document().start_material_name(), Some("start.bsdf"));
    assert_eq!(
        app.preview_state().reference.as_ref().unwrap().name,
        "start.bsdf"
    );
    let basis = app
        .document()
        .snapshot()
        .basis
        .clone()
        .expect("the basis is ready");
    let projection = OracleProjector::new(basis).project(&load_table(&bsdf).unwrap());
    let distance = |a: &[[f64; 3]], b: &[[f64; 3]]| {
        a.iter()
            .zip(b)
            .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).powi(2)))
            .sum::<f64>()
            .sqrt()
    };
    let started = app.document().snapshot().coefficients.clone();
    // The canvas now shows the material (unpainted pixels count as shown) and the prior's
    // mean is its projection: the solution sits at the projection, far from the guide's.
    let view = &app.document().views()[0];
    let render = burnish::scene::render_table(view.gbuffer(), &load_table(&bsdf).unwrap());
    assert!(
        view.prediction() == Some(&render),
        "the canvas shows the material"
    );
    // The localised prior has one coefficient set per band; each starts at the projection.
    let k = projection.len();
    let tiled: Vec<[f64; 3]> = (0..started.len() / k)
        .flat_map(|_| projection.iter().copied())
        .collect();
    assert!(
        distance(&started, &tiled) < 0.25 * distance(&mean, &tiled),
        "{} vs {}",
        distance(&started, &tiled),
        distance(&mean, &tiled)
    );

    // Exports for other renderers, chosen by extension; the analytic ones report their error.
    for name in ["out.bsdf", "out.mtlx", "out.gltf"] {
        harness
            .state_mut()
            .perform(Action::Export(dir.path().join(name)));
    }
    settle(&mut harness);
    let app = harness.state();
    assert!(app.notices().iter().all(|n| !n.is_error));
    assert!(RglBsdf::read(&dir.path().join("out.bsdf")).is_ok());
    let fits = app
        .notices()
        .iter()
        .filter(|n| n.text.contains("dB PSNR"))
        .count();
    assert_eq!(fits, 2);
    harness
        .state_mut()
        .perform(Action::Export(dir.path().join("out.png")));
    assert!(
        harness
            .state()
            .notices()
            .iter()
            .any(|n| n.is_error && n.text.contains("out.png"))
    );

    // A bad start is refused and the current one kept; a new session starts from the mean.
    let broken = dir.path().join("broken.bsdf");
    std::fs::write(&broken, b"tensor_file\0 but nothing more").unwrap();
    harness.state_mut().perform(Action::StartFrom(broken));
    settle(&mut harness);
    assert!(
        harness
            .state()
            .notices()
            .iter()
            .any(|n| n.is_error && n.text.contains("broken.bsdf"))
    );
    assert_eq!(
        harness.state().document().start_material_name(),
        Some("start.bsdf")
    );
    harness.state_mut().perform(Action::NewSession);
    settle(&mut harness);
    assert_eq!(harness.state().document().start_material_name(), None);
    // The start is dropped: the new session's guide pulls the solution back away from the
    // material, as far as a fresh session's.
    let cleared = harness.state().document().snapshot().coefficients.clone();
    assert!(
        distance(&cleared, &tiled) > 2.0 * distance(&started, &tiled),
        "{} vs {}",
        distance(&cleared, &tiled),
        distance(&started, &tiled)
    );
}

/// Where view `index`'s mirror highlight sits on its canvas (fractions of the side): the lit
/// object pixel whose local half vector is closest to its normal.
fn highlight_point(app: &BurnishApp, index: usize) -> (f32, f32) {
    let gbuffer = app.document().views()[index].gbuffer();
    let n = gbuffer.resolution();
    let best = (0..n * n)
        .filter_map(|i| {
            gbuffer
                .at(i)
                .filter(|p| p.light_bin.is_some() && p.view_bin.is_some())
                .map(|p| (i, (p.light + p.view).normalize().z))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a lit object")
        .0;
    (
        ((best % n) as f32 + 0.5) / n as f32,
        ((best / n) as f32 + 0.5) / n as f32,
    )
}

/// Preview pixels that moved by more than 6/255 in some channel, and how many of them lie
/// away from the highlight: farther than a sixth of the preview's width from where the
/// preview changed most.
fn moved_pixels(a: &[[u8; 4]], b: &[[u8; 4]], width: usize) -> (usize, usize) {
    let change = |i: usize| {
        (0..3)
            .map(|c| a[i][c].abs_diff(b[i][c]) as u32)
            .max()
            .unwrap()
    };
    let moved: Vec<usize> = (0..a.len().min(b.len()))
        .filter(|&i| change(i) > 6)
        .collect();
    let Some(&peak) = moved.iter().max_by_key(|&&i| change(i)) else {
        return (0, 0);
    };
    let (px, py) = ((peak % width) as f32, (peak / width) as f32);
    let reach = width as f32 / 6.0;
    let away = moved
        .iter()
        .filter(|&&i| {
            let (x, y) = ((i % width) as f32, (i / width) as f32);
            (x - px).hypot(y - py) > reach
        })
        .count();
    (moved.len(), away)
}

/// A short bright stroke over the highlight of a fresh sphere; the preview's pixels that
/// moved visibly.
/// Returns (moved, moved away from the highlight, preview pixels).
fn highlight_stroke_moves(rule: UnpaintedPixels) -> (usize, usize, usize) {
    let mut harness = open_app(config());
    harness.state_mut().document_mut().set_unpainted(0, rule);
    settle(&mut harness);
    let before = preview_pixels(&mut harness);
    let (u, v) = highlight_point(harness.state(), 0);
    {
        let app = harness.state_mut();
        app.brush_mut().kind = burnish::paint::BrushKind::Round;
        app.brush_mut().colour = [3.0, 3.0, 3.0];
        app.brush_mut().size = 16.0;
        app.brush_mut().opacity = 1.0;
        app.brush_mut().flow = 1.0;
    }
    stroke(&mut harness, (u - 0.03, v), (u + 0.03, v));
    let after = preview_pixels(&mut harness);
    let rect = harness.state().preview_rect().unwrap();
    let width = (rect.max.x as u32 - rect.min.x as u32) as usize;
    let (moved, away) = moved_pixels(&before, &after, width);
    (moved, away, before.len())
}

/// Issue 14, workflow 1: with "count as shown" (the default) the unpainted guide is a
/// statement (grey diffuse), so a highlight stroke changes the material only around the
/// highlight's lobe and the rest of the preview keeps the guide's material; with "ignore"
/// the same stroke is all the solver knows and the whole preview changes.
#[test]
fn a_highlight_stroke_changes_the_preview_only_around_the_highlight_when_unpainted_pixels_count() {
    let (counted, counted_away, total) = highlight_stroke_moves(UnpaintedPixels::CountAsShown);
    let (ignored, ignored_away, _) = highlight_stroke_moves(UnpaintedPixels::Ignore);
    eprintln!(
        "of {total} preview pixels, moved (away from the highlight): count as shown \
         {counted} ({counted_away}), ignore {ignored} ({ignored_away})"
    );
    assert!(counted > 0, "the stroke shows in the preview");
    assert!(
        counted * 12 < total && counted_away * 50 < total,
        "count as shown: {counted} preview pixels moved, {counted_away} away from the highlight"
    );
    assert!(
        ignored_away > 10 * counted_away.max(1),
        "ignore extrapolates the stroke over the material ({ignored_away} vs {counted_away})"
    );
}

/// The active view's guide, exported to `dir`, each channel scaled by `scale` as in an
/// external editor, and written back as `dir/painting.png` (8-bit, so it clips at 1).
fn edited_guide(
    harness: &mut Harness<'static, BurnishApp>,
    dir: &std::path::Path,
    scale: [f32; 3],
) -> PathBuf {
    let guide = dir.join("guide.png");
    harness
        .state_mut()
        .perform(Action::ExportGuide(guide.clone()));
    let resolution = harness.state().document().views()[0].scene().resolution as usize;
    let mut image = burnish::scene::read_painting(&guide, resolution).unwrap();
    for p in &mut image.pixels {
        *p = [0, 1, 2].map(|c| p[c] * scale[c]);
    }
    let painting = dir.join("painting.png");
    burnish::scene::write_png(&painting, &image).unwrap();
    painting
}

/// The app on a basis of K = 8 over 24 materials built into `cache`, where `burnish
/// reconstruct --components 8 --materials 24` finds it.
fn open_app_with_cached_basis(cache: &std::path::Path) -> Harness<'static, BurnishApp> {
    let mut harness = open_app(AppConfig {
        basis: None,
        basis_cache: Some(cache.to_path_buf()),
        basis_settings: burnish::session::BasisSettings {
            components: 8,
            materials: 24,
            ..Default::default()
        },
        ..config()
    });
    let deadline = std::time::Instant::now() + Duration::from_secs(300);
    while harness.state().document().basis().is_none() {
        assert!(std::time::Instant::now() < deadline, "no basis");
        std::thread::sleep(Duration::from_millis(100));
        harness.step();
    }
    settle(&mut harness);
    harness
}

/// Runs `burnish reconstruct --view VIEW --out OUT` on the basis of
/// [`open_app_with_cached_basis`], with `extra` arguments; fails the test if it fails or
/// does not load the app's basis.
fn cli_reconstruct(view: &str, out: &std::path::Path, cache: &std::path::Path, extra: &[&str]) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(["reconstruct", "--view", view, "--out"])
        .arg(out)
        .args(["--components", "8", "--materials", "24"])
        .args(extra)
        .env("BURNISH_CACHE_DIR", cache)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("loaded from cache"),
        "the app's basis: {stdout}"
    );
}

/// Exports the BRDF as an EXR table to `path` and waits for it (it is written in the
/// background); fails the test if the app reported an error.
fn export_table(harness: &mut Harness<'static, BurnishApp>, path: &std::path::Path) {
    harness
        .state_mut()
        .perform(Action::ExportTable(path.to_path_buf()));
    settle(harness);
    assert!(
        error_texts(harness).is_empty(),
        "{:?}",
        error_texts(harness)
    );
}

/// The largest relative difference between two table files over every entry and channel.
fn worst_relative_difference(a: &std::path::Path, b: &std::path::Path) -> f32 {
    let a = burnish::table::exr_file::read_table_exr(a).unwrap();
    let b = burnish::table::exr_file::read_table_exr(b).unwrap();
    a.pairs()
        .iter()
        .zip(b.pairs())
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs() / (1e-3 + y[k].abs())))
        .fold(0.0f32, f32::max)
}

/// Issue 14, workflow 3: a painting made in the app, exported with its mask, reconstructs on
/// the command line to the table the app shows, under either rule for unpainted pixels.
#[test]
fn the_app_and_burnish_reconstruct_give_the_same_table_for_the_same_painting() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let mut harness = open_app_with_cached_basis(&cache);
    harness.state_mut().brush_mut().colour = [1.6, 1.1, 0.7];
    stroke(&mut harness, (0.3, 0.4), (0.7, 0.5));
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        harness.state().document().views()[0].scene().to_toml(),
    )
    .unwrap();
    let painting = dir.path().join("painting.exr");
    for rule in [UnpaintedPixels::CountAsShown, UnpaintedPixels::Ignore] {
        harness.state_mut().document_mut().set_unpainted(0, rule);
        settle(&mut harness);
        let app_table = dir.path().join(format!("app-{rule}.exr"));
        let cli_table = dir.path().join(format!("cli-{rule}.exr"));
        harness
            .state_mut()
            .perform(Action::ExportPainting(painting.clone()));
        export_table(&mut harness, &app_table);
        let mask = burnish::app::painting_mask_path(&painting);
        let view = format!("{}={}", scene.display(), painting.display());
        let mask = mask.to_str().unwrap();
        cli_reconstruct(
            &view,
            &cli_table,
            &cache,
            &["--unpainted", rule.name(), "--mask", mask],
        );
        let worst = worst_relative_difference(&app_table, &cli_table);
        eprintln!("{rule}: worst relative difference app vs CLI {worst:e}");
        assert!(worst < 1e-4, "{rule}: app and CLI tables differ by {worst}");
    }
}

/// An 8-bit painting made elsewhere means the same in the app as on the command line: its
/// clipped channels say "at least this bright" to both, so importing it gives the table
/// `burnish reconstruct` gives. Read as exact values, the same pixels give another table.
#[test]
fn an_imported_8_bit_painting_gives_the_app_and_burnish_reconstruct_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let mut harness = open_app_with_cached_basis(&cache);
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        harness.state().document().views()[0].scene().to_toml(),
    )
    .unwrap();
    // The guide, warmed and brightened in an "external editor" until its light side clips.
    let painting = edited_guide(&mut harness, dir.path(), [2.5, 1.4, 0.7]);
    let decoded = burnish::scene::read_painting(&painting, 256).unwrap();
    let clipped = decoded.pixels.iter().filter(|p| p[0] == 1.0).count();
    assert!(clipped > 5_000, "{clipped} clipped pixels");

    harness
        .state_mut()
        .perform(Action::ImportPainting(painting.clone()));
    settle(&mut harness);
    let app_table = dir.path().join("app.exr");
    export_table(&mut harness, &app_table);
    let cli_table = dir.path().join("cli.exr");
    let view = format!("{}={}", scene.display(), painting.display());
    cli_reconstruct(&view, &cli_table, &cache, &[]);
    let worst = worst_relative_difference(&app_table, &cli_table);
    eprintln!("8-bit painting: worst relative difference app vs CLI {worst:e}");
    assert!(worst < 1e-4, "app and CLI tables differ by {worst}");

    // The decoded pixels as an EXR are exact values, clipped ones included: a different
    // statement, and a different table, so the agreement above is not a coincidence.
    let exact_painting = dir.path().join("exact.exr");
    burnish::scene::write_image(&exact_painting, &decoded).unwrap();
    let exact_table = dir.path().join("exact-table.exr");
    let view = format!("{}={}", scene.display(), exact_painting.display());
    cli_reconstruct(&view, &exact_table, &cache, &[]);
    let apart = worst_relative_difference(&app_table, &exact_table);
    assert!(
        apart > 1e-2,
        "bounds and exact values gave the same table ({apart})"
    );

    // The side panel says how the view's paint is read, and can read it as exact instead:
    // then the app gives the EXR's table.
    harness.get_by_label("Read as exact").click();
    settle(&mut harness);
    let app_exact = dir.path().join("app-exact.exr");
    export_table(&mut harness, &app_exact);
    let worst = worst_relative_difference(&app_exact, &exact_table);
    assert!(worst < 1e-4, "read as exact: app and CLI differ by {worst}");
    assert!(harness.query_by_label("Read as exact").is_none());
}

/// Issue 14, workflow 2: fill the object with a base colour, paint a highlight, add a view.
/// The new view proposes another light–view angle, and its canvas shows the current BRDF
/// rendered for it (the guide stays a reference layer); a correction painted there moves
/// the BRDF toward it where painted and leaves view 1 within tolerance.
#[test]
fn a_new_view_starts_from_the_current_brdf_and_a_correction_there_stays_local() {
    use burnish::app::Base;
    use burnish::scene::render_table;
    let mut harness = open_app(config());
    {
        let app = harness.state_mut();
        app.brush_mut().kind = burnish::paint::BrushKind::Fill;
        app.brush_mut().colour = [0.30, 0.16, 0.09];
        app.brush_mut().opacity = 1.0;
    }
    let centre = canvas_point(&harness, (0.5, 0.5));
    click_at(&mut harness, centre);
    settle(&mut harness);
    let (u, v) = highlight_point(harness.state(), 0);
    {
        let app = harness.state_mut();
        app.brush_mut().kind = burnish::paint::BrushKind::Round;
        app.brush_mut().colour = [2.5, 2.4, 2.2];
        app.brush_mut().size = 16.0;
        app.brush_mut().flow = 1.0;
    }
    stroke(&mut harness, (u - 0.03, v), (u + 0.03, v));
    let table = |app: &BurnishApp| {
        app.document()
            .snapshot()
            .reconstruction()
            .expect("a basis is ready")
            .materialize()
    };
    let before = table(harness.state());
    let view1_before = render_table(harness.state().document().views()[0].gbuffer(), &before);

    harness.state_mut().perform(Action::AddView);
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    while harness.state().document().views()[1].base() != Base::Prediction {
        assert!(
            std::time::Instant::now() < deadline,
            "no prediction arrived"
        );
        std::thread::sleep(Duration::from_millis(50));
        harness.step();
    }
    settle(&mut harness);
    let app = harness.state();
    let angle = |scene: &Scene| {
        let camera = burnish::scene::CameraRig::new(scene).toward_camera;
        burnish::scene::light_direction(&scene.light)
            .dot(camera)
            .acos()
            .to_degrees()
    };
    let (a1, a2) = (
        angle(app.document().views()[0].scene()),
        angle(app.document().views()[1].scene()),
    );
    assert!(
        (a1 - a2).abs() > 20.0,
        "the new view has another light–view angle ({a1:.0}° vs {a2:.0}°)"
    );
    // Its canvas is the BRDF rendered for it, where the guide would be grey.
    let doc = &app.document().views()[1];
    let expected = render_table(doc.gbuffer(), &before);
    let shown = &doc.canvas().layers().colour;
    let worst = shown
        .pixels
        .iter()
        .zip(&expected.pixels)
        .flat_map(|(s, e)| (0..3).map(move |k| (s[k] - e[k]).abs() / (1e-3 + e[k])))
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-4,
        "the canvas shows the prediction (off by {worst})"
    );
    assert!(
        shown != doc.guide(),
        "the prediction is not the guide (the guide stays as a reference layer)"
    );
    let lit = doc.counted_pixels().len();
    assert!(
        lit > 5_000,
        "every object pixel states the prediction ({lit})"
    );

    // A correction on the new view: its highlight painted much dimmer.
    let (u2, v2) = highlight_point(app, 1);
    let n = doc.gbuffer().resolution();
    let at = |(u, v): (f32, f32)| (v * n as f32) as usize * n + (u * n as f32) as usize;
    let predicted = shown.pixels[at((u2, v2))];
    let correction = predicted.map(|c| c * 0.3);
    harness.state_mut().brush_mut().colour = correction;
    stroke(&mut harness, (u2 - 0.04, v2), (u2 + 0.04, v2));
    let app = harness.state();
    let after = table(app);
    let doc = &app.document().views()[1];
    let corrected: Vec<usize> = (0..n * n)
        .filter(|&i| doc.canvas().layers().coverage[i] > 0.99)
        .collect();
    assert!(
        corrected.len() > 100,
        "{} pixels corrected",
        corrected.len()
    );
    let error = |table: &burnish::table::SymTable| {
        let render = render_table(doc.gbuffer(), table);
        corrected
            .iter()
            .map(|&i| {
                (render.pixels[i][1] - doc.canvas().layers().colour.pixels[i][1]).abs() as f64
            })
            .sum::<f64>()
            / corrected.len() as f64
    };
    let (error_before, error_after) = (error(&before), error(&after));
    assert!(
        error_after < 0.7 * error_before,
        "the BRDF moves toward the correction ({error_before:.4} → {error_after:.4})"
    );
    let view1_after = render_table(app.document().views()[0].gbuffer(), &after);
    let mut changes: Vec<f32> = view1_before
        .pixels
        .iter()
        .zip(&view1_after.pixels)
        .filter(|(b, _)| b[1] > 1e-3)
        .map(|(b, a)| (a[1] - b[1]).abs() / b[1])
        .collect();
    changes.sort_by(f32::total_cmp);
    let median = changes[changes.len() / 2];
    let p90 = changes[changes.len() * 9 / 10];
    eprintln!(
        "correction error {error_before:.4} → {error_after:.4}; view 1 change median {median:.4}, 90th percentile {p90:.4}"
    );
    assert!(
        median < 0.02 && p90 < 0.1,
        "view 1 stays within tolerance (median {median}, 90th percentile {p90})"
    );
}

/// "Suggest next view" ranks candidate views off the UI thread and adds the best as a new
/// view, one of the candidates `burnish suggest` ranks and not a copy of view 1; the table
/// tab's "uncertain" overlay asks for the posterior's standard deviation once a stroke has
/// ended, one value per pair, smaller where the paintings observed the table.
#[test]
fn suggest_next_view_adds_a_ranked_view_and_the_uncertainty_overlay_is_estimated() {
    let mut harness = open_app(config());
    stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
    settle(&mut harness);
    harness.state_mut().perform(Action::SuggestView);
    let wait = |harness: &mut Harness<'static, BurnishApp>,
                what: &str,
                pending: &dyn Fn(&BurnishApp) -> bool| {
        let deadline = std::time::Instant::now() + Duration::from_secs(180);
        while pending(harness.state()) {
            assert!(std::time::Instant::now() < deadline, "no {what} arrived");
            std::thread::sleep(Duration::from_millis(20));
            harness.step();
        }
    };
    wait(&mut harness, "ranking", &|app| {
        app.document().suggestion_pending()
    });
    settle(&mut harness);
    let app = harness.state();
    assert_eq!(app.document().views().len(), 2);
    assert_eq!(app.document().active(), 1);
    let (base, suggested) = (
        app.document().views()[0].scene(),
        app.document().views()[1].scene(),
    );
    let candidates = burnish::next_view::candidate_scenes(base, burnish::app::SUGGEST_CANDIDATES);
    assert!(candidates.contains(suggested), "{suggested:?}");
    assert_ne!(suggested, base);
    assert!(
        app.notices()
            .iter()
            .any(|n| n.text.starts_with("suggested view:")),
        "the suggestion is reported"
    );

    harness.state_mut().set_preview_tab(PreviewTab::Table);
    harness
        .state_mut()
        .preview_state_mut()
        .table_overlays
        .uncertain = true;
    harness.run_steps(2);
    wait(&mut harness, "uncertainty", &|app| {
        app.document().uncertainty_pending() || app.preview_state().uncertainty.is_none()
    });
    let app = harness.state();
    let sigma = app.preview_state().uncertainty.clone().unwrap();
    assert_eq!(sigma.len(), burnish::table::PAIRS);
    assert!(sigma.iter().all(|s| s.is_finite() && *s >= 0.0));
    let mean_of = |pairs: &mut dyn Iterator<Item = usize>| {
        let (sum, n) = pairs.fold((0.0f64, 0usize), |(s, n), p| (s + sigma[p] as f64, n + 1));
        sum / n as f64
    };
    let observed = mean_of(&mut app.document().observed().map(|p| p.index()));
    let all = mean_of(&mut (0..sigma.len()));
    assert!(observed < all, "observed bins {observed} against all {all}");
}

/// The pixels of the window image inside `rect` (points; the harness draws at 1 pixel per
/// point), rows from the top.
fn pixels_in(image: &image::RgbaImage, rect: egui::Rect) -> Vec<[u8; 4]> {
    let mut out = Vec::new();
    for y in rect.min.y.round() as u32..rect.max.y.round() as u32 {
        for x in rect.min.x.round() as u32..rect.max.x.round() as u32 {
            if x < image.width() && y < image.height() {
                out.push(image.get_pixel(x, y).0);
            }
        }
    }
    out
}

/// Compare mode: disabled (saying why) with nothing to compare with; with a material unlike
/// the reconstruction its pane differs from the reconstruction's and the difference view
/// lights up; with the reconstruction's own table as the material, the difference view is
/// black on the object.
#[test]
fn compare_mode_shows_the_material_beside_the_reconstruction_and_their_difference() {
    use egui_kittest::kittest::NodeT;
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    assert!(
        harness
            .get_by_label("Compare")
            .accesskit_node()
            .is_disabled(),
        "nothing to compare with yet"
    );
    assert!(harness.state().preview_state().compare_rects.is_none());

    harness
        .state_mut()
        .perform(Action::LoadReference(reference_table(dir.path())));
    harness.run_steps(2);
    harness.get_by_label("Compare").click();
    settle(&mut harness);
    assert!(harness.state().preview_state().compare);
    assert!(
        harness.state().notices().iter().all(|n| !n.is_error),
        "{:?}",
        harness.state().notices()
    );
    let rects = harness
        .state()
        .preview_state()
        .compare_rects
        .expect("the compare panes were laid out");
    assert_eq!(
        rects[0].size(),
        rects[1].size(),
        "side by side, the same size"
    );
    let image = harness.render().expect("the window renders");
    let [reconstruction, material, difference] = rects.map(|r| pixels_in(&image, r));
    let background = difference[0];
    let is_background = |p: &[u8; 4]| (0..3).all(|c| p[c].abs_diff(background[c]) <= 2);
    let object = difference.iter().filter(|p| !is_background(p)).count();
    assert!(
        object > difference.len() / 5,
        "the object fills the difference pane"
    );
    assert!(
        differing(&reconstruction, &material) > object / 2,
        "a glossy orange reference looks unlike the grey reconstruction"
    );
    let lit = difference
        .iter()
        .filter(|p| !is_background(p) && p[..3].iter().any(|&c| c > 40))
        .count();
    assert!(
        lit > object / 2,
        "the difference shows where they differ: {lit} of {object} object pixels"
    );

    // The reconstruction's own table as the material: no difference anywhere on the object.
    let same = dir.path().join("same.exr");
    harness
        .state_mut()
        .perform(Action::ExportTable(same.clone()));
    settle(&mut harness);
    harness.state_mut().perform(Action::LoadReference(same));
    settle(&mut harness);
    let image = harness.render().expect("the window renders");
    let [reconstruction, material, difference] = rects.map(|r| pixels_in(&image, r));
    let object: Vec<&[u8; 4]> = difference.iter().filter(|p| !is_background(p)).collect();
    assert!(object.len() > difference.len() / 5);
    let coloured = object
        .iter()
        .filter(|p| p[..3].iter().any(|&c| c > 12))
        .count();
    assert!(
        coloured * 200 < object.len(),
        "the same material shows black: {coloured} of {} object pixels are coloured",
        object.len()
    );
    let close = reconstruction
        .iter()
        .zip(&material)
        .filter(|(a, b)| (0..3).all(|c| a[c].abs_diff(b[c]) <= 2))
        .count();
    assert!(
        close * 100 > 99 * reconstruction.len(),
        "the two panes show the same picture"
    );

    // Another mode: the panes are gone.
    harness.get_by_label("Sparse only").click();
    harness.run_steps(2);
    assert!(!harness.state().preview_state().compare);
    assert!(harness.state().preview_state().compare_rects.is_none());
}

/// The starting material is saved with the session: reopened, and recovered after a crash,
/// the worker's prior mean is the same and the material is the preview's reference again.
#[test]
fn the_starting_material_is_saved_with_the_session_and_recovered() {
    let dir = tempfile::tempdir().unwrap();
    let recovery = dir.path().join("recovery.burnish");
    let material = reference_table(dir.path());
    let session = dir.path().join("started.burnish");
    let (prior, coefficients) = {
        let mut harness = open_app(autosaving(&recovery));
        harness
            .state_mut()
            .perform(Action::StartFrom(material.clone()));
        settle(&mut harness);
        let prior = harness
            .state()
            .document()
            .snapshot()
            .prior_mean
            .clone()
            .expect("the start sets the prior mean");
        harness
            .state_mut()
            .perform(Action::SaveSession(session.clone()));
        // A stroke after the save, autosaved: the recovery file holds the start too. The
        // start's own autosave began moments ago, so the stroke's is due only after the least
        // gap between two writes; flushing sooner would find nothing under way to wait for.
        stroke(&mut harness, (0.3, 0.5), (0.7, 0.5));
        harness.step();
        std::thread::sleep(burnish::session::AUTOSAVE_MIN_GAP);
        harness.step();
        harness.state_mut().document_mut().flush_autosave().unwrap();
        assert!(
            harness.state().notices().iter().all(|n| !n.is_error),
            "{:?}",
            harness.state().notices()
        );
        (
            prior,
            harness.state().document().snapshot().coefficients.clone(),
        )
    };
    // The material's file is gone: the session holds its own copy.
    std::fs::remove_file(&material).unwrap();

    let reopened = open_app(AppConfig {
        session: Some(session.clone()),
        ..config()
    });
    let app = reopened.state();
    assert_eq!(app.document().start_material_name(), Some("reference.exr"));
    assert_eq!(
        app.document().snapshot().prior_mean.as_deref(),
        Some(&*prior),
        "the same prior mean"
    );
    assert_eq!(
        app.preview_state().reference.as_ref().unwrap().name,
        "reference.exr"
    );
    drop(reopened);

    let mut recovered = open_app(AppConfig {
        recover: true,
        ..autosaving(&recovery)
    });
    settle(&mut recovered);
    let app = recovered.state();
    assert!(
        app.document().recovery_offer().is_none(),
        "recovered at once"
    );
    assert_eq!(app.document().start_material_name(), Some("reference.exr"));
    assert_eq!(
        app.document().snapshot().prior_mean.as_deref(),
        Some(&*prior)
    );
    // The same samples on the same start, added in another order: equal up to rounding.
    assert_eq!(
        app.document().snapshot().coefficients.len(),
        coefficients.len()
    );
    for (x, y) in app
        .document()
        .snapshot()
        .coefficients
        .iter()
        .zip(coefficients.iter())
    {
        for c in 0..3 {
            assert!(
                (x[c] - y[c]).abs() <= 1e-9 * (1.0 + y[c].abs()),
                "the recovered stroke on the same start solves to the same BRDF: {x:?} vs {y:?}"
            );
        }
    }

    // A new session starts from the database's mean again.
    recovered.state_mut().perform(Action::NewSession);
    settle(&mut recovered);
    assert_eq!(recovered.state().document().start_material_name(), None);
    assert_eq!(recovered.state().document().snapshot().prior_mean, None);
}

/// An export runs on its own thread: the window keeps drawing frames and says what it is
/// writing until the file is there; a failed one says which file and why.
#[test]
fn an_export_runs_off_the_ui_thread_and_the_window_keeps_drawing() {
    use egui_kittest::kittest::Queryable;
    let dir = tempfile::tempdir().unwrap();
    let mut harness = open_app(config());
    let out = dir.path().join("material.bsdf");
    harness.state_mut().perform(Action::Export(out.clone()));
    assert!(
        harness.state().document().file_jobs_pending(),
        "perform returns while the export runs"
    );
    // (egui shows a new area from its second frame.)
    harness.run_steps(2);
    // Writing a .bsdf (the full table, the NDF's power iteration, the warped grids) takes
    // seconds: the first frames after the request come long before it is done.
    assert!(harness.state().document().file_jobs_pending());
    harness.get_by_label_contains("exporting material.bsdf");
    let mut frames = 2;
    let deadline = std::time::Instant::now() + Duration::from_secs(300);
    while harness.state().document().file_jobs_pending() {
        assert!(
            std::time::Instant::now() < deadline,
            "the export never ended"
        );
        std::thread::sleep(Duration::from_millis(20));
        harness.step();
        frames += 1;
    }
    assert!(frames > 1, "frames were drawn while the export ran");
    assert!(out.is_file(), "the file appeared");
    assert!(burnish::export::RglBsdf::read(&out).is_ok());
    let app = harness.state();
    assert!(
        app.notices()
            .iter()
            .any(|n| !n.is_error && n.text.contains("material.bsdf")),
        "{:?}",
        app.notices()
    );
    assert!(harness.query_by_label_contains("exporting").is_none());

    let unwritable = dir.path().join("no such folder").join("material.gltf");
    harness
        .state_mut()
        .perform(Action::Export(unwritable.clone()));
    settle(&mut harness);
    assert!(
        harness
            .state()
            .notices()
            .iter()
            .any(|n| n.is_error && n.text.contains("material.gltf")),
        "{:?}",
        harness.state().notices()
    );
    assert!(!unwritable.exists());
}
