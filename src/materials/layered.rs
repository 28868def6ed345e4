//! Layers: thin-film interference (soap films, oxidised or anodised metal, coated lenses) and
//! coats of finite thickness that absorb (tinted varnish, car paint lacquer).

use super::Brdf;
use super::models::{Distribution, Microfacet, above, cos_half_difference, f0_from_ior, schlick};
use glam::DVec3;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Wavelengths (nm) averaged for each of R, G and B: a film's colour comes from its spectrum,
/// and a single wavelength per channel would make thick films flicker from bin to bin.
const BANDS_NM: [[f64; 5]; 3] = [
    [580.0, 605.0, 630.0, 655.0, 680.0],
    [500.0, 520.0, 540.0, 560.0, 580.0],
    [420.0, 440.0, 460.0, 480.0, 500.0],
];

/// Reflectance of a dielectric film (index `film_ior`, `thickness_nm` thick) on a substrate of
/// complex index η + iκ, seen from air at incidence cosine `cos`: the Airy sum of the
/// multiply reflected amplitudes, s and p polarisations averaged, per channel.
pub fn thin_film_reflectance(
    cos: f64,
    film_ior: f64,
    thickness_nm: f64,
    eta: [f64; 3],
    k: [f64; 3],
) -> [f64; 3] {
    let cos0 = cos.clamp(1e-6, 1.0);
    let sin2_0 = 1.0 - cos0 * cos0;
    let n1 = film_ior.max(1.0001);
    let cos1 = (1.0 - sin2_0 / (n1 * n1)).max(0.0).sqrt();
    let one = Complex64::new(1.0, 0.0);
    let n0 = one;
    let n1c = Complex64::new(n1, 0.0);
    let (c0, c1) = (Complex64::new(cos0, 0.0), Complex64::new(cos1, 0.0));
    std::array::from_fn(|ch| {
        let n2 = Complex64::new(eta[ch], k[ch]);
        // Snell into the substrate: n1 sin θ1 = n2 sin θ2.
        let sin2_2 = Complex64::new(n1 * n1 * (1.0 - cos1 * cos1), 0.0) / (n2 * n2);
        let c2 = (one - sin2_2).sqrt();
        let r01s = (n0 * c0 - n1c * c1) / (n0 * c0 + n1c * c1);
        let r01p = (n1c * c0 - n0 * c1) / (n1c * c0 + n0 * c1);
        let r12s = (n1c * c1 - n2 * c2) / (n1c * c1 + n2 * c2);
        let r12p = (n2 * c1 - n1c * c2) / (n2 * c1 + n1c * c2);
        let mut sum = 0.0;
        for &lambda in &BANDS_NM[ch] {
            let phase = 4.0 * PI * n1 * thickness_nm.max(0.0) * cos1 / lambda;
            let e = Complex64::from_polar(1.0, phase);
            let airy = |r01: Complex64, r12: Complex64| {
                let r = (r01 + r12 * e) / (one + r01 * r12 * e);
                r.norm_sqr()
            };
            sum += 0.5 * (airy(r01s, r12s) + airy(r01p, r12p));
        }
        let r = sum / BANDS_NM[ch].len() as f64;
        if r.is_finite() {
            r.clamp(0.0, 1.0)
        } else {
            1.0
        }
    })
}

/// A rough interface whose facets carry a thin film: the microfacet lobe of `facets` with
/// its Fresnel replaced by [`thin_film_reflectance`] at the half-vector angle, over an
/// optional diffuse base (a dyed or pigmented substrate).
#[derive(Clone, Debug, PartialEq)]
pub struct ThinFilm {
    /// The lobe's shape (its Fresnel is ignored).
    pub facets: Microfacet,
    pub film_ior: f64,
    pub thickness_nm: f64,
    /// Complex index of the substrate (a dielectric has κ = 0).
    pub eta: [f64; 3],
    pub k: [f64; 3],
    /// Lambertian albedo under the film (zero for metals).
    pub diffuse: [f64; 3],
}

impl Brdf for ThinFilm {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        // The lobe with unit Fresnel, then the film's reflectance at θ_d.
        let shape = self.facets.eval_unit_fresnel(l, v);
        let f = thin_film_reflectance(
            cos_half_difference(l, v),
            self.film_ior,
            self.thickness_nm,
            self.eta,
            self.k,
        );
        // The diffuse part sees what the film lets through at each end.
        let t = |z: f64| 1.0 - schlick(f0_from_ior(self.film_ior), z);
        let td = t(l.z) * t(v.z);
        [0, 1, 2].map(|c| shape * f[c] + td * self.diffuse[c] * std::f64::consts::FRAC_1_PI)
    }
    fn is_isotropic(&self) -> bool {
        self.facets.is_isotropic()
    }
}

