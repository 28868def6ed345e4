//! The left panel: the session's views and the active view's scene setup, and the
//! reconstruction settings.

use super::widgets::light_dial;
use super::{Action, BurnishApp};
use crate::basis::BasisSpec;
use crate::paint::UnpaintedPixels;
use crate::scene::{BuiltinShape, PaintRange, Projection, Scene};
use crate::solver::{Policy, Regularization};

const SHAPES: [BuiltinShape; 4] = [
    BuiltinShape::Sphere,
    BuiltinShape::Torus,
    BuiltinShape::RoundedCube,
    BuiltinShape::Blob,
];
const RESOLUTIONS: [u32; 4] = [256, 512, 1024, 2048];

pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    egui::ScrollArea::vertical().show(ui, |ui| {
        views_list(app, ui);
        ui.separator();
        scene_setup(app, ui);
        ui.separator();
        reconstruction_settings(app, ui);
    });
}

fn views_list(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.heading("Views");
    let mut select = None;
    let mut mute = None;
    let mut close = None;
    let count = app.doc.views().len();
    for (i, doc) in app.doc.views().iter().enumerate() {
        ui.horizontal(|ui| {
            if ui
                .selectable_label(i == app.doc.active(), doc.name())
                .on_hover_text("Paint this view")
                .clicked()
            {
                select = Some(i);
            }
            let mut muted = doc.muted();
            if ui
                .checkbox(&mut muted, "mute")
                .on_hover_text("A muted view keeps its paint but gives no samples")
                .changed()
            {
                mute = Some((i, muted));
            }
            if count > 1 && ui.small_button("×").on_hover_text("Close view").clicked() {
                close = Some(i);
            }
        });
    }
    ui.horizontal(|ui| {
        if ui.button("+ Add view").clicked() {
            app.queue(Action::AddView);
        }
        if ui
            .button("Suggest next view")
            .on_hover_text(
                "Rank candidate lights and cameras by how much painting them would shrink \
                 the reconstruction's uncertainty, and add the best",
            )
            .clicked()
        {
            app.queue(Action::SuggestView);
        }
    });
    if let Some(doc) = app.doc.active_view() {
        let mut rule = doc.unpainted();
        ui.horizontal(|ui| {
            let label = ui.label("Unpainted pixels");
            egui::ComboBox::from_id_salt("unpainted")
                .selected_text(unpainted_label(rule))
                .show_ui(ui, |ui| {
                    for r in [UnpaintedPixels::CountAsShown, UnpaintedPixels::Ignore] {
                        ui.selectable_value(&mut rule, r, unpainted_label(r));
                    }
                })
                .response
                .labelled_by(label.id)
                .on_hover_text(
                    "count as shown: the whole canvas is a statement about the material \
                     (on the guide: grey diffuse where you did not paint). ignore: only \
                     painted pixels count; the rest is extrapolated",
                );
        });
        let read_exact = doc.paint_range() == PaintRange::Ldr
            && ui
                .horizontal(|ui| {
                    ui.label("8-bit paint: clipped channels are lower bounds")
                        .on_hover_text(
                            "This view's painting came from an 8-bit file: a channel at its \
                             top says only \"at least this bright\", as burnish reconstruct \
                             reads the file",
                        );
                    ui.button("Read as exact").clicked()
                })
                .inner;
        if rule != doc.unpainted() {
            app.doc.set_unpainted(app.doc.active(), rule);
        }
        if read_exact {
            app.doc.set_paint_range(app.doc.active(), PaintRange::Hdr);
        }
        ui.horizontal(|ui| {
            if ui
                .button("Start from the current BRDF")
                .on_hover_text(
                    "Show the current reconstruction, rendered for this view, wherever \
                     nothing is painted: correct what is wrong instead of repainting",
                )
                .clicked()
            {
                app.queue(Action::StartFromCurrentBrdf);
            }
        });
        ui.add(
            egui::Slider::new(&mut app.guide_opacity, 0.0..=1.0)
                .text("guide over canvas")
                .fixed_decimals(2),
        )
        .on_hover_text("The grey guide as a reference layer over the canvas (display only)");
    }
    if let Some(i) = select {
        app.doc.set_active(i);
    }
    if let Some((i, muted)) = mute {
        app.doc.set_muted(i, muted);
    }
    if let Some(i) = close {
        app.doc.remove_view(i);
    }
}

