//! The painting engine on a real guide (the default sphere scene): strokes and what they
//! report, every tool, undo/redo bit for bit, the undo budget and brush presets on disk.

use burnish::image_io::RgbImage;
use burnish::paint::*;
use burnish::scene::{BuiltinShape, GBuffer, Object, Scene, guide_image};
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

const RESOLUTION: u32 = 256;

/// The guide and object mask of the default sphere scene, built once.
fn sphere_guide() -> &'static (RgbImage, Vec<bool>) {
    static GUIDE: OnceLock<(RgbImage, Vec<bool>)> = OnceLock::new();
    GUIDE.get_or_init(|| {
        let scene = Scene {
            resolution: RESOLUTION,
            ..Scene::default()
        };
        let gbuffer = GBuffer::build(&scene, &Object::builtin(BuiltinShape::Sphere));
        let mask = (0..gbuffer.pixels().len())
            .map(|i| gbuffer.at(i).is_some())
            .collect();
        (guide_image(&gbuffer), mask)
    })
}

fn canvas() -> Canvas {
    let (guide, mask) = sphere_guide();
    Canvas::new(guide.clone(), mask.clone())
}

/// The object's centre and radius in pixels, measured from the mask.
fn object_disc(canvas: &Canvas) -> (f32, f32, f32) {
    let n = canvas.resolution();
    let (mut sx, mut sy, mut count) = (0.0f64, 0.0f64, 0usize);
    for (i, _) in canvas.object_mask().iter().enumerate().filter(|(_, o)| **o) {
        sx += (i % n) as f64 + 0.5;
        sy += (i / n) as f64 + 0.5;
        count += 1;
    }
    let c = count as f64;
    (
        (sx / c) as f32,
        (sy / c) as f32,
        (c / std::f64::consts::PI).sqrt() as f32,
    )
}

/// Colour and coverage bits of every pixel.
type State = (Vec<[u32; 3]>, Vec<u32>);

fn state(canvas: &Canvas) -> State {
    let layers = canvas.layers();
    (
        layers
            .colour
            .pixels
            .iter()
            .map(|c| c.map(f32::to_bits))
            .collect(),
        layers.coverage.iter().map(|v| v.to_bits()).collect(),
    )
}

fn painted_at(state: &State, i: usize) -> Option<[u32; 3]> {
    (f32::from_bits(state.1[i]) > 0.0).then_some(state.0[i])
}

/// The changes the app must see between two states: pixels whose painted state or colour
/// differ, as (pixel, before bits, after bits).
type ChangeBits = Vec<(u32, Option<[u32; 3]>, Option<[u32; 3]>)>;

fn expected_changes(before: &State, after: &State) -> ChangeBits {
    (0..before.1.len())
        .filter_map(|i| {
            let (b, a) = (painted_at(before, i), painted_at(after, i));
            (b != a).then_some((i as u32, b, a))
        })
        .collect()
}

fn change_bits(changes: &CanvasChanges) -> ChangeBits {
    changes
        .pixels
        .iter()
        .map(|p| {
            (
                p.pixel,
                p.before.map(|c| c.map(f32::to_bits)),
                p.after.map(|c| c.map(f32::to_bits)),
            )
        })
        .collect()
}

/// The tight bounding rectangle of the changed pixels.
fn bounds(changes: &CanvasChanges, n: usize) -> PixelRect {
    changes.pixels.iter().fold(PixelRect::EMPTY, |r, p| {
        let (x, y) = ((p.pixel as usize % n) as u32, (p.pixel as usize / n) as u32);
        r.union(&PixelRect::new(x, y, x + 1, y + 1))
    })
}

fn assert_reports(changes: Option<CanvasChanges>, before: &State, after: &State, n: usize) {
    let expected = expected_changes(before, after);
    let Some(changes) = changes else {
        assert!(
            expected.is_empty(),
            "{} changes went unreported",
            expected.len()
        );
        return;
    };
    assert_eq!(change_bits(&changes), expected);
    assert_eq!(changes.dirty, bounds(&changes, n));
}

/// Unpainted pixels hold the guide exactly; nothing off the object is painted.
fn assert_invariants(canvas: &Canvas) {
    let layers = canvas.layers();
    for i in 0..layers.coverage.len() {
        let v = layers.coverage[i];
        assert!((0.0..=1.0).contains(&v), "pixel {i}: coverage {v}");
        assert!(
            layers.colour.pixels[i]
                .iter()
                .all(|c| c.is_finite() && *c >= 0.0)
        );
        if v == 0.0 {
            assert_eq!(
                layers.colour.pixels[i].map(f32::to_bits),
                canvas.base().pixels[i].map(f32::to_bits),
                "unpainted pixel {i} is not the guide"
            );
        }
        if !canvas.object_mask()[i] {
            assert_eq!(v, 0.0, "pixel {i} off the object is painted");
        }
    }
}

fn brush(kind: BrushKind, size: f32, hardness: f32, colour: [f32; 3]) -> BrushSettings {
    BrushSettings {
        kind,
        size,
        hardness,
        opacity: 1.0,
        flow: 1.0,
        spacing: 0.1,
        colour,
        pressure_size: false,
        pressure_flow: false,
    }
}

/// A stroke through `points`, each a separate pointer event at full pressure.
fn stroke(canvas: &mut Canvas, settings: &BrushSettings, points: &[(f32, f32)]) {
    canvas.begin_stroke(settings, points[0].0, points[0].1, 1.0);
    for &(x, y) in &points[1..] {
        canvas.continue_stroke(x, y, 1.0);
    }
    canvas.end_stroke();
}

