//! The fit's unconstrained parameters: logistic albedo, F0, share and edge tint, logistic
//! log-roughness, the diffuse's logistic Oren–Nayar slope, and which of them a shape varies.

use super::model::{Coat, Haze, LambertMicrofacet};
use crate::materials::models::{Distribution, Masking};

/// Roughness bounds: below 0.01 a lobe is narrower than the 2° bins can show.
pub(super) const ALPHA_MIN: f64 = 0.01;
pub(super) const ALPHA_MAX: f64 = 1.5;
/// Parameters of one lobe: three albedo logits, three F0 logits, two log-roughness logits,
/// rotation, the specular weight's logit.
pub(super) const P_ONE: usize = 10;
/// The specular weight's logit: the last of one lobe's parameters.
pub(super) const SPECULAR: usize = P_ONE - 1;
/// With a second lobe: the logit of its grey F0 within the dielectric range and its
/// log-roughness logit after those.
pub(super) const P_COAT: usize = 12;
/// With an edge tint: its three logits after those.
pub(super) const EDGE: usize = P_COAT;
/// With a rough diffuse: the logit of its Oren–Nayar slope within [0, [`SIGMA_MAX`]].
pub(super) const SIGMA: usize = EDGE + 3;
/// With a GTR lobe: the logit of its tail exponent γ within [[`GAMMA_MIN`], [`GAMMA_MAX`]] last.
pub(super) const GAMMA: usize = SIGMA + 1;
pub(super) const P: usize = GAMMA + 1;
/// The parameters D·G of the first lobe depends on (its roughnesses, turn and GTR exponent),
/// and that of the second (its roughness).
pub(super) const SHAPE: [usize; 4] = [6, 7, 8, GAMMA];
pub(super) const COAT_SHAPE: usize = 11;
/// The second lobe's F0 is a dielectric coat's, grey: indices of refraction 1.33 to 1.8.
/// Why not free: with one light every painted bin has the same θ_d, so a free F0 trades the
/// lobe's height for its Fresnel rise at will; a coat's F0 ties the lobe's height to its width,
/// and a free second lobe fitted the shape of single-lobe materials (Ward, Blinn–Phong) by two
/// GGX lobes that extrapolated worse (measured in `PriorMean::Fitted`'s notes).
pub(super) const COAT_F0_MIN: f64 = 0.02;
pub(super) const COAT_F0_MAX: f64 = 0.08;

/// A parameter vector; the fit varies only the entries [`Shape::active`] lists.
pub(super) type Params = [f64; P];

/// GTR's tail exponents: Berry's long tails at 1 (Burley's clear coat) to a core tighter than
/// Beckmann's at 6; GGX is 2.
pub(super) const GAMMA_MIN: f64 = 1.0;
pub(super) const GAMMA_MAX: f64 = 6.0;

/// The roughest diffuse: Oren–Nayar's A and B have all but levelled off by a slope of
/// 1.2 rad, and the database's rough diffuse reaches 1.
pub(super) const SIGMA_MAX: f64 = 1.2;

/// What the fit varies beyond one lobe's ten parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Shape {
    pub(super) distribution: Distribution,
    /// A clear coat (a second lobe).
    pub(super) two_lobes: bool,
    /// A haze of this distribution (a second lobe sharing the first's Fresnel); never with a
    /// coat.
    pub(super) haze: Option<Distribution>,
    /// An edge tint per channel (a conductor's exact Fresnel instead of Schlick's).
    pub(super) edge: bool,
    /// A dielectric's exact Fresnel (η from F0, κ = 0) instead of Schlick's: no parameter of
    /// its own. Ignored with an edge tint, which reaches the dielectric at its least.
    pub(super) dielectric: bool,
    /// An Oren–Nayar diffuse of fitted slope instead of Lambert's.
    pub(super) rough_diffuse: bool,
    /// Only the diffuse varies (its albedo, and its slope where it is rough): every lobe
    /// parameter stays where it is.
    pub(super) diffuse_only: bool,
    /// Cook and Torrance's V-cavity masking instead of Smith's.
    pub(super) cavity: bool,
}

