//! The right panel: the live wgpu preview of the object with the reconstructed BRDF, the
//! lobe plot and the table image.

use super::{BurnishApp, PreviewTab};
use crate::basis::Basis;
use crate::inspect::{incidence_plane, observed_mask, table_thumbnail};
use crate::preview::{DirectionalLight, PreviewMode, Sky};
use crate::scene::Object;
use crate::solver::Reconstruction;
use crate::table::Rgb;
use crate::worker::Snapshot;
use egui::{Color32, ColorImage, Sense, TextureHandle, TextureOptions, Vec2};
use std::sync::Arc;

/// Pixels per side of the table thumbnail.
const TABLE_THUMBNAIL: usize = 405;

type LobeCache = (u64, f32, f32, Vec<(f64, Rgb)>);

/// What the preview keeps between frames.
#[derive(Default)]
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
    /// The object the GPU holds: (view id, object name).
    uploaded_object: Option<(u32, String)>,
    /// The lobe last plotted: snapshot version, θ and φ of incidence, and its samples.
    lobe: Option<LobeCache>,
    table: Option<(u64, TextureHandle, bool)>,
    /// Where the last frame drew the object preview.
    pub last_rect: Option<egui::Rect>,
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

    /// Hands the renderer what changed since the last frame: basis, coefficients, object,
    /// sparse bins. Small writes only, except when the basis itself is new.
    fn feed(
        &mut self,
        snapshot: &Snapshot,
        object: Option<(u32, &str, &Object)>,
    ) -> Option<String> {
        let rs = self.render_state.as_ref()?;
        let sparse = std::mem::take(&mut self.pending_sparse);
        let basis_changed = match (&snapshot.basis, &self.uploaded_basis) {
            (Some(b), Some(u)) => !Arc::ptr_eq(b, u),
            (Some(_), None) => true,
            _ => false,
        };
        let coefficients_changed = basis_changed || self.uploaded_version != Some(snapshot.version);
        let object_changed = object.is_some_and(|(id, name, _)| {
            self.uploaded_object.as_ref() != Some(&(id, name.to_owned()))
        });
        let result = crate::preview::with_renderer(
            rs,
            |renderer| -> Result<(), crate::preview::PreviewError> {
                if let (true, Some(basis)) = (basis_changed, &snapshot.basis) {
                    renderer.set_basis(basis)?;
                }
                if coefficients_changed && snapshot.basis.is_some() {
                    renderer.set_coefficients(&snapshot.coefficients)?;
                }
                if let (true, Some((_, _, object))) = (object_changed, object) {
                    renderer.set_object(object)?;
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
        if let (true, Some((id, name, _))) = (object_changed, object) {
            self.uploaded_object = Some((id, name.to_owned()));
        }
        result.err().map(|e| e.to_string())
    }
}

pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal(|ui| {
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Object, "Object");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Lobe, "Lobe");
        ui.selectable_value(&mut app.preview_tab, PreviewTab::Table, "Table");
    });
    ui.separator();
    match app.preview_tab {
        PreviewTab::Object => object_tab(app, ui),
        PreviewTab::Lobe => lobe_tab(app, ui),
        PreviewTab::Table => table_tab(app, ui),
    }
}

fn object_controls(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let frame = &mut app.preview;
    ui.horizontal_wrapped(|ui| {
        ui.selectable_value(
            &mut frame.mode,
            PreviewMode::Reconstruction,
            "Reconstruction",
        )
        .on_hover_text("The full BRDF the solver reconstructs");
        ui.selectable_value(&mut frame.mode, PreviewMode::SparseOnly, "Sparse only")
            .on_hover_text("Only what the paintings give directly; grey where no view reached");
        ui.selectable_value(&mut frame.mode, PreviewMode::GuideMaterial, "Guide")
            .on_hover_text("The guide's grey diffuse material");
    });
    ui.horizontal_wrapped(|ui| {
        ui.checkbox(&mut frame.shadows, "shadows");
        ui.checkbox(&mut frame.interpolate, "interpolate bins");
        let mut second = frame.second_light.is_some();
        if ui.checkbox(&mut second, "second light").changed() {
            frame.second_light = second.then_some(DirectionalLight {
                elevation_deg: 20.0,
                azimuth_deg: -120.0,
                intensity: 0.5,
            });
        }
        let mut sky = frame.sky.is_some();
        if ui.checkbox(&mut sky, "sky").changed() {
            frame.sky = sky.then_some(Sky { radiance: 0.15 });
        }
        ui.add(
            egui::Slider::new(&mut frame.exposure_stops, -6.0..=6.0)
                .text("exposure")
                .suffix(" EV"),
        );
    });
    if let Some(light) = &mut frame.second_light {
        ui.horizontal(|ui| {
            ui.label("second light");
            ui.add(egui::Slider::new(&mut light.intensity, 0.0..=2.0).text("intensity"));
            super::widgets::light_dial(ui, &mut light.elevation_deg, &mut light.azimuth_deg);
        });
    }
}

