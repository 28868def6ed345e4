//! The right panel: the live wgpu preview of the object with the reconstructed BRDF, the
//! lobe plot and the table image.

use super::{BurnishApp, PreviewTab};
use crate::basis::Basis;
use crate::inspect::{LobeScale, TableWindow};
use crate::preview::{Environment, EnvironmentLight, PreviewMode, PreviewObject};
use crate::scene::Object;
use crate::solver::Reconstruction;
use crate::table::SymTable;
use lobe::{LobeCache, lobe_tab};
use object::object_tab;
use std::path::Path;
use std::sync::Arc;
use table::{TableCache, table_tab};

mod compare;
mod feed;
mod lobe;
mod object;
mod table;

/// A material to compare with: a table loaded from an EXR table or a MERL binary.
#[derive(Clone)]
pub struct Reference {
    pub name: String,
    pub table: Arc<SymTable>,
}

/// What the preview object on the GPU is: the painted view's (id, object name), or a choice.
#[derive(Clone, Debug, PartialEq)]
enum ObjectKey {
    View(u32, String),
    Chosen(PreviewObject),
}

/// Which BRDF the table tab shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TableSource {
    #[default]
    Reconstruction,
    Reference,
}

/// The overlays the table tab draws over the colour map.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TableOverlays {
    pub observed: bool,
    pub inconsistent: bool,
    /// Bins whose per-pair standard deviation is large against ρ (needs
    /// [`PreviewState::uncertainty`]).
    pub uncertain: bool,
}

/// What the preview keeps between frames.
pub struct PreviewState {
    /// Why the GPU preview is unavailable, if it is.
    pub init_error: Option<String>,
    /// The window's wgpu state, holding the preview renderer; `None` without a GPU preview.
    render_state: Option<egui_wgpu::RenderState>,
    /// The coefficients the GPU holds: the snapshot version they came from.
    uploaded_version: Option<u64>,
    /// Sparse bins changed since the GPU copy was last updated.
    pending_sparse: Vec<crate::solver::BinChange>,
    /// The snapshot version the last drawn frame showed.
    pub last_drawn_version: u64,
    /// The basis the GPU holds.
    uploaded_basis: Option<Arc<Basis>>,
    uploaded_object: Option<ObjectKey>,
    /// The preview's object, chosen apart from the painted view.
    pub object: PreviewObject,
    loaded_object: Option<(PreviewObject, Arc<Object>)>,
    /// The image the environment light samples.
    pub environment: Arc<Environment>,
    uploaded_environment: Option<Arc<Environment>>,
    /// A material to compare with, in the Lobe and Table tabs and as a preview mode.
    pub reference: Option<Reference>,
    uploaded_reference: Option<Arc<SymTable>>,
    pub lobe_scale: LobeScale,
    /// Incidence angles pinned beside the slider's, drawn together.
    pub lobe_angles: Vec<f32>,
    lobe: Option<LobeCache>,
    pub table_source: TableSource,
    pub table_overlays: TableOverlays,
    /// The part of the table the plot showed last, in bins.
    table_window: TableWindow,
    table: Option<TableCache>,
    /// Per unordered pair, the standard deviation of ρ, when the engine estimates one; the
    /// table tab's "uncertain" overlay draws it, estimated by the worker's analysis thread.
    pub uncertainty: Option<Arc<[f32]>>,
    /// The readout under the pointer in the table tab, as shown.
    pub table_readout: Option<String>,
    /// Where the last frame drew the table plot, in points.
    pub table_rect: Option<egui::Rect>,
    /// Where the last frame drew the object preview (in compare mode, the reconstruction's
    /// pane).
    pub last_rect: Option<egui::Rect>,
    /// Compare mode: the reconstruction beside the starting or reference material, and
    /// their difference.
    pub compare: bool,
    /// Where the difference view saturates, in stops.
    pub compare_stops: f32,
    /// Where the last frame drew the compare panes: reconstruction, material, difference.
    pub compare_rects: Option<[egui::Rect; 3]>,
}

