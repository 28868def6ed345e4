//! Classic analytic models the microfacet families don't cover: lobes without Fresnel or
//! shadowing (Phong, Blinn–Phong, Lafortune), Cook and Torrance's V-cavity masking, the
//! backscatter of dusty surfaces (Lommel–Seeliger with an opposition surge) and Ashikhmin's
//! velvet. They matter to the basis for their *shapes*: a database in which every glossy
//! material has a Fresnel peak at grazing teaches the solver that every glossy painting has one.
//!
//! Like [`super::models`], every formula is symmetric in `l` and `v`, zero at or below the
//! horizon, and guarded at grazing angles.

use super::Brdf;
use super::models::{Distribution, Fresnel, above, cos_half_difference, scale3, v_cavity_masking};
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI};

/// Smallest cosine in a denominator (reached only far below any bin).
const MIN_COS: f64 = 1e-9;

/// Energy-normalised Phong about the mirror direction, over a Lambertian base:
/// ρ = ρ_d/π + ρ_s·(n + 2)/(2π)·max(0, r·v)^n with r the mirror of l.
#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    pub diffuse: [f64; 3],
    pub specular: [f64; 3],
    pub exponent: f64,
}

impl Brdf for Phong {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        // r·v = 2(n·l)(n·v) − l·v, symmetric in l and v.
        let rv = 2.0 * l.z * v.z - l.dot(v);
        let lobe = if rv > 0.0 {
            (self.exponent + 2.0) / (2.0 * PI) * rv.powf(self.exponent)
        } else {
            0.0
        };
        [0, 1, 2].map(|c| self.diffuse[c] * FRAC_1_PI + self.specular[c] * lobe)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Normalised Blinn–Phong over a Lambertian base, optionally with Schlick Fresnel on the
/// lobe: ρ = ρ_d/π + F·ρ_s·(n + 8)/(8π)·(n·h)^n. No masking: no grazing falloff either.
#[derive(Clone, Debug, PartialEq)]
pub struct BlinnPhong {
    pub diffuse: [f64; 3],
    pub specular: [f64; 3],
    pub exponent: f64,
    /// Scale the lobe by Schlick's Fresnel with the specular colour as F₀ (else constant).
    pub fresnel: bool,
}

impl Brdf for BlinnPhong {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let h = (l + v).normalize();
        let lobe = (self.exponent + 8.0) / (8.0 * PI) * h.z.max(0.0).powf(self.exponent);
        let cos_d = cos_half_difference(l, v);
        [0, 1, 2].map(|c| {
            let s = if self.fresnel {
                super::models::schlick(self.specular[c], cos_d)
            } else {
                self.specular[c]
            };
            self.diffuse[c] * FRAC_1_PI + s * lobe
        })
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// One generalised cosine lobe of Lafortune et al. 1997:
/// ρ·max(0, C_x l_x v_x + C_y l_y v_y + C_z l_z v_z)^n. C_x = C_y < 0 < C_z is a specular lobe (off-specular toward grazing when
/// |C_x| > C_z); C_x = C_y > 0 a retro-reflective one; C_x ≠ C_y anisotropic.
#[derive(Clone, Debug, PartialEq)]
pub struct LafortuneLobe {
    pub albedo: [f64; 3],
    pub c: [f64; 3],
    pub exponent: f64,
}

/// A Lambertian base plus generalised cosine lobes (Lafortune et al. 1997).
#[derive(Clone, Debug, PartialEq)]
pub struct Lafortune {
    pub diffuse: [f64; 3],
    pub lobes: Vec<LafortuneLobe>,
}

impl Brdf for Lafortune {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let mut out = self.diffuse.map(|d| d * FRAC_1_PI);
        for lobe in &self.lobes {
            let [cx, cy, cz] = lobe.c;
            let dot = cx * l.x * v.x + cy * l.y * v.y + cz * l.z * v.z;
            if dot > 0.0 {
                let s = dot.powf(lobe.exponent);
                for c in 0..3 {
                    out[c] += lobe.albedo[c] * s;
                }
            }
        }
        out
    }
    fn is_isotropic(&self) -> bool {
        self.lobes.iter().all(|l| l.c[0] == l.c[1])
    }
}

/// Cook & Torrance 1982: D·F·G/(4 cos θ_l cos θ_v) with the V-cavity masking
/// G = min(1, 2(n·h)(n·v)/(v·h), 2(n·h)(n·l)/(v·h)), over a diffuse base. V-cavities shadow
/// grazing pairs much more than Smith's model, so the grazing peak is low.
#[derive(Clone, Debug, PartialEq)]
pub struct CookTorrance {
    pub diffuse: [f64; 3],
    pub distribution: Distribution,
    pub alpha: f64,
    pub fresnel: Fresnel,
    pub tint: [f64; 3],
}

impl Brdf for CookTorrance {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let h = (l + v).normalize();
        let vh = cos_half_difference(l, v).max(MIN_COS);
        let d = self.distribution.isotropic_d(h.z, self.alpha.max(1e-4));
        let g = v_cavity_masking(l, v);
        let spec = d * g / (4.0 * l.z.max(MIN_COS) * v.z.max(MIN_COS));
        let f = self.fresnel.eval(vh);
        [0, 1, 2].map(|c| self.diffuse[c] * FRAC_1_PI + self.tint[c] * f[c] * spec)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Lommel–Seeliger single scattering with a Hapke-style opposition surge, the look of dust,
/// regolith and matte powders: ρ = w/(4π)·(1 + B(g))/(cos θ_l + cos θ_v), with
/// B(g) = B₀/(1 + tan(g/2)/h) and g the angle between l and v. Brightens toward the light
/// (backscatter) and toward grazing.
#[derive(Clone, Debug, PartialEq)]
pub struct LommelSeeliger {
    /// Single-scattering albedo per channel.
    pub albedo: [f64; 3],
    /// Opposition surge amplitude B₀.
    pub surge: f64,
    /// Opposition surge width h (smaller is narrower).
    pub width: f64,
}

impl Brdf for LommelSeeliger {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        // tan(g/2) = sin g/(1 + cos g), from l·v alone.
        let cos_g = l.dot(v).clamp(-1.0, 1.0);
        let tan_half = (1.0 - cos_g * cos_g).max(0.0).sqrt() / (1.0 + cos_g).max(MIN_COS);
        let b = self.surge / (1.0 + tan_half / self.width.max(1e-6));
        let s = (1.0 + b) / (4.0 * PI * (l.z + v.z).max(MIN_COS));
        scale3(self.albedo, s)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Ashikhmin's velvet (2007): a microfacet sheen with the "inverted Gaussian" distribution
/// D = (1 + 4·exp(−cot²θ_h/σ²)/sin⁴θ_h)/(π(1 + 4σ²)) and the smooth visibility
/// 1/(4(cos θ_l + cos θ_v − cos θ_l cos θ_v)), over a diffuse base.
#[derive(Clone, Debug, PartialEq)]
pub struct Velvet {
    pub diffuse: [f64; 3],
    pub sheen: [f64; 3],
    /// Width σ of the inverted Gaussian (smaller pushes the sheen further to grazing).
    pub sigma: f64,
}

impl Brdf for Velvet {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let h = (l + v).normalize();
        let cos2 = h.z * h.z;
        let sin2 = (1.0 - cos2).max(0.0);
        let s2 = self.sigma * self.sigma;
        let grazing = if sin2 > 1e-12 {
            let cot2 = cos2 / sin2;
            4.0 * (-cot2 / s2).exp() / (sin2 * sin2)
        } else {
            0.0
        };
        let d = (1.0 + grazing) / (PI * (1.0 + 4.0 * s2));
        let vis = 1.0 / (4.0 * (l.z + v.z - l.z * v.z).max(MIN_COS));
        [0, 1, 2].map(|c| self.diffuse[c] * FRAC_1_PI + self.sheen[c] * d * vis)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::directional_albedo;
    use crate::materials::models::tests::{check_basic, check_isotropy_claim};

