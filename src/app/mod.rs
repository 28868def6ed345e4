//! The egui application: panels, menus and the canvas and preview widgets. It holds no
//! numerics: painting is `paint`, solving is `worker`, drawing the BRDF is `preview`.
//!
//! Layout: menus on top, the status bar at the bottom, the views and their scene setup on
//! the left, the live preview on the right and the canvas in the centre.

mod actions;
mod basis_job;
mod canvas_panel;
mod document;
mod file_jobs;
mod menus;
mod preview_panel;
mod side_panel;
mod status_bar;
mod widgets;

pub use actions::{Action, painting_mask_path};
pub use basis_job::{BasisJob, BasisStatus};
pub use document::{Base, ViewDoc};
pub use preview_panel::{PreviewState, Reference, TableOverlays, TableSource};

use crate::basis::{Basis, BasisCache, BasisSpec};
use crate::paint::{BrushPreset, BrushSettings, load_presets};
use crate::scene::Scene;
use crate::session::{Autosaver, BasisSettings, RecoveryInfo};
use crate::worker::{Analysis, AnalysisKind, Command, Snapshot, ViewId, Worker};
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// How the app starts.
pub struct AppConfig {
    /// A basis to use at once (tests); otherwise it is loaded or built in the background.
    pub basis: Option<Arc<Basis>>,
    /// The folder of the basis cache; `None`: [`BasisCache::default_location`].
    pub basis_cache: Option<PathBuf>,
    pub basis_settings: BasisSettings,
    /// Where brush presets are read from.
    pub brushes_dir: PathBuf,
    /// A session to open at start.
    pub session: Option<PathBuf>,
    /// Whether to autosave to the recovery file and offer recovery at start.
    pub autosave: bool,
    /// The recovery file; `None`: [`crate::session::recovery_path`].
    pub recovery_file: Option<PathBuf>,
    /// Recover a pending recovery file at start without asking (`burnish app --recover`).
    pub recover: bool,
    /// The first view's scene when no session is opened.
    pub scene: Scene,
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            basis: None,
            basis_cache: None,
            basis_settings: BasisSettings::default(),
            brushes_dir: default_brushes_dir(),
            session: None,
            autosave: true,
            recovery_file: None,
            recover: false,
            scene: Scene::default(),
        }
    }
}

/// brushes/ beside the executable's crate when run from a checkout, else the working folder's.
fn default_brushes_dir() -> PathBuf {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("brushes");
    if manifest.is_dir() {
        manifest
    } else {
        PathBuf::from("brushes")
    }
}

/// Which picture the right-hand panel shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PreviewTab {
    #[default]
    Object,
    /// Polar plot of the lobe for one incident direction.
    Lobe,
    /// The table image (paper's Figure 4).
    Table,
}

/// A message for the user: errors name the file and the problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Notice {
    pub text: String,
    pub is_error: bool,
}

/// The Burnish window.
pub struct BurnishApp {
    pub views: Vec<ViewDoc>,
    pub active: usize,
    next_view_id: ViewId,
    pub brush: BrushSettings,
    pub presets: Vec<BrushPreset>,
    pub worker: Worker,
    pub basis_job: BasisJob,
    pub basis_settings: BasisSettings,
    pub basis: Option<Arc<Basis>>,
    /// The basis cache folder asked for at start (`None`: the default location).
    basis_cache: Option<PathBuf>,
    /// The newest snapshot the UI has taken from the worker.
    pub snapshot: Arc<Snapshot>,
    /// Observed sparse bins and inconsistent ones, mirrored from the worker's updates.
    pub observed: HashMap<u32, [f32; 3]>,
    pub inconsistent: HashSet<u32>,
    /// The preview's camera, lights and mode.
    pub preview: crate::preview::PreviewFrame,
    pub preview_tab: PreviewTab,
    pub lobe_theta_deg: f32,
    pub lobe_phi_deg: f32,
    /// A scene edit waiting for the pointer to be released.
    pending_scene: Option<Scene>,
    /// The brush tip of the chosen preset, if it has one.
    pub active_tip: Option<Arc<crate::paint::TipMask>>,
    pub canvas_view: canvas_panel::CanvasView,
    pub show_overlay: bool,
    /// How strongly the view's guide shows over its canvas (the reference layer; 0: hidden).
    pub guide_opacity: f32,
    pub session_path: Option<PathBuf>,
    /// Whether anything changed since the last save.
    pub dirty: bool,
    /// Whether anything changed since the autosaver last looked.
    changed_since_autosave: bool,
    /// The window asked to close while there were unsaved changes.
    pub confirm_close: bool,
    autosaver: Option<Autosaver>,
    /// The last autosave failed and the user was told; cleared (and told) when one succeeds.
    autosave_failing: bool,
    pub recovery_offer: Option<RecoveryInfo>,
    pub notices: Vec<Notice>,
    /// Stroke-to-preview latencies in ms, oldest first (bounded).
    pub latencies_ms: Vec<f64>,
    preview_state: preview_panel::PreviewState,
    pending_actions: Vec<Action>,
    /// The material the painting starts from (saved with the session).
    pub start_material: Option<crate::session::StartMaterial>,
    /// Exports and starting materials being written or read off the UI thread.
    file_jobs: file_jobs::FileJobs,
    /// New views whose canvas waits for the prediction of the current BRDF; they give no
    /// samples until it arrives (or the worker says there is no basis to predict with).
    awaiting_prediction: HashSet<ViewId>,
    /// The ranking of candidate views asked for by "Suggest next view", until it arrives.
    pending_suggestion: Option<u64>,
    next_request: u64,
    /// The snapshot version the preview's uncertainty was estimated for, and whether an
    /// estimate is on its way.
    uncertainty_version: Option<u64>,
    uncertainty_pending: bool,
}

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

