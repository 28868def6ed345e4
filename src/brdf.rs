//! The BRDF trait: what analytic materials, measured MERL files and fits have in common.
//!
//! It sits below both `table` (a MERL file is a BRDF) and `materials` (which tabulate BRDFs
//! into tables), so that neither imports the other both ways; `materials::Brdf` re-exports it.

use glam::DVec3;

/// A BRDF in the local shading frame (z = normal, x = tangent at φ = 0).
///
/// Implementations are reciprocal (`eval(l, v) == eval(v, l)` up to rounding),
/// non-negative and finite for every pair of unit directions above the horizon.
pub trait Brdf: Send + Sync + std::fmt::Debug {
    /// ρ(l, v) in 1/sr, linear RGB. `l` points to the light, `v` to the viewer; both unit, z > 0.
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3];

    /// True when ρ depends on θ_l, θ_v and φ_v − φ_l only, which lets tabulation
    /// evaluate 45·45·36 pairs instead of 1,313,010.
    fn is_isotropic(&self) -> bool;
}

impl<B: Brdf + ?Sized> Brdf for Box<B> {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        (**self).eval(l, v)
    }
    fn is_isotropic(&self) -> bool {
        (**self).is_isotropic()
    }
}

impl<B: Brdf + ?Sized> Brdf for std::sync::Arc<B> {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        (**self).eval(l, v)
    }
    fn is_isotropic(&self) -> bool {
        (**self).is_isotropic()
    }
}
