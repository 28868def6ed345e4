//! What the menus and shortcuts do: sessions, import and export, undo, views. The
//! document carries most of it out. File dialogs only supply paths; every action takes its
//! path, so tests drive them directly.

use super::BurnishApp;
use crate::document::ExportKind;
use std::path::PathBuf;

/// Something the user asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    NewSession,
    OpenSession(PathBuf),
    SaveSession(PathBuf),
    ImportPainting(PathBuf),
    ExportGuide(PathBuf),
    /// The active view's painting as the canvas shows it (EXR: linear, HDR; PNG: sRGB), and
    /// next to it [`crate::document::painting_mask_path`] saying which pixels were painted, for
    /// `burnish reconstruct --unpainted … --mask`.
    ExportPainting(PathBuf),
    ExportTable(PathBuf),
    ExportMerl(PathBuf),
    /// The BRDF in the format the extension names (see `crate::export::Format`).
    Export(PathBuf),
    /// A material (EXR table, MERL binary or `.bsdf`) the painting edits: its projection
    /// onto the basis becomes the prior mean; it is also shown as the preview's reference.
    StartFrom(PathBuf),
    /// Back to the database's mean material as the prior mean.
    ClearStart,
    AddView,
    /// Rank candidate views by what painting them would teach (off the UI thread) and add
    /// the best when the ranking arrives.
    SuggestView,
    /// Fill the active view's object with the brush colour (one undo step).
    FillObject,
    /// Put a render of the current BRDF under the active view's paint.
    StartFromCurrentBrdf,
    Undo,
    Redo,
    Recover,
    DiscardRecovery,
    /// A BRDF to compare with in the preview: an EXR table or a MERL binary.
    LoadReference(PathBuf),
    /// An equirectangular OpenEXR image for the preview's environment light.
    LoadEnvironment(PathBuf),
    /// An OBJ file as the preview's object.
    OpenPreviewObject(PathBuf),
}

impl BurnishApp {
    pub fn perform(&mut self, action: Action) {
        let doc = &mut self.doc;
        let result = match action {
            Action::NewSession => doc.new_session(),
            Action::OpenSession(path) => doc.open_session(&path).map(|b| self.brush = b),
            Action::SaveSession(path) => doc.save_session(&path, &self.brush),
            Action::ImportPainting(path) => doc.import_painting(&path).map(drop),
            Action::ExportGuide(path) => doc.export_guide(&path),
            Action::ExportPainting(path) => doc.export_painting(&path),
            Action::ExportTable(path) => doc.export_brdf(&path, ExportKind::Table),
            Action::ExportMerl(path) => doc.export_brdf(&path, ExportKind::Merl),
            Action::Export(path) => doc.export_brdf(&path, ExportKind::Any),
            Action::StartFrom(path) => doc.start_from(&path),
            Action::ClearStart => {
                doc.clear_start();
                Ok(())
            }
            Action::AddView => doc.add_proposed_view(),
            Action::SuggestView => {
                doc.suggest_view();
                Ok(())
            }
            Action::StartFromCurrentBrdf => {
                doc.start_from_current_brdf(doc.active());
                Ok(())
            }
            Action::Undo | Action::Redo => {
                if let Some(dirty) = doc.undo_redo(action == Action::Undo) {
                    self.canvas_view.mark_dirty(dirty);
                }
                Ok(())
            }
            Action::FillObject => {
                if let Some(dirty) = doc.fill_active(&self.brush) {
                    self.canvas_view.mark_dirty(dirty);
                }
                Ok(())
            }
            Action::Recover => doc.recover().map(|brush| {
                if let Some(brush) = brush {
                    self.brush = brush;
                }
            }),
            Action::DiscardRecovery => {
                doc.discard_recovery_offer();
                Ok(())
            }
            Action::LoadReference(path) => self.load_reference(&path),
            Action::LoadEnvironment(path) => self.load_environment(&path),
            Action::OpenPreviewObject(path) => {
                self.set_preview_object(crate::preview::PreviewObject::Obj(path));
                Ok(())
            }
        };
        // What the document reported comes first, as it happened before any error.
        self.take_document_events();
        if let Err(e) = result {
            self.notify_error(e.to_string());
        }
    }
}
