//! The background worker: changed pixels in, immutable solution snapshots out.
//!
//! The UI sends [`Command`]s over a crossbeam channel and never waits: the worker drains
//! everything queued, applies it to the sparse table and the normal equations incrementally,
//! solves once for the whole batch and publishes a [`Snapshot`] through arc-swap. Changes of
//! the sparse table itself (for the sparse-only preview and the overlays) go out as the
//! sparse table's own [`BinChange`]s, one per bin and batch, on a second channel, so none is
//! lost when the UI skips snapshots. They are the UI's only source of observed and
//! inconsistent bins.
//!
//! The worker mirrors what each view says (pixel → linear colour: the painted pixels, or every
//! object pixel when the view counts unpainted pixels as shown; the app decides), so muting a
//! view, moving its light or swapping the basis re-derives the samples without asking the
//! canvas.
//!
//! The prior's mean, when the model fits it to the paint ([`crate::solver::fitted_mean`]),
//! is fitted on a third thread, the fit thread, from a copy of the bins, so a stroke never
//! waits for it: each snapshot uses the newest fit installed, and a new fit starts whenever
//! the bins changed since the last one began. [`Command::Sync`] and the analysis requests
//! are answered once the fit belongs to the bins painted now, so what they see is what
//! `burnish reconstruct` computes from the same paint.
//!
//! Work too slow for the solve loop (a prediction of the BRDF for a view, the table's
//! uncertainty, the ranking of candidate next views) runs on a second thread, the analysis
//! thread, from a copy of the worker's state when it was asked; its answers come back as
//! [`Analysis`] values on a third channel.

use crate::basis::Basis;
use crate::basis::OracleProjector;
use crate::image_io::RgbImage;
use crate::next_view::{RankedView, candidate_scenes, rank_views};
use crate::paint::PixelChange;
use crate::scene::{GBuffer, Object, PaintRange, Scene, render_table, sample_pixel_in};
use crate::solver::{
    BinChange, FittedMean, FittedReference, MeanFitRequest, Policy, PriorMean, PriorModel,
    Reconstruction, Regularization, SampleKey, Solver, SparseTable,
};
use crate::table::{PairIndex, SymTable};
use arc_swap::ArcSwap;
use crossbeam_channel::{Receiver, Sender, TryRecvError, select, unbounded};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long paint must be still before the worker fits the prior's mean to it.
const FIT_SETTLE: Duration = Duration::from_millis(150);

/// A view's identity, shared by the canvas, the worker and the sparse table's sample keys.
pub type ViewId = u32;

/// What the UI asks of the worker.
#[derive(Clone, Debug)]
pub enum Command {
    /// A view appears, or its scene changed: its pixels map to new bins. Painted pixels the
    /// worker already holds for it are re-binned.
    SetView {
        view: ViewId,
        gbuffer: Arc<GBuffer>,
    },
    /// A view is closed: its samples and paint are forgotten.
    RemoveView(ViewId),
    /// A muted view keeps its paint but gives no samples.
    MuteView {
        view: ViewId,
        muted: bool,
    },
    /// Pixels of a view changed, each as what it states (see [`PixelChange`]). `input_time`
    /// is when the pointer event that caused them happened, for latency measurement.
    Pixels {
        view: ViewId,
        edits: Vec<PixelChange>,
        input_time: Instant,
    },
    /// Replace every pixel a view states at once (import, session open, a new base under the
    /// paint, a change of the view's rule for unpainted pixels), and what their values can
    /// express (an 8-bit import's clipped channels are bounds).
    ReplacePaint {
        view: ViewId,
        painted: Vec<(u32, [f32; 3])>,
        range: PaintRange,
    },
    SetPolicy(Policy),
    SetRegularization(Regularization),
    /// A (new) basis is ready; until the first one arrives, samples accumulate unsolved.
    SetBasis(Arc<Basis>),
    /// The material the painting starts from (its projection onto each installed basis is
    /// the prior mean), or `None` for the database's mean material.
    SetStartMaterial(Option<Arc<SymTable>>),
    /// Where the prior is centred without a starting material (the database's mean, or
    /// Lambert + a microfacet lobe fitted to the paint).
    SetPriorMean(PriorMean),
    /// Answers with the version of the snapshot that includes every command sent before it,
    /// and the prior's mean fitted to them.
    Sync(Sender<u64>),
    /// Render the current BRDF for a view's geometry, as a perfect painter would paint it
    /// (answered by [`Analysis::Prediction`]).
    Predict {
        view: ViewId,
        gbuffer: Arc<GBuffer>,
    },
    /// Estimate the per-pair posterior standard deviation of ρ (answered by
    /// [`Analysis::Uncertainty`]). Requests that queue up behind a running one are merged.
    EstimateUncertainty,
    /// Rank `candidates` views of `object` around `base` by how much painting them would
    /// teach (answered by [`Analysis::RankedViews`] with the same `request`).
    RankViews {
        request: u64,
        base: Box<Scene>,
        object: Arc<Object>,
        candidates: usize,
    },
}

