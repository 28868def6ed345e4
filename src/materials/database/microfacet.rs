//! Diffuse and analytic-highlight families: Lambert, Oren–Nayar, microfacet plastics and
//! metals (varnish, anisotropic), Ward, Ashikhmin–Shirley, Cook–Torrance and principled.

use super::albedo::{Built, Lobe};
use super::families::{Gen, rgb};
use crate::materials::classic::CookTorrance;
use crate::materials::models::{
    AshikhminShirley, Fresnel, Lambert, Microfacet, Mixture, OrenNayar, Ward, f0_from_ior,
};
use crate::materials::principled::Principled;
use std::f64::consts::PI;

impl Gen {
    pub(super) fn diffuse(&mut self) -> Built {
        let albedo = self.colour();
        Built {
            brdf: Box::new(Lambert { albedo }),
            label: format!("lambert albedo={}", rgb(albedo)),
            lobes: vec![],
            bounded: false,
        }
    }

    pub(super) fn rough_diffuse(&mut self) -> Built {
        let albedo = self.colour();
        let sigma = self.uniform(0.15, 1.0);
        Built {
            brdf: Box::new(OrenNayar { albedo, sigma }),
            label: format!("oren-nayar albedo={} σ={sigma:.2}", rgb(albedo)),
            lobes: vec![],
            bounded: false,
        }
    }

    /// A dielectric specular lobe with roughness (ax, ay) over a diffuse base.
    pub(super) fn plastic_with(&mut self, ax: f64, ay: f64, rotation: f64) -> Built {
        let ior = self.uniform(1.3, 1.9);
        let f0 = f0_from_ior(ior);
        let (base, base_label) = self.diffuse_base(1.0 - f0);
        let distribution = self.distribution();
        // Mostly white highlights; some coloured (metallic paints, tinted lacquer).
        let tint = if self.chance(0.85) {
            [1.0; 3]
        } else {
            self.colour().map(|c| c.max(0.05) / 0.97)
        };
        let spec = Microfacet {
            distribution,
            alpha_x: ax,
            alpha_y: ay,
            rotation,
            fresnel: Fresnel::Schlick { f0: [f0; 3] },
            tint,
        };
        Built {
            brdf: Box::new(Mixture {
                parts: vec![(1.0, base), (1.0, Box::new(spec))],
            }),
            label: format!(
                "plastic {distribution:?} α=({ax:.3},{ay:.3}) rot={rotation:.2} ior={ior:.2} tint={} over {base_label}",
                rgb(tint)
            ),
            lobes: vec![Lobe::flat(ax, ay, rotation)],
            bounded: false,
        }
    }

    pub(super) fn glossy(&mut self) -> Built {
        let a = self.alpha(0.02, 1.0);
        self.plastic_with(a, a, 0.0)
    }

    pub(super) fn metal_with(&mut self, ax: f64, ay: f64, rotation: f64) -> Built {
        let (fresnel, name) = self.conductor();
        let distribution = self.distribution();
        // Some dull or dirty metals.
        let tint = if self.chance(0.8) {
            [1.0; 3]
        } else {
            [self.uniform(0.4, 1.0); 3]
        };
        Built {
            brdf: Box::new(Microfacet {
                distribution,
                alpha_x: ax,
                alpha_y: ay,
                rotation,
                fresnel,
                tint,
            }),
            label: format!(
                "{name} {distribution:?} α=({ax:.3},{ay:.3}) rot={rotation:.2} tint={:.2}",
                tint[0]
            ),
            lobes: vec![Lobe::flat(ax, ay, rotation)],
            bounded: false,
        }
    }

    pub(super) fn metal(&mut self) -> Built {
        let a = self.alpha(0.02, 1.0);
        self.metal_with(a, a, 0.0)
    }

    /// Anisotropic roughness: ratio up to 1:10, either axis the long one, random rotation.
    fn anisotropic_alphas(&mut self) -> (f64, f64, f64) {
        let a = self.alpha(0.02, 0.5);
        let ratio = self.log_uniform(1.5, 10.0);
        let b = (a * ratio).min(1.0);
        let rotation = self.uniform(0.0, PI);
        if self.chance(0.5) {
            (a, b, rotation)
        } else {
            (b, a, rotation)
        }
    }

    pub(super) fn anisotropic(&mut self) -> Built {
        let (ax, ay, rotation) = self.anisotropic_alphas();
        if self.chance(0.75) {
            self.metal_with(ax, ay, rotation)
        } else {
            self.plastic_with(ax, ay, rotation)
        }
    }

    pub(super) fn ward(&mut self) -> Built {
        let (ax, ay, rotation) = if self.chance(0.3) {
            let (a, b, r) = self.anisotropic_alphas();
            (a.max(0.03), b.max(0.03), r)
        } else {
            let a = self.alpha(0.03, 0.5);
            (a, a, 0.0)
        };
        // Dielectric-like (grey highlight over a colour) or metal-like (coloured highlight).
        let (rho_d, rho_s) = if self.chance(0.6) {
            let s = self.uniform(0.02, 0.25);
            (self.colour().map(|c| c * (1.0 - s)), [s; 3])
        } else {
            let s = self.colour().map(|c| c.max(0.1));
            let d = self.uniform(0.0, 0.2);
            let base = self.colour();
            (std::array::from_fn(|c| base[c] * d * (1.0 - s[c])), s)
        };
        Built {
            brdf: Box::new(Ward {
                rho_d,
                rho_s,
                alpha_x: ax,
                alpha_y: ay,
                rotation,
            }),
            label: format!(
                "ward ρd={} ρs={} α=({ax:.3},{ay:.3}) rot={rotation:.2}",
                rgb(rho_d),
                rgb(rho_s)
            ),
            lobes: vec![Lobe::flat(ax, ay, rotation)],
            bounded: false,
        }
    }

