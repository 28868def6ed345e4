//! The egui application: panels, menus and the canvas and preview widgets over a
//! [`Document`], which holds the views, the worker and the session. It holds no numerics:
//! painting is `paint`, solving is `worker`, drawing the BRDF is `preview`.
//!
//! Layout: menus on top, the status bar at the bottom, the views and their scene setup on
//! the left, the live preview on the right and the canvas in the centre.

mod actions;
mod canvas_panel;
mod commands;
mod menus;
mod preview_panel;
mod side_panel;
mod status_bar;
mod widgets;

pub use crate::document::{
    Base, BasisJob, BasisStatus, Notice, SUGGEST_CANDIDATES, ViewDoc, basis_spec,
    painting_mask_path,
};
pub use actions::Action;
pub use commands::{UiCommand, When};
pub use preview_panel::{PreviewState, Reference, TableOverlays, TableSource};

use crate::basis::Basis;
use crate::document::{BasisSource, Document, DocumentConfig, Event};
use crate::paint::{BrushPreset, BrushSettings, load_presets};
use crate::scene::Scene;
use crate::session::BasisSettings;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// How the app starts.
pub struct AppConfig {
    /// A basis to use at once (tests); otherwise it is loaded or built in the background.
    pub basis: Option<Arc<Basis>>,
    /// The folder of the basis cache; `None`: [`crate::basis::BasisCache::default_location`].
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

/// The Burnish window: a UI over a [`Document`], with the state of its own panels.
pub struct BurnishApp {
    doc: Document,
    brush: BrushSettings,
    presets: Vec<BrushPreset>,
    /// The preview's camera, lights and mode.
    preview: crate::preview::PreviewFrame,
    preview_tab: PreviewTab,
    lobe_theta_deg: f32,
    lobe_phi_deg: f32,
    /// A scene edit waiting for the pointer to be released.
    pending_scene: Option<Scene>,
    /// The brush tip of the chosen preset, if it has one.
    active_tip: Option<Arc<crate::paint::TipMask>>,
    canvas_view: canvas_panel::CanvasView,
    show_overlay: bool,
    /// How strongly the view's guide shows over its canvas (the reference layer; 0: hidden).
    guide_opacity: f32,
    /// The window asked to close while there were unsaved changes.
    confirm_close: bool,
    notices: Vec<Notice>,
    /// Stroke-to-preview latencies in ms, oldest first (bounded).
    latencies_ms: Vec<f64>,
    preview_state: preview_panel::PreviewState,
    pending_actions: Vec<Action>,
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
        // A finished autosave asks for a frame, which collects its outcome and starts the
        // next write if changes came in meanwhile.
        let ctx = cc.egui_ctx.clone();
        app.doc.set_autosave_waker(move || ctx.request_repaint());
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
        let doc = Document::new(DocumentConfig {
            basis: config.basis.map_or(BasisSource::Load, BasisSource::Given),
            basis_cache: config.basis_cache,
            basis_settings: config.basis_settings,
            autosave: config.autosave,
            recovery_file: config.recovery_file,
        });
        let (presets, preset_errors) = load_presets(&config.brushes_dir);
        let mut app = Self {
            doc,
            brush: presets
                .first()
                .map(|p| p.settings.clone())
                .unwrap_or_default(),
            presets,
            preview: preview_frame(&config.scene),
            preview_tab: PreviewTab::Object,
            lobe_theta_deg: 45.0,
            lobe_phi_deg: 0.0,
            pending_scene: None,
            active_tip: None,
            canvas_view: canvas_panel::CanvasView::default(),
            show_overlay: false,
            guide_opacity: 0.0,
            confirm_close: false,
            notices: Vec::new(),
            latencies_ms: Vec::new(),
            preview_state: preview_panel::PreviewState::default(),
            pending_actions: Vec::new(),
        };
        for e in preset_errors {
            app.notify_error(format!("brush preset skipped: {e}"));
        }
        // A recovery file that cannot be read is reported after the presets.
        app.take_document_events();
        if let Some(brush) = app.doc.begin(config.session.as_deref(), config.scene) {
            app.brush = brush;
        }
        if config.recover && app.doc.recovery_offer().is_some() {
            app.perform(Action::Recover);
        }
        app.doc.poll_basis();
        app.take_document_events();
        app
    }

    /// The document the window shows: views, worker, basis and session.
    pub fn document(&self) -> &Document {
        &self.doc
    }

    pub fn document_mut(&mut self) -> &mut Document {
        &mut self.doc
    }

    /// The brush the artist holds (tool, size, colour…).
    pub fn brush(&self) -> &BrushSettings {
        &self.brush
    }

    pub fn brush_mut(&mut self) -> &mut BrushSettings {
        &mut self.brush
    }