impl Default for PreviewState {
    fn default() -> Self {
        Self {
            init_error: None,
            render_state: None,
            uploaded_version: None,
            pending_sparse: Vec::new(),
            last_drawn_version: 0,
            uploaded_basis: None,
            uploaded_object: None,
            object: PreviewObject::PaintedView,
            loaded_object: None,
            environment: Arc::new(Environment::studio()),
            uploaded_environment: None,
            reference: None,
            uploaded_reference: None,
            lobe_scale: LobeScale::Linear,
            lobe_angles: Vec::new(),
            lobe: None,
            table_source: TableSource::Reconstruction,
            table_overlays: TableOverlays::default(),
            table_window: TableWindow::FULL,
            table: None,
            uncertainty: None,
            table_readout: None,
            table_rect: None,
            last_rect: None,
            compare: false,
            compare_stops: 2.0,
            compare_rects: None,
        }
    }
}

impl PreviewState {
    pub fn new(render_state: Option<&egui_wgpu::RenderState>) -> Self {
        let mut state = Self::default();
        match render_state {
            // eframe's defaults: no multisampling, no depth buffer in egui's pass.
            Some(rs) => match crate::preview::install(rs, 1, None) {
                Ok(()) => state.render_state = Some(rs.clone()),
                Err(e) => state.init_error = Some(e.to_string()),
            },
            None => state.init_error = Some("the window has no wgpu renderer".into()),
        }
        state
    }

    /// The linear radiance the preview shows at `pos` (exposure taken out, so it is in the
    /// units the canvas paints in), read back from an off-screen render of the same frame;
    /// `None` on the background or without a GPU preview.
    pub fn pick(
        &self,
        frame: &crate::preview::PreviewFrame,
        rect: egui::Rect,
        pos: egui::Pos2,
        pixels_per_point: f32,
    ) -> Result<Option<[f32; 3]>, crate::preview::PreviewError> {
        let Some(rs) = &self.render_state else {
            return Ok(None);
        };
        // The texel under the pointer in the target the paint callback draws.
        let size = crate::preview::physical_size(rect, pixels_per_point);
        let origin = |v: f32| (v * pixels_per_point).round() as i64;
        let under = |v: f32| (v * pixels_per_point).floor() as i64;
        let (x, y) = (
            under(pos.x) - origin(rect.min.x),
            under(pos.y) - origin(rect.min.y),
        );
        if x < 0 || y < 0 {
            return Ok(None);
        }
        let pixel = [x as u32, y as u32];
        let radiance = crate::preview::with_renderer(rs, |renderer| {
            renderer.pick(&rs.device, &rs.queue, frame, size, pixel)
        });
        let unexposed = 2f32.powf(-frame.exposure_stops as f32);
        Ok(radiance
            .transpose()?
            .flatten()
            .map(|rgb| rgb.map(|c| (c * unexposed).max(0.0)))
            .filter(|rgb| rgb.iter().all(|c| c.is_finite())))
    }

    pub fn queue_sparse(&mut self, changes: Vec<crate::solver::BinChange>) {
        if self.render_state.is_some() {
            self.pending_sparse.extend(changes);
        }
    }
}

impl BurnishApp {
    /// What compare mode shows beside the reconstruction: the reference material if one is
    /// loaded, else the material the painting starts from.
    pub fn compared_material(&self) -> Option<(String, Arc<SymTable>)> {
        match (&self.preview_state.reference, self.doc.start_material()) {
            (Some(r), _) => Some((format!("reference: {}", r.name), r.table.clone())),
            (None, Some(s)) => Some((format!("start: {}", s.name), s.table.clone())),
            (None, None) => None,
        }
    }

