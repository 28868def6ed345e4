//! Families built in layers or from other materials: clear and absorbing coats, thin
//! films, mixtures and bi-scale surfaces.

use super::albedo::{Built, Lobe, facet_lobes};
use super::families::{Gen, METALS, rgb};
use crate::materials::biscale::{BiScale, GrooveProfile};
use crate::materials::layered::{AbsorbingCoat, ThinFilm};
use crate::materials::models::{ClearCoat, Fresnel, Microfacet, Mixture};
use std::f64::consts::PI;

impl Gen {
    pub(super) fn clear_coat(&mut self) -> Built {
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

    pub(super) fn mixture(&mut self) -> Built {
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

    pub(super) fn grooves(&mut self) -> Built {
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

    pub(super) fn bumps(&mut self) -> Built {
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

    /// A coat that absorbs, of random roughness (0.02 to 0.4) and tint, over a capped base.
    pub(super) fn layered_coat(&mut self) -> Built {
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
    pub(super) fn thin_film(&mut self) -> Built {
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
