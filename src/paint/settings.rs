//! The brush the artist holds: which tool and its parameters. Saved in sessions and presets.

use serde::{Deserialize, Serialize};

/// The canvas tools.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BrushKind {
    /// Round brush with a hard edge (hardness sets the falloff).
    #[default]
    Round,
    /// Soft airbrush: builds up with flow while held.
    Airbrush,
    /// Takes paint off, back to the base (the guide or the prediction under the paint).
    Eraser,
    /// Drags the colour under the brush along the stroke.
    Smudge,
    /// Blurs the paint under the brush.
    Blur,
    /// Dodge: scales the colour up.
    Lighten,
    /// Burn: scales the colour down.
    Darken,
    /// Fills every pixel of the object with the colour.
    Fill,
    /// Picks the colour under the pointer.
    Eyedropper,
}

/// A brush's parameters. Sizes are in canvas pixels; fractions are in [0, 1].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BrushSettings {
    pub kind: BrushKind,
    /// Diameter in canvas pixels.
    pub size: f32,
    /// 1 = hard edge, 0 = falloff across the whole radius.
    pub hardness: f32,
    /// The most one stroke can change a pixel.
    pub opacity: f32,
    /// How much each dab adds.
    pub flow: f32,
    /// Distance between dabs, as a fraction of the diameter.
    pub spacing: f32,
    /// Linear RGB; components may exceed 1 (HDR paint).
    pub colour: [f32; 3],
    /// Pen pressure scales the size.
    pub pressure_size: bool,
    /// Pen pressure scales the flow.
    pub pressure_flow: bool,
}

impl Default for BrushSettings {
    fn default() -> Self {
        Self {
            kind: BrushKind::Round,
            size: 40.0,
            hardness: 0.8,
            opacity: 1.0,
            flow: 1.0,
            spacing: 0.15,
            colour: [0.5, 0.5, 0.5],
            pressure_size: true,
            pressure_flow: false,
        }
    }
}

/// The smallest brush diameter, in canvas pixels.
pub const MIN_BRUSH_SIZE: f32 = 1.0;
/// The largest brush diameter, in canvas pixels (twice the largest guide the scene allows
/// would be pointless; this is already more than any canvas needs).
pub const MAX_BRUSH_SIZE: f32 = 4096.0;
/// Dab spacing bounds, as fractions of the diameter.
pub const MIN_SPACING: f32 = 0.01;
pub const MAX_SPACING: f32 = 10.0;
/// The brightest paint a colour component may hold: the largest finite half float, so that a
/// painting survives being stored as half-float EXR.
pub const MAX_PAINT: f32 = 65504.0;

impl BrushSettings {
    /// The first problem with these settings, if any: sizes and spacing outside their bounds,
    /// fractions outside [0, 1], colour components that are not finite or outside
    /// [0, [`MAX_PAINT`]]. Presets must pass this check.
    pub fn check(&self) -> Result<(), String> {
        let range = |name: &str, value: f32, lo: f32, hi: f32| {
            if value.is_finite() && (lo..=hi).contains(&value) {
                Ok(())
            } else {
                Err(format!("{name} = {value} is outside {lo}..={hi}"))
            }
        };
        range("size", self.size, MIN_BRUSH_SIZE, MAX_BRUSH_SIZE)?;
        range("hardness", self.hardness, 0.0, 1.0)?;
        range("opacity", self.opacity, 0.0, 1.0)?;
        range("flow", self.flow, 0.0, 1.0)?;
        range("spacing", self.spacing, MIN_SPACING, MAX_SPACING)?;
        for (c, name) in self
            .colour
            .iter()
            .zip(["colour[0]", "colour[1]", "colour[2]"])
        {
            range(name, *c, 0.0, MAX_PAINT)?;
        }
        Ok(())
    }

    /// These settings brought into range, so that painting never meets a NaN or an infinity:
    /// each number is clamped into the bounds [`check`](Self::check) enforces; a NaN colour
    /// component becomes 0 and any other NaN takes the default's value.
    pub fn sanitised(&self) -> Self {
        let defaults = Self::default();
        let clamp = |value: f32, fallback: f32, lo: f32, hi: f32| {
            if value.is_nan() {
                fallback
            } else {
                value.clamp(lo, hi)
            }
        };
        Self {
            kind: self.kind,
            size: clamp(self.size, defaults.size, MIN_BRUSH_SIZE, MAX_BRUSH_SIZE),
            hardness: clamp(self.hardness, defaults.hardness, 0.0, 1.0),
            opacity: clamp(self.opacity, defaults.opacity, 0.0, 1.0),
            flow: clamp(self.flow, defaults.flow, 0.0, 1.0),
            spacing: clamp(self.spacing, defaults.spacing, MIN_SPACING, MAX_SPACING),
            colour: self.colour.map(|c| clamp(c, 0.0, 0.0, MAX_PAINT)),
            pressure_size: self.pressure_size,
            pressure_flow: self.pressure_flow,
        }
    }
}
