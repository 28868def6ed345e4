//! The menu bar, keyboard shortcuts, file dialogs and the windows over the panels (notices,
//! recovery, unsaved changes). Each choice becomes an [`Action`] or an app method.

use super::{Action, BurnishApp};
use crate::export::Format;
use egui::{Key, KeyboardShortcut, Modifiers};
use std::path::PathBuf;

const UNDO: KeyboardShortcut = KeyboardShortcut::new(Modifiers::COMMAND, Key::Z);
const REDO: KeyboardShortcut =
    KeyboardShortcut::new(Modifiers::COMMAND.plus(Modifiers::SHIFT), Key::Z);
const SAVE: KeyboardShortcut = KeyboardShortcut::new(Modifiers::COMMAND, Key::S);
const OPEN: KeyboardShortcut = KeyboardShortcut::new(Modifiers::COMMAND, Key::O);
const NEW_VIEW: KeyboardShortcut = KeyboardShortcut::new(Modifiers::COMMAND, Key::T);
const EXPORT: KeyboardShortcut = KeyboardShortcut::new(Modifiers::COMMAND, Key::E);

/// Keyboard shortcuts that work wherever the focus is.
pub(super) fn shortcuts(app: &mut BurnishApp, ctx: &egui::Context) {
    // Redo first: Ctrl+Z also matches Ctrl+Shift+Z logically and would consume it.
    let (redo, undo, save, open, new_view, export, smaller, larger) = ctx.input_mut(|i| {
        (
            i.consume_shortcut(&REDO),
            i.consume_shortcut(&UNDO),
            i.consume_shortcut(&SAVE),
            i.consume_shortcut(&OPEN),
            i.consume_shortcut(&NEW_VIEW),
            i.consume_shortcut(&EXPORT),
            i.key_pressed(Key::OpenBracket),
            i.key_pressed(Key::CloseBracket),
        )
    });
    if redo {
        app.perform(Action::Redo);
    } else if undo {
        app.perform(Action::Undo);
    }
    if save {
        match app.doc.session_path().map(PathBuf::from) {
            Some(path) => app.perform(Action::SaveSession(path)),
            None => pick_save(app, "Save session", "burnish", Action::SaveSession),
        }
    }
    if open {
        pick_open(app, "Open session", &["burnish"], Action::OpenSession);
    }
    if new_view {
        app.perform(Action::AddView);
    }
    if export {
        pick_save(app, "Export BRDF table", "exr", Action::ExportTable);
    }
    if smaller {
        app.brush.size = (app.brush.size / 1.2).max(1.0);
    }
    if larger {
        app.brush.size = (app.brush.size * 1.2).min(1000.0);
    }
}

/// Native open dialog; the chosen path becomes an action.
pub(super) fn pick_open(
    app: &mut BurnishApp,
    title: &str,
    ext: &[&str],
    action: fn(PathBuf) -> Action,
) {
    if let Some(path) = rfd::FileDialog::new()
        .set_title(title)
        .add_filter(ext.join(", "), ext)
        .pick_file()
    {
        app.queue(action(path));
    }
}

fn pick_save(app: &mut BurnishApp, title: &str, ext: &str, action: fn(PathBuf) -> Action) {
    if let Some(mut path) = rfd::FileDialog::new()
        .set_title(title)
        .add_filter(ext, &[ext])
        .save_file()
    {
        if path.extension().is_none() {
            path.set_extension(ext);
        }
        app.queue(action(path));
    }
}

