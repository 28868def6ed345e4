//! The tools: what one dab of each brush does (the capped paint model, smudge, blur), the
//! fill, and the eyedropper's picks.

use super::{Canvas, Edit, MIN_COVERAGE, Pickup, Stroke};
use crate::paint::changes::PixelRect;
use crate::paint::dab::DabMask;
use crate::paint::settings::{BrushKind, BrushSettings, MAX_PAINT};

impl Canvas {
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

    /// Round, airbrush, eraser, lighten and darken: the Photoshop model. The stroke's
    /// coverage buffer gains flow·dab·(1 − acc) per dab and each pixel becomes
    /// mix(its value at the stroke's start, the tool's target, opacity·acc), so however often
    /// a stroke passes over a spot it changes it by at most `opacity`.
    pub(super) fn capped_dab(&mut self, stroke: &mut Stroke, dab: &DabMask, flow: f32) {
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
    pub(super) fn smudge_dab(&mut self, stroke: &mut Stroke, dab: &DabMask, strength: f32) {
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
    pub(super) fn blur_dab(
        &mut self,
        stroke: &mut Stroke,
        dab: &DabMask,
        diameter: f32,
        strength: f32,
    ) {
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
