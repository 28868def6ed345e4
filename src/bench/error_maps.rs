//! Error maps: where in the table a reconstruction is wrong. One PNG per held-out material and
//! configuration, four panels side by side, each the whole 1620 × 1620 table (x the view
//! direction, y the light direction, as in the EXR and the paper's Figure 4) at one pixel per
//! `1620 / PANEL` bins:
//!
//! 1. the truth, log10 of luminance × cos θ_l cos θ_v through viridis;
//! 2. the estimate, on the same scale;
//! 3. the log error ln(estimate / truth) of that quantity: blue too dark, red too bright,
//!    white right, saturated at a factor of e²;
//! 4. the observed bins (white) over the truth dimmed to a quarter.

use crate::image_io::RgbImage;
use crate::inspect::{TableImage, TableWindow, luminance};
use crate::table::{DIRECTIONS, PairIndex, SymTable, cos_theta_centre};
use rayon::prelude::*;
use std::collections::HashSet;
use std::path::Path;

/// Pixels along each side of a panel.
pub const PANEL: usize = 405;
/// Grey between panels, in pixels.
const GAP: usize = 6;

/// The four panels of one reconstruction, as linear RGB (written as an sRGB PNG).
pub fn error_map(truth: &SymTable, estimate: &SymTable, observed: &HashSet<PairIndex>) -> RgbImage {
    let window = TableWindow::FULL;
    let lookup_truth = |l, v| truth.get(l, v);
    let lookup_estimate = |l, v| estimate.get(l, v);
    let truth_image = TableImage::new(&lookup_truth, window, PANEL, PANEL);
    let estimate_image = TableImage::new(&lookup_estimate, window, PANEL, PANEL);
    let range = truth_image.log_range(6);
    let to_linear = |c: [u8; 3]| c.map(|v| crate::scene::srgb_decode(v as f32 / 255.0));
    let truth_colours: Vec<[f32; 3]> = truth_image
        .colours(range)
        .into_iter()
        .map(to_linear)
        .collect();
    let estimate_colours: Vec<[f32; 3]> = estimate_image
        .colours(range)
        .into_iter()
        .map(to_linear)
        .collect();
    let pixels_of = |f: &(dyn Fn(usize, usize) -> [f32; 3] + Sync)| -> Vec<[f32; 3]> {
        (0..PANEL * PANEL)
            .into_par_iter()
            .map(|i| f(i % PANEL, i / PANEL))
            .collect()
    };
    let error = pixels_of(&|x, y| {
        let (l, v) = window.bins_at(x, y, PANEL, PANEL);
        let c = cos_theta_centre(l) * cos_theta_centre(v);
        let floor = 1e-4;
        let t = luminance(truth.get(l, v)) * c + floor;
        let e = luminance(estimate.get(l, v)) * c + floor;
        diverging((e / t).ln() / 2.0)
    });
    let observed_panel = pixels_of(&|x, y| {
        let (l, v) = window.bins_at(x, y, PANEL, PANEL);
        let pair = crate::table::pair_index(l, v);
        if observed.contains(&pair) {
            [1.0; 3]
        } else {
            truth_colours[y * PANEL + x].map(|c| 0.25 * c)
        }
    });
    let width = 4 * PANEL + 3 * GAP;
    let mut pixels = vec![[0.2f32; 3]; width * PANEL];
    for (panel, source) in [&truth_colours, &estimate_colours, &error, &observed_panel]
        .into_iter()
        .enumerate()
    {
        let x0 = panel * (PANEL + GAP);
        for y in 0..PANEL {
            pixels[y * width + x0..y * width + x0 + PANEL]
                .copy_from_slice(&source[y * PANEL..(y + 1) * PANEL]);
        }
    }
    debug_assert_eq!(DIRECTIONS % PANEL, 0);
    RgbImage {
        width,
        height: PANEL,
        pixels,
    }
}

/// Blue (−1) through white (0) to red (+1), linear RGB.
fn diverging(t: f64) -> [f32; 3] {
    let t = t.clamp(-1.0, 1.0) as f32;
    if t >= 0.0 {
        [1.0, 1.0 - t, 1.0 - t]
    } else {
        [1.0 + t, 1.0 + t, 1.0]
    }
}

/// Writes [`error_map`] as a PNG.
pub fn write_error_map(
    path: &Path,
    truth: &SymTable,
    estimate: &SymTable,
    observed: &HashSet<PairIndex>,
) -> crate::Result<()> {
    crate::scene::write_png(path, &error_map(truth, estimate, observed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_perfect_estimate_maps_to_white_error_and_marks_observed_bins() {
        let truth = SymTable::filled([0.2, 0.3, 0.4]);
        // The bin that the top-left pixel of a panel shows.
        let (l, v) = TableWindow::FULL.bins_at(0, 0, PANEL, PANEL);
        let observed: HashSet<PairIndex> = [crate::table::pair_index(l, v)].into();
        let map = error_map(&truth, &truth, &observed);
        assert_eq!(map.width, 4 * PANEL + 3 * GAP);
        let error_panel = 2 * (PANEL + GAP);
        assert_eq!(map.pixels[error_panel + PANEL / 2], [1.0; 3]);
        assert_eq!(map.pixels[3 * (PANEL + GAP)], [1.0; 3]);
        let darker = SymTable::filled([0.02, 0.03, 0.04]);
        let map = error_map(&truth, &darker, &observed);
        let p = map.pixels[error_panel + PANEL / 2];
        assert!(p[2] == 1.0 && p[0] < 1.0, "too dark shows blue: {p:?}");
    }
}
