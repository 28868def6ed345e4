//! The continuous marginal–conditional warp of a bilinearly interpolated 2D density, with
//! optional dependence on parameters, exactly as the RGL loaders use it for the `.bsdf`
//! fields (Mitsuba 3's `Marginal2D<Float, Dim, Continuous = true>`, pbrt-v4's
//! `PiecewiseLinear2D`, brdf-loader's `Marginal2D`).
//!
//! The density on [0, 1]² is the bilinear interpolant of a `width × height` grid (x is the
//! contiguous axis). Sampling inverts its exact marginal CDF in y, then the conditional CDF
//! in x at that y; `invert` is the inverse map. With parameters, the grid, its CDFs and the
//! values are blended linearly between the slices around the parameter values, entry by
//! entry, as the loaders do (so that this reader evaluates a file as they do).

/// Most parameters a warp here depends on (the spectral table has three).
const MAX_PARAMS: usize = 3;
const MAX_CORNERS: usize = 1 << MAX_PARAMS;

/// A (possibly parametrised) 2D warp.
#[derive(Clone, Debug)]
pub struct Marginal2D {
    width: usize,
    height: usize,
    /// Parameter values per dimension, outermost first (ascending).
    params: Vec<Vec<f32>>,
    /// Slice stride of each parameter (0 for a parameter with one value).
    strides: Vec<usize>,
    /// Density values (normalised per slice when asked), slice-major.
    data: Vec<f32>,
    /// Marginal CDF in y: `height − 1` entries per slice (the value at the end of each row
    /// interval; 0 at y = 0 is implicit).
    marginal: Vec<f32>,
    /// Conditional CDFs in x: `height × (width − 1)` entries per slice.
    conditional: Vec<f32>,
    normalized: bool,
}

/// Which slices a parameter value blends, and with what weights.
#[derive(Clone, Copy, Debug)]
struct Blend {
    slices: [usize; MAX_CORNERS],
    weights: [f64; MAX_CORNERS],
    count: usize,
}

impl Marginal2D {
    /// A warp of `data` (`slices × height × width`, C order) over parameters `params`
    /// (outermost first; each ascending, at least one value). `normalize` scales each slice
    /// to integrate to 1; `sampling` builds the CDFs that `sample` and `invert` need.
    pub fn new(
        data: &[f32],
        width: usize,
        height: usize,
        params: Vec<Vec<f32>>,
        normalize: bool,
        sampling: bool,
    ) -> Result<Self, String> {
        if width < 2 || height < 2 {
            return Err(format!(
                "a {width} × {height} grid is too small: each side must be at least 2"
            ));
        }
        if params.len() > MAX_PARAMS {
            return Err(format!(
                "{} parameters (at most {MAX_PARAMS})",
                params.len()
            ));
        }
        let mut strides = vec![0; params.len()];
        let mut slices = 1usize;
        for (i, values) in params.iter().enumerate().rev() {
            if values.is_empty() {
                return Err(format!("parameter {i} has no values"));
            }
            if values.windows(2).any(|w| w[0] >= w[1] || !w[0].is_finite()) {
                return Err(format!(
                    "parameter {i}'s values are not strictly increasing"
                ));
            }
            strides[i] = if values.len() > 1 { slices } else { 0 };
            slices *= values.len();
        }
        let n = width * height;
        if data.len() != slices * n {
            return Err(format!(
                "{} values for {slices} slices of {width} × {height}",
                data.len()
            ));
        }
        if let Some(bad) = data.iter().find(|v| !v.is_finite() || **v < 0.0) {
            return Err(format!(
                "a density value is {bad}: densities are finite and ≥ 0"
            ));
        }
        let mut out = Vec::with_capacity(data.len());
        let (mut marginal, mut conditional) = (Vec::new(), Vec::new());
        let (scale_x, scale_y) = (0.5 / (width - 1) as f64, 0.5 / (height - 1) as f64);
        for slice in data.chunks_exact(n) {
            let mut norm = 1.0f64;
            if sampling {
                let first_cond = conditional.len();
                let first_marg = marginal.len();
                let mut row_sums = Vec::with_capacity(height);
                for y in 0..height {
                    let row = &slice[y * width..(y + 1) * width];
                    let mut accum = 0f64;
                    for x in 0..width - 1 {
                        accum += scale_x * (row[x] as f64 + row[x + 1] as f64);
                        conditional.push(accum as f32);
                    }
                    row_sums.push(accum);
                }
                let mut accum = 0f64;
                for y in 0..height - 1 {
                    accum += scale_y * (row_sums[y] + row_sums[y + 1]);
                    marginal.push(accum as f32);
                }
                if normalize {
                    if accum <= 0.0 {
                        return Err("a slice of the density is zero everywhere".into());
                    }
                    norm = 1.0 / accum;
                }
                let norm32 = norm as f32;
                conditional[first_cond..]
                    .iter_mut()
                    .for_each(|c| *c *= norm32);
                marginal[first_marg..].iter_mut().for_each(|m| *m *= norm32);
            } else if normalize {
                let mut sum = 0f64;
                for y in 0..height - 1 {
                    for x in 0..width - 1 {
                        let i = y * width + x;
                        sum += slice[i] as f64
                            + slice[i + 1] as f64
                            + slice[i + width] as f64
                            + slice[i + width + 1] as f64;
                    }
                }
                if sum <= 0.0 {
                    return Err("a slice of the density is zero everywhere".into());
                }
                norm = 1.0 / (scale_x * scale_y * sum);
            }
            let norm32 = norm as f32;
            out.extend(slice.iter().map(|v| v * norm32));
        }
        Ok(Self {
            width,
            height,
            params,
            strides,
            data: out,
            marginal,
            conditional,
            normalized: normalize,
        })
    }

