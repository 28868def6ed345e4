//! The preview's environment light: an HDR equirectangular image around the object, and the
//! directions the scene pass samples it at.
//!
//! The image maps x to the azimuth (SCENE.md's: 0 toward +z, 90° toward +x, the left edge
//! at 0) and y to the polar angle from +y (the top row looks straight up). The preview does not
//! integrate the image per pixel; it draws [`Environment::samples`]: directions importance
//! sampled in proportion to luminance × solid angle, each a directional light of irradiance
//! `L / (N · pdf)`, which the scene pass evaluates through the BRDF table like any other light.

use crate::error::{Error, Result};
use crate::image_io::RgbImage;
use glam::DVec3;
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// An equirectangular HDR image of linear radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Shown in the UI: "studio", a file name.
    pub name: String,
    image: RgbImage,
}

/// One sampled direction: unit world direction toward the environment and its irradiance
/// weight (radiance × solid angle) per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentSample {
    pub direction: DVec3,
    pub weight: [f64; 3],
}

/// Width and height of the bundled studio image.
const STUDIO_SIZE: (usize, usize) = (512, 256);

/// A soft-edged rectangle of light in (elevation, azimuth) degrees.
struct Softbox {
    elevation: f64,
    azimuth: f64,
    /// Half extents in degrees: along the azimuth, along the elevation.
    half_width: f64,
    half_height: f64,
    radiance: [f64; 3],
}

/// The bundled studio: a key, a fill, a top and a rim softbox over a dim backdrop and floor.
const SOFTBOXES: [Softbox; 4] = [
    Softbox {
        elevation: 35.0,
        azimuth: 45.0,
        half_width: 16.0,
        half_height: 20.0,
        radiance: [7.0, 6.6, 6.0],
    },
    Softbox {
        elevation: 12.0,
        azimuth: -70.0,
        half_width: 22.0,
        half_height: 12.0,
        radiance: [1.6, 1.8, 2.1],
    },
    Softbox {
        elevation: 78.0,
        azimuth: 0.0,
        half_width: 40.0,
        half_height: 8.0,
        radiance: [3.0, 3.0, 3.0],
    },
    Softbox {
        elevation: 20.0,
        azimuth: 175.0,
        half_width: 5.0,
        half_height: 26.0,
        radiance: [5.0, 5.0, 5.0],
    },
];

impl Environment {
    /// Wraps an equirectangular image; the problem, as a sentence, unless it is at least
    /// 2 × 1 pixels of finite, non-negative radiance with some light in it.
    pub fn from_image(
        name: impl Into<String>,
        image: RgbImage,
    ) -> std::result::Result<Self, String> {
        if image.width < 2 || image.height < 1 || image.pixels.len() != image.width * image.height {
            return Err(format!(
                "an environment image needs at least 2 × 1 pixels (this one is {} × {})",
                image.width, image.height
            ));
        }
        if let Some(i) = image
            .pixels
            .iter()
            .position(|p| p.iter().any(|c| !(c.is_finite() && *c >= 0.0)))
        {
            return Err(format!(
                "pixel ({}, {}) is {:?}; radiance must be finite and ≥ 0",
                i % image.width,
                i / image.width,
                image.pixels[i]
            ));
        }
        if image.pixels.iter().all(|p| luminance(*p) <= 0.0) {
            return Err("the environment image is black: it would light nothing".into());
        }
        Ok(Self {
            name: name.into(),
            image,
        })
    }

    /// An equirectangular OpenEXR file (any width and height; 2:1 is usual).
    pub fn from_exr(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let image = crate::image_io::read_exr_rgb(path)?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        Self::from_image(name, image).map_err(|problem| Error::invalid(path, problem))
    }

