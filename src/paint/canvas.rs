//! The canvas: an HDR paint layer over a view's base image (the guide, or a prediction of the
//! current BRDF), the brush tools that change it,
//! the changed pixels it reports and whole-stroke undo.
//!
//! Coordinates are canvas pixels, x to the right and y down; pixel (i, j) covers
//! [i, i+1) × [j, j+1), so its centre is (i + 0.5, j + 0.5).

use super::changes::{CanvasChanges, PixelChange, PixelRect};
use super::dab::{DabMask, DabShape, TipMask, rasterise};
use super::history::{History, Step, TileData, TileGrid};
use super::layers::PaintLayers;
use super::settings::{BrushKind, BrushSettings, MAX_PAINT, MIN_BRUSH_SIZE};
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
/// The shortest distance between dabs, in pixels, however small the brush and its spacing:
/// closer dabs would cost time and change nothing visible.
const MIN_STEP: f32 = 0.5;
/// The longest rest one airbrush tick accounts for; a stalled frame should not flood the spot.
const MAX_TICK_SECONDS: f32 = 1.0;
/// The most dabs one pointer event lays: 2¹⁶ dabs of the shortest step span 32768 px, far
/// more than any canvas, so only a wild jump (a pointer far off the canvas) reaches it; the
/// rest of such a move lays nothing, and a NaN-free f32 path always ends.
const MAX_DABS_PER_EVENT: usize = 1 << 16;
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

    /// Sets every object pixel to `settings.colour` at `settings.opacity`
    /// (colour' = mix(colour, c, opacity), coverage' = coverage + opacity·(1 − coverage)),
    /// as one undo step. Ends a stroke in progress first.
    pub fn fill(&mut self, settings: &BrushSettings) {
        self.end_stroke();
        let settings = settings.sanitised();
        let (target, opacity) = (settings.colour, settings.opacity);
        let mut edit = Edit::new(self.grid.count());
        let width = self.resolution();
        for tile in 0..self.grid.count() {
            let rect = self.grid.rect(tile);
            let has_object = (rect.y0..rect.y1).any(|y| {
                let row = y as usize * width;
                self.object[row + rect.x0 as usize..row + rect.x1 as usize]
                    .iter()
                    .any(|&o| o)
            });
            if !has_object {
                continue;
            }
            self.touch(&mut edit, tile, rect);
            for y in rect.y0..rect.y1 {
                for x in rect.x0..rect.x1 {
                    let i = y as usize * width + x as usize;
                    if self.object[i] {
                        let (c, v) = (self.layers.colour.pixels[i], self.layers.coverage[i]);
                        self.layers.colour.pixels[i] = mix(c, target, opacity);
                        self.layers.coverage[i] = v + opacity * (1.0 - v);
                    }
                }
            }
        }
        self.commit(edit);
    }

    /// The colour under (`x`, `y`) as the artist sees it (the base where unpainted); points
    /// off the canvas take the nearest pixel.
    pub fn pick(&self, x: f32, y: f32) -> [f32; 3] {
        let n = self.resolution();
        let clamp = |v: f32| ((v.floor().max(0.0)) as usize).min(n - 1);
        self.layers.colour.pixels[clamp(y) * n + clamp(x)]
    }

    /// The mean colour of the object pixels whose centres lie within `radius` of
    /// (`x`, `y`); [`pick`](Self::pick) when there are none.
    pub fn pick_average(&self, x: f32, y: f32, radius: f32) -> [f32; 3] {
        let n = self.resolution();
        if !(radius.is_finite() && radius > 0.0 && x.is_finite() && y.is_finite()) {
            return self.pick(x, y);
        }
        let lo = |v: f32| ((v - radius - 0.5).floor().max(0.0) as usize).min(n);
        let hi = |v: f32| ((v + radius + 0.5).ceil().max(0.0) as usize).min(n);
        let mut sum = [0.0f64; 3];
        let mut count = 0usize;
        for py in lo(y)..hi(y) {
            for px in lo(x)..hi(x) {
                let (ddx, ddy) = (px as f32 + 0.5 - x, py as f32 + 0.5 - y);
                let i = py * n + px;
                if ddx * ddx + ddy * ddy <= radius * radius && self.object[i] {
                    for c in 0..3 {
                        sum[c] += f64::from(self.layers.colour.pixels[i][c]);
                    }
                    count += 1;
                }
            }
        }
        if count == 0 {
            return self.pick(x, y);
        }
        sum.map(|s| (s / count as f64) as f32)
    }

    /// The changes since the last call (or since the canvas was made): each pixel whose
    /// painted state or colour changed, with its state when the batch began, and the
    /// rectangle holding them. `None` when nothing changed.
    pub fn take_changes(&mut self) -> Option<CanvasChanges> {
        let width = self.resolution();
        let mut pixels = Vec::new();
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for tile in self.batch.tiles.drain(..) {
            self.batch.slot[tile.before.tile] = NO_SLOT;
            let rect = self.grid.rect(tile.before.tile);
            let tile_width = rect.width() as usize;
            let t = tile.touched;
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let i = y as usize * width + x as usize;
                    let l = (y - rect.y0) as usize * tile_width + (x - rect.x0) as usize;
                    let before = painted(tile.before.colour[l], tile.before.coverage[l]);
                    let after = painted(self.layers.colour.pixels[i], self.layers.coverage[i]);
                    if !same_state(before, after) {
                        pixels.push(PixelChange {
                            pixel: i as u32,
                            before,
                            after,
                        });
                        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
                    }
                }
            }
        }
        if pixels.is_empty() {
            return None;
        }
        pixels.sort_unstable_by_key(|p| p.pixel);
        Some(CanvasChanges {
            dirty: PixelRect::new(x0, y0, x1, y1),
            pixels,
        })
    }

    pub fn can_undo(&self) -> bool {
        self.history.can_undo() || self.stroke.as_ref().is_some_and(|s| !s.edit.is_empty())
    }

    pub fn can_redo(&self) -> bool {
        self.history.can_redo()
    }

    /// How many steps can be undone (a stroke in progress not counted).
    pub fn undo_steps(&self) -> usize {
        self.history.undo_len()
    }

    /// Bytes the undo and redo history holds.
    pub fn undo_bytes(&self) -> usize {
        self.history.bytes()
    }

    /// Bounds the memory of the undo and redo history (default [`DEFAULT_UNDO_BUDGET`]);
    /// the oldest steps are dropped to keep under it. A single step larger than the whole
    /// budget is not kept.
    pub fn set_undo_budget(&mut self, bytes: usize) {
        self.history.set_budget(bytes);
    }

    /// Undoes the last stroke or fill (ending a stroke in progress first), restoring colour
    /// and coverage bit for bit. Returns the batch of changes, drained (including any not
    /// yet taken); `None` when there is nothing to undo.
    pub fn undo(&mut self) -> Option<CanvasChanges> {
        self.end_stroke();
        let mut step = self.history.pop_undo()?;
        self.swap_in(&mut step);
        self.history.push_redo(step);
        Some(self.take_changes().unwrap_or_default())
    }

    /// Reapplies the last undone step exactly. Returns the drained batch of changes; `None`
    /// when there is nothing to redo.
    pub fn redo(&mut self) -> Option<CanvasChanges> {
        self.end_stroke();
        let mut step = self.history.pop_redo()?;
        self.swap_in(&mut step);
        self.history.push_undo_again(step);
        Some(self.take_changes().unwrap_or_default())
    }

    fn swap_in(&mut self, step: &mut Step) {
        let width = self.resolution();
        for data in &mut step.tiles {
            let rect = self.grid.rect(data.tile);
            self.batch.touch(&self.layers, &self.grid, data.tile, rect);
            data.swap_with(&mut self.layers, &self.grid);
            // The step may date from another base (a prediction put under the paint since):
            // what it leaves unpainted shows the base of now.
            for y in rect.y0 as usize..rect.y1 as usize {
                for i in y * width + rect.x0 as usize..y * width + rect.x1 as usize {
                    if self.layers.coverage[i] == 0.0 {
                        self.layers.colour.pixels[i] = self.base.pixels[i];
                    }
                }
            }
        }
    }

    /// Records the tiles an edit changed as one undo step; tiles it touched but left as they
    /// were are dropped.
    fn commit(&mut self, edit: Edit) {
        let tiles: Vec<TileData> = edit
            .before
            .into_iter()
            .filter(|t| !t.same_as(&self.layers, &self.grid))
            .collect();
        if !tiles.is_empty() {
            self.history.push(Step { tiles });
        }
    }

    /// Makes sure the edit and the change batch hold `tile` as it was before they touched it,
    /// and notes that `rect` of it may change. Returns the tile's slot in the edit.
    fn touch(&mut self, edit: &mut Edit, tile: usize, rect: PixelRect) -> usize {
        if edit.slot[tile] == NO_SLOT {
            if edit.before.is_empty() {
                // The first change of a new edit: what was undone can no longer be redone.
                self.history.clear_redo();
            }
            edit.slot[tile] = edit.before.len() as u32;
            let data = TileData::capture(&self.layers, &self.grid, tile);
            edit.accumulated.push(vec![0.0; data.coverage.len()]);
            edit.before.push(data);
        }
        self.batch.touch(&self.layers, &self.grid, tile, rect);
        edit.slot[tile] as usize
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

    /// Round, airbrush, eraser, lighten and darken: the Photoshop model. The stroke's
    /// coverage buffer gains flow·dab·(1 − acc) per dab and each pixel becomes
    /// mix(its value at the stroke's start, the tool's target, opacity·acc), so however often
    /// a stroke passes over a spot it changes it by at most `opacity`.
    fn capped_dab(&mut self, stroke: &mut Stroke, dab: &DabMask, flow: f32) {
        let (kind, opacity, target) = (
            stroke.settings.kind,
            stroke.settings.opacity,
            stroke.settings.colour,
        );
        let width = self.resolution();
        for tile in self.grid.tiles_in(dab.rect) {
            let tile_rect = self.grid.rect(tile);
            let part = tile_rect.intersect(&dab.rect);
            let slot = self.touch(&mut stroke.edit, tile, part);
            let start = &stroke.edit.before[slot];
            let accumulated = &mut stroke.edit.accumulated[slot];
            let tile_width = tile_rect.width() as usize;
            for y in part.y0..part.y1 {
                for x in part.x0..part.x1 {
                    let i = y as usize * width + x as usize;
                    let m = dab.at(x, y);
                    if m <= 0.0 || !self.object[i] {
                        continue;
                    }
                    let l = (y - tile_rect.y0) as usize * tile_width + (x - tile_rect.x0) as usize;
                    let acc = &mut accumulated[l];
                    *acc += flow * m * (1.0 - *acc);
                    let s = opacity * *acc;
                    let (c0, v0) = (start.colour[l], start.coverage[l]);
                    let painted_coverage = v0 + s * (1.0 - v0);
                    let (c, v) = match kind {
                        BrushKind::Eraser => {
                            let v = v0 * (1.0 - s);
                            if s >= 1.0 || v < MIN_COVERAGE {
                                (self.base.pixels[i], 0.0)
                            } else {
                                (mix(c0, self.base.pixels[i], s), v)
                            }
                        }
                        BrushKind::Lighten => {
                            (c0.map(|c| (c * (1.0 + s)).min(MAX_PAINT)), painted_coverage)
                        }
                        BrushKind::Darken => (c0.map(|c| c * (1.0 - s)), painted_coverage),
                        _ => (mix(c0, target, s), painted_coverage),
                    };
                    self.layers.colour.pixels[i] = c;
                    self.layers.coverage[i] = v;
                }
            }
        }
    }

    /// Smudge: each dab lays the brush's load onto the pixels under it (by strength × dab),
    /// then picks up the colour now under it, keeping `strength` of the old load. The first
    /// dab only loads the brush. Coverage travels with the colour.
    fn smudge_dab(&mut self, stroke: &mut Stroke, dab: &DabMask, strength: f32) {
        let Some(load) = stroke.pickup else {
            stroke.pickup = self.average_under(dab);
            return;
        };
        let load_colour = load.colour.map(|c| c as f32);
        let load_coverage = load.coverage as f32;
        self.for_each_dab_pixel(stroke, dab, |canvas, i, m| {
            let k = strength * m;
            let (c, v) = (canvas.layers.colour.pixels[i], canvas.layers.coverage[i]);
            canvas.set_or_unpaint(i, mix(c, load_colour, k), v + (load_coverage - v) * k);
        });
        if let Some(under) = self.average_under(dab) {
            let keep = f64::from(strength);
            stroke.pickup = Some(Pickup {
                colour: [0, 1, 2].map(|c| under.colour[c] * (1.0 - keep) + load.colour[c] * keep),
                coverage: under.coverage * (1.0 - keep) + load.coverage * keep,
            });
        }
    }

    /// Blur: each pixel under the dab moves (by strength × dab) toward the box average of
    /// the object pixels around it, colour and coverage alike; the box's half-width is a
    /// tenth of the diameter (at least 1). Where there is no paint nearby the coverage
    /// stays 0 and the base shows through untouched.
    fn blur_dab(&mut self, stroke: &mut Stroke, dab: &DabMask, diameter: f32, strength: f32) {
        let n = self.resolution() as u32;
        let reach = ((diameter * 0.1).round() as u32).max(1);
        let area = PixelRect::new(
            dab.rect.x0.saturating_sub(reach),
            dab.rect.y0.saturating_sub(reach),
            (dab.rect.x1 + reach).min(n),
            (dab.rect.y1 + reach).min(n),
        );
        let sums = AreaSums::new(self, area);
        self.for_each_dab_pixel(stroke, dab, |canvas, i, m| {
            let (x, y) = ((i % n as usize) as u32, (i / n as usize) as u32);
            let window = PixelRect::new(
                x.saturating_sub(reach),
                y.saturating_sub(reach),
                (x + reach + 1).min(n),
                (y + reach + 1).min(n),
            );
            let [r, g, b, v, count] = sums.sum(window);
            if count == 0.0 {
                return;
            }
            let k = f64::from(strength * m);
            let (c0, v0) = (canvas.layers.colour.pixels[i], canvas.layers.coverage[i]);
            let towards = |from: f32, mean: f64| f64::from(from) * (1.0 - k) + mean / count * k;
            let c = [
                towards(c0[0], r) as f32,
                towards(c0[1], g) as f32,
                towards(c0[2], b) as f32,
            ];
            canvas.set_or_unpaint(i, c, towards(v0, v) as f32);
        });
    }

    /// Calls `f(canvas, pixel, dab value)` for each object pixel the dab reaches, after the
    /// edit and the change batch have taken their snapshots.
    fn for_each_dab_pixel(
        &mut self,
        stroke: &mut Stroke,
        dab: &DabMask,
        mut f: impl FnMut(&mut Self, usize, f32),
    ) {
        let width = self.resolution();
        for tile in self.grid.tiles_in(dab.rect) {
            let part = self.grid.rect(tile).intersect(&dab.rect);
            self.touch(&mut stroke.edit, tile, part);
            for y in part.y0..part.y1 {
                for x in part.x0..part.x1 {
                    let i = y as usize * width + x as usize;
                    let m = dab.at(x, y);
                    if m > 0.0 && self.object[i] {
                        f(self, i, m);
                    }
                }
            }
        }
    }

    /// Stores a pixel's new paint; coverage under [`MIN_COVERAGE`] gives it back to the
    /// base exactly.
    fn set_or_unpaint(&mut self, i: usize, colour: [f32; 3], coverage: f32) {
        if coverage < MIN_COVERAGE {
            self.layers.colour.pixels[i] = self.base.pixels[i];
            self.layers.coverage[i] = 0.0;
        } else {
            self.layers.colour.pixels[i] = colour.map(|c| c.clamp(0.0, MAX_PAINT));
            self.layers.coverage[i] = coverage.min(1.0);
        }
    }

    /// The dab-weighted mean colour and coverage of the object pixels under a dab.
    fn average_under(&self, dab: &DabMask) -> Option<Pickup> {
        let width = self.resolution();
        let (mut colour, mut coverage, mut weight) = ([0.0f64; 3], 0.0f64, 0.0f64);
        for y in dab.rect.y0..dab.rect.y1 {
            for x in dab.rect.x0..dab.rect.x1 {
                let i = y as usize * width + x as usize;
                let m = f64::from(dab.at(x, y));
                if m > 0.0 && self.object[i] {
                    for c in 0..3 {
                        colour[c] += m * f64::from(self.layers.colour.pixels[i][c]);
                    }
                    coverage += m * f64::from(self.layers.coverage[i]);
                    weight += m;
                }
            }
        }
        (weight > 0.0).then(|| Pickup {
            colour: colour.map(|c| c / weight),
            coverage: coverage / weight,
        })
    }
}

