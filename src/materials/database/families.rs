//! The families' parameter draws: what each kind of material looks like, and how varied.

use super::Family;
use super::albedo::{Built, Lobe, facet_lobes};
use crate::materials::Brdf;
use crate::materials::biscale::{BiScale, GrooveProfile};
use crate::materials::classic::{
    BlinnPhong, CookTorrance, Lafortune, LafortuneLobe, LommelSeeliger, Phong, Velvet,
};
use crate::materials::layered::{AbsorbingCoat, ThinFilm};
use crate::materials::models::{
    AshikhminShirley, ClearCoat, Distribution, Fresnel, Lambert, Microfacet, Mixture, OrenNayar,
    Retroreflective, Sheen, Ward, f0_from_ior,
};
use crate::materials::principled::Principled;
use rand::RngExt;
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// Complex refractive indices (η, κ) at roughly 650, 550, 450 nm.
const METALS: [(&str, [f64; 3], [f64; 3]); 9] = [
    ("gold", [0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    ("copper", [0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    ("aluminium", [1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
    ("silver", [0.155, 0.117, 0.138], [4.828, 3.122, 2.147]),
    ("chrome", [4.370, 2.917, 1.651], [5.206, 4.231, 3.755]),
    ("iron", [2.870, 2.950, 2.650], [3.030, 2.930, 2.810]),
    ("platinum", [2.376, 2.085, 1.845], [4.266, 3.715, 3.137]),
    ("brass", [0.444, 0.527, 1.094], [3.695, 2.765, 1.829]),
    ("nickel", [1.990, 1.830, 1.600], [3.740, 3.190, 2.620]),
];

fn rgb(c: [f64; 3]) -> String {
    format!("({:.3},{:.3},{:.3})", c[0], c[1], c[2])
}

fn hsv(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h6 = (h.rem_euclid(1.0)) * 6.0;
    let f = |n: f64| {
        let k = (n + h6) % 6.0;
        v - v * s * (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    [f(5.0), f(3.0), f(1.0)]
}

/// Mixes seed and index into one RNG seed (SplitMix64 finaliser on each).
pub(super) fn mix(seed: u64, index: usize) -> u64 {
    fn splitmix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    splitmix(seed ^ splitmix(index as u64 ^ 0x6d61_7465_7269_616c))
}

/// Parameter draws.
pub(super) struct Gen {
    pub(super) rng: Pcg64,
}

impl Gen {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.rng.random::<f64>()
    }

    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }

    fn chance(&mut self, p: f64) -> bool {
        self.rng.random::<f64>() < p
    }

    fn below(&mut self, n: usize) -> usize {
        self.rng.random_range(0..n)
    }

    /// An albedo: uniform hue, often desaturated, value drawn in display space and made
    /// linear, with near-black and near-white over-represented; every channel ≤ 0.97.
    fn colour(&mut self) -> [f64; 3] {
        let h = self.uniform(0.0, 1.0);
        let r = self.uniform(0.0, 1.0);
        let (s, v) = if r < 0.1 {
            (self.uniform(0.0, 0.6), self.uniform(0.03, 0.15))
        } else if r < 0.2 {
            (self.uniform(0.0, 0.06), self.uniform(0.88, 0.985))
        } else {
            let s = if self.chance(0.3) {
                self.uniform(0.0, 0.15)
            } else {
                self.uniform(0.15, 1.0)
            };
            (s, self.uniform(0.15, 0.95))
        };
        hsv(h, s, v).map(|c| c.powf(2.2))
    }

    /// A roughness α, log-uniform from near-mirror to very rough.
    fn alpha(&mut self, lo: f64, hi: f64) -> f64 {
        self.log_uniform(lo, hi)
    }

    fn distribution(&mut self) -> Distribution {
        if self.chance(0.75) {
            Distribution::Ggx
        } else {
            Distribution::Beckmann
        }
    }

    /// Conductor Fresnel: a real metal, or a random one with a random reflectance colour.
    fn conductor(&mut self) -> (Fresnel, String) {
        if self.chance(0.7) {
            let (name, eta, k) = METALS[self.below(METALS.len())];
            (Fresnel::Conductor { eta, k }, name.to_string())
        } else {
            let h = self.uniform(0.0, 1.0);
            let s = self.uniform(0.0, 0.6);
            let v = self.uniform(0.6, 0.99);
            let f0 = hsv(h, s, v).map(|c| c.powf(2.2).max(0.02));
            let eta0 = self.uniform(0.15, 2.5);
            let mut eta = [0.0; 3];
            let mut k = [0.0; 3];
            for c in 0..3 {
                let n = eta0 * self.uniform(0.8, 1.25);
                // Solve ((n − 1)² + κ²)/((n + 1)² + κ²) = f0 for κ; if f0 is below the
                // dielectric reflectance of n, take the dielectric with reflectance f0.
                let f = f0[c];
                let k2 = (f * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - f);
                if k2 >= 0.0 {
                    eta[c] = n;
                    k[c] = k2.sqrt();
                } else {
                    eta[c] = (1.0 + f.sqrt()) / (1.0 - f.sqrt());
                }
            }
            (
                Fresnel::Conductor { eta, k },
                format!("metal f0={}", rgb(f0)),
            )
        }
    }

    fn diffuse(&mut self) -> Built {
        let albedo = self.colour();
        Built {
            brdf: Box::new(Lambert { albedo }),
            label: format!("lambert albedo={}", rgb(albedo)),
            lobes: vec![],
            bounded: false,
        }
    }

    fn rough_diffuse(&mut self) -> Built {
        let albedo = self.colour();
        let sigma = self.uniform(0.15, 1.0);
        Built {
            brdf: Box::new(OrenNayar { albedo, sigma }),
            label: format!("oren-nayar albedo={} σ={sigma:.2}", rgb(albedo)),
            lobes: vec![],
            bounded: false,
        }
    }

    /// A Lambert (70%) or Oren–Nayar base scaled by `k`.
    fn diffuse_base(&mut self, k: f64) -> (Box<dyn Brdf>, String) {
        let albedo = self.colour().map(|c| c * k);
        if self.chance(0.7) {
            (
                Box::new(Lambert { albedo }),
                format!("lambert {}", rgb(albedo)),
            )
        } else {
            let sigma = self.uniform(0.15, 1.0);
            (
                Box::new(OrenNayar { albedo, sigma }),
                format!("oren-nayar {} σ={sigma:.2}", rgb(albedo)),
            )
        }
    }

    /// A dielectric specular lobe with roughness (ax, ay) over a diffuse base.
    fn plastic_with(&mut self, ax: f64, ay: f64, rotation: f64) -> Built {
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

    fn glossy(&mut self) -> Built {
        let a = self.alpha(0.02, 1.0);
        self.plastic_with(a, a, 0.0)
    }

    fn metal_with(&mut self, ax: f64, ay: f64, rotation: f64) -> Built {
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

    fn metal(&mut self) -> Built {
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

    fn anisotropic(&mut self) -> Built {
        let (ax, ay, rotation) = self.anisotropic_alphas();
        if self.chance(0.75) {
            self.metal_with(ax, ay, rotation)
        } else {
            self.plastic_with(ax, ay, rotation)
        }
    }

    fn ward(&mut self) -> Built {
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

    fn ashikhmin_shirley(&mut self) -> Built {
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

    fn sheen(&mut self) -> Built {
        let (base, base_label) = self.diffuse_base(1.0);
        let roughness = self.uniform(0.15, 1.0);
        let color = if self.chance(0.5) {
            [self.uniform(0.2, 1.0); 3]
        } else {
            self.colour().map(|c| c.sqrt())
        };
        Built {
            brdf: Box::new(Mixture {
                parts: vec![(1.0, base), (1.0, Box::new(Sheen { color, roughness }))],
            }),
            label: format!("sheen {} r={roughness:.2} over {base_label}", rgb(color)),
            lobes: vec![],
            bounded: false,
        }
    }

    fn retro(&mut self) -> Built {
        let k = self.uniform(0.2, 0.8);
        let (base, base_label) = self.diffuse_base(1.0 - k);
        let exponent = self.log_uniform(3.0, 60.0);
        let color = self.colour().map(|c| c.sqrt() * k);
        let mut parts: Vec<(f64, Box<dyn Brdf>)> = vec![
            (1.0, base),
            (1.0, Box::new(Retroreflective { color, exponent })),
        ];
        let mut lobes = vec![];
        let mut label = format!("retro {} n={exponent:.1} over {base_label}", rgb(color));
        if self.chance(0.4) {
            // A glossy binder or cover sheet on top.
            let a = self.alpha(0.03, 0.5);
            parts.push((
                1.0,
                Box::new(Microfacet::isotropic(
                    Distribution::Ggx,
                    a,
                    Fresnel::Schlick { f0: [0.04; 3] },
                )),
            ));
            lobes.push(Lobe::flat(a, a, 0.0));
            label += &format!(" + gloss α={a:.3}");
        }
        Built {
            brdf: Box::new(Mixture { parts }),
            label,
            lobes,
            bounded: false,
        }
    }

    fn clear_coat(&mut self) -> Built {
        let base = match self.below(20) {
            0..8 => self.diffuse(),
            8..13 => self.metal(),
            13..17 => self.glossy(),
            _ => self.anisotropic(),
        }
        .capped();
        let ior = self.uniform(1.4, 1.6);
        let roughness = self.alpha(0.02, 0.25);
        let mut lobes = base.lobes;
        lobes.push(Lobe::flat(roughness, roughness, 0.0));
        Built {
            brdf: Box::new(ClearCoat {
                base: base.brdf,
                ior,
                roughness,
            }),
            label: format!(
                "clear coat ior={ior:.2} α={roughness:.3} over [{}]",
                base.label
            ),
            lobes,
            bounded: false,
        }
    }

    /// A part of a mixture: any simple family, anisotropic about one time in ten.
    fn simple(&mut self) -> Built {
        match self.below(20) {
            0..2 => self.diffuse(),
            2..3 => self.rough_diffuse(),
            3..6 => self.glossy(),
            6..9 => self.metal(),
            9..10 => self.ward(),
            10..11 => self.ashikhmin_shirley(),
            11..12 => self.sheen(),
            12..13 => self.retro(),
            13..14 => self.phong(),
            14..15 => self.cook_torrance(),
            15..16 => self.principled(),
            16..17 => self.dusty(),
            17..18 => self.velvet(),
            18..19 => self.lafortune(),
            _ => self.anisotropic(),
        }
    }

    fn mixture(&mut self) -> Built {
        let n = 2 + self.below(2);
        let parts: Vec<Built> = (0..n).map(|_| self.simple().capped()).collect();
        let weights: Vec<f64> = (0..n).map(|_| self.uniform(0.2, 1.0)).collect();
        let total: f64 = weights.iter().sum();
        let lobes = parts.iter().flat_map(|p| p.lobes.iter().copied()).collect();
        let label = parts
            .iter()
            .zip(&weights)
            .map(|(p, w)| format!("{:.2}·[{}]", w / total, p.label))
            .collect::<Vec<_>>()
            .join(" + ");
        // Convex weights of parts that are each within the cap: the mixture is too.
        Built {
            brdf: Box::new(Mixture {
                parts: parts
                    .into_iter()
                    .zip(weights)
                    .map(|(p, w)| (w / total, p.brdf))
                    .collect(),
            }),
            label: format!("mixture {label}"),
            lobes,
            bounded: true,
        }
    }

    /// A metal (`metal_share` of the time) or plastic base no sharper than `min_alpha`.
    fn biscale_base(&mut self, metal_share: f64, min_alpha: f64) -> Built {
        let a = self.alpha(0.02, 0.6).max(min_alpha);
        if self.chance(metal_share) {
            self.metal_with(a, a, 0.0)
        } else {
            self.plastic_with(a, a, 0.0)
        }
    }

    fn grooves(&mut self) -> Built {
        let max_tilt = self.uniform(5.0, 35.0).to_radians();
        let direction = self.uniform(0.0, PI);
        let profile = if self.chance(0.35) {
            GrooveProfile::V
        } else {
            GrooveProfile::Rounded {
                facets: 3 + self.below(3),
            }
        };
        // A rounded profile is a continuum of tilts: blur the base enough to bridge the
        // gaps between neighbouring facets rather than show one highlight per facet.
        let min_alpha = match profile {
            GrooveProfile::V => 0.02,
            GrooveProfile::Rounded { facets } => 0.5 * 2.0 * max_tilt / facets as f64,
        };
        // The bi-scale albedo is at most the base's, so capping the base bounds it.
        let base = self.biscale_base(0.7, min_alpha).capped();
        let brdf = BiScale::grooves(base.brdf, profile, max_tilt, direction);
        let lobes = facet_lobes(&brdf.facets, &base.lobes);
        Built {
            brdf: Box::new(brdf),
            label: format!(
                "grooves {profile:?} tilt={:.1}° dir={direction:.2} over [{}]",
                max_tilt.to_degrees(),
                base.label
            ),
            lobes,
            bounded: true,
        }
    }

    fn bumps(&mut self) -> Built {
        let max_tilt = self.uniform(10.0, 50.0).to_radians();
        let rings = 2 + self.below(2);
        let per_ring = if self.chance(0.5) { 6 } else { 8 };
        let base = if self.chance(0.1) {
            self.diffuse()
        } else {
            self.biscale_base(0.55, 0.5 * max_tilt / rings as f64)
        }
        .capped();
        let brdf = BiScale::bumps(base.brdf, max_tilt, rings, per_ring);
        // The isotropised ring turns with the directions, so these lobes only roughly mark
        // its highlights; the estimator stays consistent, just less efficient.
        let lobes = facet_lobes(&brdf.facets, &base.lobes);
        Built {
            brdf: Box::new(brdf),
            label: format!(
                "bumps tilt={:.1}° rings={rings}×{per_ring} over [{}]",
                max_tilt.to_degrees(),
                base.label
            ),
            lobes,
            // The isotropised ring is not covered by the facet-average bound (a few percent
            // over the base's albedo at some angles), so it is checked numerically.
            bounded: false,
        }
    }

    /// A material of `family`, before the albedo cap.
    pub(super) fn family(&mut self, family: Family) -> Built {
        match family {
            Family::Diffuse => self.diffuse(),
            Family::RoughDiffuse => self.rough_diffuse(),
            Family::Glossy => self.glossy(),
            Family::Varnish => self.varnish(),
            Family::Metal => self.metal(),
            Family::Anisotropic => self.anisotropic(),
            Family::Ward => self.ward(),
            Family::AshikhminShirley => self.ashikhmin_shirley(),
            Family::Phong => self.phong(),
            Family::Lafortune => self.lafortune(),
            Family::CookTorrance => self.cook_torrance(),
            Family::Principled => self.principled(),
            Family::Sheen => self.sheen(),
            Family::Velvet => self.velvet(),
            Family::Retro => self.retro(),
            Family::Dusty => self.dusty(),
            Family::ClearCoat => self.clear_coat(),
            Family::LayeredCoat => self.layered_coat(),
            Family::ThinFilm => self.thin_film(),
            Family::Mixture => self.mixture(),
            Family::BiScaleGrooves => self.grooves(),
            Family::BiScaleBumps => self.bumps(),
        }
    }

    /// A near-mirror dielectric highlight (α from 0.004 to 0.04) over a diffuse base.
    fn varnish(&mut self) -> Built {
        let a = self.alpha(0.004, 0.04);
        self.plastic_with(a, a, 0.0)
    }

    /// A grey (dielectric) or coloured (metal-like) highlight strength and a diffuse albedo
    /// that together stay near or below one.
    fn diffuse_and_specular(&mut self, grey_max: f64) -> ([f64; 3], [f64; 3]) {
        if self.chance(0.65) {
            let s = self.uniform(0.02, grey_max);
            (self.colour().map(|c| c * (1.0 - s)), [s; 3])
        } else {
            let s = self.colour().map(|c| c.max(0.1));
            let k = self.uniform(0.0, 0.25);
            let base = self.colour();
            (std::array::from_fn(|c| base[c] * k * (1.0 - s[c])), s)
        }
    }

    /// Phong (about the mirror direction) or Blinn–Phong (about the normal), often without
    /// Fresnel: the old rendering models, whose highlights keep their strength to grazing.
    fn phong(&mut self) -> Built {
        let (diffuse, specular) = self.diffuse_and_specular(0.5);
        let exponent = self.log_uniform(3.0, 3000.0);
        if self.chance(0.4) {
            // A Phong lobe of exponent n is about as wide as a Blinn–Phong lobe of 4n.
            let a = (2.0 / (4.0 * exponent + 2.0)).sqrt();
            Built {
                brdf: Box::new(Phong {
                    diffuse,
                    specular,
                    exponent,
                }),
                label: format!(
                    "phong n={exponent:.1} ρd={} ρs={}",
                    rgb(diffuse),
                    rgb(specular)
                ),
                lobes: vec![Lobe::flat(a, a, 0.0)],
                bounded: false,
            }
        } else {
            let fresnel = self.chance(0.4);
            let a = (2.0 / (exponent + 2.0)).sqrt();
            Built {
                brdf: Box::new(BlinnPhong {
                    diffuse,
                    specular,
                    exponent,
                    fresnel,
                }),
                label: format!(
                    "blinn-phong n={exponent:.1} fresnel={fresnel} ρd={} ρs={}",
                    rgb(diffuse),
                    rgb(specular)
                ),
                lobes: vec![Lobe::flat(a, a, 0.0)],
                bounded: false,
            }
        }
    }

    /// One to three Lafortune lobes over a diffuse base: a specular lobe, sometimes
    /// off-specular (brighter toward grazing) or anisotropic, and sometimes a retro lobe.
    fn lafortune(&mut self) -> Built {
        let (diffuse, specular) = self.diffuse_and_specular(0.6);
        let exponent = self.log_uniform(3.0, 400.0);
        // |C_x| / C_z: above one the lobe leans toward grazing; kept where (r)^n stays sane.
        let ratio = self.uniform(0.85, 1.0 + (2.0 / exponent).min(0.3));
        let (rx, ry) = if self.chance(0.2) {
            let stretch = self.uniform(0.75, 0.97);
            if self.chance(0.5) {
                (ratio, ratio * stretch)
            } else {
                (ratio * stretch, ratio)
            }
        } else {
            (ratio, ratio)
        };
        let norm = (exponent + 2.0) / (2.0 * PI);
        let mut lobes = vec![LafortuneLobe {
            albedo: specular.map(|s| s * norm),
            c: [-rx, -ry, 1.0],
            exponent,
        }];
        let a = (2.0 / (4.0 * exponent + 2.0)).sqrt();
        let mut label = format!(
            "lafortune n={exponent:.1} C=({:.3},{:.3},1) ρs={}",
            -rx,
            -ry,
            rgb(specular)
        );
        if self.chance(0.35) {
            let n = self.log_uniform(2.0, 40.0);
            let k = self.uniform(0.05, 0.4);
            let colour = self.colour().map(|c| c.sqrt() * k * (n + 1.0) / (2.0 * PI));
            lobes.push(LafortuneLobe {
                albedo: colour,
                c: [1.0, 1.0, 1.0],
                exponent: n,
            });
            label += &format!(" + retro n={n:.1}");
        }
        if self.chance(0.25) {
            let n = self.log_uniform(1.0, 10.0);
            let s = self.uniform(0.02, 0.2) * (n + 2.0) / (2.0 * PI);
            let r = self.uniform(0.9, 1.0 + (2.0 / n).min(0.5));
            lobes.push(LafortuneLobe {
                albedo: [s; 3],
                c: [-r, -r, 1.0],
                exponent: n,
            });
            label += &format!(" + haze n={n:.1}");
        }
        Built {
            brdf: Box::new(Lafortune { diffuse, lobes }),
            label: format!("{label} ρd={}", rgb(diffuse)),
            lobes: vec![Lobe::flat(a, a, 0.0)],
            bounded: false,
        }
    }

    /// Cook–Torrance with V-cavity masking, dielectric or conductor, over a diffuse base.
    fn cook_torrance(&mut self) -> Built {
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
    fn principled(&mut self) -> Built {
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

    fn velvet(&mut self) -> Built {
        let k = self.uniform(0.3, 1.0);
        let diffuse = self.colour().map(|c| c * k);
        let sheen = if self.chance(0.5) {
            [self.uniform(0.2, 1.0); 3]
        } else {
            self.colour().map(|c| c.sqrt())
        };
        let sigma = self.uniform(0.1, 0.7);
        Built {
            brdf: Box::new(Velvet {
                diffuse,
                sheen,
                sigma,
            }),
            label: format!(
                "velvet σ={sigma:.2} sheen={} ρd={}",
                rgb(sheen),
                rgb(diffuse)
            ),
            lobes: vec![],
            bounded: false,
        }
    }

    /// Powders, dust, plaster, the moon: Lommel–Seeliger with an opposition surge, sometimes
    /// mixed with a Lambertian share.
    fn dusty(&mut self) -> Built {
        let albedo = self.colour().map(|c| c.sqrt().min(0.99));
        let surge = self.uniform(0.1, 1.5);
        let width = self.log_uniform(0.02, 0.4);
        let dust = Box::new(LommelSeeliger {
            albedo,
            surge,
            width,
        });
        let label = format!(
            "lommel-seeliger w={} B0={surge:.2} h={width:.3}",
            rgb(albedo)
        );
        if self.chance(0.4) {
            let share = self.uniform(0.2, 0.8);
            let (base, base_label) = self.diffuse_base(1.0);
            Built {
                brdf: Box::new(Mixture {
                    parts: vec![(1.0 - share, dust), (share, base)],
                }),
                label: format!("{label} mixed {share:.2} with {base_label}"),
                lobes: vec![],
                bounded: false,
            }
        } else {
            Built {
                brdf: dust,
                label,
                lobes: vec![],
                bounded: false,
            }
        }
    }

    /// A coat that absorbs, of random roughness (0.02 to 0.4) and tint, over a capped base.
    fn layered_coat(&mut self) -> Built {
        let base = match self.below(20) {
            0..9 => self.diffuse(),
            9..13 => self.metal(),
            13..18 => self.glossy(),
            _ => self.anisotropic(),
        }
        .capped();
        let ior = self.uniform(1.35, 1.75);
        let roughness = self.alpha(0.02, 0.4);
        let distribution = self.distribution();
        let optical_depth = if self.chance(0.35) {
            [0.0; 3]
        } else {
            let tint = self.colour().map(|c| c.clamp(0.02, 0.98));
            let thickness = self.uniform(0.1, 1.5);
            tint.map(|t| -0.5 * t.ln() * thickness)
        };
        let mut lobes = base.lobes;
        lobes.push(Lobe::flat(roughness, roughness, 0.0));
        Built {
            brdf: Box::new(AbsorbingCoat {
                base: base.brdf,
                ior,
                roughness,
                distribution,
                optical_depth,
            }),
            label: format!(
                "absorbing coat {distribution:?} ior={ior:.2} α={roughness:.3} τ={} over [{}]",
                rgb(optical_depth),
                base.label
            ),
            lobes,
            bounded: false,
        }
    }

    /// A thin film (oxide, soap, anti-reflection coat) on a metal, or on a dielectric over a
    /// dyed base.
    fn thin_film(&mut self) -> Built {
        let alpha = self.alpha(0.02, 0.4);
        let distribution = self.distribution();
        let film_ior = self.uniform(1.3, 2.4);
        let thickness_nm = self.uniform(50.0, 900.0);
        let (eta, k, diffuse, name) = if self.chance(0.6) {
            let (name, eta, k) = METALS[self.below(METALS.len())];
            (eta, k, [0.0; 3], name.to_string())
        } else {
            let n = self.uniform(1.4, 1.9);
            let d = self.colour().map(|c| c * 0.8);
            (
                [n; 3],
                [0.0; 3],
                d,
                format!("dielectric η={n:.2} ρd={}", rgb(d)),
            )
        };
        Built {
            brdf: Box::new(ThinFilm {
                facets: Microfacet::isotropic(
                    distribution,
                    alpha,
                    Fresnel::Schlick { f0: [1.0; 3] },
                ),
                film_ior,
                thickness_nm,
                eta,
                k,
                diffuse,
            }),
            label: format!(
                "thin film n={film_ior:.2} d={thickness_nm:.0} nm {distribution:?} α={alpha:.3} on {name}"
            ),
            lobes: vec![Lobe::flat(alpha, alpha, 0.0)],
            bounded: false,
        }
    }
}