/// `steps` + 1 evenly spaced points from `a` to `b`.
fn line(a: (f32, f32), b: (f32, f32), steps: usize) -> Vec<(f32, f32)> {
    (0..=steps)
        .map(|k| {
            let t = k as f32 / steps as f32;
            (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t)
        })
        .collect()
}

fn distance_to_segment(p: (f32, f32), a: (f32, f32), b: (f32, f32)) -> f32 {
    let (abx, aby) = (b.0 - a.0, b.1 - a.1);
    let t = (((p.0 - a.0) * abx + (p.1 - a.1) * aby) / (abx * abx + aby * aby)).clamp(0.0, 1.0);
    (p.0 - a.0 - abx * t).hypot(p.1 - a.1 - aby * t)
}

fn centre_of(pixel: usize, n: usize) -> (f32, f32) {
    ((pixel % n) as f32 + 0.5, (pixel / n) as f32 + 0.5)
}

#[test]
fn a_stroke_changes_only_object_pixels_in_reach_and_reports_exactly_them() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, radius) = object_disc(&canvas);
    let start = state(&canvas);
    // From off the object, across its rim, to its middle.
    let (a, b) = (
        (cx - radius - 15.0, cy - 10.0),
        (cx + 5.0, cy + 0.3 * radius),
    );
    let settings = brush(BrushKind::Round, 20.0, 0.5, [0.9, 0.2, 0.05]);
    stroke(&mut canvas, &settings, &line(a, b, 7));
    let after = state(&canvas);
    let changes = canvas.take_changes().expect("the stroke changed pixels");
    assert!(changes.pixels.len() > 500, "{}", changes.pixels.len());
    assert_reports(Some(changes.clone()), &start, &after, n);
    assert!(canvas.take_changes().is_none(), "a drained batch is empty");

    for i in 0..start.1.len() {
        if start.0[i] != after.0[i] || start.1[i] != after.1[i] {
            assert!(canvas.object_mask()[i], "pixel {i} off the object changed");
            let d = distance_to_segment(centre_of(i, n), a, b);
            assert!(
                d <= 10.0 + 1.0,
                "pixel {i} at {d} px from the stroke changed"
            );
        }
    }
    assert!(
        changes
            .pixels
            .iter()
            .all(|p| p.before.is_none() && p.after.is_some())
    );
    assert_invariants(&canvas);

    // Two overlapping strokes in one batch: one entry per pixel, `before` from the batch's start.
    let batch_start = state(&canvas);
    let second = brush(BrushKind::Round, 16.0, 1.0, [0.1, 0.3, 2.0]);
    stroke(
        &mut canvas,
        &second,
        &line((cx, cy - 20.0), (cx, cy + 20.0), 4),
    );
    let third = brush(BrushKind::Darken, 24.0, 0.7, [0.0; 3]);
    stroke(
        &mut canvas,
        &third,
        &line((cx - 20.0, cy), (cx + 20.0, cy), 4),
    );
    let changes = canvas.take_changes();
    let pixels: Vec<u32> = changes
        .iter()
        .flat_map(|c| &c.pixels)
        .map(|p| p.pixel)
        .collect();
    assert_eq!(
        pixels.iter().collect::<HashSet<_>>().len(),
        pixels.len(),
        "one entry per pixel"
    );
    assert_reports(changes, &batch_start, &state(&canvas), n);
}

#[test]
fn a_full_strength_eraser_restores_the_guide_bit_for_bit() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, r) = object_disc(&canvas);
    let hdr = brush(BrushKind::Round, 30.0, 0.6, [4.0, 0.5, 9.0]);
    stroke(&mut canvas, &hdr, &line((cx - r, cy), (cx + r, cy), 10));
    let dodge = brush(BrushKind::Lighten, 40.0, 0.0, [0.0; 3]);
    stroke(&mut canvas, &dodge, &line((cx, cy - r), (cx, cy + r), 10));
    let smudge = brush(BrushKind::Smudge, 20.0, 0.5, [0.0; 3]);
    stroke(
        &mut canvas,
        &smudge,
        &line((cx, cy), (cx + 30.0, cy + 30.0), 10),
    );
    let painted = state(&canvas);
    canvas.take_changes();

    // One hard dab far larger than the canvas: every pixel is inside its solid part.
    let eraser = brush(BrushKind::Eraser, 4.0 * n as f32, 1.0, [0.0; 3]);
    stroke(&mut canvas, &eraser, &[(cx, cy)]);
    assert!(
        state(&canvas) == state(&self::canvas()),
        "not the guide bit for bit"
    );
    assert_eq!(canvas.layers().painted_count(), 0);
    let changes = canvas.take_changes().expect("paint was erased");
    assert!(
        changes
            .pixels
            .iter()
            .all(|p| p.before.is_some() && p.after.is_none())
    );
    assert_reports(Some(changes), &painted, &state(&canvas), n);

    // Partial erasing lowers coverage; under 1/1024 the pixel is the guide again.
    let solid = brush(BrushKind::Round, 20.0, 1.0, [2.0, 1.0, 0.5]);
    stroke(&mut canvas, &solid, &[(cx, cy)]);
    let centre = (cy as usize) * n + cx as usize;
    let strong = BrushSettings {
        opacity: 0.99,
        ..brush(BrushKind::Eraser, 20.0, 1.0, [0.0; 3])
    };
    stroke(&mut canvas, &strong, &[(cx, cy)]);
    let v = canvas.layers().coverage[centre];
    assert!((v - 0.01).abs() < 1e-6, "{v}");
    let expected = [2.0, 1.0, 0.5].map(|c: f32| c * 0.01 + canvas.base().pixels[centre][0] * 0.99);
    for (got, want) in canvas.layers().colour.pixels[centre].iter().zip(expected) {
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    }
    stroke(&mut canvas, &strong, &[(cx, cy)]);
    assert_eq!(canvas.layers().coverage[centre], 0.0);
    assert_eq!(
        canvas.layers().colour.pixels[centre].map(f32::to_bits),
        canvas.base().pixels[centre].map(f32::to_bits)
    );
    assert_invariants(&canvas);
}