    /// The slices around `param` and their weights: per parameter, the interval holding the
    /// value (clamped to the ends) and the linear weight inside it, clamped to [0, 1].
    fn blend(&self, param: &[f64]) -> Blend {
        let mut blend = Blend {
            slices: [0; MAX_CORNERS],
            weights: [0.0; MAX_CORNERS],
            count: 1,
        };
        blend.weights[0] = 1.0;
        for (dim, values) in self.params.iter().enumerate() {
            if values.len() == 1 {
                continue;
            }
            let p = param.get(dim).copied().unwrap_or(0.0);
            // The last index whose value is below p, within [0, len − 2].
            let below = values.partition_point(|&v| (v as f64) < p);
            let index = below.saturating_sub(1).min(values.len() - 2);
            let (p0, p1) = (values[index] as f64, values[index + 1] as f64);
            let w1 = ((p - p0) / (p1 - p0)).clamp(0.0, 1.0);
            let w1 = if w1.is_nan() { 0.0 } else { w1 };
            let stride = self.strides[dim];
            let n = blend.count;
            for c in 0..n {
                let (s, w) = (blend.slices[c], blend.weights[c]);
                blend.slices[c] = s + stride * index;
                blend.weights[c] = w * (1.0 - w1);
                blend.slices[n + c] = s + stride * (index + 1);
                blend.weights[n + c] = w * w1;
            }
            blend.count = 2 * n;
        }
        blend
    }

    /// Σ over the blended slices of weight × `array[slice · len + index]`.
    #[inline]
    fn fetch(array: &[f32], len: usize, blend: &Blend, index: usize) -> f64 {
        let mut sum = 0.0;
        for c in 0..blend.count {
            let w = blend.weights[c];
            if w != 0.0 {
                sum += w * array[blend.slices[c] * len + index] as f64;
            }
        }
        sum
    }

    /// The four values of the bilinear patch whose corner is (x, y).
    fn patch(&self, blend: &Blend, x: usize, y: usize) -> [f64; 4] {
        let n = self.width * self.height;
        let i = y * self.width + x;
        [
            Self::fetch(&self.data, n, blend, i),
            Self::fetch(&self.data, n, blend, i + 1),
            Self::fetch(&self.data, n, blend, i + self.width),
            Self::fetch(&self.data, n, blend, i + self.width + 1),
        ]
    }

    /// Patch index and position inside it of a point of [0, 1]² (clamped).
    fn locate(&self, pos: [f64; 2]) -> ([usize; 2], [f64; 2]) {
        let scaled = [
            pos[0].clamp(0.0, 1.0) * (self.width - 1) as f64,
            pos[1].clamp(0.0, 1.0) * (self.height - 1) as f64,
        ];
        let cell = [
            (scaled[0] as usize).min(self.width - 2),
            (scaled[1] as usize).min(self.height - 2),
        ];
        (
            cell,
            [scaled[0] - cell[0] as f64, scaled[1] - cell[1] as f64],
        )
    }

