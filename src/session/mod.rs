//! Session files: every view's scene and painting, the brush and the basis settings, in one
//! `.burnish` file; autosave and crash recovery.
//!
//! A session file is a zip archive (see [`file`] for its entries). Saving is atomic and
//! opening validates everything before anything is returned, so a bad file never half-opens.

mod autosave;
mod file;

pub use autosave::{
    AUTOSAVE_DELAY, AUTOSAVE_MIN_GAP, AUTOSAVE_RETRY, Autosaver, RecoveryInfo, pending_recovery,
    pending_recovery_at, recovery_path,
};
pub use file::{EXTENSION, FORMAT_VERSION, decode_paint_layers, object_cache_dir};

use crate::basis::BasisSpec;
use crate::error::Result;
use crate::materials::database::DatabaseSpec;
use crate::paint::{BrushSettings, PaintLayers, UnpaintedPixels};
use crate::scene::{GBuffer, Object, PaintRange, Scene, guide_image};
use crate::solver::{Policy, Regularization};

/// Everything the artist made: the views with their paintings, the brush and the basis.
#[derive(Clone, Debug, PartialEq)]
pub struct Session {
    /// At least one view.
    pub views: Vec<SessionView>,
    /// Index into `views` of the view being painted.
    pub active_view: usize,
    pub brush: BrushSettings,
    pub basis: BasisSettings,
    /// The material the painting starts from (its projection onto the basis is the prior
    /// mean), if any.
    pub start: Option<StartMaterial>,
}

/// A material the painting starts from, kept whole (every pair of the table) rather than as
/// coefficients: a session may be reopened with another basis (other K, other database),
/// and each basis needs its own projection of the material.
#[derive(Clone, PartialEq)]
pub struct StartMaterial {
    /// What the app calls it (the file name it was opened from).
    pub name: String,
    /// The file it was opened from, for the record; the session does not need it again.
    pub source: Option<std::path::PathBuf>,
    pub table: std::sync::Arc<crate::table::SymTable>,
}

impl std::fmt::Debug for StartMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StartMaterial")
            .field("name", &self.name)
            .field("source", &self.source)
            .finish_non_exhaustive()
    }
}

/// What a view is, apart from its painting: its name, scene, mute flag and unpainted rule.
/// The live document's view holds this very value, so that saving copies it whole and
/// opening moves it in, rather than each side keeping fields of its own.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSettings {
    pub name: String,
    pub scene: Scene,
    /// A muted view keeps its painting but gives no samples.
    pub muted: bool,
    /// What the pixels the artist did not paint say.
    pub unpainted: UnpaintedPixels,
    /// What the paint's values can express: `Ldr` once an 8-bit painting was imported, whose
    /// clipped channels say only "at least this bright" (as `burnish reconstruct` reads the
    /// same file).
    pub paint_range: PaintRange,
}

impl ViewSettings {
    /// An unmuted view of `scene` under the default unpainted rule.
    pub fn new(name: impl Into<String>, scene: Scene) -> Self {
        Self {
            name: name.into(),
            scene,
            muted: false,
            unpainted: UnpaintedPixels::default(),
            paint_range: PaintRange::Hdr,
        }
    }
}

/// One view as a session file holds it: its settings and the painting over its guide (in
/// the live document the canvas holds the painting, with its undo history).
#[derive(Clone, Debug, PartialEq)]
pub struct SessionView {
    pub settings: ViewSettings,
    /// `scene.resolution²` pixels.
    pub paint: PaintLayers,
    /// What the canvas shows under the paint when it is a prediction of the BRDF (`None`:
    /// the scene's guide), `scene.resolution²` pixels.
    pub base: Option<crate::image_io::RgbImage>,
}

/// How the painting becomes a table: which basis, and how the solver treats the samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BasisSettings {
    /// K, the basis components kept (1 to [`BasisSpec::MAX_COMPONENTS`]).
    pub components: usize,
    /// Materials in the database the basis is built from.
    pub materials: usize,
    pub regularization: Regularization,
    /// How several samples in one bin are combined.
    pub policy: Policy,
}

impl Default for BasisSettings {
    fn default() -> Self {
        Self {
            components: BasisSpec::DEFAULT_COMPONENTS,
            materials: DatabaseSpec::default().size,
            regularization: Regularization::Auto,
            policy: Policy::Mean,
        }
    }
}

impl SessionView {
    /// A view of `scene` with nothing painted yet: its layer is the scene's guide image.
    /// Loads the scene's object and traces its geometry buffer.
    pub fn new(name: impl Into<String>, scene: Scene) -> Result<Self> {
        let object = Object::load(&scene.object_source())?;
        let guide = guide_image(&GBuffer::build(&scene, &object));
        Ok(Self {
            settings: ViewSettings::new(name, scene),
            paint: PaintLayers::unpainted(&guide),
            base: None,
        })
    }
}

