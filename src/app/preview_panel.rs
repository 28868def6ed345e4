//! The right panel: the live wgpu preview of the object with the reconstructed BRDF, the
//! lobe plot and the table image.

use super::{BurnishApp, PreviewTab};
use crate::basis::Basis;
use crate::inspect::{
    LobeScale, Lookup, TableImage, TableWindow, bin_pair_angles, curves_bounds, incidence_plane,
    lobe_curve, lobe_floor, lobe_peak, pair_marks, relative_uncertainty, viridis,
};
use crate::preview::{DirectionalLight, Environment, EnvironmentLight, PreviewMode, PreviewObject};
use crate::scene::{BuiltinShape, Object};
use crate::solver::Reconstruction;
use crate::table::{DIRECTIONS, Rgb, SymTable, pair_index};
use crate::worker::Snapshot;
use egui::{Color32, ColorImage, Sense, TextureHandle, TextureOptions, Vec2};
use std::path::Path;
use std::sync::Arc;

/// Most pixels per side of the table image (it follows the plot's size below that).
const TABLE_IMAGE_MAX: usize = 640;
/// Decades the table's colour bar spans at most.
const TABLE_DECADES: u8 = 6;
/// Decades below the peak the lobe's log scale shows.
const LOBE_DECADES: u8 = 3;
/// The incidence angles offered for pinning beside the slider's.
const MAX_LOBE_ANGLES: usize = 6;

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

/// The lobes last plotted: what they were computed for, and per incidence angle the
/// reconstruction's and the reference's samples.
struct LobeCache {
    key: (u64, Vec<u32>, u32, bool),
    angles: Vec<f32>,
    lobes: Vec<Vec<(f64, Rgb)>>,
    reference: Vec<Vec<(f64, Rgb)>>,
    /// The plot was autoscaled to these lobes.
    scaled: bool,
    scale: LobeScale,
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

/// The table image last made: for what, and its textures.
struct TableCache {
    key: (u64, TableSource, [i64; 4], [usize; 2], TableOverlays, usize),
    image: TableImage,
    range: (f32, f32),
    texture: TextureHandle,
    overlay: Option<TextureHandle>,
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
    pending_sparse: Vec<(u32, Option<[f32; 3]>)>,
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

    pub fn queue_sparse(&mut self, pair: u32, value: Option<[f32; 3]>) {
        if self.render_state.is_some() {
            self.pending_sparse.push((pair, value));
        }
    }

    /// The object the preview draws: the chosen one, loaded once, or the painted view's.
    fn preview_object(
        &mut self,
        view: Option<(u32, &str, &Arc<Object>)>,
    ) -> Result<Option<(ObjectKey, Arc<Object>)>, String> {
        if self.object == PreviewObject::PaintedView {
            return Ok(view
                .map(|(id, name, object)| (ObjectKey::View(id, name.to_owned()), object.clone())));
        }
        if self.loaded_object.as_ref().map(|(o, _)| o) != Some(&self.object) {
            let object = self.object.load().map_err(|e| e.to_string())?;
            let object = object.expect("a chosen object is not the painted view's");
            self.loaded_object = Some((self.object.clone(), Arc::new(object)));
        }
        let (choice, object) = self.loaded_object.as_ref().expect("loaded above");
        Ok(Some((ObjectKey::Chosen(choice.clone()), object.clone())))
    }

    /// Hands the renderer what changed since the last frame: basis, coefficients, object,
    /// environment, reference table, sparse bins. Small writes only, except when the basis,
    /// a reference or an environment is new.
    fn feed(
        &mut self,
        snapshot: &Snapshot,
        view: Option<(u32, &str, &Arc<Object>)>,
    ) -> Option<String> {
        self.render_state.as_ref()?;
        let object = match self.preview_object(view) {
            Ok(object) => object,
            Err(e) => {
                // Back to the painted view's object; the error says why.
                self.object = PreviewObject::PaintedView;
                return Some(format!("preview object: {e}"));
            }
        };
        let rs = self.render_state.as_ref()?;
        let sparse = std::mem::take(&mut self.pending_sparse);
        let basis_changed = match (&snapshot.basis, &self.uploaded_basis) {
            (Some(b), Some(u)) => !Arc::ptr_eq(b, u),
            (Some(_), None) => true,
            _ => false,
        };
        let coefficients_changed = basis_changed || self.uploaded_version != Some(snapshot.version);
        let object_changed = object
            .as_ref()
            .is_some_and(|(key, _)| self.uploaded_object.as_ref() != Some(key));
        let environment_changed = self
            .uploaded_environment
            .as_ref()
            .is_none_or(|e| !Arc::ptr_eq(e, &self.environment));
        let reference = self.reference.as_ref().map(|r| r.table.clone());
        let reference_changed = match (&reference, &self.uploaded_reference) {
            (Some(r), Some(u)) => !Arc::ptr_eq(r, u),
            (Some(_), None) => true,
            _ => false,
        };
        let environment = self.environment.clone();
        let result = crate::preview::with_renderer(
            rs,
            |renderer| -> Result<(), crate::preview::PreviewError> {
                if let (true, Some(basis)) = (basis_changed, &snapshot.basis) {
                    renderer.set_basis(basis)?;
                }
                if coefficients_changed && snapshot.basis.is_some() {
                    renderer.set_coefficients(&snapshot.coefficients)?;
                }
                if let (true, Some((_, object))) = (object_changed, &object) {
                    renderer.set_object(object)?;
                }
                if environment_changed {
                    renderer.set_environment(&environment);
                }
                if let (true, Some(table)) = (reference_changed, &reference) {
                    renderer.set_table(table)?;
                }
                if !sparse.is_empty() {
                    renderer.update_sparse(&sparse)?;
                }
                Ok(())
            },
        )?;
        if basis_changed {
            self.uploaded_basis = snapshot.basis.clone();
        }
        if coefficients_changed {
            self.uploaded_version = Some(snapshot.version);
        }
        if let (true, Some((key, _))) = (object_changed, object) {
            self.uploaded_object = Some(key);
        }
        if environment_changed {
            self.uploaded_environment = Some(environment);
        }
        if reference_changed {
            self.uploaded_reference = reference;
        }
        result.err().map(|e| e.to_string())
    }
}

impl PreviewState {
    /// Hands the compare renderer (made on first use) the object, environment and the
    /// compared material's table, where they changed.
    fn feed_compare(
        &mut self,
        view: Option<(u32, &str, &Arc<Object>)>,
        table: &Arc<SymTable>,
    ) -> Option<String> {
        let rs = self.render_state.clone()?;
        let object = match self.preview_object(view) {
            Ok(Some((_, object))) => object,
            Ok(None) => return None,
            Err(e) => return Some(format!("preview object: {e}")),
        };
        let environment = self.environment.clone();
        match crate::preview::with_compare(&rs, |c| c.sync(&object, &environment, table)) {
            Ok(None | Some(Ok(()))) => None,
            Ok(Some(Err(e))) | Err(e) => Some(e.to_string()),
        }
    }

