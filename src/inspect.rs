//! What the inspection views show, computed from a BRDF: the lobe in the plane of
//! incidence, and images of the table (the paper's Figure 4) with a perceptual colour map and
//! overlays. Everything takes the BRDF as a lookup `ρ(d_l, d_v)`, so that the reconstruction
//! and a reference table are shown alike.

use crate::table::{
    DIRECTIONS, DirIndex, PairIndex, Rgb, bin_angles, direction_index, pair_directions,
};
use glam::DVec3;
use rayon::prelude::*;

/// ρ for a light bin and a view bin.
pub type Lookup<'a> = dyn Fn(DirIndex, DirIndex) -> Rgb + Sync + 'a;

/// ρ in the plane of incidence for light at (θ_i, φ_i): one point per 1° of signed outgoing
/// angle, −89°..=89°, negative on the light's side (back-scatter), positive toward the mirror
/// direction. Each point is the value of the bin the direction falls in.
pub fn incidence_plane(rho: &Lookup, theta_i_deg: f64, phi_i_deg: f64) -> Vec<(f64, Rgb)> {
    let light = direction(theta_i_deg, phi_i_deg);
    let Some(d_l) = direction_index(light) else {
        return Vec::new();
    };
    (-89..=89)
        .filter_map(|signed| {
            let theta_o = (signed as f64).abs();
            let phi_o = if signed < 0 {
                phi_i_deg
            } else {
                phi_i_deg + 180.0
            };
            let d_v = direction_index(direction(theta_o, phi_o))?;
            Some((signed as f64, rho(d_l, d_v)))
        })
        .collect()
}

fn direction(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: Rgb) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

/// How the lobe plot's radius shows ρ·cos θ_out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LobeScale {
    /// The radius is the value.
    #[default]
    Linear,
    /// The radius is log10 of the value above a floor `decades` below the largest value
    /// plotted, so that the faint tail and the peak show together.
    Log { decades: u8 },
}

/// Where the lobe plot's radius starts for values `v`: the log floor, or 0 (linear).
pub fn lobe_floor(scale: LobeScale, largest: f64) -> f64 {
    match scale {
        LobeScale::Linear => 0.0,
        LobeScale::Log { decades } => largest.max(1e-12).log10().ceil() - f64::from(decades.max(1)),
    }
}

/// The radius a value ρ·cos θ_out is drawn at (see [`LobeScale`]); `floor` from [`lobe_floor`].
pub fn lobe_radius(scale: LobeScale, value: f64, floor: f64) -> f64 {
    match scale {
        LobeScale::Linear => value.max(0.0),
        LobeScale::Log { .. } => (value.max(1e-30).log10() - floor).max(0.0),
    }
}

/// The polar curve of one channel (or luminance, `channel` = None) of an incidence-plane
/// lobe: points (x, y) with the outgoing angle from the normal (+y) and the radius of
/// ρ·cos θ_out on `scale` (light from the left, so back-scatter is drawn on the left).
pub fn lobe_curve(
    points: &[(f64, Rgb)],
    channel: Option<usize>,
    scale: LobeScale,
    floor: f64,
) -> Vec<[f64; 2]> {
    points
        .iter()
        .map(|(signed, rho)| {
            let t = signed.to_radians();
            let value = match channel {
                Some(c) => rho[c] as f64,
                None => luminance(*rho),
            } * t.cos();
            let r = lobe_radius(scale, value, floor);
            [r * t.sin(), r * t.cos()]
        })
        .collect()
}