pub(super) fn menu_bar(app: &mut BurnishApp, ui: &mut egui::Ui) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.menu_button("File", |ui| {
            if ui.button("New session").clicked() {
                app.queue(Action::NewSession);
            }
            if ui
                .add(
                    egui::Button::new("Open session…")
                        .shortcut_text(ui.ctx().format_shortcut(&OPEN)),
                )
                .clicked()
            {
                pick_open(app, "Open session", &["burnish"], Action::OpenSession);
            }
            if ui
                .add(
                    egui::Button::new("Save session")
                        .shortcut_text(ui.ctx().format_shortcut(&SAVE)),
                )
                .clicked()
            {
                match app.doc.session_path().map(PathBuf::from) {
                    Some(path) => app.queue(Action::SaveSession(path)),
                    None => pick_save(app, "Save session", "burnish", Action::SaveSession),
                }
            }
            if ui.button("Save session as…").clicked() {
                pick_save(app, "Save session", "burnish", Action::SaveSession);
            }
            ui.separator();
            if ui.button("Export guide PNG…").clicked() {
                pick_save(app, "Export guide", "png", Action::ExportGuide);
            }
            if ui
                .button("Export painting and mask (EXR or PNG)…")
                .clicked()
            {
                pick_save(app, "Export painting", "exr", Action::ExportPainting);
            }
            if ui.button("Import painting (PNG or EXR)…").clicked() {
                pick_open(
                    app,
                    "Import painting",
                    &["png", "exr"],
                    Action::ImportPainting,
                );
            }
            ui.separator();
            if ui
                .add(
                    egui::Button::new("Export BRDF as EXR table…")
                        .shortcut_text(ui.ctx().format_shortcut(&EXPORT)),
                )
                .clicked()
            {
                pick_save(app, "Export BRDF table", "exr", Action::ExportTable);
            }
            if ui.button("Export BRDF as MERL binary…").clicked() {
                pick_save(app, "Export MERL BRDF", "binary", Action::ExportMerl);
            }
            ui.menu_button("Export BRDF for other renderers", |ui| {
                for format in [Format::RglBsdf, Format::MaterialX, Format::Gltf] {
                    let label = format!("{} (.{})…", format.label(), format.extension());
                    if ui.button(label).clicked() {
                        pick_save(app, format.label(), format.extension(), Action::Export);
                    }
                }
            });
            ui.separator();
            let readable = Format::readable_extensions();
            if ui.button("Start from a material…").clicked() {
                pick_open(
                    app,
                    "Start from a material (EXR table, MERL binary or .bsdf)",
                    &readable,
                    Action::StartFrom,
                );
            }
            if let Some(name) = app.doc.start_material_name().map(str::to_owned)
                && ui
                    .button(format!("Clear starting material ({name})"))
                    .clicked()
            {
                app.queue(Action::ClearStart);
            }
            if ui.button("Load reference material…").clicked() {
                pick_open(
                    app,
                    "Load reference material (EXR table, MERL binary or .bsdf)",
                    &readable,
                    Action::LoadReference,
                );
            }
        });
        ui.menu_button("Edit", |ui| {
            let doc = app.doc.active_view();
            let (can_undo, can_redo) = doc.map_or((false, false), |d| {
                (d.canvas.can_undo(), d.canvas.can_redo())
            });
            if ui
                .add_enabled(
                    can_undo,
                    egui::Button::new("Undo stroke").shortcut_text(ui.ctx().format_shortcut(&UNDO)),
                )
                .clicked()
            {
                app.queue(Action::Undo);
            }
            if ui
                .add_enabled(
                    can_redo,
                    egui::Button::new("Redo stroke").shortcut_text(ui.ctx().format_shortcut(&REDO)),
                )
                .clicked()
            {
                app.queue(Action::Redo);
            }
            ui.separator();
            if ui.button("Fill object with brush colour").clicked() {
                app.fill_active();
            }
        });
        ui.menu_button("View", |ui| {
            if ui
                .add(
                    egui::Button::new("Add view")
                        .shortcut_text(ui.ctx().format_shortcut(&NEW_VIEW)),
                )
                .clicked()
            {
                app.queue(Action::AddView);
            }
            if ui.button("Suggest next view").clicked() {
                app.queue(Action::SuggestView);
            }
            ui.checkbox(
                &mut app.show_overlay,
                "Show disagreement and coverage overlay",
            );
            if ui.button("Zoom to fit").clicked() {
                app.canvas_view.reset_zoom();
            }
        });
    });
}