    fn examples() -> Vec<Box<dyn Brdf>> {
        vec![
            Box::new(Phong {
                diffuse: [0.3, 0.1, 0.05],
                specular: [0.2; 3],
                exponent: 80.0,
            }),
            Box::new(BlinnPhong {
                diffuse: [0.1, 0.4, 0.1],
                specular: [0.04; 3],
                exponent: 300.0,
                fresnel: true,
            }),
            Box::new(BlinnPhong {
                diffuse: [0.0; 3],
                specular: [0.6, 0.5, 0.3],
                exponent: 20.0,
                fresnel: false,
            }),
            Box::new(Lafortune {
                diffuse: [0.2; 3],
                lobes: vec![
                    LafortuneLobe {
                        albedo: [0.5; 3],
                        c: [-1.1, -1.1, 0.7],
                        exponent: 12.0,
                    },
                    LafortuneLobe {
                        albedo: [0.1, 0.2, 0.3],
                        c: [0.9, 0.9, 0.9],
                        exponent: 5.0,
                    },
                ],
            }),
            Box::new(Lafortune {
                diffuse: [0.1; 3],
                lobes: vec![LafortuneLobe {
                    albedo: [0.4; 3],
                    c: [-1.0, -0.6, 0.8],
                    exponent: 30.0,
                }],
            }),
            Box::new(CookTorrance {
                diffuse: [0.2, 0.05, 0.02],
                distribution: Distribution::Beckmann,
                alpha: 0.2,
                fresnel: Fresnel::Schlick { f0: [0.04; 3] },
                tint: [1.0; 3],
            }),
            Box::new(LommelSeeliger {
                albedo: [0.5, 0.45, 0.4],
                surge: 1.0,
                width: 0.05,
            }),
            Box::new(Velvet {
                diffuse: [0.1, 0.0, 0.05],
                sheen: [0.6, 0.2, 0.4],
                sigma: 0.3,
            }),
        ]
    }

