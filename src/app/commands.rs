//! The commands of the menus and the keyboard: what each is called, its shortcut and when it
//! can be chosen, in one table for the menu bar, the shortcut handling and the tests. A
//! command becomes an [`Action`], after a file dialog where it needs a path.

use super::{Action, BurnishApp};
use crate::export::Format;
use egui::{Key, KeyboardShortcut, Modifiers};
use std::path::PathBuf;

/// A menu entry, maybe with a keyboard shortcut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UiCommand {
    NewSession,
    OpenSession,
    /// Saves to the session's file, or asks for one when it has none yet.
    SaveSession,
    SaveSessionAs,
    ExportGuide,
    ExportPainting,
    ImportPainting,
    ExportTable,
    ExportMerl,
    StartFrom,
    LoadReference,
    Undo,
    Redo,
    Fill,
    AddView,
    SuggestView,
    ZoomToFit,
}

/// When a command's action is carried out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    /// At once: shortcuts (read before any panel draws) and dialogs that need the outcome.
    Now,
    /// At the start of the next frame, not while the menu that chose it draws.
    NextFrame,
}

impl UiCommand {
    /// Every command. Shortcuts are looked for in this order: Redo before Undo, since
    /// Ctrl+Z also matches Ctrl+Shift+Z logically and would consume it.
    pub const ALL: [UiCommand; 17] = [
        Self::Redo,
        Self::Undo,
        Self::SaveSession,
        Self::OpenSession,
        Self::AddView,
        Self::ExportTable,
        Self::NewSession,
        Self::SaveSessionAs,
        Self::ExportGuide,
        Self::ExportPainting,
        Self::ImportPainting,
        Self::ExportMerl,
        Self::StartFrom,
        Self::LoadReference,
        Self::Fill,
        Self::SuggestView,
        Self::ZoomToFit,
    ];

    /// What the menu calls it.
    pub fn label(self) -> &'static str {
        match self {
            Self::NewSession => "New session",
            Self::OpenSession => "Open session…",
            Self::SaveSession => "Save session",
            Self::SaveSessionAs => "Save session as…",
            Self::ExportGuide => "Export guide PNG…",
            Self::ExportPainting => "Export painting and mask (EXR or PNG)…",
            Self::ImportPainting => "Import painting (PNG or EXR)…",
            Self::ExportTable => "Export BRDF as EXR table…",
            Self::ExportMerl => "Export BRDF as MERL binary…",
            Self::StartFrom => "Start from a material…",
            Self::LoadReference => "Load reference material…",
            Self::Undo => "Undo stroke",
            Self::Redo => "Redo stroke",
            Self::Fill => "Fill object with brush colour",
            Self::AddView => "Add view",
            Self::SuggestView => "Suggest next view",
            Self::ZoomToFit => "Zoom to fit",
        }
    }

    /// The keys that choose it wherever the focus is.
    pub fn shortcut(self) -> Option<KeyboardShortcut> {
        let command = |key| Some(KeyboardShortcut::new(Modifiers::COMMAND, key));
        match self {
            Self::Undo => command(Key::Z),
            Self::Redo => Some(KeyboardShortcut::new(
                Modifiers::COMMAND.plus(Modifiers::SHIFT),
                Key::Z,
            )),
            Self::SaveSession => command(Key::S),
            Self::OpenSession => command(Key::O),
            Self::AddView => command(Key::T),
            Self::ExportTable => command(Key::E),
            _ => None,
        }
    }

    /// Whether it can be chosen now; the menu greys it out otherwise.
    pub fn is_enabled(self, app: &BurnishApp) -> bool {
        let canvas = app.document().active_view().map(|doc| doc.canvas());
        match self {
            Self::Undo => canvas.is_some_and(|c| c.can_undo()),
            Self::Redo => canvas.is_some_and(|c| c.can_redo()),
            _ => true,
        }
    }

    /// The action it stands for, asking for a file where it needs one. `None`: the dialog
    /// was cancelled, or the command changes only the window ([`Self::ZoomToFit`]).
    fn action(self, app: &BurnishApp) -> Option<Action> {
        let readable = Format::readable_extensions();
        match self {
            Self::NewSession => Some(Action::NewSession),
            Self::OpenSession => ask_open("Open session", &["burnish"]).map(Action::OpenSession),
            Self::SaveSession => app
                .document()
                .session_path()
                .map(PathBuf::from)
                .or_else(|| ask_save("Save session", "burnish"))
                .map(Action::SaveSession),
            Self::SaveSessionAs => ask_save("Save session", "burnish").map(Action::SaveSession),
            Self::ExportGuide => ask_save("Export guide", "png").map(Action::ExportGuide),
            Self::ExportPainting => ask_save("Export painting", "exr").map(Action::ExportPainting),
            Self::ImportPainting => {
                ask_open("Import painting", &["png", "exr"]).map(Action::ImportPainting)
            }
            Self::ExportTable => ask_save("Export BRDF table", "exr").map(Action::ExportTable),
            Self::ExportMerl => ask_save("Export MERL BRDF", "binary").map(Action::ExportMerl),
            Self::StartFrom => ask_open(
                "Start from a material (EXR table, MERL binary or .bsdf)",
                &readable,
            )
            .map(Action::StartFrom),
            Self::LoadReference => ask_open(
                "Load reference material (EXR table, MERL binary or .bsdf)",
                &readable,
            )
            .map(Action::LoadReference),
            Self::Undo => Some(Action::Undo),
            Self::Redo => Some(Action::Redo),
            Self::Fill => Some(Action::FillObject),
            Self::AddView => Some(Action::AddView),
            Self::SuggestView => Some(Action::SuggestView),
            Self::ZoomToFit => None,
        }
    }
}

