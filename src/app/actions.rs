//! What the menus and shortcuts do: sessions, import and export, undo, views.
//! File dialogs only supply paths; every action takes its path, so tests drive them directly.

use super::file_jobs::{JobKind, Outcome};
use super::{BurnishApp, ViewDoc};
use crate::export::{ExportOptions, Format, export, load_table};
use crate::image_io::RgbImage;
use crate::paint::BrushKind;
use crate::scene::{GBuffer, Scene, render_table, write_png};
use crate::session::{Session, SessionView, StartMaterial};
use crate::solver::Reconstruction;
use crate::table::merl::MerlBrdf;
use crate::worker::{Command, ViewId};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Something the user asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    NewSession,
    OpenSession(PathBuf),
    SaveSession(PathBuf),
    ImportPainting(PathBuf),
    ExportGuide(PathBuf),
    /// The active view's painting as the canvas shows it (EXR: linear, HDR; PNG: sRGB), and
    /// next to it [`painting_mask_path`] saying which pixels were painted, for
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
        let result = match action {
            Action::NewSession => self.new_session(),
            Action::OpenSession(path) => self.open_session(&path),
            Action::SaveSession(path) => self.save_session(&path),
            Action::ImportPainting(path) => self.import_painting(&path),
            Action::ExportGuide(path) => self.export_guide(&path),
            Action::ExportPainting(path) => self.export_painting(&path),
            Action::ExportTable(path) => self.export_in_background(&path, ExportKind::Table),
            Action::ExportMerl(path) => self.export_in_background(&path, ExportKind::Merl),
            Action::Export(path) => self.export_in_background(&path, ExportKind::Any),
            Action::StartFrom(path) => self.start_from(&path),
            Action::ClearStart => {
                self.clear_start();
                Ok(())
            }
            Action::AddView => {
                // A light and camera that differ from the existing views', not a copy.
                let existing: Vec<Scene> = self.views.iter().map(|v| v.scene.clone()).collect();
                let scene = match self.active_view() {
                    Some(active) => super::document::propose_view(&active.scene, &existing),
                    None => Scene::default(),
                };
                self.add_view(scene)
            }
            Action::SuggestView => {
                self.suggest_view();
                Ok(())
            }
            Action::StartFromCurrentBrdf => {
                self.start_from_current_brdf(self.active);
                Ok(())
            }
            Action::Undo => {
                self.undo_redo(true);
                Ok(())
            }
            Action::Redo => {
                self.undo_redo(false);
                Ok(())
            }
            Action::Recover => self.recover(),
            Action::DiscardRecovery => {
                if let Some(info) = self.recovery_offer.take() {
                    let _ = std::fs::remove_file(&info.path);
                }
                Ok(())
            }
            Action::LoadReference(path) => self.load_reference(&path),
            Action::LoadEnvironment(path) => self.load_environment(&path),
            Action::OpenPreviewObject(path) => {
                self.set_preview_object(crate::preview::PreviewObject::Obj(path));
                Ok(())
            }
        };
        if let Err(e) = result {
            self.notify_error(e.to_string());
        }
    }

    fn undo_redo(&mut self, undo: bool) {
        let Some(doc) = self.active_view_mut() else {
            return;
        };
        let changes = if undo {
            doc.canvas.undo()
        } else {
            doc.canvas.redo()
        };
        self.publish_canvas_changes(changes, Instant::now());
    }

    /// The session as it stands: every view, the brush and the basis settings.
    pub fn to_session(&self) -> Session {
        Session {
            views: self
                .views
                .iter()
                .map(|v| SessionView {
                    name: v.name.clone(),
                    scene: v.scene.clone(),
                    muted: v.muted,
                    paint: v.canvas.layers().clone(),
                    unpainted: v.unpainted,
                    base: v.prediction().cloned(),
                })
                .collect(),
            active_view: self.active,
            brush: self.brush.clone(),
            basis: self.basis_settings,
            start: self.start_material.clone(),
        }
    }

    /// Replaces every view with those of `session`. Nothing changes when it fails.
    pub fn load_session(&mut self, session: Session) -> crate::Result<()> {
        let first_id = self.next_view_id;
        let mut docs = Vec::with_capacity(session.views.len());
        for (i, view) in session.views.into_iter().enumerate() {
            docs.push(ViewDoc::with_paint(
                first_id + i as u32,
                view.name,
                view.scene,
                view.paint,
                view.muted,
                view.unpainted,
                view.base,
            )?);
        }
        for old in self.views.drain(..) {
            self.worker.send(Command::RemoveView(old.id));
        }
        self.next_view_id = first_id + docs.len() as u32;
        for doc in &docs {
            self.worker.send(Command::SetView {
                view: doc.id,
                gbuffer: doc.gbuffer.clone(),
            });
            self.worker.send(Command::MuteView {
                view: doc.id,
                muted: doc.muted,
            });
            self.worker.send(Command::ReplacePaint {
                view: doc.id,
                painted: doc.counted_pixels(),
            });
        }
        self.views = docs;
        // The session's own starting material, or none: its canvases already hold the
        // renders of it they were saved with.
        match session.start {
            Some(start) => {
                self.worker
                    .send(Command::SetStartMaterial(Some(start.table.clone())));
                self.set_reference(start.name.clone(), start.table.clone());
                self.start_material = Some(start);
            }
            None => self.clear_start(),
        }
        self.active = session.active_view.min(self.views.len().saturating_sub(1));
        self.brush = session.brush;
        if session.basis != self.basis_settings {
            self.worker.send(Command::SetPolicy(session.basis.policy));
            self.worker
                .send(Command::SetRegularization(session.basis.regularization));
            self.basis_settings = session.basis;
        }
        self.canvas_view.invalidate();
        Ok(())
    }

    fn new_session(&mut self) -> crate::Result<()> {
        let view = ViewDoc::new(self.next_view_id, "View 1".into(), Scene::default())?;
        let session = Session {
            views: vec![SessionView {
                name: view.name.clone(),
                scene: view.scene.clone(),
                muted: false,
                paint: view.canvas.layers().clone(),
                unpainted: view.unpainted,
                base: None,
            }],
            active_view: 0,
            brush: self.brush.clone(),
            basis: self.basis_settings,
            start: None,
        };
        self.load_session(session)?;
        self.session_path = None;
        self.dirty = false;
        Ok(())
    }

    pub fn open_session(&mut self, path: &Path) -> crate::Result<()> {
        let session = Session::open(path)?;
        self.load_session(session)?;
        self.session_path = Some(path.to_path_buf());
        self.dirty = false;
        self.saved_to(self.session_path.clone());
        self.notify(format!("opened {}", path.display()));
        Ok(())
    }

    pub fn save_session(&mut self, path: &Path) -> crate::Result<()> {
        self.to_session().save(path)?;
        self.session_path = Some(path.to_path_buf());
        self.dirty = false;
        self.saved_to(self.session_path.clone());
        self.notify(format!("saved {}", path.display()));
        Ok(())
    }

    fn recover(&mut self) -> crate::Result<()> {
        let Some(info) = self.recovery_offer.take() else {
            return Ok(());
        };
        let session = match info.open() {
            Ok(session) => session,
            Err(e) => {
                // Keep the offer: the file stays for another try (or a bug report).
                self.recovery_offer = Some(info);
                return Err(e);
            }
        };
        self.load_session(session)?;
        self.session_path = info.session_path.clone();
        self.touch();
        self.notify(format!(
            "recovered from {}. Undo history is not kept in recovery or session files: \
             undo starts from here.",
            info.path.display()
        ));
        Ok(())
    }

    /// Replaces the active view's painting with an image painted elsewhere (PNG or EXR of
    /// the guide's size). Every object pixel of the image becomes paint.
    pub fn import_painting(&mut self, path: &Path) -> crate::Result<()> {
        let Some(doc) = self.views.get_mut(self.active) else {
            return Ok(());
        };
        let resolution = doc.gbuffer.resolution();
        let image = crate::scene::read_painting(path, resolution)?;
        if image
            .pixels
            .iter()
            .any(|p| p.iter().any(|c| !c.is_finite() || *c < 0.0))
        {
            return Err(crate::Error::invalid(
                path,
                "the painting has NaN, infinite or negative pixels",
            ));
        }
        doc.import_painting(&image)?;
        self.worker.send(Command::ReplacePaint {
            view: doc.id,
            painted: doc.counted_pixels(),
        });
        self.canvas_view.invalidate();
        self.touch();
        self.notify(format!("imported {}", path.display()));
        Ok(())
    }

    pub fn export_guide(&mut self, path: &Path) -> crate::Result<()> {
        let Some(doc) = self.active_view() else {
            return Ok(());
        };
        write_png(path, &doc.guide)?;
        self.notify(format!("guide written to {}", path.display()));
        Ok(())
    }

    /// Writes the active view's painting and its coverage mask (see
    /// [`Action::ExportPainting`]).
    pub fn export_painting(&mut self, path: &Path) -> crate::Result<()> {
        let Some(doc) = self.active_view() else {
            return Ok(());
        };
        let layers = doc.canvas.layers();
        let mask = crate::image_io::RgbImage {
            width: layers.colour.width,
            height: layers.colour.height,
            pixels: layers
                .coverage
                .iter()
                .map(|&c| if c > 0.0 { [1.0; 3] } else { [0.0; 3] })
                .collect(),
        };
        let mask_path = painting_mask_path(path);
        crate::scene::write_image(path, &layers.colour)?;
        write_png(&mask_path, &mask)?;
        self.notify(format!(
            "painting written to {} and what was painted to {}",
            path.display(),
            mask_path.display()
        ));
        Ok(())
    }

    /// The current reconstruction (basis and coefficients) for an export to `path`; the
    /// full table is made on the export's thread.
    fn current_reconstruction(&self, path: &Path) -> crate::Result<Reconstruction> {
        let Some(basis) = self.snapshot.basis.clone() else {
            return Err(crate::Error::invalid(
                path,
                "the basis is not ready yet; export when the status bar says it is",
            ));
        };
        Ok(Reconstruction::new(basis, &self.snapshot.coefficients))
    }

    /// Writes the BRDF to `path` on a thread of its own (making the full table and writing
    /// a `.bsdf` or fitting an analytic material take seconds); the notice names the file
    /// and says what it holds (for the analytic formats, the fit's error).
    fn export_in_background(&mut self, path: &Path, format: ExportKind) -> crate::Result<()> {
        if format == ExportKind::Any && Format::from_path(path).is_none() {
            // An extension no writer knows is refused at once, before any work.
            return Err(crate::Error::invalid(
                path,
                format!(
                    "unknown material format: the extension must be one of .{}",
                    Format::extensions().join(", .")
                ),
            ));
        }
        let reconstruction = self.current_reconstruction(path)?;
        let target = path.to_path_buf();
        let label = format!("exporting {}…", file_name(path));
        self.file_jobs
            .spawn(label, JobKind::Export, target.clone(), move || {
                let table = reconstruction.materialize();
                let message = match format {
                    ExportKind::Merl => {
                        MerlBrdf::from_table(&table).write(&target)?;
                        format!("BRDF written to {}", target.display())
                    }
                    ExportKind::Table => {
                        crate::table::exr_file::write_table_exr(&target, &table)?;
                        format!("BRDF written to {}", target.display())
                    }
                    ExportKind::Any => {
                        let report = export(&target, &table, &ExportOptions::default())?;
                        format!("BRDF written to {}: {report}", target.display())
                    }
                };
                Ok(Outcome::Written(message))
            })
            .map_err(|e| crate::Error::io(path, e))
    }

    /// Reads a starting material and renders it under every view's paint on a thread of its
    /// own; [`Self::take_file_jobs`] puts it in place when it is done.
    fn start_from(&mut self, path: &Path) -> crate::Result<()> {
        let request = self.file_jobs.new_start_request();
        let views: Vec<(ViewId, Arc<GBuffer>)> = self
            .views
            .iter()
            .map(|d| (d.id, d.gbuffer.clone()))
            .collect();
        let source = path.to_path_buf();
        let name = file_name(path);
        let label = format!("reading {name}…");
        self.file_jobs
            .spawn(
                label,
                JobKind::Start { request },
                source.clone(),
                move || {
                    let table = Arc::new(load_table(&source)?);
                    let renders = views
                        .into_iter()
                        .map(|(id, gbuffer)| {
                            let image = render_table(&gbuffer, &table);
                            (id, gbuffer, image)
                        })
                        .collect();
                    let start = StartMaterial {
                        name,
                        source: Some(source),
                        table,
                    };
                    Ok(Outcome::StartLoaded { start, renders })
                },
            )
            .map_err(|e| crate::Error::io(path, e))
    }

    /// Takes the file jobs that finished: notices for exports, and a starting material put
    /// in place.
    pub(super) fn take_file_jobs(&mut self) {
        for (job, outcome) in self.file_jobs.take_finished() {
            match outcome {
                Ok(Outcome::Written(message)) => self.notify(message),
                Ok(Outcome::StartLoaded { start, renders }) => {
                    // A later start was asked for meanwhile: that one is the user's choice.
                    if let JobKind::Start { request } = job.kind
                        && !self.file_jobs.is_latest_start(request)
                    {
                        continue;
                    }
                    if let Err(e) = self.set_start(start, renders) {
                        self.notify_error(e.to_string());
                    }
                }
                Err(e) => self.notify_error(e.to_string()),
            }
        }
    }

    /// Whether exports or a starting material are still being written or read.
    pub fn file_jobs_pending(&self) -> bool {
        !self.file_jobs.is_empty()
    }

    /// Makes `start` the material the painting edits: the worker centres the prior on its
    /// projection, and every canvas shows it under its paint (`renders`, where they are of
    /// the view's current geometry; rendered here for views that changed meanwhile).
    fn set_start(
        &mut self,
        start: StartMaterial,
        renders: Vec<(ViewId, Arc<GBuffer>, RgbImage)>,
    ) -> crate::Result<()> {
        self.worker
            .send(Command::SetStartMaterial(Some(start.table.clone())));
        // Paint on the starting material: pixels counted as shown then say "this material"
        // rather than the grey guide.
        let mut renders: HashMap<ViewId, (Arc<GBuffer>, RgbImage)> = renders
            .into_iter()
            .map(|(id, gbuffer, image)| (id, (gbuffer, image)))
            .collect();
        let mut result = Ok(());
        for doc in &mut self.views {
            let image = match renders.remove(&doc.id) {
                Some((gbuffer, image)) if Arc::ptr_eq(&gbuffer, &doc.gbuffer) => image,
                _ => render_table(&doc.gbuffer, &start.table),
            };
            if let Err(e) = doc.set_prediction(image) {
                result = Err(e);
            }
            self.awaiting_prediction.remove(&doc.id);
            self.worker.send(Command::ReplacePaint {
                view: doc.id,
                painted: doc.counted_pixels(),
            });
        }
        self.canvas_view.invalidate();
        self.touch();
        let name = start.name.clone();
        self.set_reference(name.clone(), start.table.clone());
        self.start_material = Some(start);
        self.notify(format!("painting from {name}"));
        result
    }

    fn clear_start(&mut self) {
        if self.start_material.take().is_some() {
            self.worker.send(Command::SetStartMaterial(None));
        }
    }

    /// The name of the material the painting starts from, if any.
    pub fn start_material_name(&self) -> Option<&str> {
        self.start_material.as_ref().map(|s| s.name.as_str())
    }
}

/// Which writer an export uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ExportKind {
    /// TABLE.md's EXR table image.
    Table,
    Merl,
    /// The format the extension names (`crate::export::Format`).
    Any,
}

/// A path's file name for notices, or the whole path where it has none.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

/// Where [`Action::ExportPainting`] writes the mask of painted pixels for a painting at
/// `painting`: `NAME-mask.png` beside it (white: painted).
pub fn painting_mask_path(painting: &Path) -> PathBuf {
    let stem = painting
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    painting.with_file_name(format!("{stem}-mask.png"))
}

impl BurnishApp {
    /// Fills the active view's object with the brush colour (one undo step).
    pub fn fill_active(&mut self) {
        let mut settings = self.brush.clone();
        settings.kind = BrushKind::Fill;
        if let Some(doc) = self.active_view_mut() {
            doc.canvas.fill(&settings);
            let changes = doc.canvas.take_changes();
            self.publish_canvas_changes(changes, Instant::now());
        }
    }
}
