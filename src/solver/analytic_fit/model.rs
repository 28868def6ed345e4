//! The fitted model: Lambert plus a microfacet lobe, with an optional clear coat or haze
//! and an edge-tinted conductor's Fresnel, and its evaluation prepared once per model.

use crate::materials::Brdf;
use crate::materials::models::{
    Distribution, Fresnel, Lambert, Microfacet, above, cos_half_difference, schlick,
};
use glam::DVec3;
use std::f64::consts::FRAC_1_PI;

/// Lambertian albedo plus an anisotropic microfacet lobe (GGX or Beckmann) with Schlick
/// Fresnel, weighted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertMicrofacet {
    /// Diffuse albedo per channel (ρ_d = albedo/π).
    pub albedo: [f64; 3],
    /// Specular reflectance at normal incidence per channel.
    pub f0: [f64; 3],
    /// The lobe's weight in [0, 1] (1: Schlick's Fresnel alone). Schlick's grazing rise
    /// reaches 1 whatever F0, so without it a fit to a dark diffuse material keeps a lobe
    /// that no painted bin forbids and that outshines the material at grazing angles.
    pub specular: f64,
    /// The lobe's microfacet distribution.
    pub distribution: Distribution,
    /// Roughness along the rotated tangent.
    pub alpha_x: f64,
    /// Roughness along the rotated bitangent.
    pub alpha_y: f64,
    /// Angle (radians) the anisotropy axes are turned about the normal.
    pub rotation: f64,
    /// A clear coat over the first lobe ([`FitOptions::coat_margin`]): a second, isotropic lobe
    /// of the same distribution with its own F0 and roughness.
    pub coat: Option<Coat>,
    /// A haze beside the first lobe ([`FitOptions::haze_margin`]): a share of the lobe's
    /// reflectance spread over a second, isotropic lobe of its own distribution with the same
    /// Fresnel.
    pub haze: Option<Haze>,
    /// The lobe's edge tint per channel ([`FitOptions::edge_margin`]): its Fresnel is then a
    /// conductor's, exact, with reflectance `f0` at normal incidence
    /// ([`conductor_from_edge_tint`]); `None`: Schlick's.
    pub edge: Option<[f64; 3]>,
}

/// Gulbrandsen's artist-friendly conductor (2014): the index of refraction η and extinction κ
/// whose Fresnel reflectance is `r` at normal incidence, the edge tint `g` in [0, 1] choosing
/// between a dielectric (0: κ = 0, η = (1 + √r)/(1 − √r)) and a strong metal (1: η =
/// (1 − r)/(1 + r)). Every η, κ a real metal or dielectric has between the two is reached.
pub fn conductor_from_edge_tint(r: f64, g: f64) -> (f64, f64) {
    let r = r.clamp(0.0, 0.9999);
    let root = r.sqrt();
    let n = g * (1.0 - r) / (1.0 + r) + (1.0 - g) * (1.0 + root) / (1.0 - root);
    let k2 = (r * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - r);
    (n, k2.max(0.0).sqrt())
}

/// The clear coat of a [`LambertMicrofacet`]: a lobe with Schlick Fresnel from `f0`, weight 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coat {
    /// Specular reflectance at normal incidence per channel.
    pub f0: [f64; 3],
    /// Isotropic roughness.
    pub alpha: f64,
}

/// The haze of a [`LambertMicrofacet`]: the share of the first lobe's reflectance its second
/// lobe takes, and that lobe's isotropic roughness. Polished metals show one: a sharp peak
/// over a broad glow from scratches and grain (Ngan et al. 2005 fit measured metals with two
/// lobes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Haze {
    /// The glow's own distribution: a sharp GGX peak often sits on a Gaussian (Beckmann) glow.
    pub distribution: Distribution,
    /// The second lobe's share of the first's reflectance, in [0, 1].
    pub share: f64,
    /// The second lobe's isotropic roughness.
    pub alpha: f64,
}

