//! The document without a window: views, imports, the worker and session files driven as a
//! script would drive them, with no egui in sight. What it solves is held against what
//! `burnish reconstruct` computes from the same files.

mod common;

use burnish::basis::Basis;
use burnish::document::{BasisSource, Document, DocumentConfig, Event, painting_mask_path};
use burnish::image_io::RgbImage;
use burnish::paint::{BrushSettings, UnpaintedPixels};
use burnish::scene::{PaintRange, Scene, read_painting, samples_from_file, write_image, write_png};
use burnish::session::BasisSettings;
use burnish::solver::{Policy, Regularization, Solver, SparseTable};
use burnish::worker::Snapshot;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

const RESOLUTION: usize = 128;

/// A document on `basis`, without autosave, its basis taken in.
fn headless(basis: &Arc<Basis>) -> Document {
    let mut doc = Document::new(DocumentConfig {
        basis: BasisSource::Given(basis.clone()),
        basis_cache: None,
        basis_settings: BasisSettings {
            components: basis.components(),
            ..Default::default()
        },
        autosave: false,
        recovery_file: None,
    });
    doc.poll();
    doc
}

/// The snapshot that includes everything the document has sent the worker.
fn synced(doc: &mut Document) -> Arc<Snapshot> {
    doc.poll();
    doc.worker()
        .sync(Duration::from_secs(60))
        .expect("the worker answers")
}

/// [`headless`] with one default sphere view of [`RESOLUTION`]².
fn sphere_document(basis: &Arc<Basis>) -> Document {
    let mut doc = headless(basis);
    doc.add_view(Scene {
        resolution: RESOLUTION as u32,
        ..Scene::default()
    })
    .unwrap();
    doc
}

/// The texts of the notices the document raised since the last call.
fn notices(doc: &mut Document) -> Vec<String> {
    doc.take_events()
        .into_iter()
        .filter_map(|e| match e {
            Event::Notice(n) => Some(n.text),
            _ => None,
        })
        .collect()
}

/// The default sphere's guide, warmed and brightened "in an external editor" until its lit
/// side clips, as an 8-bit PNG in `dir`.
fn clipped_png(doc: &mut Document, dir: &Path) -> std::path::PathBuf {
    let guide = dir.join("guide.png");
    doc.export_guide(&guide).unwrap();
    let mut image = read_painting(&guide, RESOLUTION).unwrap();
    for p in &mut image.pixels {
        *p = [p[0] * 2.5, p[1] * 1.4, p[2] * 0.7];
    }
    let painting = dir.join("painting.png");
    write_png(&painting, &image).unwrap();
    let clipped = read_painting(&painting, RESOLUTION)
        .unwrap()
        .pixels
        .iter()
        .filter(|p| p[0] == 1.0)
        .count();
    assert!(clipped > 1_000, "{clipped} clipped pixels");
    painting
}

/// A document with one default sphere view into which [`clipped_png`] was imported.
fn imported_8_bit_view(basis: &Arc<Basis>, dir: &Path) -> (Document, std::path::PathBuf) {
    let mut doc = sphere_document(basis);
    let painting = clipped_png(&mut doc, dir);
    doc.import_painting(&painting).unwrap();
    (doc, painting)
}

/// What `burnish reconstruct --view SCENE=PAINTING` solves, through the same public parts
/// it uses: the painting's samples read by the file's kind (or as `range` says), binned and
/// solved by the default prior.
fn reconstruct_like_the_cli(
    basis: &Arc<Basis>,
    doc: &Document,
    painting: &Path,
    range: PaintRange,
) -> Vec<[f64; 3]> {
    let gbuffer = doc.views()[0].gbuffer();
    let set = match range {
        PaintRange::Ldr => samples_from_file(gbuffer, painting).unwrap(),
        PaintRange::Hdr => burnish::scene::samples_from_image(
            gbuffer,
            &read_painting(painting, RESOLUTION).unwrap(),
        ),
    };
    solver_of_sets(basis, &[set]).solve().coefficients
}

/// The default prior's solver with the samples of `sets[i]` binned as view i's.
fn solver_of_sets(basis: &Arc<Basis>, sets: &[burnish::scene::SampleSet]) -> Solver {
    let mut table = SparseTable::new(Policy::Mean);
    let mut changes = Vec::new();
    for (i, set) in sets.iter().enumerate() {
        set.insert_into(i as u32, &mut table, &mut changes).unwrap();
    }
    let mut solver = Solver::new(basis.clone(), Regularization::Auto);
    solver.apply_all(&changes);
    solver.refit_prior_mean();
    solver
}

