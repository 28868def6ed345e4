//! Stroke-to-preview latency of the real app: pointer event → the first frame whose preview
//! draws coefficients that include it, with the wgpu renderer drawing every frame (lavapipe
//! here, or whatever adapter wgpu picks). The app's default window (1500 × 900), a 512²
//! canvas, the default basis (K = 20, from the cache), continuous painting at a steady frame
//! rate.
//!
//! `cargo bench --bench latency` prints p50, p95 and max latency, frame times and the most
//! commands ever waiting for the worker (the worker keeps up when that stays small), with the
//! load average before and after (other work on the machine shows in the figures), and the
//! floors: the same harness rendering and reading back an egui window of the same size that
//! holds one label, and one that a single opaque rectangle covers (what any window whose
//! panels fill it costs at least: on a software rasteriser the cost is per covered pixel), so
//! that what the app adds can be told from what the adapter charges for the window.
//! `LATENCY_FRAMES` (240), `LATENCY_RESOLUTION` (512) and `LATENCY_WINDOW` (`1500x900`)
//! change the run. Under `cargo test` (no `--bench` argument) it is a quick check that the
//! loop works: 12 frames in a 1000 × 700 window on a 128² canvas with a tiny basis
//! built in memory.

use burnish::app::{AppConfig, BurnishApp};
mod common;