    pub(super) fn ashikhmin_shirley(&mut self) -> Built {
        let (ax, ay, rotation) = if self.chance(0.3) {
            let (a, b, r) = self.anisotropic_alphas();
            (a.max(0.03), b.max(0.03), r)
        } else {
            let a = self.alpha(0.03, 0.8);
            (a, a, 0.0)
        };
        // Phong exponent n with the same lobe width as a microfacet α: α² ≈ 2/(n + 2).
        let exponent = |a: f64| (2.0 / (a * a) - 2.0).max(0.5);
        let (nu, nv) = (exponent(ax), exponent(ay));
        let (rd, rs) = if self.chance(0.6) {
            (self.colour(), [self.uniform(0.02, 0.08); 3])
        } else {
            let rs = self.colour().map(|c| c.max(0.2));
            let k = self.uniform(0.0, 0.3);
            (self.colour().map(|c| c * k), rs)
        };
        Built {
            brdf: Box::new(AshikhminShirley {
                rd,
                rs,
                nu,
                nv,
                rotation,
            }),
            label: format!(
                "ashikhmin-shirley rd={} rs={} n=({nu:.1},{nv:.1}) rot={rotation:.2}",
                rgb(rd),
                rgb(rs)
            ),
            lobes: vec![Lobe::flat(ax, ay, rotation)],
            bounded: false,
        }
    }

    /// A near-mirror dielectric highlight (α from 0.004 to 0.04) over a diffuse base.
    pub(super) fn varnish(&mut self) -> Built {
        let a = self.alpha(0.004, 0.04);
        self.plastic_with(a, a, 0.0)
    }

    /// Cook–Torrance with V-cavity masking, dielectric or conductor, over a diffuse base.
    pub(super) fn cook_torrance(&mut self) -> Built {
        let distribution = self.distribution();
        let alpha = self.alpha(0.03, 0.7);
        let (fresnel, diffuse, name) = if self.chance(0.35) {
            let (f, name) = self.conductor();
            (f, [0.0; 3], name)
        } else {
            let ior = self.uniform(1.3, 2.0);
            let d = self.colour().map(|c| c * (1.0 - f0_from_ior(ior)));
            (
                Fresnel::Schlick {
                    f0: [f0_from_ior(ior); 3],
                },
                d,
                format!("dielectric ior={ior:.2} ρd={}", rgb(d)),
            )
        };
        Built {
            brdf: Box::new(CookTorrance {
                diffuse,
                distribution,
                alpha,
                fresnel,
                tint: [1.0; 3],
            }),
            label: format!("cook-torrance {distribution:?} α={alpha:.3} {name}"),
            lobes: vec![Lobe::flat(alpha, alpha, 0.0)],
            bounded: false,
        }
    }

    /// Disney's principled BRDF: parameters as artists set them, often at their ends.
    pub(super) fn principled(&mut self) -> Built {
        let base_color = self.colour();
        let metallic = match self.below(20) {
            0..12 => 0.0,
            12..17 => 1.0,
            _ => self.uniform(0.0, 1.0),
        };
        let maybe = |g: &mut Self, p: f64| {
            if g.chance(p) {
                g.uniform(0.0, 1.0)
            } else {
                0.0
            }
        };
        let subsurface = maybe(self, 0.3);
        let sheen = maybe(self, 0.2);
        let clearcoat = maybe(self, 0.3);
        let anisotropic = maybe(self, 0.15);
        let m = Principled {
            base_color,
            metallic,
            subsurface,
            specular: self.uniform(0.0, 1.0),
            specular_tint: maybe(self, 0.3),
            roughness: self.uniform(0.08, 1.0),
            anisotropic,
            rotation: self.uniform(0.0, PI),
            sheen,
            sheen_tint: self.uniform(0.0, 1.0),
            clearcoat,
            clearcoat_gloss: self.uniform(0.0, 1.0),
        };
        let aspect = (1.0 - 0.9 * m.anisotropic).sqrt();
        let r2 = m.roughness * m.roughness;
        let mut lobes = vec![Lobe::flat(
            (r2 / aspect).max(0.01),
            (r2 * aspect).max(0.01),
            m.rotation,
        )];
        if m.clearcoat > 0.0 {
            let a = 0.1 + (0.001 - 0.1) * m.clearcoat_gloss;
            lobes.push(Lobe::flat(a.max(0.01), a.max(0.01), 0.0));
        }
        Built {
            label: format!(
                "principled base={} metallic={:.2} subsurface={:.2} specular={:.2} tint={:.2} roughness={:.2} anisotropic={:.2} rot={:.2} sheen={:.2}/{:.2} clearcoat={:.2}/{:.2}",
                rgb(m.base_color),
                m.metallic,
                m.subsurface,
                m.specular,
                m.specular_tint,
                m.roughness,
                m.anisotropic,
                m.rotation,
                m.sheen,
                m.sheen_tint,
                m.clearcoat,
                m.clearcoat_gloss
            ),
            brdf: Box::new(m),
            lobes,
            bounded: false,
        }
    }
}