/// The largest difference between two coefficient sets, relative to the largest coefficient.
fn relative_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b
        .iter()
        .flatten()
        .fold(0.0f64, |m, c| m.max(c.abs()))
        .max(1e-12);
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0, f64::max)
        / scale
}

#[test]
fn an_8_bit_import_solves_as_burnish_reconstruct_reads_the_file() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    let (mut doc, painting) = imported_8_bit_view(&basis, dir.path());
    assert_eq!(doc.views()[0].paint_range(), PaintRange::Ldr);
    let said = notices(&mut doc);
    assert!(
        said.iter().any(|t| t.contains("8 bits")),
        "the import says how it reads the file: {said:?}"
    );

    let bounded = reconstruct_like_the_cli(&basis, &doc, &painting, PaintRange::Ldr);
    let exact = reconstruct_like_the_cli(&basis, &doc, &painting, PaintRange::Hdr);
    let apart = relative_difference(&bounded, &exact);
    assert!(apart > 1e-3, "the bounds change the solve ({apart})");
    let snapshot = synced(&mut doc);
    let worst = relative_difference(&snapshot.coefficients, &bounded);
    assert!(worst < 1e-6, "document and CLI differ by {worst}");

    // Read as exact, the same paint gives the exact solve.
    doc.set_paint_range(0, PaintRange::Hdr);
    let snapshot = synced(&mut doc);
    let worst = relative_difference(&snapshot.coefficients, &exact);
    assert!(
        worst < 1e-6,
        "read as exact: document and CLI differ by {worst}"
    );
}

#[test]
fn a_saved_8_bit_view_reopens_read_the_same_way() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    let (mut doc, _) = imported_8_bit_view(&basis, dir.path());
    let before = synced(&mut doc);
    let session = dir.path().join("work.burnish");
    doc.save_session(&session, &BrushSettings::default())
        .unwrap();
    assert!(!doc.is_dirty());

    let mut reopened = headless(&basis);
    reopened.open_session(&session).unwrap();
    assert_eq!(reopened.views()[0].paint_range(), PaintRange::Ldr);
    let after = synced(&mut reopened);
    assert_eq!(after.stats.samples, before.stats.samples);
    let worst = relative_difference(&after.coefficients, &before.coefficients);
    assert!(
        worst < 1e-9,
        "the reopened session solves otherwise ({worst})"
    );
}

/// A painting with the mask `burnish reconstruct --mask` reads beside it imports with only
/// the marked pixels painted, exports the same mask back, and under "ignore unpainted"
/// solves as `burnish reconstruct --unpainted ignore --mask` does.
#[test]
fn a_painting_imports_with_the_mask_beside_it() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    let mut doc = sphere_document(&basis);
    let guide = dir.path().join("guide.png");
    doc.export_guide(&guide).unwrap();
    let mut image = read_painting(&guide, RESOLUTION).unwrap();
    for p in &mut image.pixels {
        *p = [p[0] * 1.3, p[1], p[2] * 0.6];
    }
    let painting = dir.path().join("painting.exr");
    write_image(&painting, &image).unwrap();
    let left = |i: usize| i % RESOLUTION < RESOLUTION / 2;
    let mask = RgbImage {
        width: RESOLUTION,
        height: RESOLUTION,
        pixels: (0..RESOLUTION * RESOLUTION)
            .map(|i| if left(i) { [1.0; 3] } else { [0.0; 3] })
            .collect(),
    };
    write_png(painting_mask_path(&painting), &mask).unwrap();
    doc.take_events();
    doc.import_painting(&painting).unwrap();
    let said = notices(&mut doc);
    assert!(
        said.iter().any(|t| t.contains("painting-mask.png")),
        "the import names the mask it read: {said:?}"
    );

    let canvas = doc.views()[0].canvas();
    let object = canvas.object_mask().to_vec();
    let expected: Vec<bool> = (0..object.len()).map(|i| object[i] && left(i)).collect();
    assert!(expected.iter().filter(|&&p| p).count() > 1_000);
    assert!(expected.iter().zip(object.iter()).any(|(&p, &o)| o && !p));
    for (i, &c) in canvas.layers().coverage.iter().enumerate() {
        assert_eq!(c > 0.0, expected[i], "pixel {i}");
    }
    let again = dir.path().join("again.exr");
    doc.export_painting(&again).unwrap();
    let written = read_painting(painting_mask_path(&again), RESOLUTION).unwrap();
    for (i, p) in written.pixels.iter().enumerate() {
        assert_eq!(p[0] > 0.0, expected[i], "exported mask, pixel {i}");
    }

    doc.set_unpainted(0, UnpaintedPixels::Ignore);
    let snapshot = synced(&mut doc);
    let gbuffer = doc.views()[0].gbuffer().clone();
    let mut set = samples_from_file(&gbuffer, &painting).unwrap();
    set.samples.retain(|s| left(s.pixel as usize));
    let cli = solver_of_sets(&basis, std::slice::from_ref(&set))
        .solve()
        .coefficients;
    assert_eq!(snapshot.stats.samples, set.samples.len());
    let worst = relative_difference(&snapshot.coefficients, &cli);
    assert!(worst < 1e-6, "document and CLI differ by {worst}");
}

