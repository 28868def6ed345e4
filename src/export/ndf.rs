//! The microfacet distribution a `.bsdf` file is parametrised by, estimated from the BRDF's
//! retro-reflection by power iteration (Dupuy, Heitz, Iehl, Poulin & Ostromoukhov,
//! "Extracting Microfacet-based BRDF Parameters from Arbitrary Materials with Power
//! Iterations", EGSR 2015), as Dupuy & Jakob 2018 do for the RGL database.
//!
//! For a microfacet BRDF seen back along the light, f(ω, ω) = F D(ω) / (4 cos θ σ(ω)), with
//! σ(ω) = ∫ D(m) ⟨ω·m⟩ dm the microsurface's projected area. So D(ω) ∝ f(ω, ω) cos θ σ_D(ω):
//! D is the dominant eigenfunction of K D(ω) = f(ω, ω) cos θ ∫ D(m) ⟨ω·m⟩ dm, found by
//! iterating K from a constant and normalising ∫ D(m) cos θ_m dm = 1 each time.
//!
//! D and σ live on the grid the file stores them on: u_θ = √(θ / (π/2)) and
//! u_φ = (φ + π) / 2π, nodes at i / (n − 1), integrated by the trapezoid rule with the
//! solid angle dω = 2π² u_θ sin θ du_θ du_φ. An isotropic D has one value per θ; its
//! azimuthal integral is done in closed form.

use super::grid::{u2phi, u2theta};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

/// Iterations at most; the estimate usually settles in a few dozen.
const MAX_ITERATIONS: usize = 200;
/// Relative change of D (max norm) below which the iteration stops.
const TOLERANCE: f64 = 1e-7;
/// D never drops below this fraction of its peak: the file divides by D, and a warp needs a
/// density that is positive wherever the BRDF is.
const FLOOR: f64 = 1e-3;

/// D and σ on the file's u-grid, `phi` rows of `theta` values (row-major, θ contiguous).
#[derive(Clone, Debug)]
pub struct Microsurface {
    pub theta: usize,
    pub phi: usize,
    pub ndf: Vec<f32>,
    pub sigma: Vec<f32>,
    /// Power iterations run.
    pub iterations: usize,
}

/// Trapezoid weights of `n` nodes over [0, 1].
fn trapezoid(n: usize) -> Vec<f64> {
    let h = 1.0 / (n - 1) as f64;
    (0..n)
        .map(|i| if i == 0 || i == n - 1 { 0.5 * h } else { h })
        .collect()
}

/// ∫₀^{2π} max(0, sin a sin b cos φ + cos a cos b) dφ.
fn azimuthal_kernel(a: f64, b: f64) -> f64 {
    let (p, q) = (a.cos() * b.cos(), a.sin() * b.sin());
    if p >= q {
        TAU * p
    } else if p <= -q {
        0.0
    } else {
        let phi0 = (-p / q).clamp(-1.0, 1.0).acos();
        2.0 * (p * phi0 + q * phi0.sin())
    }
}

fn direction(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// Runs the power iteration `d ← normalise(retro · cos · (kernel d))` from a constant.
fn power_iterate(
    retro_cos: &[f64],
    normalise_weights: &[f64],
    apply: impl Fn(&[f64]) -> Vec<f64>,
) -> (Vec<f64>, usize) {
    let n = retro_cos.len();
    let normalise = |d: &mut Vec<f64>| {
        let total: f64 = d.iter().zip(normalise_weights).map(|(x, w)| x * w).sum();
        if total > 0.0 && total.is_finite() {
            d.iter_mut().for_each(|x| *x /= total);
            true
        } else {
            false
        }
    };
    let mut d = vec![1.0; n];
    normalise(&mut d);
    let mut iterations = 0;
    for _ in 0..MAX_ITERATIONS {
        iterations += 1;
        let sigma = apply(&d);
        let mut next: Vec<f64> = retro_cos.iter().zip(&sigma).map(|(r, s)| r * s).collect();
        if !normalise(&mut next) {
            // A black retro-reflection: keep the constant start (a valid, if uninformed, D).
            break;
        }
        let peak = next.iter().cloned().fold(0.0, f64::max);
        let change = next
            .iter()
            .zip(&d)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        d = next;
        if change <= TOLERANCE * peak {
            break;
        }
    }
    // Floor, then normalise again.
    let peak = d.iter().cloned().fold(0.0, f64::max);
    d.iter_mut().for_each(|x| *x = x.max(FLOOR * peak));
    normalise(&mut d);
    (d, iterations)
}

/// D and σ of an isotropic material: `theta` nodes, stored as two identical φ rows (the
/// loaders' 2D interpolant needs at least two).
pub fn estimate_isotropic(retro: impl Fn(DVec3) -> f64 + Sync, theta: usize) -> Microsurface {
    let u: Vec<f64> = (0..theta).map(|i| i as f64 / (theta - 1) as f64).collect();
    let th: Vec<f64> = u.iter().map(|&u| u2theta(u)).collect();
    let tw = trapezoid(theta);
    // ∫ … sin θ dθ over u: dθ = π u du.
    let measure: Vec<f64> = (0..theta)
        .map(|j| PI * u[j] * th[j].sin() * tw[j])
        .collect();
    let kernel: Vec<f64> = (0..theta * theta)
        .map(|ab| azimuthal_kernel(th[ab / theta], th[ab % theta]) * measure[ab % theta])
        .collect();
    let retro_cos: Vec<f64> = th
        .iter()
        .map(|&t| retro(direction(t, 0.0)).max(0.0) * t.cos())
        .collect();
    let normalise_weights: Vec<f64> = (0..theta).map(|j| TAU * measure[j] * th[j].cos()).collect();
    let apply = |d: &[f64]| -> Vec<f64> {
        (0..theta)
            .map(|a| (0..theta).map(|b| kernel[a * theta + b] * d[b]).sum())
            .collect()
    };
    let (d, iterations) = power_iterate(&retro_cos, &normalise_weights, apply);
    let sigma = apply(&d);
    let row = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| x as f32).collect() };
    let (ndf, sig) = (row(&d), row(&sigma));
    Microsurface {
        theta,
        phi: 2,
        ndf: [ndf.clone(), ndf].concat(),
        sigma: [sig.clone(), sig].concat(),
        iterations,
    }
}

