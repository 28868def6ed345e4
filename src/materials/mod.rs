//! Analytic and bi-scale BRDFs, and the reproducible database the basis is learnt from.

pub mod biscale;
pub mod classic;
pub mod database;
pub mod layered;
pub mod models;
pub mod principled;

use crate::table::{
    DIRECTIONS, DirIndex, PHI_BINS, SymTable, THETA_BINS, bin_centre, phi_centre, split_direction,
    theta_centre,
};
use glam::DVec3;
use rayon::prelude::*;

/// The trait lives in [`crate::brdf`] so that the table's MERL file can implement it without
/// depending on the materials.
pub use crate::brdf::Brdf;

fn to_rgb32(rgb: [f64; 3]) -> [f32; 3] {
    rgb.map(|c| {
        if c.is_finite() && c > 0.0 {
            c as f32
        } else {
            0.0
        }
    })
}

/// Values of an isotropic BRDF at every (t_l, t_v, Δp) bin-centre combination.
fn isotropic_slices(brdf: &dyn Brdf) -> Vec<[f32; 3]> {
    // Bin-centre directions at azimuth index p (light at p = 0), computed once.
    let directions: Vec<DVec3> = (0..THETA_BINS * PHI_BINS)
        .map(|i| {
            let (st, ct) = theta_centre(i / PHI_BINS).sin_cos();
            let (sp, cp) = phi_centre(i % PHI_BINS).sin_cos();
            DVec3::new(st * cp, st * sp, ct)
        })
        .collect();
    (0..THETA_BINS * THETA_BINS)
        .into_par_iter()
        .flat_map_iter(|tt| {
            let (t_l, t_v) = (tt / THETA_BINS, tt % THETA_BINS);
            let l = directions[t_l * PHI_BINS];
            let views = &directions[t_v * PHI_BINS..(t_v + 1) * PHI_BINS];
            views.iter().map(move |&v| to_rgb32(brdf.eval(l, v)))
        })
        .collect()
}

/// Evaluates a BRDF at the bin centres of every unordered direction pair.
pub fn tabulate(brdf: &dyn Brdf) -> SymTable {
    SymTable::from_pairs(tabulate_mapped(brdf, |_, _, rho| rho)).expect("PAIRS values")
}

/// `map(t_l, t_v, ρ)` of every unordered pair, in pair order, where ρ is the BRDF at the
/// pair's bin centres and t_l, t_v are the polar bins of its two directions. An isotropic
/// BRDF has only 45·45·36 distinct values, so `map` runs that many times rather than
/// 1,313,010 (the basis build maps every material of its database on every pass).
pub fn tabulate_mapped(
    brdf: &dyn Brdf,
    map: impl Fn(usize, usize, [f32; 3]) -> [f32; 3] + Sync,
) -> Vec<[f32; 3]> {
    let mut values = vec![[0f32; 3]; crate::table::PAIRS];
    if brdf.is_isotropic() {
        let slices = isotropic_slices(brdf);
        let mapped: Vec<[f32; 3]> = slices
            .par_iter()
            .enumerate()
            .with_min_len(1024)
            .map(|(i, &rho)| {
                let tt = i / PHI_BINS;
                map(tt / THETA_BINS, tt % THETA_BINS, rho)
            })
            .collect();
        fill_pairs(&mut values, |lo, hi| {
            let (t_l, p_l) = split_direction(lo);
            let (t_v, p_v) = split_direction(hi);
            let dp = (p_v + PHI_BINS - p_l) % PHI_BINS;
            mapped[(t_l * THETA_BINS + t_v) * PHI_BINS + dp]
        });
    } else {
        let centres: Vec<DVec3> = (0..DIRECTIONS as DirIndex).map(bin_centre).collect();
        fill_pairs(&mut values, |lo, hi| {
            let rho = to_rgb32(brdf.eval(centres[lo as usize], centres[hi as usize]));
            map(lo as usize / PHI_BINS, hi as usize / PHI_BINS, rho)
        });
    }
    values
}

