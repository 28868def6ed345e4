//! The centre: the brush bar and the canvas (the guide with its paint layer), with zoom,
//! pan and the disagreement overlay. Only dirty rectangles of the texture are uploaded.

use super::BurnishApp;
use crate::paint::{BrushKind, PixelRect};
use crate::scene::srgb_encode;
use crate::table::pair_index;
use egui::{Color32, ColorImage, Pos2, Rect, Sense, TextureHandle, TextureOptions, Vec2};
use std::time::{Duration, Instant};

/// How the canvas is shown: zoom, pan, the uploaded texture and what of it is stale.
#[derive(Default)]
pub struct CanvasView {
    /// Screen points per canvas pixel; `None` fits the panel.
    zoom: Option<f32>,
    /// Offset of the canvas centre from the panel centre, in screen points.
    pan: Vec2,
    texture: Option<(u32, TextureHandle)>,
    /// Canvas pixels changed since the last upload.
    dirty: Option<PixelRect>,
    /// Rebuild the whole texture (view switched, scene changed).
    stale: bool,
    stroke: Option<StrokeInput>,
    overlay: Option<(TextureHandle, Instant)>,
    /// The active view's guide, the reference layer drawn over a prediction canvas.
    guide: Option<(TextureHandle, u32, usize)>,
    /// Pen pressure of the last touch event, when the platform reports one.
    pressure: Option<f32>,
    /// What the last frame showed: canvas rectangle on screen and canvas resolution.
    pub(crate) last_layout: Option<(Rect, usize)>,
    /// The document's canvas revision the texture shows (see
    /// [`crate::document::Document::canvas_revision`]).
    revision: u64,
}

struct StrokeInput {
    last_time: Instant,
}

impl CanvasView {
    /// Shows the canvas afresh if the document replaced it since the last frame.
    fn follow(&mut self, revision: u64) {
        if self.revision != revision {
            self.revision = revision;
            self.invalidate();
        }
    }

    pub fn invalidate(&mut self) {
        self.stale = true;
        self.overlay = None;
        self.guide = None;
    }

    pub fn mark_dirty(&mut self, rect: PixelRect) {
        self.dirty = Some(match self.dirty {
            Some(d) => d.union(&rect),
            None => rect,
        });
    }

    /// Whether a stroke is being painted (the primary button is down on the canvas).
    pub fn is_stroking(&self) -> bool {
        self.stroke.is_some()
    }

    pub fn reset_zoom(&mut self) {
        self.zoom = None;
        self.pan = Vec2::ZERO;
    }

    /// Screen position → canvas pixel coordinates (continuous).
    fn to_canvas(rect: Rect, resolution: usize, pos: Pos2) -> (f32, f32) {
        let scale = resolution as f32 / rect.width();
        ((pos.x - rect.min.x) * scale, (pos.y - rect.min.y) * scale)
    }
}