    #[test]
    fn classic_models_are_reciprocal_non_negative_and_finite() {
        for (i, b) in examples().iter().enumerate() {
            check_basic(b.as_ref(), 100 + i as u64, 400);
            check_isotropy_claim(b.as_ref(), 200 + i as u64, 100);
        }
        let aniso = &examples()[4];
        assert!(!aniso.is_isotropic());
    }

    #[test]
    fn phong_lobe_peaks_at_the_mirror_direction() {
        let p = Phong {
            diffuse: [0.0; 3],
            specular: [1.0; 3],
            exponent: 50.0,
        };
        let l = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
        let mirror = DVec3::new(-l.x, -l.y, l.z);
        let peak = p.eval(l, mirror)[0];
        assert!((peak - 52.0 / (2.0 * PI)).abs() < 1e-9);
        let off = DVec3::new(-0.6, 0.1, 0.8).normalize();
        assert!(p.eval(l, off)[0] < peak);
    }

    #[test]
    fn cook_torrance_v_cavities_mask_crossed_grazing_pairs() {
        let ct = CookTorrance {
            diffuse: [0.0; 3],
            distribution: Distribution::Ggx,
            alpha: 0.3,
            fresnel: Fresnel::Schlick { f0: [1.0; 3] },
            tint: [1.0; 3],
        };
        let at = |deg: f64, phi: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            DVec3::new(s * phi.cos(), s * phi.sin(), c)
        };
        // Unmasked value: D/(4 cos θ_l cos θ_v) with unit Fresnel.
        let unmasked = |l: DVec3, v: DVec3| {
            let h = (l + v).normalize();
            Distribution::Ggx.isotropic_d(h.z, 0.3) / (4.0 * l.z * v.z)
        };
        // Both at 88°, a quarter turn apart: the half-vector lies near the horizon and the
        // V-cavity term 2(n·h)(n·l)/(v·h) is about 0.005.
        let (l, v) = (at(88.0, 0.0), at(88.0, 0.5 * PI));
        let g = ct.eval(l, v)[0] / unmasked(l, v);
        assert!((g - 0.004866).abs() < 1e-5, "{g}");
        // At normal incidence nothing is masked.
        let g0 = ct.eval(DVec3::Z, DVec3::Z)[0] / unmasked(DVec3::Z, DVec3::Z);
        assert!((g0 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn lommel_seeliger_brightens_toward_the_light() {
        let m = LommelSeeliger {
            albedo: [0.5; 3],
            surge: 1.0,
            width: 0.05,
        };
        let l = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
        let back = m.eval(l, l)[0];
        let side = m.eval(l, DVec3::new(0.0, 0.5, 0.75f64.sqrt()))[0];
        assert!(back > 1.5 * side, "{back} {side}");
        // A white powder reflects at most what it receives.
        let a = directional_albedo(&m, DVec3::Z, 64);
        assert!(a[0] < 1.0, "{a:?}");
    }

    #[test]
    fn velvet_sheen_grows_toward_grazing() {
        let m = Velvet {
            diffuse: [0.0; 3],
            sheen: [1.0; 3],
            sigma: 0.3,
        };
        // l = v puts the half-vector at θ: the inverted Gaussian favours grazing ones.
        let at = |deg: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            let l = DVec3::new(s, 0.0, c);
            m.eval(l, l)[0]
        };
        assert!(at(75.0) > at(10.0));
    }
}
