//! The posterior of the coefficients after a solve ([`super::Solver::posterior`]): its
//! precision and covariance, the variance it leaves at any pair, and the table of ρ's standard
//! deviation that the uncertainty overlay and `--uncertainty` show.

use super::prior::PriorModel;
use crate::table::PairIndex;
use faer::Mat;

/// The posterior of the coefficients after a solve.
#[derive(Clone, Debug)]
pub struct Posterior {
    pub(super) model: PriorModel,
    pub(super) components: usize,
    pub(super) alpha: f64,
    /// (N + αP₀)/α: the posterior precision.
    pub(super) precision: Mat<f64>,
    pub(super) covariance: Mat<f64>,
}

impl Posterior {
    /// The α the posterior was computed with.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// The posterior precision of the coefficients (D × D).
    pub fn precision(&self) -> &Mat<f64> {
        &self.precision
    }

    /// The posterior covariance of the coefficients (D × D).
    pub fn covariance(&self) -> &Mat<f64> {
        &self.covariance
    }

    /// ψ_p: where pair `pair`'s basis row `row` enters the coefficients (D entries).
    pub fn design_row(&self, pair: PairIndex, row: &[f32]) -> Vec<f64> {
        let k = self.components;
        let mut psi = vec![0.0; self.model.rows(k)];
        for (j, phi) in self.model.band_weights(pair).pairs() {
            if phi != 0.0 {
                for i in 0..k {
                    psi[j * k + i] = phi * row[i] as f64;
                }
            }
        }
        psi
    }

    /// Variance of the mapped value of pair `pair` given the painted bins (the coefficients'
    /// share; the basis's residual there adds to it).
    pub fn mapped_variance(&self, pair: PairIndex, row: &[f32]) -> f64 {
        let k = self.components;
        let blocks = self.model.band_weights(pair).pairs();
        let mut sum = 0.0;
        for &(ja, pa) in &blocks {
            if pa == 0.0 {
                continue;
            }
            for &(jb, pb) in &blocks {
                if pb == 0.0 {
                    continue;
                }
                for i in 0..k {
                    let ui = pa * row[i] as f64;
                    let mut s = 0.0;
                    for l in 0..k {
                        s += self.covariance[(ja * k + i, jb * k + l)] * row[l] as f64;
                    }
                    sum += ui * pb * s;
                }
            }
        }
        sum.max(0.0)
    }
}

impl Posterior {
    /// Per-pair standard deviation of ρ given the painted bins: the coefficients' posterior
    /// variance at the pair plus what the basis cannot follow there (its residual over the
    /// database), carried from the mapped domain to ρ through the map's slope
    /// (ρc + ε)/c at the reconstruction's value. Where the table is guessed rather than
    /// painted this is large; on painted bins it is small.
    pub fn table_std_dev(&self, reconstruction: &super::Reconstruction) -> crate::table::SymTable {
        use rayon::prelude::*;
        let basis = reconstruction.basis();
        let k = self.components;
        // The covariance's K × K blocks between neighbouring sets, as f64 rows.
        let block = |a: usize, b: usize| -> Vec<f64> {
            (0..k * k)
                .map(|i| self.covariance[(a * k + i / k, b * k + i % k)])
                .collect()
        };
        let sets = self.model.bands;
        let diagonal: Vec<Vec<f64>> = (0..sets).map(|a| block(a, a)).collect();
        let next: Vec<Vec<f64>> = (0..sets.saturating_sub(1))
            .map(|a| block(a, a + 1))
            .collect();
        let quadratic = |m: &[f64], u: &[f32]| -> f64 {
            let mut sum = 0.0;
            for i in 0..k {
                let row = &m[i * k..(i + 1) * k];
                let t: f64 = row.iter().zip(u).map(|(c, &x)| c * x as f64).sum();
                sum += u[i] as f64 * t;
            }
            sum
        };
        let residuals = basis.residuals();
        let values: Vec<crate::table::Rgb> = (0..crate::table::PAIRS)
            .into_par_iter()
            .with_min_len(4096)
            .map(|index| {
                let pair = PairIndex::from_index(index);
                let u = basis.row(pair);
                let w = self.model.band_weights(pair);
                let (a, f) = (w.lower as usize, w.frac as f64);
                let mut var = (1.0 - f) * (1.0 - f) * quadratic(&diagonal[a], u);
                if f != 0.0 {
                    var += 2.0 * f * (1.0 - f) * quadratic(&next[a], u)
                        + f * f * quadratic(&diagonal[a + 1], u);
                }
                let sd = (var.max(0.0) + residuals[index] as f64).sqrt();
                let c = crate::basis::cos_weight(pair);
                reconstruction.eval_pair(pair).map(|rho| {
                    let slope = (rho as f64 * c + crate::basis::MAP_EPSILON) / c;
                    let v = (slope * sd) as f32;
                    if v.is_finite() { v } else { f32::MAX }
                })
            })
            .collect();
        crate::table::SymTable::from_pairs(values).expect("PAIRS values")
    }
}