use burnish::basis::{BasisCache, CacheOutcome};
use burnish::scene::Scene;
use egui::{Event, Modifiers, PointerButton, Pos2, Vec2};
use egui_kittest::Harness;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn main() {
    let test_mode = common::test_mode();
    let setting = |name: &str| std::env::var(name).ok();
    let frames: usize = setting("LATENCY_FRAMES")
        .and_then(|v| v.parse().ok())
        .unwrap_or(if test_mode { 12 } else { 240 });
    let resolution: u32 = setting("LATENCY_RESOLUTION")
        .and_then(|v| v.parse().ok())
        .unwrap_or(if test_mode { 128 } else { 512 });
    let window = setting("LATENCY_WINDOW")
        .and_then(|v| {
            let (w, h) = v.split_once('x')?;
            Some(Vec2::new(w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or(if test_mode {
            Vec2::new(1000.0, 700.0)
        } else {
            Vec2::new(1500.0, 900.0)
        });
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
            .unwrap_or_else(|_| "unknown".into())
    };
    let load_before = load();
    let started = Instant::now();
    let (basis, outcome) = if test_mode {
        let basis = common::check_basis(20);
        (Arc::new(basis), CacheOutcome::Built)
    } else {
        let settings = burnish::session::BasisSettings::default();
        let spec = burnish::app::basis_spec(&settings);
        let cache = BasisCache::default_location().expect("a cache folder");
        cache
            .load_or_build(&spec, false, &|_| {})
            .expect("the default basis")
    };
    eprintln!(
        "basis K={} {:?} in {:.1} s",
        basis.components(),
        outcome,
        started.elapsed().as_secs_f64()
    );
    let config = AppConfig {
        basis: Some(basis),
        brushes_dir: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("brushes"),
        autosave: false,
        scene: Scene {
            resolution,
            ..Scene::default()
        },
        ..AppConfig::default()
    };
    let mut harness = Harness::builder()
        .with_size(window)
        .wgpu()
        .with_render_every_step(true)
        .build_eframe(move |cc| BurnishApp::new(cc, config));
    harness.run_steps(3);
    harness.state_mut().brush_mut().size = 60.0;
    harness.state_mut().brush_mut().colour = [0.8, 0.5, 0.3];
    let (rect, resolution) = harness.state().canvas_layout().expect("canvas laid out");
    eprintln!(
        "window {}x{}, canvas {resolution}², drawn at {:.0} points",
        window.x,
        window.y,
        rect.width()
    );

    // A slow spiral over the sphere, one pointer event per frame.
    let at = |t: f32| {
        let r = 0.1 + 0.25 * t;
        let a = t * 40.0;
        Pos2::new(
            rect.center().x + r * a.cos() * rect.width(),
            rect.center().y + r * a.sin() * rect.height(),
        )
    };
    harness.event(Event::PointerMoved(at(0.0)));
    harness.event(Event::PointerButton {
        pos: at(0.0),
        button: PointerButton::Primary,
        pressed: true,
        modifiers: Modifiers::NONE,
    });
    let mut frame_ms = Vec::with_capacity(frames);
    let mut max_queue = 0;
    for i in 0..frames {
        let frame_start = Instant::now();
        harness.event(Event::PointerMoved(at(i as f32 / frames as f32)));
        harness.step();
        max_queue = max_queue.max(harness.state().document().worker().queued());
        frame_ms.push(frame_start.elapsed().as_secs_f64() * 1e3);
    }
    harness.event(Event::PointerButton {
        pos: at(1.0),
        button: PointerButton::Primary,
        pressed: false,
        modifiers: Modifiers::NONE,
    });
    harness.step();
    harness
        .state()
        .document()
        .worker()
        .sync(Duration::from_secs(30));
    harness.run_steps(3);
    // The same pointer motion without the button: no new snapshot, so the preview draws
    // nothing new; what is left is the UI and the window's render.
    let mut idle_ms = Vec::with_capacity(frames / 4);
    for i in 0..frames / 4 {
        let frame_start = Instant::now();
        harness.event(Event::PointerMoved(at(i as f32 / frames as f32)));
        harness.step();
        idle_ms.push(frame_start.elapsed().as_secs_f64() * 1e3);
    }

    let floor_ms = bare_window_frames(window, frames / 4, false);
    let covered_ms = bare_window_frames(window, frames / 4, true);

    let app = harness.state();
    let percentile = |v: &[f64], q: f64| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[((s.len() - 1) as f64 * q).round() as usize]
    };
    let latencies = &app.latencies_ms();
    assert!(!latencies.is_empty(), "no stroke reached the preview");
    println!(
        "stroke-to-preview latency over {} updates: p50 {:.1} ms, p95 {:.1} ms, max {:.1} ms",
        latencies.len(),
        percentile(latencies, 0.5),
        percentile(latencies, 0.95),
        percentile(latencies, 1.0)
    );
    println!(
        "frame time (UI + render): p50 {:.1} ms, p95 {:.1} ms; most commands queued: {max_queue}",
        percentile(&frame_ms, 0.5),
        percentile(&frame_ms, 0.95)
    );
    println!(
        "frame time without painting (UI + render, preview unchanged): p50 {:.1} ms, p95 {:.1} ms",
        percentile(&idle_ms, 0.5),
        percentile(&idle_ms, 0.95)
    );
    println!(
        "frame time of an egui window of the same size with one label: p50 {:.1} ms, p95 {:.1} ms; covered by one opaque rectangle: p50 {:.1} ms, p95 {:.1} ms",
        percentile(&floor_ms, 0.5),
        percentile(&floor_ms, 0.95),
        percentile(&covered_ms, 0.5),
        percentile(&covered_ms, 0.95)
    );
    println!(
        "samples {}, observed bins {}, last worker batch {:.2} ms",
        app.document().snapshot().stats.samples,
        app.document().snapshot().stats.observed_bins,
        app.document().snapshot().stats.update_ms
    );
    println!("load average before {load_before}, after {}", load());
}

/// Frame times of a window of `size` holding one label (`covered`: and one opaque rectangle
/// over all of it), rendered and read back every step by the same harness and adapter as the
/// app: the floors under every figure above.
fn bare_window_frames(size: Vec2, frames: usize, covered: bool) -> Vec<f64> {
    let mut harness = Harness::builder()
        .with_size(size)
        .wgpu()
        .with_render_every_step(true)
        .build_ui(move |ui| {
            if covered {
                ui.painter()
                    .rect_filled(ui.max_rect(), 0.0, egui::Color32::from_gray(27));
            }
            ui.label("floor");
        });
    harness.run_steps(3);
    (0..frames.max(1))
        .map(|i| {
            let frame_start = Instant::now();
            harness.event(Event::PointerMoved(Pos2::new(100.0 + i as f32, 100.0)));
            harness.step();
            frame_start.elapsed().as_secs_f64() * 1e3
        })
        .collect()
}
