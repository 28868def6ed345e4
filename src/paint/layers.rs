//! What a view's painting is, as stored in sessions and handed between the canvas and files.

use crate::image_io::RgbImage;

/// A view's painting: the picture the artist sees (the canvas's base, the guide or a
/// prediction, where nothing was painted) and, per pixel, how much paint covers it. Which
/// pixels give BRDF samples is the view's [`UnpaintedPixels`] rule; an eraser brings
/// coverage back to 0 and the colour back to the base's, bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct PaintLayers {
    /// Linear RGB, row-major, `resolution²` pixels; values may exceed 1 (HDR paint).
    pub colour: RgbImage,
    /// Paint coverage in [0, 1], row-major, same size as `colour`.
    pub coverage: Vec<f32>,
}

impl PaintLayers {
    /// An unpainted layer over `base` (a guide, or a prediction).
    pub fn unpainted(base: &RgbImage) -> Self {
        Self {
            colour: base.clone(),
            coverage: vec![0.0; base.pixels.len()],
        }
    }

    /// Whether the pixel carries paint.
    pub fn is_painted(&self, pixel: usize) -> bool {
        self.coverage[pixel] > 0.0
    }

    /// How many pixels carry paint.
    pub fn painted_count(&self) -> usize {
        self.coverage.iter().filter(|&&c| c > 0.0).count()
    }
}

/// What an unpainted pixel of a view says about the material: the one rule the app and the
/// command line share (`burnish reconstruct --unpainted`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum UnpaintedPixels {
    /// Every object pixel is a statement: the canvas means what it shows. On a guide it says
    /// "grey diffuse" wherever the artist did not paint, so a stroke changes the material
    /// only around the bins it reaches; on a prediction it agrees with the other views.
    #[default]
    CountAsShown,
    /// Only painted pixels (coverage > 0) give samples; the rest of the table is
    /// extrapolated from them.
    Ignore,
}

impl UnpaintedPixels {
    /// The name used in session files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            UnpaintedPixels::CountAsShown => "count",
            UnpaintedPixels::Ignore => "ignore",
        }
    }

    /// Whether a pixel that is (`painted`) or is not painted, on the object or not, gives
    /// what it shows as a sample under this rule.
    pub fn counts(self, on_object: bool, painted: bool) -> bool {
        on_object && (painted || self == UnpaintedPixels::CountAsShown)
    }
}

impl std::fmt::Display for UnpaintedPixels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for UnpaintedPixels {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "count" => Ok(UnpaintedPixels::CountAsShown),
            "ignore" => Ok(UnpaintedPixels::Ignore),
            other => Err(format!(
                "unpainted pixels '{other}': expected 'count' (as shown) or 'ignore'"
            )),
        }
    }
}

impl PaintLayers {
    /// The pixels that give samples under `rule`, each with the colour it shows, in pixel
    /// order; `object_mask[i]` says whether pixel i shows the object.
    pub fn counted_pixels(
        &self,
        rule: UnpaintedPixels,
        object_mask: &[bool],
    ) -> Vec<(u32, [f32; 3])> {
        (0..self.coverage.len())
            .filter(|&i| rule.counts(object_mask[i], self.is_painted(i)))
            .map(|i| (i as u32, self.colour.pixels[i]))
            .collect()
    }
}
