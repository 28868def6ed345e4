//! The RGL tabulated BRDF (`.bsdf`, Dupuy & Jakob, "An Adaptive Parameterization for
//! Efficient Material Acquisition and Rendering", SIGGRAPH Asia 2018): written for Mitsuba 3
//! (`measured`), pbrt-v4 (`measured`, spectral), Falcor (`RGLMaterial`) and brdf-loader, and
//! read back the way they evaluate it.
//!
//! **Layout** (a [`TensorFile`]; shapes C-ordered, the last axis contiguous):
//! `description` u8[len]; `jacobian` u8[1] = 1; `theta_i` f32[T] and `phi_i` f32[P] (radians:
//! the slices of the incident direction); `ndf` and `sigma` f32[Φ, Θ] over the u-grid of a
//! direction (u_θ = √(θ/(π/2)) along the last axis, u_φ = (φ + π)/2π along the first);
//! `vndf` and `luminance` f32[P, T, n, n]; `rgb` f32[P, T, 3, n, n]; and for the spectral
//! flavour `spectra` f32[P, T, W, n, n] with `wavelengths` f32[W] (nm). P ≤ 2 marks an
//! isotropic material, whose microfacet azimuth is taken relative to φ_i.
//!
//! **Evaluation** (reader side, Mitsuba 3's `Measured::eval`): for ωi (the direction the
//! slices are indexed by: the camera's side in a path tracer) and ωo, with m the half
//! vector, u_m its u-coordinates and u_i ωi's, the uniform point s = VNDF⁻¹(u_m | φ_i, θ_i)
//! indexes the bilinear `rgb` grid, and f_r cos θ_o = rgb(s) · D(u_m) / (4 σ(u_i)).
//!
//! **Writing** (this module): D and σ come from the retro-reflection by power iteration
//! ([`super::ndf`]); the VNDF of each slice is D(m)⟨ωi·m⟩/σ(ωi) times the u-grid's Jacobian
//! 2π² u_θ sin θ_m; the `rgb` grid is filled at the VNDF's own sample points: the uniform
//! grid node s is warped to m, reflected to ωo, and the table evaluated there at the exact
//! directions ([`super::exact`]), divided by D and σ exactly as the reader will multiply by
//! them. `luminance` is the luminance of `rgb` (the sampling density the readers warp by
//! first).

use super::exact::{ExactTable, anisotropy, isotropic_average};
pub use super::grid::{phi2u, theta2u, u2phi, u2theta};
use super::ndf::{Microsurface, estimate_anisotropic, estimate_isotropic};
use super::spectrum::{RgbSpectrum, rgb_of_samples};
use super::tensor::{DType, Field, TensorFile};
use super::warp::Marginal2D;
use crate::error::{Error, Result};
use crate::materials::Brdf;
use crate::table::{PHI_BINS, SymTable, THETA_BINS, phi_centre, theta_centre};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// Below this render-weighted departure from its rotation average a table is exported as
/// isotropic (unless told otherwise): 2% is less than a reconstruction's own error.
pub const ANISOTROPY_THRESHOLD: f64 = 0.02;
/// Sample-space grid of an isotropic export (n × n per slice).
pub const ISOTROPIC_GRID: usize = 64;
/// Sample-space grid of an anisotropic export: 36 × 45 slices instead of 45.
pub const ANISOTROPIC_GRID: usize = 32;
/// NDF grid: θ nodes (and φ nodes when anisotropic).
const NDF_THETA: usize = 64;
const NDF_PHI: usize = 48;
/// Wavelengths of the spectral flavour: 350 to 830 nm every 20 nm.
const WAVELENGTHS: usize = 25;
const LAMBDA_FIRST: f64 = 350.0;
const LAMBDA_STEP: f64 = 20.0;

