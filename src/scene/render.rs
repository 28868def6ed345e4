//! Images made from the geometry buffer: the guide the artist paints over, and renders of a
//! BRDF exactly as a perfect painter would paint them (TABLE.md: L = π · ρ · cos θ_l).

use super::gbuffer::{GBuffer, SurfacePoint};
use crate::brdf::Brdf;
use crate::image_io::RgbImage;
use crate::table::{SymTable, direction_index};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The guide's grey Lambertian albedo: mid-grey, so the artist can paint lighter and darker.
/// A lit guide pixel shows π · (albedo / π) · cos θ_l = albedo · cos θ_l.
pub const GUIDE_ALBEDO: f32 = 0.5;
/// Linear colour of points the light does not reach (cast or attached shadow): a small
/// ambient, darker than almost all of the lit surface (sRGB ≈ 40 / 255).
pub const SHADOW: [f32; 3] = [0.02, 0.02, 0.02];
/// Linear colour off the object: a dark blue-grey, distinct from grey shading and shadow.
pub const BACKGROUND: [f32; 3] = [0.03, 0.04, 0.075];
/// How high above the horizon a view direction that dips below it is lifted when rendering
/// (tan of the elevation): enough to land in the last polar bin, never above it.
const HORIZON_LIFT: f64 = 1e-3;

/// The guide colour of one pixel: background, shadow, or albedo · cos θ_l.
pub fn guide_pixel(point: Option<&SurfacePoint>) -> [f32; 3] {
    match point {
        None => BACKGROUND,
        Some(p) if p.is_lit() => [GUIDE_ALBEDO * p.cos_light(); 3],
        Some(_) => SHADOW,
    }
}

/// The guide image: grey diffuse shading, shadows and background (linear RGB).
pub fn guide_image(gbuffer: &GBuffer) -> RgbImage {
    map_pixels(gbuffer, guide_pixel)
}

/// The object as a table BRDF shows it: π · ρ(d_l, d_v) · cos θ_l with the bins the geometry
/// buffer names and cos θ_l of the pixel's actual light direction; shadow and background as
/// in the guide. Where the shading normal turns away from the camera (silhouettes) the view
/// direction is lifted onto the horizon, into the last polar bin, so renders have no holes.
pub fn render_table(gbuffer: &GBuffer, table: &SymTable) -> RgbImage {
    map_pixels(gbuffer, |point| {
        shade(point, |p| {
            let d_l = p.light_bin?;
            let d_v = p
                .view_bin
                .or_else(|| view_above_horizon(p).and_then(direction_index))?;
            Some(table.get(d_l, d_v).map(f64::from))
        })
    })
}

/// The object as an analytic BRDF shows it, evaluated at each pixel's exact directions
/// (view lifted onto the horizon where it dips below, as in [`render_table`]).
pub fn render_brdf(gbuffer: &GBuffer, brdf: &dyn Brdf) -> RgbImage {
    map_pixels(gbuffer, |point| {
        shade(point, |p| {
            let l = p.light.as_dvec3().normalize();
            Some(brdf.eval(l, view_above_horizon(p)?))
        })
    })
}

/// Background, shadow, or π · ρ · cos θ_l with ρ from `rho` (shadow colour when it has none).
fn shade(
    point: Option<&SurfacePoint>,
    rho: impl Fn(&SurfacePoint) -> Option<[f64; 3]>,
) -> [f32; 3] {
    match point {
        None => BACKGROUND,
        Some(p) if p.is_lit() => match rho(p) {
            Some(rho) => {
                let scale = PI * p.cos_light() as f64;
                rho.map(|c| {
                    let v = (scale * c) as f32;
                    if v.is_finite() && v > 0.0 { v } else { 0.0 }
                })
            }
            None => SHADOW,
        },
        Some(_) => SHADOW,
    }
}

/// The unit view direction, lifted just above the horizon when it lies on or below it;
/// `None` only when it points straight into the surface.
fn view_above_horizon(p: &SurfacePoint) -> Option<DVec3> {
    let v = p.view.as_dvec3();
    if v.z > 0.0 {
        return Some(v.normalize());
    }
    let horizontal = DVec3::new(v.x, v.y, 0.0).try_normalize()?;
    Some((horizontal + DVec3::Z * HORIZON_LIFT).normalize())
}

fn map_pixels(gbuffer: &GBuffer, f: impl Fn(Option<&SurfacePoint>) -> [f32; 3] + Sync) -> RgbImage {
    let n = gbuffer.resolution();
    let pixels = gbuffer
        .pixels()
        .par_iter()
        .with_min_len(1024)
        .map(|p| f(p.as_ref()))
        .collect();
    RgbImage {
        width: n,
        height: n,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{DirIndex, PHI_BINS};
    use glam::Vec3;

    /// The bin a below-horizon view direction is rendered with.
    fn lifted_bin(p: &SurfacePoint) -> Option<DirIndex> {
        view_above_horizon(p).and_then(direction_index)
    }

    #[test]
    fn lifted_view_lands_in_the_last_polar_bin() {
        let point = SurfacePoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            tangent: Vec3::X,
            light: Vec3::Z,
            view: Vec3::new(0.0, 0.99, -0.1).normalize(),
            light_bin: Some(0),
            view_bin: None,
            in_shadow: false,
        };
        let d = lifted_bin(&point).unwrap();
        assert_eq!(d as usize / PHI_BINS, 44);
        assert_eq!(d as usize % PHI_BINS, 9, "φ = 90° is in azimuth bin 9");
        let straight_in = SurfacePoint {
            view: -Vec3::Z,
            ..point
        };
        assert_eq!(lifted_bin(&straight_in), None);
        assert_eq!(guide_pixel(Some(&point)), [GUIDE_ALBEDO; 3]);
        assert_eq!(
            guide_pixel(Some(&SurfacePoint {
                in_shadow: true,
                ..point
            })),
            SHADOW
        );
        assert_eq!(guide_pixel(None), BACKGROUND);
    }
}
