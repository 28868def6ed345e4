//! An analytic approximation of a table for engines that take parameters: the lobes of
//! Autodesk Standard Surface (and of glTF's PBR material with its sheen, clearcoat and
//! anisotropy extensions), fitted to what renders of the table show.
//!
//! **Model** ([`StandardSurface`]): a base that mixes by `metalness` a metal (GGX, Schlick
//! Fresnel from the base colour) and a dielectric (GGX with `specular` × Schlick(F₀ of IOR
//! 1.5), over Lambertian `base_color` / π attenuated by the specular's transmission
//! (1 − F(θ_l))(1 − F(θ_v))); both GGX lobes share the anisotropic roughness α_x, α_y along
//! the tangent turned by `rotation`; a Charlie sheen (Estevez & Kulla 2017, Ashikhmin
//! visibility) added on top; and a white dielectric coat (isotropic GGX, IOR 1.5) that lets
//! (1 − coat F(θ_l))(1 − coat F(θ_v)) of the rest through. Layering is by these simple
//! transmission factors rather than by precomputed albedo tables: an approximation, whose
//! error the fit reports.
//!
//! **Fit** (Levenberg–Marquardt, robust): observations are bin pairs drawn uniformly from
//! the table (seeded); each compares the radiance a render shows, L = π ρ cos θ_l, through
//! the compressive map ln(1 + L / L₀) (L₀ the observations' mean radiance, so highlights do
//! not drown the rest, as in a tone-mapped image), weighted by the bins' solid angles and
//! the view's projected area (sin θ_l sin θ_v cos θ_v). Bins that disagree with the model
//! far more than the rest are down-weighted by iteratively reweighted least squares with a
//! Cauchy loss. Several starting materials (dielectric, glossy, metal, coated, cloth) run a
//! few iterations; the best is refined. An isotropic table (see [`super::exact`]) keeps
//! α_x = α_y and no rotation.

use super::exact::{anisotropy, isotropic_average};
use super::rgl::ANISOTROPY_THRESHOLD;
use crate::materials::Brdf;
use crate::materials::models::{
    Distribution, Fresnel, Microfacet, Sheen, cos_half_difference, f0_from_ior, schlick,
};
use crate::table::{DIRECTIONS, DirIndex, SymTable, bin_centre};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::f64::consts::PI;

/// IOR of the dielectric specular and of the coat (F₀ = 0.04), as glTF fixes it.
pub const IOR: f64 = 1.5;
/// Smallest GGX α the fit uses (a 2° bin cannot show a narrower lobe).
const ALPHA_MIN: f64 = 0.01;
/// Largest ratio α_x / α_y.
const ASPECT_MAX: f64 = 20.0;
/// Sheen roughness range.
const SHEEN_ROUGHNESS_MIN: f64 = 0.05;
/// Observations drawn from the table.
const OBSERVATIONS: usize = 6000;

/// The fitted parameters, in the model's own terms; [`super::materialx`] and [`super::gltf`]
/// map them onto their formats' parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct StandardSurface {
    /// Diffuse albedo of the dielectric, F₀ of the metal.
    pub base_color: [f64; 3],
    pub metalness: f64,
    /// Weight of the dielectric specular reflection.
    pub specular: f64,
    /// GGX α along the tangent turned by `rotation` and along the bitangent.
    pub alpha_x: f64,
    pub alpha_y: f64,
    /// Radians, counter-clockwise about the normal from the tangent.
    pub rotation: f64,
    /// Sheen colour (its weight folded in).
    pub sheen_color: [f64; 3],
    /// Charlie roughness r in (0, 1].
    pub sheen_roughness: f64,
    pub coat: f64,
    /// GGX α of the coat.
    pub coat_alpha: f64,
}

impl Default for StandardSurface {
    fn default() -> Self {
        Self {
            base_color: [0.8; 3],
            metalness: 0.0,
            specular: 1.0,
            alpha_x: 0.3,
            alpha_y: 0.3,
            rotation: 0.0,
            sheen_color: [0.0; 3],
            sheen_roughness: 0.3,
            coat: 0.0,
            coat_alpha: 0.03,
        }
    }
}