#[cfg(test)]
mod tests {
    use crate::basis::build::small_test_basis;
    use crate::basis::{MAP_EPSILON, cos_weight};
    use crate::solver::{BinChange, EXACT, Regularization, Solver};
    use crate::table::{PAIRS, PairIndex};

    /// The posterior's shortcuts against its definition, on a solve of a few hundred bins
    /// spread over θ_d: a design row splits the basis row between the sets its θ_d blends,
    /// the mapped variance is ψᵀΣψ, covariance and precision are inverses, and the table of
    /// standard deviations (which reads only neighbouring blocks of Σ) is the map's slope
    /// times √(ψᵀΣψ + the basis's residual) at every pair.
    #[test]
    fn the_posterior_tables_follow_from_its_covariance() {
        let basis = small_test_basis();
        let k = basis.components();
        let mut solver = Solver::new(basis.clone(), Regularization::Auto);
        let painted: Vec<PairIndex> = (0..400)
            .map(|i| PairIndex::from_index(i * 1_299_709 % PAIRS))
            .collect();
        for (i, &pair) in painted.iter().enumerate() {
            let wobble = 1.0 + 0.2 * ((i % 7) as f64 - 3.0) / 3.0;
            solver.apply(&BinChange::observed(
                pair,
                [0.15 * wobble, 0.25, 0.4 / wobble],
                EXACT,
            ));
        }
        let solution = solver.solve();
        let reconstruction = solution.reconstruction(basis.clone());
        let posterior = solver.posterior();
        assert_eq!(posterior.alpha(), solution.alpha);

        let (sigma, precision) = (posterior.covariance(), posterior.precision());
        let d = sigma.nrows();
        assert_eq!(d, solver.model().rows(k));
        assert!(d > k, "the calibrated prior has several sets");
        let identity = precision * sigma;
        for i in 0..d {
            for j in 0..d {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((identity[(i, j)] - expected).abs() < 1e-8, "({i}, {j})");
            }
        }

        let sd = posterior.table_std_dev(&reconstruction);
        let residuals = basis.residuals();
        let (mut blended, mut variance_sum) = (0, 0.0);
        for index in (0..PAIRS)
            .step_by(997)
            .chain(painted.iter().map(|p| p.index()))
        {
            let pair = PairIndex::from_index(index);
            let row = basis.row(pair);
            let psi = posterior.design_row(pair, row);
            assert_eq!(psi.len(), d);
            let sets: Vec<usize> = (0..d / k)
                .filter(|&j| psi[j * k..(j + 1) * k].iter().any(|&v| v != 0.0))
                .collect();
            assert!(
                !sets.is_empty() && sets.len() <= 2,
                "{index}: sets {sets:?}"
            );
            if sets.len() == 2 {
                assert_eq!(sets[1], sets[0] + 1, "{index}: neighbouring sets");
                blended += 1;
            }
            for i in 0..k {
                let split: f64 = (0..d / k).map(|j| psi[j * k + i]).sum();
                assert!((split - row[i] as f64).abs() < 1e-6, "{index}, {i}");
            }

            let direct: f64 = (0..d)
                .map(|a| psi[a] * (0..d).map(|b| sigma[(a, b)] * psi[b]).sum::<f64>())
                .sum();
            let variance = posterior.mapped_variance(pair, row);
            assert!(
                (variance - direct).abs() <= 1e-9 * direct.abs().max(1e-12),
                "{index}: {variance} against ψᵀΣψ {direct}"
            );
            variance_sum += variance;

            let sd_mapped = (variance + residuals[index] as f64).sqrt();
            let c = cos_weight(pair);
            let rho = reconstruction.eval_pair(pair);
            for ch in 0..3 {
                let slope = (rho[ch] as f64 * c + MAP_EPSILON) / c;
                let expected = slope * sd_mapped;
                let got = sd.pairs()[index][ch] as f64;
                assert!(
                    (got - expected).abs() <= 1e-4 * expected,
                    "{index} {ch}: {got} against {expected}"
                );
            }
        }
        assert!(blended > 100, "{blended} pairs blend two sets");
        assert!(variance_sum > 0.0);
    }
}
