//! Painting: the HDR paint layer over a guide, brushes, strokes, undo and brush presets.

mod layers;

pub use layers::PaintLayers;
