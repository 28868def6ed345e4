//! Direction bins and the unordered-pair index of TABLE.md.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Polar bins over [0, π/2].
pub const THETA_BINS: usize = 45;
/// Azimuth bins over [0, 2π).
pub const PHI_BINS: usize = 36;
/// Direction bins: `d = PHI_BINS · t + p`.
pub const DIRECTIONS: usize = THETA_BINS * PHI_BINS;
/// Entries of the full (ordered) table: `DIRECTIONS²`.
pub const ENTRIES: usize = DIRECTIONS * DIRECTIONS;
/// Unordered direction pairs: what a reciprocal table stores.
pub const PAIRS: usize = DIRECTIONS * (DIRECTIONS + 1) / 2;

/// A direction bin index in `[0, DIRECTIONS)`.
pub type DirIndex = u16;

/// Polar index of an angle θ (radians), clamped to the last bin at π/2. A negative or NaN
/// angle is bin 0: a float-to-int `as` saturates, and takes NaN to 0.
pub fn theta_index(theta: f64) -> usize {
    ((theta / FRAC_PI_2 * THETA_BINS as f64).floor() as usize).min(THETA_BINS - 1)
}

/// Azimuth index of an angle φ (radians, any range); NaN is bin 0, as `as` takes it to 0.
pub fn phi_index(phi: f64) -> usize {
    let wrapped = phi.rem_euclid(TAU);
    // A φ a hair below 0 wraps to 2π itself after rounding; its bin, PHI_BINS, is bin 0.
    ((wrapped / TAU * PHI_BINS as f64).floor() as usize) % PHI_BINS
}

/// The bin of a unit direction in the local shading frame, or `None` below the horizon.
pub fn direction_index(w: DVec3) -> Option<DirIndex> {
    let len = w.length();
    if !len.is_finite() || len == 0.0 {
        return None;
    }
    let w = w / len;
    if w.z <= 0.0 {
        return None;
    }
    let theta = w.z.min(1.0).acos();
    let phi = w.y.atan2(w.x);
    Some((PHI_BINS * theta_index(theta) + phi_index(phi)) as DirIndex)
}

/// Splits a direction index into its (polar, azimuth) indices.
#[inline]
pub fn split_direction(d: DirIndex) -> (usize, usize) {
    let d = d as usize;
    (d / PHI_BINS, d % PHI_BINS)
}

/// Polar angle of the centre of polar bin `t`.
#[inline]
pub fn theta_centre(t: usize) -> f64 {
    (t as f64 + 0.5) * FRAC_PI_2 / THETA_BINS as f64
}

/// Azimuth of the centre of azimuth bin `p`.
#[inline]
pub fn phi_centre(p: usize) -> f64 {
    (p as f64 + 0.5) * TAU / PHI_BINS as f64
}

/// (θ, φ) of the centre of direction bin `d`.
#[inline]
pub fn bin_angles(d: DirIndex) -> (f64, f64) {
    let (t, p) = split_direction(d);
    (theta_centre(t), phi_centre(p))
}

