//! The localised prior's bands: coefficients that vary smoothly with θ_d, the half angle
//! between the light and view directions.
//!
//! A single directional light and an orthographic camera see one θ_d per view, so every view
//! is a slice of the table at its own θ_d. The database's components couple slices far apart
//! in θ_d (a trend between two painted slices extrapolates to a retro-reflective peak near
//! θ_d = 0, or a Fresnel peak near 90°) more tightly than materials outside it do. The
//! reconstruction therefore takes its coefficients from [`BANDS`] sets X_j, one at each knot
//! θ_j = j·90°/(BANDS − 1), blended with hat functions: x(θ_d) = (1 − f)·X_a + f·X_(a+1).
//! The prior correlates the sets (see `ridge`), so a painted slice still informs the whole
//! table, but less so the further away it lies in θ_d.

use crate::table::{PAIRS, bin_centre, for_each_pair};
use std::sync::OnceLock;

/// Number of coefficient sets (knots over θ_d ∈ [0°, 90°]).
pub const BANDS: usize = 5;

/// Where a pair lies between the knots: coefficients (1 − `frac`)·X_`lower` + `frac`·X_(`lower`+1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandWeights {
    pub lower: u8,
    pub frac: f32,
}

impl BandWeights {
    /// The knot index and blend of half angle `theta_d` (radians), for `bands` knots.
    pub fn of_theta_d(theta_d: f64, bands: usize) -> Self {
        if bands <= 1 {
            return Self {
                lower: 0,
                frac: 0.0,
            };
        }
        let step = std::f64::consts::FRAC_PI_2 / (bands - 1) as f64;
        let t = (theta_d / step).clamp(0.0, (bands - 1) as f64);
        let lower = (t.floor() as usize).min(bands - 2);
        Self {
            lower: lower as u8,
            frac: (t - lower as f64) as f32,
        }
    }

    /// The weights of the two sets this pair blends: (lower, 1 − frac), (lower + 1, frac).
    #[inline]
    pub fn pairs(self) -> [(usize, f64); 2] {
        let a = self.lower as usize;
        [(a, 1.0 - self.frac as f64), (a + 1, self.frac as f64)]
    }
}

/// θ_d of two unit directions, from l·v alone so that it is symmetric: cos θ_d = √((1 + l·v)/2).
#[inline]
pub fn theta_d(l_dot_v: f64) -> f64 {
    (0.5 + 0.5 * l_dot_v).clamp(0.0, 1.0).sqrt().acos()
}

/// The band weights of every pair at [`BANDS`] knots, computed once.
pub fn pair_bands() -> &'static [BandWeights] {
    static TABLE: OnceLock<Vec<BandWeights>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut out = vec![
            BandWeights {
                lower: 0,
                frac: 0.0
            };
            PAIRS
        ];
        let centres: Vec<glam::DVec3> = (0..crate::table::DIRECTIONS as u16)
            .map(bin_centre)
            .collect();
        for_each_pair(|pair, lo, hi| {
            let d = centres[lo as usize].dot(centres[hi as usize]);
            out[pair] = BandWeights::of_theta_d(theta_d(d), BANDS);
        });
        out
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hats_partition_unity_and_hit_the_knots() {
        for deg in [0.0, 10.0, 22.5, 30.0, 45.0, 80.0, 90.0] {
            let w = BandWeights::of_theta_d(f64::to_radians(deg), 5);
            let [(a, wa), (b, wb)] = w.pairs();
            assert_eq!(b, a + 1);
            assert!(b < 5);
            assert!((wa + wb - 1.0).abs() < 1e-12);
            let at = (a as f64 + wb) * 22.5;
            assert!((at - deg).abs() < 1e-4, "{deg}: {at}");
        }
        assert_eq!(BandWeights::of_theta_d(1.0, 1).pairs()[1].1, 0.0);
    }

    #[test]
    fn theta_d_is_half_the_angle_between() {
        assert!(theta_d(1.0).abs() < 1e-12);
        assert!((theta_d(-1.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((theta_d(0.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // A pair and its reverse share their weights: the table is reciprocal.
        let bands = pair_bands();
        assert_eq!(bands.len(), PAIRS);
    }
}