    /// Why the last compare pane could not be drawn, if it could not.
    fn compare_error(&self) -> Option<String> {
        let rs = self.render_state.as_ref()?;
        crate::preview::with_compare(rs, |c| c.last_error().map(str::to_owned))
            .ok()
            .flatten()
            .flatten()
    }
}

impl BurnishApp {
    /// What compare mode shows beside the reconstruction: the reference material if one is
    /// loaded, else the material the painting starts from.
    pub fn compared_material(&self) -> Option<(String, Arc<SymTable>)> {
        match (&self.preview_state.reference, &self.start_material) {
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

pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal(|ui| {
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Object, "Object");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Lobe, "Lobe");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Table, "Table");
        ui.separator();
        reference_controls(app, ui);
    });
    ui.separator();
    match app.preview_tab {
        PreviewTab::Object => object_tab(app, ui),
        PreviewTab::Lobe => lobe_tab(app, ui),
        PreviewTab::Table => table_tab(app, ui),
    }
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
                super::menus::pick_open(
                    app,
                    "Load reference material",
                    &["exr", "binary", "bsdf"],
                    super::Action::LoadReference,
                );
            }
        }
    }
}

const OBJECTS: [PreviewObject; 6] = [
    PreviewObject::PaintedView,
    PreviewObject::Builtin(BuiltinShape::Sphere),
    PreviewObject::Builtin(BuiltinShape::Torus),
    PreviewObject::Builtin(BuiltinShape::RoundedCube),
    PreviewObject::Builtin(BuiltinShape::Blob),
    PreviewObject::MaterialTest,
];