/// A dielectric coat of finite thickness over a base: a rough coat surface (its own lobe and
/// Fresnel), refraction into the coat, absorption along both refracted paths, and the base
/// seen through it: ρ = ρ_coat + T(θ_l)T(θ_v)·exp(−τ(1/cos θ'_l + 1/cos θ'_v))·ρ_base, with
/// θ' the refracted angles and τ the coat's optical depth at normal incidence per channel.
#[derive(Debug)]
pub struct AbsorbingCoat {
    pub base: Box<dyn Brdf>,
    pub ior: f64,
    pub roughness: f64,
    pub distribution: Distribution,
    /// Optical depth at normal incidence per channel (0 is clear).
    pub optical_depth: [f64; 3],
}

impl Brdf for AbsorbingCoat {
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !above(l, v) {
            return [0.0; 3];
        }
        let f0 = f0_from_ior(self.ior);
        let lobe = Microfacet::isotropic(
            self.distribution,
            self.roughness,
            super::models::Fresnel::Schlick { f0: [f0; 3] },
        );
        let coat = lobe.eval(l, v)[0];
        let refracted = |z: f64| {
            let s2 = (1.0 - z * z) / (self.ior * self.ior);
            (1.0 - s2).max(1e-6).sqrt()
        };
        let path = 1.0 / refracted(l.z) + 1.0 / refracted(v.z);
        let t = (1.0 - schlick(f0, l.z)) * (1.0 - schlick(f0, v.z));
        let b = self.base.eval(l, v);
        [0, 1, 2].map(|c| coat + t * (-self.optical_depth[c] * path).exp() * b[c])
    }
    fn is_isotropic(&self) -> bool {
        self.base.is_isotropic()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::models::tests::{check_basic, check_isotropy_claim};
    use crate::materials::models::{Fresnel, Lambert, fresnel_conductor};

    #[test]
    fn a_film_of_zero_thickness_is_the_bare_substrate() {
        let (eta, k) = ([0.2, 0.9, 1.1], [3.9, 2.4, 2.1]);
        for cos in [1.0, 0.7, 0.3, 0.05] {
            let r = thin_film_reflectance(cos, 1.5, 0.0, eta, k);
            for c in 0..3 {
                let bare = fresnel_conductor(cos, eta[c], k[c]);
                assert!((r[c] - bare).abs() < 1e-9, "{cos} {c}: {} vs {bare}", r[c]);
            }
        }
    }

    #[test]
    fn a_quarter_wave_film_cancels_reflection() {
        // n1 = √n2 and n1·d = λ/4 at normal incidence: the classic anti-reflection coat,
        // near zero in green, where the band is centred.
        let n2 = 1.9f64;
        let n1 = n2.sqrt();
        let d = 540.0 / (4.0 * n1);
        let r = thin_film_reflectance(1.0, n1, d, [n2; 3], [0.0; 3]);
        let bare = f0_from_ior(n2);
        assert!(r[1] < 0.1 * bare, "{r:?} vs {bare}");
        assert!(r[0] > r[1] && r[2] > r[1]);
    }

    #[test]
    fn layered_models_are_reciprocal_non_negative_and_finite() {
        let film = ThinFilm {
            facets: Microfacet::isotropic(
                Distribution::Ggx,
                0.1,
                Fresnel::Schlick { f0: [1.0; 3] },
            ),
            film_ior: 1.4,
            thickness_nm: 380.0,
            eta: [1.5; 3],
            k: [0.0; 3],
            diffuse: [0.05, 0.02, 0.1],
        };
        let coat = AbsorbingCoat {
            base: Box::new(Lambert {
                albedo: [0.8, 0.7, 0.6],
            }),
            ior: 1.5,
            roughness: 0.15,
            distribution: Distribution::Beckmann,
            optical_depth: [0.05, 0.3, 0.9],
        };
        check_basic(&film, 1, 300);
        check_isotropy_claim(&film, 2, 100);
        check_basic(&coat, 3, 300);
        check_isotropy_claim(&coat, 4, 100);
        // A thicker coat absorbs more of the base toward grazing, channel by channel.
        let l = DVec3::new(0.6, 0.0, 0.8);
        let v = DVec3::new(0.0, 0.6, 0.8);
        let rho = coat.eval(l, v);
        assert!(rho[0] > rho[1] && rho[1] > rho[2], "{rho:?}");
    }
}