/// The preview's starting frame: the scene's camera and light, bins interpolated.
fn preview_frame(scene: &Scene) -> crate::preview::PreviewFrame {
    let mut frame = crate::preview::PreviewFrame::from_scene(scene);
    frame.interpolate = true;
    frame
}

/// Latencies kept for the status bar and the benchmark.
const LATENCY_HISTORY: usize = 4096;

impl BurnishApp {
    /// The app, with the wgpu render state of `cc` (when the backend is wgpu) for the preview.
    pub fn new(cc: &eframe::CreationContext<'_>, config: AppConfig) -> Self {
        let mut app = Self::headless(config);
        if let Some(saver) = app.autosaver.as_mut() {
            // A finished autosave asks for a frame, which collects its outcome and starts the
            // next write if changes came in meanwhile.
            let ctx = cc.egui_ctx.clone();
            saver.set_waker(move || ctx.request_repaint());
        }
        // A session opened by `headless` may have set a reference (its starting material).
        let reference = app.preview_state.reference.take();
        app.preview_state = preview_panel::PreviewState::new(cc.wgpu_render_state.as_ref());
        app.preview_state.reference = reference;
        if let Some(e) = app.preview_state.init_error.clone() {
            app.notify_error(format!("preview: {e}"));
        }
        app
    }

    /// The app without a window (the state the UI drives); `new` adds the GPU preview.
    pub fn headless(config: AppConfig) -> Self {
        let settings = config.basis_settings;
        let worker = Worker::spawn(settings.policy, settings.regularization);
        let spec = basis_spec(&settings);
        let basis_job = match config.basis {
            Some(basis) => BasisJob::ready(spec, basis),
            None => BasisJob::start(spec, config.basis_cache.clone().map(BasisCache::at)),
        };
        let (presets, preset_errors) = load_presets(&config.brushes_dir);
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
        let mut app = Self {
            views: Vec::new(),
            active: 0,
            next_view_id: 0,
            brush: presets
                .first()
                .map(|p| p.settings.clone())
                .unwrap_or_default(),
            presets,
            worker,
            basis_job,
            basis_settings: settings,
            basis: None,
            basis_cache: config.basis_cache.clone(),
            snapshot: Arc::new(Snapshot::default()),
            observed: HashMap::new(),
            inconsistent: HashSet::new(),
            preview: preview_frame(&config.scene),
            preview_tab: PreviewTab::Object,
            lobe_theta_deg: 45.0,
            lobe_phi_deg: 0.0,
            pending_scene: None,
            active_tip: None,
            canvas_view: canvas_panel::CanvasView::default(),
            show_overlay: false,
            guide_opacity: 0.0,
            session_path: None,
            dirty: false,
            changed_since_autosave: false,
            confirm_close: false,
            autosaver,
            autosave_failing: false,
            recovery_offer: None,
            notices: Vec::new(),
            latencies_ms: Vec::new(),
            preview_state: preview_panel::PreviewState::default(),
            pending_actions: Vec::new(),
            start_material: None,
            file_jobs: file_jobs::FileJobs::default(),
            awaiting_prediction: HashSet::new(),
            pending_suggestion: None,
            next_request: 0,
            uncertainty_version: None,
            uncertainty_pending: false,
        };
        for e in preset_errors {
            app.notify_error(format!("brush preset skipped: {e}"));
        }
        match recovery_offer {
            Some(Ok(offer)) => app.recovery_offer = offer,
            Some(Err(e)) => app.notify_error(e.to_string()),
            None => {}
        }
        let opened = match config.session {
            Some(path) => app.open_session(&path).is_ok(),
            None => false,
        };
        if !opened {
            if let Err(e) = app.add_view(config.scene) {
                app.notify_error(e.to_string());
                let _ = app.add_view(Scene::default());
            }
            app.dirty = false;
        }
        // Setting up the first view is not the user's work: nothing to autosave yet.
        app.changed_since_autosave = false;
        if config.recover && app.recovery_offer.is_some() {
            app.perform(Action::Recover);
        }
        app.poll_basis();
        app
    }