impl Batch {
    fn touch(&mut self, layers: &PaintLayers, grid: &TileGrid, tile: usize, rect: PixelRect) {
        match self.slot[tile] {
            NO_SLOT => {
                self.slot[tile] = self.tiles.len() as u32;
                self.tiles.push(BatchTile {
                    before: TileData::capture(layers, grid, tile),
                    touched: rect,
                });
            }
            slot => {
                let entry = &mut self.tiles[slot as usize];
                entry.touched = entry.touched.union(&rect);
            }
        }
    }
}

impl Edit {
    fn new(tiles: usize) -> Self {
        Self {
            slot: vec![NO_SLOT; tiles],
            before: Vec::new(),
            accumulated: Vec::new(),
        }
    }

    fn is_empty(&self) -> bool {
        self.before.is_empty()
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

/// Summed-area tables of colour, coverage and object-pixel count over a rectangle, in f64.
struct AreaSums {
    area: PixelRect,
    /// (width + 1) × (height + 1) entries of [r, g, b, coverage, count].
    table: Vec<[f64; 5]>,
}

impl AreaSums {
    fn new(canvas: &Canvas, area: PixelRect) -> Self {
        let width = canvas.resolution();
        let stride = area.width() as usize + 1;
        let mut table = vec![[0.0f64; 5]; stride * (area.height() as usize + 1)];
        for (row, y) in (area.y0..area.y1).enumerate() {
            let mut running = [0.0f64; 5];
            for (column, x) in (area.x0..area.x1).enumerate() {
                let i = y as usize * width + x as usize;
                if canvas.object[i] {
                    let c = canvas.layers.colour.pixels[i];
                    let v = canvas.layers.coverage[i];
                    let values = [c[0], c[1], c[2], v, 1.0].map(f64::from);
                    for k in 0..5 {
                        running[k] += values[k];
                    }
                }
                let above = table[row * stride + column + 1];
                table[(row + 1) * stride + column + 1] =
                    [0, 1, 2, 3, 4].map(|k| above[k] + running[k]);
            }
        }
        Self { area, table }
    }

    /// Sums over `window` (clipped to the area).
    fn sum(&self, window: PixelRect) -> [f64; 5] {
        let w = window.intersect(&self.area);
        if w.is_empty() {
            return [0.0; 5];
        }
        let stride = self.area.width() as usize + 1;
        let at = |x: u32, y: u32| {
            self.table[(y - self.area.y0) as usize * stride + (x - self.area.x0) as usize]
        };
        let (a, b, c, d) = (
            at(w.x0, w.y0),
            at(w.x1, w.y0),
            at(w.x0, w.y1),
            at(w.x1, w.y1),
        );
        [0, 1, 2, 3, 4].map(|k| d[k] - b[k] - c[k] + a[k])
    }
}

/// a·(1 − t) + b·t, exact at both ends (t = 1 gives b bit for bit).
#[inline]
fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [0, 1, 2].map(|k| a[k] * (1.0 - t) + b[k] * t)
}

fn sanitise_pressure(pressure: f32) -> f32 {
    if pressure.is_nan() {
        1.0
    } else {
        pressure.clamp(0.0, 1.0)
    }
}

/// A pixel's state as the app sees it: its colour if painted.
#[inline]
fn painted(colour: [f32; 3], coverage: f32) -> Option<[f32; 3]> {
    (coverage > 0.0).then_some(colour)
}

fn same_state(a: Option<[f32; 3]>, b: Option<[f32; 3]>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => a.map(f32::to_bits) == b.map(f32::to_bits),
        _ => false,
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