/// D and σ of an anisotropic material on a `theta × phi` grid (φ from −π to π).
pub fn estimate_anisotropic(
    retro: impl Fn(DVec3) -> f64 + Sync,
    theta: usize,
    phi: usize,
) -> Microsurface {
    let n = theta * phi;
    let (tw, pw) = (trapezoid(theta), trapezoid(phi));
    let mut dirs = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for j in 0..phi {
        for i in 0..theta {
            let u = i as f64 / (theta - 1) as f64;
            let (t, p) = (u2theta(u), u2phi(j as f64 / (phi - 1) as f64));
            dirs.push(direction(t, p));
            weights.push(2.0 * PI * PI * u * t.sin() * tw[i] * pw[j]);
        }
    }
    let retro_cos: Vec<f64> = dirs
        .iter()
        .map(|&w| retro(w).max(0.0) * w.z.max(0.0))
        .collect();
    let normalise_weights: Vec<f64> = dirs.iter().zip(&weights).map(|(w, a)| a * w.z).collect();
    let apply = |d: &[f64]| -> Vec<f64> {
        dirs.par_iter()
            .map(|&w| {
                let mut s = 0.0;
                for b in 0..n {
                    let c = w.dot(dirs[b]);
                    if c > 0.0 {
                        s += weights[b] * d[b] * c;
                    }
                }
                s
            })
            .collect()
    };
    let (d, iterations) = power_iterate(&retro_cos, &normalise_weights, apply);
    let sigma = apply(&d);
    Microsurface {
        theta,
        phi,
        ndf: d.iter().map(|&x| x as f32).collect(),
        sigma: sigma.iter().map(|&x| x as f32).collect(),
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::models::Distribution;

    #[test]
    fn the_kernel_matches_quadrature() {
        for (a, b) in [(0.3, 1.2), (1.4, 1.5), (0.0, 0.7), (1.5, 0.1)] {
            let n = 20_000;
            let q: f64 = (0..n)
                .map(|k| {
                    let p = (k as f64 + 0.5) * TAU / n as f64;
                    (f64::sin(a) * f64::sin(b) * p.cos() + f64::cos(a) * f64::cos(b)).max(0.0)
                })
                .sum::<f64>()
                * TAU
                / n as f64;
            assert!((azimuthal_kernel(a, b) - q).abs() < 1e-6, "{a} {b}");
        }
    }

    /// A GGX microsurface's own retro-reflection gives back its D (up to the grid).
    #[test]
    fn recovers_a_ggx_distribution() {
        let alpha = 0.3;
        let ndf = |cos_h: f64| Distribution::Ggx.isotropic_d(cos_h, alpha);
        // f(ω, ω) = D(ω) G₁(ω) / (4 cos² θ) with Smith G₁ for GGX, F = 1.
        let retro = |w: DVec3| {
            let c = w.z.clamp(1e-9, 1.0);
            let tan2 = (1.0 - c * c) / (c * c);
            let g1 = 2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt());
            ndf(c) * g1 / (4.0 * c * c)
        };
        let micro = estimate_isotropic(retro, 64);
        for i in [0usize, 10, 20, 30, 40] {
            let u = i as f64 / 63.0;
            let want = ndf(u2theta(u).cos());
            let got = micro.ndf[i] as f64;
            assert!((got / want - 1.0).abs() < 0.02, "u = {u}: {got} vs {want}");
        }
        // σ(normal) = ∫ D cos = 1.
        assert!((micro.sigma[0] - 1.0).abs() < 1e-3, "{}", micro.sigma[0]);
        let aniso = estimate_anisotropic(retro, 24, 24);
        for j in [0usize, 7, 15] {
            for i in [0usize, 6, 12] {
                let got = aniso.ndf[j * 24 + i] as f64;
                let want = micro.ndf[(i as f64 / 23.0 * 63.0).round() as usize] as f64;
                let want_exact = ndf(u2theta(i as f64 / 23.0).cos());
                assert!(
                    (got / want_exact - 1.0).abs() < 0.05,
                    "{got} {want} {want_exact}"
                );
            }
        }
    }
}
