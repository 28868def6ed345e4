//! The document's files: the session (open, save, recover), paintings imported and
//! exported, BRDF exports and the material the painting starts from. Slow work (exports,
//! reading a starting material) runs on a thread of its own; [`Document::poll`] takes it.

use super::file_jobs::{JobKind, Outcome};
use super::{Document, Event, ViewDoc};
use crate::export::{ExportOptions, Format, export, load_table};
use crate::image_io::RgbImage;
use crate::paint::BrushSettings;
use crate::scene::{
    GBuffer, PaintRange, SampleCounts, Scene, SkipReason, paint_range_of, render_table,
    sample_pixel_in, write_png,
};
use crate::session::{BasisSettings, Session, StartMaterial, ViewSettings};
use crate::solver::Reconstruction;
use crate::table::merl::MerlBrdf;
use crate::worker::{Command, ViewId};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// How long an export waits for the worker to catch up with the paint (a fit of the prior's
/// mean takes well under a second) before it writes the BRDF it has.
const EXPORT_SETTLE_TIMEOUT: Duration = Duration::from_secs(30);

impl Document {
    /// The session as it stands: every view, `brush` (the tool the artist holds) and the
    /// basis settings.
    pub fn to_session(&self, brush: &BrushSettings) -> Session {
        Session {
            views: self.views.iter().map(ViewDoc::to_saved).collect(),
            active_view: self.active,
            brush: brush.clone(),
            basis: self.basis_settings,
            start: self.start_material.clone(),
        }
    }

    /// Replaces every view with those of `session`, and returns its brush. Nothing changes
    /// when it fails.
    pub fn load_session(&mut self, session: Session) -> crate::Result<BrushSettings> {
        let first_id = self.next_view_id;
        let mut docs = Vec::with_capacity(session.views.len());
        for (i, view) in session.views.into_iter().enumerate() {
            docs.push(ViewDoc::from_saved(first_id + i as u32, view)?);
        }
        self.install_views(docs, session.active_view, session.start, session.basis);
        Ok(session.brush)
    }

    /// Replaces every view with `docs` (numbered on from the next view id), and the
    /// starting material and basis settings with those given.
    fn install_views(
        &mut self,
        docs: Vec<ViewDoc>,
        active: usize,
        start: Option<StartMaterial>,
        basis: BasisSettings,
    ) {
        for old in self.views.drain(..) {
            self.worker.send(Command::RemoveView(old.id));
        }
        self.next_view_id += docs.len() as u32;
        for doc in &docs {
            self.worker.send(Command::SetView {
                view: doc.id,
                gbuffer: doc.gbuffer.clone(),
            });
            self.worker.send(Command::MuteView {
                view: doc.id,
                muted: doc.settings.muted,
            });
            self.worker.send(doc.paint_command());
        }
        self.views = docs;
        // The session's own starting material, or none: its canvases already hold the
        // renders of it they were saved with.
        match start {
            Some(start) => {
                self.worker
                    .send(Command::SetStartMaterial(Some(start.table.clone())));
                self.events.push(Event::StartMaterial {
                    name: start.name.clone(),
                    table: start.table.clone(),
                });
                self.start_material = Some(start);
            }
            None => self.clear_start(),
        }
        self.active = active.min(self.views.len().saturating_sub(1));
        if basis != self.basis_settings {
            self.worker.send(Command::SetPolicy(basis.policy));
            self.worker
                .send(Command::SetRegularization(basis.regularization));
            self.basis_settings = basis;
        }
        self.canvas_revision += 1;
    }

    /// Starts over with one unpainted view of the default scene, keeping the basis settings
    /// (the brush is the UI's).
    pub fn new_session(&mut self) -> crate::Result<()> {
        // Installed as it is: a round trip through a saved session would trace it again.
        let settings = ViewSettings::new("View 1", Scene::default());
        let view = ViewDoc::new(self.next_view_id, settings)?;
        self.install_views(vec![view], 0, None, self.basis_settings);
        self.session_path = None;
        self.dirty = false;
        Ok(())
    }

    /// Opens the session file at `path`; returns its brush.
    pub fn open_session(&mut self, path: &Path) -> crate::Result<BrushSettings> {
        let session = Session::open(path)?;
        let brush = self.load_session(session)?;
        self.session_path = Some(path.to_path_buf());
        self.dirty = false;
        self.saved_to(self.session_path.clone());
        self.notify(format!("opened {}", path.display()));
        Ok(brush)
    }

    /// Saves the session, with `brush`, to `path`, which becomes the session's file.
    pub fn save_session(&mut self, path: &Path, brush: &BrushSettings) -> crate::Result<()> {
        self.to_session(brush).save(path)?;
        self.session_path = Some(path.to_path_buf());
        self.dirty = false;
        self.saved_to(self.session_path.clone());
        self.notify(format!("saved {}", path.display()));
        Ok(())
    }

