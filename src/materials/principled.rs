//! Disney's "principled" BRDF (Burley 2012), the model most artists' materials are made in:
//! a retro-reflective diffuse with a subsurface look, an anisotropic GGX specular whose colour
//! moves from dielectric grey to the base colour with metalness, sheen, and a GTR1 clear coat.
//! Transmission and the diffuse-transmission parts of the 2015 version are left out (they are
//! not reflection).

use super::Brdf;
use super::models::{above, cos_half_difference};
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI};

/// The parameters of Burley 2012, all in [0, 1] except the colours and the rotation.
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    /// Linear base colour.
    pub base_color: [f64; 3],
    pub metallic: f64,
    pub subsurface: f64,
    /// Dielectric specular amount (0.5 is F₀ = 0.04).
    pub specular: f64,
    pub specular_tint: f64,
    pub roughness: f64,
    pub anisotropic: f64,
    /// Angle (radians) the anisotropy axes are turned about the normal.
    pub rotation: f64,
    pub sheen: f64,
    pub sheen_tint: f64,
    pub clearcoat: f64,
    pub clearcoat_gloss: f64,
}

impl Default for Principled {
    /// Burley's defaults: a grey plastic.
    fn default() -> Self {
        Self {
            base_color: [0.8; 3],
            metallic: 0.0,
            subsurface: 0.0,
            specular: 0.5,
            specular_tint: 0.0,
            roughness: 0.5,
            anisotropic: 0.0,
            rotation: 0.0,
            sheen: 0.0,
            sheen_tint: 0.5,
            clearcoat: 0.0,
            clearcoat_gloss: 1.0,
        }
    }
}

fn schlick_weight(cos: f64) -> f64 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

fn mix(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// GTR1 (the clear coat's distribution), normalised over the hemisphere.
fn gtr1(cos_h: f64, a: f64) -> f64 {
    if a >= 1.0 {
        return FRAC_1_PI;
    }
    let a2 = a * a;
    let t = 1.0 + (a2 - 1.0) * cos_h * cos_h;
    (a2 - 1.0) / (PI * a2.ln() * t)
}

/// Smith G₁ for isotropic GGX in Burley's form, 1/(n·v + √(α² + (n·v)² − α²(n·v)²)), which
/// folds in the 1/(2 n·v) of the microfacet denominator.
fn smith_ggx(cos: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let c2 = cos * cos;
    1.0 / (cos + (a2 + c2 - a2 * c2).sqrt())
}

fn smith_ggx_aniso(w: (f64, f64, f64), ax: f64, ay: f64) -> f64 {
    let (x, y, z) = w;
    1.0 / (z + ((x * ax).powi(2) + (y * ay).powi(2) + z * z).sqrt())
}

impl Brdf for Principled {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let h = (l + v).normalize();
        let cos_d = cos_half_difference(l, v);
        let base = self.base_color;
        let lum = 0.3 * base[0] + 0.6 * base[1] + 0.1 * base[2];
        let tint = if lum > 0.0 {
            base.map(|c| c / lum)
        } else {
            [1.0; 3]
        };
        let spec0: [f64; 3] = std::array::from_fn(|c| {
            mix(
                self.specular * 0.08 * mix(1.0, tint[c], self.specular_tint),
                base[c],
                self.metallic,
            )
        });
        let sheen_colour: [f64; 3] = std::array::from_fn(|c| mix(1.0, tint[c], self.sheen_tint));

        // Diffuse: Schlick-shaped retro-reflection toward grazing, and Hanrahan–Krueger's
        // subsurface look, blended by `subsurface`.
        let (fl, fv) = (schlick_weight(l.z), schlick_weight(v.z));
        let fd90 = 0.5 + 2.0 * cos_d * cos_d * self.roughness;
        let fd = mix(1.0, fd90, fl) * mix(1.0, fd90, fv);
        let fss90 = cos_d * cos_d * self.roughness;
        let fss = mix(1.0, fss90, fl) * mix(1.0, fss90, fv);
        let ss = 1.25 * (fss * (1.0 / (l.z + v.z) - 0.5) + 0.5);
        let diffuse = FRAC_1_PI * mix(fd, ss, self.subsurface);

        // Specular: anisotropic GTR2 (GGX) with separable Smith masking.
        let aspect = (1.0 - 0.9 * self.anisotropic).sqrt();
        let r2 = self.roughness * self.roughness;
        let (ax, ay) = ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001));
        let (s, c) = self.rotation.sin_cos();
        let local = |w: DVec3| (c * w.x + s * w.y, -s * w.x + c * w.y, w.z);
        let (hx, hy, hz) = local(h);
        let q = (hx / ax).powi(2) + (hy / ay).powi(2) + hz * hz;
        let ds = 1.0 / (PI * ax * ay * q * q);
        let fh = schlick_weight(cos_d);
        let gs = smith_ggx_aniso(local(l), ax, ay) * smith_ggx_aniso(local(v), ax, ay);

        // Sheen and the clear coat.
        let sheen = fh * self.sheen;
        let dr = gtr1(h.z, mix(0.1, 0.001, self.clearcoat_gloss));
        let fr = mix(0.04, 1.0, fh);
        let gr = smith_ggx(l.z, 0.25) * smith_ggx(v.z, 0.25);
        let coat = 0.25 * self.clearcoat * gr * fr * dr;

        std::array::from_fn(|ch| {
            let fs = mix(spec0[ch], 1.0, fh);
            let value = (diffuse * base[ch] + sheen * sheen_colour[ch]) * (1.0 - self.metallic)
                + gs * fs * ds
                + coat;
            value.max(0.0)
        })
    }
    fn is_isotropic(&self) -> bool {
        self.anisotropic == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::directional_albedo;
    use crate::materials::models::tests::{check_basic, check_isotropy_claim};

    fn examples() -> Vec<Principled> {
        vec![
            Principled::default(),
            Principled {
                base_color: [0.9, 0.6, 0.2],
                metallic: 1.0,
                roughness: 0.3,
                anisotropic: 0.8,
                rotation: 0.4,
                ..Principled::default()
            },
            Principled {
                base_color: [0.5, 0.05, 0.05],
                subsurface: 1.0,
                sheen: 1.0,
                clearcoat: 1.0,
                clearcoat_gloss: 0.9,
                roughness: 0.8,
                ..Principled::default()
            },
        ]
    }

    #[test]
    fn principled_is_reciprocal_non_negative_and_finite() {
        for (i, m) in examples().iter().enumerate() {
            check_basic(m, 300 + i as u64, 400);
            check_isotropy_claim(m, 400 + i as u64, 100);
        }
    }

    #[test]
    fn a_rough_diffuse_principled_is_near_lambert_at_normal_incidence() {
        // At l = v = n, F_D90 terms vanish (both weights are 0): diffuse = base/π exactly.
        let m = Principled {
            specular: 0.0,
            roughness: 1.0,
            ..Principled::default()
        };
        let rho = m.eval(DVec3::Z, DVec3::Z);
        let spec_only = Principled {
            base_color: [0.0; 3],
            ..m.clone()
        }
        .eval(DVec3::Z, DVec3::Z);
        assert!((rho[0] - spec_only[0] - 0.8 * FRAC_1_PI).abs() < 1e-12);
        let a = directional_albedo(&m, DVec3::Z, 64);
        assert!(a[0] > 0.6 && a[0] < 1.0, "{a:?}");
    }
}
