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