fn object_controls(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let has_reference = app.preview_state.reference.is_some();
    let can_compare = has_reference || app.start_material.is_some();
    let comparing = &mut app.preview_state.compare;
    let frame = &mut app.preview;
    ui.horizontal_wrapped(|ui| {
        let mut mode = |ui: &mut egui::Ui, mode: PreviewMode, text: &str, hover: &str| {
            let selected = frame.mode == mode && !*comparing;
            let response = ui.selectable_label(selected, text).on_hover_text(hover);
            if response.clicked() {
                frame.mode = mode;
                *comparing = false;
            }
            response
        };
        mode(
            ui,
            PreviewMode::Reconstruction,
            "Reconstruction",
            "The full BRDF the solver reconstructs",
        );
        mode(
            ui,
            PreviewMode::SparseOnly,
            "Sparse only",
            "Only what the paintings give directly; grey where no view reached",
        );
        mode(
            ui,
            PreviewMode::GuideMaterial,
            "Guide",
            "The guide's grey diffuse material",
        );
        ui.add_enabled_ui(has_reference, |ui| {
            mode(
                ui,
                PreviewMode::Table,
                "Reference",
                "The reference material loaded to compare with",
            )
            .on_disabled_hover_text("Load a reference material first");
        });
        ui.add_enabled_ui(can_compare, |ui| {
            if ui
                .selectable_label(*comparing, "Compare")
                .on_hover_text(
                    "The reconstruction beside the reference material (or the one the \
                     painting started from), on the same object under the same lights, and \
                     their difference in stops",
                )
                .on_disabled_hover_text(
                    "Nothing to compare with: start from a material or load a reference \
                     material first (File menu)",
                )
                .clicked()
            {
                *comparing = true;
                frame.mode = PreviewMode::Reconstruction;
            }
        });
    });
    if !can_compare {
        app.preview_state.compare = false;
    }
    if app.preview_state.compare {
        ui.horizontal_wrapped(|ui| {
            ui.add(
                egui::Slider::new(&mut app.preview_state.compare_stops, 0.25..=6.0)
                    .text("difference scale ±")
                    .suffix(" EV"),
            )
            .on_hover_text("Where the difference's colours saturate, in stops (EV)");
        });
    }
    let mut open_obj = false;
    ui.horizontal_wrapped(|ui| {
        let label = ui.label("object");
        let state = &mut app.preview_state;
        egui::ComboBox::from_id_salt("preview object")
            .selected_text(state.object.label())
            .show_ui(ui, |ui| {
                for choice in OBJECTS {
                    let text = choice.label();
                    ui.selectable_value(&mut state.object, choice, text);
                }
                if ui.button("Open OBJ…").clicked() {
                    open_obj = true;
                }
            })
            .response
            .labelled_by(label.id)
            .on_hover_text("What the preview shows the material on, apart from the painted view");
        let frame = &mut app.preview;
        ui.checkbox(&mut frame.shadows, "shadows");
        ui.checkbox(&mut frame.interpolate, "interpolate bins");
    });
    let frame = &mut app.preview;
    ui.horizontal_wrapped(|ui| {
        let mut second = frame.second_light.is_some();
        if ui.checkbox(&mut second, "second light").changed() {
            frame.second_light = second.then_some(DirectionalLight {
                elevation_deg: 20.0,
                azimuth_deg: -120.0,
                intensity: 0.5,
            });
        }
        let mut environment = frame.environment.is_some();
        if ui
            .checkbox(&mut environment, "environment")
            .on_hover_text("Light from an HDR image all around, through the same BRDF table")
            .changed()
        {
            frame.environment = environment.then(EnvironmentLight::default);
        }
        ui.add(
            egui::Slider::new(&mut frame.exposure_stops, -6.0..=6.0)
                .text("exposure")
                .suffix(" EV"),
        );
    });
    let mut load_environment = false;
    if let Some(environment) = &mut frame.environment {
        ui.horizontal_wrapped(|ui| {
            ui.label(format!(
                "environment: {}",
                app.preview_state.environment.name
            ));
            ui.add(egui::Slider::new(&mut environment.intensity, 0.0..=4.0).text("intensity"));
            ui.add(
                egui::Slider::new(&mut environment.rotation_deg, -180.0..=180.0)
                    .text("turn")
                    .suffix("°"),
            );
            load_environment = ui
                .small_button("Load HDR…")
                .on_hover_text("An equirectangular OpenEXR image")
                .clicked();
        });
    }
    if let Some(light) = &mut frame.second_light {
        ui.horizontal(|ui| {
            ui.label("second light");
            ui.add(egui::Slider::new(&mut light.intensity, 0.0..=2.0).text("intensity"));
            super::widgets::light_dial(ui, &mut light.elevation_deg, &mut light.azimuth_deg);
        });
    }
    if open_obj {
        super::menus::pick_open(
            app,
            "Preview object",
            &["obj"],
            super::Action::OpenPreviewObject,
        );
    }
    if load_environment {
        super::menus::pick_open(
            app,
            "Environment (equirectangular EXR)",
            &["exr"],
            super::Action::LoadEnvironment,
        );
    }
}

