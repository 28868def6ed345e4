//! The menu bar, keyboard shortcuts and the windows over the panels (notices, recovery,
//! unsaved changes). Each choice is a [`UiCommand`] or an [`Action`].

use super::commands::{UiCommand, When, ask_export, ask_open};
use super::{Action, BurnishApp};
use crate::export::Format;
use egui::Key;
use std::path::PathBuf;

/// Keyboard shortcuts that work wherever the focus is.
pub(super) fn shortcuts(app: &mut BurnishApp, ctx: &egui::Context) {
    let (pressed, smaller, larger) = ctx.input_mut(|i| {
        let pressed: Vec<UiCommand> = UiCommand::ALL
            .into_iter()
            .filter(|c| c.shortcut().is_some_and(|s| i.consume_shortcut(&s)))
            .collect();
        (
            pressed,
            i.key_pressed(Key::OpenBracket),
            i.key_pressed(Key::CloseBracket),
        )
    });
    for command in pressed {
        if command.is_enabled(app) {
            app.run_command(command, When::Now);
        }
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
    if let Some(path) = ask_open(title, ext) {
        app.queue(action(path));
    }
}

/// A menu entry for `command`: its label and shortcut, greyed out when it cannot be chosen.
fn command_button(ui: &mut egui::Ui, app: &mut BurnishApp, command: UiCommand) {
    let mut button = egui::Button::new(command.label());
    if let Some(shortcut) = command.shortcut() {
        button = button.shortcut_text(ui.ctx().format_shortcut(&shortcut));
    }
    if ui.add_enabled(command.is_enabled(app), button).clicked() {
        app.run_command(command, When::NextFrame);
    }
}

pub(super) fn menu_bar(app: &mut BurnishApp, ui: &mut egui::Ui) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.menu_button("File", |ui| {
            for command in [
                UiCommand::NewSession,
                UiCommand::OpenSession,
                UiCommand::SaveSession,
                UiCommand::SaveSessionAs,
            ] {
                command_button(ui, app, command);
            }
            ui.separator();
            for command in [
                UiCommand::ExportGuide,
                UiCommand::ExportPainting,
                UiCommand::ImportPainting,
            ] {
                command_button(ui, app, command);
            }
            ui.separator();
            command_button(ui, app, UiCommand::ExportTable);
            command_button(ui, app, UiCommand::ExportMerl);
            ui.menu_button("Export BRDF for other renderers", |ui| {
                for format in [Format::RglBsdf, Format::MaterialX, Format::Gltf] {
                    let label = format!("{} (.{})…", format.label(), format.extension());
                    if ui.button(label).clicked()
                        && let Some(action) = ask_export(format)
                    {
                        app.queue(action);
                    }
                }
            });
            ui.separator();
            command_button(ui, app, UiCommand::StartFrom);
            if let Some(name) = app.doc.start_material_name().map(str::to_owned)
                && ui
                    .button(format!("Clear starting material ({name})"))
                    .clicked()
            {
                app.queue(Action::ClearStart);
            }
            command_button(ui, app, UiCommand::LoadReference);
        });
        ui.menu_button("Edit", |ui| {
            command_button(ui, app, UiCommand::Undo);
            command_button(ui, app, UiCommand::Redo);
            ui.separator();
            command_button(ui, app, UiCommand::Fill);
        });
        ui.menu_button("View", |ui| {
            command_button(ui, app, UiCommand::AddView);
            command_button(ui, app, UiCommand::SuggestView);
            ui.checkbox(
                &mut app.show_overlay,
                "Show disagreement and coverage overlay",
            );
            command_button(ui, app, UiCommand::ZoomToFit);
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
                        app.run_command(UiCommand::SaveSession, When::Now);
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
