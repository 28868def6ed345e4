//! What a view's painting is, as stored in sessions and handed between the canvas and files.

use crate::image_io::RgbImage;

/// A view's painting: the picture the artist sees (the guide where nothing was painted) and,
/// per pixel, how much paint covers it. Only pixels with coverage > 0 give BRDF samples;
/// an eraser brings coverage back to 0 and the colour back to the guide's, bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct PaintLayers {
    /// Linear RGB, row-major, `resolution²` pixels; values may exceed 1 (HDR paint).
    pub colour: RgbImage,
    /// Paint coverage in [0, 1], row-major, same size as `colour`.
    pub coverage: Vec<f32>,
}

impl PaintLayers {
    /// An unpainted layer over `guide`.
    pub fn unpainted(guide: &RgbImage) -> Self {
        Self {
            colour: guide.clone(),
            coverage: vec![0.0; guide.pixels.len()],
        }
    }

    /// Whether the pixel carries paint (and so gives a sample).
    pub fn is_painted(&self, pixel: usize) -> bool {
        self.coverage[pixel] > 0.0
    }

    /// How many pixels carry paint.
    pub fn painted_count(&self) -> usize {
        self.coverage.iter().filter(|&&c| c > 0.0).count()
    }
}