fn object_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    object_controls(app, ui);
    let compared = app
        .compared_material()
        .filter(|_| app.preview_state.compare && app.preview_state.render_state.is_some());
    let (rect, response, compare_layout) = match &compared {
        Some((name, _)) => {
            let layout = compare_layout(ui, name, app.preview_state.compare_stops);
            (layout.panes[0], layout.response.clone(), Some(layout))
        }
        None => {
            let side = ui.available_width().min(ui.available_height()).max(64.0);
            let (rect, response) =
                ui.allocate_exact_size(Vec2::splat(side), Sense::click_and_drag());
            (rect, response, None)
        }
    };
    app.preview_state.last_rect = Some(rect);
    app.preview_state.compare_rects = compare_layout.as_ref().map(|l| l.panes);
    // Drag orbits the camera; Shift + drag (or the secondary button) moves the light.
    let delta = response.drag_delta();
    let move_light =
        ui.input(|i| i.modifiers.shift) || response.dragged_by(egui::PointerButton::Secondary);
    if response.dragged() && delta != Vec2::ZERO {
        if move_light {
            let light = &mut app.preview.light;
            light.azimuth_deg = wrap_degrees(light.azimuth_deg + delta.x as f64 * 0.5);
            light.elevation_deg = (light.elevation_deg - delta.y as f64 * 0.5).clamp(1.0, 90.0);
        } else {
            let camera = &mut app.preview.camera;
            camera.yaw_deg = wrap_degrees(camera.yaw_deg - delta.x as f64 * 0.5);
            camera.pitch_deg = (camera.pitch_deg + delta.y as f64 * 0.5).clamp(-89.0, 89.0);
        }
    }
    if app.brush.kind == crate::paint::BrushKind::Eyedropper
        && response.clicked()
        && let Some(pos) = response.interact_pointer_pos()
    {
        let ppp = ui.ctx().pixels_per_point();
        match app.preview_state.pick(&app.preview, rect, pos, ppp) {
            Ok(Some(colour)) => app.brush.colour = colour,
            Ok(None) => {}
            Err(e) => app.notify_error(format!("preview eyedropper: {e}")),
        }
    }
    if response.double_clicked()
        && let Some(doc) = app.active_view()
    {
        let scene = doc.scene.clone();
        let previous = app.preview.clone();
        app.preview = crate::preview::PreviewFrame::from_scene(&scene);
        app.preview.mode = previous.mode;
        app.preview.environment = previous.environment;
        app.preview.second_light = previous.second_light;
        app.preview.exposure_stops = previous.exposure_stops;
        app.preview.interpolate = true;
    }
    if app.preview_state.render_state.is_none() {
        ui.painter()
            .rect_filled(rect, 0.0, ui.visuals().extreme_bg_color);
        let text = format!(
            "No GPU preview: {}",
            app.preview_state
                .init_error
                .as_deref()
                .unwrap_or("no renderer")
        );
        ui.painter().text(
            rect.center(),
            egui::Align2::CENTER_CENTER,
            text,
            egui::FontId::proportional(14.0),
            ui.visuals().error_fg_color,
        );
        return;
    }
    if app.preview.mode == PreviewMode::Table && app.preview_state.reference.is_none() {
        app.preview.mode = PreviewMode::Reconstruction;
    }
    let snapshot = app.snapshot.clone();
    let view = app
        .views
        .get(app.active)
        .map(|doc| (doc.id, doc.scene.object.clone(), doc.object.clone()));
    let error = app.preview_state.feed(
        &snapshot,
        view.as_ref().map(|(id, name, o)| (*id, name.as_str(), o)),
    );
    if let Some(error) = error {
        app.notify_error(format!("preview: {error}"));
    }
    // While a stroke is painted on the canvas, a draft (a quarter of the gather); the stroke's
    // end refines it.
    let canvas = app.canvas_layout().map(|(rect, _)| rect);
    app.preview.draft = ui.input(|i| {
        i.pointer.primary_down()
            && i.pointer
                .press_origin()
                .zip(canvas)
                .is_some_and(|(origin, canvas)| canvas.contains(origin))
    });
    let ppp = ui.ctx().pixels_per_point();
    ui.painter().add(crate::preview::paint_callback(
        rect,
        ppp,
        app.preview.clone(),
    ));
    if let (Some((_, table)), Some(layout)) = (&compared, &compare_layout) {
        let view = app
            .views
            .get(app.active)
            .map(|doc| (doc.id, doc.scene.object.clone(), doc.object.clone()));
        let error = app.preview_state.feed_compare(
            view.as_ref().map(|(id, name, o)| (*id, name.as_str(), o)),
            table,
        );
        if let Some(error) = error {
            app.notify_error(format!("preview: {error}"));
        }
        let stops = app.preview_state.compare_stops;
        for (pane, kind) in [
            (layout.panes[1], crate::preview::ComparePane::Material),
            (
                layout.panes[2],
                crate::preview::ComparePane::Difference { stops },
            ),
        ] {
            ui.painter().add(crate::preview::compare_callback(
                pane,
                ppp,
                app.preview.clone(),
                kind,
            ));
        }
        if let Some(error) = app.preview_state.compare_error() {
            ui.painter().text(
                layout.panes[1].center(),
                egui::Align2::CENTER_CENTER,
                error,
                egui::FontId::proportional(12.0),
                ui.visuals().error_fg_color,
            );
        }
    }
    app.record_drawn(snapshot.version, snapshot.oldest_input);
}

/// Where compare mode draws: the reconstruction and the compared material side by side
/// (the same size, so that each pixel of one faces the same pixel of the other), and below
/// them their difference with its scale.
struct CompareLayout {
    /// Reconstruction, compared material, difference.
    panes: [egui::Rect; 3],
    /// Dragging over the two top panes orbits the camera (or moves the light).
    response: egui::Response,
}

fn compare_layout(ui: &mut egui::Ui, compared: &str, stops: f32) -> CompareLayout {
    let row = ui.text_style_height(&egui::TextStyle::Body) + ui.spacing().item_spacing.y;
    let width = ui.available_width();
    let pane = (width / 2.0)
        .min((ui.available_height() - 2.0 * row) / 2.0)
        .max(32.0)
        .floor();
    ui.horizontal(|ui| {
        let label = |ui: &mut egui::Ui, text: &str| {
            ui.add_sized(
                [pane - ui.spacing().item_spacing.x, row],
                egui::Label::new(text).truncate(),
            );
        };
        label(ui, "reconstruction");
        label(ui, compared);
    });
    let (top, response) =
        ui.allocate_exact_size(Vec2::new(2.0 * pane, pane), Sense::click_and_drag());
    let left = egui::Rect::from_min_size(top.min, Vec2::splat(pane));
    let right = egui::Rect::from_min_size(top.min + Vec2::new(pane, 0.0), Vec2::splat(pane));
    ui.label("difference: reconstruction against it, in the channel that differs most")
        .on_hover_text(
            "Per pixel, log2 of the reconstruction's radiance over the compared material's: \
             black where they agree, orange where the reconstruction is brighter, blue where \
             it is darker",
        );
    let difference = ui
        .horizontal(|ui| {
            let (difference, _) = ui.allocate_exact_size(Vec2::splat(pane), Sense::hover());
            difference_legend(ui, stops, pane);
            difference
        })
        .inner;
    CompareLayout {
        panes: [left, right, difference],
        response,
    }
}

