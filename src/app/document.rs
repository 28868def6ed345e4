//! The views of a session as the app holds them: scene, geometry, guide and canvas.

use crate::paint::{Canvas, PaintLayers};
use crate::scene::{GBuffer, Object, Scene, guide_image};
use crate::worker::ViewId;
use std::sync::Arc;

/// One view: a scene (object, light, camera), its geometry buffer and its canvas.
pub struct ViewDoc {
    pub id: ViewId,
    pub name: String,
    pub scene: Scene,
    pub object: Arc<Object>,
    pub gbuffer: Arc<GBuffer>,
    pub canvas: Canvas,
    pub muted: bool,
}

impl ViewDoc {
    /// A new, unpainted view of `scene`.
    pub fn new(id: ViewId, name: String, scene: Scene) -> crate::Result<Self> {
        let object = Arc::new(Object::load(&scene.object_source())?);
        let gbuffer = Arc::new(GBuffer::build(&scene, &object));
        let guide = guide_image(&gbuffer);
        let mask = object_mask(&gbuffer);
        Ok(Self {
            id,
            name,
            scene,
            object,
            gbuffer,
            canvas: Canvas::new(guide, mask),
            muted: false,
        })
    }

    /// A view with saved paint (session open, recovery).
    pub fn with_paint(
        id: ViewId,
        name: String,
        scene: Scene,
        layers: PaintLayers,
        muted: bool,
    ) -> crate::Result<Self> {
        let mut doc = Self::new(id, name, scene)?;
        let guide = doc.canvas.guide().clone();
        doc.canvas = Canvas::from_layers(guide, object_mask(&doc.gbuffer), layers)
            .map_err(|e| paint_error(&doc.name, e))?;
        doc.muted = muted;
        Ok(doc)
    }

    /// Applies a new scene. The geometry and guide are rebuilt; painted pixels keep their
    /// colour (they now stand for the new light and view), unpainted ones show the new guide.
    /// Undo history starts over, since old strokes refer to the old guide.
    pub fn set_scene(&mut self, scene: Scene) -> crate::Result<()> {
        let object = if scene.object_source() == self.scene.object_source() {
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
        self.canvas =
            Canvas::from_layers(guide, mask, layers).map_err(|e| paint_error(&self.name, e))?;
        self.scene = scene;
        self.object = object;
        self.gbuffer = gbuffer;
        Ok(())
    }

    /// Replaces the painting with an image painted elsewhere: every object pixel becomes
    /// paint of the image's colour, as one edit that Ctrl+Z takes back.
    pub fn import_painting(&mut self, image: &crate::image_io::RgbImage) -> crate::Result<()> {
        let guide = self.canvas.guide().clone();
        let mask = object_mask(&self.gbuffer);
        let mut layers = PaintLayers::unpainted(&guide);
        for (i, &inside) in mask.iter().enumerate() {
            if inside {
                layers.colour.pixels[i] = image.pixels[i];
                layers.coverage[i] = 1.0;
            }
        }
        self.canvas
            .replace_layers(layers)
            .map_err(|e| paint_error(&self.name, e))?;
        // The caller hands the worker the whole painting at once; undo still sees the edit.
        drop(self.canvas.take_changes());
        Ok(())
    }

    /// Every painted pixel and its colour, for the worker.
    pub fn painted_pixels(&self) -> Vec<(u32, [f32; 3])> {
        let layers = self.canvas.layers();
        layers
            .coverage
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0.0)
            .map(|(i, _)| (i as u32, layers.colour.pixels[i]))
            .collect()
    }
}

/// Which pixels show the object (the only ones paint may touch).
pub fn object_mask(gbuffer: &GBuffer) -> Vec<bool> {
    gbuffer.pixels().iter().map(Option::is_some).collect()
}

fn paint_error(view: &str, e: crate::paint::CanvasError) -> crate::Error {
    crate::Error::invalid(std::path::Path::new(view), format!("painting: {e}"))
}