impl LambertMicrofacet {
    /// The model as the library's Lambert and microfacet lobe, whose sum [`Brdf::eval`]
    /// computes through [`Self::eval_from_lobes`].
    pub(super) fn parts(&self) -> (Lambert, Microfacet) {
        (
            Lambert {
                albedo: self.albedo,
            },
            Microfacet {
                distribution: self.distribution,
                alpha_x: self.alpha_x,
                alpha_y: self.alpha_y,
                rotation: self.rotation,
                fresnel: self.fresnel(),
                tint: [self.specular; 3],
            },
        )
    }

    /// The first lobe's Fresnel: Schlick's from F0, or with an edge tint the conductor it names.
    pub(super) fn fresnel(&self) -> Fresnel {
        match self.edge {
            None => Fresnel::Schlick { f0: self.f0 },
            Some(edge) => {
                let conductors = [0, 1, 2].map(|c| conductor_from_edge_tint(self.f0[c], edge[c]));
                Fresnel::Conductor {
                    eta: conductors.map(|(n, _)| n),
                    k: conductors.map(|(_, k)| k),
                }
            }
        }
    }

    /// The second lobe (a coat's, or a haze's with the first lobe's Fresnel) as the library's
    /// microfacet lobe, if there is one.
    pub(super) fn second_part(&self) -> Option<Microfacet> {
        let coat = self.coat.map(|second| {
            Microfacet::isotropic(
                self.distribution,
                second.alpha,
                Fresnel::Schlick { f0: second.f0 },
            )
        });
        let haze = self
            .haze
            .map(|haze| Microfacet::isotropic(haze.distribution, haze.alpha, self.fresnel()));
        coat.or(haze)
    }

    /// ρ from each lobe's D·G/(4 cos θ_l cos θ_v) (`dg` and `dg_second`, as
    /// [`Microfacet::eval_unit_fresnel`] gives them; the second is ignored without a second
    /// lobe), the first lobe's Fresnel (`self.fresnel()`, worked out once per model rather
    /// than per bin) and the half-difference cosine. [`Brdf::eval`] is this, so the fit can
    /// reuse one `dg` across every parameter but a lobe's shape and still step on `eval`'s
    /// bits.
    #[inline]
    pub(super) fn eval_from_lobes(
        &self,
        fresnel: &Fresnel,
        visible: bool,
        dg: f64,
        dg_second: f64,
        cos_d: f64,
    ) -> [f64; 3] {
        if !visible {
            return [0.0; 3];
        }
        let dg = match self.haze {
            Some(haze) => (1.0 - haze.share) * dg + haze.share * dg_second,
            None => dg,
        };
        let fresnel = match fresnel {
            Fresnel::Conductor { .. } if dg == 0.0 => [0.0; 3],
            fresnel => fresnel.eval(cos_d),
        };
        std::array::from_fn(|c| {
            let specular = if dg == 0.0 {
                0.0
            } else {
                self.specular * fresnel[c] * dg
            };
            let mut rho = self.albedo[c] * FRAC_1_PI + specular;
            if let Some(second) = self.coat
                && dg_second != 0.0
            {
                rho += schlick(second.f0[c], cos_d) * dg_second;
            }
            rho
        })
    }
}

/// A model with its lobes and their Fresnel worked out once, to evaluate many bins with the
/// bits [`Brdf::eval`] gives.
pub(super) struct Prepared {
    pub(super) model: LambertMicrofacet,
    pub(super) lobe: Microfacet,
    pub(super) second: Option<Microfacet>,
}

impl Prepared {
    pub(super) fn new(model: LambertMicrofacet) -> Self {
        Self {
            lobe: model.parts().1,
            second: model.second_part(),
            model,
        }
    }

    #[inline]
    pub(super) fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        let dg_second = self
            .second
            .as_ref()
            .map_or(0.0, |second| second.eval_unit_fresnel(l, v));
        self.model.eval_from_lobes(
            &self.lobe.fresnel,
            above(l, v),
            self.lobe.eval_unit_fresnel(l, v),
            dg_second,
            cos_half_difference(l, v),
        )
    }
}

impl Brdf for LambertMicrofacet {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        Prepared::new(*self).eval(l, v)
    }
    fn is_isotropic(&self) -> bool {
        self.alpha_x == self.alpha_y
    }
}