impl Shape {
    pub(super) fn one_lobe(distribution: Distribution) -> Self {
        Self {
            distribution,
            two_lobes: false,
            haze: None,
            edge: false,
            dielectric: false,
            rough_diffuse: false,
            diffuse_only: false,
            cavity: false,
        }
    }

    /// The indices of `Params` the fit varies, in order, and how many there are.
    pub(super) fn active(self) -> ([usize; P], usize) {
        let mut indices = [0; P];
        let mut n = 0;
        let mut take = |range: std::ops::Range<usize>| {
            for i in range {
                indices[n] = i;
                n += 1;
            }
        };
        if self.diffuse_only {
            take(0..3);
            if self.rough_diffuse {
                take(SIGMA..GAMMA);
            }
            return (indices, n);
        }
        take(0..P_ONE);
        if self.two_lobes || self.haze.is_some() {
            take(P_ONE..P_COAT);
        }
        if self.edge {
            take(EDGE..SIGMA);
        }
        if self.rough_diffuse {
            take(SIGMA..GAMMA);
        }
        if matches!(self.distribution, Distribution::Gtr { .. }) {
            take(GAMMA..P);
        }
        (indices, n)
    }
}

pub(super) fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

pub(super) fn logit(p: f64) -> f64 {
    let p = p.clamp(1e-6, 1.0 - 1e-6);
    (p / (1.0 - p)).ln()
}

pub(super) fn alpha_of(s: f64) -> f64 {
    // exp(ln) can round a hair past either end; the bounds are the model's.
    (ALPHA_MIN.ln() + (ALPHA_MAX / ALPHA_MIN).ln() * logistic(s))
        .exp()
        .clamp(ALPHA_MIN, ALPHA_MAX)
}

pub(super) fn alpha_param(alpha: f64) -> f64 {
    logit((alpha.ln() - ALPHA_MIN.ln()) / (ALPHA_MAX / ALPHA_MIN).ln())
}

pub(super) fn gamma_of(s: f64) -> f64 {
    GAMMA_MIN + (GAMMA_MAX - GAMMA_MIN) * logistic(s)
}

pub(super) fn gamma_param(gamma: f64) -> f64 {
    logit((gamma - GAMMA_MIN) / (GAMMA_MAX - GAMMA_MIN))
}

pub(super) fn model_of(theta: &Params, shape: Shape) -> LambertMicrofacet {
    let Shape {
        distribution,
        two_lobes,
        haze,
        edge,
        dielectric,
        rough_diffuse,
        cavity,
        ..
    } = shape;
    LambertMicrofacet {
        albedo: [0, 1, 2].map(|c| logistic(theta[c])),
        sigma: if rough_diffuse {
            SIGMA_MAX * logistic(theta[SIGMA])
        } else {
            0.0
        },
        f0: [0, 1, 2].map(|c| logistic(theta[3 + c])),
        distribution: match distribution {
            Distribution::Gtr { .. } => Distribution::Gtr {
                gamma: gamma_of(theta[GAMMA]),
            },
            other => other,
        },
        alpha_x: alpha_of(theta[6]),
        alpha_y: alpha_of(theta[7]),
        // A lobe turned by π is the same lobe: the reported angle stays in [0, π).
        rotation: theta[8].rem_euclid(std::f64::consts::PI),
        specular: logistic(theta[SPECULAR]),
        coat: two_lobes.then(|| Coat {
            f0: [COAT_F0_MIN + (COAT_F0_MAX - COAT_F0_MIN) * logistic(theta[P_ONE]); 3],
            alpha: alpha_of(theta[COAT_SHAPE]),
        }),
        haze: haze.filter(|_| !two_lobes).map(|distribution| Haze {
            distribution,
            share: logistic(theta[P_ONE]),
            alpha: alpha_of(theta[COAT_SHAPE]),
        }),
        edge: if edge {
            Some([0, 1, 2].map(|c| {
                let least = least_edge_tint(logistic(theta[3 + c]));
                least + (1.0 - least) * logistic(theta[EDGE + c])
            }))
        } else {
            dielectric.then(|| [0, 1, 2].map(|c| least_edge_tint(logistic(theta[3 + c]))))
        },
        masking: if cavity {
            Masking::VCavity
        } else {
            Masking::Smith
        },
    }
}