/// A mask beside the painting that does not fit the view refuses the import, names the mask
/// and leaves the canvas as it was.
#[test]
fn a_mask_of_the_wrong_size_refuses_the_import_and_names_the_mask() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    let mut doc = sphere_document(&basis);
    let painting = dir.path().join("painting.png");
    doc.export_guide(&painting).unwrap();
    let small = RgbImage {
        width: 16,
        height: 16,
        pixels: vec![[1.0; 3]; 256],
    };
    write_png(painting_mask_path(&painting), &small).unwrap();
    let before = doc.views()[0].canvas().layers().coverage.clone();
    let error = doc.import_painting(&painting).unwrap_err().to_string();
    assert!(
        error.contains("painting-mask.png") && error.contains("16 × 16"),
        "{error}"
    );
    assert_eq!(doc.views()[0].canvas().layers().coverage, before);
}

/// What `reconstruct` solved before it drove a document: every `(scene, painting)` read
/// whole as view i, binned and solved by the default prior.
fn solver_of_views(basis: &Arc<Basis>, doc: &Document, paintings: &[&Path]) -> Solver {
    let sets: Vec<_> = paintings
        .iter()
        .enumerate()
        .map(|(i, painting)| samples_from_file(doc.views()[i].gbuffer(), painting).unwrap())
        .collect();
    solver_of_sets(basis, &sets)
}

/// Two views painted elsewhere: the guide of each, tinted, as an EXR in `dir`.
fn tinted_guides(doc: &mut Document, dir: &Path, tints: &[[f32; 3]]) -> Vec<std::path::PathBuf> {
    let mut paths = Vec::new();
    for (i, tint) in tints.iter().enumerate() {
        doc.set_active(i);
        let guide = dir.join(format!("guide{i}.png"));
        doc.export_guide(&guide).unwrap();
        let mut image = read_painting(&guide, RESOLUTION).unwrap();
        for p in &mut image.pixels {
            *p = [p[0] * tint[0], p[1] * tint[1], p[2] * tint[2]];
        }
        let painting = dir.join(format!("painting{i}.exr"));
        write_image(&painting, &image).unwrap();
        paths.push(painting);
    }
    paths
}