fn chalk_tip() -> Arc<TipMask> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("brushes/chalk.png");
    Arc::new(TipMask::load_png(&path).unwrap())
}

#[test]
fn undo_restores_every_tool_bit_for_bit_and_redo_reapplies_identically() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, r) = object_disc(&canvas);
    let mut states = vec![state(&canvas)];
    type Edit = Box<dyn Fn(&mut Canvas)>;
    let edits: Vec<Edit> = vec![
        Box::new(move |c| {
            let s = brush(BrushKind::Round, 25.0, 0.8, [0.8, 0.1, 0.1]);
            stroke(c, &s, &line((cx - r, cy - 20.0), (cx + r, cy + 20.0), 9));
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                flow: 0.1,
                opacity: 0.7,
                ..brush(BrushKind::Airbrush, 50.0, 0.0, [0.1, 0.9, 3.0])
            };
            c.begin_stroke(&s, cx + 10.0, cy - 30.0, 0.6);
            for _ in 0..5 {
                c.airbrush_tick(1.0 / 60.0);
            }
            c.continue_stroke(cx + 40.0, cy - 10.0, 0.9);
            c.airbrush_tick(0.25);
            c.end_stroke();
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                flow: 0.8,
                ..brush(BrushKind::Smudge, 20.0, 0.4, [0.0; 3])
            };
            stroke(
                c,
                &s,
                &line((cx - 10.0, cy - 15.0), (cx + 30.0, cy + 40.0), 12),
            );
        }),
        Box::new(move |c| {
            let s = brush(BrushKind::Blur, 30.0, 0.3, [0.0; 3]);
            stroke(c, &s, &line((cx - 40.0, cy), (cx + 40.0, cy + 5.0), 6));
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                opacity: 0.5,
                ..brush(BrushKind::Lighten, 40.0, 0.0, [0.0; 3])
            };
            stroke(c, &s, &line((cx, cy - r), (cx, cy + r), 5));
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                opacity: 0.4,
                flow: 0.5,
                ..brush(BrushKind::Darken, 35.0, 0.2, [0.0; 3])
            };
            stroke(c, &s, &line((cx - r, cy + 30.0), (cx + r, cy - 30.0), 5));
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                opacity: 0.6,
                ..brush(BrushKind::Eraser, 30.0, 0.5, [0.0; 3])
            };
            stroke(
                c,
                &s,
                &line((cx - 30.0, cy - 30.0), (cx + 30.0, cy + 30.0), 4),
            );
        }),
        Box::new(move |c| {
            let s = BrushSettings {
                opacity: 0.5,
                ..brush(BrushKind::Fill, 1.0, 1.0, [0.3, 0.3, 0.6])
            };
            c.fill(&s);
        }),
        Box::new(move |c| {
            c.set_tip(Some(chalk_tip()));
            let s = BrushSettings {
                pressure_size: true,
                pressure_flow: true,
                ..brush(BrushKind::Round, 40.0, 1.0, [6.0, 6.0, 6.0])
            };
            c.begin_stroke(&s, cx - 50.0, cy + 40.0, 0.3);
            c.continue_stroke(cx, cy + 45.0, 1.0);
            c.continue_stroke(cx + 50.0, cy + 40.0, 0.5);
            c.end_stroke();
            c.set_tip(None);
        }),
    ];
    for edit in &edits {
        edit(&mut canvas);
        assert_reports(
            canvas.take_changes(),
            states.last().unwrap(),
            &state(&canvas),
            n,
        );
        assert_invariants(&canvas);
        states.push(state(&canvas));
    }
    assert_eq!(
        canvas.undo_steps(),
        edits.len(),
        "one step per stroke or fill"
    );
    for k in (0..edits.len()).rev() {
        let changes = canvas.undo().expect("a step to undo");
        assert!(
            states[k] == state(&canvas),
            "undo of edit {k} is not bit for bit"
        );
        assert_reports(
            Some(changes).filter(|c| !c.is_empty()),
            &states[k + 1],
            &states[k],
            n,
        );
    }
    assert!(!canvas.can_undo() && canvas.undo().is_none());
    for k in 0..edits.len() {
        let changes = canvas.redo().expect("a step to redo");
        assert!(states[k + 1] == state(&canvas), "redo of edit {k} differs");
        assert_reports(
            Some(changes).filter(|c| !c.is_empty()),
            &states[k],
            &states[k + 1],
            n,
        );
    }
    assert!(!canvas.can_redo() && canvas.redo().is_none());

    // A new stroke after undoing clears what could have been redone.
    canvas.undo();
    canvas.undo();
    assert!(canvas.can_redo());
    edits[0](&mut canvas);
    assert!(!canvas.can_redo());
    assert!(canvas.undo().is_some());
    assert!(states[edits.len() - 2] == state(&canvas));
}