fn unpainted_label(rule: UnpaintedPixels) -> &'static str {
    match rule {
        UnpaintedPixels::CountAsShown => "count as shown",
        UnpaintedPixels::Ignore => "ignore",
    }
}

fn scene_setup(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let Some(doc) = app.doc.active_view() else {
        return;
    };
    let original = doc.scene().clone();
    let mut scene = original.clone();
    ui.heading("Scene");
    let mut open_obj = false;
    egui::Grid::new("scene_grid").num_columns(2).show(ui, |ui| {
        let label = ui.label("Object");
        egui::ComboBox::from_id_salt("object")
            .selected_text(object_label(&scene))
            .show_ui(ui, |ui| {
                for shape in SHAPES {
                    ui.selectable_value(&mut scene.object, shape.name().to_owned(), shape.name());
                }
                if ui.button("Open OBJ…").clicked() {
                    open_obj = true;
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
        let label = ui.label("Resolution");
        egui::ComboBox::from_id_salt("resolution")
            .selected_text(format!("{0}²", scene.resolution))
            .show_ui(ui, |ui| {
                for r in RESOLUTIONS {
                    ui.selectable_value(&mut scene.resolution, r, format!("{r}²"));
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
        ui.label("Shadows");
        ui.checkbox(&mut scene.shadows, "cast shadows");
        ui.end_row();
    });
    ui.label("Light");
    ui.horizontal(|ui| {
        light_dial(
            ui,
            &mut scene.light.elevation_deg,
            &mut scene.light.azimuth_deg,
        );
        ui.vertical(|ui| {
            ui.add(
                egui::DragValue::new(&mut scene.light.elevation_deg)
                    .range(1.0..=90.0)
                    .suffix("° elevation"),
            );
            ui.add(
                egui::DragValue::new(&mut scene.light.azimuth_deg)
                    .range(-180.0..=180.0)
                    .suffix("° azimuth"),
            );
        });
    });
    ui.label("Camera");
    egui::Grid::new("camera_grid")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("Projection");
            ui.horizontal(|ui| {
                ui.selectable_value(
                    &mut scene.camera.projection,
                    Projection::Orthographic,
                    "ortho",
                );
                ui.selectable_value(
                    &mut scene.camera.projection,
                    Projection::Perspective,
                    "persp",
                );
            });
            ui.end_row();
            if scene.camera.projection == Projection::Perspective {
                ui.label("Field of view");
                ui.add(
                    egui::Slider::new(&mut scene.camera.fov_deg, 5.0..=120.0)
                        .suffix("°")
                        .text("fov"),
                );
                ui.end_row();
            }
            ui.label("Yaw");
            ui.add(
                egui::Slider::new(&mut scene.camera.yaw_deg, -180.0..=180.0)
                    .suffix("°")
                    .text("yaw"),
            );
            ui.end_row();
            ui.label("Pitch");
            ui.add(
                egui::Slider::new(&mut scene.camera.pitch_deg, -89.0..=89.0)
                    .suffix("°")
                    .text("pitch"),
            );
            ui.end_row();
            let label = ui.label("Tangent ref.");
            ui.horizontal(|ui| {
                for (v, axis) in scene.tangent_reference.iter_mut().zip(["x ", "y ", "z "]) {
                    ui.add(
                        egui::DragValue::new(v)
                            .speed(0.02)
                            .range(-1.0..=1.0)
                            .prefix(axis),
                    )
                    .labelled_by(label.id);
                }
            });
            ui.end_row();
        });
    if open_obj
        && let Some(path) = rfd::FileDialog::new()
            .set_title("Open OBJ")
            .add_filter("Wavefront OBJ", &["obj"])
            .pick_file()
    {
        scene.object = path.display().to_string();
        scene.base_dir = Default::default();
    }
    if let Err(problem) = scene.check() {
        ui.colored_label(ui.visuals().error_fg_color, problem);
        return;
    }
    // Rebuilding the geometry takes tens of milliseconds: wait until the drag ends.
    let dragging = ui.input(|i| i.pointer.any_down());
    if scene != original && !dragging {
        let index = app.doc.active();
        if let Err(e) = app.doc.set_scene(index, scene) {
            app.notify_error(e.to_string());
        }
    } else if scene != original {
        app.pending_scene = Some(scene);
    }
    if !dragging && let Some(scene) = app.pending_scene.take() {
        let index = app.doc.active();
        if let Err(e) = app.doc.set_scene(index, scene) {
            app.notify_error(e.to_string());
        }
    }
}

fn object_label(scene: &Scene) -> String {
    match BuiltinShape::from_name(&scene.object) {
        Some(shape) => shape.name().to_owned(),
        None => std::path::Path::new(&scene.object).file_name().map_or_else(
            || scene.object.clone(),
            |n| n.to_string_lossy().into_owned(),
        ),
    }
}

fn reconstruction_settings(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.heading("Reconstruction");
    let mut settings = app.doc.basis_settings();
    egui::Grid::new("basis_grid").num_columns(2).show(ui, |ui| {
        ui.label("Components K");
        ui.add(
            egui::Slider::new(&mut settings.components, 1..=BasisSpec::MAX_COMPONENTS).text("K"),
        );
        ui.end_row();
        ui.label("Database");
        ui.add(
            egui::DragValue::new(&mut settings.materials)
                .range(8..=BasisSpec::MAX_MATERIALS)
                .suffix(" materials"),
        );
        ui.end_row();
        ui.label("Samples per bin");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut settings.policy, Policy::Mean, "mean");
            ui.selectable_value(&mut settings.policy, Policy::Min, "min");
            ui.selectable_value(&mut settings.policy, Policy::Max, "max");
        });
        ui.end_row();
        let label = ui.label("Regularisation");
        let mut kind = regularization_kind(settings.regularization);
        egui::ComboBox::from_id_salt("regularization")
            .selected_text(kind)
            .show_ui(ui, |ui| {
                for k in ["auto", "gcv", "prior", "ridge"] {
                    ui.selectable_value(&mut kind, k, k);
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
        settings.regularization = match (kind, settings.regularization) {
            ("auto", _) => Regularization::Auto,
            ("gcv", _) => Regularization::Gcv,
            ("prior", Regularization::Prior { alpha }) => Regularization::Prior { alpha },
            ("prior", _) => Regularization::Prior {
                alpha: crate::solver::ridge::DEFAULT_ALPHA,
            },
            (_, Regularization::Ridge { lambda }) => Regularization::Ridge { lambda },
            _ => Regularization::Ridge { lambda: 1e-2 },
        };
        match &mut settings.regularization {
            Regularization::Prior { alpha } => {
                ui.label("α");
                ui.add(
                    egui::Slider::new(alpha, 1e-3..=100.0)
                        .logarithmic(true)
                        .text("α"),
                );
                ui.end_row();
            }
            Regularization::Ridge { lambda } => {
                ui.label("λ");
                ui.add(
                    egui::Slider::new(lambda, 1e-6..=10.0)
                        .logarithmic(true)
                        .text("λ"),
                );
                ui.end_row();
            }
            _ => {}
        }
    });
    // A new K or database size restarts the basis job once the slider is released.
    app.doc.set_basis_settings(settings);
}

fn regularization_kind(r: Regularization) -> &'static str {
    match r {
        Regularization::Auto => "auto",
        Regularization::Gcv => "gcv",
        Regularization::Prior { .. } => "prior",
        Regularization::Ridge { .. } => "ridge",
    }
}
