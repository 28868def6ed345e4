//! Bi-scale materials in the spirit of Wu, Dorsey & Rushmeier 2011: a base BRDF seen through
//! a discrete distribution of mesoscale facets.
//!
//! With facet normals n_k and facet areas A_k (true areas, not projected),
//!
//! ρ(l, v) = A_macro · Σ_k A_k ρ_base(l_k, v_k) (l·n_k)⁺ (v·n_k)⁺ / (P(l) P(v)),
//! P(w) = Σ_j A_j (w·n_j)⁺,  A_macro = Σ_k A_k n_k·z.
//!
//! Derivation: the flux E·A_macro·l_z reaching the patch is shared among the facets in
//! proportion to their projected areas A_k (l·n_k)⁺, i.e. each lit facet receives
//! irradiance E (l·n_k)⁺ · A_macro l_z / P(l) (the last factor is the lit fraction, taken
//! as uniform over facets); the viewer sees facet k with weight A_k (v·n_k)⁺ / P(v) of the
//! visible projected area A_macro v_z. Dividing the radiance by E l_z gives the formula. It
//! is symmetric in l and v, and when Σ_k A_k n_k is along z (a heightfield) then
//! P(w) ≥ Σ_k A_k (w·n_k) = A_macro w_z, so the visible fraction A_macro w_z / P(w) ≤ 1 and
//! the albedo is at most the largest albedo of the base.

use super::Brdf;
use glam::DVec3;

/// A base BRDF averaged over mesoscale facets.
#[derive(Debug)]
pub struct BiScale {
    /// The BRDF of every facet, in the facet's own frame.
    pub base: Box<dyn Brdf>,
    /// (unit normal with z > 0, area) per facet; Σ area·normal must be along z.
    pub facets: Vec<(DVec3, f64)>,
    /// When set, the facet set is turned about z to the mean azimuth (φ_l + φ_v)/2 before
    /// evaluating, which makes ρ depend on φ_v − φ_l only (exactly, so tabulation's isotropic
    /// shortcut is faithful) and keeps it reciprocal. The facet set must then be unchanged by
    /// a half-turn about z, since the mean azimuth is only defined modulo π.
    pub isotropic: bool,
}

/// Cross-section of a groove.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrooveProfile {
    /// Two flat walls at ± the tilt.
    V,
    /// A circular arc from −tilt to +tilt, split into this many facets of equal width
    /// (an odd count includes a flat bottom).
    Rounded {
        /// Facets across the arc (≥ 2).
        facets: usize,
    },
}

/// Tangent and bitangent of the frame obtained by rotating (x, y, z) minimally so that z
/// lands on `n`, so that the base's tangent stays as close as possible to the macro tangent.
#[inline]
pub fn facet_frame(n: DVec3) -> (DVec3, DVec3) {
    let k = 1.0 / (1.0 + n.z);
    let xy = -n.x * n.y * k;
    (
        DVec3::new(1.0 - n.x * n.x * k, xy, -n.x),
        DVec3::new(xy, 1.0 - n.y * n.y * k, -n.y),
    )
}

impl BiScale {
    /// A bi-scale BRDF from explicit facets; normals are normalised.
    ///
    /// # Panics
    /// If a facet faces below the horizon, has a non-positive area, or the area-weighted
    /// normals do not sum to a vector along z (the heightfield condition).
    pub fn new(base: Box<dyn Brdf>, facets: Vec<(DVec3, f64)>, isotropic: bool) -> Self {
        let facets: Vec<(DVec3, f64)> = facets
            .into_iter()
            .map(|(n, a)| (n.normalize(), a))
            .collect();
        assert!(!facets.is_empty(), "a bi-scale material needs facets");
        let mut sum = DVec3::ZERO;
        for &(n, a) in &facets {
            assert!(n.z > 0.0 && a > 0.0, "facet {n} with area {a}");
            sum += a * n;
        }
        assert!(
            sum.x.hypot(sum.y) <= 1e-9 * sum.z,
            "facets are not a heightfield: {sum}"
        );
        Self {
            base,
            facets,
            isotropic,
        }
    }