/// A vertical bar of the difference's colours from −`stops` to +`stops`, labelled.
fn difference_legend(ui: &mut egui::Ui, stops: f32, height: f32) {
    let (rect, _) = ui.allocate_exact_size(Vec2::new(150.0, height), Sense::hover());
    let bar = egui::Rect::from_min_size(
        rect.min + Vec2::new(4.0, 8.0),
        Vec2::new(14.0, (height - 16.0).max(8.0)),
    );
    let steps = 64;
    let painter = ui.painter();
    for i in 0..steps {
        let t = (i as f32 + 0.5) / steps as f32 * 2.0 - 1.0;
        let [r, g, b] = crate::preview::difference_colour(t);
        let y1 = bar.max.y - bar.height() * i as f32 / steps as f32;
        let y0 = bar.max.y - bar.height() * (i + 1) as f32 / steps as f32;
        painter.rect_filled(
            egui::Rect::from_min_max(egui::pos2(bar.min.x, y0), egui::pos2(bar.max.x, y1)),
            0.0,
            Color32::from(egui::Rgba::from_rgb(r, g, b)),
        );
    }
    let text = |y: f32, label: String| {
        painter.text(
            egui::pos2(bar.max.x + 4.0, y),
            egui::Align2::LEFT_CENTER,
            label,
            egui::FontId::proportional(11.0),
            ui.visuals().text_color(),
        );
    };
    text(bar.min.y, format!("+{stops:.2} EV brighter"));
    text(bar.center().y, "0 same".into());
    text(bar.max.y, format!("−{stops:.2} EV darker"));
}

fn wrap_degrees(deg: f64) -> f64 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

fn current_reconstruction(app: &BurnishApp) -> Option<Reconstruction> {
    let snapshot = &app.snapshot;
    let basis = snapshot.basis.clone()?;
    let (n, k) = (snapshot.coefficients.len(), basis.components());
    (n == k || n == crate::solver::BANDS * k)
        .then(|| Reconstruction::new(basis, &snapshot.coefficients))
}

/// Colours for several lobes at once: spread over viridis, skipping its darkest end (it
/// hides on the plot's dark background).
fn lobe_colour(i: usize, count: usize) -> Color32 {
    let t = if count <= 1 {
        0.7
    } else {
        0.3 + 0.7 * i as f32 / (count - 1) as f32
    };
    let [r, g, b] = viridis(t).map(|c| (c * 255.0).round() as u8);
    Color32::from_rgb(r, g, b)
}

