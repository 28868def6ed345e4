//! The painting as a document, without a window: its views (scene, geometry, canvas), the
//! worker that solves for the BRDF, the basis job, what the worker reported back, and the
//! session file it is saved to. The app is a UI over it; tests, benchmarks and scripts can
//! drive it the same way. It knows nothing of egui (it builds without the `app` feature).
//!
//! Operations that finish at once return their outcome; what background threads finish
//! arrives through [`Document::poll`]. Messages for the user and hints for the UI (such as
//! "show this material as the reference") wait in [`Document::take_events`].

mod basis_job;
mod file_jobs;
mod files;
mod view;

pub use basis_job::{BasisJob, BasisStatus};
pub use files::{ExportKind, ImportMask, ImportReport, painting_mask_path};
pub use view::{Base, ViewDoc, object_mask, propose_view};

use crate::basis::{Basis, BasisCache, BasisSpec, CacheOutcome};
use crate::next_view::RankedView;
use crate::paint::{BrushKind, BrushSettings, Canvas, CanvasChanges, PixelRect, UnpaintedPixels};
use crate::scene::{PaintRange, Scene};
use crate::session::{Autosaver, BasisSettings, RecoveryInfo, StartMaterial, ViewSettings};
use crate::solver::{BinChange, PriorMean};
use crate::table::{PairIndex, SymTable};
use crate::worker::{Analysis, AnalysisKind, Command, Snapshot, ViewId, Worker};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Candidate views "Suggest next view" ranks (as `burnish suggest` does by default).
pub const SUGGEST_CANDIDATES: usize = 48;

/// The basis the settings ask for: the default database at its size, K components.
pub fn basis_spec(settings: &BasisSettings) -> BasisSpec {
    BasisSpec {
        database: crate::materials::database::DatabaseSpec {
            size: settings.materials,
            ..Default::default()
        },
        ..BasisSpec::default_for(settings.components)
    }
}

/// A message for the user: errors name the file and the problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Notice {
    pub text: String,
    pub is_error: bool,
}

/// What the document has to tell whoever shows it, in the order it happened.
#[derive(Clone, Debug)]
pub enum Event {
    Notice(Notice),
    /// The painting now starts from this material (opened, or read from a session): worth
    /// showing beside the reconstruction.
    StartMaterial {
        name: String,
        table: Arc<SymTable>,
    },
}

/// What [`Document::poll`] took from the background threads that a UI draws itself.
#[derive(Default)]
pub struct Polled {
    /// Sparse bins that changed, oldest first, as the worker reported them.
    pub bins: Vec<BinChange>,
    /// A new estimate of the table's uncertainty: per unordered pair, the standard deviation
    /// of ρ.
    pub uncertainty: Option<Arc<[f32]>>,
}

/// Where a document's basis comes from.
pub enum BasisSource {
    /// Loaded from the cache or built, in the background (the app).
    Load,
    /// This one, at once (tests).
    Given(Arc<Basis>),
    /// The caller hands it over with [`Document::set_basis`] once it has it (the command
    /// line, which reports loading it itself).
    Later,
}

/// How a document starts.
pub struct DocumentConfig {
    pub basis: BasisSource,
    /// The folder of the basis cache; `None`: [`BasisCache::default_location`].
    pub basis_cache: Option<PathBuf>,
    pub basis_settings: BasisSettings,
    /// Whether to autosave to the recovery file and offer recovery at start.
    pub autosave: bool,
    /// The recovery file; `None`: [`crate::session::recovery_path`].
    pub recovery_file: Option<PathBuf>,
}

