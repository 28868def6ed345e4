//! The canvas: an HDR paint layer over a view's base image (the guide, or a prediction of the
//! current BRDF), the brush tools that change it,
//! the changed pixels it reports and whole-stroke undo.
//!
//! Coordinates are canvas pixels, x to the right and y down; pixel (i, j) covers
//! [i, i+1) × [j, j+1), so its centre is (i + 0.5, j + 0.5).
//!
//! The canvas's state and its paint layers are here; the strokes (`strokes`), the tools
//! that lay each dab or change the whole painting (`tools`), and the change batches and
//! undo history (`undo`) have their files.

mod strokes;
mod tools;
mod undo;

use super::changes::PixelRect;
use super::dab::TipMask;
use super::history::{History, TileData, TileGrid};
use super::layers::PaintLayers;
use super::settings::BrushSettings;
use crate::image_io::RgbImage;
use std::sync::Arc;

/// Coverage below this counts as none: the eraser, smudge and blur then give the pixel back
/// to the base, bit for bit, instead of leaving an invisible trace that would still be a
/// BRDF sample.
pub const MIN_COVERAGE: f32 = 1.0 / 1024.0;
/// The default memory bound of the undo history (undo and redo together).
pub const DEFAULT_UNDO_BUDGET: usize = 256 << 20;
/// Dabs per second an airbrush lays while the pointer rests (see [`Canvas::airbrush_tick`]).
pub const AIRBRUSH_RATE: f32 = 10.0;
/// Marks a tile with no slot in a per-tile index.
const NO_SLOT: u32 = u32::MAX;

/// Why paint layers do not fit a canvas.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CanvasError {
    #[error("{what} has {found} pixels; the base image has {expected}")]
    SizeMismatch {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("the base image is {width}×{height}; a canvas must be square")]
    NotSquare { width: usize, height: usize },
    #[error("pixel {pixel}: {problem}")]
    BadPixel { pixel: usize, problem: String },
}

/// The paint layer of one view and its brush engine. See the module docs for coordinates.
///
/// Painting model: `layers().colour` is what the artist sees (linear RGB, may exceed 1) and
/// `layers().coverage` how much paint is there; painted pixels (coverage > 0) are the BRDF
/// samples (with all object pixels, under
/// [`UnpaintedPixels::CountAsShown`](super::UnpaintedPixels)), unpainted ones hold the
/// base's colour exactly. Nothing outside the object mask
/// is ever painted.
///
/// Edits leave their changes in a batch that [`take_changes`](Self::take_changes) drains;
/// [`undo`](Self::undo) and [`redo`](Self::redo) drain it themselves.
#[derive(Clone)]
pub struct Canvas {
    /// What unpainted pixels show: the guide, or a prediction of the current BRDF.
    base: RgbImage,
    object: Vec<bool>,
    layers: PaintLayers,
    grid: TileGrid,
    history: History,
    batch: Batch,
    stroke: Option<Stroke>,
    tip: Option<Arc<TipMask>>,
    last_stroke_dabs: usize,
}

/// Snapshots of the tiles the current batch of changes touched, from before it touched them.
#[derive(Clone)]
struct Batch {
    slot: Vec<u32>,
    tiles: Vec<BatchTile>,
}

#[derive(Clone)]
struct BatchTile {
    before: TileData,
    /// The part of the tile that may have changed.
    touched: PixelRect,
}

/// An edit in progress: the tiles it touched as they were before it (its future undo step),
/// and for strokes the per-stroke coverage buffer of each tile.
#[derive(Clone)]
struct Edit {
    slot: Vec<u32>,
    before: Vec<TileData>,
    accumulated: Vec<Vec<f32>>,
}

#[derive(Clone)]
struct Stroke {
    settings: BrushSettings,
    tip: Option<Arc<TipMask>>,
    edit: Edit,
    /// Where the pointer last was, and its pressure.
    last: (f32, f32, f32),
    /// Path length still to go before the next dab.
    to_next: f32,
    dabs: usize,
    /// The smudge brush's load; `None` until its first dab picks it up.
    pickup: Option<Pickup>,
}

#[derive(Clone, Copy, Debug)]
struct Pickup {
    colour: [f64; 3],
    coverage: f64,
}

impl Canvas {
    /// An unpainted canvas over `base` (linear RGB: `scene::guide_image`, or a render of a BRDF);
    /// `object_mask[i]` is true where the object covers pixel i (`GBuffer::at(i).is_some()`).
    ///
    /// # Panics
    /// If the base is not square or the mask's length is not the base's pixel count; both
    /// come from the same geometry buffer, so a mismatch is a programming error.
    pub fn new(base: RgbImage, object_mask: Vec<bool>) -> Self {
        assert_eq!(base.width, base.height, "the base image must be square");
        assert_eq!(
            object_mask.len(),
            base.pixels.len(),
            "the object mask must have one entry per base pixel"
        );
        let layers = PaintLayers::unpainted(&base);
        let grid = TileGrid::new(base.width, base.height);
        Self {
            batch: Batch {
                slot: vec![NO_SLOT; grid.count()],
                tiles: Vec::new(),
            },
            base,
            object: object_mask,
            layers,
            grid,
            history: History::new(DEFAULT_UNDO_BUDGET),
            stroke: None,
            tip: None,
            last_stroke_dabs: 0,
        }
    }