fn lobe_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal_wrapped(|ui| {
        ui.add(
            egui::Slider::new(&mut app.lobe_theta_deg, 0.0..=89.0)
                .text("θ in")
                .suffix("°"),
        );
        ui.add(
            egui::Slider::new(&mut app.lobe_phi_deg, 0.0..=359.0)
                .text("φ in")
                .suffix("°"),
        );
        let state = &mut app.preview_state;
        let theta = app.lobe_theta_deg.round();
        if ui
            .add_enabled(
                state.lobe_angles.len() < MAX_LOBE_ANGLES && !state.lobe_angles.contains(&theta),
                egui::Button::new("+ pin θ").small(),
            )
            .on_hover_text("Keep this incidence angle in the plot while the slider moves on")
            .clicked()
        {
            state.lobe_angles.push(theta);
        }
    });
    ui.horizontal_wrapped(|ui| {
        let state = &mut app.preview_state;
        ui.selectable_value(&mut state.lobe_scale, LobeScale::Linear, "linear");
        ui.selectable_value(
            &mut state.lobe_scale,
            LobeScale::Log {
                decades: LOBE_DECADES,
            },
            "log",
        )
        .on_hover_text(format!(
            "Radius: log10 of ρ·cos θ_out, {LOBE_DECADES} decades below the peak"
        ));
        let mut unpin = None;
        for (i, angle) in state.lobe_angles.iter().enumerate() {
            if ui
                .small_button(format!("{angle:.0}° ×"))
                .on_hover_text("Unpin")
                .clicked()
            {
                unpin = Some(i);
            }
        }
        if let Some(i) = unpin {
            state.lobe_angles.remove(i);
        }
    });
    let mut angles = vec![app.lobe_theta_deg];
    angles.extend(
        app.preview_state
            .lobe_angles
            .iter()
            .filter(|a| (**a - app.lobe_theta_deg).abs() > 0.5),
    );
    let version = app.snapshot.version;
    let has_reference = app.preview_state.reference.is_some();
    let key = (
        version,
        angles.iter().map(|a| a.to_bits()).collect::<Vec<_>>(),
        app.lobe_phi_deg.to_bits(),
        has_reference,
    );
    let scale = app.preview_state.lobe_scale;
    let stale = app.preview_state.lobe.as_ref().is_none_or(|l| l.key != key);
    if stale && let Some(recon) = current_reconstruction(app) {
        let phi = app.lobe_phi_deg as f64;
        let eval = |l, v| recon.eval(l, v);
        let lobes = angles
            .iter()
            .map(|&t| incidence_plane(&eval, t as f64, phi))
            .collect();
        let reference = match &app.preview_state.reference {
            Some(r) => {
                let table = r.table.clone();
                let lookup = move |l, v| table.get(l, v);
                angles
                    .iter()
                    .map(|&t| incidence_plane(&lookup, t as f64, phi))
                    .collect()
            }
            None => Vec::new(),
        };
        app.preview_state.lobe = Some(LobeCache {
            key,
            angles: angles.clone(),
            lobes,
            reference,
            scaled: false,
            scale,
        });
    }
    let Some(cache) = &mut app.preview_state.lobe else {
        ui.label("The lobe appears when the basis is ready.");
        return;
    };
    if cache.scale != scale {
        cache.scale = scale;
        cache.scaled = false;
    }
    let single = cache.angles.len() == 1;
    ui.label(if single {
        "ρ·cos θ_out in the plane of incidence, per channel (polar; light from the left)"
    } else {
        "luminance of ρ·cos θ_out in the plane of incidence (polar; light from the left)"
    });
    let peak = lobe_peak(
        cache
            .lobes
            .iter()
            .chain(&cache.reference)
            .map(|l| l.as_slice()),
    );
    let floor = lobe_floor(scale, peak);
    // (name, points, colour, dashed)
    let mut curves: Vec<(String, Vec<[f64; 2]>, Color32, bool)> = Vec::new();
    let channel_colours = [
        Color32::from_rgb(230, 80, 80),
        Color32::from_rgb(80, 200, 80),
        Color32::from_rgb(90, 120, 240),
    ];
    for (i, (theta, lobe)) in cache.angles.iter().zip(&cache.lobes).enumerate() {
        if single {
            for c in 0..3 {
                curves.push((
                    ["R", "G", "B"][c].into(),
                    lobe_curve(lobe, Some(c), scale, floor),
                    channel_colours[c],
                    false,
                ));
            }
        } else {
            curves.push((
                format!("θ in {theta:.0}°"),
                lobe_curve(lobe, None, scale, floor),
                lobe_colour(i, cache.angles.len()),
                false,
            ));
        }
    }
    for (i, (theta, lobe)) in cache.angles.iter().zip(&cache.reference).enumerate() {
        let colour = if single {
            Color32::from_gray(220)
        } else {
            lobe_colour(i, cache.angles.len())
        };
        curves.push((
            format!("reference θ in {theta:.0}°"),
            lobe_curve(lobe, None, scale, floor),
            colour,
            true,
        ));
    }
    let (min, max) = curves_bounds(curves.iter().map(|c| c.1.as_slice()));
    let reach = (max[0] - min[0]).max(max[1] - min[1]) * 0.5;
    let rescale = !cache.scaled;
    cache.scaled = true;
    let log_rings = match scale {
        LobeScale::Log { decades } => decades,
        LobeScale::Linear => 0,
    };
    let angles_drawn = cache.angles.clone();
    egui_plot::Plot::new("lobe")
        .data_aspect(1.0)
        .allow_scroll(false)
        .legend(egui_plot::Legend::default())
        .show(ui, |plot| {
            if rescale {
                plot.set_plot_bounds(egui_plot::PlotBounds::from_min_max(min, max));
            }
            // Decade rings of the log scale, labelled by the value they stand for (unnamed, so
            // that the legend lists only the lobes).
            for ring in 1..=log_rings {
                let r = f64::from(ring);
                let circle: Vec<[f64; 2]> = (0..=90)
                    .map(|k| {
                        let t = (k as f64 * 2.0 - 90.0).to_radians();
                        [r * t.sin(), r * t.cos()]
                    })
                    .collect();
                plot.line(
                    egui_plot::Line::new("", circle)
                        .color(Color32::from_gray(90))
                        .style(egui_plot::LineStyle::dotted_dense()),
                );
                plot.text(
                    egui_plot::Text::new(
                        "",
                        egui_plot::PlotPoint::new(0.0, r),
                        format!("1e{}", floor as i32 + ring as i32),
                    )
                    .color(Color32::from_gray(150))
                    .anchor(egui::Align2::LEFT_BOTTOM),
                );
            }
            for (name, points, colour, dashed) in curves {
                let mut line = egui_plot::Line::new(name, points).color(colour);
                if dashed {
                    line = line.style(egui_plot::LineStyle::dashed_loose());
                }
                plot.line(line);
            }
            for (i, theta) in angles_drawn.iter().enumerate() {
                let t = (*theta as f64).to_radians();
                let colour = if single {
                    Color32::from_rgb(255, 220, 120)
                } else {
                    lobe_colour(i, angles_drawn.len())
                };
                // The light's direction, unnamed: the lobe of the same colour names it.
                plot.line(
                    egui_plot::Line::new("", vec![[0.0, 0.0], [-t.sin() * reach, t.cos() * reach]])
                        .color(colour.gamma_multiply(0.6)),
                );
            }
        });
}

