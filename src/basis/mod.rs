//! The PCA basis of the material database in the log-mapped domain of Nielsen et al. 2015.
//!
//! For every unordered direction pair p the basis holds the reference of the map (e^mean of
//! ln(ρ·c + ε) over the database, less ε), the mean of the mapped values, the range the
//! database spans, what the components leave unexplained there, and one row of K components.
//! Component k is orthonormal over the *full* 1620² table, which counts an off-diagonal pair
//! twice: Σ_p mult(p) u_p u_pᵀ = I.

pub mod build;
pub mod cache;
pub mod projection;

pub use build::{BasisSpec, BuildProgress, build_basis};
pub use cache::{BasisCache, CacheOutcome};
pub use projection::OracleProjector;

use crate::table::{PAIRS, PHI_BINS, PairIndex, THETA_BINS, pair_directions, theta_centre};
use std::sync::OnceLock;

/// Cosine floor of the mapping weight c = clamp(cos θ_l cos θ_v, 0.01, 1).
pub const MAP_COS_FLOOR: f64 = 0.01;
/// Offset that keeps the logarithm finite for black entries.
pub const MAP_EPSILON: f64 = 0.001;
/// Floor of the residual variance, so that a database the basis spans exactly still leaves
/// the prior some say.
pub const MIN_RESIDUAL_VARIANCE: f64 = 1e-4;
/// How far (in the mapped domain) a reconstruction may leave the range the database spans.
pub const RANGE_MARGIN: f32 = 0.25;

/// c for polar bins `t_l`, `t_v`.
#[inline]
pub fn cos_weight_polar(t_l: usize, t_v: usize) -> f64 {
    static COS: OnceLock<[f64; THETA_BINS]> = OnceLock::new();
    let cos = COS.get_or_init(|| std::array::from_fn(|t| theta_centre(t).cos()));
    (cos[t_l] * cos[t_v]).clamp(MAP_COS_FLOOR, 1.0)
}

/// c for the pair `pair`.
#[inline]
pub fn cos_weight(pair: PairIndex) -> f64 {
    let (lo, hi) = pair_directions(pair);
    cos_weight_polar(lo as usize / PHI_BINS, hi as usize / PHI_BINS)
}

/// The forward map m = ln((ρc + ε) / (reference + ε)).
#[inline]
pub fn map_value(rho: f64, c: f64, reference: f64) -> f64 {
    ((rho.max(0.0) * c + MAP_EPSILON) / (reference + MAP_EPSILON)).ln()
}

/// The inverse map, clamped to ρ ≥ 0.
#[inline]
pub fn unmap_value(m: f64, c: f64, reference: f64) -> f64 {
    ((m.exp() * (reference + MAP_EPSILON) - MAP_EPSILON) / c).max(0.0)
}

/// Backing store of a basis: built in memory, or memory-mapped from the cache.
enum Backing {
    Owned(Vec<f32>),
    Mapped { map: memmap2::Mmap, offset: usize },
}

/// A loaded or freshly built basis. Cheap to share behind an `Arc`.
pub struct Basis {
    components: usize,
    observations: usize,
    /// Variance of each component's coefficient over the database observations.
    variances: Vec<f64>,
    /// Mean squared residual per table entry of the database projected on the K components.
    residual_variance: f64,
    backing: Backing,
}

impl std::fmt::Debug for Basis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Basis")
            .field("components", &self.components)
            .field("observations", &self.observations)
            .field("variances", &self.variances)
            .field("residual_variance", &self.residual_variance)
            .finish()
    }
}

/// Offsets (in f32 elements) of the per-pair arrays inside the backing store (`ROWS` is
/// shared with the builder, which fills them in this order).
const REFERENCE: usize = 0;
const MEAN: usize = PAIRS;
const LOWER: usize = 2 * PAIRS;
const UPPER: usize = 3 * PAIRS;
const RESIDUAL: usize = 4 * PAIRS;
pub(crate) const ROWS: usize = 5 * PAIRS;

