//! Spectra for the spectral `.bsdf` flavour (pbrt-v4 renders spectrally only).
//!
//! - **Observer:** the CIE 1931 2° colour matching functions in the multi-lobe Gaussian fit
//!   of Wyman, Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ Color
//!   Matching Functions", JCGT 2(2), 2013 (within about 1% of the table).
//! - **Illuminant:** CIE standard illuminant D65 (CIE 15:2004, table T.3, 380–780 nm in
//!   10 nm steps), the white point of linear sRGB / Rec. 709: a spectral renderer lights a
//!   scene "white" with it, so a reflectance spectrum is chosen to give back its RGB under it.
//! - **Upsampling:** the sigmoid-polynomial spectra of Jakob & Hanika, "A Low-Dimensional
//!   Function Space for Efficient Spectral Upsampling", Eurographics 2019:
//!   s(λ) = S(c₀x² + c₁x + c₂), S(z) = ½ + z/(2√(1 + z²)), x the normalised wavelength. As in
//!   pbrt-v4's unbounded spectra, an RGB value is upsampled as 2m · s(λ) with m its largest
//!   component, so the polynomial only ever fits colours whose largest component is ½. Those
//!   form a 2D family per largest channel; the coefficients are solved (Gauss–Newton) on a
//!   grid of it once per process, by continuation from grey, and interpolated between nodes.
//!   Nothing is precomputed outside this code.

use std::sync::OnceLock;

/// Wavelength range the fit and the integrals cover, nm (pbrt-v4 samples 360–830).
pub const LAMBDA_MIN: f64 = 360.0;
pub const LAMBDA_MAX: f64 = 830.0;
/// Integration step, nm.
const STEP: f64 = 5.0;
/// Nodes per axis of the coefficient grid (ratios of the two smaller channels to the largest).
const GRID: usize = 33;

/// CIE D65, 380–780 nm every 10 nm (CIE 15:2004 table T.3).
const D65: [f64; 41] = [
    49.9755, 54.6482, 82.7549, 91.4860, 93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861,
    115.923, 108.811, 109.354, 107.802, 104.790, 107.689, 104.405, 104.046, 100.000, 96.3342,
    95.7880, 88.6856, 90.0062, 89.5991, 87.6987, 83.2886, 83.6992, 80.0268, 80.2146, 82.2778,
    78.2842, 69.7213, 71.6091, 74.3496, 61.6045, 69.8856, 75.0870, 63.5928, 46.4182, 66.8054,
    63.3828,
];

/// D65 at `lambda` nm, linear between the table's entries, its end values outside it.
pub fn d65(lambda: f64) -> f64 {
    let x = ((lambda - 380.0) / 10.0).clamp(0.0, (D65.len() - 1) as f64);
    let i = (x as usize).min(D65.len() - 2);
    let t = x - i as f64;
    D65[i] + (D65[i + 1] - D65[i]) * t
}