    /// Opens the recovery file offered at start; returns its brush (`None`: nothing was
    /// offered).
    pub fn recover(&mut self) -> crate::Result<Option<BrushSettings>> {
        let Some(info) = self.recovery_offer.take() else {
            return Ok(None);
        };
        let session = match info.open() {
            Ok(session) => session,
            Err(e) => {
                // Keep the offer: the file stays for another try (or a bug report).
                self.recovery_offer = Some(info);
                return Err(e);
            }
        };
        let brush = self.load_session(session)?;
        self.session_path = info.session_path.clone();
        self.touch();
        self.notify(format!(
            "recovered from {}. Undo history is not kept in recovery or session files: \
             undo starts from here.",
            info.path.display()
        ));
        Ok(Some(brush))
    }

    /// Replaces the active view's painting with an image painted elsewhere (PNG or EXR of
    /// the guide's size). Every object pixel of the image becomes paint, unless a mask of
    /// what was painted lies beside it ([`painting_mask_path`], as
    /// [`Self::export_painting`] writes it and `burnish reconstruct --mask` reads it): then
    /// only its non-black pixels do, and the rest stay unpainted.
    pub fn import_painting(&mut self, path: &Path) -> crate::Result<ImportReport> {
        self.import_painting_with(path, &ImportMask::Beside)
    }

    /// [`Self::import_painting`] with the pixels that are paint chosen by `mask`. A painted
    /// object pixel that is NaN, infinite or negative refuses the import (naming the file,
    /// how many and where the first is) and leaves the canvas as it was.
    pub fn import_painting_with(
        &mut self,
        path: &Path,
        mask: &ImportMask,
    ) -> crate::Result<ImportReport> {
        let Some(doc) = self.views.get_mut(self.active) else {
            return Err(crate::Error::invalid(
                path,
                "there is no view to import into",
            ));
        };
        let resolution = doc.gbuffer.resolution();
        let image = crate::scene::read_painting(path, resolution)?;
        let mask_path = match mask {
            ImportMask::Beside => Some(painting_mask_path(path)).filter(|p| p.is_file()),
            ImportMask::Whole => None,
            ImportMask::File(file) => Some(file.clone()),
        };
        let painted: Option<Vec<bool>> = match &mask_path {
            Some(file) => Some(
                crate::scene::read_painting(file, resolution)?
                    .pixels
                    .iter()
                    .map(|p| p.iter().any(|&c| c > 0.0))
                    .collect(),
            ),
            None => None,
        };
        // An 8-bit file's clipped channels say "at least this bright", as `burnish
        // reconstruct` reads the same file.
        let range = paint_range_of(path);
        let report = ImportReport::of(&doc.gbuffer, &image, painted.as_deref(), range, mask_path);
        if report.bad_paint > 0 {
            let first = report.first_bad_pixel.unwrap_or(0);
            return Err(crate::Error::invalid(
                path,
                format!(
                    "{} pixels of the object are NaN, infinite or negative (the first at x = {}, \
                     y = {}); paint them, or leave them out with a mask",
                    report.bad_paint,
                    first % resolution,
                    first / resolution
                ),
            ));
        }
        doc.import_painting(&image, painted.as_deref())?;
        doc.settings.paint_range = range;
        self.worker.send(doc.paint_command());
        self.canvas_revision += 1;
        self.touch();
        let masked = match &report.mask {
            Some(file) => format!(", painted where {} says", file.display()),
            None => String::new(),
        };
        self.notify(match range {
            PaintRange::Ldr => format!(
                "imported {}{masked} (8 bits: a clipped channel says \"at least this bright\")",
                path.display()
            ),
            PaintRange::Hdr => format!("imported {}{masked}", path.display()),
        });
        Ok(report)
    }

    pub fn export_guide(&mut self, path: &Path) -> crate::Result<()> {
        let Some(doc) = self.active_view() else {
            return Ok(());
        };
        write_png(path, &doc.guide)?;
        self.notify(format!("guide written to {}", path.display()));
        Ok(())
    }

    /// Writes the active view's painting as the canvas shows it (EXR: linear, HDR; PNG:
    /// sRGB), and next to it [`painting_mask_path`] saying which pixels were painted, for
    /// `burnish reconstruct --unpainted … --mask`.
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

    /// The current reconstruction (basis and coefficients) for an export to `path`, used
    /// as it is should the worker not settle within [`EXPORT_SETTLE_TIMEOUT`]; the
    /// full table is made on the export's thread.
    fn current_reconstruction(&self, path: &Path) -> crate::Result<Reconstruction> {
        self.snapshot.reconstruction().ok_or_else(|| {
            crate::Error::invalid(
                path,
                "the basis is not ready yet; export when the status bar says it is",
            )
        })
    }