/// Notices and the recovery question.
pub(super) fn dialogs(app: &mut BurnishApp, ctx: &egui::Context) {
    if let Some(info) = app.doc.recovery_offer().cloned() {
        egui::Window::new("Recover unsaved work?")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .show(ctx, |ui| {
                ui.label(format!(
                    "Burnish did not close cleanly. A recovery file with {} view(s) was saved {}.",
                    info.views,
                    age_text(info.modified)
                ));
                if let Some(path) = &info.session_path {
                    ui.label(format!("It holds unsaved changes to {}.", path.display()));
                }
                ui.horizontal(|ui| {
                    if ui.button("Recover").clicked() {
                        app.queue(Action::Recover);
                    }
                    if ui.button("Discard").clicked() {
                        app.queue(Action::DiscardRecovery);
                    }
                });
            });
    }
    if app.confirm_close {
        egui::Window::new("Save changes before closing?")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .show(ctx, |ui| {
                ui.horizontal(|ui| {
                    if ui.button("Save").clicked() {
                        match app.doc.session_path().map(PathBuf::from) {
                            Some(path) => app.perform(Action::SaveSession(path)),
                            None => {
                                if let Some(path) = rfd::FileDialog::new()
                                    .add_filter("burnish", &["burnish"])
                                    .save_file()
                                {
                                    app.perform(Action::SaveSession(path));
                                }
                            }
                        }
                        app.confirm_close = false;
                        if !app.doc.is_dirty() {
                            app.doc.discard_recovery();
                            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                        }
                    }
                    if ui.button("Don't save").clicked() {
                        app.doc.discard_unsaved();
                        app.confirm_close = false;
                        app.doc.discard_recovery();
                        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                    }
                    if ui.button("Cancel").clicked() {
                        app.confirm_close = false;
                    }
                });
            });
    }
    if app.doc.file_jobs_pending() {
        let labels: Vec<String> = app.doc.file_job_labels().map(str::to_owned).collect();
        egui::Area::new(egui::Id::unique("burnish-file-jobs"))
            .anchor(egui::Align2::LEFT_BOTTOM, [12.0, -36.0])
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    for label in labels {
                        ui.horizontal(|ui| {
                            ui.spinner();
                            ui.label(label);
                        });
                    }
                });
            });
    }
    if !app.notices.is_empty() {
        let mut dismissed = Vec::new();
        egui::Area::new(egui::Id::unique("burnish-notices"))
            .anchor(egui::Align2::RIGHT_BOTTOM, [-12.0, -36.0])
            .show(ctx, |ui| {
                for (i, notice) in app.notices.iter().enumerate().rev().take(4) {
                    egui::Frame::popup(ui.style()).show(ui, |ui| {
                        ui.horizontal(|ui| {
                            let text = egui::RichText::new(&notice.text);
                            ui.label(if notice.is_error {
                                text.color(ui.visuals().error_fg_color)
                            } else {
                                text
                            });
                            if ui.small_button("×").clicked() {
                                dismissed.push(i);
                            }
                        });
                    });
                }
            });
        dismissed.sort_unstable();
        for i in dismissed.into_iter().rev() {
            app.notices.remove(i);
        }
    }
}

/// "3 minutes ago" and the like.
fn age_text(modified: std::time::SystemTime) -> String {
    let seconds = std::time::SystemTime::now()
        .duration_since(modified)
        .map_or(0, |d| d.as_secs());
    match seconds {
        0..60 => "less than a minute ago".into(),
        60..3600 => format!("{} minutes ago", seconds / 60),
        3600..86400 => format!("{} hours ago", seconds / 3600),
        _ => format!("{} days ago", seconds / 86400),
    }
}