/// The CIE 1931 2° observer (x̄, ȳ, z̄) at `lambda` nm (Wyman et al. 2013, multi-lobe fit).
pub fn cie_xyz(lambda: f64) -> [f64; 3] {
    let g = |mu: f64, s1: f64, s2: f64| {
        let t = (lambda - mu) / if lambda < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    [
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    ]
}

/// The observer weighted by D65 on the integration grid, and the matrix from XYZ to linear
/// sRGB whose white is this integral's (so a flat spectrum of 1 gives RGB (1, 1, 1)).
struct Colorimetry {
    lambdas: Vec<f64>,
    /// Per wavelength: D65 · (x̄, ȳ, z̄) · Δλ / ∫ D65 ȳ dλ, turned into RGB weights.
    rgb_weights: Vec<[f64; 3]>,
}

fn colorimetry() -> &'static Colorimetry {
    static C: OnceLock<Colorimetry> = OnceLock::new();
    C.get_or_init(|| {
        let n = ((LAMBDA_MAX - LAMBDA_MIN) / STEP).round() as usize + 1;
        let lambdas: Vec<f64> = (0..n).map(|i| LAMBDA_MIN + STEP * i as f64).collect();
        let weighted: Vec<[f64; 3]> = lambdas
            .iter()
            .map(|&l| cie_xyz(l).map(|c| c * d65(l) * STEP))
            .collect();
        let y_norm: f64 = weighted.iter().map(|w| w[1]).sum();
        let white: [f64; 3] =
            std::array::from_fn(|c| weighted.iter().map(|w| w[c]).sum::<f64>() / y_norm);
        let to_rgb = xyz_to_rgb_matrix(white);
        let rgb_weights = weighted
            .iter()
            .map(|w| {
                let xyz = w.map(|c| c / y_norm);
                mat_vec(&to_rgb, xyz)
            })
            .collect();
        Colorimetry {
            lambdas,
            rgb_weights,
        }
    })
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn invert3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let inv = 1.0 / det;
    let c =
        |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    [
        [
            c(1, 1, 2, 2) * inv,
            -c(0, 1, 2, 2) * inv,
            c(0, 1, 1, 2) * inv,
        ],
        [
            -c(1, 0, 2, 2) * inv,
            c(0, 0, 2, 2) * inv,
            -c(0, 0, 1, 2) * inv,
        ],
        [
            c(1, 0, 2, 1) * inv,
            -c(0, 0, 2, 1) * inv,
            c(0, 0, 1, 1) * inv,
        ],
    ]
}

/// XYZ → linear RGB for the Rec. 709 primaries and the given white (Y = 1).
fn xyz_to_rgb_matrix(white: [f64; 3]) -> [[f64; 3]; 3] {
    let primaries = [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)];
    // Columns: the primaries' XYZ at Y = 1, scaled so that RGB (1, 1, 1) is the white.
    let cols: Vec<[f64; 3]> = primaries
        .iter()
        .map(|&(x, y)| [x / y, 1.0, (1.0 - x - y) / y])
        .collect();
    let p = [
        [cols[0][0], cols[1][0], cols[2][0]],
        [cols[0][1], cols[1][1], cols[2][1]],
        [cols[0][2], cols[1][2], cols[2][2]],
    ];
    let s = mat_vec(&invert3(&p), white);
    let rgb_to_xyz: [[f64; 3]; 3] =
        std::array::from_fn(|r| std::array::from_fn(|c| p[r][c] * s[c]));
    invert3(&rgb_to_xyz)
}

/// Linear RGB of a reflectance-like spectrum `s(λ)` lit by D65 (white gives (1, 1, 1)).
pub fn rgb_of(spectrum: impl Fn(f64) -> f64) -> [f64; 3] {
    let c = colorimetry();
    let mut rgb = [0.0; 3];
    for (&l, w) in c.lambdas.iter().zip(&c.rgb_weights) {
        let s = spectrum(l);
        for k in 0..3 {
            rgb[k] += s * w[k];
        }
    }
    rgb
}

/// Linear RGB of a spectrum sampled at `wavelengths` (nm, ascending), linear in between and
/// constant beyond the ends, as the loaders interpolate a `.bsdf`'s spectra.
pub fn rgb_of_samples(wavelengths: &[f64], values: &[f64]) -> [f64; 3] {
    rgb_of(|l| interpolate(wavelengths, values, l))
}

fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    match xs.len() {
        0 => 0.0,
        1 => ys[0],
        n => {
            let i = xs.partition_point(|&v| v < x).clamp(1, n - 1) - 1;
            let t = ((x - xs[i]) / (xs[i + 1] - xs[i])).clamp(0.0, 1.0);
            ys[i] + (ys[i + 1] - ys[i]) * t
        }
    }
}