/// The highest index of refraction an edge tint may name. No material painted as a metal or
/// a dielectric has η much above germanium's (about 5.5 in visible light), yet Gulbrandsen's
/// dielectric end reaches any F0 with η alone: F0 = 0.97 there is η ≈ 117 and κ = 0. Where F0
/// is that high, views at a few θ_d hardly tell a conductor's Fresnel from such a dielectric's,
/// and a free tint wandered from one end to the other as views were added.
pub(super) const EDGE_ETA_MAX: f64 = 6.0;

/// The least edge tint whose conductor ([`conductor_from_edge_tint`]) has η at most
/// [`EDGE_ETA_MAX`] at normal-incidence reflectance `f0`: 0 for a dielectric's F0.
pub(super) fn least_edge_tint(f0: f64) -> f64 {
    let r = f0.clamp(0.0, 0.9999);
    let root = r.sqrt();
    let dielectric = (1.0 + root) / (1.0 - root);
    let metal = (1.0 - r) / (1.0 + r);
    ((dielectric - EDGE_ETA_MAX) / (dielectric - metal)).max(0.0)
}

/// The parameter of edge tint `g` at F0 `f0`, the inverse of [`model_of`]'s mapping.
pub(super) fn edge_param(f0: f64, g: f64) -> f64 {
    let least = least_edge_tint(f0);
    logit((g - least) / (1.0 - least))
}