    /// Loads a reference material to compare with: an EXR table (TABLE.md), a MERL binary
    /// (`.binary`) or an RGL `.bsdf`, chosen by the extension.
    pub fn load_reference(&mut self, path: &Path) -> crate::Result<()> {
        let table = crate::export::load_table(path)?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        self.set_reference(name, Arc::new(table));
        Ok(())
    }

    /// Shows `table` as the preview's reference material.
    pub fn set_reference(&mut self, name: String, table: Arc<SymTable>) {
        self.preview_state.reference = Some(Reference {
            name: name.clone(),
            table,
        });
        self.preview_state.lobe = None;
        self.preview_state.table = None;
        self.notify(format!("reference material {name} loaded"));
    }

    /// Lights the preview with an equirectangular OpenEXR image instead of the bundled studio.
    pub fn load_environment(&mut self, path: &Path) -> crate::Result<()> {
        let environment = Environment::from_exr(path)?;
        self.notify(format!("environment {} loaded", environment.name));
        self.preview_state.environment = Arc::new(environment);
        self.preview
            .environment
            .get_or_insert_with(EnvironmentLight::default);
        Ok(())
    }

    /// The preview's own object (chosen apart from the painted view).
    pub fn preview_object(&self) -> &PreviewObject {
        &self.preview_state.object
    }

    pub fn set_preview_object(&mut self, object: PreviewObject) {
        self.preview_state.object = object;
    }

    /// The preview's panel state: reference, lobe and table settings.
    pub fn preview_state_mut(&mut self) -> &mut PreviewState {
        &mut self.preview_state
    }

    pub fn preview_state(&self) -> &PreviewState {
        &self.preview_state
    }
}

/// The preview panel's contents, and its fill: the panel's frame has none (see
/// [`panel_frame`]), so it is painted here around the preview, which is opaque.
pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let whole_panel = ui.max_rect() + panel_frame(ui.style()).inner_margin;
    let fill_painter = ui.painter().clone();
    let fill = fill_painter.add(egui::Shape::Noop);
    ui.horizontal(|ui| {
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Object, "Object");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Lobe, "Lobe");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Table, "Table");
        ui.separator();
        reference_controls(app, ui);
    });
    ui.separator();
    let preview = match app.preview_tab {
        PreviewTab::Object => object_tab(app, ui),
        PreviewTab::Lobe => {
            lobe_tab(app, ui);
            None
        }
        PreviewTab::Table => {
            table_tab(app, ui);
            None
        }
    };
    fill_painter.set(
        fill,
        super::widgets::fill_around(
            whole_panel,
            preview.unwrap_or(egui::Rect::NOTHING),
            ui.visuals().panel_fill,
        ),
    );
}

/// The preview panel's frame: the standard side panel's without its fill, which [`show`]
/// paints.
pub(super) fn panel_frame(style: &egui::Style) -> egui::Frame {
    egui::Frame::side_top_panel(style).fill(egui::Color32::TRANSPARENT)
}

fn reference_controls(app: &mut BurnishApp, ui: &mut egui::Ui) {
    match &app.preview_state.reference {
        Some(reference) => {
            ui.label(format!("reference: {}", reference.name))
                .on_hover_text("Drawn dashed in the Lobe tab; a mode of the Object tab");
            if ui
                .small_button("×")
                .on_hover_text("Forget the reference")
                .clicked()
            {
                app.preview_state.reference = None;
                app.preview_state.lobe = None;
                app.preview_state.table_source = TableSource::Reconstruction;
                if app.preview.mode == PreviewMode::Table {
                    app.preview.mode = PreviewMode::Reconstruction;
                }
            }
        }
        None => {
            if ui
                .small_button("Load reference…")
                .on_hover_text("A BRDF to compare with: an EXR table, a MERL binary or a .bsdf")
                .clicked()
            {
                app.run_command(super::UiCommand::LoadReference, super::When::NextFrame);
            }
        }
    }
}

fn current_reconstruction(app: &BurnishApp) -> Option<Reconstruction> {
    app.doc.snapshot().reconstruction()
}