/// Unit vector of the centre of direction bin `d`.
pub fn bin_centre(d: DirIndex) -> DVec3 {
    let (theta, phi) = bin_angles(d);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// The index of an unordered (light bin, view bin) pair in a reciprocal table: always below
/// [`PAIRS`]. One type for it everywhere (sparse bins, the solver, the worker's updates, the
/// preview), where a bare integer once stood, sometimes `usize` and sometimes `u32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(transparent)]
pub struct PairIndex(u32);

/// A pair index at or past [`PAIRS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("pair index {0} is out of range (there are {PAIRS} pairs)")]
pub struct PairOutOfRange(pub usize);

impl PairIndex {
    /// The pair at storage position `index`. Panics at or past [`PAIRS`].
    #[inline]
    pub const fn from_index(index: usize) -> Self {
        assert!(index < PAIRS, "pair index out of range");
        Self(index as u32)
    }

    /// The position of the pair in pair-ordered storage.
    #[inline]
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The index as the `u32` GPU buffers hold.
    #[inline]
    pub const fn get(self) -> u32 {
        self.0
    }

    /// Every pair, in storage order.
    pub fn all() -> impl DoubleEndedIterator<Item = Self> + ExactSizeIterator + Clone {
        (0..PAIRS as u32).map(Self)
    }
}

impl TryFrom<usize> for PairIndex {
    type Error = PairOutOfRange;
    fn try_from(index: usize) -> Result<Self, PairOutOfRange> {
        if index < PAIRS {
            Ok(Self(index as u32))
        } else {
            Err(PairOutOfRange(index))
        }
    }
}

impl TryFrom<u32> for PairIndex {
    type Error = PairOutOfRange;
    fn try_from(index: u32) -> Result<Self, PairOutOfRange> {
        Self::try_from(index as usize)
    }
}

impl From<PairIndex> for usize {
    fn from(pair: PairIndex) -> usize {
        pair.index()
    }
}

impl std::fmt::Display for PairIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// Index of the unordered pair {a, b} in a reciprocal table.
///
/// Pairs are ordered by the larger index, then the smaller, so that iterating
/// `hi in 0..DIRECTIONS, lo in 0..=hi` walks the storage in order.
#[inline]
pub fn pair_index(a: DirIndex, b: DirIndex) -> PairIndex {
    let (lo, hi) = if a <= b {
        (a as u32, b as u32)
    } else {
        (b as u32, a as u32)
    };
    debug_assert!((hi as usize) < DIRECTIONS);
    PairIndex(hi * (hi + 1) / 2 + lo)
}

/// The directions (lo, hi) of a pair index; inverse of [`pair_index`].
pub fn pair_directions(pair: PairIndex) -> (DirIndex, DirIndex) {
    let pair = pair.index();
    // hi is the largest integer with hi(hi+1)/2 <= pair: ⌊(√(8·pair + 1) − 1)/2⌋, exact in f64
    // for every pair. 8·pair + 1 < 2²⁴, so its root is exact where it is a whole number and
    // elsewhere lies further from one (more than 1/(2√(8·pair + 1)) ≈ 1.5e-4) than rounding
    // reaches; `pair_index_is_a_bijection` checks every pair.
    let hi = ((((8 * pair + 1) as f64).sqrt() - 1.0) / 2.0) as usize;
    let lo = pair - hi * (hi + 1) / 2;
    (lo as DirIndex, hi as DirIndex)
}

/// How many full-table entries a pair stands for: 1 on the diagonal, 2 off it.
#[inline]
pub fn pair_multiplicity(pair: PairIndex) -> f64 {
    let (lo, hi) = pair_directions(pair);
    if lo == hi { 1.0 } else { 2.0 }
}

/// Calls `f(pair, lo, hi)` for every pair in storage order.
pub fn for_each_pair(mut f: impl FnMut(PairIndex, DirIndex, DirIndex)) {
    let mut pair = 0;
    for hi in 0..DIRECTIONS {
        for lo in 0..=hi {
            f(PairIndex(pair), lo as DirIndex, hi as DirIndex);
            pair += 1;
        }
    }
}

/// The cosine of the polar centre of a direction bin.
#[inline]
pub fn cos_theta_centre(d: DirIndex) -> f64 {
    theta_centre(split_direction(d).0).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centres_round_trip_to_their_bins() {
        for d in 0..DIRECTIONS as DirIndex {
            assert_eq!(direction_index(bin_centre(d)), Some(d));
        }
    }

    #[test]
    fn bin_centres_follow_table_md() {
        // t = 0, p = 0: θ = 1°, φ = 5°.
        let (theta, phi) = bin_angles(0);
        assert!((theta - 1f64.to_radians()).abs() < 1e-15);
        assert!((phi - 5f64.to_radians()).abs() < 1e-15);
        // d = 36 t + p.
        let (theta, phi) = bin_angles(36 * 44 + 35);
        assert!((theta - 89f64.to_radians()).abs() < 1e-13);
        assert!((phi - 355f64.to_radians()).abs() < 1e-13);
    }

    #[test]
    fn edges_and_horizon() {
        // The normal itself lands in polar bin 0.
        assert_eq!(direction_index(DVec3::Z), Some(0));
        // Below or on the horizon gives no bin.
        assert_eq!(direction_index(DVec3::new(1.0, 0.0, 0.0)), None);
        assert_eq!(direction_index(DVec3::new(0.0, 1.0, -0.1)), None);
        assert_eq!(direction_index(DVec3::ZERO), None);
        assert_eq!(direction_index(DVec3::new(f64::NAN, 0.0, 1.0)), None);
        // Just under φ = 2π wraps to the last azimuth bin, just over 0 to the first.
        let near = |phi: f64| DVec3::new(0.5 * phi.cos(), 0.5 * phi.sin(), 0.8);
        assert_eq!(direction_index(near(-1e-9)).map(|d| d % 36), Some(35));
        assert_eq!(direction_index(near(1e-9)).map(|d| d % 36), Some(0));
        assert_eq!(phi_index(TAU), 0);
        assert_eq!(theta_index(FRAC_PI_2), THETA_BINS - 1);
    }

    #[test]
    fn pair_index_is_a_bijection() {
        let mut expected = 0;
        for_each_pair(|pair, lo, hi| {
            assert_eq!(pair.index(), expected);
            assert_eq!(pair_index(lo, hi), pair);
            assert_eq!(pair_index(hi, lo), pair);
            assert_eq!(pair_directions(pair), (lo, hi));
            expected += 1;
        });
        assert_eq!(expected, PAIRS);
        assert_eq!(PAIRS, 1_313_010);
        assert_eq!(
            PairIndex::try_from(PAIRS - 1),
            Ok(PairIndex::from_index(PAIRS - 1))
        );
        assert_eq!(PairIndex::try_from(PAIRS), Err(PairOutOfRange(PAIRS)));
    }

    /// What the storage's users lean on beyond the bijection: each pair's weight in the full
    /// table, the index's conversions, and angles outside a bin's usual range.
    #[test]
    fn pairs_weigh_and_convert_as_the_full_table_counts_them() {
        let (mut total, mut diagonal) = (0.0, 0);
        for_each_pair(|pair, lo, hi| {
            let m = pair_multiplicity(pair);
            assert_eq!(m, if lo == hi { 1.0 } else { 2.0 }, "{pair}");
            diagonal += usize::from(lo == hi);
            total += m;
        });
        assert_eq!(diagonal, DIRECTIONS);
        assert_eq!(total, ENTRIES as f64);

        let all: Vec<PairIndex> = PairIndex::all().collect();
        assert_eq!(all.len(), PAIRS);
        assert!(all.iter().enumerate().all(|(i, p)| p.index() == i));
        let pair = PairIndex::from_index(123_456);
        assert_eq!(pair.get(), 123_456);
        assert_eq!(usize::from(pair), 123_456);
        assert_eq!(pair.to_string(), "123456");
        assert_eq!(PairIndex::try_from(123_456u32), Ok(pair));
        assert_eq!(
            PairIndex::try_from(PAIRS as u32),
            Err(PairOutOfRange(PAIRS))
        );

        // Polar angles: 1° wide bins, negative and NaN angles in the first, past π/2 the last.
        assert_eq!(theta_index(0.0), 0);
        assert_eq!(theta_index(44.5f64.to_radians()), 22);
        assert_eq!(theta_index(-0.1), 0);
        assert_eq!(theta_index(f64::NAN), 0);
        assert_eq!(theta_index(2.0), THETA_BINS - 1);
        assert_eq!(theta_index(f64::INFINITY), THETA_BINS - 1);
        assert_eq!(theta_index(f64::NEG_INFINITY), 0);
        // Azimuths wrap: 10° wide bins over any multiple of 2π; NaN in the first.
        assert_eq!(phi_index(15f64.to_radians()), 1);
        assert_eq!(phi_index(15f64.to_radians() - 2.0 * TAU), 1);
        assert_eq!(phi_index(-15f64.to_radians()), PHI_BINS - 2);
        assert_eq!(phi_index(f64::NAN), 0);
        assert_eq!(phi_index(f64::INFINITY), 0);
        // A direction need not be unit length, and rounding past z = 1 is still the normal.
        let w = bin_centre(36 * 30 + 7);
        assert_eq!(direction_index(w * 3.5), Some(36 * 30 + 7));
        assert_eq!(
            direction_index(DVec3::new(1e-17, 0.0, 1.0 + 1e-15)),
            Some(0)
        );
        assert_eq!(direction_index(DVec3::new(0.0, 0.0, f64::INFINITY)), None);
        for d in [0, 36 * 44 + 3, 36 * 20] {
            let (t, _) = split_direction(d);
            assert_eq!(cos_theta_centre(d), theta_centre(t).cos());
            assert!((bin_centre(d).z - cos_theta_centre(d)).abs() < 1e-15);
        }
    }
}
