//! The angular parametrisation of the RGL format's grids (Dupuy & Jakob 2018): u ∈ [0, 1]
//! maps to θ = u²·π/2 (dense near the normal) and to φ = (2u − 1)·π. The `.bsdf` writer and
//! reader and the NDF estimate share it, so it stands apart from both.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

pub fn u2theta(u: f64) -> f64 {
    u * u * FRAC_PI_2
}
pub fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}
pub fn theta2u(theta: f64) -> f64 {
    (theta / FRAC_PI_2).max(0.0).sqrt()
}
pub fn phi2u(phi: f64) -> f64 {
    (phi + PI) / TAU
}