#[test]
fn opacity_caps_what_one_stroke_does_however_often_it_passes() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    let (x, y) = (cx.floor() + 0.5, cy.floor() + 0.5);
    let centre = y as usize * n + x as usize;
    let colour = [3.0, 0.2, 0.7];
    let settings = BrushSettings {
        opacity: 0.4,
        flow: 0.3,
        ..brush(BrushKind::Round, 30.0, 0.5, colour)
    };
    let scrub: Vec<(f32, f32)> = (0..80)
        .map(|k| (x + if k % 2 == 0 { -6.0 } else { 6.0 }, y))
        .collect();
    let mut scrubbed = scrub.clone();
    scrubbed.push((x, y));
    stroke(&mut canvas, &settings, &scrubbed);
    let v = canvas.layers().coverage[centre];
    assert!(
        v <= 0.4 + 1e-6 && v > 0.399,
        "one stroke reached coverage {v}"
    );
    let guide = canvas.base().pixels[centre];
    for k in 0..3 {
        let want = guide[k] * (1.0 - v) + colour[k] * v;
        assert!((canvas.layers().colour.pixels[centre][k] - want).abs() < 1e-5);
    }
    // A second stroke starts from there: 1 − 0.6² of the way.
    stroke(&mut canvas, &settings, &scrubbed);
    let v = canvas.layers().coverage[centre];
    assert!((v - 0.64).abs() < 1e-3, "two strokes reached coverage {v}");
    // Flow alone builds up within the cap: a single dab gives opacity · flow at the centre.
    let mut fresh = self::canvas();
    stroke(&mut fresh, &settings, &[(x, y)]);
    let v = fresh.layers().coverage[centre];
    assert!((v - 0.4 * 0.3).abs() < 0.01, "a single dab gave {v}");
}

/// Connected groups of painted pixels (4-neighbourhood).
fn painted_groups(canvas: &Canvas) -> usize {
    let n = canvas.resolution();
    let layers = canvas.layers();
    let mut seen = vec![false; n * n];
    let mut groups = 0;
    for start in 0..n * n {
        if seen[start] || !layers.is_painted(start) {
            continue;
        }
        groups += 1;
        let mut todo = vec![start];
        seen[start] = true;
        while let Some(i) = todo.pop() {
            let (x, y) = (i % n, i / n);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < n).then(|| i + 1),
                (y > 0).then(|| i - n),
                (y + 1 < n).then(|| i + n),
            ];
            for j in neighbours.into_iter().flatten() {
                if !seen[j] && layers.is_painted(j) {
                    seen[j] = true;
                    todo.push(j);
                }
            }
        }
    }
    groups
}

#[test]
fn spacing_lays_the_expected_number_of_dabs() {
    let (cx, cy) = {
        let c = canvas();
        let (cx, cy, r) = object_disc(&c);
        assert!(r > 90.0, "the sphere must hold the test line (radius {r})");
        (cx, cy)
    };
    // Diameter 8, spacing 2: a dab every 16 px; 165 px of path gives dabs at 0, 16, …, 160.
    let settings = BrushSettings {
        spacing: 2.0,
        ..brush(BrushKind::Round, 8.0, 1.0, [1.0, 1.0, 1.0])
    };
    let (a, b) = ((cx - 80.0, cy), (cx + 85.0, cy));
    for events in [1, 13, 165] {
        let mut canvas = canvas();
        stroke(&mut canvas, &settings, &line(a, b, events));
        assert_eq!(canvas.dabs_in_stroke(), 11, "{events} events");
        assert_eq!(painted_groups(&canvas), 11, "{events} events");
    }
    // A pen lifting pressure shrinks the dabs, and with them the spacing.
    let mut canvas = canvas();
    let pressured = BrushSettings {
        pressure_size: true,
        ..settings
    };
    canvas.begin_stroke(&pressured, a.0, a.1, 0.5);
    canvas.continue_stroke(b.0, b.1, 0.5);
    canvas.end_stroke();
    assert_eq!(canvas.dabs_in_stroke(), 21, "4 px dabs every 8 px");
}

/// Coverage of one dab of `hardness` (diameter 40, full opacity and flow) along the row
/// through its centre, as (distance from the centre, coverage).
fn dab_profile(hardness: f32) -> (f32, Vec<(f32, f32)>) {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    let (x, y) = (cx.floor() + 0.5, cy.floor() + 0.5);
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 40.0, hardness, [1.0; 3]),
        &[(x, y)],
    );
    let row = y as usize * n;
    let profile = (0..30)
        .map(|d| (d as f32, canvas.layers().coverage[row + x as usize + d]))
        .collect();
    (20.0, profile)
}