pub(super) fn params_of(model: &LambertMicrofacet) -> Params {
    let mut theta = [0.0; P];
    for c in 0..3 {
        theta[c] = logit(model.albedo[c]);
        theta[3 + c] = logit(model.f0[c]);
    }
    theta[6] = alpha_param(model.alpha_x);
    theta[7] = alpha_param(model.alpha_y);
    theta[8] = model.rotation;
    theta[SPECULAR] = logit(model.specular);
    theta[SIGMA] = logit(model.sigma / SIGMA_MAX);
    if let Distribution::Gtr { gamma } = model.distribution {
        theta[GAMMA] = gamma_param(gamma);
    }
    if let Some(second) = model.coat {
        let grey = (second.f0[0] + second.f0[1] + second.f0[2]) / 3.0;
        theta[P_ONE] = logit((grey - COAT_F0_MIN) / (COAT_F0_MAX - COAT_F0_MIN));
        theta[COAT_SHAPE] = alpha_param(second.alpha);
    }
    if let Some(haze) = model.haze {
        theta[P_ONE] = logit(haze.share);
        theta[COAT_SHAPE] = alpha_param(haze.alpha);
    }
    if let Some(edge) = model.edge {
        for c in 0..3 {
            theta[EDGE + c] = edge_param(model.f0[c], edge[c]);
        }
    }
    theta
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_shape_varies_its_own_parameters() {
        let one = Shape::one_lobe(Distribution::Ggx);
        let cases = [
            (one, (0..P_ONE).collect::<Vec<_>>()),
            (
                Shape {
                    two_lobes: true,
                    ..one
                },
                (0..P_COAT).collect(),
            ),
            (
                Shape {
                    haze: Some(Distribution::Beckmann),
                    ..one
                },
                (0..P_COAT).collect(),
            ),
            (
                Shape { edge: true, ..one },
                (0..P_ONE).chain(EDGE..SIGMA).collect(),
            ),
            (
                Shape {
                    dielectric: true,
                    ..one
                },
                (0..P_ONE).collect(),
            ),
            (
                Shape {
                    haze: Some(Distribution::Ggx),
                    edge: true,
                    ..one
                },
                (0..SIGMA).collect(),
            ),
            (
                Shape {
                    rough_diffuse: true,
                    ..one
                },
                (0..P_ONE).chain(SIGMA..GAMMA).collect(),
            ),
            (
                Shape {
                    two_lobes: true,
                    edge: true,
                    rough_diffuse: true,
                    ..one
                },
                (0..GAMMA).collect(),
            ),
            (
                Shape {
                    two_lobes: true,
                    edge: true,
                    rough_diffuse: true,
                    ..Shape::one_lobe(Distribution::Gtr { gamma: 2.0 })
                },
                (0..P).collect(),
            ),
            (
                Shape::one_lobe(Distribution::Gtr { gamma: 2.0 }),
                (0..P_ONE).chain(GAMMA..P).collect(),
            ),
            (
                Shape {
                    edge: true,
                    rough_diffuse: true,
                    diffuse_only: true,
                    ..one
                },
                (0..3).chain(SIGMA..GAMMA).collect(),
            ),
            (
                Shape {
                    diffuse_only: true,
                    ..one
                },
                (0..3).collect(),
            ),
        ];
        for (shape, expected) in cases {
            let (active, n) = shape.active();
            assert_eq!(active[..n], expected[..], "{shape:?}");
        }
        assert!(SHAPE.iter().all(|&i| i < P_ONE || i == GAMMA));
        assert!((P_ONE..P_COAT).contains(&COAT_SHAPE));
        // A dielectric's Fresnel is the edge tint at its least: κ = 0 at a plastic's F0.
        let mut theta = [0.0; P];
        theta[3..6].fill(logit(0.04));
        let dielectric = Shape {
            dielectric: true,
            ..one
        };
        assert_eq!(model_of(&theta, dielectric).edge, Some([0.0; 3]));
        assert_eq!(model_of(&theta, one).edge, None);
    }

    #[test]
    fn the_maps_from_parameters_stay_in_their_ranges_and_invert() {
        assert_eq!(logistic(0.0), 0.5);
        for x in [-10.0, -2.0, 0.3, 5.0] {
            assert!((logistic(x) + logistic(-x) - 1.0).abs() < 1e-15);
            assert!((logit(logistic(x)) - x).abs() < 1e-6 * x.abs().max(1.0));
        }
        // Probabilities at or past the ends map to the clamped logit, never to ±∞.
        let end = (1e-6f64 / (1.0 - 1e-6)).ln();
        assert_eq!(logit(0.0), end);
        assert_eq!(logit(-1.0), end);
        assert!((logit(1.0) + end).abs() < 1e-9);
        let (lowest, highest) = (alpha_of(-1e3), alpha_of(1e3));
        assert!(
            lowest >= ALPHA_MIN && lowest - ALPHA_MIN < 1e-15,
            "{lowest}"
        );
        assert!(
            highest <= ALPHA_MAX && ALPHA_MAX - highest < 1e-14,
            "{highest}"
        );
        assert!((alpha_of(0.0) - (ALPHA_MIN * ALPHA_MAX).sqrt()).abs() < 1e-12);
        for alpha in [0.011, 0.1, 0.7, 1.4] {
            assert!(
                (alpha_of(alpha_param(alpha)) - alpha).abs() < 1e-9,
                "{alpha}"
            );
        }
    }

    /// A dielectric's F0 may take any tint; a metal's stops where η would pass
    /// [`EDGE_ETA_MAX`].
    #[test]
    fn the_least_edge_tint_keeps_eta_within_its_bound() {
        assert_eq!(least_edge_tint(0.04), 0.0);
        for f0 in [0.6, 0.8, 0.95] {
            let least = least_edge_tint(f0);
            assert!(least > 0.0 && least < 1.0, "{f0}: {least}");
            let (eta, _) = super::super::model::conductor_from_edge_tint(f0, least);
            assert!((eta - EDGE_ETA_MAX).abs() < 1e-9, "{f0}: η {eta}");
            for g in [least, 0.5 * (least + 1.0), 1.0] {
                let u = logistic(edge_param(f0, g));
                assert!((least + (1.0 - least) * u - g).abs() < 1e-6, "{f0} {g}");
            }
        }
    }
}
