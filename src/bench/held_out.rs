//! Held-out materials: database materials from a seed the basis never saw, and hand-built
//! ones from compositions the generator never makes.

use crate::materials::Brdf;
use crate::materials::database::{DatabaseSpec, Family, material};
use crate::materials::models::{
    ClearCoat, Distribution, Fresnel, Lambert, Microfacet, Mixture, OrenNayar, Retroreflective,
    Sheen,
};

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
    ];
    all.into_iter().take(count).collect()
}

/// Number of hand-built materials.
pub const HAND_BUILT: usize = 5;
