//! What the inspection views show, computed from a BRDF: the lobe in the plane of
//! incidence, and a thumbnail of the whole table (the paper's Figure 4).

use crate::image_io::RgbImage;
use crate::solver::Reconstruction;
use crate::table::{DIRECTIONS, DirIndex, Rgb, direction_index};
use glam::DVec3;
use rayon::prelude::*;

/// ρ in the plane of incidence for light at (θ_i, φ_i): one point per 1° of signed outgoing
/// angle, −89°..=89°, negative on the light's side (back-scatter), positive toward the mirror
/// direction. Each point is the value of the bin the direction falls in.
pub fn incidence_plane(
    recon: &Reconstruction,
    theta_i_deg: f64,
    phi_i_deg: f64,
) -> Vec<(f64, Rgb)> {
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
            Some((signed as f64, recon.eval(d_l, d_v)))
        })
        .collect()
}

fn direction(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// The table as an image `size × size` (x = view direction, y = light direction, as in the
/// EXR), each pixel the mean ρ·cos θ_l·cos θ_v of the entries it covers, tone-mapped as
/// log10 over four decades and sRGB-ready in [0, 1]. Only the entries at the block centres
/// are evaluated (`size²`, not 2.6 million).
pub fn table_thumbnail(recon: &Reconstruction, size: usize) -> RgbImage {
    let size = size.clamp(1, DIRECTIONS);
    let step = DIRECTIONS as f64 / size as f64;
    let centre = |i: usize| (((i as f64 + 0.5) * step) as usize).min(DIRECTIONS - 1) as DirIndex;
    let pixels: Vec<[f32; 3]> = (0..size * size)
        .into_par_iter()
        .map(|i| {
            let (d_l, d_v) = (centre(i / size), centre(i % size));
            let rho = recon.eval(d_l, d_v);
            let c = crate::table::cos_theta_centre(d_l) * crate::table::cos_theta_centre(d_v);
            rho.map(|r| log_tone(r as f64 * c))
        })
        .collect();
    RgbImage {
        width: size,
        height: size,
        pixels,
    }
}

/// log10 over [1e-4, 1] mapped to [0, 1].
pub fn log_tone(value: f64) -> f32 {
    ((value.max(1e-12).log10() + 4.0) / 4.0).clamp(0.0, 1.0) as f32
}

/// Where the observed bins fall in a `size × size` thumbnail of the table: per pixel, whether
/// any observed pair lies in it.
pub fn observed_mask(observed: impl Iterator<Item = u32>, size: usize) -> Vec<bool> {
    let size = size.clamp(1, DIRECTIONS);
    let mut mask = vec![false; size * size];
    for pair in observed {
        let (a, b) = crate::table::pair_directions(pair as usize);
        for (l, v) in [(a, b), (b, a)] {
            let x = v as usize * size / DIRECTIONS;
            let y = l as usize * size / DIRECTIONS;
            mask[y * size + x] = true;
        }
    }
    mask
}
