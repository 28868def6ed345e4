//! Does following the suggestion beat a random next view? For each held-out material, one
//! view is painted (the SCENE.md default light), the next-view candidates of `burnish suggest`
//! are ranked, and a second view is painted either where the ranking says or at candidates
//! drawn at random from the same list; each two-view reconstruction is scored against the truth.

use super::VIEWS;
use crate::basis::Basis;
use crate::metrics::table_errors;
use crate::next_view::{candidate_scenes, rank_views};
use crate::scene::{GBuffer, Object, PaintRange, Scene, render_table, samples_from_image_in};
use crate::solver::{Policy, PriorModel, Regularization, Solver, SparseTable};
use crate::table::SymTable;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use std::collections::BTreeSet;
use std::sync::Arc;

/// What the trial does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrialOptions {
    /// Candidates ranked, as `burnish suggest --candidates`.
    pub candidates: usize,
    /// Random second views tried per material (distinct candidates).
    pub random_picks: usize,
    pub resolution: u32,
}

/// One material's result.
#[derive(Clone, Debug, PartialEq)]
pub struct NextViewTrial {
    pub material: String,
    /// Relative RMSE with the first view alone.
    pub one_view: f64,
    /// With the suggested second view.
    pub suggested: f64,
    /// With each random second view.
    pub random: Vec<f64>,
    /// The suggested view's light (elevation, azimuth) and camera (yaw, pitch), degrees.
    pub suggested_view: [f64; 4],
}

impl NextViewTrial {
    pub fn random_mean(&self) -> f64 {
        self.random.iter().sum::<f64>() / self.random.len().max(1) as f64
    }
}

/// Paints `scenes` of `truth` in order into one sparse table and sets up the solve under the
/// default prior; also returns the observed bins.
fn reconstruct(
    basis: &Arc<Basis>,
    truth: &SymTable,
    scenes: &[Scene],
    object: &Object,
) -> (Solver, BTreeSet<crate::table::PairIndex>) {
    let mut table = SparseTable::new(Policy::Mean);
    let mut changes = Vec::new();
    for (view, scene) in scenes.iter().enumerate() {
        let gbuffer = GBuffer::build(scene, object);
        let painting = render_table(&gbuffer, truth);
        samples_from_image_in(&gbuffer, &painting, PaintRange::Hdr)
            .insert_into(view as u32, &mut table, &mut changes)
            .expect("a render of a physical table is finite and non-negative");
    }
    let mut solver =
        Solver::with_model(basis.clone(), Regularization::Auto, PriorModel::CALIBRATED);
    solver.apply_all(&changes);
    solver.refit_prior_mean();
    (solver, table.observed().map(|(pair, _)| pair).collect())
}

fn score(basis: &Arc<Basis>, truth: &SymTable, solver: &Solver) -> f64 {
    let solution = solver.solve();
    let estimate = solution.reconstruction(basis.clone()).materialize();
    table_errors(truth, &estimate).relative_rmse
}

/// Runs the trial on one material; `seed` fixes its random picks.
pub fn trial(
    name: &str,
    truth: &SymTable,
    basis: &Arc<Basis>,
    options: TrialOptions,
    seed: u64,
) -> NextViewTrial {
    let object = Object::builtin(crate::scene::BuiltinShape::Sphere);
    let first = VIEWS[0].scene(options.resolution);
    let (solver, painted) = reconstruct(basis, truth, std::slice::from_ref(&first), &object);
    let one_view = score(basis, truth, &solver);
    let candidates = candidate_scenes(&first, options.candidates);
    let ranked = rank_views(&solver, &object, &candidates, &painted);
    let best = ranked[0].scene.clone();
    let with = |second: &Scene| {
        let (solver, _) = reconstruct(basis, truth, &[first.clone(), second.clone()], &object);
        score(basis, truth, &solver)
    };
    let suggested = with(&best);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.shuffle(&mut rng);
    let random = order
        .iter()
        .take(options.random_picks)
        .map(|&i| with(&candidates[i]))
        .collect();
    NextViewTrial {
        material: name.to_string(),
        one_view,
        suggested,
        random,
        suggested_view: [
            best.light.elevation_deg,
            best.light.azimuth_deg,
            best.camera.yaw_deg,
            best.camera.pitch_deg,
        ],
    }
}
