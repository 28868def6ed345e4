//! The BRDF table of TABLE.md: direction bins, reciprocal storage and its files.

pub mod bins;
pub mod exr_file;
pub mod merl;

pub use bins::*;

use rayon::prelude::*;

/// Linear RGB, one value per Rec. 709 primary.
pub type Rgb = [f32; 3];

/// A reciprocal 1620 × 1620 table that stores each unordered direction pair once,
/// so that ρ(l, v) = ρ(v, l) holds bit for bit by construction.
#[derive(Clone, PartialEq)]
pub struct SymTable {
    values: Vec<Rgb>,
}

impl std::fmt::Debug for SymTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SymTable")
            .field("pairs", &self.values.len())
            .finish()
    }
}

impl SymTable {
    /// A table with every entry set to `value`.
    pub fn filled(value: Rgb) -> Self {
        Self {
            values: vec![value; PAIRS],
        }
    }

    /// Wraps pair-ordered values (see [`pair_index`]); `None` unless there are exactly [`PAIRS`].
    pub fn from_pairs(values: Vec<Rgb>) -> Option<Self> {
        (values.len() == PAIRS).then_some(Self { values })
    }

    /// Builds a table by evaluating `f(lo, hi)` once per unordered pair, in parallel.
    pub fn from_fn(f: impl Fn(DirIndex, DirIndex) -> Rgb + Sync) -> Self {
        let values = (0..PAIRS)
            .into_par_iter()
            .with_min_len(4096)
            .map(|pair| {
                let (lo, hi) = pair_directions(PairIndex::from_index(pair));
                f(lo, hi)
            })
            .collect();
        Self { values }
    }

    /// ρ for light bin `d_l` and view bin `d_v`.
    #[inline]
    pub fn get(&self, d_l: DirIndex, d_v: DirIndex) -> Rgb {
        self.values[pair_index(d_l, d_v).index()]
    }

    /// Sets ρ(d_l, d_v) and, by construction, ρ(d_v, d_l).
    #[inline]
    pub fn set(&mut self, d_l: DirIndex, d_v: DirIndex, value: Rgb) {
        self.values[pair_index(d_l, d_v).index()] = value;
    }

    /// The stored values in pair order.
    pub fn pairs(&self) -> &[Rgb] {
        &self.values
    }

    /// True when every value is finite and ≥ 0.
    pub fn is_physical(&self) -> bool {
        self.values
            .par_iter()
            .all(|rgb| rgb.iter().all(|c| c.is_finite() && *c >= 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_value_serves_both_orders_of_a_pair() {
        let mut table = SymTable::filled([0.1, 0.2, 0.3]);
        assert_eq!(table.pairs().len(), PAIRS);
        assert!(table.pairs().iter().all(|v| *v == [0.1, 0.2, 0.3]));
        table.set(1200, 7, [1.0, 2.0, 3.0]);
        assert_eq!(table.get(1200, 7), [1.0, 2.0, 3.0]);
        assert_eq!(table.get(7, 1200), [1.0, 2.0, 3.0]);
        assert_eq!(table.pairs()[pair_index(7, 1200).index()], [1.0, 2.0, 3.0]);
        // Nothing else moved.
        let changed = table
            .pairs()
            .iter()
            .filter(|v| **v != [0.1, 0.2, 0.3])
            .count();
        assert_eq!(changed, 1);
        assert_eq!(table.get(7, 1201), [0.1, 0.2, 0.3]);
    }

    #[test]
    fn a_table_is_built_from_exactly_one_value_per_pair() {
        assert!(SymTable::from_pairs(vec![[0.0; 3]; PAIRS - 1]).is_none());
        assert!(SymTable::from_pairs(vec![[0.0; 3]; PAIRS + 1]).is_none());
        let values: Vec<Rgb> = (0..PAIRS).map(|p| [p as f32, 0.0, 1.0]).collect();
        let table = SymTable::from_pairs(values.clone()).unwrap();
        assert_eq!(table.pairs(), &values[..]);
        // from_fn is asked once per pair, the lower direction first.
        let built = SymTable::from_fn(|lo, hi| {
            assert!(lo <= hi);
            [lo as f32, hi as f32, 0.0]
        });
        for (d_l, d_v) in [(0, 0), (3, 1619), (1619, 3), (800, 801)] {
            let (lo, hi) = (d_l.min(d_v), d_l.max(d_v));
            assert_eq!(built.get(d_l, d_v), [lo as f32, hi as f32, 0.0]);
        }
        assert_eq!(
            format!("{built:?}"),
            format!("SymTable {{ pairs: {PAIRS} }}")
        );
    }

    #[test]
    fn a_table_is_physical_only_when_every_channel_is_finite_and_non_negative() {
        assert!(SymTable::filled([0.0; 3]).is_physical());
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1e-30] {
            for channel in 0..3 {
                let mut table = SymTable::filled([0.5; 3]);
                let mut value = [0.5; 3];
                value[channel] = bad;
                table.set(100, 900, value);
                assert!(!table.is_physical(), "{bad} in channel {channel}");
            }
        }
    }
}