impl Brdf for StandardSurface {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let f0 = f0_from_ior(IOR);
        let cos_d = cos_half_difference(l, v);
        let lobe = Microfacet {
            distribution: Distribution::Ggx,
            alpha_x: self.alpha_x,
            alpha_y: self.alpha_y,
            rotation: self.rotation,
            fresnel: Fresnel::Schlick { f0: [1.0; 3] },
            tint: [1.0; 3],
        }
        .eval_unit_fresnel(l, v);
        let spec_f = self.specular * schlick(f0, cos_d);
        let through =
            (1.0 - self.specular * schlick(f0, l.z)) * (1.0 - self.specular * schlick(f0, v.z));
        let sheen = if self.sheen_color.iter().any(|&c| c > 0.0) {
            Sheen {
                color: self.sheen_color,
                roughness: self.sheen_roughness,
            }
            .eval(l, v)
        } else {
            [0.0; 3]
        };
        let (coat_lobe, coat_through) = if self.coat > 0.0 {
            let coat = Microfacet {
                distribution: Distribution::Ggx,
                alpha_x: self.coat_alpha,
                alpha_y: self.coat_alpha,
                rotation: 0.0,
                fresnel: Fresnel::Schlick { f0: [1.0; 3] },
                tint: [1.0; 3],
            }
            .eval_unit_fresnel(l, v);
            (
                self.coat * coat * schlick(f0, cos_d),
                (1.0 - self.coat * schlick(f0, l.z)) * (1.0 - self.coat * schlick(f0, v.z)),
            )
        } else {
            (0.0, 1.0)
        };
        std::array::from_fn(|c| {
            let base = self.base_color[c];
            let metal = lobe * schlick(base, cos_d);
            let dielectric = lobe * spec_f + through * base / PI;
            let under = self.metalness * metal + (1.0 - self.metalness) * dielectric + sheen[c];
            let rho = coat_lobe + coat_through * under;
            if rho.is_finite() { rho.max(0.0) } else { 0.0 }
        })
    }

    fn is_isotropic(&self) -> bool {
        self.alpha_x == self.alpha_y
    }
}

/// The fit and how far it is from the table.
#[derive(Clone, Debug, PartialEq)]
pub struct FitReport {
    pub model: StandardSurface,
    /// Whether the table was fitted as isotropic.
    pub isotropic: bool,
    /// Median PSNR of sRGB sphere renders under 8 lights (`burnish eval`'s figure).
    pub median_psnr_db: f64,
    /// ‖(ρ̂ − ρ) cos θ_l cos θ_v‖ / ‖ρ cos θ_l cos θ_v‖ over the whole table.
    pub relative_rmse: f64,
    pub log_rmse: f64,
}

impl std::fmt::Display for FitReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "standard-surface fit: sphere renders {:.1} dB PSNR (median of 8 lights), \
             relative RMSE {:.1}%, log RMSE {:.3}",
            self.median_psnr_db,
            100.0 * self.relative_rmse,
            self.log_rmse
        )
    }
}

const P: usize = 14;

fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

fn logit(p: f64) -> f64 {
    let p = p.clamp(1e-6, 1.0 - 1e-6);
    (p / (1.0 - p)).ln()
}

/// α in [ALPHA_MIN, 1], log-uniform in its parameter.
fn alpha_of(s: f64) -> f64 {
    (ALPHA_MIN.ln() * (1.0 - logistic(s)))
        .exp()
        .clamp(ALPHA_MIN, 1.0)
}

fn alpha_param(alpha: f64) -> f64 {
    logit(1.0 - alpha.clamp(ALPHA_MIN, 1.0).ln() / ALPHA_MIN.ln())
}

fn model_of(p: &[f64; P]) -> StandardSurface {
    let alpha = alpha_of(p[5]);
    let half_log_aspect = 0.5 * ASPECT_MAX.ln() * p[6].tanh();
    StandardSurface {
        base_color: [logistic(p[0]), logistic(p[1]), logistic(p[2])],
        metalness: logistic(p[3]),
        specular: logistic(p[4]),
        alpha_x: (alpha * half_log_aspect.exp()).clamp(ALPHA_MIN, 1.0),
        alpha_y: (alpha * (-half_log_aspect).exp()).clamp(ALPHA_MIN, 1.0),
        rotation: p[7],
        sheen_color: [logistic(p[8]), logistic(p[9]), logistic(p[10])],
        sheen_roughness: SHEEN_ROUGHNESS_MIN + (1.0 - SHEEN_ROUGHNESS_MIN) * logistic(p[11]),
        coat: logistic(p[12]),
        coat_alpha: alpha_of(p[13]),
    }
}

