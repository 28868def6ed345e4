//! The families' parameter draws: the shared ones (colours, roughness, Fresnel, diffuse
//! bases) and the dispatch by family; each family's own draws are in `microfacet`,
//! `empirical` and `composite`.

use super::Family;
use super::albedo::Built;
use crate::materials::Brdf;
use crate::materials::models::{Distribution, Fresnel, Lambert, OrenNayar};
use rand::RngExt;
use rand_pcg::Pcg64;

/// Complex refractive indices (η, κ) at roughly 650, 550, 450 nm.
pub(super) const METALS: [(&str, [f64; 3], [f64; 3]); 9] = [
    ("gold", [0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    ("copper", [0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    ("aluminium", [1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
    ("silver", [0.155, 0.117, 0.138], [4.828, 3.122, 2.147]),
    ("chrome", [4.370, 2.917, 1.651], [5.206, 4.231, 3.755]),
    ("iron", [2.870, 2.950, 2.650], [3.030, 2.930, 2.810]),
    ("platinum", [2.376, 2.085, 1.845], [4.266, 3.715, 3.137]),
    ("brass", [0.444, 0.527, 1.094], [3.695, 2.765, 1.829]),
    ("nickel", [1.990, 1.830, 1.600], [3.740, 3.190, 2.620]),
];

pub(super) fn rgb(c: [f64; 3]) -> String {
    format!("({:.3},{:.3},{:.3})", c[0], c[1], c[2])
}

fn hsv(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h6 = (h.rem_euclid(1.0)) * 6.0;
    let f = |n: f64| {
        let k = (n + h6) % 6.0;
        v - v * s * (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    [f(5.0), f(3.0), f(1.0)]
}

/// Mixes seed and index into one RNG seed (SplitMix64 finaliser on each).
pub(super) fn mix(seed: u64, index: usize) -> u64 {
    fn splitmix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    splitmix(seed ^ splitmix(index as u64 ^ 0x6d61_7465_7269_616c))
}

/// Parameter draws.
pub(super) struct Gen {
    pub(super) rng: Pcg64,
}

impl Gen {
    pub(super) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.rng.random::<f64>()
    }

    pub(super) fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }

    pub(super) fn chance(&mut self, p: f64) -> bool {
        self.rng.random::<f64>() < p
    }

    pub(super) fn below(&mut self, n: usize) -> usize {
        self.rng.random_range(0..n)
    }

    /// An albedo: uniform hue, often desaturated, value drawn in display space and made
    /// linear, with near-black and near-white over-represented; every channel ≤ 0.97.
    pub(super) fn colour(&mut self) -> [f64; 3] {
        let h = self.uniform(0.0, 1.0);
        let r = self.uniform(0.0, 1.0);
        let (s, v) = if r < 0.1 {
            (self.uniform(0.0, 0.6), self.uniform(0.03, 0.15))
        } else if r < 0.2 {
            (self.uniform(0.0, 0.06), self.uniform(0.88, 0.985))
        } else {
            let s = if self.chance(0.3) {
                self.uniform(0.0, 0.15)
            } else {
                self.uniform(0.15, 1.0)
            };
            (s, self.uniform(0.15, 0.95))
        };
        hsv(h, s, v).map(|c| c.powf(2.2))
    }

    /// A roughness α, log-uniform from near-mirror to very rough.
    pub(super) fn alpha(&mut self, lo: f64, hi: f64) -> f64 {
        self.log_uniform(lo, hi)
    }

    pub(super) fn distribution(&mut self) -> Distribution {
        if self.chance(0.75) {
            Distribution::Ggx
        } else {
            Distribution::Beckmann
        }
    }

    /// Conductor Fresnel: a real metal, or a random one with a random reflectance colour.
    pub(super) fn conductor(&mut self) -> (Fresnel, String) {
        if self.chance(0.7) {
            let (name, eta, k) = METALS[self.below(METALS.len())];
            (Fresnel::Conductor { eta, k }, name.to_string())
        } else {
            let h = self.uniform(0.0, 1.0);
            let s = self.uniform(0.0, 0.6);
            let v = self.uniform(0.6, 0.99);
            let f0 = hsv(h, s, v).map(|c| c.powf(2.2).max(0.02));
            let eta0 = self.uniform(0.15, 2.5);
            let mut eta = [0.0; 3];
            let mut k = [0.0; 3];
            for c in 0..3 {
                let n = eta0 * self.uniform(0.8, 1.25);
                // Solve ((n − 1)² + κ²)/((n + 1)² + κ²) = f0 for κ; if f0 is below the
                // dielectric reflectance of n, take the dielectric with reflectance f0.
                let f = f0[c];
                let k2 = (f * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - f);
                if k2 >= 0.0 {
                    eta[c] = n;
                    k[c] = k2.sqrt();
                } else {
                    eta[c] = (1.0 + f.sqrt()) / (1.0 - f.sqrt());
                }
            }
            (
                Fresnel::Conductor { eta, k },
                format!("metal f0={}", rgb(f0)),
            )
        }
    }

    /// A Lambert (70%) or Oren–Nayar base scaled by `k`.
    pub(super) fn diffuse_base(&mut self, k: f64) -> (Box<dyn Brdf>, String) {
        let albedo = self.colour().map(|c| c * k);
        if self.chance(0.7) {
            (
                Box::new(Lambert { albedo }),
                format!("lambert {}", rgb(albedo)),
            )
        } else {
            let sigma = self.uniform(0.15, 1.0);
            (
                Box::new(OrenNayar { albedo, sigma }),
                format!("oren-nayar {} σ={sigma:.2}", rgb(albedo)),
            )
        }
    }

    /// A material of `family`, before the albedo cap.
    pub(super) fn family(&mut self, family: Family) -> Built {
        match family {
            Family::Diffuse => self.diffuse(),
            Family::RoughDiffuse => self.rough_diffuse(),
            Family::Glossy => self.glossy(),
            Family::Varnish => self.varnish(),
            Family::Metal => self.metal(),
            Family::Anisotropic => self.anisotropic(),
            Family::Ward => self.ward(),
            Family::AshikhminShirley => self.ashikhmin_shirley(),
            Family::Phong => self.phong(),
            Family::Lafortune => self.lafortune(),
            Family::CookTorrance => self.cook_torrance(),
            Family::Principled => self.principled(),
            Family::Sheen => self.sheen(),
            Family::Velvet => self.velvet(),
            Family::Retro => self.retro(),
            Family::Dusty => self.dusty(),
            Family::ClearCoat => self.clear_coat(),
            Family::LayeredCoat => self.layered_coat(),
            Family::ThinFilm => self.thin_film(),
            Family::Mixture => self.mixture(),
            Family::BiScaleGrooves => self.grooves(),
            Family::BiScaleBumps => self.bumps(),
        }
    }
}