impl BurnishApp {
    /// Carries out `command` (`when` says when its action runs).
    pub fn run_command(&mut self, command: UiCommand, when: When) {
        if command == UiCommand::ZoomToFit {
            self.canvas_view.reset_zoom();
            return;
        }
        let Some(action) = command.action(self) else {
            return;
        };
        match when {
            When::Now => self.perform(action),
            When::NextFrame => self.queue(action),
        }
    }
}

/// The native open dialog: a file with one of the extensions `ext`.
pub(super) fn ask_open(title: &str, ext: &[&str]) -> Option<PathBuf> {
    rfd::FileDialog::new()
        .set_title(title)
        .add_filter(ext.join(", "), ext)
        .pick_file()
}

/// The native save dialog; a name without an extension gets `ext`.
fn ask_save(title: &str, ext: &str) -> Option<PathBuf> {
    let mut path = rfd::FileDialog::new()
        .set_title(title)
        .add_filter(ext, &[ext])
        .save_file()?;
    if path.extension().is_none() {
        path.set_extension(ext);
    }
    Some(path)
}

/// The native save dialog for `format`; the chosen path becomes an [`Action::Export`].
pub(super) fn ask_export(format: Format) -> Option<Action> {
    ask_save(format.label(), format.extension()).map(Action::Export)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_is_listed_once_with_a_label_and_no_two_share_a_shortcut() {
        for (i, a) in UiCommand::ALL.iter().enumerate() {
            assert!(!a.label().is_empty());
            for b in &UiCommand::ALL[i + 1..] {
                assert_ne!(a, b);
                if let (Some(x), Some(y)) = (a.shortcut(), b.shortcut()) {
                    assert_ne!(x, y, "{a:?} and {b:?}");
                }
            }
        }
    }

    #[test]
    fn redo_is_looked_for_before_undo() {
        let at = |c| UiCommand::ALL.iter().position(|&x| x == c).unwrap();
        assert!(at(UiCommand::Redo) < at(UiCommand::Undo));
    }
}