impl Default for Session {
    /// One unpainted view of the default scene (the built-in sphere).
    fn default() -> Self {
        let view = SessionView::new("View 1", Scene::default())
            .expect("the default scene's built-in sphere needs no file");
        Self {
            views: vec![view],
            active_view: 0,
            brush: BrushSettings::default(),
            basis: BasisSettings::default(),
            start: None,
        }
    }
}

impl Session {
    /// Every value in range, as a sentence naming what is wrong when not. [`Session::save`]
    /// refuses a session that fails this; [`Session::open`] refuses a file that would.
    pub fn check(&self) -> std::result::Result<(), String> {
        if self.views.is_empty() {
            return Err("a session needs at least one view".into());
        }
        if self.active_view >= self.views.len() {
            return Err(format!(
                "active_view = {} but there are only {} views",
                self.active_view,
                self.views.len()
            ));
        }
        check_brush(&self.brush).map_err(|p| format!("brush: {p}"))?;
        check_basis(&self.basis).map_err(|p| format!("basis: {p}"))?;
        for (i, view) in self.views.iter().enumerate() {
            view.check()
                .map_err(|p| format!("view {} ({:?}): {p}", i + 1, view.settings.name))?;
        }
        if let Some(start) = &self.start
            && !start.table.is_physical()
        {
            return Err(format!(
                "start material {:?}: the table has values that are negative or not finite",
                start.name
            ));
        }
        Ok(())
    }
}

impl SessionView {
    /// The scene in range and the painting the scene's size, finite, coverage in [0, 1].
    pub fn check(&self) -> std::result::Result<(), String> {
        self.settings.scene.check()?;
        let side = self.settings.scene.resolution as usize;
        check_colour(&self.paint.colour, side)?;
        if let Some(base) = &self.base {
            check_colour(base, side).map_err(|p| format!("the prediction under the paint: {p}"))?;
        }
        check_coverage(&self.paint.coverage, side)
    }
}

pub(crate) fn check_colour(
    colour: &crate::image_io::RgbImage,
    side: usize,
) -> std::result::Result<(), String> {
    if colour.width != side || colour.height != side {
        return Err(format!(
            "the colour layer is {} × {} pixels but the scene's resolution is {side}",
            colour.width, colour.height
        ));
    }
    if colour.pixels.len() != side * side {
        return Err(format!(
            "the colour layer has {} pixels, not {side} × {side}",
            colour.pixels.len()
        ));
    }
    if let Some(i) = colour
        .pixels
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite()))
    {
        return Err(format!(
            "the colour layer's pixel ({}, {}) is {:?}: colours must be finite",
            i % side,
            i / side,
            colour.pixels[i]
        ));
    }
    Ok(())
}

pub(crate) fn check_coverage(coverage: &[f32], side: usize) -> std::result::Result<(), String> {
    if coverage.len() != side * side {
        return Err(format!(
            "the coverage layer has {} pixels but the scene's resolution is {side} ({} pixels)",
            coverage.len(),
            side * side
        ));
    }
    if let Some(i) = coverage.iter().position(|c| !(0.0..=1.0).contains(c)) {
        return Err(format!(
            "the coverage layer's pixel ({}, {}) is {}: coverage must be in [0, 1]",
            i % side,
            i / side,
            coverage[i]
        ));
    }
    Ok(())
}

fn check_brush(brush: &BrushSettings) -> std::result::Result<(), String> {
    if !(brush.size.is_finite() && brush.size > 0.0) {
        return Err(format!("size = {} must be a positive number", brush.size));
    }
    for (name, value) in [
        ("hardness", brush.hardness),
        ("opacity", brush.opacity),
        ("flow", brush.flow),
    ] {
        if !(0.0..=1.0).contains(&value) {
            return Err(format!("{name} = {value} must be in [0, 1]"));
        }
    }
    if !(brush.spacing.is_finite() && brush.spacing > 0.0) {
        return Err(format!(
            "spacing = {} must be a positive number",
            brush.spacing
        ));
    }
    if brush.colour.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
        return Err(format!(
            "colour = {:?} must be finite and not negative",
            brush.colour
        ));
    }
    Ok(())
}

fn check_basis(basis: &BasisSettings) -> std::result::Result<(), String> {
    if !(1..=BasisSpec::MAX_COMPONENTS).contains(&basis.components) {
        return Err(format!(
            "components = {} must be 1 to {}",
            basis.components,
            BasisSpec::MAX_COMPONENTS
        ));
    }
    if basis.materials == 0 {
        return Err("materials = 0: the database needs at least one material".into());
    }
    match basis.regularization {
        Regularization::Prior { alpha: x } | Regularization::Ridge { lambda: x }
            if !(x.is_finite() && x > 0.0) =>
        {
            Err(format!(
                "regularization = {} must have a positive finite weight",
                basis.regularization
            ))
        }
        _ => Ok(()),
    }
}