/// Jakob & Hanika's sigmoid.
fn sigmoid(z: f64) -> f64 {
    if z.is_infinite() {
        return if z > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + z / (2.0 * (1.0 + z * z).sqrt())
}

/// Normalised wavelength in [0, 1] over the fit's range (keeps the polynomial well scaled).
fn unit_lambda(lambda: f64) -> f64 {
    (lambda - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN)
}

fn polynomial_spectrum(c: [f64; 3], lambda: f64) -> f64 {
    let x = unit_lambda(lambda);
    sigmoid((c[0] * x + c[1]) * x + c[2])
}

/// Coefficients whose sigmoid spectrum has linear RGB `target` under D65 (Levenberg–
/// Marquardt from `start`), and the remaining RGB error (largest component).
fn fit_coefficients(target: [f64; 3], start: [f64; 3]) -> ([f64; 3], f64) {
    let residual = |c: [f64; 3]| {
        let rgb = rgb_of(|l| polynomial_spectrum(c, l));
        [rgb[0] - target[0], rgb[1] - target[1], rgb[2] - target[2]]
    };
    let norm2 = |r: [f64; 3]| r.iter().map(|x| x * x).sum::<f64>();
    let mut c = start;
    let mut r = residual(c);
    let mut lambda = 1e-3;
    for _ in 0..60 {
        if norm2(r) < 1e-14 {
            break;
        }
        let h = 1e-5;
        let mut jac = [[0.0; 3]; 3];
        for k in 0..3 {
            let mut cp = c;
            cp[k] += h;
            let rp = residual(cp);
            for i in 0..3 {
                jac[i][k] = (rp[i] - r[i]) / h;
            }
        }
        // (JᵀJ + λ diag) δ = −Jᵀr
        let mut improved = false;
        for _ in 0..8 {
            let mut a = [[0.0; 3]; 3];
            let mut g = [0.0; 3];
            for i in 0..3 {
                for k in 0..3 {
                    g[k] += jac[i][k] * r[i];
                    for m in 0..3 {
                        a[k][m] += jac[i][k] * jac[i][m];
                    }
                }
            }
            for k in 0..3 {
                a[k][k] *= 1.0 + lambda;
                a[k][k] += 1e-12;
            }
            let delta = mat_vec(&invert3(&a), g.map(|x| -x));
            if delta.iter().any(|d| !d.is_finite()) {
                lambda *= 10.0;
                continue;
            }
            let candidate = std::array::from_fn(|k| c[k] + delta[k]);
            let rc = residual(candidate);
            if norm2(rc) < norm2(r) {
                c = candidate;
                r = rc;
                lambda = (lambda * 0.3).max(1e-9);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (c, r.iter().fold(0.0f64, |m, x| m.max(x.abs())))
}

/// Coefficients on the grid: per largest channel, GRID × GRID nodes over the ratios of the
/// other two channels (in channel order) to the largest.
struct CoefficientTable {
    nodes: [Vec<[f64; 3]>; 3],
    /// The largest RGB error of any node's fit (out-of-reach colours near the spectral locus
    /// are fitted as closely as the sigmoid allows).
    worst_error: f64,
}

fn coefficient_table() -> &'static CoefficientTable {
    static T: OnceLock<CoefficientTable> = OnceLock::new();
    T.get_or_init(|| {
        let mut worst = 0.0f64;
        let nodes = std::array::from_fn(|channel| {
            let others: Vec<usize> = (0..3).filter(|&c| c != channel).collect();
            let mut grid = vec![[0.0; 3]; GRID * GRID];
            // Continuation: grey (ratios 1, 1) first, then outward along rows and columns.
            for i in (0..GRID).rev() {
                for j in (0..GRID).rev() {
                    let start = if j + 1 < GRID {
                        grid[i * GRID + j + 1]
                    } else if i + 1 < GRID {
                        grid[(i + 1) * GRID + j]
                    } else {
                        [0.0; 3]
                    };
                    let mut target = [0.0; 3];
                    target[channel] = 0.5;
                    target[others[0]] = 0.5 * i as f64 / (GRID - 1) as f64;
                    target[others[1]] = 0.5 * j as f64 / (GRID - 1) as f64;
                    let (c, err) = fit_coefficients(target, start);
                    worst = worst.max(err);
                    grid[i * GRID + j] = c;
                }
            }
            grid
        });
        CoefficientTable {
            nodes,
            worst_error: worst,
        }
    })
}

/// The largest linear-RGB error of the upsampling at its grid nodes (colours whose largest
/// component is ½); 0 for every colour the sigmoid family reaches.
pub fn upsampling_worst_error() -> f64 {
    coefficient_table().worst_error
}

/// An RGB value as a smooth spectrum: `value(λ)` for any wavelength in nm. Black and
/// non-finite input give the zero spectrum; negative components count as 0.
#[derive(Clone, Copy, Debug)]
pub struct RgbSpectrum {
    scale: f64,
    coefficients: [f64; 3],
}

impl RgbSpectrum {
    pub fn new(rgb: [f64; 3]) -> Self {
        let rgb = rgb.map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 });
        let (channel, max) =
            rgb.iter().enumerate().fold(
                (0, 0.0f64),
                |best, (i, &c)| if c > best.1 { (i, c) } else { best },
            );
        if max <= 0.0 {
            return Self {
                scale: 0.0,
                coefficients: [0.0; 3],
            };
        }
        let others: Vec<usize> = (0..3).filter(|&c| c != channel).collect();
        let ratios = [rgb[others[0]] / max, rgb[others[1]] / max];
        let table = coefficient_table();
        let grid = &table.nodes[channel];
        let pos = ratios.map(|r| r.clamp(0.0, 1.0) * (GRID - 1) as f64);
        let cell = pos.map(|p| (p as usize).min(GRID - 2));
        let t = [pos[0] - cell[0] as f64, pos[1] - cell[1] as f64];
        let at = |i: usize, j: usize| grid[i * GRID + j];
        let coefficients = std::array::from_fn(|k| {
            let c00 = at(cell[0], cell[1])[k];
            let c01 = at(cell[0], cell[1] + 1)[k];
            let c10 = at(cell[0] + 1, cell[1])[k];
            let c11 = at(cell[0] + 1, cell[1] + 1)[k];
            let c0 = c00 + (c01 - c00) * t[1];
            let c1 = c10 + (c11 - c10) * t[1];
            c0 + (c1 - c0) * t[0]
        });
        Self {
            scale: 2.0 * max,
            coefficients,
        }
    }

    /// The spectrum at `lambda` nm.
    pub fn value(&self, lambda: f64) -> f64 {
        if self.scale == 0.0 {
            0.0
        } else {
            self.scale * polynomial_spectrum(self.coefficients, lambda)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_is_flat_and_maps_to_one() {
        let rgb = rgb_of(|_| 1.0);
        for c in rgb {
            assert!((c - 1.0).abs() < 1e-12, "{rgb:?}");
        }
        let grey = RgbSpectrum::new([0.3, 0.3, 0.3]);
        for l in [400.0, 550.0, 700.0] {
            assert!((grey.value(l) - 0.3).abs() < 1e-9);
        }
    }

    #[test]
    fn upsampled_colours_give_their_rgb_back() {
        // Colours a reflectance can have (well inside sRGB), over several decades.
        for rgb in [
            [0.8, 0.2, 0.1],
            [0.1, 0.6, 0.2],
            [0.05, 0.1, 0.7],
            [2.5, 1.0, 0.4],
            [0.02, 0.03, 0.025],
            [0.5, 0.45, 0.0],
        ] {
            let s = RgbSpectrum::new(rgb);
            let back = rgb_of(|l| s.value(l));
            let max = rgb.iter().cloned().fold(0.0, f64::max);
            for c in 0..3 {
                assert!((back[c] - rgb[c]).abs() < 0.02 * max, "{rgb:?} → {back:?}");
            }
            for l in [360.0, 450.0, 600.0, 830.0] {
                let v = s.value(l);
                assert!(v >= 0.0 && v <= 2.0 * max + 1e-12);
            }
        }
        assert_eq!(RgbSpectrum::new([0.0, -1.0, f64::NAN]).value(500.0), 0.0);
    }
}
