//! The Object tab: the live preview of the object, its mode, object, lights and compare
//! panes, and orbiting it with the pointer.

use super::compare::compare_layout;
use crate::app::BurnishApp;
use crate::preview::{DirectionalLight, EnvironmentLight, PreviewMode, PreviewObject};
use crate::scene::BuiltinShape;
use egui::{Sense, Vec2};

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
    let can_compare = has_reference || app.doc.start_material().is_some();
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
            crate::app::widgets::light_dial(ui, &mut light.elevation_deg, &mut light.azimuth_deg);
        });
    }
    if open_obj {
        crate::app::menus::pick_open(
            app,
            "Preview object",
            &["obj"],
            crate::app::Action::OpenPreviewObject,
        );
    }
    if load_environment {
        crate::app::menus::pick_open(
            app,
            "Environment (equirectangular EXR)",
            &["exr"],
            crate::app::Action::LoadEnvironment,
        );
    }
}

/// The Object tab; returns the area it painted over with something opaque (the single
/// preview, or the notice drawn where no GPU preview could start), if any.
pub(super) fn object_tab(app: &mut BurnishApp, ui: &mut egui::Ui) -> Option<egui::Rect> {
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
        && let Some(doc) = app.doc.active_view()
    {
        let scene = doc.scene().clone();
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
        return Some(rect);
    }
    if app.preview.mode == PreviewMode::Table && app.preview_state.reference.is_none() {
        app.preview.mode = PreviewMode::Reconstruction;
    }
    let snapshot = app.doc.snapshot().clone();
    let view = app
        .doc
        .active_view()
        .map(|doc| (doc.id(), doc.scene().object.clone(), doc.object().clone()));
    let error = app.preview_state.feed(
        &snapshot,
        view.as_ref().map(|(id, name, o)| (*id, name.as_str(), o)),
    );
    if let Some(error) = error {
        app.notify_error(format!("preview: {error}"));
    }
    // While a stroke is painted on the canvas, a draft (a quarter of the pixels, at the
    // nearest bins); the stroke's end refines it.
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
            .doc
            .active_view()
            .map(|doc| (doc.id(), doc.scene().object.clone(), doc.object().clone()));
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
    // With a comparison the panes leave gaps between them; the panel fills behind them all.
    compare_layout.is_none().then_some(rect)
}

fn wrap_degrees(deg: f64) -> f64 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}