/// A view added while a BRDF exists starts from its prediction, which arrives later. A
/// painting imported at once, before it arrives, stays the view's paint: the document then
/// solves what `reconstruct` solves from the same files, and the late prediction only goes
/// under the paint.
#[test]
fn a_painting_imported_before_the_prediction_arrives_stays_the_paint() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    // The paintings, made from the guides of the two scenes.
    let second = Scene {
        resolution: RESOLUTION as u32,
        light: burnish::scene::LightSettings {
            elevation_deg: 30.0,
            azimuth_deg: -70.0,
        },
        ..Scene::default()
    };
    let mut scratch = sphere_document(&basis);
    scratch.add_view(second.clone()).unwrap();
    let paintings = tinted_guides(
        &mut scratch,
        dir.path(),
        &[[1.2, 1.0, 0.7], [0.9, 1.1, 1.3]],
    );

    let mut doc = sphere_document(&basis);
    doc.import_painting(&paintings[0]).unwrap();
    synced(&mut doc);
    doc.add_view(second).unwrap();
    assert!(doc.predictions_pending(), "view 2 waits for its prediction");
    doc.import_painting(&paintings[1]).unwrap();
    let snapshot = doc.settle(Duration::from_secs(60)).unwrap();
    assert!(!doc.predictions_pending());
    assert_eq!(doc.views()[1].base(), burnish::document::Base::Prediction);
    let view = &doc.views()[1];
    let imported = read_painting(&paintings[1], RESOLUTION).unwrap();
    for (i, &inside) in view.canvas().object_mask().iter().enumerate() {
        if inside {
            assert_eq!(view.canvas().layers().coverage[i], 1.0, "pixel {i} painted");
            assert_eq!(view.canvas().layers().colour.pixels[i], imported.pixels[i]);
        }
    }

    let solver = solver_of_views(&basis, &doc, &[&paintings[0], &paintings[1]]);
    let worst = relative_difference(&snapshot.coefficients, &solver.solve().coefficients);
    assert!(worst < 1e-6, "document and CLI differ by {worst}");

    // The uncertainty it reports is the solver's, per channel.
    let sd = doc.settled_uncertainty(Duration::from_secs(60)).unwrap();
    let expected = solver
        .posterior()
        .table_std_dev(&solver.solve().reconstruction(basis.clone()));
    let scale = expected
        .pairs()
        .iter()
        .flatten()
        .fold(0.0f32, |m, s| m.max(*s));
    let worst = sd
        .pairs()
        .iter()
        .zip(expected.pairs())
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0f32, f32::max);
    assert!(
        scale > 0.0 && worst <= 1e-5 * scale,
        "uncertainty differs by {worst} of {scale}"
    );

    // The ranking of next views is the solver's too.
    let ranked = doc.settled_ranking(8, Duration::from_secs(120)).unwrap();
    let candidates = burnish::next_view::candidate_scenes(doc.views()[1].scene(), 8);
    let observed = doc.observed().collect();
    let direct =
        burnish::next_view::rank_views(&solver, doc.views()[1].object(), &candidates, &observed);
    assert_eq!(ranked.len(), direct.len());
    for (a, b) in ranked.iter().zip(&direct) {
        assert_eq!((a.bins, a.new_bins), (b.bins, b.new_bins));
        assert!(
            (a.score - b.score).abs() <= 1e-6 * b.score.abs().max(1e-30),
            "{} vs {}",
            a.score,
            b.score
        );
    }
}

/// NaN, infinite or negative paint on the object refuses an import and leaves the canvas as
/// it was, naming the file, the count and the first pixel; in the background, where it is
/// no paint, it is ignored (as `burnish reconstruct` reads the same file).
#[test]
fn an_import_refuses_bad_paint_on_the_object_only() {
    let basis = common::small_basis(8);
    let dir = tempfile::tempdir().unwrap();
    let mut doc = sphere_document(&basis);
    let guide = dir.path().join("guide.png");
    doc.export_guide(&guide).unwrap();
    let mut image = read_painting(&guide, RESOLUTION).unwrap();
    let mask = doc.views()[0].canvas().object_mask().to_vec();
    let background = mask.iter().position(|&m| !m).unwrap();
    image.pixels[background] = [f32::NAN, -1.0, f32::INFINITY];
    let painting = dir.path().join("painting.exr");
    write_image(&painting, &image).unwrap();
    let report = doc.import_painting(&painting).unwrap();
    assert_eq!(report.bad_paint, 0);
    assert!(report.counts.used > 1_000);
    let coverage = doc.views()[0].canvas().layers().coverage.clone();
    assert!(
        doc.views()[0]
            .canvas()
            .layers()
            .colour
            .pixels
            .iter()
            .flatten()
            .all(|c| c.is_finite())
    );

    let inside: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
    let (first, second) = (inside[10], inside[inside.len() / 2]);
    image.pixels[first] = [0.1, f32::NAN, 0.1];
    image.pixels[second] = [0.1, 0.1, -0.5];
    write_image(&painting, &image).unwrap();
    let error = doc.import_painting(&painting).unwrap_err().to_string();
    let at = format!("x = {}, y = {}", first % RESOLUTION, first / RESOLUTION);
    for expected in [
        "painting.exr",
        "2 pixels",
        "NaN, infinite or negative",
        at.as_str(),
    ] {
        assert!(
            error.contains(expected),
            "'{expected}' missing from: {error}"
        );
    }
    assert_eq!(doc.views()[0].canvas().layers().coverage, coverage);
}
