//! The Table tab: the table image with its overlays, colour bar and readout.

use super::{TableOverlays, TableSource, current_reconstruction};
use crate::app::BurnishApp;
use crate::inspect::{
    Lookup, TableImage, TableWindow, bin_pair_angles, pair_marks, relative_uncertainty, viridis,
};
use crate::table::{DIRECTIONS, pair_index};
use egui::{Color32, ColorImage, Sense, TextureHandle, TextureOptions, Vec2};

/// Most pixels per side of the table image (it follows the plot's size below that).
const TABLE_IMAGE_MAX: usize = 640;
/// Decades the table's colour bar spans at most.
const TABLE_DECADES: u8 = 6;

/// The table image last made: for what, and its textures.
pub(super) struct TableCache {
    key: (u64, TableSource, [i64; 4], [usize; 2], TableOverlays, usize),
    image: TableImage,
    range: (f32, f32),
    texture: TextureHandle,
    overlay: Option<TextureHandle>,
}

pub(super) fn table_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
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
            app.doc.snapshot().version
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
            let pair = pair_index(d_l, d_v);
            let state = if app.doc.is_inconsistent(pair) {
                " · inconsistent"
            } else if app.doc.is_observed(pair) {
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
        let marks = dilate(pair_marks(app.doc.observed(), window, pixels, pixels));
        for (p, m) in image.iter_mut().zip(marks) {
            if m {
                *p = Color32::from_rgb(60, 220, 90);
            }
        }
    }
    if o.inconsistent {
        let marks = dilate(pair_marks(app.doc.inconsistent(), window, pixels, pixels));
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