/// An answer of the analysis thread. `version` is the snapshot whose state it was computed
/// from.
#[derive(Clone, Debug)]
pub enum Analysis {
    /// The BRDF of snapshot `version` rendered for `gbuffer` (the view's geometry when asked).
    Prediction {
        view: ViewId,
        version: u64,
        gbuffer: Arc<GBuffer>,
        image: RgbImage,
    },
    /// The posterior standard deviation of ρ: per table entry and channel (`table`, as
    /// `burnish reconstruct --uncertainty` writes it) and, per unordered pair, of the
    /// luminance (`luminance`, the app's overlay).
    Uncertainty {
        version: u64,
        table: Arc<SymTable>,
        luminance: Arc<[f32]>,
    },
    /// Candidate views, best first.
    RankedViews {
        request: u64,
        version: u64,
        views: Vec<RankedView>,
    },
    /// A request that has no answer yet: there is no basis to solve with.
    NoBasis { what: AnalysisKind },
}

/// What an analysis request asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnalysisKind {
    Prediction { view: ViewId },
    Uncertainty,
    RankedViews { request: u64 },
}

/// What one solve gives the UI. Immutable; replaced as a whole.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    /// Increases with every publication.
    pub version: u64,
    /// The basis the coefficients refer to; `None` until one is ready.
    pub basis: Option<Arc<Basis>>,
    /// x_kc for each component; empty without a basis.
    pub coefficients: Arc<Vec<[f64; 3]>>,
    /// The fitted reference the coefficients are measured from (`None`: the basis's mean).
    pub reference: Option<Arc<FittedReference>>,
    pub stats: SolveStats,
    /// The earliest pointer event among the inputs this snapshot is the first to include.
    pub oldest_input: Option<Instant>,
    /// The prior's mean coefficients when a starting material sets them (its projection
    /// onto the basis); `None`: the database's mean material.
    pub prior_mean: Option<Arc<Vec<[f64; 3]>>>,
    /// Whether the prior's mean is still being fitted to the paint: a later snapshot will
    /// follow without any input (the UI keeps looking for it).
    pub fitting_mean: bool,
}

impl Snapshot {
    /// The BRDF this snapshot holds, or `None` before a basis is ready (or while the
    /// coefficients belong to another basis).
    pub fn reconstruction(&self) -> Option<Reconstruction> {
        let basis = self.basis.clone()?;
        let sets = self.coefficients.len() / basis.components().max(1);
        let whole = sets * basis.components() == self.coefficients.len();
        (whole && (sets == 1 || sets == crate::solver::BANDS)).then(|| {
            Reconstruction::new(basis, &self.coefficients).with_reference(self.reference.clone())
        })
    }
}