impl Basis {
    /// Number of f32 values a basis of `components` components stores.
    pub fn stored_len(components: usize) -> usize {
        ROWS + PAIRS * components
    }

    pub(crate) fn from_owned(
        components: usize,
        observations: usize,
        variances: Vec<f64>,
        residual_variance: f64,
        data: Vec<f32>,
    ) -> Self {
        assert_eq!(data.len(), Self::stored_len(components));
        assert_eq!(variances.len(), components);
        let backing = Backing::Owned(data);
        Self {
            components,
            observations,
            variances,
            residual_variance,
            backing,
        }
    }

    pub(crate) fn from_mapped(
        components: usize,
        observations: usize,
        variances: Vec<f64>,
        residual_variance: f64,
        map: memmap2::Mmap,
        offset: usize,
    ) -> Self {
        assert!(map.len() >= offset + 4 * Self::stored_len(components));
        assert_eq!(offset % 4, 0);
        let backing = Backing::Mapped { map, offset };
        Self {
            components,
            observations,
            variances,
            residual_variance,
            backing,
        }
    }

    fn data(&self) -> &[f32] {
        match &self.backing {
            Backing::Owned(v) => v,
            Backing::Mapped { map, offset } => {
                let bytes = &map[*offset..*offset + 4 * Self::stored_len(self.components)];
                bytemuck::cast_slice(bytes)
            }
        }
    }

    /// All stored values, in file order.
    pub(crate) fn raw(&self) -> &[f32] {
        self.data()
    }

    /// K, the number of components.
    pub fn components(&self) -> usize {
        self.components
    }

    /// Observations (material × colour channel) the basis was learnt from.
    pub fn observations(&self) -> usize {
        self.observations
    }

    /// Coefficient variance of each component over the database, largest first.
    pub fn variances(&self) -> &[f64] {
        &self.variances
    }

    /// Mean squared residual, per table entry in the mapped domain, of the database's
    /// observations after projection on the K components: what the basis cannot represent.
    /// It is the observation noise variance the solver's prior assumes by default.
    pub fn residual_variance(&self) -> f64 {
        self.residual_variance
    }

    /// Per-pair reference of the map: e^mean of ln(ρ·c + ε) over the database, less ε.
    pub fn references(&self) -> &[f32] {
        &self.data()[REFERENCE..MEAN]
    }

    /// Per-pair mean of the mapped values.
    pub fn means(&self) -> &[f32] {
        &self.data()[MEAN..LOWER]
    }

    /// Per-pair lowest mapped value in the database.
    pub fn lowers(&self) -> &[f32] {
        &self.data()[LOWER..UPPER]
    }

    /// Per-pair highest mapped value in the database.
    pub fn uppers(&self) -> &[f32] {
        &self.data()[UPPER..RESIDUAL]
    }

    /// Per-pair variance, over the database, of what the K components leave of its mapped
    /// values (floored at [`MIN_RESIDUAL_VARIANCE`]): how far the basis can't follow a
    /// material at that entry.
    pub fn residuals(&self) -> &[f32] {
        &self.data()[RESIDUAL..ROWS]
    }

    /// All component rows, pair-major: `rows()[p * K + k]`.
    pub fn rows(&self) -> &[f32] {
        &self.data()[ROWS..]
    }

    /// The K component values of pair `pair`.
    #[inline]
    pub fn row(&self, pair: PairIndex) -> &[f32] {
        let (k, p) = (self.components, pair.index());
        &self.rows()[p * k..(p + 1) * k]
    }

    /// Maps a BRDF value of pair `pair` into the mean-centred domain the components span,
    /// clamped to the database's range (plus a margin) so that wild paint stays bounded.
    #[inline]
    pub fn centred_observation(&self, pair: PairIndex, rho: f64) -> f64 {
        self.centred_residual(pair, rho, 0.0)
    }

