//! Painting figures on a 1024² sphere guide: one dab of a stroke in progress at diameters
//! 20, 60 and 200 (round, soft) and with the chalk tip, a whole 100-dab stroke with its
//! changes taken, and undoing and redoing such a stroke.

use burnish::paint::{BrushKind, BrushSettings, Canvas, TipMask};
use burnish::scene::{BuiltinShape, GBuffer, Object, Scene, guide_image};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

const RESOLUTION: u32 = 1024;

fn sphere_canvas() -> Canvas {
    let scene = Scene {
        resolution: RESOLUTION,
        ..Scene::default()
    };
    let gbuffer = GBuffer::build(&scene, &Object::builtin(BuiltinShape::Sphere));
    let mask = (0..gbuffer.pixels().len())
        .map(|i| gbuffer.at(i).is_some())
        .collect();
    Canvas::new(guide_image(&gbuffer), mask)
}

fn round(size: f32, hardness: f32) -> BrushSettings {
    BrushSettings {
        kind: BrushKind::Round,
        size,
        hardness,
        opacity: 0.8,
        flow: 0.5,
        spacing: 0.25,
        colour: [1.5, 0.4, 0.2],
        pressure_size: false,
        pressure_flow: false,
    }
}

/// A 100-dab stroke across the sphere's middle in ten pointer events.
fn hundred_dab_stroke(canvas: &mut Canvas, settings: &BrushSettings) {
    let c = RESOLUTION as f32 / 2.0;
    let step = settings.spacing * settings.size;
    let length = 99.0 * step + step / 2.0;
    canvas.begin_stroke(settings, c - length / 2.0, c, 1.0);
    for k in 1..=10 {
        canvas.continue_stroke(c - length / 2.0 + length * k as f32 / 10.0, c, 1.0);
    }
    canvas.end_stroke();
    assert_eq!(canvas.dabs_in_stroke(), 100);
}

fn paint_benches(c: &mut Criterion) {
    let canvas = sphere_canvas();
    let centre = RESOLUTION as f32 / 2.0;

    // One dab per iteration: the stroke moves on by exactly one dab spacing, back and forth,
    // so every dab lands on tiles the stroke has already snapshotted, as in a long stroke.
    let mut dabs = c.benchmark_group("dab");
    let chalk = Path::new(env!("CARGO_MANIFEST_DIR")).join("brushes/chalk.png");
    let chalk = Arc::new(TipMask::load_png(&chalk).expect("the shipped chalk tip"));
    for size in [20.0f32, 60.0, 200.0] {
        for (name, hardness, tip) in [
            ("hard", 1.0, None),
            ("soft", 0.0, None),
            ("chalk", 1.0, Some(chalk.clone())),
        ] {
            let settings = round(size, hardness);
            let mut canvas = canvas.clone();
            canvas.set_tip(tip);
            let step = settings.spacing * size;
            canvas.begin_stroke(&settings, centre, centre, 1.0);
            let mut k = 0u64;
            dabs.bench_function(BenchmarkId::new(name, size), |b| {
                b.iter(|| {
                    k += 1;
                    let x = centre + if k % 2 == 1 { step } else { 0.0 };
                    canvas.continue_stroke(black_box(x), centre, 1.0);
                });
            });
            canvas.end_stroke();
        }
    }
    dabs.finish();

    let mut strokes = c.benchmark_group("stroke");
    strokes.sample_size(30);
    let settings = round(60.0, 0.5);
    strokes.bench_function("100 dabs of 60 px, changes taken", |b| {
        let mut canvas = canvas.clone();
        b.iter(|| {
            hundred_dab_stroke(&mut canvas, &settings);
            black_box(canvas.take_changes());
        });
    });
    strokes.bench_function("undo then redo of a 100-dab stroke", |b| {
        let mut canvas = canvas.clone();
        hundred_dab_stroke(&mut canvas, &settings);
        canvas.take_changes();
        b.iter(|| {
            black_box(canvas.undo().expect("a stroke to undo"));
            black_box(canvas.redo().expect("a stroke to redo"));
        });
    });
    strokes.finish();
}

criterion_group!(benches, paint_benches);
criterion_main!(benches);
