//! The analytic baseline: Lambert plus an anisotropic microfacet lobe (GGX, and where asked
//! Beckmann beside it) fitted by Levenberg–Marquardt to the same binned samples the sparse
//! solver sees, as tools like BRDFLab fit analytic models.
//!
//! The residual of a bin is ln((ρ̂c + ε)/(ρc + ε)) per channel, weighted by the bin's pair
//! multiplicity: the log-mapped domain and weights the basis and its solver use, so both
//! methods minimise the same kind of error. A channel that is only a bound (clipped 8-bit
//! paint) costs nothing on the side the bound allows (a hinge). Bounds come from the parametrisation (logistic
//! albedo and F0, logistic log-roughness), so the optimiser itself is unconstrained. Several
//! starts run a few iterations each; the best ones are run to convergence.

use super::prior::PriorModel;
use super::sparse::{Bound, Bounds, EXACT};
use crate::basis::{MAP_EPSILON, cos_weight};
use crate::materials::Brdf;
pub use crate::materials::models::Distribution;
use crate::materials::models::{Fresnel, Lambert, Microfacet, above, cos_half_difference, schlick};
use crate::table::{PairIndex, bin_centre, pair_directions, pair_multiplicity};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4};

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
    fn parts(&self) -> (Lambert, Microfacet) {
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
    fn fresnel(&self) -> Fresnel {
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
    fn second_part(&self) -> Option<Microfacet> {
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
    fn eval_from_lobes(
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
struct Prepared {
    model: LambertMicrofacet,
    lobe: Microfacet,
    second: Option<Microfacet>,
}

impl Prepared {
    fn new(model: LambertMicrofacet) -> Self {
        Self {
            lobe: model.parts().1,
            second: model.second_part(),
            model,
        }
    }

    #[inline]
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
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

/// Roughness bounds: below 0.01 a lobe is narrower than the 2° bins can show.
const ALPHA_MIN: f64 = 0.01;
const ALPHA_MAX: f64 = 1.5;
/// Parameters of one lobe: three albedo logits, three F0 logits, two log-roughness logits,
/// rotation, the specular weight's logit.
const P_ONE: usize = 10;
/// With a second lobe: the logit of its grey F0 within the dielectric range and its
/// log-roughness logit after those.
const P_COAT: usize = 12;
/// With an edge tint: its three logits after those.
const EDGE: usize = P_COAT;
const P: usize = EDGE + 3;
/// The parameters D·G of the first lobe depends on (its roughnesses and turn), and that of
/// the second (its roughness).
const SHAPE: [usize; 3] = [6, 7, 8];
const COAT_SHAPE: usize = 11;
/// The second lobe's F0 is a dielectric coat's, grey: indices of refraction 1.33 to 1.8.
/// Why not free: with one light every painted bin has the same θ_d, so a free F0 trades the
/// lobe's height for its Fresnel rise at will; a coat's F0 ties the lobe's height to its width,
/// and a free second lobe fitted the shape of single-lobe materials (Ward, Blinn–Phong) by two
/// GGX lobes that extrapolated worse (measured in `PriorMean::Fitted`'s notes).
const COAT_F0_MIN: f64 = 0.02;
const COAT_F0_MAX: f64 = 0.08;

/// A parameter vector; the fit varies only the entries [`Shape::active`] lists.
type Params = [f64; P];

/// What the fit varies beyond one lobe's ten parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Shape {
    distribution: Distribution,
    /// A clear coat (a second lobe).
    two_lobes: bool,
    /// A haze of this distribution (a second lobe sharing the first's Fresnel); never with a
    /// coat.
    haze: Option<Distribution>,
    /// An edge tint per channel (a conductor's exact Fresnel instead of Schlick's).
    edge: bool,
}

impl Shape {
    fn one_lobe(distribution: Distribution) -> Self {
        Self {
            distribution,
            two_lobes: false,
            haze: None,
            edge: false,
        }
    }

    /// The indices of `Params` the fit varies, in order, and how many there are.
    fn active(self) -> ([usize; P], usize) {
        let mut indices = [0; P];
        let mut n = 0;
        let mut take = |range: std::ops::Range<usize>| {
            for i in range {
                indices[n] = i;
                n += 1;
            }
        };
        take(0..P_ONE);
        if self.two_lobes || self.haze.is_some() {
            take(P_ONE..P_COAT);
        }
        if self.edge {
            take(EDGE..P);
        }
        (indices, n)
    }
}

fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

fn logit(p: f64) -> f64 {
    let p = p.clamp(1e-6, 1.0 - 1e-6);
    (p / (1.0 - p)).ln()
}

fn alpha_of(s: f64) -> f64 {
    // exp(ln) can round a hair past either end; the bounds are the model's.
    (ALPHA_MIN.ln() + (ALPHA_MAX / ALPHA_MIN).ln() * logistic(s))
        .exp()
        .clamp(ALPHA_MIN, ALPHA_MAX)
}

fn alpha_param(alpha: f64) -> f64 {
    logit((alpha.ln() - ALPHA_MIN.ln()) / (ALPHA_MAX / ALPHA_MIN).ln())
}

fn model_of(theta: &Params, shape: Shape) -> LambertMicrofacet {
    let Shape {
        distribution,
        two_lobes,
        haze,
        edge,
    } = shape;
    LambertMicrofacet {
        albedo: [0, 1, 2].map(|c| logistic(theta[c])),
        f0: [0, 1, 2].map(|c| logistic(theta[3 + c])),
        distribution,
        alpha_x: alpha_of(theta[6]),
        alpha_y: alpha_of(theta[7]),
        // A lobe turned by π is the same lobe: the reported angle stays in [0, π).
        rotation: theta[8].rem_euclid(std::f64::consts::PI),
        specular: logistic(theta[9]),
        coat: two_lobes.then(|| Coat {
            f0: [COAT_F0_MIN + (COAT_F0_MAX - COAT_F0_MIN) * logistic(theta[P_ONE]); 3],
            alpha: alpha_of(theta[COAT_SHAPE]),
        }),
        haze: haze.filter(|_| !two_lobes).map(|distribution| Haze {
            distribution,
            share: logistic(theta[P_ONE]),
            alpha: alpha_of(theta[COAT_SHAPE]),
        }),
        edge: edge.then(|| {
            [0, 1, 2].map(|c| {
                let least = least_edge_tint(logistic(theta[3 + c]));
                least + (1.0 - least) * logistic(theta[EDGE + c])
            })
        }),
    }
}

/// The highest index of refraction an edge tint may name. No material painted as a metal or
/// a dielectric has η much above germanium's (about 5.5 in visible light), yet Gulbrandsen's
/// dielectric end reaches any F0 with η alone: F0 = 0.97 there is η ≈ 117 and κ = 0. Where F0
/// is that high, views at a few θ_d hardly tell a conductor's Fresnel from such a dielectric's,
/// and a free tint wandered from one end to the other as views were added.
const EDGE_ETA_MAX: f64 = 6.0;

/// The least edge tint whose conductor ([`conductor_from_edge_tint`]) has η at most
/// [`EDGE_ETA_MAX`] at normal-incidence reflectance `f0`: 0 for a dielectric's F0.
fn least_edge_tint(f0: f64) -> f64 {
    let r = f0.clamp(0.0, 0.9999);
    let root = r.sqrt();
    let dielectric = (1.0 + root) / (1.0 - root);
    let metal = (1.0 - r) / (1.0 + r);
    ((dielectric - EDGE_ETA_MAX) / (dielectric - metal)).max(0.0)
}

/// The parameter of edge tint `g` at F0 `f0`, the inverse of [`model_of`]'s mapping.
fn edge_param(f0: f64, g: f64) -> f64 {
    let least = least_edge_tint(f0);
    logit((g - least) / (1.0 - least))
}

fn params_of(model: &LambertMicrofacet) -> Params {
    let mut theta = [0.0; P];
    for c in 0..3 {
        theta[c] = logit(model.albedo[c]);
        theta[3 + c] = logit(model.f0[c]);
    }
    theta[6] = alpha_param(model.alpha_x);
    theta[7] = alpha_param(model.alpha_y);
    theta[8] = model.rotation;
    theta[9] = logit(model.specular);
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

/// One observed bin, ready for the fit.
#[derive(Clone, Copy, Debug)]
struct Observation {
    l: DVec3,
    v: DVec3,
    /// ln(ρc + ε) of the observed value, per channel.
    target: [f64; 3],
    c: f64,
    sqrt_weight: f64,
    bounds: Bounds,
}

/// How hard the fit tries, and which lobe shapes it tries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Iterations every start gets before the best are chosen.
    pub scout_iterations: usize,
    /// How many of the best starts are run to convergence.
    pub finalists: usize,
    /// Iteration cap of a finalist.
    pub max_iterations: usize,
    /// Also fit a Beckmann lobe, and keep it over GGX when its RMS log residual and its
    /// brightness-weighted one are both below GGX's divided by this factor (1: whichever fits
    /// better on both); `None`: GGX only.
    pub beckmann_margin: Option<f64>,
    /// Also fit a clear coat (a second, isotropic lobe with a dielectric's grey F0) over the
    /// chosen lobe, and keep it when its RMS log
    /// residual and its brightness-weighted one are both below one lobe's divided by this
    /// factor (two lobes always fit at least as well, so it is above 1); `None`: one lobe.
    pub coat_margin: Option<f64>,
    /// Also fit an edge tint per channel (the lobe's Fresnel a conductor's, exact, rather
    /// than Schlick's) from the chosen fit, and keep it when its RMS log residual and its
    /// brightness-weighted one are both below Schlick's divided by this factor; `None`:
    /// Schlick's. Tried only where the chosen fit is a conductor's, its lobe's F0 above its
    /// diffuse albedo in every channel.
    pub edge_margin: Option<f64>,
    /// Also fit a haze (a share of the lobe's reflectance over a second, isotropic lobe with
    /// the same Fresnel) beside the chosen lobe, and keep it when its RMS log residual and its
    /// brightness-weighted one are both below one lobe's divided by this factor; `None`: one
    /// lobe. Tried only where the chosen fit is a metal's (no more diffuse than a tenth of
    /// F0) without a coat.
    pub haze_margin: Option<f64>,
}

impl Default for FitOptions {
    /// GGX only: the analytic baseline and the exports' shape.
    fn default() -> Self {
        Self {
            scout_iterations: 8,
            finalists: 2,
            max_iterations: 80,
            beckmann_margin: None,
            coat_margin: None,
            edge_margin: None,
            haze_margin: None,
        }
    }
}

/// The fitted model and how the fit went.
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    pub model: LambertMicrofacet,
    /// RMS of the weighted log residuals at the optimum.
    pub rms_log_residual: f64,
    /// Starts tried (over every shape).
    pub starts: usize,
    /// LM iterations run over all starts.
    pub iterations: usize,
}

/// Fits Lambert + a microfacet lobe to observed bins `(pair, ρ)` (as
/// [`crate::solver::SparseTable::observed`] gives them). With no observation it returns a
/// mid-grey diffuse model.
pub fn fit_lambert_microfacet(bins: &[(PairIndex, [f64; 3])], options: &FitOptions) -> FitResult {
    let bins: Vec<_> = bins.iter().map(|&(pair, rho)| (pair, rho, EXACT)).collect();
    fit_lambert_microfacet_bounded(&bins, options)
}

/// [`fit_lambert_microfacet`] on bins whose channels may be bounds (as the solver holds them).
///
/// Why Beckmann beside GGX: fitted with GGX alone, a lobe with Gaussian tails (Beckmann,
/// Blinn–Phong, Ward, Ashikhmin–Shirley) takes a narrower, taller GGX peak whose extrapolation
/// overshoots where the peak is clipped or unpainted. With [`FitOptions::beckmann_margin`]
/// both shapes are fitted, and Beckmann is kept only where it beats GGX by the margin both in
/// the log residual and in the brightness-weighted one.
pub fn fit_lambert_microfacet_bounded(
    bins: &[(PairIndex, [f64; 3], Bounds)],
    options: &FitOptions,
) -> FitResult {
    let observations: Vec<Observation> = bins
        .iter()
        .map(|&(pair, rho, bounds)| {
            let (lo, hi) = pair_directions(pair);
            let c = cos_weight(pair);
            Observation {
                l: bin_centre(lo),
                v: bin_centre(hi),
                target: rho.map(|r| (r.max(0.0) * c + MAP_EPSILON).ln()),
                c,
                sqrt_weight: pair_multiplicity(pair).sqrt(),
                bounds,
            }
        })
        .collect();
    let starts = starting_points(bins);
    if observations.is_empty() {
        return FitResult {
            model: model_of(&starts[0], Shape::one_lobe(Distribution::Ggx)),
            rms_log_residual: 0.0,
            starts: 0,
            iterations: 0,
        };
    }
    let residuals = 3.0 * observations.len() as f64;
    let rms = |cost: f64| (2.0 * cost / residuals).sqrt();
    let weighted = |fit: &ShapeFit| brightness_weighted_rms(&observations, &fit.model());
    let ggx = fit_shape(
        &observations,
        &starts,
        Shape::one_lobe(Distribution::Ggx),
        options,
    );
    let mut best = ggx.clone();
    let mut iterations = ggx.iterations;
    let mut tried = starts.len();
    let beckmann = options.beckmann_margin.map(|_| {
        fit_shape(
            &observations,
            &starts,
            Shape::one_lobe(Distribution::Beckmann),
            options,
        )
    });
    if let (Some(margin), Some(beckmann)) = (options.beckmann_margin, &beckmann) {
        iterations += beckmann.iterations;
        tried += starts.len();
        // Beckmann must follow both the bulk of the bins (the fit's own log residual) and
        // the bright ones (weighted as the ridge weighs them). A sharp lobe over a haze (two
        // lobes) is fitted better in the log domain by a Beckmann lobe on the haze, which
        // misses the peak, and a second view would only pull it further onto the haze.
        if rms(beckmann.cost) * margin < rms(best.cost)
            && weighted(beckmann) * margin < weighted(&best)
        {
            best = beckmann.clone();
        }
    }
    if let Some(margin) = options.coat_margin {
        // One lobe fitted to a clear coat over a rougher lobe settles between them, and the
        // log domain favours the broad one: each view added then trades more of the coat's
        // peak for the tails. A coat can hold the peak, but two lobes always fit at least as
        // well, so it must earn its place by the margin.
        let starts = coat_starts(&best.theta);
        let shape = Shape {
            two_lobes: true,
            ..best.shape
        };
        let two = fit_shape(&observations, &starts, shape, options);
        iterations += two.iterations;
        tried += starts.len();
        if rms(two.cost) * margin < rms(best.cost) && weighted(&two) * margin < weighted(&best) {
            best = two;
        }
    }
    if let Some(margin) = options
        .haze_margin
        .filter(|_| !best.shape.two_lobes && metal_like(&best.model()))
    {
        // One lobe fitted to a sharp peak over a broad glow settles between them: too broad
        // for the peak, too narrow for the glow, and where the peak is clipped (8-bit paint)
        // the glow alone decides it. Two lobes of one Fresnel hold both. Each one-lobe fit
        // (GGX's, and Beckmann's where it was fitted) starts a haze of either distribution:
        // a Beckmann fit to a clipped peak has settled on the glow and cannot find the peak
        // on its own. Only a metal may take one (its chosen fit decides): where a very rough
        // lobe stands in for a plastic's diffuse, a haze turns its mirror highlight into a
        // metal's.
        let mut hazy: Option<ShapeFit> = None;
        for first in std::iter::once(&ggx).chain(beckmann.as_ref()) {
            let starts = haze_starts(&first.theta);
            for distribution in [Distribution::Ggx, Distribution::Beckmann] {
                let shape = Shape {
                    haze: Some(distribution),
                    ..first.shape
                };
                let fit = fit_shape(&observations, &starts, shape, options);
                iterations += fit.iterations;
                tried += starts.len();
                if hazy.as_ref().is_none_or(|h| fit.cost < h.cost) {
                    hazy = Some(fit);
                }
            }
        }
        if let Some(hazy) = hazy
            && rms(hazy.cost) * margin < rms(best.cost)
            && weighted(&hazy) * margin < weighted(&best)
        {
            best = hazy;
        }
    }
    if let Some(margin) = options
        .edge_margin
        .filter(|_| conductor_like(&best.model()))
    {
        // Schlick's rise is one curve for every F0, where a metal's reflectance can dip or
        // climb at mid angles. One view sees one θ_d and cannot tell; views at several θ_d
        // of a metal disagree with any Schlick lobe, and the fit then bends the lobe's width
        // and height to meet them, which where the peak is clipped (8-bit paint) moves the
        // peak it extrapolates far off. The edge tint starts where the conductor is closest
        // to the Schlick fit, so what it changes is what the paint asks for. Only a lobe that
        // outshines its diffuse may take one: a tint free to bend a plastic's Fresnel at
        // grazing angles follows what Lambert misses of its diffuse there instead.
        let start = edge_start(&best.theta, best.shape);
        let shape = Shape {
            edge: true,
            ..best.shape
        };
        let tinted = fit_shape(&observations, &[start], shape, options);
        iterations += tinted.iterations;
        tried += 1;
        if rms(tinted.cost) * margin < rms(best.cost)
            && weighted(&tinted) * margin < weighted(&best)
        {
            best = tinted;
        }
    }
    FitResult {
        model: best.model(),
        rms_log_residual: rms(best.cost),
        starts: tried,
        iterations,
    }
}

/// Whether a fit's lobe outshines its diffuse in every channel, as a conductor's does: light
/// that enters a metal is absorbed, so a metal has no diffuse.
fn conductor_like(model: &LambertMicrofacet) -> bool {
    (0..3).all(|c| model.albedo[c] <= model.specular * model.f0[c])
}

/// Whether a fit is a metal's: a conductor's ([`conductor_like`]) whose diffuse is at most a
/// tenth of its lobe's F0 in every channel. Fits of metals keep a few thousandths of diffuse
/// at most; a rough lobe that stands in for a plastic's rough diffuse (Oren–Nayar) keeps
/// more than half its F0 beside it.
fn metal_like(model: &LambertMicrofacet) -> bool {
    (0..3).all(|c| model.albedo[c] <= 0.1 * model.specular * model.f0[c])
}

/// Starts for a coat beside a fitted first lobe (`theta`): sharper and broader than it, at
/// the low and high end of a dielectric's F0.
fn coat_starts(theta: &Params) -> Vec<Params> {
    let first = model_of(theta, Shape::one_lobe(Distribution::Ggx));
    let alpha = (first.alpha_x * first.alpha_y).sqrt();
    let mut starts = Vec::new();
    for second_alpha in [alpha / 4.0, alpha * 4.0] {
        for f0 in [0.03, 0.06] {
            let mut start = *theta;
            start[P_ONE] = logit((f0 - COAT_F0_MIN) / (COAT_F0_MAX - COAT_F0_MIN));
            start[COAT_SHAPE] = alpha_param(second_alpha.clamp(ALPHA_MIN, ALPHA_MAX));
            starts.push(start);
        }
    }
    starts
}

/// Starts for a haze beside a fitted lobe (`theta`): the lobe split into a sharper one and a
/// broader one, the broad one taking a third or a half of it.
fn haze_starts(theta: &Params) -> Vec<Params> {
    let first = model_of(theta, Shape::one_lobe(Distribution::Ggx));
    let alpha = (first.alpha_x * first.alpha_y).sqrt();
    let mut starts = Vec::new();
    for (sharper, broader) in [(0.3, 2.5), (0.5, 4.0)] {
        for share in [0.3, 0.5] {
            let mut start = *theta;
            start[6] = alpha_param((first.alpha_x * sharper).clamp(ALPHA_MIN, ALPHA_MAX));
            start[7] = alpha_param((first.alpha_y * sharper).clamp(ALPHA_MIN, ALPHA_MAX));
            start[P_ONE] = logit(share);
            start[COAT_SHAPE] = alpha_param((alpha * broader).clamp(ALPHA_MIN, ALPHA_MAX));
            starts.push(start);
        }
    }
    starts
}

/// The start of an edge-tinted fit from a Schlick fit `theta`: per channel, the edge tint
/// whose conductor is closest to Schlick's curve at that F0 over the incidence cosines.
fn edge_start(theta: &Params, shape: Shape) -> Params {
    let schlick_fit = model_of(theta, shape);
    let mut start = *theta;
    for c in 0..3 {
        let f0 = schlick_fit.f0[c];
        let distance = |g: f64| -> f64 {
            let (eta, k) = conductor_from_edge_tint(f0, g);
            (0..=16)
                .map(|i| {
                    let cos = i as f64 / 16.0;
                    let d =
                        crate::materials::models::fresnel_conductor(cos, eta, k) - schlick(f0, cos);
                    d * d
                })
                .sum()
        };
        // Inside the tint's range: a saturated logistic would not move.
        let least = least_edge_tint(f0);
        let best = (1..40)
            .map(|i| 0.025 * i as f64)
            .min_by(|&a, &b| {
                let tint = |u: f64| least + (1.0 - least) * u;
                distance(tint(a)).total_cmp(&distance(tint(b)))
            })
            .unwrap_or(0.5);
        start[EDGE + c] = logit(best);
    }
    start
}

/// RMS of the log residuals weighted by each bin's brightness L (luminance × cos θ_l cos θ_v)
/// as the calibrated prior weighs them, ((L + κ L̄)/((1 + κ) L̄))^β: how well a fit follows
/// the bins that decide a render.
fn brightness_weighted_rms(observations: &[Observation], model: &LambertMicrofacet) -> f64 {
    const KAPPA: f64 = PriorModel::CALIBRATED.brightness_floor;
    const BETA: f64 = PriorModel::CALIBRATED.brightness_exponent;
    let brightness = |o: &Observation| {
        let v = o.target.map(|t| (t.exp() - MAP_EPSILON).max(0.0));
        0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]
    };
    let mean = observations.iter().map(brightness).sum::<f64>() / observations.len() as f64;
    if mean.is_nan() || mean <= 0.0 {
        return 0.0;
    }
    let model = Prepared::new(*model);
    let (mut sum, mut weights) = (0.0, 0.0);
    for o in observations {
        let w = ((brightness(o) + KAPPA * mean) / ((1.0 + KAPPA) * mean)).powf(BETA);
        sum += w * residuals(&model, o).iter().map(|r| r * r).sum::<f64>();
        weights += w * 3.0 * o.sqrt_weight * o.sqrt_weight;
    }
    (sum / weights).sqrt()
}

/// The best fit of one lobe shape.
#[derive(Clone)]
struct ShapeFit {
    theta: Params,
    /// ½‖r‖² at `theta`.
    cost: f64,
    /// LM iterations run over every start.
    iterations: usize,
    shape: Shape,
}

impl ShapeFit {
    fn model(&self) -> LambertMicrofacet {
        model_of(&self.theta, self.shape)
    }
}

/// The best parameters for one lobe shape from `starts`: every start scouted for a few
/// iterations, the best finalists run to convergence.
fn fit_shape(
    observations: &[Observation],
    starts: &[Params],
    shape: Shape,
    options: &FitOptions,
) -> ShapeFit {
    let mut iterations = 0;
    let mut scouted: Vec<(Params, f64)> = starts
        .iter()
        .map(|start| {
            let (theta, cost, it) =
                levenberg_marquardt(observations, *start, shape, options.scout_iterations);
            iterations += it;
            (theta, cost)
        })
        .collect();
    scouted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (mut best, mut best_cost) = (scouted[0].0, scouted[0].1);
    for &(theta, _) in scouted.iter().take(options.finalists.max(1)) {
        let (theta, cost, it) =
            levenberg_marquardt(observations, theta, shape, options.max_iterations);
        iterations += it;
        if cost < best_cost {
            (best, best_cost) = (theta, cost);
        }
    }
    ShapeFit {
        theta: best,
        cost: best_cost,
        iterations,
        shape,
    }
}

/// Starting points: the albedo from the darker bins, the F0 of a dielectric and of a metal,
/// four isotropic roughnesses and anisotropic ones at four orientations.
fn starting_points(bins: &[(PairIndex, [f64; 3], Bounds)]) -> Vec<Params> {
    let albedo: [f64; 3] = std::array::from_fn(|c| {
        let mut v: Vec<f64> = bins
            .iter()
            .map(|(_, rho, _)| rho[c] * std::f64::consts::PI)
            .collect();
        if v.is_empty() {
            return 0.5;
        }
        let i = v.len() / 5;
        let (_, low, _) = v.select_nth_unstable_by(i, f64::total_cmp);
        low.clamp(0.01, 0.95)
    });
    let mut starts = Vec::new();
    for f0 in [0.04, 0.6] {
        let albedo = if f0 > 0.5 {
            albedo.map(|a| 0.2 * a)
        } else {
            albedo
        };
        for alpha in [0.03, 0.1, 0.3, 0.7] {
            starts.push(params_of(&LambertMicrofacet {
                albedo: albedo.map(|a| a.max(0.01)),
                f0: [f0; 3],
                distribution: Distribution::Ggx,
                alpha_x: alpha,
                alpha_y: alpha,
                rotation: 0.0,
                specular: 0.9,
                coat: None,
                haze: None,
                edge: None,
            }));
        }
    }
    // Nearly diffuse: a faint lobe, which the scouts could not reach from a full one.
    for alpha in [0.1, 0.4] {
        starts.push(params_of(&LambertMicrofacet {
            albedo: albedo.map(|a| a.max(0.01)),
            f0: [0.04; 3],
            distribution: Distribution::Ggx,
            alpha_x: alpha,
            alpha_y: alpha,
            rotation: 0.0,
            specular: 0.01,
            coat: None,
            haze: None,
            edge: None,
        }));
    }
    for rotation in [0.0, FRAC_PI_4, FRAC_PI_2, 3.0 * FRAC_PI_4] {
        starts.push(params_of(&LambertMicrofacet {
            albedo,
            f0: [0.04; 3],
            distribution: Distribution::Ggx,
            alpha_x: 0.05,
            alpha_y: 0.3,
            rotation,
            specular: 0.9,
            coat: None,
            haze: None,
            edge: None,
        }));
    }
    starts
}

/// Bins per deterministic partial sum.
const CHUNK: usize = 512;

/// Weighted log residuals of one observation under `model`; a bounded channel's is zero on
/// the side its bound allows.
#[inline]
fn residuals(model: &Prepared, o: &Observation) -> [f64; 3] {
    residuals_of(model.eval(o.l, o.v), o)
}

/// [`residuals`] of a given ρ.
#[inline]
fn residuals_of(rho: [f64; 3], o: &Observation) -> [f64; 3] {
    std::array::from_fn(|ch| {
        let r = (rho[ch] * o.c + MAP_EPSILON).ln() - o.target[ch];
        let r = match o.bounds[ch] {
            Bound::Exact => r,
            Bound::AtLeast => r.min(0.0),
            Bound::AtMost => r.max(0.0),
        };
        o.sqrt_weight * r
    })
}

/// ½‖r‖² at `theta`.
fn cost(observations: &[Observation], theta: &Params, shape: Shape) -> f64 {
    let model = Prepared::new(model_of(theta, shape));
    let partials: Vec<f64> = observations
        .par_chunks(CHUNK)
        .map(|chunk| {
            chunk
                .iter()
                .map(|o| residuals(&model, o).iter().map(|r| r * r).sum::<f64>())
                .sum()
        })
        .collect();
    0.5 * partials.iter().sum::<f64>()
}

/// One parameter stepped for the forward-difference Jacobian: the stepped model and its
/// first lobe's Fresnel, the stepped lobe when the step changes a lobe's D·G (first,
/// second), and the step taken.
struct Stepped {
    model: LambertMicrofacet,
    fresnel: Fresnel,
    lobe: Option<Microfacet>,
    second: Option<Microfacet>,
    h: f64,
}

/// JᵀJ, Jᵀr and ½‖r‖² at `theta`, with a forward-difference Jacobian, summed in chunk order.
/// Only a lobe's shape (the first's two roughnesses and turn, the second's roughness) changes
/// its D·G, so a bin evaluates each lobe once at `theta` and once per shape step rather than
/// once per parameter; every stepped ρ is still the bits [`Brdf::eval`] would give.
fn normal_equations(
    observations: &[Observation],
    theta: &Params,
    shape: Shape,
) -> ([f64; P * P], Params, f64) {
    const STEP: f64 = 1e-6;
    let (active, n) = shape.active();
    let base = model_of(theta, shape);
    let lobe = base.parts().1;
    let second = base.second_part();
    let stepped: Vec<Stepped> = active[..n]
        .iter()
        .map(|&i| {
            let mut t = *theta;
            let h = STEP * theta[i].abs().max(1.0);
            t[i] += h;
            let model = model_of(&t, shape);
            Stepped {
                lobe: SHAPE.contains(&i).then(|| model.parts().1),
                // A haze's lobe carries the first's Fresnel, which its D·G does not use.
                second: (i == COAT_SHAPE).then(|| model.second_part()).flatten(),
                fresnel: model.fresnel(),
                model,
                h: t[i] - theta[i],
            }
        })
        .collect();
    let partials: Vec<([f64; P * P], Params, f64)> = observations
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut jtj = [0.0; P * P];
            let mut jtr = [0.0; P];
            let mut sum = 0.0;
            for o in chunk {
                let visible = above(o.l, o.v);
                let cos_d = cos_half_difference(o.l, o.v);
                let dg = lobe.eval_unit_fresnel(o.l, o.v);
                let dg_second = second
                    .as_ref()
                    .map_or(0.0, |s| s.eval_unit_fresnel(o.l, o.v));
                let rho = base.eval_from_lobes(&lobe.fresnel, visible, dg, dg_second, cos_d);
                let r = residuals_of(rho, o);
                let mut jac = [[0.0; P]; 3];
                for (j, step) in stepped.iter().enumerate() {
                    let dg = step
                        .lobe
                        .as_ref()
                        .map_or(dg, |moved| moved.eval_unit_fresnel(o.l, o.v));
                    let dg_second = step
                        .second
                        .as_ref()
                        .map_or(dg_second, |moved| moved.eval_unit_fresnel(o.l, o.v));
                    let rho =
                        step.model
                            .eval_from_lobes(&step.fresnel, visible, dg, dg_second, cos_d);
                    let rp = residuals_of(rho, o);
                    for ch in 0..3 {
                        jac[ch][j] = (rp[ch] - r[ch]) / step.h;
                    }
                }
                for ch in 0..3 {
                    sum += r[ch] * r[ch];
                    for a in 0..n {
                        jtr[a] += jac[ch][a] * r[ch];
                        for b in a..n {
                            jtj[a * P + b] += jac[ch][a] * jac[ch][b];
                        }
                    }
                }
            }
            (jtj, jtr, sum)
        })
        .collect();
    let mut jtj = [0.0; P * P];
    let mut jtr = [0.0; P];
    let mut sum = 0.0;
    for (a, b, s) in &partials {
        for i in 0..P * P {
            jtj[i] += a[i];
        }
        for i in 0..P {
            jtr[i] += b[i];
        }
        sum += s;
    }
    for a in 0..n {
        for b in 0..a {
            jtj[a * P + b] = jtj[b * P + a];
        }
    }
    (jtj, jtr, 0.5 * sum)
}