#[test]
fn hardness_one_is_a_disc_and_zero_falls_off_over_the_radius() {
    let (radius, hard) = dab_profile(1.0);
    for &(d, v) in &hard {
        if d <= radius - 1.0 {
            assert_eq!(v, 1.0, "hard dab at {d}");
        } else if d >= radius + 1.0 {
            assert_eq!(v, 0.0, "hard dab at {d}");
        }
    }
    let edge: Vec<f32> = hard
        .iter()
        .filter(|(d, _)| (d - radius).abs() < 1.0)
        .map(|p| p.1)
        .collect();
    assert!(
        edge.iter().all(|v| *v > 0.0 && *v < 1.0),
        "a 1-px antialiased edge: {edge:?}"
    );

    let (_, soft) = dab_profile(0.0);
    assert!(soft[0].1 > 0.97, "soft centre {}", soft[0].1);
    for pair in soft.windows(2) {
        assert!(pair[1].1 <= pair[0].1, "soft profile rises: {pair:?}");
    }
    let half = soft[10].1;
    assert!((half - 0.5).abs() < 0.08, "soft at half the radius: {half}");
    assert!(
        soft[18].1 < 0.05 && soft[18].1 > 0.0,
        "soft near the rim: {}",
        soft[18].1
    );
    assert!(
        soft.iter()
            .filter(|(d, _)| *d >= radius + 1.0)
            .all(|p| p.1 == 0.0)
    );
    // Softness spreads the paint: clearly less in total than the hard disc.
    let total = |p: &[(f32, f32)]| p.iter().map(|q| q.1).sum::<f32>();
    assert!(total(&soft) < 0.7 * total(&hard));
}

#[test]
fn fill_covers_exactly_the_object_in_one_undo_step() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let colour = [0.25, 0.5, 5.0];
    canvas.begin_stroke(&brush(BrushKind::Fill, 10.0, 1.0, colour), 3.0, 3.0, 1.0);
    canvas.end_stroke();
    let changes = canvas.take_changes().expect("fill changes pixels");
    let object: Vec<u32> = (0..n * n)
        .filter(|&i| canvas.object_mask()[i])
        .map(|i| i as u32)
        .collect();
    assert_eq!(
        changes.pixels.iter().map(|p| p.pixel).collect::<Vec<_>>(),
        object
    );
    assert!(changes.pixels.iter().all(|p| p.after == Some(colour)));
    for i in 0..n * n {
        assert_eq!(canvas.layers().is_painted(i), canvas.object_mask()[i]);
    }
    assert_invariants(&canvas);
    assert_eq!(canvas.undo_steps(), 1);
    let undone = canvas.undo().unwrap();
    assert_eq!(undone.pixels.len(), object.len());
    assert_eq!(canvas.layers(), &PaintLayers::unpainted(canvas.base()));
    // At opacity 0.5 over paint the fill mixes.
    canvas.fill(&brush(BrushKind::Fill, 1.0, 1.0, [1.0; 3]));
    canvas.fill(&BrushSettings {
        opacity: 0.5,
        ..brush(BrushKind::Fill, 1.0, 1.0, [3.0; 3])
    });
    let i = object[object.len() / 2] as usize;
    assert_eq!(canvas.layers().colour.pixels[i], [2.0; 3]);
}

#[test]
fn the_eyedropper_returns_painted_hdr_colours() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, r) = object_disc(&canvas);
    let hdr = [4.0, 0.25, 12.5];
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 30.0, 1.0, hdr),
        &[(cx, cy)],
    );
    canvas.take_changes();
    assert_eq!(canvas.pick(cx, cy), hdr);
    assert_eq!(canvas.pick_average(cx, cy, 4.0), hdr);
    let changed: Vec<_> = canvas
        .layers()
        .colour
        .pixels
        .iter()
        .filter(|c| **c == hdr)
        .collect();
    assert!(changed.len() > 500);
    // Unpainted places give the guide; off the canvas the nearest pixel.
    let (gx, gy) = (cx - r * 0.7, cy);
    let guide_pixel = gy as usize * n + gx as usize;
    assert_eq!(canvas.pick(gx, gy), canvas.base().pixels[guide_pixel]);
    assert_eq!(canvas.pick(-5.0, 1e9), canvas.base().pixels[(n - 1) * n]);
    // Averages mix painted and unpainted object pixels, and skip the background.
    let edge = canvas.pick_average(cx + 15.0, cy, 3.0);
    assert!(edge[0] > canvas.base().pixels[guide_pixel][0] && edge[0] < 4.0);
    // Picking is not painting.
    canvas.begin_stroke(
        &brush(BrushKind::Eyedropper, 5.0, 1.0, [0.0; 3]),
        cx,
        cy,
        1.0,
    );
    canvas.continue_stroke(cx + 50.0, cy, 1.0);
    canvas.end_stroke();
    assert!(canvas.take_changes().is_none());
    assert_eq!(canvas.undo_steps(), 1);
}

#[test]
fn non_finite_input_is_clamped_or_ignored() {
    let mut canvas = canvas();
    let (cx, cy, _) = object_disc(&canvas);
    let wild = BrushSettings {
        size: f32::NAN,
        opacity: f32::INFINITY,
        ..brush(BrushKind::Round, 1.0, 1.0, [f32::NAN, f32::INFINITY, -3.0])
    };
    canvas.begin_stroke(&wild, cx, cy, f32::NAN);
    canvas.continue_stroke(f32::NAN, cy, 1.0);
    canvas.continue_stroke(cx, f32::INFINITY, 1.0);
    canvas.end_stroke();
    assert_eq!(canvas.pick(cx, cy), [0.0, MAX_PAINT, 0.0]);
    assert_invariants(&canvas);
    // Wild jumps end quickly and paint only on the canvas.
    let fine = BrushSettings {
        spacing: 0.01,
        ..brush(BrushKind::Round, 1.0, 1.0, [1.0; 3])
    };
    canvas.begin_stroke(&fine, cx, cy + 20.0, 1.0);
    canvas.continue_stroke(1e30, cy + 20.0, 1.0);
    canvas.continue_stroke(-3e38, 3e38, 1.0);
    canvas.continue_stroke(cx, cy + 30.0, 1.0);
    canvas.end_stroke();
    assert_eq!(canvas.dabs_in_stroke(), 1 + (1 << 16));
    assert_invariants(&canvas);
    // Lightening the brightest paint stays finite.
    stroke(
        &mut canvas,
        &brush(BrushKind::Lighten, 40.0, 1.0, [0.0; 3]),
        &[(cx, cy)],
    );
    assert_eq!(canvas.pick(cx, cy), [0.0, MAX_PAINT, 0.0]);
    assert_invariants(&canvas);
}