/// The views, their worker and basis, and the session they are saved to.
pub struct Document {
    views: Vec<ViewDoc>,
    active: usize,
    next_view_id: ViewId,
    worker: Worker,
    basis_job: BasisJob,
    basis_settings: BasisSettings,
    basis: Option<Arc<Basis>>,
    /// The basis cache folder asked for at start (`None`: the default location).
    basis_cache: Option<PathBuf>,
    /// The newest snapshot taken from the worker.
    snapshot: Arc<Snapshot>,
    /// The observed sparse bins, each with whether it is inconsistent, as the worker's bin
    /// changes last reported them: the UI's one copy of what the sparse table holds.
    observed: HashMap<PairIndex, bool>,
    session_path: Option<PathBuf>,
    /// Whether anything changed since the last save.
    dirty: bool,
    /// Whether anything changed since the autosaver last looked.
    changed_since_autosave: bool,
    autosaver: Option<Autosaver>,
    /// The last autosave failed and the user was told; cleared (and told) when one succeeds.
    autosave_failing: bool,
    /// A recovery file left by a session that did not close cleanly, until the user answers.
    recovery_offer: Option<RecoveryInfo>,
    /// The material the painting starts from (saved with the session).
    start_material: Option<StartMaterial>,
    /// Exports and starting materials being written or read off the caller's thread.
    file_jobs: file_jobs::FileJobs,
    /// New views whose canvas waits for the prediction of the current BRDF; they give no
    /// samples until it arrives (or the worker says there is no basis to predict with).
    awaiting_prediction: HashSet<ViewId>,
    /// The ranking of candidate views asked for by "Suggest next view", until it arrives.
    pending_suggestion: Option<u64>,
    /// A ranking a headless caller waits for ([`Self::settled_ranking`]), and the answer
    /// once it arrived.
    caller_ranking: Option<(u64, Option<Vec<RankedView>>)>,
    next_request: u64,
    /// The snapshot version the uncertainty was estimated for, and whether an estimate is
    /// on its way.
    uncertainty_version: Option<u64>,
    uncertainty_pending: bool,
    /// The newest estimate, per table entry and channel (of `uncertainty_version`).
    uncertainty_table: Option<Arc<SymTable>>,
    /// Counts changes after which the active canvas must be shown afresh (the views or the
    /// active one changed, or a canvas was replaced as a whole).
    canvas_revision: u64,
    events: Vec<Event>,
}

impl Document {
    /// A document with no views yet (see [`Self::begin`]): the worker is started and the
    /// basis is loaded or built in the background.
    pub fn new(config: DocumentConfig) -> Self {
        let settings = config.basis_settings;
        let worker = Worker::spawn(settings.policy, settings.regularization);
        let spec = basis_spec(&settings);
        let basis_job = match config.basis {
            BasisSource::Given(basis) => BasisJob::ready(spec, basis),
            BasisSource::Load => {
                BasisJob::start(spec, config.basis_cache.clone().map(BasisCache::at))
            }
            BasisSource::Later => BasisJob::awaiting_caller(spec),
        };
        let autosaver = config
            .autosave
            .then(|| match &config.recovery_file {
                Some(path) => Some(Autosaver::new(path)),
                None => Autosaver::at_default_location(),
            })
            .flatten();
        let recovery_offer = autosaver
            .as_ref()
            .map(|saver| crate::session::pending_recovery_at(saver.path()));
        let mut doc = Self {
            views: Vec::new(),
            active: 0,
            next_view_id: 0,
            worker,
            basis_job,
            basis_settings: settings,
            basis: None,
            basis_cache: config.basis_cache,
            snapshot: Arc::new(Snapshot::default()),
            observed: HashMap::new(),
            session_path: None,
            dirty: false,
            changed_since_autosave: false,
            autosaver,
            autosave_failing: false,
            recovery_offer: None,
            start_material: None,
            file_jobs: file_jobs::FileJobs::default(),
            awaiting_prediction: HashSet::new(),
            pending_suggestion: None,
            caller_ranking: None,
            next_request: 0,
            uncertainty_version: None,
            uncertainty_pending: false,
            uncertainty_table: None,
            canvas_revision: 0,
            events: Vec::new(),
        };
        match recovery_offer {
            Some(Ok(offer)) => doc.recovery_offer = offer,
            Some(Err(e)) => doc.notify_error(e.to_string()),
            None => {}
        }
        doc
    }