/// The display value of a linear HDR colour: clipped, sRGB-encoded.
fn display_colour(c: [f32; 3]) -> Color32 {
    let encode = |v: f32| (srgb_encode(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
    Color32::from_rgb(encode(c[0]), encode(c[1]), encode(c[2]))
}

fn region_image(pixels: &[[f32; 3]], width: usize, rect: PixelRect) -> ColorImage {
    let (w, h) = (rect.width() as usize, rect.height() as usize);
    let (x0, x1) = (rect.x0 as usize, rect.x1 as usize);
    let mut out = Vec::with_capacity(w * h);
    for y in rect.y0 as usize..rect.y1 as usize {
        let row = &pixels[y * width + x0..y * width + x1];
        out.extend(row.iter().map(|&c| display_colour(c)));
    }
    ColorImage::new([w, h], out)
}

/// The central panel's contents, and its fill: the panel's frame has none (see
/// [`central_frame`]), so it is painted here around the canvas, which paints its own.
pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    // The panel as laid out, before any row of the brush bar can widen the Ui past it: the
    // canvas fits what is visible, not what the widest row asked for.
    let panel = ui.max_rect();
    let whole_panel = panel + central_frame(ui.style()).inner_margin;
    let fill_painter = ui.painter().clone();
    let fill = fill_painter.add(egui::Shape::Noop);
    ui.set_clip_rect(panel.intersect(ui.clip_rect()));
    brush_bar(app, ui);
    ui.separator();
    let below_bar = Rect::from_min_max(egui::pos2(panel.min.x, ui.cursor().min.y), panel.max);
    let canvas_area = ui
        .scope_builder(egui::UiBuilder::new().max_rect(below_bar), |ui| {
            canvas(app, ui)
        })
        .inner
        .unwrap_or(Rect::NOTHING);
    fill_painter.set(
        fill,
        super::widgets::fill_around(whole_panel, canvas_area, ui.visuals().panel_fill),
    );
}

/// The central panel's frame: the standard one without its fill, which [`show`] paints.
pub(super) fn central_frame(style: &egui::Style) -> egui::Frame {
    egui::Frame::central_panel(style).fill(Color32::TRANSPARENT)
}

const TOOLS: [(BrushKind, &str, &str); 9] = [
    (BrushKind::Round, "Brush", "Round brush (B)"),
    (
        BrushKind::Airbrush,
        "Airbrush",
        "Soft airbrush, builds up while held (A)",
    ),
    (BrushKind::Eraser, "Eraser", "Erase back to the guide (E)"),
    (BrushKind::Smudge, "Smudge", "Drag colour along (S)"),
    (BrushKind::Blur, "Blur", "Blur the paint (R)"),
    (BrushKind::Lighten, "Dodge", "Lighten (O)"),
    (BrushKind::Darken, "Burn", "Darken (N)"),
    (BrushKind::Fill, "Fill", "Fill the whole object (F)"),
    (
        BrushKind::Eyedropper,
        "Pick",
        "Eyedropper: click the canvas or the preview (I)",
    ),
];

fn brush_bar(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal_wrapped(|ui| {
        for (kind, label, hint) in TOOLS {
            ui.selectable_value(&mut app.brush.kind, kind, label)
                .on_hover_text(hint);
        }
        ui.separator();
        if !app.presets.is_empty() {
            egui::ComboBox::from_label("presets")
                .selected_text("choose…")
                .show_ui(ui, |ui| {
                    for preset in &app.presets {
                        if ui.selectable_label(false, &preset.name).clicked() {
                            let colour = app.brush.colour;
                            app.brush = preset.settings.clone();
                            // A preset sets the tool, not the colour the artist mixed.
                            app.brush.colour = colour;
                            app.active_tip = preset.tip.clone();
                        }
                    }
                });
        }
    });
    ui.horizontal_wrapped(|ui| {
        let b = &mut app.brush;
        wrap_before_slider(ui);
        ui.add(
            egui::Slider::new(&mut b.size, 1.0..=400.0)
                .logarithmic(true)
                .text("size"),
        )
        .on_hover_text("[ and ] change the size");
        wrap_before_slider(ui);
        ui.add(egui::Slider::new(&mut b.hardness, 0.0..=1.0).text("hardness"));
        wrap_before_slider(ui);
        ui.add(egui::Slider::new(&mut b.opacity, 0.0..=1.0).text("opacity"));
        wrap_before_slider(ui);
        ui.add(egui::Slider::new(&mut b.flow, 0.01..=1.0).text("flow"));
        wrap_before_slider(ui);
        ui.add(egui::Slider::new(&mut b.spacing, 0.02..=1.0).text("spacing"));
    });
    ui.horizontal_wrapped(|ui| {
        colour_picker(app, ui);
        wrap_before(ui, 240.0);
        ui.checkbox(&mut app.brush.pressure_size, "pressure: size");
        ui.checkbox(&mut app.brush.pressure_flow, "pressure: flow");
    });
}

/// Starts a new row of a wrapped layout unless `width` points still fit. egui lays a slider's
/// parts out in a nested row, which its wrapped parent cannot move to the next line.
fn wrap_before(ui: &mut egui::Ui, width: f32) {
    if ui.available_size_before_wrap().x < width {
        ui.end_row();
    }
}

/// [`wrap_before`] the width of a slider with its value and a short label.
fn wrap_before_slider(ui: &mut egui::Ui) {
    let width = ui.spacing().slider_width + ui.spacing().interact_size.x + 70.0;
    wrap_before(ui, width);
}

/// HSV with a separate intensity that may exceed 1 (HDR paint).
fn colour_picker(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let c = app.brush.colour;
    let intensity = c.iter().cloned().fold(0.0f32, f32::max).max(1.0);
    let unit = c.map(|v| v / intensity);
    let mut hsva = egui::ecolor::Hsva::from_rgb(unit);
    let mut new_intensity = intensity;
    ui.label("colour");
    let changed = egui::widgets::color_picker::color_edit_button_hsva(
        ui,
        &mut hsva,
        egui::widgets::color_picker::Alpha::Opaque,
    )
    .changed();
    wrap_before_slider(ui);
    let intensity_changed = ui
        .add(
            egui::Slider::new(&mut new_intensity, 1.0..=16.0)
                .logarithmic(true)
                .text("intensity"),
        )
        .on_hover_text("Multiplies the colour: values above 1 paint highlights brighter than white")
        .changed();
    if changed || intensity_changed {
        let rgb = hsva.to_rgb();
        app.brush.colour = [rgb[0], rgb[1], rgb[2]].map(|v| v * new_intensity);
    }
    ui.label(format!(
        "({:.2}, {:.2}, {:.2})",
        app.brush.colour[0], app.brush.colour[1], app.brush.colour[2]
    ));
}

/// Lays out and paints the canvas; returns the area it painted over entirely, if any.
fn canvas(app: &mut BurnishApp, ui: &mut egui::Ui) -> Option<Rect> {
    app.canvas_view.follow(app.doc.canvas_revision());
    let doc = app.doc.active_view()?;
    let view_id = doc.id();
    let resolution = doc.canvas().resolution();
    let (panel, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
    let view = &mut app.canvas_view;

    // Zoom with the wheel around the pointer; pan with the middle button or space + drag.
    let fit = (panel.width().min(panel.height()) / resolution as f32).max(1e-3);
    let mut zoom = view.zoom.unwrap_or(fit);
    if response.hovered() {
        let (scroll, pointer) = ui.input(|i| (i.smooth_scroll_delta.y, i.pointer.hover_pos()));
        if scroll != 0.0 {
            let factor = (scroll / 200.0).exp();
            let new_zoom = (zoom * factor).clamp(fit * 0.25, 32.0);
            if let Some(p) = pointer {
                let from_centre = p - panel.center() - view.pan;
                view.pan -= from_centre * (new_zoom / zoom - 1.0);
            }
            zoom = new_zoom;
            view.zoom = Some(zoom);
        }
    }
    let panning = ui.input(|i| i.pointer.middle_down() || i.key_down(egui::Key::Space));
    if panning && response.dragged() {
        view.pan += response.drag_delta();
    }
    let size = Vec2::splat(resolution as f32 * zoom);
    let rect = Rect::from_center_size(panel.center() + view.pan, size);
    view.last_layout = Some((rect, resolution));

    upload_texture(app, ui.ctx(), view_id);
    let painter = ui.painter_at(panel);
    // The canvas texture is opaque: the background goes only where it does not reach.
    let covered = if app.canvas_view.texture.is_some() {
        rect
    } else {
        Rect::NOTHING
    };
    painter.add(super::widgets::fill_around(
        panel,
        covered,
        ui.visuals().extreme_bg_color,
    ));
    if let Some((_, texture)) = &app.canvas_view.texture {
        painter.image(
            texture.id(),
            rect,
            Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
            Color32::WHITE,
        );
    }
    if app.guide_opacity > 0.0
        && let Some(doc) = app.doc.active_view()
    {
        let side = doc.guide().width;
        let current = app
            .canvas_view
            .guide
            .as_ref()
            .is_some_and(|(_, id, n)| *id == view_id && *n == side);
        if !current {
            let full = PixelRect::new(0, 0, side as u32, doc.guide().height as u32);
            let image = region_image(&doc.guide().pixels, side, full);
            app.canvas_view.guide = Some((
                ui.ctx()
                    .load_texture("guide", image, TextureOptions::NEAREST),
                view_id,
                side,
            ));
        }
        if let Some((texture, _, _)) = &app.canvas_view.guide {
            painter.image(
                texture.id(),
                rect,
                Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
                Color32::from_white_alpha((app.guide_opacity.clamp(0.0, 1.0) * 255.0) as u8),
            );
        }
    }
    if app.show_overlay {
        update_overlay(app, ui.ctx());
        if let Some((texture, _)) = &app.canvas_view.overlay {
            painter.image(
                texture.id(),
                rect,
                Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
                Color32::WHITE,
            );
        }
    }
    if !panning {
        paint_input(app, ui, &response, rect, resolution);
    }
    if let Some(pos) = response.hover_pos() {
        let radius = app.brush.size * 0.5 * zoom;
        painter.circle_stroke(pos, radius, (1.0, Color32::from_white_alpha(160)));
    }
    Some(panel)
}

fn upload_texture(app: &mut BurnishApp, ctx: &egui::Context, view_id: u32) {
    let Some(doc) = app.doc.active_view() else {
        return;
    };
    let layers = doc.canvas().layers();
    let width = layers.colour.width;
    let view = &mut app.canvas_view;
    let current = view
        .texture
        .as_ref()
        .is_some_and(|(id, t)| *id == view_id && t.size() == [width, layers.colour.height]);
    if !current || view.stale {
        let full = PixelRect::new(0, 0, width as u32, layers.colour.height as u32);
        let image = region_image(&layers.colour.pixels, width, full);
        view.texture = Some((
            view_id,
            ctx.load_texture("canvas", image, TextureOptions::NEAREST),
        ));
        view.stale = false;
        view.dirty = None;
    } else if let Some(dirty) = view.dirty.take() {
        let full = PixelRect::new(0, 0, width as u32, layers.colour.height as u32);
        let dirty = dirty.intersect(&full);
        if !dirty.is_empty() {
            let image = region_image(&layers.colour.pixels, width, dirty);
            if let Some((_, texture)) = &mut view.texture {
                texture.set_partial(
                    [dirty.x0 as usize, dirty.y0 as usize],
                    image,
                    TextureOptions::NEAREST,
                );
            }
        }
    }
}

/// Tints pixels whose bin is inconsistent (red) and lit pixels whose bin no view has
/// reached yet (blue). Rebuilt at most four times a second.
fn update_overlay(app: &mut BurnishApp, ctx: &egui::Context) {
    let fresh = app
        .canvas_view
        .overlay
        .as_ref()
        .is_some_and(|(_, t)| t.elapsed() < Duration::from_millis(250));
    if fresh {
        return;
    }
    let Some(doc) = app.doc.active_view() else {
        return;
    };
    let n = doc.gbuffer().resolution();
    let mut pixels = vec![Color32::TRANSPARENT; n * n];
    for (i, point) in doc.gbuffer().pixels().iter().enumerate() {
        let Some(p) = point else { continue };
        let (Some(l), Some(v)) = (p.light_bin, p.view_bin) else {
            continue;
        };
        if !p.is_lit() {
            continue;
        }
        let pair = pair_index(l, v);
        if app.doc.is_inconsistent(pair) {
            pixels[i] = Color32::from_rgba_unmultiplied(255, 40, 40, 150);
        } else if !app.doc.is_observed(pair) {
            pixels[i] = Color32::from_rgba_unmultiplied(40, 120, 255, 70);
        }
    }
    let image = ColorImage::new([n, n], pixels);
    app.canvas_view.overlay = Some((
        ctx.load_texture("overlay", image, TextureOptions::NEAREST),
        Instant::now(),
    ));
}

/// Paints with the frame's pointer events, in the order they came: a fast stroke brings
/// several moves (and maybe its press and release) within one frame, and every one of them
/// places dabs; the stroke starts where the button went down, not where a drag was first
/// recognised.
fn paint_input(
    app: &mut BurnishApp,
    ui: &egui::Ui,
    response: &egui::Response,
    rect: Rect,
    resolution: usize,
) {
    let frame_start = Instant::now();
    let (events, primary_down) = ui.input(|i| (i.events.clone(), i.pointer.primary_down()));
    let kind = app.brush.kind;
    let brush = app.brush.clone();
    let tip = app.active_tip.clone();
    let layer = ui.layer_id();
    let ctx = ui.ctx().clone();
    // A press starts a stroke only on the canvas itself, not under a menu or popup over it.
    let on_canvas = |pos: Pos2| response.rect.contains(pos) && ctx.layer_id_at(pos) == Some(layer);
    let to_canvas = |pos: Pos2| CanvasView::to_canvas(rect, resolution, pos);
    let Some(canvas) = app.doc.active_canvas_mut() else {
        return;
    };
    let view = &mut app.canvas_view;
    let mut moved = false;
    for event in &events {
        let pressure = view.pressure.unwrap_or(1.0);
        match event {
            egui::Event::Touch { force, .. } => view.pressure = *force,
            egui::Event::PointerButton {
                pos,
                button: egui::PointerButton::Primary,
                pressed: true,
                ..
            } if view.stroke.is_none() && on_canvas(*pos) => {
                let (x, y) = to_canvas(*pos);
                match kind {
                    BrushKind::Eyedropper => app.brush.colour = canvas.pick(x, y),
                    BrushKind::Fill => canvas.fill(&brush),
                    _ => {
                        canvas.set_tip(tip.clone());
                        canvas.begin_stroke(&brush, x, y, pressure);
                        view.stroke = Some(StrokeInput {
                            last_time: frame_start,
                        });
                    }
                }
            }
            egui::Event::PointerMoved(pos) if view.stroke.is_some() => {
                let (x, y) = to_canvas(*pos);
                canvas.continue_stroke(x, y, pressure);
                moved = true;
            }
            egui::Event::PointerButton {
                pos,
                button: egui::PointerButton::Primary,
                pressed: false,
                ..
            } if view.stroke.is_some() => {
                let (x, y) = to_canvas(*pos);
                canvas.continue_stroke(x, y, pressure);
                canvas.end_stroke();
                view.stroke = None;
            }
            _ => {}
        }
    }
    if let Some(stroke) = &mut view.stroke {
        let dt = frame_start.duration_since(stroke.last_time).as_secs_f32();
        stroke.last_time = frame_start;
        if !moved && kind == BrushKind::Airbrush && primary_down {
            canvas.airbrush_tick(dt);
            ui.ctx().request_repaint();
        }
        // The release was lost (the window lost the pointer): the stroke ends here.
        if !primary_down {
            canvas.end_stroke();
            view.stroke = None;
        }
    }
    let changes = canvas.take_changes();
    app.publish_canvas_changes(changes, frame_start);
}