    /// The (normalised, when built so) density at `pos` ∈ [0, 1]².
    pub fn eval(&self, pos: [f64; 2], param: &[f64]) -> f64 {
        let blend = self.blend(param);
        let (cell, frac) = self.locate(pos);
        let [v00, v10, v01, v11] = self.patch(&blend, cell[0], cell[1]);
        let c0 = lerp(v00, v01, frac[1]);
        let c1 = lerp(v10, v11, frac[1]);
        lerp(c0, c1, frac[0])
    }

    fn require_cdfs(&self) {
        assert!(
            !self.marginal.is_empty(),
            "Marginal2D built without sampling support"
        );
    }

    /// Conditional CDF of row `y` at column entry `x` (blended).
    #[inline]
    fn conditional_at(&self, blend: &Blend, y: usize, x: usize) -> f64 {
        let len = self.height * (self.width - 1);
        Self::fetch(&self.conditional, len, blend, y * (self.width - 1) + x)
    }

    #[inline]
    fn marginal_at(&self, blend: &Blend, y: usize) -> f64 {
        Self::fetch(&self.marginal, self.height - 1, blend, y)
    }

    /// The point of [0, 1]² that `invert` maps to `u`, and the density there.
    pub fn sample(&self, u: [f64; 2], param: &[f64]) -> ([f64; 2], f64) {
        self.require_cdfs();
        let blend = self.blend(param);
        let eps = f32::EPSILON as f64;
        let mut s = [u[0].clamp(eps, 1.0 - eps), u[1].clamp(eps, 1.0 - eps)];
        let rows = self.height - 1;
        if !self.normalized {
            s[1] *= self.marginal_at(&blend, rows - 1);
        }
        // The first row whose marginal CDF reaches s.y.
        let row = first_false(rows, |i| self.marginal_at(&blend, i) < s[1]).min(rows - 1);
        if row > 0 {
            s[1] -= self.marginal_at(&blend, row - 1);
        }
        let last = self.width - 2;
        let r0 = self.conditional_at(&blend, row, last);
        let r1 = self.conditional_at(&blend, row + 1, last);
        s[1] = sample_segment(s[1], (self.height - 1) as f64, r0, r1);
        s[0] *= lerp(r0, r1, s[1]);
        let conditional = |x: usize| {
            lerp(
                self.conditional_at(&blend, row, x),
                self.conditional_at(&blend, row + 1, x),
                s[1],
            )
        };
        let col = first_false(self.width - 1, |x| conditional(x) < s[0]).min(last);
        if col > 0 {
            s[0] -= conditional(col - 1);
        }
        let [v00, v10, v01, v11] = self.patch(&blend, col, row);
        let c0 = lerp(v00, v01, s[1]);
        let c1 = lerp(v10, v11, s[1]);
        s[0] = sample_segment(s[0], (self.width - 1) as f64, c0, c1);
        (
            [
                (col as f64 + s[0]) / (self.width - 1) as f64,
                (row as f64 + s[1]) / (self.height - 1) as f64,
            ],
            lerp(c0, c1, s[0]),
        )
    }

    /// The uniform point that `sample` maps to `pos`, and the density at `pos`.
    pub fn invert(&self, pos: [f64; 2], param: &[f64]) -> ([f64; 2], f64) {
        self.require_cdfs();
        let blend = self.blend(param);
        let (cell, mut s) = self.locate(pos);
        let [v00, v10, v01, v11] = self.patch(&blend, cell[0], cell[1]);
        let c0 = lerp(v00, v01, s[1]);
        let c1 = lerp(v10, v11, s[1]);
        let pdf = lerp(c0, c1, s[0]);
        let patch = [
            1.0 / (self.width - 1) as f64,
            1.0 / (self.height - 1) as f64,
        ];
        s[0] = invert_segment(s[0], patch[0], c0, c1);
        if cell[0] > 0 {
            s[0] += lerp(
                self.conditional_at(&blend, cell[1], cell[0] - 1),
                self.conditional_at(&blend, cell[1] + 1, cell[0] - 1),
                s[1],
            );
        }
        let last = self.width - 2;
        let r0 = self.conditional_at(&blend, cell[1], last);
        let r1 = self.conditional_at(&blend, cell[1] + 1, last);
        s[0] /= lerp(r0, r1, s[1]);
        s[1] = invert_segment(s[1], patch[1], r0, r1);
        if cell[1] > 0 {
            s[1] += self.marginal_at(&blend, cell[1] - 1);
        }
        if !self.normalized {
            s[1] /= self.marginal_at(&blend, self.height - 2);
        }
        (s, pdf)
    }
}

