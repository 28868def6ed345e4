//! A table evaluated at exact directions, for the exporters and fits that need ρ(l, v) of
//! any pair of unit vectors: each direction's bin, exactly as `burnish render` and the
//! preview's nearest-bin mode look a table up, so an export shows what Burnish shows.
//!
//! An isotropic export uses the table averaged over rotations about the normal (the 36
//! azimuth bins), as a function of the azimuth *difference* (all an isotropic reader sees):
//! for a difference of δ bins, a nearest-bin lookup of the two directions lands δ's floor or
//! its ceiling apart, the latter with probability frac(δ) over where in its bin the light's
//! azimuth lies. So the isotropic value is the average table interpolated linearly in δ:
//! the expectation of what `burnish render` shows for that pair.

use crate::table::{
    DirIndex, PHI_BINS, SymTable, THETA_BINS, direction_index, theta_centre, theta_index,
};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::TAU;

/// ρ of a table at exact directions.
pub struct ExactTable<'a> {
    table: &'a SymTable,
    /// For an isotropic evaluation: per (t_l, t_v, Δp) the mean over rotations, in f64.
    isotropic: Option<Vec<[f64; 3]>>,
}

/// Index of (t_l, t_v, Δp) in [`isotropic_average`].
#[inline]
fn slice_index(t_l: usize, t_v: usize, dp: usize) -> usize {
    (t_l * THETA_BINS + t_v) * PHI_BINS + dp
}

/// The table averaged over the 36 rotations about the normal: per (t_l, t_v, Δp) the mean
/// of ρ(36 t_l + p, 36 t_v + (p + Δp) mod 36) over p, accumulated in f64.
pub fn isotropic_average(table: &SymTable) -> Vec<[f64; 3]> {
    (0..THETA_BINS * THETA_BINS)
        .into_par_iter()
        .flat_map_iter(|tt| {
            let (t_l, t_v) = (tt / THETA_BINS, tt % THETA_BINS);
            (0..PHI_BINS).map(move |dp| {
                let mut sum = [0.0f64; 3];
                for p in 0..PHI_BINS {
                    let d_l = (PHI_BINS * t_l + p) as DirIndex;
                    let d_v = (PHI_BINS * t_v + (p + dp) % PHI_BINS) as DirIndex;
                    let rho = table.get(d_l, d_v);
                    for c in 0..3 {
                        sum[c] += rho[c] as f64;
                    }
                }
                sum.map(|s| s / PHI_BINS as f64)
            })
        })
        .collect()
}

/// How far a table is from isotropic: ‖ρ − ρ̄‖ / ‖ρ‖ over every entry, weighted by
/// cos θ_l cos θ_v (what a render of it shows), with ρ̄ the rotation average.
pub fn anisotropy(table: &SymTable, average: &[[f64; 3]]) -> f64 {
    let cos: Vec<f64> = (0..THETA_BINS).map(|t| theta_centre(t).cos()).collect();
    let (diff, total) = (0..THETA_BINS * PHI_BINS)
        .into_par_iter()
        .map(|d_l| {
            let (t_l, p_l) = (d_l / PHI_BINS, d_l % PHI_BINS);
            let mut acc = (0.0f64, 0.0f64);
            for d_v in 0..THETA_BINS * PHI_BINS {
                let (t_v, p_v) = (d_v / PHI_BINS, d_v % PHI_BINS);
                let w = cos[t_l] * cos[t_v];
                let rho = table.get(d_l as DirIndex, d_v as DirIndex);
                let mean = average[slice_index(t_l, t_v, (p_v + PHI_BINS - p_l) % PHI_BINS)];
                for c in 0..3 {
                    acc.0 += (w * (rho[c] as f64 - mean[c])).powi(2);
                    acc.1 += (w * rho[c] as f64).powi(2);
                }
            }
            acc
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if total > 0.0 {
        (diff / total).sqrt()
    } else {
        0.0
    }
}

impl<'a> ExactTable<'a> {
    /// The table as it is, each direction in its own bin.
    pub fn anisotropic(table: &'a SymTable) -> Self {
        Self {
            table,
            isotropic: None,
        }
    }

    /// The rotation average, looked up by azimuth difference.
    pub fn isotropic(table: &'a SymTable, average: Vec<[f64; 3]>) -> Self {
        Self {
            table,
            isotropic: Some(average),
        }
    }

    pub fn is_isotropic(&self) -> bool {
        self.isotropic.is_some()
    }

    /// ρ(l, v) for unit `l`, `v`; zero when either is at or below the horizon.
    pub fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if l.z <= 0.0 || v.z <= 0.0 {
            return [0.0; 3];
        }
        match &self.isotropic {
            None => match (direction_index(l), direction_index(v)) {
                (Some(d_l), Some(d_v)) => self.table.get(d_l, d_v).map(f64::from),
                _ => [0.0; 3],
            },
            Some(average) => {
                let theta = |w: DVec3| w.z.min(1.0).acos();
                let (t_l, t_v) = (theta_index(theta(l)), theta_index(theta(v)));
                let dphi = v.y.atan2(v.x) - l.y.atan2(l.x);
                let steps = dphi / (TAU / PHI_BINS as f64);
                let below = steps.floor();
                let frac = steps - below;
                let dp = (below as i64).rem_euclid(PHI_BINS as i64) as usize;
                let (a, b) = (
                    average[slice_index(t_l, t_v, dp)],
                    average[slice_index(t_l, t_v, (dp + 1) % PHI_BINS)],
                );
                std::array::from_fn(|c| a[c] + (b[c] - a[c]) * frac)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::{models::Lambert, tabulate};
    use crate::table::bin_centre;

    #[test]
    fn bins_are_looked_up_as_render_does() {
        let table = SymTable::from_fn(|lo, hi| [lo as f32, hi as f32, 1.0]);
        let exact = ExactTable::anisotropic(&table);
        let (a, b) = (bin_centre(100), bin_centre(1500));
        assert_eq!(exact.eval(a, b), [100.0, 1500.0, 1.0]);
        assert_eq!(exact.eval(DVec3::new(1.0, 0.0, -0.1), b), [0.0; 3]);
    }

    #[test]
    fn an_isotropic_table_is_isotropic() {
        let table = tabulate(&Lambert {
            albedo: [0.5, 0.25, 0.125],
        });
        let average = isotropic_average(&table);
        assert!(anisotropy(&table, &average) < 1e-6);
        let exact = ExactTable::isotropic(&table, average);
        let v = exact.eval(DVec3::Z, DVec3::new(0.3, 0.4, 0.8).normalize());
        assert!((v[0] - 0.5 / std::f64::consts::PI).abs() < 1e-6);
        let skewed = SymTable::from_fn(|lo, hi| {
            let p = (lo as usize % PHI_BINS) + (hi as usize % PHI_BINS);
            [1.0 + (p % 7) as f32; 3]
        });
        let average = isotropic_average(&skewed);
        assert!(anisotropy(&skewed, &average) > 0.05);
    }
}