    /// Writes the image as an OpenEXR file, atomically.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<()> {
        crate::image_io::write_exr_rgb(path, &self.image)
    }

    /// The bundled studio, made here: four softboxes (key, fill, top, rim) over a dim
    /// graded backdrop and a darker floor. Deterministic, so every machine lights alike.
    pub fn studio() -> Self {
        let (width, height) = STUDIO_SIZE;
        let pixels = (0..width * height)
            .map(|i| {
                let (elevation, azimuth) = pixel_angles(i % width, i / width, width, height);
                studio_radiance(elevation, azimuth).map(|c| c as f32)
            })
            .collect();
        Self {
            name: "studio".into(),
            image: RgbImage {
                width,
                height,
                pixels,
            },
        }
    }

    /// A uniform sky of `radiance` over the upper hemisphere (world +y), black below: a white
    /// Lambertian surface facing straight up shows `radiance`.
    pub fn uniform_sky(radiance: f32) -> Self {
        let (width, height) = (64, 32);
        let pixels = (0..width * height)
            .map(|i| {
                if i / width < height / 2 {
                    [radiance; 3]
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        Self {
            name: "uniform sky".into(),
            image: RgbImage {
                width,
                height,
                pixels,
            },
        }
    }

    pub fn image(&self) -> &RgbImage {
        &self.image
    }

    /// `count` directions importance-sampled by luminance × solid angle, through the inverse
    /// CDFs of the rows and, within a row, of its pixels, at the points of the Halton sequence
    /// in bases 2 and 3 (deterministic, and every prefix is evenly spread: the first quarter is
    /// a good set of its own, which the preview's draft uses). Each sample's weight is
    /// `L / (count · pdf)`, so `Σ weight · f(direction)` estimates `∫ L f dω`.
    pub fn samples(&self, count: usize) -> Vec<EnvironmentSample> {
        let (w, h) = (self.image.width, self.image.height);
        if count == 0 {
            return Vec::new();
        }
        // Probability mass per pixel ∝ luminance × sin θ (the pixel's solid angle).
        let row_sin: Vec<f64> = (0..h)
            .map(|y| ((y as f64 + 0.5) / h as f64 * PI).sin())
            .collect();
        let mass: Vec<f64> = (0..w * h)
            .map(|i| luminance(self.image.pixels[i]) * row_sin[i / w])
            .collect();
        let row_mass: Vec<f64> = mass.chunks_exact(w).map(|r| r.iter().sum()).collect();
        let total: f64 = row_mass.iter().sum();
        // A black image (from_image refuses one) or a NaN sum: nothing to sample.
        if total.is_nan() || total <= 0.0 {
            return Vec::new();
        }
        let row_cdf = cumulative(&row_mass);
        // Solid angle of a pixel divided by sin θ.
        let cell = (PI / h as f64) * (TAU / w as f64);
        (0..count)
            .map(|i| {
                let u = radical_inverse(i as u32 + 1, 2);
                let v = radical_inverse(i as u32 + 1, 3);
                let (row, row_offset) = invert(&row_cdf, u);
                let pixels = &mass[row * w..(row + 1) * w];
                let (column, column_offset) = invert(&cumulative(pixels), v);
                let theta = (row as f64 + row_offset) / h as f64 * PI;
                let phi = (column as f64 + column_offset) / w as f64 * TAU;
                let direction = DVec3::new(
                    theta.sin() * phi.sin(),
                    theta.cos(),
                    theta.sin() * phi.cos(),
                );
                let radiance = self.image.pixels[row * w + column];
                // pdf per solid angle = (mass / total) / (cell · sin θ_row); the mass holds
                // that sin θ_row, so it cancels.
                let pdf = luminance(radiance) / (total * cell);
                let weight = radiance.map(|c| c as f64 / (count as f64 * pdf));
                EnvironmentSample { direction, weight }
            })
            .collect()
    }
}

/// Rec. 709 luminance.
fn luminance(c: [f32; 3]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

/// Running sums, normalised to end at 1.
fn cumulative(mass: &[f64]) -> Vec<f64> {
    let total: f64 = mass.iter().sum();
    let mut sum = 0.0;
    mass.iter()
        .map(|m| {
            sum += m;
            sum / total
        })
        .collect()
}

/// The bin of `cdf` that `u` ∈ (0, 1) falls in, and where in it (0 to 1).
fn invert(cdf: &[f64], u: f64) -> (usize, f64) {
    let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    let low = if i == 0 { 0.0 } else { cdf[i - 1] };
    let width = cdf[i] - low;
    let offset = if width > 0.0 {
        ((u - low) / width).clamp(0.0, 1.0)
    } else {
        0.5
    };
    (i, offset)
}

/// The radical inverse of `i` ≥ 1 in `base`: its digits mirrored about the point, in (0, 1).
fn radical_inverse(mut i: u32, base: u32) -> f64 {
    let mut value = 0.0;
    let mut scale = 1.0 / base as f64;
    while i > 0 {
        value += (i % base) as f64 * scale;
        i /= base;
        scale /= base as f64;
    }
    value
}

/// Elevation and azimuth (degrees) of the centre of pixel (x, y) of a `width × height` map.
fn pixel_angles(x: usize, y: usize, width: usize, height: usize) -> (f64, f64) {
    let theta = (y as f64 + 0.5) / height as f64 * 180.0;
    let phi = (x as f64 + 0.5) / width as f64 * 360.0;
    (90.0 - theta, if phi > 180.0 { phi - 360.0 } else { phi })
}

/// The studio's radiance toward (elevation, azimuth) in degrees.
fn studio_radiance(elevation: f64, azimuth: f64) -> [f64; 3] {
    let mut c = if elevation >= 0.0 {
        // Backdrop: brighter toward the horizon, a little cooler overhead.
        let t = (elevation / 90.0).clamp(0.0, 1.0);
        [0.20 - 0.10 * t, 0.20 - 0.09 * t, 0.21 - 0.07 * t]
    } else {
        // Floor: a warm grey that darkens away from the horizon.
        let t = (-elevation / 90.0).clamp(0.0, 1.0);
        [0.09 - 0.05 * t, 0.08 - 0.045 * t, 0.07 - 0.04 * t]
    };
    for b in &SOFTBOXES {
        let mut d_az = (azimuth - b.azimuth).rem_euclid(360.0);
        if d_az > 180.0 {
            d_az -= 360.0;
        }
        // Angular distance along the azimuth shrinks toward the poles.
        let across = d_az.abs() * elevation.to_radians().cos().max(0.05)
            / b.elevation.to_radians().cos().max(0.05);
        let along = (elevation - b.elevation).abs();
        // Soft edges: full inside, a 2° ramp outside.
        let edge = |distance: f64, half: f64| ((half + 2.0 - distance) / 2.0).clamp(0.0, 1.0);
        let inside = edge(across, b.half_width) * edge(along, b.half_height);
        for k in 0..3 {
            c[k] += inside * b.radiance[k];
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Irradiance on a plane of unit normal `n` estimated from the samples.
    fn irradiance(samples: &[EnvironmentSample], n: DVec3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for s in samples {
            let cos = n.dot(s.direction).max(0.0);
            for k in 0..3 {
                e[k] += s.weight[k] * cos;
            }
        }
        e
    }

    #[test]
    fn a_uniform_sky_gives_the_analytic_irradiance() {
        let sky = Environment::uniform_sky(0.4);
        let samples = sky.samples(256);
        assert_eq!(samples.len(), 256);
        assert!(samples.iter().all(|s| s.direction.y > 0.0));
        // Every sample carries the same weight, 2π R / N (to the image's row quadrature).
        let expected = TAU * 0.4 / 256.0;
        for s in &samples {
            assert!(
                (s.weight[0] - expected).abs() < 1e-3 * expected,
                "{:?}",
                s.weight
            );
            assert_eq!(s.weight, samples[0].weight);
        }
        // A plane tilted by β from horizontal under a uniform sky: E = π R (1 + cos β) / 2.
        for n in [
            DVec3::Y,
            DVec3::new(1.0, 1.0, 0.0).normalize(),
            DVec3::X,
            DVec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let expected = PI * 0.4 * (1.0 + n.y) / 2.0;
            let got = irradiance(&samples, n)[1];
            assert!(
                (got - expected).abs() < 0.03 * expected,
                "{n}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn samples_follow_the_light() {
        let studio = Environment::studio();
        let samples = studio.samples(256);
        // Σ weight estimates ∫ L dω: exactly for the luminance the samples are drawn by
        // (each carries the same share of it), closely for each channel.
        let weight_luminance = |w: [f64; 3]| 0.2126 * w[0] + 0.7152 * w[1] + 0.0722 * w[2];
        let total: f64 = samples.iter().map(|s| weight_luminance(s.weight)).sum();
        let green: f64 = samples.iter().map(|s| s.weight[1]).sum();
        let (w, h) = (studio.image.width, studio.image.height);
        let (mut integral, mut green_integral) = (0.0, 0.0);
        for y in 0..h {
            let sin = ((y as f64 + 0.5) / h as f64 * PI).sin();
            for x in 0..w {
                let area = sin * (PI / h as f64) * (TAU / w as f64);
                integral += luminance(studio.image.get(x, y)) * area;
                green_integral += studio.image.get(x, y)[1] as f64 * area;
            }
        }
        assert!(
            (total - integral).abs() < 1e-9 * integral,
            "{total} vs {integral}"
        );
        assert!(
            (green - green_integral).abs() < 0.01 * green_integral,
            "{green} vs {green_integral}"
        );
        // The key softbox (about 4% of the sphere) holds most of the light, so most samples.
        let key = light_direction(35.0, 45.0);
        let near_key = samples
            .iter()
            .filter(|s| s.direction.dot(key) > 25f64.to_radians().cos())
            .count();
        assert!(
            near_key > 64,
            "{near_key} of 256 samples near the key light"
        );
        assert!(
            samples
                .iter()
                .all(|s| s.weight.iter().all(|w| w.is_finite() && *w > 0.0))
        );
    }

    fn light_direction(elevation: f64, azimuth: f64) -> DVec3 {
        crate::scene::light_direction(&crate::scene::LightSettings {
            elevation_deg: elevation,
            azimuth_deg: azimuth,
        })
    }

    #[test]
    fn the_equirectangular_mapping_matches_the_light_convention() {
        // A single bright pixel at (elevation 30°, azimuth 90°) samples to that direction.
        let (w, h) = (72, 36);
        let mut image = RgbImage::filled(w, h, [0.0; 3]);
        let (x, y) = (
            ((90.0 / 360.0) * w as f64) as usize,
            ((60.0 / 180.0) * h as f64) as usize,
        );
        image.pixels[y * w + x] = [1.0; 3];
        let env = Environment::from_image("dot", image).unwrap();
        let (elevation, azimuth) = pixel_angles(x, y, w, h);
        let expected = light_direction(elevation, azimuth);
        for s in env.samples(16) {
            assert!(
                s.direction.dot(expected) > 0.995,
                "{} vs {expected}",
                s.direction
            );
        }
    }

    #[test]
    fn bad_images_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        let black = RgbImage::filled(8, 4, [0.0; 3]);
        assert!(
            Environment::from_image("x", black)
                .unwrap_err()
                .contains("black")
        );
        let mut nan = RgbImage::filled(8, 4, [1.0; 3]);
        nan.pixels[9] = [f32::NAN, 0.0, 0.0];
        assert!(
            Environment::from_image("x", nan)
                .unwrap_err()
                .contains("(1, 1)")
        );
        let path = dir.path().join("studio.exr");
        Environment::studio().write_exr(&path).unwrap();
        let back = Environment::from_exr(&path).unwrap();
        assert_eq!(back.image, Environment::studio().image);
        assert_eq!(back.name, "studio.exr");
        let bad = dir.path().join("bad.exr");
        std::fs::write(&bad, b"not an exr").unwrap();
        let e = Environment::from_exr(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.exr"), "{e}");
    }
}