/// θ of a unit vector, accurate near the normal (the loaders' `elevation`).
pub fn elevation(d: DVec3) -> f64 {
    let dist = (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}

fn spherical(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

fn luminance(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The u-coordinates of a microfacet normal as a reader computes them.
fn normal_u(m: DVec3, phi_i: f64, isotropic: bool) -> [f64; 2] {
    let phi_m = m.y.atan2(m.x);
    let u_phi = phi2u(if isotropic { phi_m - phi_i } else { phi_m });
    [theta2u(elevation(m)), u_phi - u_phi.floor()]
}

/// How to write a `.bsdf`.
#[derive(Clone, Debug, PartialEq)]
pub struct BsdfSettings {
    /// `Some` forces the choice; `None` exports isotropic when the table's anisotropy is
    /// below [`ANISOTROPY_THRESHOLD`].
    pub isotropic: Option<bool>,
    /// Add `spectra` and `wavelengths` (for pbrt-v4 and Mitsuba's spectral variants, which
    /// then require them; Mitsuba's RGB variants refuse such a file).
    pub spectral: bool,
    /// Sample-space resolution per slice; `None`: [`ISOTROPIC_GRID`] or [`ANISOTROPIC_GRID`].
    pub grid: Option<usize>,
    /// Text stored in the `description` field.
    pub description: String,
}

impl Default for BsdfSettings {
    fn default() -> Self {
        Self {
            isotropic: None,
            spectral: false,
            grid: None,
            description: "Burnish painted BRDF".into(),
        }
    }
}

/// What was written.
#[derive(Clone, Debug, PartialEq)]
pub struct BsdfReport {
    pub isotropic: bool,
    /// The table's render-weighted departure from isotropy (see [`anisotropy`]).
    pub anisotropy: f64,
    pub grid: usize,
    pub theta_slices: usize,
    pub phi_slices: usize,
    pub spectral: bool,
    pub ndf_iterations: usize,
    pub bytes: usize,
}

/// The `.bsdf` of a table as a tensor file, and what it holds.
pub fn bsdf_tensor(table: &SymTable, settings: &BsdfSettings) -> (TensorFile, BsdfReport) {
    let average = isotropic_average(table);
    let departure = anisotropy(table, &average);
    let isotropic = settings
        .isotropic
        .unwrap_or(departure < ANISOTROPY_THRESHOLD);
    let grid = settings
        .grid
        .unwrap_or(if isotropic {
            ISOTROPIC_GRID
        } else {
            ANISOTROPIC_GRID
        })
        .max(4);
    let exact = if isotropic {
        ExactTable::isotropic(table, average)
    } else {
        ExactTable::anisotropic(table)
    };
    let retro = |w: DVec3| luminance(exact.eval(w, w));
    let micro = if isotropic {
        estimate_isotropic(retro, NDF_THETA)
    } else {
        estimate_anisotropic(retro, NDF_THETA, NDF_PHI)
    };
    let theta_i: Vec<f32> = (0..THETA_BINS).map(|t| theta_centre(t) as f32).collect();
    let phi_i: Vec<f32> = if isotropic {
        vec![0.0]
    } else {
        // Bin centres, moved into (−π, π] and sorted: −175°, …, −5°, 5°, …, 175°.
        let mut v: Vec<f32> = (0..PHI_BINS)
            .map(|p| {
                let phi = phi_centre(p);
                (if phi > PI { phi - TAU } else { phi }) as f32
            })
            .collect();
        v.sort_by(f32::total_cmp);
        v
    };
    let filled = fill_slices(&exact, &micro, &phi_i, &theta_i, grid, isotropic);

    let mut fields = vec![
        Field::bytes("description", settings.description.as_bytes()),
        Field::bytes("jacobian", &[1]),
        Field::f32("theta_i", &[theta_i.len()], &theta_i),
        Field::f32("phi_i", &[phi_i.len()], &phi_i),
        Field::f32("ndf", &[micro.phi, micro.theta], &micro.ndf),
        Field::f32("sigma", &[micro.phi, micro.theta], &micro.sigma),
    ];
    let (p, t, n) = (phi_i.len(), theta_i.len(), grid);
    fields.push(Field::f32("vndf", &[p, t, n, n], &filled.vndf));
    fields.push(Field::f32("luminance", &[p, t, n, n], &filled.luminance));
    fields.push(Field::f32("rgb", &[p, t, 3, n, n], &filled.rgb));
    if settings.spectral {
        let wavelengths: Vec<f32> = (0..WAVELENGTHS)
            .map(|i| (LAMBDA_FIRST + LAMBDA_STEP * i as f64) as f32)
            .collect();
        let spectra = upsample(&filled.rgb, n * n, &wavelengths);
        fields.push(Field::f32(
            "spectra",
            &[p, t, wavelengths.len(), n, n],
            &spectra,
        ));
        fields.push(Field::f32(
            "wavelengths",
            &[wavelengths.len()],
            &wavelengths,
        ));
    }
    let file = TensorFile { fields };
    let bytes = file.to_bytes().len();
    let report = BsdfReport {
        isotropic,
        anisotropy: departure,
        grid,
        theta_slices: t,
        phi_slices: p,
        spectral: settings.spectral,
        ndf_iterations: micro.iterations,
        bytes,
    };
    (file, report)
}

/// Writes a table as a `.bsdf` file, atomically.
pub fn write_bsdf(path: &Path, table: &SymTable, settings: &BsdfSettings) -> Result<BsdfReport> {
    let (file, report) = bsdf_tensor(table, settings);
    file.write(path)?;
    Ok(report)
}

/// The per-slice grids, concatenated in file order.
struct Filled {
    vndf: Vec<f32>,
    luminance: Vec<f32>,
    rgb: Vec<f32>,
}

fn fill_slices(
    exact: &ExactTable<'_>,
    micro: &Microsurface,
    phi_i: &[f32],
    theta_i: &[f32],
    n: usize,
    isotropic: bool,
) -> Filled {
    let ndf = Marginal2D::new(&micro.ndf, micro.theta, micro.phi, vec![], false, false)
        .expect("the NDF grid is at least 2 × 2, finite and non-negative");
    let sigma = Marginal2D::new(&micro.sigma, micro.theta, micro.phi, vec![], false, false)
        .expect("the σ grid is at least 2 × 2, finite and non-negative");
    let slices: Vec<(f64, f64)> = phi_i
        .iter()
        .flat_map(|&p| theta_i.iter().map(move |&t| (p as f64, t as f64)))
        .collect();
    let per_slice: Vec<(Vec<f32>, Vec<f32>, Vec<f32>)> = slices
        .par_iter()
        .map(|&(phi, theta)| fill_slice(exact, &ndf, &sigma, phi, theta, n, isotropic))
        .collect();
    let mut filled = Filled {
        vndf: Vec::with_capacity(slices.len() * n * n),
        luminance: Vec::with_capacity(slices.len() * n * n),
        rgb: Vec::with_capacity(3 * slices.len() * n * n),
    };
    for (vndf, lum, rgb) in per_slice {
        filled.vndf.extend(vndf);
        filled.luminance.extend(lum);
        filled.rgb.extend(rgb);
    }
    filled
}

/// One slice: its VNDF, luminance and RGB grids (the RGB as 3 planes).
fn fill_slice(
    exact: &ExactTable<'_>,
    ndf: &Marginal2D,
    sigma: &Marginal2D,
    phi_i: f64,
    theta_i: f64,
    n: usize,
    isotropic: bool,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let wi = spherical(theta_i, phi_i);
    let sigma_i = sigma.eval([theta2u(theta_i), phi2u(phi_i)], &[]);
    let node = |k: usize| k as f64 / (n - 1) as f64;
    let azimuth_offset = if isotropic { phi_i } else { 0.0 };
    let mut vndf = vec![0f32; n * n];
    for j in 0..n {
        for i in 0..n {
            let u = [node(i), node(j)];
            let theta_m = u2theta(u[0]);
            let m = spherical(theta_m, u2phi(u[1]) + azimuth_offset);
            let d = ndf.eval([u[0], u[1] - u[1].floor()], &[]);
            let density = d * wi.dot(m).max(0.0) / sigma_i * 2.0 * PI * PI * u[0] * theta_m.sin();
            vndf[j * n + i] = if density.is_finite() {
                density as f32
            } else {
                0.0
            };
        }
    }
    if vndf.iter().all(|&v| v <= 0.0) {
        // Cannot happen for D > 0 and θ_i < 90°; a constant keeps the warp defined.
        vndf.iter_mut().for_each(|v| *v = 1.0);
    }
    let warp = Marginal2D::new(&vndf, n, n, vec![], true, true)
        .expect("the VNDF grid is finite, non-negative and not zero");
    let mut rgb = vec![0f32; 3 * n * n];
    let mut lum = vec![0f32; n * n];
    for j in 0..n {
        for i in 0..n {
            let (u_m, _) = warp.sample([node(i), node(j)], &[]);
            let m = spherical(u2theta(u_m[0]), u2phi(u_m[1]) + azimuth_offset);
            let wo = m * (2.0 * wi.dot(m)) - wi;
            if wo.z <= 0.0 {
                continue;
            }
            let m = (wi + wo).normalize();
            let d = ndf.eval(normal_u(m, phi_i, isotropic), &[]);
            if d <= 0.0 {
                continue;
            }
            let rho = exact.eval(wo, wi);
            let scale = wo.z * 4.0 * sigma_i / d;
            let value = rho.map(|r| r * scale);
            for c in 0..3 {
                let v = value[c];
                rgb[(c * n + j) * n + i] = if v.is_finite() && v > 0.0 {
                    v as f32
                } else {
                    0.0
                };
            }
            lum[j * n + i] = luminance(value).max(0.0) as f32;
        }
    }
    // The readers normalise `luminance` per slice and sample by it: keep every node positive
    // (a small floor) so that no part of the lobe has zero sampling density.
    let mean = lum.iter().map(|&v| v as f64).sum::<f64>() / lum.len() as f64;
    let floor = if mean > 0.0 { 1e-3 * mean } else { 1.0 };
    lum.iter_mut().for_each(|v| *v = (*v as f64 + floor) as f32);
    (vndf, lum, rgb)
}

/// `spectra` from `rgb` ([P·T, 3, n, n] → [P·T, W, n, n]).
fn upsample(rgb: &[f32], plane: usize, wavelengths: &[f32]) -> Vec<f32> {
    let slices = rgb.len() / (3 * plane);
    let w = wavelengths.len();
    let mut out = vec![0f32; slices * w * plane];
    out.par_chunks_mut(w * plane)
        .enumerate()
        .for_each(|(s, chunk)| {
            let base = s * 3 * plane;
            for k in 0..plane {
                let value = [0, 1, 2].map(|c| rgb[base + c * plane + k] as f64);
                let spectrum = RgbSpectrum::new(value);
                for (l, &lambda) in wavelengths.iter().enumerate() {
                    chunk[l * plane + k] = spectrum.value(lambda as f64) as f32;
                }
            }
        });
    out
}

/// A `.bsdf` file, evaluated as the reference loaders evaluate it.
#[derive(Clone, Debug)]
pub struct RglBsdf {
    pub description: String,
    isotropic: bool,
    jacobian: bool,
    /// Symmetry reduction of an anisotropic file (1, 2 or 4), as Mitsuba 3 reads it.
    reduction: i32,
    ndf: Marginal2D,
    sigma: Marginal2D,
    vndf: Marginal2D,
    /// The `rgb` grid, or the `spectra` grid converted to linear RGB under D65.
    values: Marginal2D,
}

impl RglBsdf {
    /// Reads and checks a `.bsdf` file (RGB, spectral, or both).
    pub fn read(path: &Path) -> Result<Self> {
        let file = TensorFile::read(path)?;
        Self::from_tensor(&file).map_err(|problem| Error::invalid(path, problem))
    }

    /// Builds the evaluator from a tensor file; the error names the field at fault.
    pub fn from_tensor(file: &TensorFile) -> std::result::Result<Self, String> {
        let field = |name: &str| {
            file.field(name)
                .ok_or_else(|| format!("no `{name}` field: not an RGL material (.bsdf) file"))
        };
        let floats =
            |name: &str, ndim: usize| -> std::result::Result<(Vec<usize>, Vec<f32>), String> {
                let f = field(name)?;
                if f.dtype != DType::Float32 || f.shape.len() != ndim {
                    return Err(format!(
                        "field `{name}` is {:?} of {} dimensions, expected float32 of {ndim}",
                        f.dtype,
                        f.shape.len()
                    ));
                }
                let values = f.as_f32().expect("float32");
                if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                    return Err(format!("field `{name}` holds {bad}"));
                }
                Ok((f.shape.iter().map(|&s| s as usize).collect(), values))
            };
        let description = field("description")?;
        if description.dtype != DType::UInt8 || description.shape.len() != 1 {
            return Err("field `description` is not a byte string".into());
        }
        let jacobian = field("jacobian")?;
        if jacobian.dtype != DType::UInt8 || jacobian.shape != [1] {
            return Err("field `jacobian` is not one byte".into());
        }
        let (_, theta_i) = floats("theta_i", 1)?;
        let (_, phi_i) = floats("phi_i", 1)?;
        if theta_i.is_empty() || phi_i.is_empty() {
            return Err("`theta_i` and `phi_i` need at least one value each".into());
        }
        let (ndf_shape, ndf) = floats("ndf", 2)?;
        let (sigma_shape, sigma) = floats("sigma", 2)?;
        let (vndf_shape, vndf) = floats("vndf", 4)?;
        let (p, t) = (phi_i.len(), theta_i.len());
        if vndf_shape[..2] != [p, t] {
            return Err(format!(
                "`vndf` has shape {vndf_shape:?}, expected [{p}, {t}, n, n]"
            ));
        }
        let (rows, cols) = (vndf_shape[2], vndf_shape[3]);
        let spectral = file.field("wavelengths").is_some();
        let (values, channels) = if let Some(rgb) = file.field("rgb") {
            let _ = rgb;
            let (shape, values) = floats("rgb", 5)?;
            if shape != [p, t, 3, rows, cols] {
                return Err(format!(
                    "`rgb` has shape {shape:?}, expected [{p}, {t}, 3, {rows}, {cols}]"
                ));
            }
            (values, 3)
        } else if spectral {
            let (_, wavelengths) = floats("wavelengths", 1)?;
            let (shape, spectra) = floats("spectra", 5)?;
            let w = wavelengths.len();
            if shape != [p, t, w, rows, cols] {
                return Err(format!(
                    "`spectra` has shape {shape:?}, expected [{p}, {t}, {w}, {rows}, {cols}]"
                ));
            }
            (
                spectra_to_rgb(&spectra, p * t, w, rows * cols, &wavelengths),
                3,
            )
        } else {
            return Err("neither `rgb` nor `spectra` + `wavelengths`".into());
        };
        let isotropic = p <= 2;
        let reduction = if isotropic {
            1
        } else {
            let span = (phi_i[p - 1] - phi_i[0]) as f64;
            (TAU / span).round() as i32
        };
        if !matches!(reduction, 1 | 2 | 4) {
            return Err(format!(
                "`phi_i` spans {:.1}°, which is no symmetry reduction a reader knows",
                (phi_i[p - 1] - phi_i[0]).to_degrees()
            ));
        }
        let with = |what: &str, r: std::result::Result<Marginal2D, String>| {
            r.map_err(|e| format!("field `{what}`: {e}"))
        };
        let params = vec![phi_i.clone(), theta_i.clone()];
        let channel_values: Vec<f32> = (0..channels).map(|c| c as f32).collect();
        Ok(Self {
            description: String::from_utf8_lossy(&description.data).into_owned(),
            isotropic,
            jacobian: jacobian.data[0] != 0,
            reduction,
            ndf: with(
                "ndf",
                Marginal2D::new(&ndf, ndf_shape[1], ndf_shape[0], vec![], false, false),
            )?,
            sigma: with(
                "sigma",
                Marginal2D::new(&sigma, sigma_shape[1], sigma_shape[0], vec![], false, false),
            )?,
            vndf: with(
                "vndf",
                Marginal2D::new(&vndf, cols, rows, params.clone(), true, true),
            )?,
            values: with(
                "rgb",
                Marginal2D::new(
                    &values,
                    cols,
                    rows,
                    vec![phi_i, theta_i, channel_values],
                    false,
                    false,
                ),
            )?,
        })
    }

    pub fn is_isotropic(&self) -> bool {
        self.isotropic
    }

    /// f_r(ωi, ωo) cos θ_o in linear RGB, ωi the direction the file's slices are indexed by
    /// (what Mitsuba 3's `measured` returns from `eval`).
    pub fn eval_cos(&self, wi: DVec3, wo: DVec3) -> [f64; 3] {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return [0.0; 3];
        }
        let (mut wi, mut wo) = (wi.normalize(), wo.normalize());
        if self.reduction >= 2 {
            // Mitsuba folds the azimuth into the stored wedge: negate x and y by the signs of
            // ωi's (y, and x too for a four-fold reduction).
            let sy = wi.y;
            let sx = if self.reduction == 4 { wi.x } else { sy };
            let flip = |a: f64, s: f64| if s >= 0.0 { -a } else { a };
            wi = DVec3::new(flip(wi.x, sx), flip(wi.y, sy), wi.z);
            wo = DVec3::new(flip(wo.x, sx), flip(wo.y, sy), wo.z);
        }
        let m = (wi + wo).normalize();
        let (theta_i, phi_i) = (elevation(wi), wi.y.atan2(wi.x));
        let u_wi = [theta2u(theta_i), phi2u(phi_i)];
        let u_m = normal_u(m, phi_i, self.isotropic);
        let (sample, _) = self.vndf.invert(u_m, &[phi_i, theta_i]);
        let mut value = [0, 1, 2].map(|c| self.values.eval(sample, &[phi_i, theta_i, c as f64]));
        if self.jacobian {
            let scale = self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_wi, &[]));
            value = value.map(|v| v * scale);
        }
        value.map(|v| if v.is_finite() { v } else { 0.0 })
    }
}

