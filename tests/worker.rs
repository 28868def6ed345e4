//! The background worker: pixels in over the channel, snapshots out through arc-swap.
//! Its incremental state must equal a batch solve of the same paint, whatever the batching.

mod common;

use burnish::paint::PixelChange;
use burnish::scene::{GBuffer, Object, PaintRange, Scene, render_brdf, samples_from_image};
use burnish::solver::{Policy, Regularization, SampleKey, Solver, SparseTable};
use burnish::worker::{Command, Worker};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn view(light_azimuth: f64) -> (Scene, Arc<GBuffer>) {
    let mut scene = Scene {
        resolution: 96,
        ..Scene::default()
    };
    scene.light.azimuth_deg = light_azimuth;
    let object = Object::load(&scene.object_source()).unwrap();
    let gbuffer = Arc::new(GBuffer::build(&scene, &object));
    (scene, gbuffer)
}

/// A perfect painting of a held-out material on the view.
fn painting(gbuffer: &GBuffer) -> Vec<(u32, [f32; 3])> {
    let material = burnish::materials::database::material(0xfeed, 3);
    let image = render_brdf(gbuffer, material.brdf.as_ref());
    gbuffer
        .pixels()
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_some())
        .map(|(i, _)| (i as u32, image.pixels[i]))
        .collect()
}

fn sync(worker: &Worker) -> Arc<burnish::worker::Snapshot> {
    worker
        .sync(Duration::from_secs(60))
        .expect("the worker answers")
}

/// A view's id, its geometry and its painted pixels with their colours.
type PaintedView<'a> = (u32, &'a GBuffer, &'a [(u32, [f32; 3])]);

/// The coefficients a from-scratch batch solve gives for these samples.
fn batch_solution(basis: Arc<burnish::basis::Basis>, views: &[PaintedView]) -> Vec<[f64; 3]> {
    batch_solution_with(basis, views, burnish::solver::PriorModel::CALIBRATED)
}

/// [`batch_solution`] under `model`, its prior's mean fitted first when the model says so
/// (as `burnish reconstruct` does).
fn batch_solution_with(
    basis: Arc<burnish::basis::Basis>,
    views: &[PaintedView],
    model: burnish::solver::PriorModel,
) -> Vec<[f64; 3]> {
    let mut sparse = SparseTable::new(Policy::Mean);
    let mut changes = Vec::new();
    for &(view, gbuffer, paint) in views {
        for &(pixel, colour) in paint {
            if let Ok(s) = burnish::scene::sample_pixel(gbuffer, pixel as usize, colour) {
                sparse
                    .set_sample(
                        SampleKey { view, pixel },
                        s.light_bin,
                        s.view_bin,
                        s.rho,
                        &mut changes,
                    )
                    .unwrap();
            }
        }
    }
    let mut solver = Solver::with_model(basis, Regularization::Auto, model);
    let all: Vec<_> = sparse
        .observed()
        .map(|(pair, v)| burnish::solver::BinChange::observed(pair, v, burnish::solver::EXACT))
        .collect();
    solver.apply_all(&all);
    solver.rebuild();
    solver.refit_prior_mean();
    solver.solve().coefficients
}

/// A dab that paints `pixels` of `view` for the first time.
fn first_paint(view: u32, pixels: &[(u32, [f32; 3])]) -> Command {
    Command::Pixels {
        view,
        edits: pixels
            .iter()
            .map(|&(pixel, colour)| PixelChange {
                pixel,
                before: None,
                after: Some(colour),
            })
            .collect(),
        input_time: Instant::now(),
    }
}

fn close(a: &[[f64; 3]], b: &[[f64; 3]], tolerance: f64) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (0..3).all(|c| (x[c] - y[c]).abs() <= tolerance * (1.0 + y[c].abs())))
}