fn table_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let has_reference = app.preview_state.reference.is_some();
    let has_uncertainty = app.preview_state.uncertainty.is_some();
    ui.horizontal_wrapped(|ui| {
        let state = &mut app.preview_state;
        ui.selectable_value(
            &mut state.table_source,
            TableSource::Reconstruction,
            "reconstruction",
        );
        ui.add_enabled_ui(has_reference, |ui| {
            ui.selectable_value(&mut state.table_source, TableSource::Reference, "reference")
                .on_disabled_hover_text("Load a reference material first");
        });
        ui.separator();
        let o = &mut state.table_overlays;
        ui.checkbox(&mut o.observed, "observed")
            .on_hover_text("Bins the paintings reached (green)");
        ui.checkbox(&mut o.inconsistent, "inconsistent")
            .on_hover_text("Bins where views or strokes disagree (red)");
        ui.checkbox(&mut o.uncertain, "uncertain").on_hover_text(
            "Bins whose posterior standard deviation is large against ρ (magenta): where \
             the BRDF is guessed rather than painted. Estimated in the background when a \
             stroke ends",
        );
        if o.uncertain && !has_uncertainty {
            ui.spinner();
        }
    });
    if !has_reference {
        app.preview_state.table_source = TableSource::Reconstruction;
    }
    let source = app.preview_state.table_source;
    let recon = current_reconstruction(app);
    let reference = app
        .preview_state
        .reference
        .as_ref()
        .map(|r| r.table.clone());
    let lookup: Option<Box<Lookup>> = match source {
        TableSource::Reconstruction => {
            recon.map(|r| Box::new(move |l, v| r.eval(l, v)) as Box<Lookup>)
        }
        TableSource::Reference => {
            reference.map(|t| Box::new(move |l, v| t.get(l, v)) as Box<Lookup>)
        }
    };
    let Some(lookup) = lookup else {
        ui.label("The table appears when the basis is ready.");
        return;
    };
    ui.label("log ρ·cos θ_l·cos θ_v (luminance); x: view bin, y: light bin, 36 bins per 2° of θ");
    let bar_width = 64.0;
    let side = (ui.available_width() - bar_width)
        .min(ui.available_height() - 2.0 * ui.spacing().interact_size.y)
        .max(64.0);
    let ppp = ui.ctx().pixels_per_point();
    let pixels = ((side * ppp) as usize).clamp(16, TABLE_IMAGE_MAX);
    let window = app.preview_state.table_window.clipped();
    let overlays = app.preview_state.table_overlays;
    let uncertainty_id = app
        .preview_state
        .uncertainty
        .as_ref()
        .map_or(0, |u| u.as_ptr() as usize);
    let round = |v: f64| (v * 16.0).round() as i64;
    let key = (
        if source == TableSource::Reconstruction {
            app.snapshot.version
        } else {
            0
        },
        source,
        [
            round(window.x[0]),
            round(window.x[1]),
            round(window.y[0]),
            round(window.y[1]),
        ],
        [pixels, pixels],
        overlays,
        uncertainty_id,
    );
    if app
        .preview_state
        .table
        .as_ref()
        .is_none_or(|t| t.key != key)
    {
        let image = TableImage::new(&*lookup, window, pixels, pixels);
        let range = image.log_range(TABLE_DECADES);
        let colours = image.colours(range);
        let texture = ui.ctx().load_texture(
            "table",
            ColorImage::new(
                [pixels, pixels],
                colours
                    .iter()
                    .map(|c| Color32::from_rgb(c[0], c[1], c[2]))
                    .collect(),
            ),
            TextureOptions::NEAREST,
        );
        let overlay = table_overlay(app, &*lookup, window, pixels).map(|image| {
            ui.ctx()
                .load_texture("table overlay", image, TextureOptions::NEAREST)
        });
        app.preview_state.table = Some(TableCache {
            key,
            image,
            range,
            texture,
            overlay,
        });
    }
    let cache = app.preview_state.table.as_ref().expect("made above");
    let shown = cache.image.window;
    let centre = egui_plot::PlotPoint::new(
        (shown.x[0] + shown.x[1]) / 2.0,
        -(shown.y[0] + shown.y[1]) / 2.0,
    );
    let size = Vec2::new(
        (shown.x[1] - shown.x[0]) as f32,
        (shown.y[1] - shown.y[0]) as f32,
    );
    let n = DIRECTIONS as f64;
    let mut window_now = window;
    let mut hovered = None;
    let mut table_rect = None;
    ui.horizontal(|ui| {
        let response = egui_plot::Plot::new("table")
            .width(side)
            .height(side)
            .data_aspect(1.0)
            .show_grid(false)
            .include_x(0.0)
            .include_x(n)
            .include_y(0.0)
            .include_y(-n)
            .y_axis_formatter(|mark, _| format!("{:.0}", -mark.value))
            .label_formatter(|_| None)
            .show(ui, |plot| {
                plot.image(egui_plot::PlotImage::new(
                    "table",
                    cache.texture.id(),
                    centre,
                    size,
                ));
                if let Some(overlay) = &cache.overlay {
                    plot.image(egui_plot::PlotImage::new(
                        "overlay",
                        overlay.id(),
                        centre,
                        size,
                    ));
                }
                let bounds = plot.plot_bounds();
                window_now = TableWindow {
                    x: [bounds.min()[0], bounds.max()[0]],
                    y: [-bounds.max()[1], -bounds.min()[1]],
                }
                .clipped();
                plot.pointer_coordinate()
            });
        hovered = response.inner;
        table_rect = Some(response.response.rect);
        colour_bar(ui, cache.range, side, bar_width);
    });
    if window_now != window {
        app.preview_state.table_window = window_now;
        ui.ctx().request_repaint();
    }
    let readout = hovered.and_then(|p| {
        let (x, y) = (p.x, -p.y);
        ((0.0..n).contains(&x) && (0.0..n).contains(&y)).then(|| {
            let (d_l, d_v) = (y as u16, x as u16);
            let [tl, pl, tv, pv] = bin_pair_angles(d_l, d_v);
            let rho = lookup(d_l, d_v);
            let pair = pair_index(d_l, d_v) as u32;
            let state = if app.inconsistent.contains(&pair) {
                " · inconsistent"
            } else if app.observed.contains_key(&pair) {
                " · observed"
            } else {
                ""
            };
            format!(
                "light θ {tl:.0}° φ {pl:.0}° · view θ {tv:.0}° φ {pv:.0}° · ρ ({:.4}, {:.4}, {:.4}){state}",
                rho[0], rho[1], rho[2]
            )
        })
    });
    ui.label(
        readout
            .clone()
            .unwrap_or_else(|| "point at the table for (θ_l, φ_l, θ_v, φ_v) and ρ".into()),
    );
    app.preview_state.table_readout = readout;
    app.preview_state.table_rect = table_rect;
}

