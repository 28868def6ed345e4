//! The localised prior's bands: coefficients that vary smoothly with θ_d, the half angle
//! between the light and view directions.
//!
//! A single directional light and an orthographic camera see one θ_d per view, so every view
//! is a slice of the table at its own θ_d. The database's components couple slices far apart
//! in θ_d (a trend between two painted slices extrapolates to a retro-reflective peak near
//! θ_d = 0, or a Fresnel peak near 90°) more tightly than materials outside it do. The
//! reconstruction therefore takes its coefficients from [`BANDS`] sets X_j, one at each knot
//! θ_j, blended with hat functions: x(θ_d) = (1 − f)·X_a + f·X_(a+1), where the knots sit as
//! [`KnotSpacing`] says ([`DEFAULT_KNOTS`], uniform in θ_d, for the default prior). The prior
//! correlates the sets (see `ridge`), so a painted slice still informs the whole table, but
//! less so the further away it lies in θ_d.

use crate::table::{PAIRS, bin_centre, for_each_pair};
use std::sync::OnceLock;

/// Number of coefficient sets (knots over θ_d ∈ [0°, 90°]).
pub const BANDS: usize = 5;

/// Where the knots sit over θ_d ∈ [0°, 90°].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum KnotSpacing {
    /// θ_j = j·90°/(B − 1): 0°, 22.5°, 45°, 67.5°, 90°.
    Uniform,
    /// Uniform in 1 − cos θ_d, the variable of Schlick's Fresnel term: 0°, 41°, 60°, 76°, 90°.
    /// Knots are dense where Fresnel and shadowing change fast (grazing) and sparse where a
    /// BRDF's shape barely changes with θ_d, so a slice painted at small θ_d also sets the
    /// table at θ_d = 0 (back-scatter at normal incidence, where renders look most) by
    /// interpolation rather than through the prior alone.
    Cosine,
    /// Uniform in sin² θ_d: 0°, 30°, 45°, 60°, 90°.
    SineSquared,
    /// Uniform in (1 − cos θ_d)²: 0°, 60°, 73°, 82°, 90°. Flatter still at small θ_d.
    CosineSquared,
}

impl KnotSpacing {
    pub const ALL: [Self; 4] = [
        Self::Uniform,
        Self::Cosine,
        Self::SineSquared,
        Self::CosineSquared,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Uniform => "uniform",
            Self::Cosine => "cosine",
            Self::SineSquared => "sine-squared",
            Self::CosineSquared => "cosine-squared",
        }
    }

    /// The knot coordinate of `theta_d` (radians), from 0 at 0° to 1 at 90°.
    fn coordinate(self, theta_d: f64) -> f64 {
        match self {
            Self::Uniform => theta_d / std::f64::consts::FRAC_PI_2,
            Self::Cosine => 1.0 - theta_d.cos(),
            Self::SineSquared => theta_d.sin().powi(2),
            Self::CosineSquared => (1.0 - theta_d.cos()).powi(2),
        }
    }
}

impl std::str::FromStr for KnotSpacing {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown knot spacing '{s}' (uniform, cosine, sine-squared, cosine-squared)"
                )
            })
    }
}

/// Where a pair lies between the knots: coefficients (1 − `frac`)·X_`lower` + `frac`·X_(`lower`+1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandWeights {
    pub lower: u8,
    pub frac: f32,
}

impl BandWeights {
    /// The knot index and blend of half angle `theta_d` (radians), for `bands` uniform knots.
    pub fn of_theta_d(theta_d: f64, bands: usize) -> Self {
        Self::of_theta_d_spaced(theta_d, bands, KnotSpacing::Uniform)
    }

