//! The views of a session: scene, geometry, guide and canvas.

use crate::image_io::RgbImage;
use crate::paint::{Canvas, PaintLayers, UnpaintedPixels};
use crate::scene::{GBuffer, Object, PaintRange, Scene, guide_image};
use crate::session::{SessionView, ViewSettings};
use crate::worker::{Command, ViewId};
use std::sync::Arc;

/// What a view's canvas shows under the paint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Base {
    /// The grey diffuse guide.
    Guide,
    /// The BRDF as it was reconstructed when the prediction was made, rendered for this view.
    Prediction,
}

/// One view: its settings (name, scene, mute flag, unpainted rule, as sessions save them),
/// the object and geometry buffer its scene makes, and its canvas. The document changes it
/// (so that the worker hears of every change); others read it.
pub struct ViewDoc {
    pub(super) id: ViewId,
    pub(super) settings: ViewSettings,
    pub(super) object: Arc<Object>,
    pub(super) gbuffer: Arc<GBuffer>,
    /// The scene's grey diffuse guide: a fresh canvas's base, and the reference layer.
    pub(super) guide: RgbImage,
    pub(super) canvas: Canvas,
    base: Base,
}

impl ViewDoc {
    /// A new, unpainted view of its settings' scene over its guide.
    pub fn new(id: ViewId, settings: ViewSettings) -> crate::Result<Self> {
        let object = Arc::new(Object::load(&settings.scene.object_source())?);
        let gbuffer = Arc::new(GBuffer::build(&settings.scene, &object));
        let guide = guide_image(&gbuffer);
        let mask = object_mask(&gbuffer);
        Ok(Self {
            id,
            settings,
            object,
            gbuffer,
            canvas: Canvas::new(guide.clone(), mask),
            guide,
            base: Base::Guide,
        })
    }

    /// A view opened from a session (a file, or recovery): its settings move in, and its
    /// paint goes over its guide, or over its saved prediction.
    pub fn from_saved(id: ViewId, saved: SessionView) -> crate::Result<Self> {
        let SessionView {
            settings,
            paint,
            base: prediction,
        } = saved;
        let mut doc = Self::new(id, settings)?;
        doc.base = if prediction.is_some() {
            Base::Prediction
        } else {
            Base::Guide
        };
        let base = prediction.unwrap_or_else(|| doc.guide.clone());
        doc.canvas = Canvas::from_layers(base, object_mask(&doc.gbuffer), paint)
            .map_err(|e| paint_error(&doc.settings.name, e))?;
        Ok(doc)
    }

    /// The view as a session file holds it: its settings, its paint and the prediction
    /// under it, if any.
    pub fn to_saved(&self) -> SessionView {
        SessionView {
            settings: self.settings.clone(),
            paint: self.canvas.layers().clone(),
            base: self.prediction().cloned(),
        }
    }

    pub fn id(&self) -> ViewId {
        self.id
    }

    pub fn name(&self) -> &str {
        &self.settings.name
    }

    pub fn scene(&self) -> &Scene {
        &self.settings.scene
    }

    pub fn object(&self) -> &Arc<Object> {
        &self.object
    }

    pub fn gbuffer(&self) -> &Arc<GBuffer> {
        &self.gbuffer
    }

    /// The scene's grey diffuse guide: a fresh canvas's base, and the reference layer.
    pub fn guide(&self) -> &RgbImage {
        &self.guide
    }

    /// The canvas; the document's operations paint on it (see
    /// [`super::Document::active_canvas_mut`]).
    pub fn canvas(&self) -> &Canvas {
        &self.canvas
    }

    /// A muted view keeps its paint but gives no samples.
    pub fn muted(&self) -> bool {
        self.settings.muted
    }

    /// What the pixels the artist did not paint say.
    pub fn unpainted(&self) -> UnpaintedPixels {
        self.settings.unpainted
    }

    /// What the paint's values can express (`Ldr` after an 8-bit import).
    pub fn paint_range(&self) -> PaintRange {
        self.settings.paint_range
    }

    /// What the canvas shows under the paint.
    pub fn base(&self) -> Base {
        self.base
    }

    /// The prediction under the paint, if the canvas shows one (for session files).
    pub fn prediction(&self) -> Option<&RgbImage> {
        (self.base == Base::Prediction).then(|| self.canvas.base())
    }

    /// Puts a render of the current BRDF for this view under the paint.
    pub fn set_prediction(&mut self, image: RgbImage) -> crate::Result<()> {
        self.canvas
            .set_base(image)
            .map_err(|e| paint_error(&self.settings.name, e))?;
        self.base = Base::Prediction;
        Ok(())
    }

    /// Puts the guide back under the paint.
    pub fn set_guide_base(&mut self) {
        if self.base != Base::Guide {
            self.canvas
                .set_base(self.guide.clone())
                .expect("the guide fits its own canvas");
            self.base = Base::Guide;
        }
    }