/// Solves (JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr over the first `n` parameters; `None` when the damped
/// matrix is not positive definite.
fn damped_step(jtj: &[f64; P * P], jtr: &Params, lambda: f64, n: usize) -> Option<Params> {
    let mut m = Mat::<f64>::from_fn(n, n, |i, j| jtj[i * P + j]);
    for i in 0..n {
        m[(i, i)] += lambda * jtj[i * P + i].max(1e-12);
    }
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| -jtr[i]);
    m.llt(Side::Lower).ok()?.solve_in_place(x.as_mut());
    let step: Params = std::array::from_fn(|i| if i < n { x[(i, 0)] } else { 0.0 });
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// Runs at most `max_iterations` LM iterations from `theta`; returns the parameters, their
/// cost and the iterations run.
fn levenberg_marquardt(
    observations: &[Observation],
    mut theta: Params,
    shape: Shape,
    max_iterations: usize,
) -> (Params, f64, usize) {
    let (active, n) = shape.active();
    let mut lambda = 1e-3;
    let (mut jtj, mut jtr, mut current) = normal_equations(observations, &theta, shape);
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let mut accepted = false;
        // Raise the damping until a step lowers the cost (or the damping is hopeless).
        while lambda < 1e10 {
            if let Some(step) = damped_step(&jtj, &jtr, lambda, n) {
                let mut trial = theta;
                for (j, &i) in active[..n].iter().enumerate() {
                    trial[i] += step[j];
                }
                let trial_cost = cost(observations, &trial, shape);
                if trial_cost.is_finite() && trial_cost < current {
                    let gain = (current - trial_cost) / current.max(f64::MIN_POSITIVE);
                    theta = trial;
                    lambda = (lambda / 3.0).max(1e-9);
                    accepted = true;
                    if gain < 1e-9 {
                        return (theta, trial_cost, iterations);
                    }
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
        (jtj, jtr, current) = normal_equations(observations, &theta, shape);
    }
    (theta, current, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Anisotropic, tinted, neither dielectric nor metal.
    const MIXED: LambertMicrofacet = LambertMicrofacet {
        albedo: [0.2, 0.5, 0.9],
        f0: [0.04, 0.3, 0.95],
        distribution: Distribution::Ggx,
        alpha_x: 0.02,
        alpha_y: 1.2,
        rotation: 0.7,
        specular: 0.3,
        coat: None,
        haze: None,
        edge: None,
    };

    /// `eval` (through `eval_from_lobes`, which the fit's Jacobian reuses) is the library's
    /// Lambert plus microfacet lobe to the bit, above and below the horizon.
    #[test]
    fn evaluation_is_lambert_plus_the_library_lobe_to_the_bit() {
        use crate::table::PAIRS;
        let models = [
            MIXED,
            LambertMicrofacet {
                albedo: [0.0; 3],
                f0: [0.9; 3],
                distribution: Distribution::Beckmann,
                alpha_x: 0.01,
                alpha_y: 0.01,
                rotation: 0.0,
                specular: 1.0,
                coat: None,
                haze: None,
                edge: None,
            },
            LambertMicrofacet {
                edge: Some([0.2, 0.6, 1.0]),
                ..MIXED
            },
        ];
        for model in models {
            let (diffuse, lobe) = model.parts();
            for p in (0..PAIRS).step_by(997) {
                let (lo, hi) = pair_directions(PairIndex::from_index(p));
                for (l, v) in [
                    (bin_centre(lo), bin_centre(hi)),
                    (bin_centre(hi), -bin_centre(lo)),
                ] {
                    let (d, s) = (diffuse.eval(l, v), lobe.eval(l, v));
                    let composed = [d[0] + s[0], d[1] + s[1], d[2] + s[2]];
                    assert_eq!(
                        model.eval(l, v).map(f64::to_bits),
                        composed.map(f64::to_bits),
                        "{l} {v}"
                    );
                }
            }
        }
    }

    #[test]
    fn parametrisation_round_trips_within_bounds() {
        let model = MIXED;
        let back = model_of(&params_of(&model), Shape::one_lobe(model.distribution));
        for c in 0..3 {
            assert!((back.albedo[c] - model.albedo[c]).abs() < 1e-9);
            assert!((back.f0[c] - model.f0[c]).abs() < 1e-9);
        }
        assert!((back.alpha_x - 0.02).abs() < 1e-9 && (back.alpha_y - 1.2).abs() < 1e-9);
        assert!((back.specular - 0.3).abs() < 1e-9);
        let extreme = model_of(
            &[
                1e3, -1e3, 0.0, 50.0, -50.0, 0.0, 1e3, -1e3, 0.0, -1e3, 0.0, 0.0, 1e3, -1e3, 0.0,
            ],
            Shape {
                edge: true,
                ..Shape::one_lobe(Distribution::Ggx)
            },
        );
        assert!(extreme.alpha_x <= ALPHA_MAX && extreme.alpha_y >= ALPHA_MIN);
        assert!(extreme.albedo.iter().all(|a| (0.0..=1.0).contains(a)));
        let edge = extreme.edge.expect("an edge tint");
        assert!(edge.iter().all(|g| (0.0..=1.0).contains(g)));
        let tinted = LambertMicrofacet {
            // Blue's F0 (0.95) allows no tint below about 0.92 (EDGE_ETA_MAX).
            edge: Some([0.1, 0.5, 0.95]),
            ..MIXED
        };
        let shape = Shape {
            edge: true,
            ..Shape::one_lobe(tinted.distribution)
        };
        let back = model_of(&params_of(&tinted), shape).edge.unwrap();
        for c in 0..3 {
            assert!((back[c] - tinted.edge.unwrap()[c]).abs() < 1e-9);
        }
        // At a metal's F0 the tint stops short of the dielectric end, where η would pass
        // EDGE_ETA_MAX, and still round-trips above it.
        for f0 in [0.5, 0.9, 0.97, 0.999] {
            let lowest = model_of(
                &[
                    0.0,
                    0.0,
                    0.0,
                    logit(f0),
                    logit(f0),
                    logit(f0),
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    -1e3,
                    0.0,
                    1e3,
                ],
                shape,
            );
            let (eta, _) = conductor_from_edge_tint(lowest.f0[0], lowest.edge.unwrap()[0]);
            assert!(
                eta <= EDGE_ETA_MAX + 1e-9 && eta > 0.9 * EDGE_ETA_MAX,
                "{f0}: η {eta}"
            );
            assert!(lowest.edge.unwrap()[2] > 0.999);
            let metal = LambertMicrofacet {
                f0: [f0; 3],
                edge: Some([0.1, 0.5, 0.9].map(|u| {
                    let least = least_edge_tint(f0);
                    least + (1.0 - least) * u
                })),
                ..tinted
            };
            let back = model_of(&params_of(&metal), shape).edge.unwrap();
            for c in 0..3 {
                assert!((back[c] - metal.edge.unwrap()[c]).abs() < 1e-9, "{f0} {c}");
            }
        }
        let haze = Haze {
            distribution: Distribution::Beckmann,
            share: 0.35,
            alpha: 0.45,
        };
        let hazy = LambertMicrofacet {
            haze: Some(haze),
            ..tinted
        };
        let shape = Shape {
            haze: Some(Distribution::Beckmann),
            ..shape
        };
        let back = model_of(&params_of(&hazy), shape);
        let back_haze = back.haze.expect("a haze");
        assert_eq!(back_haze.distribution, Distribution::Beckmann);
        assert!((back_haze.share - 0.35).abs() < 1e-9 && (back_haze.alpha - 0.45).abs() < 1e-9);
        assert!((back.alpha_x - 0.02).abs() < 1e-9 && back.edge.is_some());
    }

    /// A haze splits the lobe's reflectance between its two shapes: the model is the
    /// library's mixture of the two lobes, each carrying the first's Fresnel.
    #[test]
    fn a_haze_is_the_mixture_of_its_two_lobes() {
        use crate::materials::models::Mixture;
        let hazy = LambertMicrofacet {
            albedo: [0.0; 3],
            specular: 1.0,
            edge: Some([0.3, 0.6, 0.9]),
            haze: Some(Haze {
                distribution: Distribution::Beckmann,
                share: 0.25,
                alpha: 0.4,
            }),
            ..MIXED
        };
        let sharp = hazy.parts().1;
        let glow = Microfacet::isotropic(Distribution::Beckmann, 0.4, hazy.fresnel());
        let mixture = Mixture {
            parts: vec![(0.75, Box::new(sharp)), (0.25, Box::new(glow))],
        };
        use crate::table::PAIRS;
        for p in (0..PAIRS).step_by(997) {
            let (lo, hi) = pair_directions(PairIndex::from_index(p));
            let (l, v) = (bin_centre(lo), bin_centre(hi));
            let (got, want) = (hazy.eval(l, v), mixture.eval(l, v));
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 1e-12 * want[c].abs().max(1.0),
                    "{l} {v}: {got:?} against {want:?}"
                );
            }
        }
    }

    /// 8-bit paint of gold under two lights: every bin at θ_d near 26° or near 59°, as one
    /// orthographic view per light shows it, and the peak clipped (a bound only). Schlick's
    /// rise is one curve for every F0 and gold's is not, so a Schlick lobe meets the two
    /// views by bending its width and height, and the peak it extrapolates above the clip
    /// falls far off; the edge-tinted conductor holds both views and the peak.
    #[test]
    fn an_edge_tint_holds_a_metals_peak_from_two_clipped_views() {
        use crate::materials::models::Microfacet;
        let gold = Microfacet::isotropic(
            Distribution::Ggx,
            0.05,
            Fresnel::Conductor {
                eta: [0.143, 0.374, 1.442],
                k: [3.983, 2.385, 1.603],
            },
        );
        let bins = clipped_bins(
            &gold,
            pairs_at_half_differences(7, &[24.0..28.0, 57.0..61.0]),
        );
        let truth = crate::materials::tabulate(&gold);
        let fit = |edge_margin| {
            let options = FitOptions {
                beckmann_margin: Some(1.0),
                edge_margin,
                ..FitOptions::default()
            };
            fit_and_score(&bins, &options, &truth)
        };
        let (schlick, schlick_error) = fit(None);
        let (tinted, tinted_error) = fit(Some(1.2));
        println!(
            "Schlick {schlick:?}: {:.4}\ntinted {tinted:?}: {:.4}",
            schlick_error.relative_rmse, tinted_error.relative_rmse
        );
        assert!(tinted.edge.is_some(), "{tinted:?}");
        // Measured: Schlick 0.087, the edge tint 0.0000 (gold's own η + iκ and α to 1e-12).
        assert!(tinted_error.relative_rmse < 0.005, "{tinted_error:?}");
        assert!(schlick_error.relative_rmse > 0.05, "{schlick_error:?}");
    }

    /// The fit of `bins` under `options`, and how far its table is from `truth`.
    fn fit_and_score(
        bins: &[(PairIndex, [f64; 3], Bounds)],
        options: &FitOptions,
        truth: &crate::table::SymTable,
    ) -> (LambertMicrofacet, crate::metrics::Evaluation) {
        let model = fit_lambert_microfacet_bounded(bins, options).model;
        let error = crate::metrics::evaluate(truth, &crate::materials::tabulate(&model));
        (model, error)
    }

    /// What 8-bit paint of `brdf` gives on `pairs`: a pixel lit by irradiance π holds
    /// π ρ cos θ_l, clipped at 1, where it is only a bound. Asserts that some are.
    fn clipped_bins(
        brdf: &dyn Brdf,
        pairs: Vec<(PairIndex, DVec3, DVec3)>,
    ) -> Vec<(PairIndex, [f64; 3], Bounds)> {
        let bins: Vec<_> = pairs
            .into_iter()
            .map(|(pair, l, v)| {
                let clip = 1.0 / (std::f64::consts::PI * l.z.max(1e-3));
                let rho = brdf.eval(l, v);
                let value = rho.map(|r| r.min(clip));
                let bounds = rho.map(|r| {
                    if r >= clip {
                        Bound::AtLeast
                    } else {
                        Bound::Exact
                    }
                });
                (pair, value, bounds)
            })
            .collect();
        assert!(
            bins.iter().any(|b| b.2.contains(&Bound::AtLeast)),
            "no clipped peak"
        );
        bins
    }

    /// 8-bit paint of a polished silver, one view: a sharp Beckmann peak, clipped, over a
    /// broad GGX glow. One lobe settles between the two (and on the glow alone where the
    /// peak is clipped); a haze holds both, and what the clipped peak's shoulders show of it
    /// is enough to place the peak.
    #[test]
    fn a_haze_holds_a_clipped_peak_over_a_glow() {
        use crate::materials::models::Mixture;
        let silver = Fresnel::Conductor {
            eta: [0.155, 0.117, 0.138],
            k: [4.83, 3.12, 2.15],
        };
        let polished = Mixture {
            parts: vec![
                (
                    0.6,
                    Box::new(Microfacet::isotropic(Distribution::Beckmann, 0.06, silver)),
                ),
                (
                    0.4,
                    Box::new(Microfacet::isotropic(Distribution::Ggx, 0.3, silver)),
                ),
            ],
        };
        let bins = clipped_bins(&polished, pairs_at_half_differences(9, &[20.0..24.0]));
        let truth = crate::materials::tabulate(&polished);
        let fit = |haze_margin| {
            let options = FitOptions {
                beckmann_margin: Some(1.0),
                haze_margin,
                ..FitOptions::default()
            };
            fit_and_score(&bins, &options, &truth)
        };
        let (one, one_error) = fit(None);
        let (hazy, hazy_error) = fit(Some(1.5));
        println!(
            "one lobe {one:?}: {:.4}\nhaze {hazy:?}: {:.4}",
            one_error.relative_rmse, hazy_error.relative_rmse
        );
        assert!(hazy.haze.is_some(), "{hazy:?}");
        // Measured: one lobe 0.954 (GGX α 0.29 on the glow), the haze 0.184 (both roughnesses
        // to 2%; what is left is Schlick's Fresnel for silver's).
        assert!(hazy_error.relative_rmse < 0.22, "{hazy_error:?}");
        assert!(one_error.relative_rmse > 0.8, "{one_error:?}");
    }

    /// A gold painted at two θ_d: a sharp peak over a haze, red's F0 0.97. Near F0 = 1 a
    /// conductor's Fresnel and a dielectric's of the same F0 differ by little, and with the
    /// dielectric end free (η ≈ 117, κ = 0) the second θ_d pulled red's tint there: relative
    /// RMSE 0.007 from one view became 0.018 from two. With η bounded the fit finds the gold.
    #[test]
    fn a_gold_seen_at_two_half_angles_keeps_a_metals_edge() {
        use crate::materials::models::Mixture;
        let gold = Fresnel::Conductor {
            eta: [0.143, 0.374, 1.442],
            k: [3.983, 2.385, 1.603],
        };
        let polished = Mixture {
            parts: vec![
                (
                    0.7,
                    Box::new(Microfacet::isotropic(Distribution::Ggx, 0.05, gold)),
                ),
                (
                    0.3,
                    Box::new(Microfacet::isotropic(Distribution::Beckmann, 0.4, gold)),
                ),
            ],
        };
        let bins: Vec<_> = pairs_at_half_differences(7, &[14.0..16.0, 33.0..37.0])
            .into_iter()
            .map(|(pair, l, v)| (pair, polished.eval(l, v), EXACT))
            .collect();
        let options = FitOptions {
            beckmann_margin: Some(1.0),
            edge_margin: Some(1.5),
            haze_margin: Some(1.5),
            ..FitOptions::default()
        };
        let (fit, error) = fit_and_score(&bins, &options, &crate::materials::tabulate(&polished));
        println!("{fit:?}: {:.5}", error.relative_rmse);
        let edge = fit.edge.expect("an edge tint");
        let (eta, k) = conductor_from_edge_tint(fit.f0[0], edge[0]);
        assert!(
            (eta - 0.143).abs() < 0.05 && (k - 3.983).abs() < 0.2,
            "red η {eta}, κ {k}"
        );
        assert!(error.relative_rmse < 0.005, "{error:?}");
    }

    /// Every `step`-th pair whose bin centres' half-difference angle θ_d (degrees) lies in
    /// one of `ranges`, with its light and view directions: what views at those θ_d paint.
    fn pairs_at_half_differences(
        step: usize,
        ranges: &[std::ops::Range<f64>],
    ) -> Vec<(PairIndex, DVec3, DVec3)> {
        (0..crate::table::PAIRS)
            .step_by(step)
            .filter_map(|p| {
                let pair = PairIndex::from_index(p);
                let (lo, hi) = pair_directions(pair);
                let (l, v) = (bin_centre(lo), bin_centre(hi));
                let theta_d = cos_half_difference(l, v).acos().to_degrees();
                ranges
                    .iter()
                    .any(|r| r.contains(&theta_d))
                    .then_some((pair, l, v))
            })
            .collect()
    }

    /// A glossy plastic painted at a middle and a grazing θ_d: its diffuse is rough (Oren–Nayar),
    /// which Lambert misses most at grazing angles, and a tint free to bend the lobe's Fresnel
    /// there would follow that misfit and name the plastic a metal. A conductor has no
    /// diffuse, so a lobe over a diffuse keeps Schlick's.
    #[test]
    fn a_plastic_seen_at_grazing_angles_keeps_schlicks_fresnel() {
        use crate::materials::models::{Mixture, OrenNayar};
        let plastic = Mixture {
            parts: vec![
                (
                    1.0,
                    Box::new(OrenNayar {
                        albedo: [0.7, 0.35, 0.15],
                        sigma: 1.2,
                    }),
                ),
                (
                    1.0,
                    Box::new(Microfacet::isotropic(
                        Distribution::Ggx,
                        0.2,
                        Fresnel::Schlick { f0: [0.04; 3] },
                    )),
                ),
            ],
        };
        let bins: Vec<(PairIndex, [f64; 3])> =
            pairs_at_half_differences(2, &[20.0..24.0, 82.0..86.0])
                .into_iter()
                .map(|(pair, l, v)| (pair, plastic.eval(l, v)))
                .collect();
        let options = FitOptions {
            beckmann_margin: Some(1.0),
            edge_margin: Some(1.0),
            ..FitOptions::default()
        };
        let fit = fit_lambert_microfacet(&bins, &options).model;
        println!("{fit:?}");
        assert!(fit.edge.is_none(), "{fit:?}");
        assert!(!conductor_like(&fit));
        let gold_like = LambertMicrofacet {
            albedo: [0.0; 3],
            f0: [0.9, 0.7, 0.35],
            specular: 1.0,
            ..fit
        };
        assert!(conductor_like(&gold_like));
    }

    /// The edge tint's conductor reflects F0 at normal incidence whatever the tint; tint 0 is
    /// the dielectric of that F0 and tint 1 the strongest metal Gulbrandsen's map allows.
    #[test]
    fn an_edge_tint_names_a_conductor_of_its_f0() {
        use crate::materials::models::fresnel_conductor;
        for r in [0.02, 0.04, 0.3, 0.65, 0.97] {
            for g in [0.0, 0.3, 0.7, 1.0] {
                let (n, k) = conductor_from_edge_tint(r, g);
                assert!(n > 0.0 && k >= 0.0, "r {r} g {g}: η {n} κ {k}");
                let f = fresnel_conductor(1.0, n, k);
                assert!((f - r).abs() < 1e-9, "r {r} g {g}: F(0°) = {f}");
            }
            let (n, k) = conductor_from_edge_tint(r, 0.0);
            assert!(k < 1e-6, "r {r}: κ {k} at tint 0");
            assert!((n - (1.0 + r.sqrt()) / (1.0 - r.sqrt())).abs() < 1e-9);
            let (n, _) = conductor_from_edge_tint(r, 1.0);
            assert!((n - (1.0 - r) / (1.0 + r)).abs() < 1e-12);
        }
        // Gold's measured η + iκ, per channel, lies inside the map: the edge tint that gives
        // its η gives its κ too.
        for (eta, k) in [(0.143, 3.983), (0.374, 2.385), (1.442, 1.603)] {
            let r = fresnel_conductor(1.0, eta, k);
            let root = r.sqrt();
            let (strongest, dielectric) = ((1.0 - r) / (1.0 + r), (1.0 + root) / (1.0 - root));
            let g = (dielectric - eta) / (dielectric - strongest);
            assert!((0.0..=1.0).contains(&g), "gold η {eta}: tint {g}");
            let (n, reached) = conductor_from_edge_tint(r, g);
            assert!(
                (n - eta).abs() < 1e-9 && (reached - k).abs() < 1e-6,
                "κ {reached} for {k}"
            );
        }
    }
}