    /// The knot index and blend of half angle `theta_d` (radians), for `bands` knots spaced
    /// by `spacing`.
    pub fn of_theta_d_spaced(theta_d: f64, bands: usize, spacing: KnotSpacing) -> Self {
        if bands <= 1 {
            return Self {
                lower: 0,
                frac: 0.0,
            };
        }
        let t = (spacing.coordinate(theta_d) * (bands - 1) as f64).clamp(0.0, (bands - 1) as f64);
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

/// The knot spacing of the default prior ([`super::PriorModel::CALIBRATED`]), which the
/// preview's GPU evaluation and [`super::Reconstruction::new`] use.
pub const DEFAULT_KNOTS: KnotSpacing = KnotSpacing::Uniform;

/// The band weights of every pair at [`BANDS`] knots of the default spacing, computed once.
pub fn pair_bands() -> &'static [BandWeights] {
    pair_bands_spaced(DEFAULT_KNOTS)
}

/// The band weights of every pair at [`BANDS`] knots spaced by `spacing`, computed once each.
pub fn pair_bands_spaced(spacing: KnotSpacing) -> &'static [BandWeights] {
    static TABLES: [OnceLock<Vec<BandWeights>>; KnotSpacing::ALL.len()] =
        [const { OnceLock::new() }; KnotSpacing::ALL.len()];
    let slot = KnotSpacing::ALL
        .iter()
        .position(|&k| k == spacing)
        .expect("every spacing is in ALL");
    TABLES[slot].get_or_init(|| {
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
            out[pair.index()] = BandWeights::of_theta_d_spaced(theta_d(d), BANDS, spacing);
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
    fn spaced_knots_sit_where_their_coordinate_says() {
        let at = |deg: f64, spacing| {
            let w = BandWeights::of_theta_d_spaced(f64::to_radians(deg), 5, spacing);
            w.lower as f64 + w.frac as f64
        };
        for spacing in KnotSpacing::ALL {
            assert!(at(0.0, spacing).abs() < 1e-6);
            assert!((at(90.0, spacing) - 4.0).abs() < 1e-5);
            assert_eq!(spacing.name().parse::<KnotSpacing>(), Ok(spacing));
        }
        // Cosine: knots at acos(1 − j/4) = 0°, 41.4°, 60°, 75.5°, 90°.
        assert!((at(60.0, KnotSpacing::Cosine) - 2.0).abs() < 1e-5);
        assert!((at(41.409_622, KnotSpacing::Cosine) - 1.0).abs() < 1e-5);
        // Sine squared: 0°, 30°, 45°, 60°, 90°.
        assert!((at(30.0, KnotSpacing::SineSquared) - 1.0).abs() < 1e-5);
        assert!((at(45.0, KnotSpacing::SineSquared) - 2.0).abs() < 1e-5);
    }

    /// A half angle blends two neighbouring knots with weights in [0, 1]: at 90° all the
    /// weight is on the last knot, paired with the one before it, and a uniform knot's half
    /// angle past 90° (which no pair has) is held there.
    #[test]
    fn grazing_half_angles_weigh_the_last_knot_whole() {
        for spacing in KnotSpacing::ALL {
            for deg in 0..=90 {
                let w = BandWeights::of_theta_d_spaced(f64::from(deg).to_radians(), 5, spacing);
                assert!(
                    w.lower <= 3 && (0.0..=1.0).contains(&w.frac),
                    "{spacing:?} {deg}°: {w:?}"
                );
            }
            let w = BandWeights::of_theta_d_spaced(std::f64::consts::FRAC_PI_2, 5, spacing);
            assert!(
                w.lower == 3 && (w.frac - 1.0).abs() < 1e-5,
                "{spacing:?}: {w:?}"
            );
        }
        for angle in [2.0, 10.0] {
            let w = BandWeights::of_theta_d(angle, 5);
            assert_eq!((w.lower, w.frac), (3, 1.0), "{angle}");
        }
    }

    /// Every spacing has its own table of pair weights, whichever is asked for first.
    #[test]
    fn each_spacing_keeps_its_own_table() {
        use crate::table::{PairIndex, pair_directions};
        for spacing in KnotSpacing::ALL {
            let table = pair_bands_spaced(spacing);
            for p in (0..PAIRS).step_by(9973) {
                let (lo, hi) = pair_directions(PairIndex::from_index(p));
                let d = bin_centre(lo).dot(bin_centre(hi));
                let expected = BandWeights::of_theta_d_spaced(theta_d(d), BANDS, spacing);
                assert_eq!(table[p], expected, "{spacing:?}, pair {p}");
            }
        }
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
