//! Painting: the HDR paint layer over a guide or a prediction, brushes, strokes, undo and brush presets.
//!
//! [`Canvas`] holds a view's [`PaintLayers`] and applies the [`BrushKind`] tools to them,
//! dab by dab (dabs rasterised with tiny-skia); it reports changed pixels as
//! [`CanvasChanges`] for the app to turn into BRDF samples, and undoes whole strokes from
//! tile snapshots. [`load_presets`] reads the brush palette (see brushes/README.md).

mod canvas;
mod changes;
mod dab;
mod history;
mod layers;
mod presets;
mod settings;

pub use canvas::{AIRBRUSH_RATE, Canvas, CanvasError, DEFAULT_UNDO_BUDGET, MIN_COVERAGE};
pub use changes::{CanvasChanges, PixelChange, PixelRect};
pub use dab::{MAX_TIP_SIDE, TipMask};
pub use layers::{PaintLayers, UnpaintedPixels};
pub use presets::{BrushPreset, load_preset, load_presets, parse_preset};
pub use settings::{
    BrushKind, BrushSettings, MAX_BRUSH_SIZE, MAX_PAINT, MAX_SPACING, MIN_BRUSH_SIZE, MIN_SPACING,
};