fn params_of(m: &StandardSurface) -> [f64; P] {
    let alpha = (m.alpha_x * m.alpha_y).sqrt();
    let aspect = (m.alpha_x / m.alpha_y).ln() / ASPECT_MAX.ln();
    [
        logit(m.base_color[0]),
        logit(m.base_color[1]),
        logit(m.base_color[2]),
        logit(m.metalness),
        logit(m.specular),
        alpha_param(alpha),
        aspect.clamp(-0.999, 0.999).atanh(),
        m.rotation,
        logit(m.sheen_color[0]),
        logit(m.sheen_color[1]),
        logit(m.sheen_color[2]),
        logit((m.sheen_roughness - SHEEN_ROUGHNESS_MIN) / (1.0 - SHEEN_ROUGHNESS_MIN)),
        logit(m.coat),
        alpha_param(m.coat_alpha),
    ]
}

/// One bin pair of the table as the fit sees it.
struct Observation {
    l: DVec3,
    v: DVec3,
    /// π cos θ_l: radiance per unit ρ.
    radiance_scale: f64,
    /// ln(1 + L / L₀) of the table's value, per channel.
    target: [f64; 3],
    /// √ of the measure weight (solid angles and projected area).
    sqrt_weight: f64,
}

/// The compressive map of radiance the fit compares in.
fn compress(radiance: f64, reference: f64) -> f64 {
    (radiance.max(0.0) / reference).ln_1p()
}

fn observations(table: &SymTable) -> (Vec<Observation>, f64) {
    let mut rng = Pcg64::seed_from_u64(0x05ee_df17);
    let picks: Vec<(DirIndex, DirIndex)> = (0..OBSERVATIONS)
        .map(|_| {
            (
                rng.random_range(0..DIRECTIONS) as DirIndex,
                rng.random_range(0..DIRECTIONS) as DirIndex,
            )
        })
        .collect();
    let raw: Vec<(DVec3, DVec3, [f64; 3])> = picks
        .iter()
        .map(|&(a, b)| (bin_centre(a), bin_centre(b), table.get(a, b).map(f64::from)))
        .collect();
    let mean_radiance = raw
        .iter()
        .map(|(l, _, rho)| PI * l.z * (rho[0] + rho[1] + rho[2]) / 3.0)
        .sum::<f64>()
        / raw.len() as f64;
    let reference = mean_radiance.max(1e-3);
    let obs = raw
        .into_iter()
        .map(|(l, v, rho)| {
            let sin = |w: DVec3| (1.0 - w.z * w.z).max(0.0).sqrt();
            let radiance_scale = PI * l.z;
            Observation {
                l,
                v,
                radiance_scale,
                target: rho.map(|r| compress(r * radiance_scale, reference)),
                sqrt_weight: (sin(l) * sin(v) * v.z).sqrt(),
            }
        })
        .collect();
    (obs, reference)
}

/// Weighted residuals of every observation (3 per observation).
fn residuals(
    model: &StandardSurface,
    obs: &[Observation],
    robust: &[f64],
    reference: f64,
    out: &mut [f64],
) {
    out.par_chunks_mut(3)
        .zip(obs.par_iter())
        .zip(robust.par_iter())
        .for_each(|((r, o), &w)| {
            let rho = model.eval(o.l, o.v);
            for c in 0..3 {
                r[c] = w
                    * o.sqrt_weight
                    * (compress(rho[c] * o.radiance_scale, reference) - o.target[c]);
            }
        });
}