    /// Applies a new scene. The geometry and guide are rebuilt; painted pixels keep their
    /// colour (they now stand for the new light and view), unpainted ones show the new guide
    /// (a prediction was made for the old scene: the caller may ask for a new one).
    /// Undo history starts over, since old strokes refer to the old base.
    pub fn set_scene(&mut self, scene: Scene) -> crate::Result<()> {
        let object = if scene.object_source() == self.settings.scene.object_source() {
            self.object.clone()
        } else {
            Arc::new(Object::load(&scene.object_source())?)
        };
        let gbuffer = Arc::new(GBuffer::build(&scene, &object));
        let guide = guide_image(&gbuffer);
        let mask = object_mask(&gbuffer);
        let old = self.canvas.layers();
        let layers = if old.colour.width == guide.width && old.colour.height == guide.height {
            let mut layers = PaintLayers::unpainted(&guide);
            for (i, &coverage) in old.coverage.iter().enumerate() {
                if coverage > 0.0 && mask[i] {
                    layers.colour.pixels[i] = old.colour.pixels[i];
                    layers.coverage[i] = coverage;
                }
            }
            layers
        } else {
            PaintLayers::unpainted(&guide)
        };
        self.canvas = Canvas::from_layers(guide.clone(), mask, layers)
            .map_err(|e| paint_error(&self.settings.name, e))?;
        self.guide = guide;
        self.base = Base::Guide;
        self.settings.scene = scene;
        self.object = object;
        self.gbuffer = gbuffer;
        Ok(())
    }

    /// Replaces the painting with an image painted elsewhere, as one edit that Ctrl+Z takes
    /// back: every object pixel becomes paint of the image's colour, or, with `painted`
    /// (one flag per pixel), those it marks; the others stay unpainted over the base.
    pub fn import_painting(
        &mut self,
        image: &RgbImage,
        painted: Option<&[bool]>,
    ) -> crate::Result<()> {
        let mask = object_mask(&self.gbuffer);
        let mut layers = PaintLayers::unpainted(self.canvas.base());
        for (i, &inside) in mask.iter().enumerate() {
            if inside && painted.is_none_or(|p| p[i]) {
                layers.colour.pixels[i] = image.pixels[i];
                layers.coverage[i] = 1.0;
            }
        }
        self.canvas
            .replace_layers(layers)
            .map_err(|e| paint_error(&self.settings.name, e))?;
        // The caller hands the worker the whole painting at once; undo still sees the edit.
        drop(self.canvas.take_changes());
        Ok(())
    }

    /// Every pixel that gives a sample under the view's rule, with the colour it shows, for
    /// the worker.
    pub fn counted_pixels(&self) -> Vec<(u32, [f32; 3])> {
        self.canvas
            .layers()
            .counted_pixels(self.settings.unpainted, self.canvas.object_mask())
    }

    /// The command that hands the worker everything this view states at once: its counted
    /// pixels and the range their values are read in.
    pub(super) fn paint_command(&self) -> Command {
        Command::ReplacePaint {
            view: self.id,
            painted: self.counted_pixels(),
            range: self.settings.paint_range,
        }
    }

    /// What pixel `pixel` says after a change whose painted state is `painted` (`None`:
    /// unpainted): its paint, or under "count as shown" the base it shows.
    pub fn statement(&self, pixel: u32, painted: Option<[f32; 3]>) -> Option<[f32; 3]> {
        let i = pixel as usize;
        painted.or_else(|| {
            self.settings
                .unpainted
                .counts(self.canvas.object_mask()[i], false)
                .then(|| self.canvas.base().pixels[i])
        })
    }
}

/// Which pixels show the object (the only ones paint may touch).
pub fn object_mask(gbuffer: &GBuffer) -> Vec<bool> {
    gbuffer.pixels().iter().map(Option::is_some).collect()
}

fn paint_error(view: &str, e: crate::paint::CanvasError) -> crate::Error {
    crate::Error::invalid(std::path::Path::new(view), format!("painting: {e}"))
}

/// Light–view angles a proposed view may have: narrower shows little new, wider leaves most
/// of the object in shadow.
const PROPOSED_ANGLE_DEG: std::ops::RangeInclusive<f64> = 20.0..=100.0;

/// The angle between the light and the camera of `scene`, in degrees.
fn light_view_angle_deg(scene: &Scene) -> f64 {
    let toward_camera = crate::scene::CameraRig::new(scene).toward_camera;
    let light = crate::scene::light_direction(&scene.light);
    light
        .dot(toward_camera)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// A view to add after `existing` (at least one): among the next-view candidates around
/// `base`, the one whose light–view angle is farthest from every existing view's, so the new
/// canvas reaches other bins instead of repeating view 1's.
pub fn propose_view(base: &Scene, existing: &[Scene]) -> Scene {
    let angles: Vec<f64> = existing.iter().map(light_view_angle_deg).collect();
    crate::next_view::candidate_scenes(base, 48)
        .into_iter()
        .map(|scene| {
            let angle = light_view_angle_deg(&scene);
            let distance = angles
                .iter()
                .map(|a| (a - angle).abs())
                .fold(f64::INFINITY, f64::min);
            (scene, angle, distance)
        })
        .filter(|(_, angle, _)| PROPOSED_ANGLE_DEG.contains(angle))
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map_or_else(|| base.clone(), |(scene, _, _)| scene)
}
