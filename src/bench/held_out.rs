//! Held-out materials: database materials from a seed the basis never saw, and hand-built
//! ones from compositions the generator never makes.

use crate::materials::Brdf;
use crate::materials::database::{DatabaseSpec, Family, material};
use crate::materials::models::schlick;
use crate::materials::models::{
    ClearCoat, Distribution, Fresnel, Lambert, Microfacet, Mixture, OrenNayar, Retroreflective,
    Sheen,
};
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI};

/// The seed of the held-out database materials; differs from every basis database's seed.
pub const HELD_OUT_SEED: u64 = 0x4e1d_0a7e;

/// One material to reconstruct.
#[derive(Debug)]
pub struct HeldOut {
    /// Short unique name.
    pub name: String,
    /// The database family, or "hand-built".
    pub family: &'static str,
    /// Human-readable parameters.
    pub label: String,
    /// True when Lambert plus GGX (Schlick or conductor Fresnel) describes it: the analytic
    /// baseline's own model family.
    pub lambert_ggx: bool,
    pub brdf: Box<dyn Brdf>,
}

/// Database materials `0..count` of [`HELD_OUT_SEED`]: 20 in a row cover every family.
pub fn database_materials(count: usize) -> Vec<HeldOut> {
    assert_ne!(
        HELD_OUT_SEED,
        DatabaseSpec::default().seed,
        "held out means another seed"
    );
    (0..count)
        .map(|i| {
            let m = material(HELD_OUT_SEED, i);
            let lambert_ggx = match m.family {
                Family::Diffuse => true,
                // Plastic over a Lambert base, or a bare metal, with a GGX lobe.
                Family::Glossy | Family::Metal | Family::Anisotropic => {
                    m.label.contains("Ggx") && !m.label.contains("oren-nayar")
                }
                _ => false,
            };
            HeldOut {
                name: format!("db{i:02}-{}", m.family.name()),
                family: m.family.name(),
                label: m.label,
                lambert_ggx,
                brdf: m.brdf,
            }
        })
        .collect()
}

/// Minnaert's limb-darkening law (lunar and planetary photometry):
/// ρ = albedo·(k + 1)/(2π)·(cos θ_l cos θ_v)^(k − 1); k > 1 darkens toward grazing, k < 1 brightens.
#[derive(Debug)]
struct Minnaert {
    albedo: [f64; 3],
    k: f64,
}

