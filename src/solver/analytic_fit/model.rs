//! The fitted model: Lambert (or Oren–Nayar) diffuse plus a microfacet lobe, with an optional clear coat or haze
//! and an edge-tinted conductor's Fresnel, and its evaluation prepared once per model.

use crate::materials::Brdf;
use crate::materials::models::{
    Distribution, Fresnel, LobeShape, Masking, Microfacet, OrenNayar, above, cos_half_difference,
    oren_nayar_scale, schlick,
};
use glam::DVec3;

/// Lambertian albedo plus an anisotropic microfacet lobe (GGX or Beckmann) with Schlick
/// Fresnel, weighted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertMicrofacet {
    /// Diffuse albedo per channel (ρ_d = albedo/π where `sigma` is 0).
    pub albedo: [f64; 3],
    /// The diffuse's Oren–Nayar facet slope σ (radians; [`FitOptions::rough_margin`]); 0:
    /// Lambert's.
    pub sigma: f64,
    /// Specular reflectance at normal incidence per channel.
    pub f0: [f64; 3],
    /// The lobe's weight in [0, 1] (1: Schlick's Fresnel alone). Schlick's grazing rise
    /// reaches 1 whatever F0, so without it a fit to a dark diffuse material keeps a lobe
    /// that no painted bin forbids and that outshines the material at grazing angles.
    ///
    /// The paint hardly tells it from F0: the lobe is `specular · F0` at normal incidence, and
    /// only Schlick's rise `specular · (1 − F0)(1 − cos θ_d)⁵` tells them apart, a few
    /// millionths at one view's θ_d (22.5° under a light at 45°) and a few ten-thousandths at
    /// 35°. The fit leaves it where the optimiser's path ends (an 8-bit painting of a plastic
    /// kept 0.49 where its HDR painting kept 0.95, and extrapolated half the grazing peak).
    /// Raising it to 1 wherever the paint allows was measured and rejected: a Lafortune
    /// material's one view went 0.22 → 0.70 (relative RMSE) and the database's folds 0.0340 →
    /// 0.0346 (geometric mean); for metals' fits alone, 0.0348, a nickel's one view 0.005 →
    /// 0.011. The database, not a rule, would have to decide it.
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
    /// How the lobes' facets mask each other ([`FitOptions::cavity_margin`]): Smith's, or
    /// Cook and Torrance's V-cavities. Blinn–Phong's and Ashikhmin–Shirley's lobes bring their
    /// own.
    pub masking: Masking,
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
    /// The model as the library's Oren–Nayar diffuse (Lambert's bits where `sigma` is 0) and
    /// microfacet lobe, whose sum [`Brdf::eval`] computes through [`Self::eval_from_lobes`].
    pub(super) fn parts(&self) -> (OrenNayar, Microfacet) {
        (
            OrenNayar {
                albedo: self.albedo,
                sigma: self.sigma,
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

    /// The first lobe's D·G₂/(4 cos θ_l cos θ_v) under the model's masking, prepared for many
    /// bins.
    pub(super) fn lobe_shape(&self) -> LobeShape {
        self.parts().1.shape().with_masking(self.masking)
    }

    /// The second lobe's (a coat's or a haze's) D·G₂/(4 cos θ_l cos θ_v) under the model's
    /// masking, if there is one.
    pub(super) fn second_shape(&self) -> Option<LobeShape> {
        self.second_part()
            .map(|second| second.shape().with_masking(self.masking))
    }

    /// The diffuse's ρ at unit albedo for a pair above the surface: 1/π where `sigma` is 0.
    #[inline]
    pub(super) fn diffuse_scale(&self, l: DVec3, v: DVec3) -> f64 {
        oren_nayar_scale(self.sigma, l, v)
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

    /// ρ from the diffuse's ρ at unit albedo (`diffuse`, [`Self::diffuse_scale`]), each lobe's
    /// D·G/(4 cos θ_l cos θ_v) (`dg` and `dg_second`, as
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
        diffuse: f64,
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
            let mut rho = self.albedo[c] * diffuse + specular;
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
/// bits [`Brdf::eval`] gives: tabulate this rather than the model (1.3 million pairs).
#[derive(Clone, Debug)]
pub struct Prepared {
    pub(super) model: LambertMicrofacet,
    fresnel: Fresnel,
    lobe: LobeShape,
    second: Option<LobeShape>,
}

impl Prepared {
    pub fn new(model: LambertMicrofacet) -> Self {
        Self {
            fresnel: model.fresnel(),
            lobe: model.lobe_shape(),
            second: model.second_shape(),
            model,
        }
    }

    #[inline]
    pub(super) fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        let dg_second = self.second.as_ref().map_or(0.0, |second| second.eval(l, v));
        self.model.eval_from_lobes(
            &self.fresnel,
            above(l, v),
            self.model.diffuse_scale(l, v),
            self.lobe.eval(l, v),
            dg_second,
            cos_half_difference(l, v),
        )
    }
}

impl Brdf for Prepared {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        Prepared::eval(self, l, v)
    }
    fn is_isotropic(&self) -> bool {
        self.model.is_isotropic()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::models::fresnel_conductor;
    use std::f64::consts::FRAC_1_PI;

    const PLASTIC: LambertMicrofacet = LambertMicrofacet {
        albedo: [0.4, 0.2, 0.1],
        sigma: 0.0,
        f0: [0.04; 3],
        specular: 0.8,
        distribution: Distribution::Ggx,
        alpha_x: 0.2,
        alpha_y: 0.2,
        rotation: 0.0,
        coat: None,
        haze: None,
        edge: None,
        masking: Masking::Smith,
    };

    /// Reflectance at normal incidence of a conductor η + iκ, written out.
    fn normal_reflectance(eta: f64, k: f64) -> f64 {
        ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
    }

    /// Whatever the edge tint, the conductor it names reflects `r` at normal incidence; a
    /// tint of 0 is the dielectric of that reflectance and 1 the strongest metal, and the index
    /// falls as the tint rises.
    #[test]
    fn an_edge_tint_names_a_conductor_that_reflects_f0_head_on() {
        for r in [0.02, 0.04, 0.3, 0.6, 0.95] {
            let root: f64 = f64::sqrt(r);
            let mut last_eta = f64::INFINITY;
            for g in [0.0, 0.25, 0.5, 0.75, 1.0] {
                let (eta, k) = conductor_from_edge_tint(r, g);
                assert!(eta.is_finite() && k.is_finite() && k >= 0.0, "{r} {g}");
                assert!((normal_reflectance(eta, k) - r).abs() < 1e-9, "{r} {g}");
                assert!((fresnel_conductor(1.0, eta, k) - r).abs() < 1e-9, "{r} {g}");
                assert!(eta < last_eta, "{r} {g}: η {eta} after {last_eta}");
                last_eta = eta;
                if g == 0.0 {
                    assert!((eta - (1.0 + root) / (1.0 - root)).abs() < 1e-9 * eta);
                    assert!(k < 1e-6, "{r}: κ {k}");
                }
                if g == 1.0 {
                    assert!((eta - (1.0 - r) / (1.0 + r)).abs() < 1e-12, "{r}: η {eta}");
                }
            }
        }
        // Reflectances outside [0, 1) are held inside it rather than named as NaN.
        let (eta, k) = conductor_from_edge_tint(0.0, 0.0);
        assert!((eta - 1.0).abs() < 1e-12 && k == 0.0);
        let (eta, k) = conductor_from_edge_tint(-0.5, 0.5);
        assert!((eta - 1.0).abs() < 1e-12 && k == 0.0, "{eta} {k}");
        let (eta, k) = conductor_from_edge_tint(1.5, 0.5);
        assert!(eta.is_finite() && k.is_finite());
        assert!(
            (normal_reflectance(eta, k) - 0.9999).abs() < 1e-6,
            "{eta} {k}"
        );
    }

    /// Without an edge tint the lobe's Fresnel is Schlick's from F0; with one, each channel
    /// is the conductor its F0 and tint name, for the first lobe and for a haze alike.
    #[test]
    fn the_fresnel_is_schlicks_or_the_conductor_an_edge_tint_names() {
        assert_eq!(PLASTIC.fresnel(), Fresnel::Schlick { f0: [0.04; 3] });
        assert_eq!(PLASTIC.parts().1.fresnel, PLASTIC.fresnel());
        let gold = LambertMicrofacet {
            albedo: [0.0; 3],
            f0: [0.9, 0.6, 0.3],
            edge: Some([0.1, 0.5, 0.9]),
            haze: Some(Haze {
                distribution: Distribution::Beckmann,
                share: 0.3,
                alpha: 0.4,
            }),
            ..PLASTIC
        };
        let Fresnel::Conductor { eta, k } = gold.fresnel() else {
            panic!("an edge tint gives Schlick's Fresnel");
        };
        for c in 0..3 {
            let (want_eta, want_k) = conductor_from_edge_tint(gold.f0[c], gold.edge.unwrap()[c]);
            assert_eq!((eta[c], k[c]), (want_eta, want_k), "channel {c}");
        }
        let glow = gold.second_part().expect("a haze is a second lobe");
        assert_eq!(glow.fresnel, gold.fresnel());
        assert_eq!(glow.distribution, Distribution::Beckmann);
        assert_eq!((glow.alpha_x, glow.alpha_y), (0.4, 0.4));
        // A coat's lobe has its own Schlick Fresnel and the first lobe's distribution.
        let coated = LambertMicrofacet {
            coat: Some(Coat {
                f0: [0.05; 3],
                alpha: 0.03,
            }),
            ..gold
        };
        let coat = coated.second_part().unwrap();
        assert_eq!(coat.fresnel, Fresnel::Schlick { f0: [0.05; 3] });
        assert_eq!(coat.distribution, Distribution::Ggx);
        assert_eq!(PLASTIC.second_part(), None);
    }

    /// A pair with either direction under the surface reflects nothing, diffuse included;
    /// and a lobe whose distribution is zero adds nothing to the diffuse, conductor or not.
    #[test]
    fn nothing_is_reflected_below_the_horizon_and_a_zero_lobe_adds_nothing() {
        let up = DVec3::new(0.3, 0.1, 0.9).normalize();
        let down = DVec3::new(0.3, 0.1, -0.9).normalize();
        let metal = LambertMicrofacet {
            edge: Some([0.5; 3]),
            f0: [0.9; 3],
            ..PLASTIC
        };
        for model in [PLASTIC, metal] {
            assert_eq!(model.eval(up, down), [0.0; 3]);
            assert_eq!(model.eval(down, up), [0.0; 3]);
            let fresnel = model.fresnel();
            let rho = model.eval_from_lobes(&fresnel, true, FRAC_1_PI, 0.0, 0.0, 0.5);
            assert_eq!(rho, model.albedo.map(|a| a * FRAC_1_PI));
            assert_eq!(
                model.eval_from_lobes(&fresnel, false, FRAC_1_PI, 1.0, 1.0, 0.5),
                [0.0; 3]
            );
        }
        // A coat with nothing from its lobe adds nothing either.
        let coated = LambertMicrofacet {
            coat: Some(Coat {
                f0: [0.05; 3],
                alpha: 0.03,
            }),
            ..PLASTIC
        };
        let fresnel = coated.fresnel();
        let without = coated.eval_from_lobes(&fresnel, true, FRAC_1_PI, 0.5, 0.0, 0.7);
        let with = coated.eval_from_lobes(&fresnel, true, FRAC_1_PI, 0.5, 2.0, 0.7);
        for c in 0..3 {
            let lobe = 0.8 * schlick(0.04, 0.7) * 0.5;
            assert!((without[c] - (PLASTIC.albedo[c] * FRAC_1_PI + lobe)).abs() < 1e-15);
            assert!((with[c] - without[c] - schlick(0.05, 0.7) * 2.0).abs() < 1e-15);
        }
    }

    /// A haze mixes the two lobes' D·G by its share before the shared Fresnel and weight.
    #[test]
    fn a_haze_mixes_the_lobes_by_its_share() {
        let hazy = LambertMicrofacet {
            haze: Some(Haze {
                distribution: Distribution::Beckmann,
                share: 0.25,
                alpha: 0.5,
            }),
            ..PLASTIC
        };
        let fresnel = hazy.fresnel();
        let rho = hazy.eval_from_lobes(&fresnel, true, FRAC_1_PI, 2.0, 0.4, 0.6);
        for c in 0..3 {
            let mixed = 0.75 * 2.0 + 0.25 * 0.4;
            let want = PLASTIC.albedo[c] * FRAC_1_PI + 0.8 * schlick(0.04, 0.6) * mixed;
            assert!(
                (rho[c] - want).abs() < 1e-15,
                "{c}: {} against {want}",
                rho[c]
            );
        }
    }

    #[test]
    fn a_model_is_isotropic_only_when_its_two_roughnesses_agree() {
        assert!(PLASTIC.is_isotropic());
        let brushed = LambertMicrofacet {
            alpha_y: 0.05,
            ..PLASTIC
        };
        assert!(!brushed.is_isotropic());
        assert!(
            !LambertMicrofacet {
                alpha_x: 0.05,
                ..PLASTIC
            }
            .is_isotropic()
        );
    }
}