    /// As [`Self::centred_observation`], for a value measured from a reference that lies
    /// `offset` above the mean in the mapped domain (a fitted model's, see
    /// `solver::fitted_mean`): the residual is clamped to the range the database spans about
    /// its mean, as the reconstruction clamps what it adds to the reference.
    #[inline]
    pub fn centred_residual(&self, pair: PairIndex, rho: f64, offset: f64) -> f64 {
        let data = self.data();
        let m = map_value(rho, cos_weight(pair), data[REFERENCE + pair.index()] as f64);
        let (lo, hi) = self.mapped_range(pair);
        (m - offset).clamp(lo, hi) - data[MEAN + pair.index()] as f64
    }

    /// map(ρ) − mean of pair `pair`, unclamped.
    #[inline]
    pub fn mapped_from_mean(&self, pair: PairIndex, rho: f64) -> f64 {
        let data = self.data();
        map_value(rho, cos_weight(pair), data[REFERENCE + pair.index()] as f64)
            - data[MEAN + pair.index()] as f64
    }

    /// The mapped range a reconstruction of pair `pair` may take.
    #[inline]
    pub fn mapped_range(&self, pair: PairIndex) -> (f64, f64) {
        let (data, pair) = (self.data(), pair.index());
        (
            (data[LOWER + pair] - RANGE_MARGIN) as f64,
            (data[UPPER + pair] + RANGE_MARGIN) as f64,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_inverts() {
        for &rho in &[0.0, 1e-6, 0.3, 5.0, 1e4] {
            for &c in &[0.01, 0.4, 1.0] {
                let m = map_value(rho, c, 0.2);
                let back = unmap_value(m, c, 0.2);
                assert!(
                    (back - rho).abs() <= 1e-9 * rho.max(1.0),
                    "{rho} {c} {back}"
                );
            }
        }
        // Nothing maps to a non-finite value, and ρ ≥ 0 comes back even from extreme m.
        assert!(map_value(0.0, 0.01, 0.0).is_finite());
        assert_eq!(unmap_value(-50.0, 0.5, 0.1), 0.0);
    }

    /// A basis whose stored value at index i is i: every array reads its own slice.
    fn numbered(components: usize) -> Basis {
        let data: Vec<f32> = (0..Basis::stored_len(components))
            .map(|i| i as f32)
            .collect();
        Basis::from_owned(components, 7, vec![3.0, 2.0], 0.5, data)
    }

    #[test]
    fn each_array_is_its_slice_of_the_stored_values() {
        let basis = numbered(2);
        assert_eq!(Basis::stored_len(2), 7 * PAIRS);
        assert_eq!(basis.raw().len(), 7 * PAIRS);
        assert_eq!(basis.components(), 2);
        assert_eq!(basis.observations(), 7);
        assert_eq!(basis.variances(), &[3.0, 2.0]);
        assert_eq!(basis.residual_variance(), 0.5);
        let arrays: [(&str, &[f32], usize); 5] = [
            ("references", basis.references(), 0),
            ("means", basis.means(), 1),
            ("lowers", basis.lowers(), 2),
            ("uppers", basis.uppers(), 3),
            ("residuals", basis.residuals(), 4),
        ];
        for (name, array, slot) in arrays {
            assert_eq!(array.len(), PAIRS, "{name}");
            for p in [0, 1, PAIRS / 3, PAIRS - 1] {
                assert_eq!(array[p], (slot * PAIRS + p) as f32, "{name}[{p}]");
            }
        }
        assert_eq!(
            format!("{basis:?}"),
            "Basis { components: 2, observations: 7, variances: [3.0, 2.0], \
             residual_variance: 0.5 }"
        );
        assert_eq!(basis.rows().len(), 2 * PAIRS);
        assert_eq!(basis.rows()[0], (5 * PAIRS) as f32);
        for p in [0, 1, 777, PAIRS - 1] {
            let pair = PairIndex::from_index(p);
            let first = (5 * PAIRS + 2 * p) as f32;
            assert_eq!(basis.row(pair), &[first, first + 1.0], "pair {p}");
        }
    }

    /// A pair's reference, mean and range, with every other value 0.
    fn one_pair_basis(pair: PairIndex, reference: f32, mean: f32, range: (f32, f32)) -> Basis {
        let mut data = vec![0.0f32; Basis::stored_len(1)];
        let p = pair.index();
        data[REFERENCE + p] = reference;
        data[MEAN + p] = mean;
        data[LOWER + p] = range.0;
        data[UPPER + p] = range.1;
        Basis::from_owned(1, 1, vec![1.0], 1.0, data)
    }

    /// The centred value written out: ln((ρc + ε)/(reference + ε)) less the offset, clamped
    /// to the range widened by the margin, less the mean.
    #[test]
    fn a_centred_value_is_its_map_clamped_to_the_range_less_the_mean() {
        let pair = crate::table::pair_index(36 * 20 + 3, 36 * 30 + 17);
        let c = cos_weight(pair);
        let (t_l, t_v) = (20, 30);
        assert_eq!(c, theta_centre(t_l).cos() * theta_centre(t_v).cos());
        let (reference, mean, lower, upper) = (0.2f32, 0.3f32, -1.0f32, 2.0f32);
        let basis = one_pair_basis(pair, reference, mean, (lower, upper));
        let (lo, hi) = ((lower - RANGE_MARGIN) as f64, (upper + RANGE_MARGIN) as f64);
        assert_eq!(basis.mapped_range(pair), (lo, hi));
        assert_eq!((lo, hi), (-1.25, 2.25));
        let mapped = |rho: f64| ((rho * c + MAP_EPSILON) / (reference as f64 + MAP_EPSILON)).ln();
        for rho in [0.0, 0.05, 0.4, 1.5, 40.0] {
            for offset in [0.0, 0.7, -0.9] {
                let expected = (mapped(rho) - offset).clamp(lo, hi) - mean as f64;
                let got = basis.centred_residual(pair, rho, offset);
                assert!((got - expected).abs() < 1e-12, "ρ {rho} offset {offset}");
            }
            let unclamped = mapped(rho) - mean as f64;
            assert!((basis.mapped_from_mean(pair, rho) - unclamped).abs() < 1e-12);
            assert_eq!(
                basis.centred_observation(pair, rho),
                basis.centred_residual(pair, rho, 0.0)
            );
        }
        // Both clamps are reached: black below the range, 40 above it.
        assert_eq!(basis.centred_observation(pair, 0.0), lo - mean as f64);
        assert_eq!(basis.centred_observation(pair, 40.0), hi - mean as f64);
    }

    #[test]
    fn the_map_is_the_log_of_the_weighted_value_over_the_reference() {
        let expected = ((2.0 * 0.5 + MAP_EPSILON) / (0.3 + MAP_EPSILON)).ln();
        assert!((map_value(2.0, 0.5, 0.3) - expected).abs() < 1e-15);
        // Negative paint counts as black.
        assert_eq!(map_value(-1.0, 0.5, 0.3), map_value(0.0, 0.5, 0.3));
        let back = (0.4f64.exp() * (0.3 + MAP_EPSILON) - MAP_EPSILON) / 0.5;
        assert!((unmap_value(0.4, 0.5, 0.3) - back).abs() < 1e-15);
    }

    #[test]
    fn cos_weight_is_clamped() {
        for (t_l, t_v) in [(0, 0), (10, 30), (44, 3), (30, 40)] {
            let product = theta_centre(t_l).cos() * theta_centre(t_v).cos();
            assert_eq!(
                cos_weight_polar(t_l, t_v),
                product.clamp(MAP_COS_FLOOR, 1.0),
                "{t_l} {t_v}"
            );
        }
        assert!(theta_centre(44).cos() * theta_centre(44).cos() < MAP_COS_FLOOR);
        assert_eq!(cos_weight_polar(44, 44), MAP_COS_FLOOR);
        let first = PairIndex::from_index(0);
        assert!((cos_weight(first) - theta_centre(0).cos().powi(2)).abs() < 1e-12);
        let last = PairIndex::from_index(crate::table::PAIRS - 1);
        assert_eq!(cos_weight(last), MAP_COS_FLOOR);
    }
}