    /// Opens `session` or, without one (or when it cannot be read), starts with one view of
    /// `scene`. Returns the opened session's brush. Setting up is not the user's work: it
    /// leaves nothing unsaved and nothing to autosave.
    pub fn begin(&mut self, session: Option<&Path>, scene: Scene) -> Option<BrushSettings> {
        let brush = session.and_then(|path| self.open_session(path).ok());
        if brush.is_none() {
            if let Err(e) = self.add_view(scene) {
                self.notify_error(e.to_string());
                let _ = self.add_view(Scene::default());
            }
            self.dirty = false;
        }
        self.changed_since_autosave = false;
        brush
    }

    /// What happened since the last call: messages for the user and hints for the UI.
    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    pub(crate) fn notify_error(&mut self, text: impl Into<String>) {
        self.events.push(Event::Notice(Notice {
            text: text.into(),
            is_error: true,
        }));
    }

    pub(crate) fn notify(&mut self, text: impl Into<String>) {
        self.events.push(Event::Notice(Notice {
            text: text.into(),
            is_error: false,
        }));
    }

    /// Marks the session changed (unsaved, and due for the next autosave).
    pub fn touch(&mut self) {
        self.dirty = true;
        self.changed_since_autosave = true;
    }

    /// Whether anything changed since the last save.
    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    /// The user chose to close without saving: nothing counts as unsaved any more.
    pub fn discard_unsaved(&mut self) {
        self.dirty = false;
    }

    /// The file the session was last opened from or saved to.
    pub fn session_path(&self) -> Option<&Path> {
        self.session_path.as_deref()
    }

    pub fn views(&self) -> &[ViewDoc] {
        &self.views
    }

    /// The index of the view being painted.
    pub fn active(&self) -> usize {
        self.active
    }

    /// Makes the view at `index` the one being painted.
    pub fn set_active(&mut self, index: usize) {
        if index < self.views.len() {
            self.active = index;
            self.canvas_revision += 1;
        }
    }

    pub fn active_view(&self) -> Option<&ViewDoc> {
        self.views.get(self.active)
    }

    /// The active view's canvas, to paint on; hand what the painting changed (its
    /// `take_changes`) to [`Self::publish_canvas_changes`].
    pub fn active_canvas_mut(&mut self) -> Option<&mut Canvas> {
        self.views.get_mut(self.active).map(|doc| &mut doc.canvas)
    }

    /// Changes whenever the active canvas must be shown afresh: the views or the active one
    /// changed, or a canvas was replaced as a whole (not by strokes, which report what they
    /// touched).
    pub fn canvas_revision(&self) -> u64 {
        self.canvas_revision
    }

    pub fn worker(&self) -> &Worker {
        &self.worker
    }

    /// The basis, once it is loaded or built.
    pub fn basis(&self) -> Option<&Arc<Basis>> {
        self.basis.as_ref()
    }

    pub fn basis_status(&self) -> BasisStatus {
        self.basis_job.status()
    }

    pub fn basis_settings(&self) -> BasisSettings {
        self.basis_settings
    }

    /// Changes how the painting becomes a table. The worker takes a new policy or
    /// regulariser at once; a new K or database size waits for [`Self::restart_basis`].
    pub fn set_basis_settings(&mut self, settings: BasisSettings) {
        if settings == self.basis_settings {
            return;
        }
        if settings.policy != self.basis_settings.policy {
            self.worker.send(Command::SetPolicy(settings.policy));
        }
        if settings.regularization != self.basis_settings.regularization {
            self.worker
                .send(Command::SetRegularization(settings.regularization));
        }
        self.basis_settings = settings;
        self.touch();
    }

    /// Loads or builds the basis the settings ask for, if it is not the one there is or is
    /// on its way; painting goes on meanwhile.
    pub fn restart_basis(&mut self) {
        let spec = basis_spec(&self.basis_settings);
        if *self.basis_job.spec() != spec {
            self.basis_job = BasisJob::start(spec, self.basis_cache().map(BasisCache::at));
        }
    }

