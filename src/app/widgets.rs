//! Small custom widgets.

use egui::{Color32, Pos2, Sense, Stroke, Vec2};

/// A draggable dial for a light direction: the centre is straight up (elevation 90°), the
/// rim the horizon; the angle around is the azimuth (0 toward the default camera, which is
/// at the bottom of the dial, 90° to its right). Returns whether it changed.
pub fn light_dial(ui: &mut egui::Ui, elevation_deg: &mut f64, azimuth_deg: &mut f64) -> bool {
    let size = 72.0;
    let (rect, response) = ui.allocate_exact_size(Vec2::splat(size), Sense::click_and_drag());
    let centre = rect.center();
    let radius = size * 0.5 - 3.0;
    let mut changed = false;
    if let Some(pos) = response.interact_pointer_pos()
        && (response.dragged() || response.clicked())
    {
        let d = (pos - centre) / radius;
        let r = d.length().min(1.0);
        // The dial is an orthographic view from above: r = cos(elevation).
        let elevation = r.acos().to_degrees().clamp(1.0, 90.0) as f64;
        let azimuth = d.x.atan2(d.y).to_degrees() as f64;
        if (elevation - *elevation_deg).abs() > 1e-6 || (azimuth - *azimuth_deg).abs() > 1e-6 {
            *elevation_deg = elevation;
            *azimuth_deg = azimuth;
            changed = true;
        }
    }
    let painter = ui.painter_at(rect);
    let visuals = ui.visuals();
    painter.circle(
        centre,
        radius,
        visuals.extreme_bg_color,
        Stroke::new(1.0, visuals.widgets.noninteractive.fg_stroke.color),
    );
    for ring in [30.0f32, 60.0] {
        painter.circle_stroke(
            centre,
            radius * ring.to_radians().cos(),
            Stroke::new(0.5, visuals.widgets.noninteractive.bg_stroke.color),
        );
    }
    let r = (*elevation_deg as f32).to_radians().cos() * radius;
    let a = (*azimuth_deg as f32).to_radians();
    let light = centre + Vec2::new(a.sin(), a.cos()) * r;
    painter.line_segment([centre, light], Stroke::new(1.0, Color32::from_gray(160)));
    painter.circle_filled(light, 5.0, Color32::from_rgb(255, 220, 120));
    painter.circle_filled(
        Pos2::new(centre.x, rect.bottom() - 2.0),
        2.5,
        visuals.widgets.noninteractive.fg_stroke.color,
    );
    response.on_hover_text(
        "Drag to move the light: centre = overhead, rim = horizon, bottom = toward the camera",
    );
    changed
}