/// Figures for the status bar.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Samples (painted, usable pixels of unmuted views).
    pub samples: usize,
    pub observed_bins: usize,
    pub inconsistent_bins: usize,
    /// Painted pixels that give no sample (shadow, grazing, background).
    pub skipped_pixels: usize,
    pub components: usize,
    pub condition_number: f64,
    /// The regularisation strength used (α of the prior, or λ).
    pub alpha: f64,
    /// Time of the last batch: sparse update, normal equations and solve.
    pub update_ms: f64,
    /// Commands the last batch drained.
    pub batch_commands: usize,
}

/// The UI's end of the worker.
pub struct Worker {
    commands: Sender<Command>,
    snapshot: Arc<ArcSwap<Snapshot>>,
    bin_updates: Receiver<Vec<BinChange>>,
    analyses: Receiver<Analysis>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the worker thread.
    pub fn spawn(policy: Policy, regularization: Regularization) -> Self {
        let (commands, inbox) = unbounded();
        let (updates_out, bin_updates) = unbounded();
        let (analyses_out, analyses) = unbounded();
        let snapshot = Arc::new(ArcSwap::from_pointee(Snapshot::default()));
        let published = snapshot.clone();
        let thread = std::thread::Builder::new()
            .name("burnish-worker".into())
            .spawn(move || {
                let jobs = spawn_analysis(analyses_out);
                let (fitted_out, fitted) = unbounded();
                let mut state = WorkerState::new(policy, regularization, published, updates_out);
                state.jobs = Some(jobs);
                state.fits = Some(spawn_fitter(fitted_out));
                state.run(inbox, fitted);
            })
            .expect("spawning the worker thread");
        Self {
            commands,
            snapshot,
            bin_updates,
            analyses,
            thread: Some(thread),
        }
    }

    /// Queues a command; never blocks.
    pub fn send(&self, command: Command) {
        // The worker only stops when this handle drops, so the channel is open.
        let _ = self.commands.send(command);
    }

    /// The newest published snapshot; never blocks.
    pub fn snapshot(&self) -> Arc<Snapshot> {
        self.snapshot.load_full()
    }

    /// Commands waiting in the queue (for the benchmark's "keeps up" check).
    pub fn queued(&self) -> usize {
        self.commands.len()
    }

    /// Bin changes published since the last call, oldest first (each batch's coalesced, see
    /// [`BinChange::coalesce`]); never blocks.
    pub fn take_bin_updates(&self) -> Vec<BinChange> {
        self.bin_updates.try_iter().flatten().collect()
    }

    /// Answers of the analysis thread since the last call, oldest first; never blocks.
    pub fn take_analyses(&self) -> Vec<Analysis> {
        self.analyses.try_iter().collect()
    }

    /// Waits up to `timeout` for the next answer of the analysis thread (tests, benchmarks).
    pub fn wait_analysis(&self, timeout: Duration) -> Option<Analysis> {
        self.analyses.recv_timeout(timeout).ok()
    }

    /// Blocks until every command sent so far is processed and returns the snapshot that
    /// includes them, or `None` when `timeout` passes first. For tests, benchmarks and
    /// saving; the UI thread never calls it while painting.
    pub fn sync(&self, timeout: Duration) -> Option<Arc<Snapshot>> {
        self.sync_later().wait(timeout)
    }

    /// Sends a sync without waiting for it; never blocks.
    pub fn sync_later(&self) -> PendingSync {
        let (tx, rx) = crossbeam_channel::bounded(1);
        self.send(Command::Sync(tx));
        PendingSync {
            reply: rx,
            snapshot: self.snapshot.clone(),
        }
    }
}

/// A [`Command::Sync`] under way, to wait for on another thread (an export must write what
/// `burnish reconstruct` would, so it waits for the prior's mean to catch up with the paint).
pub struct PendingSync {
    reply: Receiver<u64>,
    snapshot: Arc<ArcSwap<Snapshot>>,
}