impl Brdf for Minnaert {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let s = (l.z * v.z).powf(self.k - 1.0) * (self.k + 1.0) * 0.5 * FRAC_1_PI;
        self.albedo.map(|a| a * s)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// A microfacet lobe with Burley's generalised Trowbridge–Reitz distribution (tail exponent
/// γ) and Kelemen's masking approximation G/(4 cos θ_l cos θ_v) ≈ 1/(4 cos² θ_d), over a
/// Lambertian base: a distribution and a masking term the generator uses neither of.
#[derive(Debug)]
struct GeneralisedTrowbridgeReitz {
    alpha: f64,
    gamma: f64,
    f0: [f64; 3],
    diffuse: [f64; 3],
}

impl Brdf for GeneralisedTrowbridgeReitz {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let h = (l + v).normalize();
        let (a2, g) = (self.alpha * self.alpha, self.gamma);
        let norm = (g - 1.0) * (a2 - 1.0) / (PI * (1.0 - a2.powf(1.0 - g)));
        let d = norm / (1.0 + (a2 - 1.0) * h.z * h.z).powf(g);
        let cos_d = (0.5 + 0.5 * l.dot(v)).max(0.0).sqrt().max(1e-6);
        let spec = d / (4.0 * cos_d * cos_d);
        [0, 1, 2].map(|c| self.diffuse[c] * FRAC_1_PI + schlick(self.f0[c], cos_d) * spec)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Two-tone "flop" paint: a diffuse colour that shifts from `face` at normal incidence to
/// `edge` toward grazing, under a clear gloss lobe.
#[derive(Debug)]
struct Flop {
    face: [f64; 3],
    edge: [f64; 3],
    gloss: Microfacet,
}

impl Brdf for Flop {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let t = (1.0 - (l.z * v.z).sqrt()).powi(2);
        let s = self.gloss.eval(l, v);
        [0, 1, 2].map(|c| (self.face[c] * (1.0 - t) + self.edge[c] * t) * FRAC_1_PI + s[c])
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Single scattering in a forward-scattering medium (Henyey–Greenstein phase g, Hanrahan and
/// Krueger's layer term 1/(cos θ_l + cos θ_v)) plus a fifth of Lambertian multiple scattering:
/// skin, wax, milk-like looks.
#[derive(Debug)]
struct ForwardScattering {
    albedo: [f64; 3],
    g: f64,
}

impl Brdf for ForwardScattering {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let cos = -l.dot(v);
        let g = self.g;
        let phase = (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5));
        let s = phase / (l.z + v.z);
        self.albedo.map(|a| a * s + 0.2 * a * FRAC_1_PI)
    }
    fn is_isotropic(&self) -> bool {
        true
    }
}

/// Hand-built materials the generator does not make, and one the analytic baseline fits
/// exactly; `count` of them, at most [`HAND_BUILT`].
pub fn hand_built_materials(count: usize) -> Vec<HeldOut> {
    let all: Vec<HeldOut> = vec![
        HeldOut {
            name: "hand-layered-paint".into(),
            family: "hand-built",
            label: "clear coat α=0.04 over a blue Beckmann metallic flake layer on Oren–Nayar"
                .into(),
            lambert_ggx: false,
            brdf: Box::new(ClearCoat {
                base: Box::new(Mixture {
                    parts: vec![
                        (
                            0.7,
                            Box::new(OrenNayar {
                                albedo: [0.02, 0.05, 0.25],
                                sigma: 0.4,
                            }),
                        ),
                        (
                            0.3,
                            Box::new(Microfacet::isotropic(
                                Distribution::Beckmann,
                                0.35,
                                Fresnel::Schlick {
                                    f0: [0.35, 0.45, 0.8],
                                },
                            )),
                        ),
                    ],
                }),
                ior: 1.5,
                roughness: 0.04,
            }),
        },
        HeldOut {
            name: "hand-retroreflector".into(),
            family: "hand-built",
            label: "pure retroreflective lobe, n = 12, no diffuse base".into(),
            lambert_ggx: false,
            brdf: Box::new(Retroreflective {
                color: [0.8, 0.75, 0.6],
                exponent: 12.0,
            }),
        },
        HeldOut {
            name: "hand-velvet".into(),
            family: "hand-built",
            label: "cloth: strong sheen r = 0.35 over dark red Oren–Nayar".into(),
            lambert_ggx: false,
            brdf: Box::new(Mixture {
                parts: vec![
                    (
                        1.0,
                        Box::new(OrenNayar {
                            albedo: [0.12, 0.01, 0.02],
                            sigma: 0.8,
                        }),
                    ),
                    (
                        1.0,
                        Box::new(Sheen {
                            color: [0.9, 0.5, 0.55],
                            roughness: 0.35,
                        }),
                    ),
                ],
            }),
        },
        HeldOut {
            name: "hand-two-lobe-metal".into(),
            family: "hand-built",
            label: "gold: sharp GGX α=0.05 plus haze Beckmann α=0.4".into(),
            lambert_ggx: false,
            brdf: Box::new(Mixture {
                parts: vec![
                    (
                        0.7,
                        Box::new(Microfacet::isotropic(
                            Distribution::Ggx,
                            0.05,
                            Fresnel::Conductor {
                                eta: [0.143, 0.374, 1.442],
                                k: [3.983, 2.385, 1.603],
                            },
                        )),
                    ),
                    (
                        0.3,
                        Box::new(Microfacet::isotropic(
                            Distribution::Beckmann,
                            0.4,
                            Fresnel::Conductor {
                                eta: [0.143, 0.374, 1.442],
                                k: [3.983, 2.385, 1.603],
                            },
                        )),
                    ),
                ],
            }),
        },
        HeldOut {
            name: "hand-lambert-ggx".into(),
            family: "hand-built",
            label: "green plastic: Lambert + anisotropic GGX α=(0.08, 0.3), rot 0.6, F0 0.04"
                .into(),
            lambert_ggx: true,
            brdf: Box::new(Mixture {
                parts: vec![
                    (
                        1.0,
                        Box::new(Lambert {
                            albedo: [0.05, 0.35, 0.08],
                        }),
                    ),
                    (
                        1.0,
                        Box::new(Microfacet {
                            distribution: Distribution::Ggx,
                            alpha_x: 0.08,
                            alpha_y: 0.3,
                            rotation: 0.6,
                            fresnel: Fresnel::Schlick { f0: [0.04; 3] },
                            tint: [1.0; 3],
                        }),
                    ),
                ],
            }),
        },
        HeldOut {
            name: "hand-minnaert-dark".into(),
            family: "hand-built",
            label: "Minnaert k = 1.4 (limb darkening), albedo (0.4, 0.3, 0.2)".into(),
            lambert_ggx: false,
            brdf: Box::new(Minnaert {
                albedo: [0.4, 0.3, 0.2],
                k: 1.4,
            }),
        },
        HeldOut {
            name: "hand-gtr-plastic".into(),
            family: "hand-built",
            label: "red plastic: GTR γ = 1.5 α = 0.15 with Kelemen masking, F0 0.04".into(),
            lambert_ggx: false,
            brdf: Box::new(GeneralisedTrowbridgeReitz {
                alpha: 0.15,
                gamma: 1.5,
                f0: [0.04; 3],
                diffuse: [0.5, 0.1, 0.1],
            }),
        },
        HeldOut {
            name: "hand-flop-paint".into(),
            family: "hand-built",
            label: "two-tone paint, blue face to purple edge, GGX α = 0.06 gloss".into(),
            lambert_ggx: false,
            brdf: Box::new(Flop {
                face: [0.05, 0.2, 0.5],
                edge: [0.4, 0.05, 0.3],
                gloss: Microfacet::isotropic(
                    Distribution::Ggx,
                    0.06,
                    Fresnel::Schlick { f0: [0.05; 3] },
                ),
            }),
        },
        HeldOut {
            name: "hand-forward-scattering".into(),
            family: "hand-built",
            label: "skin-like forward scattering, Henyey-Greenstein g = 0.6".into(),
            lambert_ggx: false,
            brdf: Box::new(ForwardScattering {
                albedo: [0.8, 0.5, 0.4],
                g: 0.6,
            }),
        },
        HeldOut {
            name: "hand-gtr-metal".into(),
            family: "hand-built",
            label: "copper-like metal: GTR γ = 3 α = 0.25 with Kelemen masking".into(),
            lambert_ggx: false,
            brdf: Box::new(GeneralisedTrowbridgeReitz {
                alpha: 0.25,
                gamma: 3.0,
                f0: [0.9, 0.6, 0.3],
                diffuse: [0.0; 3],
            }),
        },
        HeldOut {
            name: "hand-coated-brushed".into(),
            family: "hand-built",
            label: "clear coat α = 0.2 over brushed Beckmann metal α = (0.4, 0.08) turned 1.1 rad"
                .into(),
            lambert_ggx: false,
            brdf: Box::new(ClearCoat {
                base: Box::new(Microfacet {
                    distribution: Distribution::Beckmann,
                    alpha_x: 0.4,
                    alpha_y: 0.08,
                    rotation: 1.1,
                    fresnel: Fresnel::Schlick {
                        f0: [0.6, 0.6, 0.65],
                    },
                    tint: [1.0; 3],
                }),
                ior: 1.5,
                roughness: 0.2,
            }),
        },
    ];
    all.into_iter().take(count).collect()
}

/// Number of hand-built materials.
pub const HAND_BUILT: usize = 11;