#[test]
fn smudge_drags_paint_and_blur_softens_it_on_the_object_only() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    let red = [2.0, 0.0, 0.0];
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 30.0, 1.0, red),
        &[(cx - 30.0, cy)],
    );
    // Smudging from the red disc to the right drags red where there was none.
    let smudge = brush(BrushKind::Smudge, 16.0, 0.8, [0.0; 3]);
    stroke(
        &mut canvas,
        &smudge,
        &line((cx - 30.0, cy), (cx + 10.0, cy), 10),
    );
    let dragged = cy as usize * n + (cx - 5.0) as usize;
    assert!(canvas.layers().is_painted(dragged));
    let c = canvas.layers().colour.pixels[dragged];
    assert!(c[0] > 0.5 && c[0] > 3.0 * c[1], "smudged colour {c:?}");
    assert_invariants(&canvas);

    // Blur over a hard edge: the pixel just outside gains some paint; blurring where there
    // is no paint near leaves the guide as it was.
    let mut canvas = self::canvas();
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 40.0, 1.0, red),
        &[(cx, cy)],
    );
    let outside = cy as usize * n + (cx + 21.5) as usize;
    assert!(!canvas.layers().is_painted(outside));
    let before = state(&canvas);
    canvas.take_changes();
    let blur = brush(BrushKind::Blur, 60.0, 1.0, [0.0; 3]);
    stroke(
        &mut canvas,
        &blur,
        &line((cx + 20.0, cy - 10.0), (cx + 20.0, cy + 10.0), 4),
    );
    assert!(canvas.layers().is_painted(outside));
    let changes = canvas.take_changes();
    assert_reports(changes, &before, &state(&canvas), n);
    assert_invariants(&canvas);
    let blurred = state(&canvas);
    stroke(
        &mut canvas,
        &blur,
        &line((cx - 60.0, cy + 30.0), (cx - 60.0, cy + 50.0), 4),
    );
    assert!(
        canvas.take_changes().is_none(),
        "blur without paint near changed the guide"
    );
    assert!(state(&canvas) == blurred);

    // Blur and smudge next to the background never paint it, nor take its colour.
    let (_, _, r) = object_disc(&canvas);
    stroke(
        &mut canvas,
        &brush(BrushKind::Fill, 1.0, 1.0, [1.0; 3]),
        &[(0.0, 0.0)],
    );
    stroke(
        &mut canvas,
        &blur,
        &line((cx + r, cy - 20.0), (cx + r, cy + 20.0), 4),
    );
    stroke(
        &mut canvas,
        &smudge,
        &line((cx + r + 20.0, cy), (cx + r - 30.0, cy), 6),
    );
    assert_invariants(&canvas);
    let rim = cy as usize * n + (cx + r - 3.0) as usize;
    let c = canvas.layers().colour.pixels[rim];
    assert!(
        c.iter().all(|v| (v - 1.0).abs() < 1e-5),
        "rim took the background: {c:?}"
    );
}

#[test]
fn lighten_and_darken_scale_the_colour_and_mark_it_painted() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    let i = cy as usize * n + cx as usize;
    let guide = canvas.base().pixels[i];
    stroke(
        &mut canvas,
        &brush(BrushKind::Lighten, 20.0, 1.0, [0.0; 3]),
        &[(cx, cy)],
    );
    assert!(canvas.layers().is_painted(i));
    assert_eq!(canvas.layers().colour.pixels[i], guide.map(|c| c * 2.0));
    let half = BrushSettings {
        opacity: 0.5,
        ..brush(BrushKind::Darken, 20.0, 1.0, [0.0; 3])
    };
    stroke(&mut canvas, &half, &[(cx, cy)]);
    assert_eq!(canvas.layers().colour.pixels[i], guide);
    assert_eq!(canvas.layers().coverage[i], 1.0);
}

#[test]
fn the_airbrush_builds_up_while_resting_up_to_the_opacity() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    let i = cy as usize * n + cx as usize;
    let settings = BrushSettings {
        flow: 0.1,
        opacity: 0.8,
        ..brush(BrushKind::Airbrush, 30.0, 0.0, [1.0, 0.0, 0.0])
    };
    canvas.begin_stroke(&settings, cx, cy, 1.0);
    let mut last = canvas.layers().coverage[i];
    assert!(last > 0.05 && last < 0.1, "{last}");
    for _ in 0..10 {
        canvas.airbrush_tick(0.1);
        let v = canvas.layers().coverage[i];
        assert!(v > last, "resting did not build up");
        last = v;
    }
    for _ in 0..100 {
        canvas.airbrush_tick(0.5);
    }
    let v = canvas.layers().coverage[i];
    assert!(v <= 0.8 + 1e-6 && v > 0.79, "{v}");
    canvas.end_stroke();
    // Ticking other brushes, or with no stroke, does nothing.
    canvas.take_changes();
    canvas.airbrush_tick(1.0);
    canvas.begin_stroke(&brush(BrushKind::Round, 10.0, 1.0, [0.0; 3]), 1.0, 1.0, 1.0);
    canvas.airbrush_tick(1.0);
    canvas.end_stroke();
    assert!(canvas.take_changes().is_none());
}