impl PendingSync {
    /// The snapshot that includes every command sent before the sync, or `None` when
    /// `timeout` passes first (or the worker is gone).
    pub fn wait(self, timeout: Duration) -> Option<Arc<Snapshot>> {
        self.reply.recv_timeout(timeout).ok()?;
        Some(self.snapshot.load_full())
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the channel ends the thread's loop.
        let (closed, _) = unbounded();
        self.commands = closed;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// What turns a view's pixels into samples (geometry, mute flag, pixel colours), not the view.
struct ViewSamples {
    gbuffer: Arc<GBuffer>,
    muted: bool,
    /// Painted pixels and their radiance, whether or not they give a sample.
    painted: HashMap<u32, [f32; 3]>,
    /// What the painted values can express.
    range: PaintRange,
}

struct WorkerState {
    views: BTreeMap<ViewId, ViewSamples>,
    sparse: SparseTable,
    solver: Option<Solver>,
    regularization: Regularization,
    skipped: usize,
    version: u64,
    published: Arc<ArcSwap<Snapshot>>,
    updates_out: Sender<Vec<BinChange>>,
    last_stats: SolveStats,
    last_coefficients: Arc<Vec<[f64; 3]>>,
    last_reference: Option<Arc<FittedReference>>,
    /// Kept as a table so that a later basis gets its own projection.
    start_material: Option<Arc<SymTable>>,
    prior_mean: PriorMean,
    /// The analysis thread's inbox.
    jobs: Option<Sender<Job>>,
    /// The fit thread's inbox, and whether a fit is under way there.
    fits: Option<Sender<MeanFitRequest>>,
    fit_in_flight: bool,
    /// When the last batch changed the bins.
    last_bin_change: Instant,
    /// Syncs and analysis requests waiting for the prior's mean to catch up with the bins.
    waiting_syncs: Vec<Sender<u64>>,
    waiting_requests: Vec<Command>,
}

impl WorkerState {
    fn new(
        policy: Policy,
        regularization: Regularization,
        published: Arc<ArcSwap<Snapshot>>,
        updates_out: Sender<Vec<BinChange>>,
    ) -> Self {
        Self {
            views: BTreeMap::new(),
            sparse: SparseTable::new(policy),
            solver: None,
            regularization,
            skipped: 0,
            version: 0,
            published,
            updates_out,
            last_stats: SolveStats::default(),
            last_coefficients: Arc::new(Vec::new()),
            last_reference: None,
            start_material: None,
            prior_mean: PriorModel::CALIBRATED.mean,
            jobs: None,
            fits: None,
            fit_in_flight: false,
            last_bin_change: Instant::now(),
            waiting_syncs: Vec::new(),
            waiting_requests: Vec::new(),
        }
    }

    fn run(&mut self, inbox: Receiver<Command>, mut fitted: Receiver<FittedMean>) {
        loop {
            let fit_timer = match self.fit_due_in() {
                Some(wait) => crossbeam_channel::after(wait),
                None => crossbeam_channel::never(),
            };
            select! {
                recv(inbox) -> first => match first {
                    Ok(first) => self.run_batch(first, &inbox),
                    Err(_) => return,
                },
                recv(fitted) -> mean => {
                    self.fit_in_flight = false;
                    match mean {
                        Ok(mean) => self.take_fitted_mean(mean),
                        // The fit thread is gone (it panicked): fit on this thread from now on.
                        Err(_) => {
                            self.fits = None;
                            fitted = crossbeam_channel::never();
                        }
                    }
                },
                recv(fit_timer) -> _ => {},
            }
            self.request_mean_fit();
            if !self.fit_in_flight {
                // The mean belongs to the bins now: what waited for it may go.
                for request in std::mem::take(&mut self.waiting_requests) {
                    self.dispatch(request);
                }
                for reply in std::mem::take(&mut self.waiting_syncs) {
                    let _ = reply.send(self.version);
                }
            }
        }
    }

    /// Whether the prior's mean is not yet the fit of the bins painted now.
    fn fitting_mean(&self) -> bool {
        self.fit_in_flight
            || self
                .solver
                .as_ref()
                .is_some_and(|s| !s.prior_mean_is_current())
    }

    /// How long until a fit of the prior's mean is due: the bins changed since the last fit
    /// began, none is under way, and paint has been still for [`FIT_SETTLE`] (a fit during a
    /// stroke would be stale when done and would take the cores the preview draws with).
    /// `None` when no fit is due.
    fn fit_due_in(&self) -> Option<Duration> {
        if self.fit_in_flight || self.solver.as_ref()?.prior_mean_is_current() {
            return None;
        }
        Some(FIT_SETTLE.saturating_sub(self.last_bin_change.elapsed()))
    }

    /// Starts a fit of the prior's mean when one is due, or at once when a sync or an
    /// analysis request waits for it; without a fit thread (it panicked), fits on this one.
    fn request_mean_fit(&mut self) {
        let waited_for = !self.waiting_syncs.is_empty() || !self.waiting_requests.is_empty();
        if self
            .fit_due_in()
            .is_none_or(|wait| !wait.is_zero() && !waited_for)
        {
            return;
        }
        let Some(request) = self.solver.as_ref().and_then(Solver::mean_fit_request) else {
            return;
        };
        match &self.fits {
            Some(fits) if fits.send(request.clone()).is_ok() => self.fit_in_flight = true,
            _ => self.take_fitted_mean(request.run()),
        }
    }

    /// Installs a fitted mean and, when the solve's mean changed, solves and publishes again.
    fn take_fitted_mean(&mut self, mean: FittedMean) {
        let started = Instant::now();
        let changed = self
            .solver
            .as_mut()
            .is_some_and(|solver| solver.install_fitted_mean(mean));
        // Publish also when only the "still fitting" flag changes, so the UI stops waiting.
        self.request_mean_fit();
        if changed || self.published.load().fitting_mean != self.fitting_mean() {
            self.publish(&[], 0, started, 0, None);
        }
    }

    fn run_batch(&mut self, first: Command, inbox: &Receiver<Command>) {
        let started = Instant::now();
        let mut batch = vec![first];
        loop {
            match inbox.try_recv() {
                Ok(command) => batch.push(command),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => break,
            }
        }
        let batch_commands = batch.len();
        let mut changes = Vec::new();
        let mut syncs = Vec::new();
        let mut requests = Vec::new();
        let mut oldest_input: Option<Instant> = None;
        let mut resolve = false;
        // Changes before a basis install are already in the new solver's first build.
        let mut solver_start = 0;
        for command in batch {
            match command {
                Command::Pixels {
                    view,
                    edits,
                    input_time,
                } => {
                    oldest_input = Some(oldest_input.map_or(input_time, |t| t.min(input_time)));
                    self.apply_edits(view, &edits, &mut changes);
                }
                Command::Sync(reply) => syncs.push(reply),
                request @ (Command::Predict { .. }
                | Command::EstimateUncertainty
                | Command::RankViews { .. }) => requests.push(request),
                Command::SetBasis(basis) => {
                    self.install_basis(basis);
                    solver_start = changes.len();
                    resolve = true;
                }
                Command::SetRegularization(regularization) => {
                    self.regularization = regularization;
                    if let Some(solver) = &mut self.solver {
                        solver.set_regularization(regularization);
                    }
                    resolve = true;
                }
                Command::SetPriorMean(mean) => {
                    self.prior_mean = mean;
                    if let Some(solver) = &mut self.solver {
                        solver.set_mean_kind(mean);
                    }
                    resolve = true;
                }
                Command::SetStartMaterial(material) => {
                    self.start_material = material;
                    if let Some(solver) = &mut self.solver {
                        let basis = solver.basis().clone();
                        let mean = self
                            .start_material
                            .as_deref()
                            .map(|t| OracleProjector::new(basis).project(t));
                        solver.set_prior_mean(mean);
                    }
                    resolve = true;
                }
                other => self.apply_view_command(other, &mut changes),
            }
        }
        if !changes.is_empty() {
            self.last_bin_change = Instant::now();
        }
        if !changes.is_empty() || resolve || self.version == 0 {
            self.publish(
                &changes,
                solver_start,
                started,
                batch_commands,
                oldest_input,
            );
        }
        // Answered after the batch's solve, once the prior's mean caught up (see `run`):
        // the answers include everything sent before the request.
        self.waiting_requests.extend(requests);
        self.waiting_syncs.extend(syncs);
    }

    fn apply_view_command(&mut self, command: Command, changes: &mut Vec<BinChange>) {
        match command {
            Command::SetView { view, gbuffer } => {
                self.sparse.remove_view(view, changes);
                let state = self.views.entry(view).or_insert_with(|| ViewSamples {
                    gbuffer: gbuffer.clone(),
                    muted: false,
                    painted: HashMap::new(),
                    range: PaintRange::Hdr,
                });
                state.gbuffer = gbuffer;
                self.resample_view(view, changes);
            }
            Command::RemoveView(view) => {
                self.sparse.remove_view(view, changes);
                self.views.remove(&view);
                self.recount_skipped();
            }
            Command::MuteView { view, muted } => {
                if let Some(state) = self.views.get_mut(&view)
                    && state.muted != muted
                {
                    state.muted = muted;
                    self.sparse.remove_view(view, changes);
                    self.resample_view(view, changes);
                }
            }
            Command::ReplacePaint {
                view,
                painted,
                range,
            } => {
                if let Some(state) = self.views.get_mut(&view) {
                    state.painted = painted.into_iter().collect();
                    state.range = range;
                    self.sparse.remove_view(view, changes);
                    self.resample_view(view, changes);
                }
            }
            Command::SetPolicy(policy) => self.sparse.set_policy(policy, changes),
            Command::Pixels { .. }
            | Command::Sync(_)
            | Command::SetBasis(_)
            | Command::SetStartMaterial(_)
            | Command::SetPriorMean(_)
            | Command::SetRegularization(_)
            | Command::Predict { .. }
            | Command::EstimateUncertainty
            | Command::RankViews { .. } => {
                unreachable!("handled in the batch loop")
            }
        }
    }

    /// Hands an analysis request to the analysis thread with a copy of what it needs, or
    /// answers at once that there is no basis yet.
    fn dispatch(&mut self, request: Command) {
        let Some(jobs) = &self.jobs else { return };
        let version = self.version;
        let job = match (request, &self.solver) {
            (Command::Predict { view, gbuffer }, Some(solver)) => Job::Predict {
                view,
                version,
                gbuffer,
                reconstruction: self.last_reconstruction(solver),
            },
            (Command::EstimateUncertainty, Some(solver)) => Job::Uncertainty {
                version,
                solver: Box::new(solver.clone()),
                reconstruction: self.last_reconstruction(solver),
            },
            (
                Command::RankViews {
                    request,
                    base,
                    object,
                    candidates,
                },
                Some(solver),
            ) => Job::Rank {
                request,
                version,
                solver: Box::new(solver.clone()),
                base,
                object,
                candidates,
                painted: self.sparse.observed().map(|(pair, _)| pair).collect(),
            },
            (request, None) => Job::NoBasis(match request {
                Command::Predict { view, .. } => AnalysisKind::Prediction { view },
                Command::RankViews { request, .. } => AnalysisKind::RankedViews { request },
                _ => AnalysisKind::Uncertainty,
            }),
            _ => unreachable!("only analysis requests are dispatched"),
        };
        let _ = jobs.send(job);
    }

    /// Re-derives every sample of a view from its painted pixels (after removing them).
    fn resample_view(&mut self, view: ViewId, changes: &mut Vec<BinChange>) {
        if let Some(state) = self.views.get(&view)
            && !state.muted
        {
            let mut pixels: Vec<_> = state.painted.iter().map(|(&p, &c)| (p, c)).collect();
            pixels.sort_unstable_by_key(|&(p, _)| p);
            for (pixel, colour) in pixels {
                set_pixel(&mut self.sparse, state, view, pixel, Some(colour), changes);
            }
        }
        self.recount_skipped();
    }

    fn recount_skipped(&mut self) {
        let painted: usize = self
            .views
            .values()
            .filter(|v| !v.muted)
            .map(|v| v.painted.len())
            .sum();
        self.skipped = painted.saturating_sub(self.sparse.sample_count());
    }

    fn apply_edits(&mut self, view: ViewId, edits: &[PixelChange], changes: &mut Vec<BinChange>) {
        let Some(state) = self.views.get_mut(&view) else {
            return;
        };
        for edit in edits {
            match edit.after {
                Some(colour) => state.painted.insert(edit.pixel, colour),
                None => state.painted.remove(&edit.pixel),
            };
            if !state.muted {
                set_pixel(
                    &mut self.sparse,
                    state,
                    view,
                    edit.pixel,
                    edit.after,
                    changes,
                );
            }
        }
        self.recount_skipped();
    }

    fn install_basis(&mut self, basis: Arc<Basis>) {
        let model = PriorModel {
            mean: self.prior_mean,
            ..PriorModel::CALIBRATED
        };
        let mut solver = Solver::with_model(basis.clone(), self.regularization, model);
        if let Some(material) = &self.start_material {
            solver.set_prior_mean(Some(OracleProjector::new(basis).project(material)));
        }
        let existing: Vec<BinChange> = self.sparse.observed_changes().collect();
        solver.apply_all(&existing);
        solver.rebuild();
        self.solver = Some(solver);
    }

    /// The last published BRDF, on `solver`'s basis.
    fn last_reconstruction(&self, solver: &Solver) -> Reconstruction {
        Reconstruction::new(solver.basis().clone(), &self.last_coefficients)
            .with_reference(self.last_reference.clone())
    }

    fn publish(
        &mut self,
        changes: &[BinChange],
        solver_start: usize,
        started: Instant,
        batch_commands: usize,
        oldest_input: Option<Instant>,
    ) {
        let updates = BinChange::coalesce(changes);
        if let Some(solver) = &mut self.solver {
            solver.apply_all(&changes[solver_start..]);
        }
        let (coefficients, reference, condition_number, alpha, components, basis) =
            match &self.solver {
                Some(solver) => {
                    let solution = solver.solve();
                    (
                        Arc::new(solution.coefficients),
                        solution.reference,
                        solution.condition_number,
                        solution.alpha,
                        solver.basis().components(),
                        Some(solver.basis().clone()),
                    )
                }
                None => (
                    self.last_coefficients.clone(),
                    self.last_reference.clone(),
                    0.0,
                    0.0,
                    0,
                    None,
                ),
            };
        self.version += 1;
        self.last_coefficients = coefficients.clone();
        self.last_reference = reference.clone();
        self.last_stats = SolveStats {
            samples: self.sparse.sample_count(),
            observed_bins: self.sparse.observed_count(),
            inconsistent_bins: self.sparse.inconsistent_count(),
            skipped_pixels: self.skipped,
            components,
            condition_number,
            alpha,
            update_ms: started.elapsed().as_secs_f64() * 1e3,
            batch_commands,
        };
        if !updates.is_empty() {
            let _ = self.updates_out.send(updates);
        }
        self.published.store(Arc::new(Snapshot {
            version: self.version,
            basis,
            coefficients,
            reference,
            stats: self.last_stats,
            oldest_input,
            prior_mean: self
                .solver
                .as_ref()
                .and_then(|s| s.prior_mean())
                .map(|m| Arc::new(m.to_vec())),
            fitting_mean: self.fitting_mean(),
        }));
    }
}

/// Puts one pixel's sample into the sparse table, or takes it out (no paint, or the pixel
/// gives no usable sample), read in the view's paint range as `burnish reconstruct` reads
/// a painting file.
fn set_pixel(
    sparse: &mut SparseTable,
    samples: &ViewSamples,
    view: ViewId,
    pixel: u32,
    radiance: Option<[f32; 3]>,
    changes: &mut Vec<BinChange>,
) {
    let key = SampleKey { view, pixel };
    let sample = radiance
        .and_then(|r| sample_pixel_in(&samples.gbuffer, pixel as usize, r, samples.range).ok());
    match sample {
        Some(sample) => {
            if sparse
                .set_reading(
                    key,
                    sample.light_bin,
                    sample.view_bin,
                    sample.reading(),
                    changes,
                )
                .is_err()
            {
                sparse.remove_sample(key, changes);
            }
        }
        None => sparse.remove_sample(key, changes),
    }
}

/// An analysis request with its own copy of the state it needs.
enum Job {
    Predict {
        view: ViewId,
        version: u64,
        gbuffer: Arc<GBuffer>,
        reconstruction: Reconstruction,
    },
    Uncertainty {
        version: u64,
        solver: Box<Solver>,
        reconstruction: Reconstruction,
    },
    Rank {
        request: u64,
        version: u64,
        solver: Box<Solver>,
        base: Box<Scene>,
        object: Arc<Object>,
        candidates: usize,
        painted: std::collections::BTreeSet<PairIndex>,
    },
    NoBasis(AnalysisKind),
}

/// Starts the fit thread; it ends when the returned sender (the worker's) is dropped. The
/// worker keeps at most one request in it.
fn spawn_fitter(out: Sender<FittedMean>) -> Sender<MeanFitRequest> {
    let (requests, inbox) = unbounded::<MeanFitRequest>();
    std::thread::Builder::new()
        .name("burnish-fit".into())
        .spawn(move || {
            while let Ok(request) = inbox.recv() {
                if out.send(request.run()).is_err() {
                    return;
                }
            }
        })
        .expect("spawning the fit thread");
    requests
}

/// Starts the analysis thread; it ends when the returned sender (the worker's) is dropped.
fn spawn_analysis(out: Sender<Analysis>) -> Sender<Job> {
    let (jobs, inbox) = unbounded::<Job>();
    std::thread::Builder::new()
        .name("burnish-analysis".into())
        .spawn(move || {
            while let Ok(first) = inbox.recv() {
                let mut batch = vec![first];
                batch.extend(inbox.try_iter());
                // Only the newest uncertainty request is worth its second of work.
                let newest_uncertainty = batch
                    .iter()
                    .rposition(|j| matches!(j, Job::Uncertainty { .. }));
                for (i, job) in batch.into_iter().enumerate() {
                    if matches!(job, Job::Uncertainty { .. }) && Some(i) != newest_uncertainty {
                        continue;
                    }
                    if out.send(run_job(job)).is_err() {
                        return;
                    }
                }
            }
        })
        .expect("spawning the analysis thread");
    jobs
}

fn run_job(job: Job) -> Analysis {
    match job {
        Job::Predict {
            view,
            version,
            gbuffer,
            reconstruction,
        } => {
            let table = reconstruction.materialize();
            Analysis::Prediction {
                view,
                version,
                image: render_table(&gbuffer, &table),
                gbuffer,
            }
        }
        Job::Uncertainty {
            version,
            solver,
            reconstruction,
        } => {
            let table = solver.posterior().table_std_dev(&reconstruction);
            // Every channel's deviation is the same mapped-domain deviation times that
            // channel's slope, so the luminance's deviation is their weighted sum.
            let luminance = table
                .pairs()
                .iter()
                .map(|sd| (0.2126 * sd[0] + 0.7152 * sd[1] + 0.0722 * sd[2]).min(f32::MAX))
                .collect();
            Analysis::Uncertainty {
                version,
                table: Arc::new(table),
                luminance,
            }
        }
        Job::Rank {
            request,
            version,
            solver,
            base,
            object,
            candidates,
            painted,
        } => {
            let scenes = candidate_scenes(&base, candidates);
            Analysis::RankedViews {
                request,
                version,
                views: rank_views(&solver, &object, &scenes, &painted),
            }
        }
        Job::NoBasis(what) => Analysis::NoBasis { what },
    }
}