    /// Marks the session changed (unsaved, and due for the next autosave).
    pub fn touch(&mut self) {
        self.dirty = true;
        self.changed_since_autosave = true;
    }

    pub fn notify_error(&mut self, text: impl Into<String>) {
        self.notices.push(Notice {
            text: text.into(),
            is_error: true,
        });
    }

    pub fn notify(&mut self, text: impl Into<String>) {
        self.notices.push(Notice {
            text: text.into(),
            is_error: false,
        });
    }

    pub fn active_view(&self) -> Option<&ViewDoc> {
        self.views.get(self.active)
    }

    pub fn active_view_mut(&mut self) -> Option<&mut ViewDoc> {
        self.views.get_mut(self.active)
    }

    /// Adds a view of `scene` and makes it active.
    pub fn add_view(&mut self, scene: Scene) -> crate::Result<()> {
        let id = self.next_view_id;
        let doc = ViewDoc::new(id, format!("View {}", id + 1), scene)?;
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
            self.worker.send(Command::ReplacePaint {
                view: id,
                painted: doc.counted_pixels(),
            });
        }
        self.views.push(doc);
        self.active = self.views.len() - 1;
        self.canvas_view.invalidate();
        self.touch();
        Ok(())
    }

    /// Closes the view at `index`; its samples leave the table.
    pub fn remove_view(&mut self, index: usize) {
        if index >= self.views.len() || self.views.len() == 1 {
            return;
        }
        let doc = self.views.remove(index);
        self.worker.send(Command::RemoveView(doc.id));
        self.active = self.active.min(self.views.len() - 1);
        self.canvas_view.invalidate();
        self.touch();
    }

    pub fn set_muted(&mut self, index: usize, muted: bool) {
        if let Some(doc) = self.views.get_mut(index) {
            doc.muted = muted;
            self.worker.send(Command::MuteView {
                view: doc.id,
                muted,
            });
            self.touch();
        }
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
    fn take_analysis(&mut self, answer: Analysis) {
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
                self.worker.send(Command::ReplacePaint {
                    view,
                    painted: doc.counted_pixels(),
                });
                if index == self.active {
                    self.canvas_view.invalidate();
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
                    self.worker.send(Command::ReplacePaint {
                        view,
                        painted: doc.counted_pixels(),
                    });
                }
                self.notify("no BRDF to predict yet: the view shows the guide");
            }
            Analysis::Uncertainty { version, std_dev } => {
                self.uncertainty_pending = false;
                self.uncertainty_version = Some(version);
                self.preview_state.uncertainty = Some(std_dev);
            }
            Analysis::NoBasis {
                what: AnalysisKind::Uncertainty,
            } => self.uncertainty_pending = false,
            Analysis::RankedViews { request, views, .. } => {
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
        let Some(doc) = self.active_view() else {
            return;
        };
        let (base, object) = (Box::new(doc.scene.clone()), doc.object.clone());
        let request = self.next_request;
        self.next_request += 1;
        self.worker.send(Command::RankViews {
            request,
            base,
            object,
            candidates: SUGGEST_CANDIDATES,
        });
        self.pending_suggestion = Some(request);
        self.notify(format!(
            "ranking {SUGGEST_CANDIDATES} candidate views by what they would teach…"
        ));
    }

    /// Whether a "Suggest next view" ranking is still on its way.
    pub fn suggestion_pending(&self) -> bool {
        self.pending_suggestion.is_some()
    }

    /// Asks for the table's uncertainty when the table tab's overlay shows it and the BRDF
    /// changed since the last estimate, once a stroke has ended (it takes about a second).
    fn request_uncertainty(&mut self) {
        let wanted = self.preview_state.table_overlays.uncertain;
        if !wanted
            || self.uncertainty_pending
            || self.basis.is_none()
            || self.canvas_view.is_stroking()
            || self.uncertainty_version == Some(self.snapshot.version)
        {
            return;
        }
        self.worker.send(Command::EstimateUncertainty);
        self.uncertainty_pending = true;
    }

    /// Whether an uncertainty estimate is on its way.
    pub fn uncertainty_pending(&self) -> bool {
        self.uncertainty_pending
    }

    /// Sets what the unpainted pixels of the view at `index` say; the worker re-derives its
    /// samples.
    pub fn set_unpainted(&mut self, index: usize, rule: crate::paint::UnpaintedPixels) {
        let Some(doc) = self.views.get_mut(index) else {
            return;
        };
        if doc.unpainted == rule {
            return;
        }
        doc.unpainted = rule;
        self.worker.send(Command::ReplacePaint {
            view: doc.id,
            painted: doc.counted_pixels(),
        });
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
        self.worker.send(Command::ReplacePaint {
            view: doc.id,
            painted: doc.counted_pixels(),
        });
        self.canvas_view.invalidate();
        self.touch();
        Ok(())
    }

    /// Sends a canvas operation's changes to the worker and marks the texture for upload.
    pub(crate) fn publish_canvas_changes(
        &mut self,
        changes: Option<crate::paint::CanvasChanges>,
        input_time: Instant,
    ) {
        let Some(changes) = changes.filter(|c| !c.is_empty()) else {
            return;
        };
        let Some(doc) = self.views.get(self.active) else {
            return;
        };
        self.canvas_view.mark_dirty(changes.dirty);
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
    }

    /// Takes what background threads finished: the basis, snapshots and bin updates.
    pub fn poll_background(&mut self) {
        self.poll_basis();
        for answer in self.worker.take_analyses() {
            self.take_analysis(answer);
        }
        for update in self.worker.take_bin_updates() {
            match update.value {
                Some(v) => self.observed.insert(update.pair, v),
                None => self.observed.remove(&update.pair),
            };
            if update.inconsistent {
                self.inconsistent.insert(update.pair);
            } else {
                self.inconsistent.remove(&update.pair);
            }
            self.preview_state.queue_sparse(update.pair, update.value);
        }
        let snapshot = self.worker.snapshot();
        if snapshot.version != self.snapshot.version {
            self.snapshot = snapshot;
        }
        self.take_file_jobs();
        self.request_uncertainty();
    }

    fn poll_basis(&mut self) {
        if let Some(basis) = self.basis_job.take_result() {
            self.basis = Some(basis.clone());
            self.worker.send(Command::SetBasis(basis));
            if let BasisStatus::Ready {
                outcome: crate::basis::CacheOutcome::NotStored { reason },
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

    /// Records the latency of the newest snapshot the first time a frame draws it.
    pub(crate) fn record_drawn(&mut self, version: u64, oldest_input: Option<Instant>) {
        if let Some(t) = oldest_input
            && self.preview_state.last_drawn_version < version
        {
            if self.latencies_ms.len() == LATENCY_HISTORY {
                self.latencies_ms.remove(0);
            }
            self.latencies_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        self.preview_state.last_drawn_version = version;
    }

    /// Where the last frame drew the canvas (in points) and the canvas resolution.
    pub fn canvas_layout(&self) -> Option<(egui::Rect, usize)> {
        self.canvas_view.last_layout
    }

    /// Where the last frame drew the object preview, in points.
    pub fn preview_rect(&self) -> Option<egui::Rect> {
        self.preview_state.last_rect
    }

    /// The stroke-to-preview latency percentile `q` in [0, 1], in ms.
    pub fn latency_percentile(&self, q: f64) -> Option<f64> {
        if self.latencies_ms.is_empty() {
            return None;
        }
        let mut sorted = self.latencies_ms.clone();
        sorted.sort_by(f64::total_cmp);
        let i = ((sorted.len() - 1) as f64 * q).round() as usize;
        Some(sorted[i])
    }

    /// Queues an action for the next frame (menus, shortcuts, tests).
    pub fn queue(&mut self, action: Action) {
        self.pending_actions.push(action);
    }

    /// Starts an autosave when one is due and asks egui for a frame when the next one will
    /// be: an idle window draws no frames, and the write must not wait for the next input.
    fn autosave(&mut self, ctx: &egui::Context) {
        // While a recovery file waits for the user's answer, writing would replace it.
        if self.recovery_offer.is_some() {
            return;
        }
        let Some(mut saver) = self.autosaver.take() else {
            return;
        };
        let changed = std::mem::take(&mut self.changed_since_autosave);
        let now = Instant::now();
        saver.maybe_save(now, changed, self.canvas_view.is_stroking(), || {
            self.to_session()
        });
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
        if let Some(wait) = saver.wake_in(now) {
            ctx.request_repaint_after(wait);
        }
        self.autosaver = Some(saver);
    }

    /// The basis cache folder asked for at start (`None`: the default location).
    pub fn basis_cache(&self) -> Option<PathBuf> {
        self.basis_cache.clone()
    }

    /// The recovery file autosave writes, if autosave is on.
    pub fn recovery_file(&self) -> Option<&std::path::Path> {
        self.autosaver.as_ref().map(|s| s.path())
    }

    /// Waits for an autosave under way (tests).
    pub fn flush_autosave(&mut self) -> crate::Result<()> {
        self.autosaver.as_mut().map_or(Ok(()), |s| s.flush())
    }

    /// After the user's own save: recovery would only repeat it.
    pub(crate) fn saved_to(&mut self, path: Option<PathBuf>) {
        if let Some(saver) = self.autosaver.as_mut() {
            saver.set_session_path(path);
            // A recovery file still waiting for the user's answer is another session's work.
            if !self.dirty && self.recovery_offer.is_none() {
                let _ = saver.discard();
            }
        }
    }

    /// Ends cleanly: the recovery file goes (unless it is another session's, still offered).
    pub(crate) fn discard_recovery(&mut self) {
        if let Some(saver) = self.autosaver.as_mut()
            && self.recovery_offer.is_none()
        {
            let _ = saver.discard();
        }
    }
}

impl eframe::App for BurnishApp {
    fn logic(&mut self, ctx: &egui::Context, _frame: &mut eframe::Frame) {
        self.poll_background();
        for action in std::mem::take(&mut self.pending_actions) {
            self.perform(action);
        }
        self.autosave(ctx);
        let pointer_down = ctx.input(|i| i.pointer.any_down());
        if !pointer_down && *self.basis_job.spec() != basis_spec(&self.basis_settings) {
            self.restart_basis();
        }
        if matches!(self.basis_job.status(), BasisStatus::Working { .. })
            || self.worker.queued() > 0
            || self.snapshot.version != self.preview_state.last_drawn_version
        {
            ctx.request_repaint();
        }
        if self.file_jobs_pending() {
            // Look again soon: a finished job's outcome is taken at the next frame.
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
        if ctx.input(|i| i.viewport().close_requested()) {
            if self.dirty {
                // Ask first; the recovery file stays until the user decides.
                ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
                self.confirm_close = true;
            } else {
                self.discard_recovery();
            }
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        menus::shortcuts(self, ui.ctx());
        egui::Panel::top("menu").show(ui, |ui| menus::menu_bar(self, ui));
        egui::Panel::bottom("status").show(ui, |ui| status_bar::show(self, ui));
        egui::Panel::left("views")
            .resizable(true)
            .default_size(260.0)
            .show(ui, |ui| side_panel::show(self, ui));
        egui::Panel::right("preview")
            .resizable(true)
            .default_size(ui.available_width() * 0.4)
            .show(ui, |ui| preview_panel::show(self, ui));
        egui::CentralPanel::default().show(ui, |ui| canvas_panel::show(self, ui));
        menus::dialogs(self, ui.ctx());
        // The frame's strokes and actions are in: write them (or schedule the write) now.
        self.autosave(ui.ctx());
    }
}

/// Opens the Burnish window (the default command).
pub fn run(config: AppConfig) -> anyhow::Result<()> {
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("Burnish")
            .with_inner_size([1500.0, 900.0])
            .with_min_inner_size([900.0, 600.0]),
        ..Default::default()
    };
    eframe::run_native(
        "Burnish",
        options,
        Box::new(move |cc| Ok(Box::new(BurnishApp::new(cc, config)))),
    )
    .map_err(|e| anyhow::anyhow!("could not open the window: {e}"))
}
