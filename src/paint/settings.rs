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
    /// Takes paint off, back to the guide.
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