fn cost(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Levenberg–Marquardt on the free parameters, `iterations` steps at most.
fn levenberg_marquardt(
    start: [f64; P],
    free: &[bool; P],
    obs: &[Observation],
    robust: &[f64],
    reference: f64,
    iterations: usize,
) -> ([f64; P], f64) {
    let m = 3 * obs.len();
    let mut p = start;
    let mut r = vec![0.0; m];
    residuals(&model_of(&p), obs, robust, reference, &mut r);
    let mut current = cost(&r);
    let mut damping = 1e-2;
    let mut rp = vec![0.0; m];
    let cols: Vec<usize> = (0..P).filter(|&k| free[k]).collect();
    let mut jac = vec![vec![0.0; m]; cols.len()];
    for _ in 0..iterations {
        for (j, &k) in cols.iter().enumerate() {
            let h = 1e-4 * (1.0 + p[k].abs());
            let mut q = p;
            q[k] += h;
            residuals(&model_of(&q), obs, robust, reference, &mut rp);
            for i in 0..m {
                jac[j][i] = (rp[i] - r[i]) / h;
            }
        }
        let n = cols.len();
        let mut jtj = Mat::<f64>::zeros(n, n);
        let mut jtr = Mat::<f64>::zeros(n, 1);
        for a in 0..n {
            jtr[(a, 0)] = -jac[a].iter().zip(&r).map(|(x, y)| x * y).sum::<f64>();
            for b in a..n {
                let s: f64 = jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum();
                jtj[(a, b)] = s;
                jtj[(b, a)] = s;
            }
        }
        let mut accepted = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for d in 0..n {
                a[(d, d)] += damping * (jtj[(d, d)] + 1e-9);
            }
            let Ok(llt) = a.llt(Side::Lower) else {
                damping *= 10.0;
                continue;
            };
            let delta = llt.solve(&jtr);
            let mut q = p;
            for (j, &k) in cols.iter().enumerate() {
                q[k] += delta[(j, 0)].clamp(-4.0, 4.0);
            }
            residuals(&model_of(&q), obs, robust, reference, &mut rp);
            let c = cost(&rp);
            if c.is_finite() && c < current {
                p = q;
                std::mem::swap(&mut r, &mut rp);
                let gain = (current - c) / current.max(1e-300);
                current = c;
                damping = (damping * 0.3).max(1e-7);
                accepted = gain > 1e-7;
                break;
            }
            damping *= 10.0;
        }
        if !accepted {
            break;
        }
    }
    (p, current)
}