#[inline]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// The first index in [0, n) where `pred` is false, or n.
fn first_false(n: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Inverts the CDF of a linear density from v0 to v1 over one patch of width 1/inv_width:
/// the fraction of the patch where the integral reaches `sample`.
fn sample_segment(sample: f64, inv_width: f64, v0: f64, v1: f64) -> f64 {
    let non_const = (v0 - v1).abs() > 1e-4 * (v0 + v1);
    let divisor = if non_const { v0 - v1 } else { v0 + v1 };
    let mut s = sample * 2.0 * inv_width;
    if non_const {
        s = v0 - (v0 * v0 + s * (v1 - v0)).max(0.0).sqrt();
    }
    if divisor != 0.0 { s / divisor } else { s }
}

/// The integral of the linear density from v0 to v1 over a fraction `t` of a patch.
fn invert_segment(t: f64, width: f64, v0: f64, v1: f64) -> f64 {
    t * lerp(v0, v1, 0.5 * t) * width
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bumpy(width: usize, height: usize, phase: f32) -> Vec<f32> {
        (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as f32, (i / width) as f32);
                1.0 + (x * 0.7 + phase).sin().powi(2) * 5.0 + (y * 0.3).cos().abs()
            })
            .collect()
    }

    #[test]
    fn sample_and_invert_are_inverse() {
        let warp = Marginal2D::new(&bumpy(7, 5, 0.0), 7, 5, vec![], true, true).unwrap();
        for i in 0..50 {
            let u = [(i as f64 * 0.618).fract(), (i as f64 * 0.377 + 0.1).fract()];
            let (p, pdf) = warp.sample(u, &[]);
            let (back, pdf2) = warp.invert(p, &[]);
            assert!(
                (back[0] - u[0]).abs() < 1e-5 && (back[1] - u[1]).abs() < 1e-5,
                "{u:?} {back:?}"
            );
            assert!((pdf - pdf2).abs() < 1e-5 * pdf.max(1.0));
            assert!((warp.eval(p, &[]) - pdf).abs() < 1e-5 * pdf.max(1.0));
        }
    }

    #[test]
    fn the_normalised_density_integrates_to_one() {
        let warp = Marginal2D::new(&bumpy(9, 6, 1.0), 9, 6, vec![], true, true).unwrap();
        let n = 400;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                sum += warp.eval(
                    [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64],
                    &[],
                );
            }
        }
        assert!(
            (sum / (n * n) as f64 - 1.0).abs() < 1e-3,
            "{}",
            sum / (n * n) as f64
        );
    }

    #[test]
    fn parameters_blend_slices() {
        let (w, h) = (4, 3);
        let mut data = vec![1.0f32; w * h];
        data.extend(vec![3.0f32; w * h]);
        let warp = Marginal2D::new(&data, w, h, vec![vec![0.0, 2.0]], false, false).unwrap();
        assert!((warp.eval([0.3, 0.6], &[0.0]) - 1.0).abs() < 1e-12);
        assert!((warp.eval([0.3, 0.6], &[1.0]) - 2.0).abs() < 1e-12);
        assert!(
            (warp.eval([0.3, 0.6], &[5.0]) - 3.0).abs() < 1e-12,
            "clamped above"
        );
        assert!(
            (warp.eval([0.3, 0.6], &[-1.0]) - 1.0).abs() < 1e-12,
            "clamped below"
        );
        assert!(Marginal2D::new(&data, 1, 24, vec![vec![0.0, 2.0]], false, false).is_err());
        assert!(Marginal2D::new(&[0.0; 12], 4, 3, vec![], true, true).is_err());
    }
}
