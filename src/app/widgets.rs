//! Small custom widgets.

use egui::{Color32, Pos2, Rect, Sense, Stroke, Vec2};

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

/// `outer` filled with `colour` except for `hole`, where something opaque is drawn on top: as
/// at most four unfeathered rectangles. On a software rasteriser every pixel a shape covers
/// costs the same whether or not a later image hides it, and a panel's fill under the canvas
/// or the preview was a third of the window's frame on lavapipe.
pub fn fill_around(outer: Rect, hole: Rect, colour: Color32) -> egui::Shape {
    let mut mesh = egui::Mesh::default();
    let hole = hole.intersect(outer);
    if !hole.is_positive() {
        mesh.add_colored_rect(outer, colour);
        return egui::Shape::mesh(mesh);
    }
    let strips = [
        Rect::from_min_max(outer.min, Pos2::new(outer.max.x, hole.min.y)),
        Rect::from_min_max(Pos2::new(outer.min.x, hole.max.y), outer.max),
        Rect::from_min_max(
            Pos2::new(outer.min.x, hole.min.y),
            Pos2::new(hole.min.x, hole.max.y),
        ),
        Rect::from_min_max(
            Pos2::new(hole.max.x, hole.min.y),
            Pos2::new(outer.max.x, hole.max.y),
        ),
    ];
    for strip in strips.into_iter().filter(|r| r.is_positive()) {
        mesh.add_colored_rect(strip, colour);
    }
    egui::Shape::mesh(mesh)
}