impl Brdf for RglBsdf {
    /// ρ(l, v) with v as ωi (the camera's side, as renderers call it) and l as ωo.
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let cos_l = l.z / l.length();
        self.eval_cos(v, l).map(|x| (x / cos_l).max(0.0))
    }
    fn is_isotropic(&self) -> bool {
        self.isotropic
    }
}

/// A spectral grid [slices, W, plane] as linear RGB [slices, 3, plane].
fn spectra_to_rgb(
    spectra: &[f32],
    slices: usize,
    w: usize,
    plane: usize,
    wavelengths: &[f32],
) -> Vec<f32> {
    let lambdas: Vec<f64> = wavelengths.iter().map(|&l| l as f64).collect();
    let mut out = vec![0f32; slices * 3 * plane];
    out.par_chunks_mut(3 * plane)
        .enumerate()
        .for_each(|(s, chunk)| {
            let mut values = vec![0f64; w];
            for k in 0..plane {
                for l in 0..w {
                    values[l] = spectra[(s * w + l) * plane + k] as f64;
                }
                let rgb = rgb_of_samples(&lambdas, &values);
                for c in 0..3 {
                    chunk[c * plane + k] = rgb[c] as f32;
                }
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn u_coordinates_round_trip() {
        for theta in [0.0, 0.1, 0.7, 1.5] {
            assert!((u2theta(theta2u(theta)) - theta).abs() < 1e-12);
        }
        for phi in [-3.0, -0.5, 0.0, 2.0] {
            assert!((u2phi(phi2u(phi)) - phi).abs() < 1e-12);
        }
        let w = spherical(0.3, 1.0);
        assert!((elevation(w) - 0.3).abs() < 1e-12);
    }
}