    /// The brush presets read at start.
    pub fn presets(&self) -> &[BrushPreset] {
        &self.presets
    }

    /// The messages shown in the corner, oldest first.
    pub fn notices(&self) -> &[Notice] {
        &self.notices
    }

    /// Dismisses every message.
    pub fn clear_notices(&mut self) {
        self.notices.clear();
    }

    /// The preview's camera, lights and mode.
    pub fn preview_frame(&self) -> &crate::preview::PreviewFrame {
        &self.preview
    }

    pub fn preview_frame_mut(&mut self) -> &mut crate::preview::PreviewFrame {
        &mut self.preview
    }

    /// Which picture the right-hand panel shows.
    pub fn preview_tab(&self) -> PreviewTab {
        self.preview_tab
    }

    pub fn set_preview_tab(&mut self, tab: PreviewTab) {
        self.preview_tab = tab;
    }

    /// Whether the canvas shows the disagreement and coverage overlay.
    pub fn show_overlay(&self) -> bool {
        self.show_overlay
    }

    pub fn set_show_overlay(&mut self, show: bool) {
        self.show_overlay = show;
    }

    /// Stroke-to-preview latencies in ms, oldest first (the last few thousand).
    pub fn latencies_ms(&self) -> &[f64] {
        &self.latencies_ms
    }

    /// Shows what the document reported: its messages, and a starting material as the
    /// preview's reference.
    fn take_document_events(&mut self) {
        for event in self.doc.take_events() {
            match event {
                Event::Notice(notice) => self.notices.push(notice),
                Event::StartMaterial { name, table } => self.set_reference(name, table),
            }
        }
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

    /// The session as it stands: the document's views and settings with the brush.
    pub fn to_session(&self) -> crate::session::Session {
        self.doc.to_session(&self.brush)
    }

    /// Asks for the table's uncertainty when the table tab's overlay shows it, once a stroke
    /// has ended (it takes about a second).
    fn request_uncertainty(&mut self) {
        if self.preview_state.table_overlays.uncertain && !self.canvas_view.is_stroking() {
            self.doc.request_uncertainty();
        }
    }

    /// Sends a canvas operation's changes to the worker and marks the texture for upload.
    pub(crate) fn publish_canvas_changes(
        &mut self,
        changes: Option<crate::paint::CanvasChanges>,
        input_time: Instant,
    ) {
        if let Some(dirty) = self.doc.publish_canvas_changes(changes, input_time) {
            self.canvas_view.mark_dirty(dirty);
        }
    }

    /// Takes what background threads finished: the basis, snapshots and bin updates.
    pub fn poll_background(&mut self) {
        let polled = self.doc.poll();
        if let Some(std_dev) = polled.uncertainty {
            self.preview_state.uncertainty = Some(std_dev);
        }
        self.preview_state.queue_sparse(polled.bins);
        self.take_document_events();
        self.request_uncertainty();
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
        let wait = self
            .doc
            .autosave(self.canvas_view.is_stroking(), &self.brush);
        self.take_document_events();
        if let Some(wait) = wait {
            ctx.request_repaint_after(wait);
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
        if !pointer_down {
            self.doc.restart_basis();
        }
        if self.doc.basis_working()
            || self.doc.worker().queued() > 0
            || self.doc.snapshot().version != self.preview_state.last_drawn_version
        {
            ctx.request_repaint();
        }
        if self.doc.file_jobs_pending() || self.doc.snapshot().fitting_mean {
            // Look again soon: a finished job's outcome, or the solve on the prior's mean
            // fitted to the last strokes, is taken at the next frame.
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
        if ctx.input(|i| i.viewport().close_requested()) {
            if self.doc.is_dirty() {
                // Ask first; the recovery file stays until the user decides.
                ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
                self.confirm_close = true;
            } else {
                self.doc.discard_recovery();
            }
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        // What a caller asked of the document directly since the last frame.
        self.take_document_events();
        menus::shortcuts(self, ui.ctx());
        egui::Panel::top("menu").show(ui, |ui| menus::menu_bar(self, ui));
        egui::Panel::bottom("status").show(ui, |ui| status_bar::show(self, ui));
        egui::Panel::left("views")
            .resizable(true)
            .default_size(260.0)
            .show(ui, |ui| side_panel::show(self, ui));
        egui::Panel::right("preview")
            .frame(preview_panel::panel_frame(ui.style()))
            .resizable(true)
            .default_size(ui.available_width() * 0.4)
            .show(ui, |ui| preview_panel::show(self, ui));
        egui::CentralPanel::default()
            .frame(canvas_panel::central_frame(ui.style()))
            .show(ui, |ui| canvas_panel::show(self, ui));
        self.take_document_events();
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
