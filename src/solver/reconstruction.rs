//! The reconstructed BRDF: evaluated lazily, entry by entry, for what a view needs, or
//! materialised in parallel as a full table for export.

use crate::basis::{Basis, MAP_EPSILON, cos_weight_polar};
use crate::table::{DIRECTIONS, DirIndex, PHI_BINS, Rgb, SymTable, pair_index};
use rayon::prelude::*;
use std::sync::Arc;

/// A basis and one set of coefficients: ρ = unmap(mean + Σ_k u_k x_k), clamped to the range the
/// database spans so that one stray sample can't blow a highlight up.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    basis: Arc<Basis>,
    /// Coefficients by channel, K each, in f32 for the evaluation loops.
    coefficients: [Vec<f32>; 3],
}

impl Reconstruction {
    /// The reconstruction for coefficients `x` (K rows of R, G, B).
    pub fn new(basis: Arc<Basis>, x: &[[f64; 3]]) -> Self {
        assert_eq!(
            x.len(),
            basis.components(),
            "one coefficient row per component"
        );
        let coefficients = std::array::from_fn(|c| x.iter().map(|row| row[c] as f32).collect());
        Self {
            basis,
            coefficients,
        }
    }

    /// The database's mean material (all coefficients zero): what an empty painting gives.
    pub fn mean_material(basis: Arc<Basis>) -> Self {
        let k = basis.components();
        Self::new(basis, &vec![[0.0; 3]; k])
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    /// ρ of the unordered pair `pair`.
    #[inline]
    pub fn eval_pair(&self, pair: usize) -> Rgb {
        let (lo, hi) = crate::table::pair_directions(pair);
        self.eval_with_weight(
            pair,
            cos_weight_polar(lo as usize / PHI_BINS, hi as usize / PHI_BINS),
        )
    }

    /// ρ(d_l, d_v).
    #[inline]
    pub fn eval(&self, d_l: DirIndex, d_v: DirIndex) -> Rgb {
        let c = cos_weight_polar(d_l as usize / PHI_BINS, d_v as usize / PHI_BINS);
        self.eval_with_weight(pair_index(d_l, d_v), c)
    }

    /// Evaluates only the pairs a view asks for.
    pub fn eval_pairs(&self, pairs: &[u32], out: &mut Vec<Rgb>) {
        out.clear();
        out.extend(pairs.iter().map(|&p| self.eval_pair(p as usize)));
    }

    #[inline]
    fn eval_with_weight(&self, pair: usize, c: f64) -> Rgb {
        let row = self.basis.row(pair);
        let mean = self.basis.means()[pair];
        let reference = self.basis.references()[pair] + MAP_EPSILON as f32;
        let (lo, hi) = self.basis.mapped_range(pair);
        let (lo, hi) = (lo as f32, hi as f32);
        let inv_c = (1.0 / c) as f32;
        let [xr, xg, xb] = &self.coefficients;
        let (mut r, mut g, mut b) = (0f32, 0f32, 0f32);
        for (i, &u) in row.iter().enumerate() {
            r += u * xr[i];
            g += u * xg[i];
            b += u * xb[i];
        }
        let unmap = |d: f32| {
            let m = (mean + d).clamp(lo, hi);
            let rho = (m.exp() * reference - MAP_EPSILON as f32) * inv_c;
            // Clamping m keeps rho finite; max(0) also maps a NaN from bad coefficients to 0.
            rho.max(0.0)
        };
        [unmap(r), unmap(g), unmap(b)]
    }

    /// The full table, in parallel. Each pair is evaluated once: reciprocal by construction.
    pub fn materialize(&self) -> SymTable {
        let mut values = vec![[0f32; 3]; crate::table::PAIRS];
        // Split the storage into the runs of one `hi` each (pairs (0..=hi, hi)).
        let mut runs: Vec<(usize, &mut [Rgb])> = Vec::with_capacity(DIRECTIONS);
        let mut rest: &mut [Rgb] = &mut values;
        for hi in 0..DIRECTIONS {
            let (run, tail) = rest.split_at_mut(hi + 1);
            runs.push((hi, run));
            rest = tail;
        }
        runs.into_par_iter().with_min_len(8).for_each(|(hi, run)| {
            let base = hi * (hi + 1) / 2;
            let t_hi = hi / PHI_BINS;
            for (lo, out) in run.iter_mut().enumerate() {
                *out = self.eval_with_weight(base + lo, cos_weight_polar(lo / PHI_BINS, t_hi));
            }
        });
        SymTable::from_pairs(values).expect("PAIRS values")
    }
}