/// The overlay image of the chosen bin marks, if any is on: observed green, inconsistent red,
/// uncertain magenta with the relative uncertainty as opacity.
fn table_overlay(
    app: &BurnishApp,
    lookup: &Lookup,
    window: TableWindow,
    pixels: usize,
) -> Option<ColorImage> {
    let o = app.preview_state.table_overlays;
    let uncertainty = app
        .preview_state
        .uncertainty
        .as_ref()
        .filter(|_| o.uncertain);
    if !(o.observed || o.inconsistent || uncertainty.is_some()) {
        return None;
    }
    let mut image = vec![Color32::TRANSPARENT; pixels * pixels];
    if let Some(sigma) = uncertainty
        && let Some(alpha) = relative_uncertainty(sigma, lookup, window, pixels, pixels)
    {
        for (p, a) in image.iter_mut().zip(alpha) {
            *p = Color32::from_rgba_unmultiplied(230, 60, 230, (a * 200.0) as u8);
        }
    }
    // Zoomed out, a pixel holds several bins: a mark then covers its neighbours too, so that
    // a single bin stays visible.
    let spread = usize::from((window.x[1] - window.x[0]) > pixels as f64);
    let dilate = |marks: Vec<bool>| {
        let mut out = marks.clone();
        for y in 0..pixels {
            for x in 0..pixels {
                if marks[y * pixels + x] {
                    for yy in y.saturating_sub(spread)..=(y + spread).min(pixels - 1) {
                        for xx in x.saturating_sub(spread)..=(x + spread).min(pixels - 1) {
                            out[yy * pixels + xx] = true;
                        }
                    }
                }
            }
        }
        out
    };
    if o.observed {
        let marks = dilate(pair_marks(
            app.observed.keys().copied(),
            window,
            pixels,
            pixels,
        ));
        for (p, m) in image.iter_mut().zip(marks) {
            if m {
                *p = Color32::from_rgb(60, 220, 90);
            }
        }
    }
    if o.inconsistent {
        let marks = dilate(pair_marks(
            app.inconsistent.iter().copied(),
            window,
            pixels,
            pixels,
        ));
        for (p, m) in image.iter_mut().zip(marks) {
            if m {
                *p = Color32::from_rgb(255, 40, 40);
            }
        }
    }
    Some(ColorImage::new([pixels, pixels], image))
}

/// A vertical viridis bar for log10 values in `range`, labelled at each decade.
fn colour_bar(ui: &mut egui::Ui, range: (f32, f32), height: f32, width: f32) {
    let (rect, _) = ui.allocate_exact_size(Vec2::new(width, height), Sense::hover());
    let bar = egui::Rect::from_min_size(
        rect.min + Vec2::new(4.0, 8.0),
        Vec2::new(14.0, height - 16.0),
    );
    let steps = 64;
    let painter = ui.painter();
    for i in 0..steps {
        let t = (i as f32 + 0.5) / steps as f32;
        let [r, g, b] = viridis(t).map(|c| (c * 255.0).round() as u8);
        let y1 = bar.max.y - bar.height() * i as f32 / steps as f32;
        let y0 = bar.max.y - bar.height() * (i + 1) as f32 / steps as f32;
        painter.rect_filled(
            egui::Rect::from_min_max(egui::pos2(bar.min.x, y0), egui::pos2(bar.max.x, y1)),
            0.0,
            Color32::from_rgb(r, g, b),
        );
    }
    let decades = (range.1 - range.0).round() as i32;
    for k in 0..=decades {
        let y = bar.max.y - bar.height() * k as f32 / decades.max(1) as f32;
        painter.text(
            egui::pos2(bar.max.x + 4.0, y),
            egui::Align2::LEFT_CENTER,
            format!("1e{}", range.0 as i32 + k),
            egui::FontId::proportional(11.0),
            ui.visuals().text_color(),
        );
    }
}