#[test]
fn dabs_in_any_batching_give_the_batch_solution() {
    let basis = common::small_basis(8);
    let (_, gbuffer) = view(30.0);
    let paint = painting(&gbuffer);
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    // On the database's mean, every snapshot comes from input (a fitted reference adds one
    // published without input: see a_sync_waits_for_the_prior_mean_fitted_to_the_paint).
    worker.send(Command::SetPriorMean(burnish::solver::PriorMean::Database));
    worker.send(Command::SetView {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::SetBasis(basis.clone()));
    let empty = sync(&worker);
    assert_eq!(empty.stats.samples, 0);
    assert!(empty.coefficients.iter().all(|c| *c == [0.0; 3]));

    // Dabs of uneven size, sent without waiting: the worker drains them in batches.
    let mut sent = 0;
    for (i, chunk) in paint.chunks(97).enumerate() {
        worker.send(first_paint(0, chunk));
        sent += 1;
        if i % 7 == 0 {
            std::thread::yield_now();
        }
    }
    let snapshot = sync(&worker);
    assert!(sent > 10);
    let on_database = burnish::solver::PriorModel {
        mean: burnish::solver::PriorMean::Database,
        ..burnish::solver::PriorModel::CALIBRATED
    };
    let expected = batch_solution_with(basis.clone(), &[(0, &gbuffer, &paint)], on_database);
    assert!(
        close(&snapshot.coefficients, &expected, 1e-9),
        "incremental {:?} vs batch {:?}",
        &snapshot.coefficients[..2],
        &expected[..2]
    );
    assert!(snapshot.stats.samples > 1000);
    assert!(snapshot.oldest_input.is_some());

    // The bin changes carry the sparse table: every observed bin arrives, with its value.
    let updates = worker.take_bin_updates();
    let mut mirrored = std::collections::HashMap::new();
    for u in updates {
        match u.after {
            Some(v) => mirrored.insert(u.pair, v),
            None => mirrored.remove(&u.pair),
        };
    }
    assert_eq!(mirrored.len(), snapshot.stats.observed_bins);
}

#[test]
fn erasing_every_pixel_returns_to_the_mean_material() {
    let basis = common::small_basis(8);
    let (_, gbuffer) = view(30.0);
    let paint = painting(&gbuffer);
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    worker.send(Command::SetView {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::SetBasis(basis));
    worker.send(Command::ReplacePaint {
        view: 0,
        painted: paint.clone(),
        range: PaintRange::Hdr,
    });
    assert!(sync(&worker).stats.samples > 0);
    worker.send(Command::Pixels {
        view: 0,
        edits: paint
            .iter()
            .map(|&(pixel, colour)| PixelChange {
                pixel,
                before: Some(colour),
                after: None,
            })
            .collect(),
        input_time: Instant::now(),
    });
    let snapshot = sync(&worker);
    assert_eq!(snapshot.stats.samples, 0);
    assert_eq!(snapshot.stats.observed_bins, 0);
    assert!(
        snapshot
            .coefficients
            .iter()
            .all(|c| c.iter().all(|v| v.abs() < 1e-9)),
        "no sample, no deviation from the mean"
    );
}

#[test]
fn paint_before_the_basis_is_solved_when_it_arrives() {
    let basis = common::small_basis(8);
    let (_, gbuffer) = view(30.0);
    let paint = painting(&gbuffer);
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    worker.send(Command::SetView {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::ReplacePaint {
        view: 0,
        painted: paint.clone(),
        range: PaintRange::Hdr,
    });
    let waiting = sync(&worker);
    assert!(waiting.basis.is_none());
    assert!(waiting.stats.samples > 0, "samples gather without a basis");
    assert!(waiting.coefficients.is_empty());
    worker.send(Command::SetBasis(basis.clone()));
    let solved = sync(&worker);
    assert!(solved.basis.is_some());
    let expected = batch_solution(basis, &[(0, &gbuffer, &paint)]);
    assert!(close(&solved.coefficients, &expected, 1e-9));
}

#[test]
fn views_mute_move_and_close() {
    let basis = common::small_basis(8);
    let (mut scene_b, gbuffer_a) = view(30.0);
    let (_, gbuffer_b) = view(-70.0);
    let (paint_a, paint_b) = (painting(&gbuffer_a), painting(&gbuffer_b));
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    worker.send(Command::SetBasis(basis.clone()));
    for (id, g, p) in [(0, &gbuffer_a, &paint_a), (1, &gbuffer_b, &paint_b)] {
        worker.send(Command::SetView {
            view: id,
            gbuffer: g.clone(),
        });
        worker.send(Command::ReplacePaint {
            view: id,
            painted: p.clone(),
            range: PaintRange::Hdr,
        });
    }
    let both = sync(&worker);
    let expected = batch_solution(
        basis.clone(),
        &[(0, &gbuffer_a, &paint_a), (1, &gbuffer_b, &paint_b)],
    );
    assert!(close(&both.coefficients, &expected, 1e-9));

    worker.send(Command::MuteView {
        view: 1,
        muted: true,
    });
    let muted = sync(&worker);
    let only_a = batch_solution(basis.clone(), &[(0, &gbuffer_a, &paint_a)]);
    assert!(close(&muted.coefficients, &only_a, 1e-9));
    worker.send(Command::MuteView {
        view: 1,
        muted: false,
    });
    assert!(close(&sync(&worker).coefficients, &expected, 1e-9));

    // Moving view 1's light re-bins the paint it holds.
    scene_b.light.azimuth_deg = 120.0;
    let object = Object::load(&scene_b.object_source()).unwrap();
    let moved = Arc::new(GBuffer::build(&scene_b, &object));
    worker.send(Command::SetView {
        view: 1,
        gbuffer: moved.clone(),
    });
    let expected_moved = batch_solution(
        basis.clone(),
        &[(0, &gbuffer_a, &paint_a), (1, &moved, &paint_b)],
    );
    assert!(close(&sync(&worker).coefficients, &expected_moved, 1e-9));

    worker.send(Command::RemoveView(1));
    let closed = sync(&worker);
    assert!(close(&closed.coefficients, &only_a, 1e-9));
    let samples_a = samples_from_image(&gbuffer_a, &{
        let mut image = burnish::scene::guide_image(&gbuffer_a);
        for &(p, c) in &paint_a {
            image.pixels[p as usize] = c;
        }
        image
    })
    .samples
    .len();
    assert_eq!(closed.stats.samples, samples_a);
}

/// The analysis thread: a prediction is the snapshot's BRDF rendered for the geometry asked
/// about, the uncertainty has one finite non-negative deviation per pair and is smaller
/// where the view observes, ranked views come best first; without a basis each request is
/// answered as such.
#[test]
fn analyses_answer_from_the_state_when_asked() {
    use burnish::worker::{Analysis, AnalysisKind};
    let (scene, gbuffer) = view(30.0);
    let paint = painting(&gbuffer);
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    let wait = || {
        worker
            .wait_analysis(Duration::from_secs(120))
            .expect("the analysis thread answers")
    };
    worker.send(Command::Predict {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    match wait() {
        Analysis::NoBasis { what } => assert_eq!(what, AnalysisKind::Prediction { view: 0 }),
        other => panic!("without a basis: {other:?}"),
    }

    let basis = common::small_basis(8);
    worker.send(Command::SetBasis(basis.clone()));
    worker.send(Command::SetView {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::ReplacePaint {
        view: 0,
        painted: paint.clone(),
        range: PaintRange::Hdr,
    });
    worker.send(Command::Predict {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::EstimateUncertainty);
    let object = Arc::new(Object::load(&scene.object_source()).unwrap());
    worker.send(Command::RankViews {
        request: 7,
        base: Box::new(scene.clone()),
        object,
        candidates: 6,
    });
    let snapshot = sync(&worker);
    let table = snapshot
        .reconstruction()
        .expect("a basis is ready")
        .materialize();
    let (mut predicted, mut uncertain, mut ranked) = (false, false, false);
    for _ in 0..3 {
        match wait() {
            Analysis::Prediction {
                view,
                version,
                image,
                ..
            } => {
                assert_eq!((view, version), (0, snapshot.version));
                assert!(image == burnish::scene::render_table(&gbuffer, &table));
                predicted = true;
            }
            Analysis::Uncertainty {
                version,
                table: per_channel,
                luminance: std_dev,
            } => {
                assert!(
                    per_channel
                        .pairs()
                        .iter()
                        .flatten()
                        .all(|s| s.is_finite() && *s >= 0.0)
                );
                assert_eq!(version, snapshot.version);
                assert_eq!(std_dev.len(), burnish::table::PAIRS);
                assert!(std_dev.iter().all(|s| s.is_finite() && *s >= 0.0));
                let mut observed = Vec::new();
                let mut unobserved = Vec::new();
                let seen: std::collections::HashSet<usize> = paint
                    .iter()
                    .filter_map(|&(pixel, _)| {
                        let p = gbuffer.at(pixel as usize)?;
                        Some(burnish::table::pair_index(p.light_bin?, p.view_bin?).index())
                    })
                    .collect();
                for (i, s) in std_dev.iter().enumerate() {
                    if seen.contains(&i) {
                        observed.push(*s as f64);
                    } else {
                        unobserved.push(*s as f64);
                    }
                }
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
                assert!(
                    mean(&observed) < mean(&unobserved),
                    "observed pairs are less uncertain ({} vs {})",
                    mean(&observed),
                    mean(&unobserved)
                );
                uncertain = true;
            }
            Analysis::RankedViews { request, views, .. } => {
                assert_eq!(request, 7);
                assert_eq!(views.len(), 6);
                assert!(views.windows(2).all(|w| w[0].score >= w[1].score));
                ranked = true;
            }
            other => panic!("with a basis: {other:?}"),
        }
    }
    assert!(predicted && uncertain && ranked);
}

/// With the prior centred on a fit of the paint, the worker fits off its solve loop and a
/// sync waits for the fit: what it returns is what a one-shot solve of the same bins gives
/// (`burnish reconstruct --prior-mean`), and differs from the database-centred solve.
#[test]
fn a_sync_waits_for_the_prior_mean_fitted_to_the_paint() {
    use burnish::solver::{PriorMean, PriorModel};
    let basis = common::small_basis(8);
    let (_, gbuffer) = view(30.0);
    let paint = painting(&gbuffer);
    let always = PriorMean::Fitted {
        margin_nats: f64::NEG_INFINITY,
        beckmann_margin: None,
        coat_margin: None,
        edge_margin: None,
        haze_margin: None,
        rough_margin: None,
        grazing_weight: None,
        dielectric_margin: None,
        phong_margin: None,
        gtr_margin: None,
        closer_margin: None,
        cavity_margin: None,
    };
    let worker = Worker::spawn(Policy::Mean, Regularization::Auto);
    worker.send(Command::SetPriorMean(always));
    worker.send(Command::SetView {
        view: 0,
        gbuffer: gbuffer.clone(),
    });
    worker.send(Command::SetBasis(basis.clone()));
    for chunk in paint.chunks(300) {
        worker.send(first_paint(0, chunk));
    }
    let snapshot = sync(&worker);
    assert!(!snapshot.fitting_mean, "a sync answers once the fit is in");
    assert!(
        snapshot.reference.is_some(),
        "the snapshot carries the fit its coefficients are measured from"
    );

    let model = PriorModel {
        mean: always,
        ..PriorModel::CALIBRATED
    };
    let expected = batch_solution_with(basis.clone(), &[(0, &gbuffer, &paint)], model);
    assert!(
        close(&snapshot.coefficients, &expected, 1e-9),
        "worker {:?} vs one-shot {:?}",
        &snapshot.coefficients[..2],
        &expected[..2]
    );
    let on_database = PriorModel {
        mean: PriorMean::Database,
        ..PriorModel::CALIBRATED
    };
    let database = batch_solution_with(basis, &[(0, &gbuffer, &paint)], on_database);
    assert!(
        !close(&snapshot.coefficients, &database, 1e-3),
        "the fitted mean moved the solution"
    );

    // Back to the database's mean: the same paint solves as it always did.
    worker.send(Command::SetPriorMean(PriorMean::Database));
    let back = sync(&worker);
    assert!(back.reference.is_none());
    assert!(close(&back.coefficients, &database, 1e-9));
}