#[test]
fn the_undo_budget_drops_the_oldest_steps() {
    let mut canvas = canvas();
    let n = canvas.resolution();
    let (cx, cy, _) = object_disc(&canvas);
    // Five small dabs, each inside a different 64² tile.
    let spots: Vec<(f32, f32)> = [
        (-64.0, -64.0),
        (0.0, -64.0),
        (-64.0, 0.0),
        (0.0, 0.0),
        (64.0, 0.0),
    ]
    .iter()
    .map(|(dx, dy)| {
        (
            (cx / 64.0).floor() * 64.0 + 32.0 + dx,
            (cy / 64.0).floor() * 64.0 + 32.0 + dy,
        )
    })
    .collect();
    let dab = brush(BrushKind::Round, 10.0, 1.0, [1.0, 1.0, 0.0]);
    stroke(&mut canvas, &dab, &[spots[0]]);
    let step_bytes = canvas.undo_bytes();
    assert_eq!(step_bytes, 64 * 64 * 16, "one tile of colour and coverage");
    canvas.set_undo_budget(3 * step_bytes);
    for &spot in &spots[1..] {
        stroke(&mut canvas, &dab, &[spot]);
    }
    assert_eq!(canvas.undo_steps(), 3);
    assert_eq!(canvas.undo_bytes(), 3 * step_bytes);
    for _ in 0..3 {
        assert!(canvas.undo().is_some());
    }
    assert!(canvas.undo().is_none());
    let painted = |(x, y): (f32, f32)| canvas.layers().is_painted(y as usize * n + x as usize);
    assert!(painted(spots[0]) && painted(spots[1]));
    assert!(!painted(spots[2]) && !painted(spots[3]) && !painted(spots[4]));
    // Shrinking the budget drops steps (redo ones too, once undo is empty).
    canvas.set_undo_budget(step_bytes);
    assert_eq!(canvas.undo_bytes(), step_bytes);
    assert!(canvas.redo().is_some());
    assert!(canvas.redo().is_none());
}

fn shipped_presets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("brushes")
}

#[test]
fn the_shipped_presets_all_load_and_paint() {
    let (presets, errors) = load_presets(&shipped_presets());
    assert!(errors.is_empty(), "{errors:?}");
    let kinds: HashSet<BrushKind> = presets.iter().map(|p| p.settings.kind).collect();
    for kind in [
        BrushKind::Round,
        BrushKind::Airbrush,
        BrushKind::Eraser,
        BrushKind::Smudge,
        BrushKind::Blur,
        BrushKind::Lighten,
        BrushKind::Darken,
        BrushKind::Fill,
    ] {
        assert!(kinds.contains(&kind), "no {kind:?} preset");
    }
    let names: Vec<&str> = presets.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names[0], "Hard round", "file-name order");
    let chalk = presets
        .iter()
        .find(|p| p.name == "Chalk")
        .expect("a tip preset");
    let tip = chalk.tip.as_ref().expect("chalk has a tip");
    assert_eq!((tip.width(), tip.height()), (64, 64));

    let (cx, cy, _) = object_disc(&canvas());
    for preset in &presets {
        let mut canvas = canvas();
        canvas.fill(&brush(BrushKind::Fill, 1.0, 1.0, [0.2, 0.4, 0.6]));
        stroke(
            &mut canvas,
            &brush(BrushKind::Round, 20.0, 1.0, [2.0, 0.1, 0.1]),
            &[(cx, cy)],
        );
        canvas.take_changes();
        canvas.set_tip(preset.tip.clone());
        stroke(
            &mut canvas,
            &preset.settings,
            &line((cx - 20.0, cy - 5.0), (cx + 20.0, cy + 5.0), 8),
        );
        let changed = canvas.take_changes().map_or(0, |c| c.pixels.len());
        let paints = preset.settings.kind != BrushKind::Eyedropper;
        assert_eq!(
            changed > 0,
            paints,
            "{}: {changed} pixels changed",
            preset.name
        );
        assert_invariants(&canvas);
    }
    // The chalk tip leaves gaps where a round dab would not.
    let mut canvas = canvas();
    canvas.set_tip(chalk.tip.clone());
    // At a whole-pixel centre the 64 px tip maps one to one onto the canvas.
    let (cx, cy) = (cx.round(), cy.round());
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 64.0, 1.0, [1.0; 3]),
        &[(cx, cy)],
    );
    let n = canvas.resolution();
    let inside: Vec<f32> = (0..n * n)
        .filter(|&i| {
            let (x, y) = centre_of(i, n);
            (x - cx).hypot(y - cy) < 16.0
        })
        .map(|i| canvas.layers().coverage[i])
        .collect();
    let gaps = inside.iter().filter(|v| **v < 0.3).count();
    assert!(
        gaps > inside.len() / 10 && gaps < inside.len() * 9 / 10,
        "{gaps} of {}",
        inside.len()
    );
}

