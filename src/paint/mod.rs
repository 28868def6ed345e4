//! Painting: the HDR paint layer over a guide, brushes, strokes, undo and brush presets.

mod layers;
mod settings;

pub use layers::PaintLayers;
pub use settings::{BrushKind, BrushSettings};