    /// A canvas holding saved paint. Sizes must match the base, colours must be finite and
    /// non-negative and coverage in [0, 1]. Paint off the object is dropped and unpainted
    /// pixels are given the base's colour, so the canvas's invariants hold.
    pub fn from_layers(
        base: RgbImage,
        object_mask: Vec<bool>,
        layers: PaintLayers,
    ) -> Result<Self, CanvasError> {
        if base.width != base.height {
            return Err(CanvasError::NotSquare {
                width: base.width,
                height: base.height,
            });
        }
        check_layers(&base, object_mask.len(), &layers)?;
        let mut canvas = Self::new(base, object_mask);
        canvas.layers = layers;
        canvas.unpaint_where_uncovered();
        Ok(canvas)
    }

    /// Replaces the whole painting with `layers` (an imported image, say) as one edit that
    /// undo takes back; the same checks as [`from_layers`](Self::from_layers). The changed
    /// pixels come out of [`take_changes`](Self::take_changes) like any edit's.
    pub fn replace_layers(&mut self, mut layers: PaintLayers) -> Result<(), CanvasError> {
        check_layers(&self.base, self.object.len(), &layers)?;
        self.end_stroke();
        std::mem::swap(&mut self.layers, &mut layers);
        self.unpaint_where_uncovered();
        let incoming = std::mem::replace(&mut self.layers, layers);
        let mut edit = Edit::new(self.grid.count());
        let width = self.resolution();
        for tile in 0..self.grid.count() {
            let rect = self.grid.rect(tile);
            self.touch(&mut edit, tile, rect);
            for y in rect.y0 as usize..rect.y1 as usize {
                let row = y * width + rect.x0 as usize..y * width + rect.x1 as usize;
                self.layers.colour.pixels[row.clone()]
                    .copy_from_slice(&incoming.colour.pixels[row.clone()]);
                self.layers.coverage[row.clone()].copy_from_slice(&incoming.coverage[row]);
            }
        }
        self.commit(edit);
        Ok(())
    }

    /// Shows the base, with no coverage, wherever nothing is painted or there is no object.
    fn unpaint_where_uncovered(&mut self) {
        for i in 0..self.base.pixels.len() {
            if !self.object[i] || self.layers.coverage[i] == 0.0 {
                self.layers.colour.pixels[i] = self.base.pixels[i];
                self.layers.coverage[i] = 0.0;
            }
        }
    }

    pub fn layers(&self) -> &PaintLayers {
        &self.layers
    }

    /// What unpainted pixels show (and the eraser brings back).
    pub fn base(&self) -> &RgbImage {
        &self.base
    }

    /// Puts `base` under the paint: unpainted pixels show it from now on, painted ones keep
    /// their colour. Not an undo step (the paint is unchanged); strokes made before still
    /// undo and redo exactly, their unpainted pixels showing the base of the moment. Ends a
    /// stroke in progress first. The changed pixels are not reported by
    /// [`take_changes`](Self::take_changes): the caller resends what the view shows.
    pub fn set_base(&mut self, base: RgbImage) -> Result<(), CanvasError> {
        if base.width != self.base.width || base.height != self.base.height {
            return Err(CanvasError::SizeMismatch {
                what: "the new base image",
                expected: self.base.pixels.len(),
                found: base.pixels.len(),
            });
        }
        if let Some(pixel) = base
            .pixels
            .iter()
            .position(|c| !c.iter().all(|x| x.is_finite() && *x >= 0.0))
        {
            let problem = format!(
                "colour {:?} is not a finite non-negative colour",
                base.pixels[pixel]
            );
            return Err(CanvasError::BadPixel { pixel, problem });
        }
        self.end_stroke();
        self.base = base;
        self.unpaint_where_uncovered();
        Ok(())
    }

    pub fn object_mask(&self) -> &[bool] {
        &self.object
    }

    /// Pixels along each side.
    pub fn resolution(&self) -> usize {
        self.base.width
    }

    /// The tip image round brushes use instead of their round shape, from the next stroke on
    /// (a preset's tip); `None` for round dabs.
    pub fn set_tip(&mut self, tip: Option<Arc<TipMask>>) {
        self.tip = tip;
    }

    pub fn tip(&self) -> Option<&Arc<TipMask>> {
        self.tip.as_ref()
    }
}

/// Checks that `layers` fit a canvas with this base and a mask of `mask_len` pixels and hold
/// only finite, non-negative colour and coverage within [0, 1].
fn check_layers(base: &RgbImage, mask_len: usize, layers: &PaintLayers) -> Result<(), CanvasError> {
    let expected = base.pixels.len();
    let sizes = [
        ("the object mask", mask_len),
        ("the paint colour", layers.colour.pixels.len()),
        ("the paint coverage", layers.coverage.len()),
    ];
    for (what, found) in sizes {
        if found != expected {
            return Err(CanvasError::SizeMismatch {
                what,
                expected,
                found,
            });
        }
    }
    if (layers.colour.width, layers.colour.height) != (base.width, base.height) {
        return Err(CanvasError::SizeMismatch {
            what: "the paint colour's rows",
            expected: base.width,
            found: layers.colour.width,
        });
    }
    for (pixel, (c, v)) in layers
        .colour
        .pixels
        .iter()
        .zip(&layers.coverage)
        .enumerate()
    {
        if !c.iter().all(|x| x.is_finite() && *x >= 0.0) {
            let problem = format!("colour {c:?} is not a finite non-negative colour");
            return Err(CanvasError::BadPixel { pixel, problem });
        }
        if !(0.0..=1.0).contains(v) {
            let problem = format!("coverage {v} is outside [0, 1]");
            return Err(CanvasError::BadPixel { pixel, problem });
        }
    }
    Ok(())
}