    /// Writes the BRDF to `path` on a thread of its own (making the full table and writing
    /// a `.bsdf` or fitting an analytic material take seconds); the notice names the file
    /// and says what it holds (for the analytic formats, the fit's error).
    pub fn export_brdf(&mut self, path: &Path, format: ExportKind) -> crate::Result<()> {
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
        // The worker may still be fitting the prior's mean to the last strokes: the file
        // holds the BRDF once it caught up, as `burnish reconstruct` computes it.
        let settled = self.worker.sync_later();
        let target = path.to_path_buf();
        let label = format!("exporting {}…", file_name(path));
        self.file_jobs
            .spawn(label, JobKind::Export, target.clone(), move || {
                let reconstruction = settled
                    .wait(EXPORT_SETTLE_TIMEOUT)
                    .and_then(|snapshot| snapshot.reconstruction())
                    .unwrap_or(reconstruction);
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
    /// own; [`Self::poll`] puts it in place when it is done.
    pub fn start_from(&mut self, path: &Path) -> crate::Result<()> {
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

    /// Makes `start` the material the painting edits at once: [`Self::start_from`] for a
    /// caller that read the file itself (the command line reads it before any slow work).
    pub fn set_start_material(&mut self, start: StartMaterial) -> crate::Result<()> {
        self.set_start(start, Vec::new())
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

    /// What the file jobs under way are doing, oldest first (e.g. "exporting out.bsdf…").
    pub fn file_job_labels(&self) -> impl Iterator<Item = &str> {
        self.file_jobs.labels()
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
            self.worker.send(doc.paint_command());
        }
        self.canvas_revision += 1;
        self.touch();
        let name = start.name.clone();
        self.events.push(Event::StartMaterial {
            name: name.clone(),
            table: start.table.clone(),
        });
        self.start_material = Some(start);
        self.notify(format!("painting from {name}"));
        result
    }

    /// Back to the database's mean material as the prior mean.
    pub fn clear_start(&mut self) {
        if self.start_material.take().is_some() {
            self.worker.send(Command::SetStartMaterial(None));
        }
    }
}

/// Which pixels of an imported painting are paint.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum ImportMask {
    /// Those the mask beside the painting ([`painting_mask_path`]) marks, where there is
    /// one; otherwise every object pixel (the app's import).
    #[default]
    Beside,
    /// Every object pixel.
    Whole,
    /// The non-black pixels of this image (PNG or EXR of the painting's size).
    File(PathBuf),
}

/// What an imported painting holds, pixel by pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportReport {
    /// Every pixel by what it gives, judged by geometry first: background, shadow and
    /// grazing pixels whatever the mask says; then, of the painted ones, samples (`used`).
    /// Usable pixels the mask leaves unpainted are counted in [`Self::unpainted`] only.
    pub counts: SampleCounts,
    /// Usable pixels the mask leaves unpainted.
    pub unpainted: usize,
    /// Samples with a clipped channel, read as "at least this bright" (8-bit files).
    pub clipped: usize,
    /// Painted object pixels that are NaN, infinite or negative (the import refuses them),
    /// and the first of them.
    pub bad_paint: usize,
    pub first_bad_pixel: Option<usize>,
    /// What the values can express, by the file's kind.
    pub range: PaintRange,
    /// The mask that chose the painted pixels, if one did.
    pub mask: Option<PathBuf>,
}

impl ImportReport {
    fn of(
        gbuffer: &GBuffer,
        image: &RgbImage,
        painted: Option<&[bool]>,
        range: PaintRange,
        mask: Option<PathBuf>,
    ) -> Self {
        let mut report = Self {
            counts: SampleCounts::default(),
            unpainted: 0,
            clipped: 0,
            bad_paint: 0,
            first_bad_pixel: None,
            range,
            mask,
        };
        for (i, &colour) in image.pixels.iter().enumerate() {
            let is_painted = painted.is_none_or(|p| p[i]);
            if is_painted
                && gbuffer.at(i).is_some()
                && colour.iter().any(|c| !c.is_finite() || *c < 0.0)
            {
                report.bad_paint += 1;
                report.first_bad_pixel.get_or_insert(i);
            }
            let outcome = sample_pixel_in(gbuffer, i, colour, range);
            let geometry_skip = matches!(
                outcome,
                Err(SkipReason::Background | SkipReason::Shadow | SkipReason::Grazing)
            );
            if !geometry_skip && !is_painted {
                report.unpainted += 1;
                continue;
            }
            if let Ok(sample) = &outcome
                && sample.bounds != crate::solver::EXACT
            {
                report.clipped += 1;
            }
            report.counts.add(&outcome);
        }
        report
    }
}

/// Which writer an export uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportKind {
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

/// Where [`Document::export_painting`] writes the mask of painted pixels for a painting at
/// `painting`: `NAME-mask.png` beside it (white: painted).
pub fn painting_mask_path(painting: &Path) -> PathBuf {
    let stem = painting
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    painting.with_file_name(format!("{stem}-mask.png"))
}