/// Cauchy IRLS weights from the current residuals (per observation).
fn robust_weights(model: &StandardSurface, obs: &[Observation], reference: f64) -> Vec<f64> {
    let ones = vec![1.0; obs.len()];
    let mut r = vec![0.0; 3 * obs.len()];
    residuals(model, obs, &ones, reference, &mut r);
    let per_obs: Vec<f64> = r
        .chunks(3)
        .zip(obs)
        .map(|(c, o)| {
            let norm = (c.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt();
            if o.sqrt_weight > 0.0 {
                norm / o.sqrt_weight
            } else {
                0.0
            }
        })
        .collect();
    let mut sorted = per_obs.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let scale = (2.0 * 1.4826 * median).max(1e-3);
    per_obs
        .iter()
        .map(|&x| (1.0 / (1.0 + (x / scale).powi(2))).sqrt())
        .collect()
}

/// Starting materials for the multi-start.
fn starts(base: [f64; 3]) -> Vec<StandardSurface> {
    let plain = StandardSurface {
        base_color: base,
        ..Default::default()
    };
    vec![
        plain.clone(),
        StandardSurface {
            alpha_x: 0.05,
            alpha_y: 0.05,
            ..plain.clone()
        },
        StandardSurface {
            metalness: 0.95,
            base_color: base.map(|b| b.max(0.3)),
            alpha_x: 0.15,
            alpha_y: 0.15,
            ..plain.clone()
        },
        StandardSurface {
            coat: 0.9,
            coat_alpha: 0.03,
            alpha_x: 0.4,
            alpha_y: 0.4,
            ..plain.clone()
        },
        StandardSurface {
            sheen_color: [0.5; 3],
            sheen_roughness: 0.4,
            alpha_x: 0.8,
            alpha_y: 0.8,
            specular: 0.3,
            ..plain
        },
    ]
}

/// A diffuse colour to start from: π ρ away from the mirror direction, per channel median.
fn diffuse_estimate(obs: &[Observation], table_rho: impl Fn(&Observation) -> [f64; 3]) -> [f64; 3] {
    let mut per_channel: [Vec<f64>; 3] = Default::default();
    for o in obs {
        let h = (o.l + o.v).normalize();
        if o.l.z > 0.5 && o.v.z > 0.5 && h.z < 0.9 {
            let rho = table_rho(o);
            for c in 0..3 {
                per_channel[c].push(PI * rho[c]);
            }
        }
    }
    per_channel.map(|mut v| {
        if v.is_empty() {
            return 0.5;
        }
        v.sort_by(f64::total_cmp);
        v[v.len() / 2].clamp(0.02, 0.98)
    })
}

/// Fits the model to a table and measures what the approximation loses.
pub fn fit(table: &SymTable) -> FitReport {
    let isotropic = anisotropy(table, &isotropic_average(table)) < ANISOTROPY_THRESHOLD;
    let (obs, reference) = observations(table);
    let mut free = [true; P];
    if isotropic {
        free[6] = false;
        free[7] = false;
    }
    let base = diffuse_estimate(&obs, |o| {
        // Invert the compression: ρ = L₀ (e^t − 1) / (π cos θ_l).
        o.target
            .map(|t| reference * t.exp_m1() / o.radiance_scale.max(1e-9))
    });
    let ones = vec![1.0; obs.len()];
    let mut candidates: Vec<([f64; P], f64)> = starts(base)
        .iter()
        .flat_map(|s| {
            let mut p = params_of(s);
            let mut out = vec![];
            // Anisotropic tables also start along the diagonal axes.
            let rotations: &[f64] = if isotropic { &[0.0] } else { &[0.0, PI / 4.0] };
            for &rot in rotations {
                if !isotropic {
                    p[6] = 0.3;
                    p[7] = rot;
                }
                out.push(p);
            }
            out
        })
        .map(|p| levenberg_marquardt(p, &free, &obs, &ones, reference, 12))
        .collect();
    candidates.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best = candidates[0].0;
    let mut robust = ones;
    for _ in 0..3 {
        let (p, _) = levenberg_marquardt(best, &free, &obs, &robust, reference, 40);
        best = p;
        robust = robust_weights(&model_of(&best), &obs, reference);
    }
    let mut model = model_of(&best);
    if isotropic {
        model.alpha_y = model.alpha_x;
        model.rotation = 0.0;
    }
    model.rotation = model.rotation.rem_euclid(PI);
    let fitted = crate::materials::tabulate(&model);
    let evaluation = crate::metrics::evaluate(table, &fitted);
    FitReport {
        model,
        isotropic,
        median_psnr_db: evaluation.median_psnr_db,
        relative_rmse: evaluation.relative_rmse,
        log_rmse: evaluation.log_rmse,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::tabulate;

    #[test]
    fn parameters_round_trip() {
        let m = StandardSurface {
            base_color: [0.2, 0.5, 0.7],
            metalness: 0.3,
            specular: 0.8,
            alpha_x: 0.4,
            alpha_y: 0.1,
            rotation: 0.5,
            sheen_color: [0.1, 0.2, 0.3],
            sheen_roughness: 0.5,
            coat: 0.6,
            coat_alpha: 0.05,
        };
        let back = model_of(&params_of(&m));
        for (a, b) in [
            (m.alpha_x, back.alpha_x),
            (m.alpha_y, back.alpha_y),
            (m.coat_alpha, back.coat_alpha),
            (m.sheen_roughness, back.sheen_roughness),
            (m.base_color[2], back.base_color[2]),
        ] {
            assert!((a - b).abs() < 1e-6, "{a} {b}");
        }
    }

    #[test]
    fn the_model_is_reciprocal_and_bounded() {
        let m = StandardSurface {
            sheen_color: [0.3; 3],
            coat: 1.0,
            alpha_x: 0.2,
            alpha_y: 0.05,
            rotation: 0.7,
            ..Default::default()
        };
        let (l, v) = (
            DVec3::new(0.3, -0.2, 0.9).normalize(),
            DVec3::new(-0.5, 0.4, 0.6).normalize(),
        );
        let (a, b) = (m.eval(l, v), m.eval(v, l));
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-12 * a[c].abs().max(1.0));
        }
        let albedo = crate::materials::directional_albedo(&m, DVec3::new(0.0, 0.6, 0.8), 64);
        assert!(albedo.iter().all(|&x| x > 0.0 && x < 1.2), "{albedo:?}");
    }

    /// A material the model can represent is found again.
    #[test]
    fn recovers_a_representable_material() {
        let truth = StandardSurface {
            base_color: [0.6, 0.3, 0.1],
            alpha_x: 0.2,
            alpha_y: 0.2,
            ..Default::default()
        };
        let report = fit(&tabulate(&truth));
        assert!(report.isotropic);
        assert!(report.median_psnr_db > 35.0, "{report}");
        let m = &report.model;
        assert!((m.alpha_x - 0.2).abs() < 0.05, "{m:?}");
        assert!((m.base_color[0] - 0.6).abs() < 0.1, "{m:?}");
    }
}