/// The largest ρ·cos θ_out of the lobes, over every channel: what [`lobe_floor`] and the
/// plot's autoscale start from.
pub fn lobe_peak<'a>(lobes: impl IntoIterator<Item = &'a [(f64, Rgb)]>) -> f64 {
    lobes
        .into_iter()
        .flatten()
        .map(|(signed, rho)| {
            let c = signed.to_radians().cos();
            rho.iter().map(|&v| v as f64 * c).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

/// The smallest box (min, max) holding every curve and the origin, with a margin of 5% of
/// its larger side: the lobe plot's bounds, so that no lobe runs out of it.
pub fn curves_bounds<'a>(curves: impl IntoIterator<Item = &'a [[f64; 2]]>) -> ([f64; 2], [f64; 2]) {
    let mut min = [0.0f64, 0.0];
    let mut max = [0.0f64, 0.0];
    for p in curves.into_iter().flatten() {
        for k in 0..2 {
            if p[k].is_finite() {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
    }
    let side = (max[0] - min[0]).max(max[1] - min[1]).max(1e-9);
    let margin = 0.05 * side;
    (
        [min[0] - margin, min[1] - margin],
        [max[0] + margin, max[1] + margin],
    )
}

/// A window onto the table in bin units: x the view direction, y the light direction (row 0
/// at the top, as in the EXR), each in [0, 1620].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableWindow {
    pub x: [f64; 2],
    pub y: [f64; 2],
}

impl TableWindow {
    /// The whole table.
    pub const FULL: Self = Self {
        x: [0.0, DIRECTIONS as f64],
        y: [0.0, DIRECTIONS as f64],
    };

    /// This window clipped to the table, at least a bin on each side.
    pub fn clipped(self) -> Self {
        let clip = |[a, b]: [f64; 2]| {
            let n = DIRECTIONS as f64;
            let (lo, hi) = (a.min(b).clamp(0.0, n - 1.0), a.max(b).clamp(1.0, n));
            if hi - lo < 1.0 {
                [lo, lo + 1.0]
            } else {
                [lo, hi]
            }
        };
        Self {
            x: clip(self.x),
            y: clip(self.y),
        }
    }

    /// The (light, view) bins under pixel (column, row) of a `width × height` image of it.
    pub fn bins_at(
        &self,
        column: usize,
        row: usize,
        width: usize,
        height: usize,
    ) -> (DirIndex, DirIndex) {
        let at = |[a, b]: [f64; 2], i: usize, n: usize| {
            let v = a + (i as f64 + 0.5) * (b - a) / n as f64;
            (v.floor().max(0.0) as usize).min(DIRECTIONS - 1) as DirIndex
        };
        (at(self.y, row, height), at(self.x, column, width))
    }

    /// The pixel of a `width × height` image of this window that shows (light, view), if any.
    pub fn pixel_of(
        &self,
        d_l: DirIndex,
        d_v: DirIndex,
        width: usize,
        height: usize,
    ) -> Option<(usize, usize)> {
        let at = |[a, b]: [f64; 2], d: DirIndex, n: usize| {
            // The bin's centre.
            let f = (d as f64 + 0.5 - a) / (b - a);
            (0.0..1.0)
                .contains(&f)
                .then(|| ((f * n as f64) as usize).min(n - 1))
        };
        Some((at(self.x, d_v, width)?, at(self.y, d_l, height)?))
    }
}

/// An image of a window onto the table: per pixel log10 of the luminance of
/// ρ·cos θ_l·cos θ_v at the bin under its centre (−∞ where that is 0).
#[derive(Clone, Debug, PartialEq)]
pub struct TableImage {
    pub width: usize,
    pub height: usize,
    pub window: TableWindow,
    pub log_values: Vec<f32>,
}

impl TableImage {
    pub fn new(rho: &Lookup, window: TableWindow, width: usize, height: usize) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let log_values = (0..width * height)
            .into_par_iter()
            .map(|i| {
                let (d_l, d_v) = window.bins_at(i % width, i / width, width, height);
                let c = crate::table::cos_theta_centre(d_l) * crate::table::cos_theta_centre(d_v);
                (luminance(rho(d_l, d_v)) * c).log10() as f32
            })
            .collect();
        Self {
            width,
            height,
            window,
            log_values,
        }
    }

    /// The colour bar's range in log10: whole decades around the finite values, at most
    /// `decades` of them below the top (so that a few near-zero bins do not wash it out).
    pub fn log_range(&self, decades: u8) -> (f32, f32) {
        let finite = self.log_values.iter().filter(|v| v.is_finite());
        let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
        if !(lo.is_finite() && hi.is_finite()) {
            return (-4.0, 0.0);
        }
        let top = hi.ceil().max(lo.floor() + 1.0);
        (lo.floor().max(top - f32::from(decades.max(1))), top)
    }

    /// sRGB bytes per pixel through [`viridis`] over `range` (log10).
    pub fn colours(&self, range: (f32, f32)) -> Vec<[u8; 3]> {
        self.log_values
            .par_iter()
            .map(|&v| {
                let t = if v.is_finite() {
                    (v - range.0) / (range.1 - range.0)
                } else {
                    0.0
                };
                viridis(t).map(|c| (c * 255.0).round() as u8)
            })
            .collect()
    }
}

/// The viridis colour map (perceptually uniform, readable in grey and by the colour blind) at
/// t ∈ [0, 1], as display (sRGB-encoded) values: the polynomial fit of Matt Zucker's
/// (public domain), within about 1/255 of the original table.
pub fn viridis(t: f32) -> [f32; 3] {
    const C: [[f64; 3]; 7] = [
        [
            0.277_727_327_223_417_7,
            0.005_407_344_544_966_578,
            0.334_099_805_335_306_1,
        ],
        [
            0.105_093_043_108_577_4,
            1.404_613_529_898_575,
            1.384_590_162_594_685,
        ],
        [
            -0.330_861_828_725_556_3,
            0.214_847_559_468_213,
            0.095_095_163_028_236_59,
        ],
        [
            -4.634_230_498_983_486,
            -5.799_100_973_351_585,
            -19.332_440_956_279_87,
        ],
        [
            6.228_269_936_347_081,
            14.179_933_366_805_09,
            56.690_552_600_681_05,
        ],
        [
            4.776_384_997_670_288,
            -13.745_145_377_746_01,
            -65.353_032_633_372_34,
        ],
        [
            -5.435_455_855_934_631,
            4.645_852_612_178_535,
            26.312_435_249_583_2,
        ],
    ];
    let t = f64::from(t.clamp(0.0, 1.0));
    std::array::from_fn(|k| {
        let v = C.iter().rev().fold(0.0, |acc, c| acc * t + c[k]);
        v.clamp(0.0, 1.0) as f32
    })
}

/// Which pixels of a `width × height` image of `window` hold any of `pairs` (each pair is
/// drawn at both of its (light, view) orders: the table is reciprocal).
pub fn pair_marks(
    pairs: impl Iterator<Item = PairIndex>,
    window: TableWindow,
    width: usize,
    height: usize,
) -> Vec<bool> {
    let mut mask = vec![false; width * height];
    for pair in pairs {
        let (a, b) = pair_directions(pair);
        for (l, v) in [(a, b), (b, a)] {
            if let Some((x, y)) = window.pixel_of(l, v, width, height) {
                mask[y * width + x] = true;
            }
        }
    }
    mask
}

/// Where the per-pair standard deviation `std_dev` (one value per unordered pair, in units
/// of ρ) is large against ρ itself: per pixel of a `width × height` image of `window`, the
/// relative uncertainty σ / (ρ + 10⁻⁴) of the luminance at the bin under the pixel, clamped
/// to [0, 1]. `None` when the array does not hold one value per pair.
pub fn relative_uncertainty(
    std_dev: &[f32],
    rho: &Lookup,
    window: TableWindow,
    width: usize,
    height: usize,
) -> Option<Vec<f32>> {
    if std_dev.len() != crate::table::PAIRS {
        return None;
    }
    Some(
        (0..width * height)
            .into_par_iter()
            .map(|i| {
                let (d_l, d_v) = window.bins_at(i % width, i / width, width, height);
                let sigma = std_dev[crate::table::pair_index(d_l, d_v).index()];
                let value = luminance(rho(d_l, d_v));
                if sigma.is_finite() {
                    (sigma as f64 / (value + 1e-4)).clamp(0.0, 1.0) as f32
                } else {
                    1.0
                }
            })
            .collect(),
    )
}

/// (θ_l, φ_l, θ_v, φ_v) in degrees at the centres of a light and a view bin.
pub fn bin_pair_angles(d_l: DirIndex, d_v: DirIndex) -> [f64; 4] {
    let (tl, pl) = bin_angles(d_l);
    let (tv, pv) = bin_angles(d_v);
    [tl, pl, tv, pv].map(f64::to_degrees)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{PAIRS, pair_index};

    #[test]
    fn viridis_runs_dark_blue_to_yellow_with_rising_lightness() {
        let start = viridis(0.0);
        let end = viridis(1.0);
        assert!(
            (start[0] - 0.267).abs() < 0.02 && (start[2] - 0.329).abs() < 0.02,
            "{start:?}"
        );
        assert!(
            (end[0] - 0.993).abs() < 0.02 && (end[1] - 0.906).abs() < 0.02,
            "{end:?}"
        );
        let lightness = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let mut last = -1.0;
        for i in 0..=64 {
            let l = lightness(viridis(i as f32 / 64.0));
            assert!(l > last, "lightness falls at {i}");
            last = l;
        }
    }

    #[test]
    fn windows_map_bins_to_pixels_and_back() {
        let full = TableWindow::FULL;
        assert_eq!(full.bins_at(0, 0, 1620, 1620), (0, 0));
        assert_eq!(full.bins_at(1619, 3, 1620, 1620), (3, 1619));
        assert_eq!(full.pixel_of(3, 1619, 1620, 1620), Some((1619, 3)));
        // Zoomed: 10 bins across 100 pixels.
        let zoomed = TableWindow {
            x: [100.0, 110.0],
            y: [50.0, 60.0],
        };
        assert_eq!(zoomed.bins_at(0, 99, 100, 100), (59, 100));
        assert_eq!(zoomed.pixel_of(55, 105, 100, 100), Some((55, 55)));
        assert_eq!(zoomed.pixel_of(49, 105, 100, 100), None);
        let clipped = TableWindow {
            x: [-50.0, 5000.0],
            y: [7.0, 7.2],
        }
        .clipped();
        assert_eq!(clipped.x, [0.0, 1620.0]);
        assert!((clipped.y[1] - clipped.y[0] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn marks_show_both_orders_of_a_pair() {
        let pair = pair_index(30, 900);
        let mask = pair_marks([pair].into_iter(), TableWindow::FULL, 162, 162);
        assert_eq!(mask.iter().filter(|&&m| m).count(), 2);
        assert!(mask[3 * 162 + 90] && mask[90 * 162 + 3]);
    }

    #[test]
    fn the_uncertainty_overlay_takes_a_per_pair_array() {
        let rho = |_: DirIndex, _: DirIndex| [0.5f32; 3];
        let window = TableWindow::FULL;
        assert!(relative_uncertainty(&[0.1; 10], &rho, window, 8, 8).is_none());
        let mut sigma = vec![0.0f32; PAIRS];
        // One uncertain pair: the light bin 0 with the view bin 0, at the top-left pixel.
        sigma[pair_index(0, 0).index()] = 0.25;
        let overlay = relative_uncertainty(&sigma, &rho, window, 1620, 1620).unwrap();
        assert!((overlay[0] - 0.25 / 0.5001).abs() < 1e-4, "{}", overlay[0]);
        assert_eq!(overlay[1], 0.0);
    }

    #[test]
    fn table_images_and_their_colour_range() {
        let rho = |l: DirIndex, v: DirIndex| [(1 + l % 7 + v % 5) as f32 * 0.01; 3];
        let image = TableImage::new(&rho, TableWindow::FULL, 81, 81);
        assert!(image.log_values.iter().all(|v| v.is_finite()));
        let (lo, hi) = image.log_range(6);
        assert!(lo < hi && hi - lo <= 6.0 && lo == lo.floor() && hi == hi.ceil());
        let colours = image.colours((lo, hi));
        assert_eq!(colours.len(), 81 * 81);
        // Black (ρ = 0) maps to the bottom of the bar, not to NaN.
        let black = TableImage::new(&|_, _| [0.0; 3], TableWindow::FULL, 4, 4);
        assert_eq!(black.log_range(4), (-4.0, 0.0));
        let bottom = viridis(0.0).map(|c| (c * 255.0).round() as u8);
        assert!(black.colours((-4.0, 0.0)).iter().all(|c| *c == bottom));
    }

    #[test]
    fn lobes_autoscale_and_log_scale() {
        let points = vec![
            (-30.0, [0.1f32, 0.2, 0.3]),
            (0.0, [1.0, 2.0, 3.0]),
            (45.0, [10.0, 5.0, 1.0]),
        ];
        let peak = lobe_peak([&points[..]]);
        assert!((peak - 10.0 * 45f64.to_radians().cos()).abs() < 1e-6);
        let curve = lobe_curve(&points, Some(0), LobeScale::Linear, 0.0);
        let (min, max) = curves_bounds([&curve[..]]);
        for p in &curve {
            assert!(p[0] >= min[0] && p[0] <= max[0] && p[1] >= min[1] && p[1] <= max[1]);
        }
        let log = LobeScale::Log { decades: 3 };
        let floor = lobe_floor(log, peak);
        assert_eq!(floor, 1.0 - 3.0);
        // 0.1 · cos 30° is about 10^-1.06: radius about 0.94 above a floor of 10^-2.
        let r = lobe_radius(log, 0.1 * 30f64.to_radians().cos(), floor);
        assert!((r - (0.0866f64.log10() + 2.0)).abs() < 1e-3, "{r}");
        assert_eq!(lobe_radius(log, 1e-9, floor), 0.0);
    }
}
