//! Strokes: a dab every `spacing × size` along the pointer's path, pressure, and the
//! airbrush's build-up while the pointer rests.

use super::{AIRBRUSH_RATE, Canvas, Edit, Stroke};
use crate::paint::dab::{DabShape, rasterise};
use crate::paint::settings::{BrushKind, BrushSettings, MIN_BRUSH_SIZE};

/// The shortest distance between dabs, in pixels, however small the brush and its spacing:
/// closer dabs would cost time and change nothing visible.
const MIN_STEP: f32 = 0.5;
/// The longest rest one airbrush tick accounts for; a stalled frame should not flood the spot.
const MAX_TICK_SECONDS: f32 = 1.0;
/// The most dabs one pointer event lays: 2¹⁶ dabs of the shortest step span 32768 px, far
/// more than any canvas, so only a wild jump (a pointer far off the canvas) reaches it; the
/// rest of such a move lays nothing, and a NaN-free f32 path always ends.
const MAX_DABS_PER_EVENT: usize = 1 << 16;

impl Canvas {
    /// Whether a stroke is in progress.
    pub fn is_stroking(&self) -> bool {
        self.stroke.is_some()
    }

    /// How many dabs the stroke in progress (or else the last one) has laid, including dabs
    /// that fell off the canvas.
    pub fn dabs_in_stroke(&self) -> usize {
        self.stroke
            .as_ref()
            .map_or(self.last_stroke_dabs, |s| s.dabs)
    }

    /// Starts a stroke with `settings` (brought into range by [`BrushSettings::sanitised`],
    /// so non-finite colours are clamped: NaN to 0, infinities to 0 or [`MAX_PAINT`]) and
    /// lays its first dab. `pressure` is in [0, 1] (1 for a mouse; a NaN counts as 1). A
    /// stroke in progress is ended first. A `Fill` brush fills at once (see
    /// [`fill`](Self::fill)); an `Eyedropper` changes nothing (use [`pick`](Self::pick)).
    /// Positions that are not finite are ignored.
    pub fn begin_stroke(&mut self, settings: &BrushSettings, x: f32, y: f32, pressure: f32) {
        self.end_stroke();
        let settings = settings.sanitised();
        self.last_stroke_dabs = 0;
        if settings.kind == BrushKind::Fill {
            self.fill(&settings);
        }
        let paints = !matches!(settings.kind, BrushKind::Fill | BrushKind::Eyedropper);
        if !(paints && x.is_finite() && y.is_finite()) {
            return;
        }
        let pressure = sanitise_pressure(pressure);
        let mut stroke = Stroke {
            tip: self.tip.clone(),
            edit: Edit::new(self.grid.count()),
            last: (x, y, pressure),
            to_next: 0.0,
            dabs: 0,
            pickup: None,
            settings,
        };
        stroke.to_next = stroke.step(pressure);
        self.lay_dab(&mut stroke, x, y, pressure, None);
        self.stroke = Some(stroke);
    }

    /// Moves the stroke in progress to (`x`, `y`), laying dabs every `spacing × size` along
    /// the way (position and pressure interpolated; the distance left over carries on to
    /// the next event; at most 65536 dabs per event). Does nothing without a stroke or with a
    /// non-finite position.
    pub fn continue_stroke(&mut self, x: f32, y: f32, pressure: f32) {
        let Some(mut stroke) = self.stroke.take() else {
            return;
        };
        if !(x.is_finite() && y.is_finite()) {
            self.stroke = Some(stroke);
            return;
        }
        let pressure = sanitise_pressure(pressure);
        let (x0, y0, p0) = stroke.last;
        let (dx, dy, dp) = (x - x0, y - y0, pressure - p0);
        let distance = dx.hypot(dy);
        // A distance that overflows is a jump from far off the canvas: no dabs on the way.
        if distance.is_finite() {
            let mut travelled = 0.0;
            for laid in 0.. {
                let need = stroke.to_next;
                if travelled + need > distance {
                    stroke.to_next = need - (distance - travelled);
                    break;
                }
                if laid == MAX_DABS_PER_EVENT {
                    stroke.to_next = stroke.step(pressure);
                    break;
                }
                travelled += need;
                let t = travelled / distance;
                let p = p0 + dp * t;
                self.lay_dab(&mut stroke, x0 + dx * t, y0 + dy * t, p, None);
                stroke.to_next = stroke.step(p);
            }
        }
        stroke.last = (x, y, pressure);
        self.stroke = Some(stroke);
    }

    /// Lets an airbrush stroke build up while the pointer rests: lays one dab at the last
    /// position with the flow that `dt_seconds × AIRBRUSH_RATE` dabs would give
    /// (1 − (1 − flow)^(dt·rate)), so the build-up hardly depends on the frame rate. Does
    /// nothing for other tools or without a stroke; a rest over a second counts as a second.
    pub fn airbrush_tick(&mut self, dt_seconds: f32) {
        let Some(mut stroke) = self.stroke.take() else {
            return;
        };
        if stroke.settings.kind == BrushKind::Airbrush && dt_seconds > 0.0 {
            let dt = dt_seconds.min(MAX_TICK_SECONDS);
            let (x, y, p) = stroke.last;
            let flow = stroke.flow(p);
            let rested_flow = 1.0 - (1.0 - flow).powf(dt * AIRBRUSH_RATE);
            self.lay_dab(&mut stroke, x, y, p, Some(rested_flow));
        }
        self.stroke = Some(stroke);
    }

    /// Ends the stroke in progress and records it as one undo step (if it changed anything).
    pub fn end_stroke(&mut self) {
        if let Some(stroke) = self.stroke.take() {
            self.last_stroke_dabs = stroke.dabs;
            self.commit(stroke.edit);
        }
    }

    /// Lays one dab of the stroke at (`x`, `y`); `flow` overrides the brush's (airbrush rests).
    fn lay_dab(&mut self, stroke: &mut Stroke, x: f32, y: f32, pressure: f32, flow: Option<f32>) {
        stroke.dabs += 1;
        let diameter = stroke.diameter(pressure);
        let flow = flow.unwrap_or_else(|| stroke.flow(pressure));
        let tip = stroke.tip.clone();
        let shape = match &tip {
            Some(tip) => DabShape::Tip(tip),
            None => DabShape::Round {
                hardness: stroke.settings.hardness,
            },
        };
        let n = self.resolution() as u32;
        let Some(dab) = rasterise(x, y, diameter, shape, n, n) else {
            return;
        };
        let strength = stroke.settings.opacity * flow;
        match stroke.settings.kind {
            BrushKind::Smudge => self.smudge_dab(stroke, &dab, strength),
            BrushKind::Blur => self.blur_dab(stroke, &dab, diameter, strength),
            _ => self.capped_dab(stroke, &dab, flow),
        }
    }
}

impl Stroke {
    fn diameter(&self, pressure: f32) -> f32 {
        if self.settings.pressure_size {
            (self.settings.size * pressure).max(MIN_BRUSH_SIZE)
        } else {
            self.settings.size
        }
    }

    fn flow(&self, pressure: f32) -> f32 {
        if self.settings.pressure_flow {
            self.settings.flow * pressure
        } else {
            self.settings.flow
        }
    }

    /// Path length from one dab to the next.
    fn step(&self, pressure: f32) -> f32 {
        (self.settings.spacing * self.diameter(pressure)).max(MIN_STEP)
    }
}

fn sanitise_pressure(pressure: f32) -> f32 {
    if pressure.is_nan() {
        1.0
    } else {
        pressure.clamp(0.0, 1.0)
    }
}
