//! Error metrics between two tables, as `burnish eval` reports them.

use crate::basis::{MAP_EPSILON, cos_weight_polar};
use crate::table::{PHI_BINS, SymTable, for_each_pair, theta_centre};

/// Errors of an estimate against the truth over the whole table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableErrors {
    /// ‖(ρ̂ − ρ) cos θ_l cos θ_v‖ / ‖ρ cos θ_l cos θ_v‖ over every entry and channel.
    pub relative_rmse: f64,
    /// RMSE in the log-mapped domain: ln((ρ̂c + ε)/(ρc + ε)), c clamped as in the basis.
    pub log_rmse: f64,
}

/// Compares two tables entry by entry; off-diagonal pairs count twice, as in the full table.
pub fn table_errors(truth: &SymTable, estimate: &SymTable) -> TableErrors {
    let cos: Vec<f64> = (0..crate::table::THETA_BINS)
        .map(|t| theta_centre(t).cos())
        .collect();
    let (mut err2, mut ref2, mut log2, mut count) = (0f64, 0f64, 0f64, 0f64);
    let (t_vals, e_vals) = (truth.pairs(), estimate.pairs());
    for_each_pair(|pair, lo, hi| {
        let w = if lo == hi { 1.0 } else { 2.0 };
        let (t_l, t_v) = (lo as usize / PHI_BINS, hi as usize / PHI_BINS);
        let cc = cos[t_l] * cos[t_v];
        let c = cos_weight_polar(t_l, t_v);
        for ch in 0..3 {
            let (t, e) = (t_vals[pair][ch] as f64, e_vals[pair][ch] as f64);
            err2 += w * ((e - t) * cc).powi(2);
            ref2 += w * (t * cc).powi(2);
            log2 += w * (((e * c + MAP_EPSILON) / (t * c + MAP_EPSILON)).ln()).powi(2);
            count += w;
        }
    });
    TableErrors {
        relative_rmse: if ref2 > 0.0 {
            (err2 / ref2).sqrt()
        } else {
            err2.sqrt()
        },
        log_rmse: (log2 / count).sqrt(),
    }
}