    /// The basis cache folder asked for at start (`None`: the default location).
    pub fn basis_cache(&self) -> Option<PathBuf> {
        self.basis_cache.clone()
    }

    /// The newest snapshot taken from the worker.
    pub fn snapshot(&self) -> &Arc<Snapshot> {
        &self.snapshot
    }

    /// The observed sparse bins, as the worker last reported them (in no order).
    pub fn observed(&self) -> impl ExactSizeIterator<Item = PairIndex> + '_ {
        self.observed.keys().copied()
    }

    pub fn is_observed(&self, pair: PairIndex) -> bool {
        self.observed.contains_key(&pair)
    }

    /// The bins where views or strokes disagree, as the worker last reported them (in no
    /// order).
    pub fn inconsistent(&self) -> impl Iterator<Item = PairIndex> + '_ {
        self.observed
            .iter()
            .filter(|&(_, &inconsistent)| inconsistent)
            .map(|(&pair, _)| pair)
    }

    pub fn is_inconsistent(&self, pair: PairIndex) -> bool {
        self.observed.get(&pair).copied().unwrap_or(false)
    }

    /// Adds a view of `scene` and makes it active.
    pub fn add_view(&mut self, scene: Scene) -> crate::Result<()> {
        let id = self.next_view_id;
        let doc = ViewDoc::new(id, ViewSettings::new(format!("View {}", id + 1), scene))?;
        self.next_view_id += 1;
        self.worker.send(Command::SetView {
            view: id,
            gbuffer: doc.gbuffer.clone(),
        });
        if self.basis.is_some() && !self.views.is_empty() {
            // Paint on the prediction: the canvas starts from the current BRDF rendered for
            // this view. Its pixels are stated once the render is under them.
            self.worker.send(Command::Predict {
                view: id,
                gbuffer: doc.gbuffer.clone(),
            });
            self.awaiting_prediction.insert(id);
        } else {
            // Under "count as shown" an unpainted canvas already says what its base shows.
            self.worker.send(doc.paint_command());
        }
        self.views.push(doc);
        self.active = self.views.len() - 1;
        self.canvas_revision += 1;
        self.touch();
        Ok(())
    }

    /// Adds a view whose light and camera differ from the existing views' (not a copy).
    pub fn add_proposed_view(&mut self) -> crate::Result<()> {
        let existing: Vec<Scene> = self.views.iter().map(|v| v.scene().clone()).collect();
        let scene = match self.active_view() {
            Some(active) => propose_view(active.scene(), &existing),
            None => Scene::default(),
        };
        self.add_view(scene)
    }

    /// Closes the view at `index`; its samples leave the table. The last view stays.
    pub fn remove_view(&mut self, index: usize) {
        if index >= self.views.len() || self.views.len() == 1 {
            return;
        }
        let doc = self.views.remove(index);
        self.worker.send(Command::RemoveView(doc.id));
        self.active = self.active.min(self.views.len() - 1);
        self.canvas_revision += 1;
        self.touch();
    }

    pub fn set_muted(&mut self, index: usize, muted: bool) {
        if let Some(doc) = self.views.get_mut(index) {
            doc.settings.muted = muted;
            self.worker.send(Command::MuteView {
                view: doc.id,
                muted,
            });
            self.touch();
        }
    }

    /// Where the prior is centred without a starting material (`burnish reconstruct
    /// --prior-mean`); sessions do not keep it, a new document starts from the calibrated
    /// one.
    pub fn set_prior_mean(&mut self, mean: PriorMean) {
        self.worker.send(Command::SetPriorMean(mean));
    }

    /// Whether a new view still waits for the prediction its canvas starts from.
    pub fn predictions_pending(&self) -> bool {
        !self.awaiting_prediction.is_empty()
    }

    /// Asks for a render of the current BRDF for the view at `index`, to put under its paint
    /// when it arrives ("Start from the current BRDF").
    pub fn start_from_current_brdf(&mut self, index: usize) {
        let Some(doc) = self.views.get(index) else {
            return;
        };
        if self.basis.is_none() {
            self.notify_error("there is no BRDF to start from until the basis is ready");
            return;
        }
        self.worker.send(Command::Predict {
            view: doc.id,
            gbuffer: doc.gbuffer.clone(),
        });
    }

    /// Takes an answer of the worker's analysis thread.
    fn take_analysis(&mut self, answer: Analysis, polled: &mut Polled) {
        match answer {
            Analysis::Prediction {
                view,
                gbuffer,
                image,
                ..
            } => {
                let awaited = self.awaiting_prediction.remove(&view);
                let Some(index) = self.views.iter().position(|d| d.id == view) else {
                    return;
                };
                let doc = &mut self.views[index];
                // A scene changed since the request: the render is of other geometry, and
                // the change already sent the view's pixels.
                if !Arc::ptr_eq(&doc.gbuffer, &gbuffer) {
                    return;
                }
                let result = doc.set_prediction(image);
                self.worker.send(doc.paint_command());
                if index == self.active {
                    self.canvas_revision += 1;
                }
                if !awaited {
                    self.touch();
                }
                if let Err(e) = result {
                    self.notify_error(e.to_string());
                }
            }
            Analysis::NoBasis {
                what: AnalysisKind::Prediction { view },
            } => {
                if self.awaiting_prediction.remove(&view)
                    && let Some(doc) = self.views.iter().find(|d| d.id == view)
                {
                    self.worker.send(doc.paint_command());
                }
                self.notify("no BRDF to predict yet: the view shows the guide");
            }
            Analysis::Uncertainty {
                version,
                table,
                luminance,
            } => {
                self.uncertainty_pending = false;
                self.uncertainty_version = Some(version);
                self.uncertainty_table = Some(table);
                polled.uncertainty = Some(luminance);
            }
            Analysis::NoBasis {
                what: AnalysisKind::Uncertainty,
            } => self.uncertainty_pending = false,
            Analysis::RankedViews { request, views, .. } => {
                if let Some((asked, answer)) = &mut self.caller_ranking
                    && *asked == request
                {
                    *answer = Some(views);
                    return;
                }
                if self.pending_suggestion != Some(request) {
                    return;
                }
                self.pending_suggestion = None;
                let Some(best) = views.into_iter().next() else {
                    self.notify("no candidate view sees the object");
                    return;
                };
                let light = &best.scene.light;
                let message = format!(
                    "suggested view: light {:.0}° elevation, {:.0}° azimuth, camera yaw {:.0}°, \
                     pitch {:.0}°; {} of its {} bins are new",
                    light.elevation_deg,
                    light.azimuth_deg,
                    best.scene.camera.yaw_deg,
                    best.scene.camera.pitch_deg,
                    best.new_bins,
                    best.bins
                );
                match self.add_view(best.scene) {
                    Ok(()) => self.notify(message),
                    Err(e) => self.notify_error(e.to_string()),
                }
            }
            Analysis::NoBasis {
                what: AnalysisKind::RankedViews { request },
            } => {
                if self
                    .caller_ranking
                    .as_ref()
                    .is_some_and(|(r, _)| *r == request)
                {
                    self.caller_ranking = None;
                }
                if self.pending_suggestion == Some(request) {
                    self.pending_suggestion = None;
                    self.notify_error("no views to suggest until the basis is ready");
                }
            }
        }
    }

    /// Asks the worker to rank candidate views around the active one; the best is added
    /// when the answer arrives.
    pub fn suggest_view(&mut self) {
        if self.basis.is_none() {
            self.notify_error("no views to suggest until the basis is ready");
            return;
        }
        let Some(request) = self.request_ranking(SUGGEST_CANDIDATES) else {
            return;
        };
        self.pending_suggestion = Some(request);
        self.notify(format!(
            "ranking {SUGGEST_CANDIDATES} candidate views by what they would teach…"
        ));
    }

    /// Asks the worker to rank `candidates` views around the active one; `None` without a
    /// view. Returns the request the answer will carry.
    fn request_ranking(&mut self, candidates: usize) -> Option<u64> {
        let doc = self.active_view()?;
        let (base, object) = (Box::new(doc.scene().clone()), doc.object.clone());
        let request = self.next_request;
        self.next_request += 1;
        self.worker.send(Command::RankViews {
            request,
            base,
            object,
            candidates,
        });
        Some(request)
    }

    /// [`Self::settle`], then `candidates` views around the active one, ranked by what
    /// painting them would teach, best first (as `burnish suggest` lists them; "Suggest
    /// next view" adds the best instead). `None` on a timeout or without a basis.
    pub fn settled_ranking(
        &mut self,
        candidates: usize,
        timeout: Duration,
    ) -> Option<Vec<RankedView>> {
        let deadline = Instant::now() + timeout;
        self.settle(timeout)?;
        self.basis.as_ref()?;
        let request = self.request_ranking(candidates)?;
        self.caller_ranking = Some((request, None));
        loop {
            match &mut self.caller_ranking {
                Some((_, answer @ Some(_))) => {
                    let views = answer.take();
                    self.caller_ranking = None;
                    return views;
                }
                Some(_) if Instant::now() < deadline => {}
                _ => {
                    self.caller_ranking = None;
                    return None;
                }
            }
            std::thread::sleep(Duration::from_millis(2));
            self.poll();
        }
    }

    /// Whether a "Suggest next view" ranking is still on its way.
    pub fn suggestion_pending(&self) -> bool {
        self.pending_suggestion.is_some()
    }

    /// Asks for the table's uncertainty (it takes about a second) unless an estimate is on
    /// its way or the BRDF did not change since the last one; it arrives through
    /// [`Self::poll`].
    pub fn request_uncertainty(&mut self) {
        if self.uncertainty_pending
            || self.basis.is_none()
            || self.uncertainty_version == Some(self.snapshot.version)
        {
            return;
        }
        self.worker.send(Command::EstimateUncertainty);
        self.uncertainty_pending = true;
    }

    /// The BRDF as it stands once every background job the document started has landed
    /// (the basis, the predictions new views start from, file jobs) and the worker has
    /// solved everything sent to it, its prior's mean fitted to it: what a headless driver
    /// (the command line, a script) reads. `None` if that takes longer than `timeout`.
    pub fn settle(&mut self, timeout: Duration) -> Option<Arc<Snapshot>> {
        let deadline = Instant::now() + timeout;
        loop {
            self.poll();
            if !self.basis_working() && !self.predictions_pending() && !self.file_jobs_pending() {
                break;
            }
            if Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let snapshot = self
            .worker
            .sync(deadline.saturating_duration_since(Instant::now()))?;
        self.poll();
        Some(snapshot)
    }

    /// [`Self::settle`], then the posterior standard deviation of ρ per table entry and
    /// channel for that BRDF, waited for. `None` on a timeout or without a basis.
    pub fn settled_uncertainty(&mut self, timeout: Duration) -> Option<Arc<SymTable>> {
        let deadline = Instant::now() + timeout;
        let snapshot = self.settle(timeout)?;
        self.basis.as_ref()?;
        loop {
            if let Some(table) = &self.uncertainty_table
                && self.uncertainty_version >= Some(snapshot.version)
            {
                return Some(table.clone());
            }
            // (Re)ask while no estimate of this BRDF is on its way: one asked for earlier may
            // arrive for an older one.
            if !self.uncertainty_pending {
                self.worker.send(Command::EstimateUncertainty);
                self.uncertainty_pending = true;
            }
            if Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
            self.poll();
        }
    }

    /// Whether an uncertainty estimate is on its way.
    pub fn uncertainty_pending(&self) -> bool {
        self.uncertainty_pending
    }

    /// Sets what the unpainted pixels of the view at `index` say; the worker re-derives its
    /// samples.
    pub fn set_unpainted(&mut self, index: usize, rule: UnpaintedPixels) {
        let Some(doc) = self.views.get_mut(index) else {
            return;
        };
        if doc.settings.unpainted == rule {
            return;
        }
        doc.settings.unpainted = rule;
        self.worker.send(doc.paint_command());
        self.touch();
    }

    /// Sets what the paint of the view at `index` can express: `Hdr` reads a clipped 8-bit
    /// import's channels as exact values again.
    pub fn set_paint_range(&mut self, index: usize, range: PaintRange) {
        let Some(doc) = self.views.get_mut(index) else {
            return;
        };
        if doc.settings.paint_range == range {
            return;
        }
        doc.settings.paint_range = range;
        self.worker.send(doc.paint_command());
        self.touch();
    }

    /// Applies a changed scene to the view at `index`.
    pub fn set_scene(&mut self, index: usize, scene: Scene) -> crate::Result<()> {
        let Some(doc) = self.views.get_mut(index) else {
            return Ok(());
        };
        doc.set_scene(scene)?;
        self.awaiting_prediction.remove(&doc.id);
        self.worker.send(Command::SetView {
            view: doc.id,
            gbuffer: doc.gbuffer.clone(),
        });
        self.worker.send(doc.paint_command());
        self.canvas_revision += 1;
        self.touch();
        Ok(())
    }

    /// Sends the changes of an operation on the active canvas to the worker. Returns the
    /// pixels to show afresh.
    pub fn publish_canvas_changes(
        &mut self,
        changes: Option<CanvasChanges>,
        input_time: Instant,
    ) -> Option<PixelRect> {
        let changes = changes.filter(|c| !c.is_empty())?;
        let doc = self.views.get(self.active)?;
        // The worker hears what each pixel says under the view's rule: an unpainted pixel
        // that counts as shown states the base under it.
        let mut edits = changes.pixels;
        for c in &mut edits {
            c.before = doc.statement(c.pixel, c.before);
            c.after = doc.statement(c.pixel, c.after);
        }
        self.worker.send(Command::Pixels {
            view: doc.id,
            edits,
            input_time,
        });
        self.touch();
        Some(changes.dirty)
    }

    /// Takes back (`undo`) or repeats the active canvas's last edit. Returns the pixels to
    /// show afresh.
    pub fn undo_redo(&mut self, undo: bool) -> Option<PixelRect> {
        let canvas = self.active_canvas_mut()?;
        let changes = if undo { canvas.undo() } else { canvas.redo() };
        self.publish_canvas_changes(changes, Instant::now())
    }

    /// Fills the active view's object with the colour of `brush` (one undo step). Returns
    /// the pixels to show afresh.
    pub fn fill_active(&mut self, brush: &BrushSettings) -> Option<PixelRect> {
        let mut settings = brush.clone();
        settings.kind = BrushKind::Fill;
        let canvas = self.active_canvas_mut()?;
        canvas.fill(&settings);
        let changes = canvas.take_changes();
        self.publish_canvas_changes(changes, Instant::now())
    }

    /// Takes what background threads finished: the basis, answers of the worker's analysis
    /// thread, bin updates, the newest snapshot and finished file jobs.
    pub fn poll(&mut self) -> Polled {
        let mut polled = Polled::default();
        self.poll_basis();
        for answer in self.worker.take_analyses() {
            self.take_analysis(answer, &mut polled);
        }
        polled.bins = self.worker.take_bin_updates();
        for change in &polled.bins {
            match change.after {
                Some(_) => self.observed.insert(change.pair, change.inconsistent),
                None => self.observed.remove(&change.pair),
            };
        }
        let snapshot = self.worker.snapshot();
        if snapshot.version != self.snapshot.version {
            self.snapshot = snapshot;
        }
        self.take_file_jobs();
        polled
    }

    /// Hands the basis to the worker if the job has just finished it.
    pub fn poll_basis(&mut self) {
        if let Some(basis) = self.basis_job.take_result() {
            self.basis = Some(basis.clone());
            self.worker.send(Command::SetBasis(basis));
            if let BasisStatus::Ready {
                outcome: CacheOutcome::NotStored { reason },
                ..
            } = self.basis_job.status()
            {
                self.notify(format!(
                    "warning: the basis is used from memory but could not be cached, so the \
                     next start builds it again: {reason}"
                ));
            }
        }
    }

    /// Hands over the basis of a document started with [`BasisSource::Later`] (or replaces
    /// the one there is): the worker solves with it from now on.
    pub fn set_basis(&mut self, basis: Arc<Basis>) {
        self.basis_job = BasisJob::ready(basis_spec(&self.basis_settings), basis);
        self.poll_basis();
    }

    /// Whether the basis is still being loaded or built.
    pub fn basis_working(&self) -> bool {
        matches!(self.basis_job.status(), BasisStatus::Working { .. })
    }

    /// Asks for `wake` to be called when an autosave finishes (a window draws a frame then,
    /// which collects its outcome).
    pub fn set_autosave_waker(&mut self, wake: impl Fn() + Send + Sync + 'static) {
        if let Some(saver) = self.autosaver.as_mut() {
            saver.set_waker(wake);
        }
    }

    /// Starts an autosave when one is due (`brush` is saved with it; none starts while a
    /// stroke is painted). Returns when to call again, should nothing else happen before.
    pub fn autosave(&mut self, stroking: bool, brush: &BrushSettings) -> Option<Duration> {
        // While a recovery file waits for the user's answer, writing would replace it.
        if self.recovery_offer.is_some() {
            return None;
        }
        let mut saver = self.autosaver.take()?;
        let changed = std::mem::take(&mut self.changed_since_autosave);
        let now = Instant::now();
        saver.maybe_save(now, changed, stroking, || self.to_session(brush));
        if let Some(e) = saver.take_error()
            && !self.autosave_failing
        {
            self.autosave_failing = true;
            self.notify_error(format!(
                "autosave failed: {e}. The painting is kept in memory; autosave tries again \
                 every {} s, and Save still works elsewhere.",
                crate::session::AUTOSAVE_RETRY.as_secs()
            ));
        }
        if self.autosave_failing && !saver.is_failing() && !saver.is_writing() {
            self.autosave_failing = false;
            self.notify(format!("autosave works again ({})", saver.path().display()));
        }
        let wait = saver.wake_in(now);
        self.autosaver = Some(saver);
        wait
    }

    /// The recovery file autosave writes, if autosave is on.
    pub fn recovery_file(&self) -> Option<&Path> {
        self.autosaver.as_ref().map(|s| s.path())
    }

    /// Waits for an autosave under way (tests).
    pub fn flush_autosave(&mut self) -> crate::Result<()> {
        self.autosaver.as_mut().map_or(Ok(()), |s| s.flush())
    }

    /// The recovery file found at start, while the user has not answered.
    pub fn recovery_offer(&self) -> Option<&RecoveryInfo> {
        self.recovery_offer.as_ref()
    }

    /// The user declined the recovery file: it is deleted.
    pub fn discard_recovery_offer(&mut self) {
        if let Some(info) = self.recovery_offer.take() {
            let _ = std::fs::remove_file(&info.path);
        }
    }

    /// After the user's own save: recovery would only repeat it.
    fn saved_to(&mut self, path: Option<PathBuf>) {
        if let Some(saver) = self.autosaver.as_mut() {
            saver.set_session_path(path);
            // A recovery file still waiting for the user's answer is another session's work.
            if !self.dirty && self.recovery_offer.is_none() {
                let _ = saver.discard();
            }
        }
    }

    /// Ends cleanly: the recovery file goes (unless it is another session's, still offered).
    pub fn discard_recovery(&mut self) {
        if let Some(saver) = self.autosaver.as_mut()
            && self.recovery_offer.is_none()
        {
            let _ = saver.discard();
        }
    }

    /// The material the painting starts from, if any.
    pub fn start_material(&self) -> Option<&StartMaterial> {
        self.start_material.as_ref()
    }

    /// The name of the material the painting starts from, if any.
    pub fn start_material_name(&self) -> Option<&str> {
        self.start_material.as_ref().map(|s| s.name.as_str())
    }
}
