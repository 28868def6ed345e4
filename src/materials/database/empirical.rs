//! Families with empirical lobes: Phong and Blinn–Phong, Lafortune, sheen, velvet,
//! retro-reflection and dust.

use super::albedo::{Built, Lobe};
use super::families::{Gen, rgb};
use crate::materials::Brdf;
use crate::materials::classic::{
    BlinnPhong, Lafortune, LafortuneLobe, LommelSeeliger, Phong, Velvet,
};
use crate::materials::models::{
    Distribution, Fresnel, Microfacet, Mixture, Retroreflective, Sheen,
};
use std::f64::consts::PI;

impl Gen {
    pub(super) fn sheen(&mut self) -> Built {
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

    pub(super) fn retro(&mut self) -> Built {
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
    pub(super) fn phong(&mut self) -> Built {
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
    pub(super) fn lafortune(&mut self) -> Built {
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

    pub(super) fn velvet(&mut self) -> Built {
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
    pub(super) fn dusty(&mut self) -> Built {
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
}
