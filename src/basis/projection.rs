//! The projection of a full table onto the basis: least squares over all pairs in the
//! log-mapped domain (cos weight inside the map, pair multiplicity as the weight, values
//! clamped to the database's range), which is what the solver minimises over the painted
//! bins. Of the truth, it is the bench's oracle: the best any sparse method could do with
//! this basis. Of a starting material or an analytic fit, it is the solver's prior mean.

use crate::basis::Basis;
use crate::table::{PAIRS, PairIndex, SymTable, pair_multiplicity};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;
use std::sync::Arc;

/// Pairs per deterministic partial sum.
const BLOCK: usize = 4096;

/// Projects tables onto one basis; the Gram matrix is computed once.
#[derive(Debug)]
pub struct OracleProjector {
    basis: Arc<Basis>,
    /// Cholesky-factorable Gram matrix Σ_p w_p u_p u_pᵀ (≈ I by construction, kept exact
    /// against the rows' f32 rounding).
    gram: Mat<f64>,
}

impl OracleProjector {
    pub fn new(basis: Arc<Basis>) -> Self {
        let k = basis.components();
        let partials: Vec<Vec<f64>> = (0..PAIRS.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut g = vec![0f64; k * k];
                let mut row = vec![0f64; k];
                for pair in (b * BLOCK..((b + 1) * BLOCK).min(PAIRS)).map(PairIndex::from_index) {
                    let w = pair_multiplicity(pair);
                    for (r, &u) in row.iter_mut().zip(basis.row(pair)) {
                        *r = u as f64;
                    }
                    for i in 0..k {
                        let wu = w * row[i];
                        for j in i..k {
                            g[i * k + j] += wu * row[j];
                        }
                    }
                }
                g
            })
            .collect();
        let mut gram = Mat::<f64>::zeros(k, k);
        for g in &partials {
            for i in 0..k {
                for j in i..k {
                    gram[(i, j)] += g[i * k + j];
                }
            }
        }
        for i in 0..k {
            for j in 0..i {
                gram[(i, j)] = gram[(j, i)];
            }
        }
        Self { basis, gram }
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    /// The least-squares coefficients of `truth` (K rows of R, G, B).
    pub fn project(&self, truth: &SymTable) -> Vec<[f64; 3]> {
        let basis = &self.basis;
        let k = basis.components();
        let values = truth.pairs();
        let partials: Vec<Vec<[f64; 3]>> = (0..PAIRS.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut rhs = vec![[0f64; 3]; k];
                for index in b * BLOCK..((b + 1) * BLOCK).min(PAIRS) {
                    let pair = PairIndex::from_index(index);
                    let w = pair_multiplicity(pair);
                    let y = values[index].map(|v| w * basis.centred_observation(pair, v as f64));
                    for (r, &u) in rhs.iter_mut().zip(basis.row(pair)) {
                        for c in 0..3 {
                            r[c] += u as f64 * y[c];
                        }
                    }
                }
                rhs
            })
            .collect();
        let mut x = Mat::<f64>::zeros(k, 3);
        for part in &partials {
            for i in 0..k {
                for c in 0..3 {
                    x[(i, c)] += part[i][c];
                }
            }
        }
        // The rows are orthonormal by construction: should G fail to factor, Gx = b is
        // x = b to within their rounding.
        if let Ok(llt) = self.gram.llt(Side::Lower) {
            llt.solve_in_place(x.as_mut());
        }
        (0..k)
            .map(|i| {
                std::array::from_fn(|c| {
                    if x[(i, c)].is_finite() {
                        x[(i, c)]
                    } else {
                        0.0
                    }
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::small_test_basis;
    use crate::solver::Reconstruction;

    /// A table the basis holds projects back onto the coefficients that made it (to within
    /// the table's f32 rounding), and the mean material onto zeros.
    #[test]
    fn a_table_in_the_basis_projects_back_onto_its_coefficients() {
        let basis = small_test_basis();
        let projector = OracleProjector::new(basis.clone());
        let scale: Vec<f64> = basis.variances().iter().map(|v| 0.2 * v.sqrt()).collect();
        let x: Vec<[f64; 3]> = scale
            .iter()
            .enumerate()
            .map(|(i, &s)| [s, -0.5 * s, if i % 2 == 0 { 0.8 * s } else { -s }])
            .collect();
        let table = Reconstruction::new(basis.clone(), &x).materialize();
        let back = projector.project(&table);
        assert_eq!(back.len(), x.len());
        for (i, (b, t)) in back.iter().zip(&x).enumerate() {
            for c in 0..3 {
                assert!(
                    (b[c] - t[c]).abs() <= 1e-3 * scale[i],
                    "{i} {c}: {b:?} {t:?}"
                );
            }
        }
        let mean = Reconstruction::mean_material(basis.clone()).materialize();
        for b in projector.project(&mean) {
            assert!(b.iter().all(|v| v.abs() <= 1e-3 * scale[0]), "{b:?}");
        }
    }
}