fn object_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    object_controls(app, ui);
    let side = ui.available_width().min(ui.available_height()).max(64.0);
    let (rect, response) = ui.allocate_exact_size(Vec2::splat(side), Sense::click_and_drag());
    app.preview_state.last_rect = Some(rect);
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
        let mode = app.preview.mode;
        app.preview = crate::preview::PreviewFrame::from_scene(&scene);
        app.preview.mode = mode;
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
    let snapshot = app.snapshot.clone();
    let object = app
        .views
        .get(app.active)
        .map(|doc| (doc.id, doc.scene.object.clone(), doc.object.clone()));
    let error = app.preview_state.feed(
        &snapshot,
        object
            .as_ref()
            .map(|(id, name, o)| (*id, name.as_str(), o.as_ref())),
    );
    if let Some(error) = error {
        app.notify_error(format!("preview: {error}"));
    }
    let ppp = ui.ctx().pixels_per_point();
    ui.painter().add(crate::preview::paint_callback(
        rect,
        ppp,
        app.preview.clone(),
    ));
    app.record_drawn(snapshot.version, snapshot.oldest_input);
}

fn wrap_degrees(deg: f64) -> f64 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

fn current_reconstruction(app: &BurnishApp) -> Option<Reconstruction> {
    let snapshot = &app.snapshot;
    let basis = snapshot.basis.clone()?;
    (snapshot.coefficients.len() == basis.components())
        .then(|| Reconstruction::new(basis, &snapshot.coefficients))
}

fn lobe_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal(|ui| {
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
    });
    let version = app.snapshot.version;
    let (theta, phi) = (app.lobe_theta_deg, app.lobe_phi_deg);
    let stale = app
        .preview_state
        .lobe
        .as_ref()
        .is_none_or(|(v, t, p, _)| *v != version || *t != theta || *p != phi);
    if stale && let Some(recon) = current_reconstruction(app) {
        let points = incidence_plane(&recon, theta as f64, phi as f64);
        app.preview_state.lobe = Some((version, theta, phi, points));
    }
    let Some((_, _, _, points)) = &app.preview_state.lobe else {
        ui.label("The lobe appears when the basis is ready.");
        return;
    };
    ui.label("ρ·cos θ_out in the plane of incidence (polar; light from the left)");
    let colours = [
        Color32::from_rgb(230, 80, 80),
        Color32::from_rgb(80, 200, 80),
        Color32::from_rgb(90, 120, 240),
    ];
    egui_plot::Plot::new("lobe")
        .data_aspect(1.0)
        .allow_scroll(false)
        .show(ui, |plot| {
            for (c, colour) in colours.into_iter().enumerate() {
                let line: Vec<[f64; 2]> = points
                    .iter()
                    .map(|(signed, rho)| {
                        let t = signed.to_radians();
                        let r = rho[c] as f64 * t.cos();
                        [r * t.sin(), r * t.cos()]
                    })
                    .collect();
                plot.line(egui_plot::Line::new(["R", "G", "B"][c], line).color(colour));
            }
            let t = (theta as f64).to_radians();
            plot.line(
                egui_plot::Line::new("light", vec![[0.0, 0.0], [-t.sin(), t.cos()]])
                    .color(Color32::from_rgb(255, 220, 120)),
            );
        });
}

fn table_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let version = app.snapshot.version;
    let show_reached = app.show_overlay;
    let stale = app
        .preview_state
        .table
        .as_ref()
        .is_none_or(|(v, _, o)| *v != version || *o != show_reached);
    if stale && let Some(recon) = current_reconstruction(app) {
        let thumb = table_thumbnail(&recon, TABLE_THUMBNAIL);
        let reached =
            show_reached.then(|| observed_mask(app.observed.keys().copied(), TABLE_THUMBNAIL));
        let inconsistent =
            show_reached.then(|| observed_mask(app.inconsistent.iter().copied(), TABLE_THUMBNAIL));
        let pixels = thumb
            .pixels
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0) as u8;
                let base = Color32::from_rgb(byte(p[0]), byte(p[1]), byte(p[2]));
                match (&reached, &inconsistent) {
                    (Some(_), Some(bad)) if bad[i] => Color32::from_rgb(255, 40, 40),
                    (Some(seen), _) if seen[i] => Color32::from_rgb(60, 220, 90),
                    (Some(_), _) => base.gamma_multiply(0.45),
                    _ => base,
                }
            })
            .collect();
        let image = ColorImage::new([TABLE_THUMBNAIL, TABLE_THUMBNAIL], pixels);
        let texture = ui
            .ctx()
            .load_texture("table", image, TextureOptions::NEAREST);
        app.preview_state.table = Some((version, texture, show_reached));
    }
    ui.checkbox(
        &mut app.show_overlay,
        "mark observed (green) and inconsistent (red) bins",
    );
    match &app.preview_state.table {
        Some((_, texture, _)) => {
            ui.label("log ρ·cos·cos; x = view direction, y = light direction");
            let side = ui.available_width().min(ui.available_height()).max(64.0);
            ui.image((texture.id(), Vec2::splat(side)));
        }
        None => {
            ui.label("The table appears when the basis is ready.");
        }
    }
}
