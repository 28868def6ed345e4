//! Compare mode: the compare renderer's inputs and the panes it draws into.

use super::PreviewState;
use crate::scene::Object;
use crate::table::SymTable;
use egui::{Color32, Sense, Vec2};
use std::sync::Arc;

impl PreviewState {
    /// Hands the compare renderer (made on first use) the object, environment and the
    /// compared material's table, where they changed.
    pub(super) fn feed_compare(
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
    pub(super) fn compare_error(&self) -> Option<String> {
        let rs = self.render_state.as_ref()?;
        crate::preview::with_compare(rs, |c| c.last_error().map(str::to_owned))
            .ok()
            .flatten()
            .flatten()
    }
}

/// Where compare mode draws: the reconstruction and the compared material side by side
/// (the same size, so that each pixel of one faces the same pixel of the other), and below
/// them their difference with its scale.
pub(super) struct CompareLayout {
    /// Reconstruction, compared material, difference.
    pub(super) panes: [egui::Rect; 3],
    /// Dragging over the two top panes orbits the camera (or moves the light).
    pub(super) response: egui::Response,
}

pub(super) fn compare_layout(ui: &mut egui::Ui, compared: &str, stops: f32) -> CompareLayout {
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