    /// Parallel grooves running along the tangent direction at angle `direction` (radians
    /// from x) with walls tilted up to `max_tilt` (radians, < π/2) across the groove: brushed
    /// or machined metal, satin. Anisotropic.
    pub fn grooves(
        base: Box<dyn Brdf>,
        profile: GrooveProfile,
        max_tilt: f64,
        direction: f64,
    ) -> Self {
        let tilts: Vec<f64> = match profile {
            GrooveProfile::V => vec![-max_tilt, max_tilt],
            GrooveProfile::Rounded { facets } => {
                assert!(facets >= 2, "a rounded groove needs at least two facets");
                // Midpoints of equal arc lengths: symmetric about 0, equal areas.
                (0..facets)
                    .map(|i| max_tilt * (2.0 * i as f64 + 1.0 - facets as f64) / facets as f64)
                    .collect()
            }
        };
        // Normals tilt in the plane spanned by z and the in-surface direction across the groove.
        let (s, c) = direction.sin_cos();
        let across = DVec3::new(-s, c, 0.0);
        let facets = tilts
            .iter()
            .map(|&t| (DVec3::Z * t.cos() + across * t.sin(), 1.0))
            .collect();
        Self::new(base, facets, false)
    }

    /// Densely packed spherical-cap bumps whose slopes reach `max_tilt` (radians, < π/2):
    /// `n_rings` rings of `n_per_ring` (even) facets around z, each ring's area that of its
    /// band of the sphere. The discrete ring is not rotation-invariant, so the result is
    /// declared isotropic and evaluated with the ring turned to the mean azimuth of l and v
    /// (see [`BiScale::isotropic`]): hammered or orange-peel surfaces.
    pub fn bumps(base: Box<dyn Brdf>, max_tilt: f64, n_rings: usize, n_per_ring: usize) -> Self {
        assert!(n_rings >= 1, "bumps need at least one ring");
        assert!(
            n_per_ring >= 2 && n_per_ring.is_multiple_of(2),
            "an isotropised ring must be symmetric under a half-turn: even count"
        );
        let mut facets = Vec::with_capacity(n_rings * n_per_ring);
        let band = max_tilt / n_rings as f64;
        for j in 0..n_rings {
            let (lo, hi) = (j as f64 * band, (j + 1) as f64 * band);
            let tilt = 0.5 * (lo + hi);
            let area = (lo.cos() - hi.cos()) / n_per_ring as f64;
            // Alternate rings are staggered by half a step to spread the azimuths.
            let offset = 0.5 * (j % 2) as f64;
            for k in 0..n_per_ring {
                let phi = std::f64::consts::TAU * (k as f64 + offset) / n_per_ring as f64;
                let (sp, cp) = phi.sin_cos();
                let (st, ct) = tilt.sin_cos();
                facets.push((DVec3::new(st * cp, st * sp, ct), area));
            }
        }
        Self::new(base, facets, true)
    }
}