/// Sets every pair's value from `f(lo, hi)`, in parallel over the runs of pairs that share
/// `hi` (pairs (0..=hi, hi) are stored together), so no pair index is ever decoded.
fn fill_pairs(values: &mut [[f32; 3]], f: impl Fn(DirIndex, DirIndex) -> [f32; 3] + Sync) {
    let mut runs: Vec<(usize, &mut [[f32; 3]])> = Vec::with_capacity(DIRECTIONS);
    let mut rest = values;
    for hi in 0..DIRECTIONS {
        let (run, tail) = rest.split_at_mut(hi + 1);
        runs.push((hi, run));
        rest = tail;
    }
    runs.into_par_iter().with_min_len(16).for_each(|(hi, run)| {
        for (lo, out) in run.iter_mut().enumerate() {
            *out = f(lo as DirIndex, hi as DirIndex);
        }
    });
}

/// Directional albedo ∫ ρ(l, v) cos θ_v dω_v for light direction `l`, by a midpoint rule
/// over `n_theta × 4·n_theta` cells of the hemisphere. Accumulated in f64.
pub fn directional_albedo(brdf: &dyn Brdf, l: DVec3, n_theta: usize) -> [f64; 3] {
    let n_phi = 4 * n_theta;
    let d_theta = std::f64::consts::FRAC_PI_2 / n_theta as f64;
    let d_phi = std::f64::consts::TAU / n_phi as f64;
    let mut sum = [0.0f64; 3];
    for i in 0..n_theta {
        let theta = (i as f64 + 0.5) * d_theta;
        let (st, ct) = theta.sin_cos();
        let weight = ct * st * d_theta * d_phi;
        for j in 0..n_phi {
            let (sp, cp) = ((j as f64 + 0.5) * d_phi).sin_cos();
            let rho = brdf.eval(l, DVec3::new(st * cp, st * sp, ct));
            for c in 0..3 {
                sum[c] += rho[c] * weight;
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deliberately anisotropic, reciprocal test BRDF.
    #[derive(Debug)]
    struct Stripes;
    impl Brdf for Stripes {
        fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
            let h = (l + v).normalize();
            [h.x * h.x + 0.1, l.z * v.z, (l.x + v.x).abs()]
        }
        fn is_isotropic(&self) -> bool {
            false
        }
    }

    #[derive(Debug)]
    struct IsoLobe;
    impl Brdf for IsoLobe {
        fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
            let r = DVec3::new(-l.x, -l.y, l.z);
            let s = r.dot(v).max(0.0).powi(8);
            [0.2 + s, 0.1 + 2.0 * s, 0.05]
        }
        fn is_isotropic(&self) -> bool {
            true
        }
    }

    #[test]
    fn isotropic_shortcut_matches_direct_evaluation() {
        let table = tabulate(&IsoLobe);
        for &(a, b) in &[
            (0u16, 0u16),
            (5, 700),
            (1619, 3),
            (800, 801),
            (36 * 20 + 7, 36 * 30 + 29),
        ] {
            let direct = to_rgb32(IsoLobe.eval(bin_centre(a), bin_centre(b)));
            let got = table.get(a, b);
            for c in 0..3 {
                assert!(
                    (got[c] - direct[c]).abs() <= 1e-5 * direct[c].abs().max(1.0),
                    "{a} {b}"
                );
            }
        }
    }

    #[test]
    fn anisotropic_tabulation_is_at_bin_centres() {
        let table = tabulate(&Stripes);
        let v = to_rgb32(Stripes.eval(bin_centre(10), bin_centre(1000)));
        assert_eq!(table.get(10, 1000), v);
        assert_eq!(table.get(1000, 10), v);
    }

    #[test]
    fn lambert_albedo_is_one() {
        #[derive(Debug)]
        struct White;
        impl Brdf for White {
            fn eval(&self, _: DVec3, _: DVec3) -> [f64; 3] {
                [std::f64::consts::FRAC_1_PI; 3]
            }
            fn is_isotropic(&self) -> bool {
                true
            }
        }
        let a = directional_albedo(&White, DVec3::Z, 64);
        assert!((a[0] - 1.0).abs() < 1e-3, "{a:?}");
    }
}