#[test]
fn bad_presets_are_reported_by_file_and_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let good = "name = \"Good\"\n[brush]\nkind = \"blur\"\nsize = 12.0\n";
    let files: BTreeMap<&str, (&str, &[&str])> = BTreeMap::from([
        ("a-good.toml", (good, &[][..])),
        (
            "b-syntax.toml",
            (
                "name = \"Broken\"\n[brush\nsize = 3\n",
                &["valid brush preset"][..],
            ),
        ),
        (
            "c-unknown.toml",
            ("name = \"U\"\n[brush]\nsise = 3.0\n", &["sise"][..]),
        ),
        (
            "d-missing-tip.toml",
            (
                "name = \"M\"\ntip = \"nope.png\"\n[brush]\n",
                &["nope.png"][..],
            ),
        ),
        (
            "e-corrupt-tip.toml",
            (
                "name = \"C\"\ntip = \"bad.png\"\n[brush]\n",
                &["bad.png", "PNG"][..],
            ),
        ),
        (
            "f-range.toml",
            (
                "name = \"R\"\n[brush]\nopacity = 2.0\n",
                &["opacity", "2"][..],
            ),
        ),
        ("g-no-brush.toml", ("name = \"B\"\n", &["brush"][..])),
        (
            "h-black-tip.toml",
            (
                "name = \"K\"\ntip = \"black.png\"\n[brush]\n",
                &["black.png", "nothing"][..],
            ),
        ),
        (
            "i-nan.toml",
            (
                "name = \"N\"\n[brush]\ncolour = [nan, 0.0, 0.0]\n",
                &["colour[0]"][..],
            ),
        ),
        (
            "j-kind.toml",
            ("name = \"K\"\n[brush]\nkind = \"spray\"\n", &["spray"][..]),
        ),
        (
            "k-top-level.toml",
            (
                "name = \"T\"\ncolour = [1.0, 1.0, 1.0]\n[brush]\n",
                &["colour"][..],
            ),
        ),
    ]);
    for (name, (text, _)) in &files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    std::fs::write(dir.path().join("bad.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    image::GrayImage::new(8, 8)
        .save(dir.path().join("black.png"))
        .unwrap();
    std::fs::write(dir.path().join("notes.txt"), "not a preset").unwrap();

    let (presets, errors) = load_presets(dir.path());
    assert_eq!(presets.len(), 1);
    assert_eq!(presets[0].name, "Good");
    assert_eq!(presets[0].settings.kind, BrushKind::Blur);
    assert_eq!(presets[0].settings.size, 12.0);
    assert_eq!(
        presets[0].settings.opacity,
        BrushSettings::default().opacity,
        "defaults fill in"
    );
    assert_eq!(errors.len(), files.len() - 1, "{errors:#?}");
    for ((name, (_, words)), error) in files.iter().skip(1).zip(&errors) {
        let text = error.to_string();
        assert!(
            text.contains(&*dir.path().join(name).to_string_lossy()),
            "{text}"
        );
        for word in *words {
            assert!(text.contains(word), "{name}: {text} (wanted {word:?})");
        }
    }
    let (none, errors) = load_presets(&dir.path().join("missing"));
    assert!(none.is_empty() && errors.len() == 1);
    assert!(errors[0].to_string().contains("missing"));
}

#[test]
fn from_layers_checks_sizes_and_values() {
    let mut canvas = canvas();
    let (cx, cy, _) = object_disc(&canvas);
    stroke(
        &mut canvas,
        &brush(BrushKind::Round, 30.0, 0.5, [5.0, 1.0, 0.0]),
        &[(cx, cy)],
    );
    let (guide, mask) = sphere_guide();
    let restored =
        Canvas::from_layers(guide.clone(), mask.clone(), canvas.layers().clone()).unwrap();
    assert!(state(&restored) == state(&canvas));
    assert!(!restored.can_undo());

    let small = RgbImage::filled(RESOLUTION as usize / 2, RESOLUTION as usize / 2, [0.1; 3]);
    let wrong = PaintLayers::unpainted(&small);
    let err = Canvas::from_layers(guide.clone(), mask.clone(), wrong)
        .err()
        .unwrap();
    assert!(matches!(err, CanvasError::SizeMismatch { .. }), "{err}");
    assert!(err.to_string().contains("pixels"));
    let err = Canvas::from_layers(guide.clone(), vec![true; 3], canvas.layers().clone())
        .err()
        .unwrap();
    assert!(err.to_string().contains("object mask"), "{err}");
    let mut bad = canvas.layers().clone();
    bad.colour.pixels[5] = [f32::NAN, 0.0, 0.0];
    let err = Canvas::from_layers(guide.clone(), mask.clone(), bad)
        .err()
        .unwrap();
    assert!(err.to_string().contains("pixel 5"), "{err}");
    let mut bad = canvas.layers().clone();
    bad.coverage[7] = 1.5;
    assert!(Canvas::from_layers(guide.clone(), mask.clone(), bad).is_err());
    // Paint off the object is dropped; unpainted pixels show the guide.
    let mut stray = canvas.layers().clone();
    stray.coverage[0] = 1.0;
    stray.colour.pixels[0] = [9.0; 3];
    stray.colour.pixels[1] = [9.0; 3];
    let repaired = Canvas::from_layers(guide.clone(), mask.clone(), stray).unwrap();
    assert!(state(&repaired) == state(&canvas));
}