impl Brdf for BiScale {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        let (l, v) = if self.isotropic {
            // Turning both by the same symmetric angle keeps reciprocity and makes the result
            // depend on the azimuth difference only.
            let psi = 0.5 * (l.y.atan2(l.x) + v.y.atan2(v.x));
            let (s, c) = psi.sin_cos();
            let turn = |w: DVec3| DVec3::new(c * w.x + s * w.y, -s * w.x + c * w.y, w.z);
            (turn(l), turn(v))
        } else {
            (l, v)
        };
        let (mut p_l, mut p_v, mut a_macro) = (0.0, 0.0, 0.0);
        let mut sum = [0.0; 3];
        for &(n, area) in &self.facets {
            let (dl, dv) = (l.dot(n), v.dot(n));
            a_macro += area * n.z;
            if dl > 0.0 {
                p_l += area * dl;
            }
            if dv > 0.0 {
                p_v += area * dv;
            }
            if dl > 0.0 && dv > 0.0 {
                let (t, b) = facet_frame(n);
                let lk = DVec3::new(l.dot(t), l.dot(b), dl);
                let vk = DVec3::new(v.dot(t), v.dot(b), dv);
                let rho = self.base.eval(lk, vk);
                // dl·dv grouped first so that swapping l and v gives the same bits.
                let w = area * (dl * dv);
                for c in 0..3 {
                    sum[c] += w * rho[c];
                }
            }
        }
        if p_l <= 0.0 || p_v <= 0.0 {
            return [0.0; 3];
        }
        let k = a_macro / (p_l * p_v);
        sum.map(|x| x * k)
    }

    fn is_isotropic(&self) -> bool {
        self.isotropic
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::directional_albedo;
    use crate::materials::models::tests::{check_basic, check_isotropy_claim, random_dir};
    use crate::materials::models::{Distribution, Fresnel, Lambert, Microfacet};
    use rand::SeedableRng;
    use rand_pcg::Pcg64;

    fn metal(alpha: f64) -> Box<dyn Brdf> {
        Box::new(Microfacet::isotropic(
            Distribution::Ggx,
            alpha,
            Fresnel::Conductor {
                eta: [1.657, 0.880, 0.521],
                k: [9.224, 6.270, 4.837],
            },
        ))
    }

    fn examples() -> Vec<BiScale> {
        vec![
            BiScale::grooves(metal(0.05), GrooveProfile::V, 0.3, 0.4),
            BiScale::grooves(metal(0.2), GrooveProfile::Rounded { facets: 7 }, 0.6, 2.0),
            BiScale::bumps(metal(0.1), 0.8, 3, 6),
            BiScale::bumps(
                Box::new(Lambert {
                    albedo: [0.9, 0.5, 0.1],
                }),
                1.2,
                2,
                8,
            ),
        ]
    }

    #[test]
    fn frames_are_orthonormal_and_minimal() {
        let mut rng = Pcg64::seed_from_u64(1);
        for _ in 0..100 {
            let n = random_dir(&mut rng);
            let (t, b) = facet_frame(n);
            assert!((t.length() - 1.0).abs() < 1e-12 && (b.length() - 1.0).abs() < 1e-12);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12);
            assert!((t.cross(b) - n).length() < 1e-12, "right-handed");
        }
        let (t, b) = facet_frame(DVec3::Z);
        assert_eq!((t, b), (DVec3::X, DVec3::Y));
    }

    #[test]
    fn constructors_build_heightfields() {
        for m in examples() {
            let sum: DVec3 = m.facets.iter().map(|&(n, a)| a * n).sum();
            assert!(sum.x.hypot(sum.y) < 1e-12 * sum.z, "{sum}");
            assert!(m.facets.len() <= 24);
        }
    }

    #[test]
    fn reciprocal_finite_and_honest_about_isotropy() {
        for (i, m) in examples().iter().enumerate() {
            check_basic(m, 200 + i as u64, 300);
            check_isotropy_claim(m, 300 + i as u64, 100);
        }
        assert!(!examples()[0].is_isotropic());
        assert!(examples()[2].is_isotropic());
    }

    #[test]
    fn a_single_flat_facet_is_the_base() {
        let flat = BiScale::new(metal(0.3), vec![(DVec3::Z, 2.0)], false);
        let base = metal(0.3);
        let mut rng = Pcg64::seed_from_u64(5);
        for _ in 0..50 {
            let (l, v) = (random_dir(&mut rng), random_dir(&mut rng));
            let (a, b) = (flat.eval(l, v), base.eval(l, v));
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-12 * b[c].max(1e-300),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn grooves_are_anisotropic_and_energy_bounded() {
        let m = BiScale::grooves(
            Box::new(Lambert { albedo: [1.0; 3] }),
            GrooveProfile::Rounded { facets: 6 },
            1.0,
            0.0,
        );
        // Light across the grooves vs along them: different shading.
        let v = DVec3::new(0.0, 0.0, 1.0);
        let across = m.eval(DVec3::new(0.0, 0.8, 0.6), v)[0];
        let along = m.eval(DVec3::new(0.8, 0.0, 0.6), v)[0];
        assert!((across - along).abs() > 1e-3, "{across} {along}");
        for &t in &[0.0f64, 0.7, 1.2, 1.5] {
            for &phi in &[0.0f64, 0.8, 1.57] {
                let l = DVec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
                let a = directional_albedo(&m, l, 32)[0];
                assert!(a <= 1.0 + 2e-3, "θ {t} φ {phi}: {a}");
            }
        }
    }
}
