//! Building the basis: generate the database, map it, and take its leading principal
//! components by randomized subspace iteration (Halko, Martinsson & Tropp 2011).
//!
//! Memory: the mapped database is held once, as f16 in pair-major order (PAIRS × observations,
//! 2 bytes each: 2.4 GB for the default 300 materials), never as f32 or f64. Products with it run
//! over fixed blocks of rows, converted to f64 one block per thread at a time, so the sums that
//! accumulate are f64 and the result does not depend on the number of threads.

use super::{Basis, MAP_EPSILON, cos_weight_polar};
use crate::materials::database::{DatabaseSpec, material};
use crate::materials::tabulate;
use crate::table::{PAIRS, PHI_BINS, SymTable};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par, Side};
use half::f16;
use rand::SeedableRng;
use rayon::prelude::*;

/// Everything that shapes a basis; the cache is keyed by all of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BasisSpec {
    pub database: DatabaseSpec,
    /// K: components kept (1..=100).
    pub components: usize,
    /// Extra random directions beyond K in the subspace iteration.
    pub oversampling: usize,
    /// Power iterations; each costs one pass over the database.
    pub power_iterations: usize,
}

impl BasisSpec {
    /// Largest K supported.
    pub const MAX_COMPONENTS: usize = 100;
    /// Default K, as in the paper.
    pub const DEFAULT_COMPONENTS: usize = 20;

    /// What users get: the default database and K = 20.
    pub fn default_for(components: usize) -> Self {
        Self {
            database: DatabaseSpec::default(),
            components,
            oversampling: 10,
            power_iterations: 3,
        }
    }

    /// A small database for tests and quick runs.
    pub fn small(components: usize) -> Self {
        Self {
            database: DatabaseSpec { seed: 7, size: 48 },
            components,
            oversampling: 10,
            power_iterations: 3,
        }
    }

    /// A stable text form of every input, stored in cache files and hashed for their names.
    pub fn key(&self) -> String {
        format!(
            "generator={};seed={};size={};components={};oversampling={};power={}",
            crate::materials::database::GENERATOR_VERSION,
            self.database.seed,
            self.database.size,
            self.components,
            self.oversampling,
            self.power_iterations
        )
    }
}

/// Progress of a build, reported through a callback.
#[derive(Clone, Copy, Debug)]
pub struct BuildProgress {
    pub stage: &'static str,
    pub done: usize,
    pub total: usize,
}

/// Rows of the database converted to f64 together; also the unit of deterministic reduction.
const BLOCK_ROWS: usize = 2048;
/// Materials tabulated together before being scattered into the pair-major matrix.
const MATERIAL_BATCH: usize = 8;

/// The mapped, pair-major database.
struct MappedDatabase {
    observations: usize,
    /// PAIRS × observations, mapped and not centred.
    values: Vec<f16>,
    mean: Vec<f64>,
    /// Σ over pairs of w·Σ_j (m_j − mean)²: the total sum of squares of the full table.
    total_sum_of_squares: f64,
    reference: Vec<f32>,
    lower: Vec<f32>,
    upper: Vec<f32>,
}

fn pair_polar_bins() -> Vec<(u8, u8)> {
    let mut out = Vec::with_capacity(PAIRS);
    crate::table::for_each_pair(|_, lo, hi| {
        out.push((
            (lo as usize / PHI_BINS) as u8,
            (hi as usize / PHI_BINS) as u8,
        ));
    });
    out
}

fn generate(spec: &DatabaseSpec, progress: &(dyn Fn(BuildProgress) + Sync)) -> MappedDatabase {
    let n = 3 * spec.size;
    let polar = pair_polar_bins();
    let mut values = vec![f16::ZERO; PAIRS * n];
    let report = |done| {
        progress(BuildProgress {
            stage: "tabulating materials",
            done,
            total: spec.size,
        })
    };
    report(0);
    for batch_start in (0..spec.size).step_by(MATERIAL_BATCH) {
        let batch_end = (batch_start + MATERIAL_BATCH).min(spec.size);
        let tables: Vec<SymTable> = (batch_start..batch_end)
            .into_par_iter()
            .map(|i| tabulate(&*material(spec.seed, i).brdf))
            .collect();
        values
            .par_chunks_mut(n * BLOCK_ROWS)
            .enumerate()
            .for_each(|(block, chunk)| {
                for (r, row) in chunk.chunks_mut(n).enumerate() {
                    let pair = block * BLOCK_ROWS + r;
                    let (t_l, t_v) = polar[pair];
                    let c = cos_weight_polar(t_l as usize, t_v as usize) as f32;
                    for (j, table) in tables.iter().enumerate() {
                        let rgb = table.pairs()[pair];
                        for ch in 0..3 {
                            // f16 saturates to infinity past 65,504; no database value is that bright.
                            row[3 * (batch_start + j) + ch] =
                                f16::from_f32((rgb[ch] * c).min(65_000.0));
                        }
                    }
                }
            });
        report(batch_end);
    }

    // Reference = per-pair median of ρc; then map in place and record mean and range.
    // ρc ≥ 0 is held as f16, whose bit patterns sort like their values when non-negative, and
    // whose 65,536 values make ln(ρc + ε) a table look-up instead of a billion logarithms.
    progress(BuildProgress {
        stage: "mapping",
        done: 0,
        total: 1,
    });
    let log_table: Vec<f64> = (0..=u16::MAX)
        .map(|bits| (f16::from_bits(bits).to_f64().max(0.0) + MAP_EPSILON).ln())
        .collect();
    let mut reference = vec![0f32; PAIRS];
    let mut lower = vec![0f32; PAIRS];
    let mut upper = vec![0f32; PAIRS];
    let mut mean = vec![0f64; PAIRS];
    values
        .par_chunks_mut(n)
        .zip(reference.par_iter_mut())
        .zip(lower.par_iter_mut())
        .zip(upper.par_iter_mut())
        .zip(mean.par_iter_mut())
        .with_min_len(256)
        .for_each_init(
            || vec![0u16; n],
            |scratch, ((((row, reference), lower), upper), mean)| {
                for (s, v) in scratch.iter_mut().zip(row.iter()) {
                    *s = v.to_bits();
                }
                let median = median_of_nonnegative_f16(scratch);
                *reference = median;
                let log_reference = (median as f64 + MAP_EPSILON).ln();
                let (mut lo, mut hi, mut sum) = (f32::INFINITY, f32::NEG_INFINITY, 0f64);
                for v in row.iter_mut() {
                    let stored = f16::from_f64(log_table[v.to_bits() as usize] - log_reference);
                    *v = stored;
                    let m = stored.to_f32();
                    lo = lo.min(m);
                    hi = hi.max(m);
                    sum += m as f64;
                }
                *lower = lo;
                *upper = hi;
                *mean = sum / n as f64;
            },
        );
    // Summed per block, then in block order, so the figure doesn't depend on threads.
    let total_sum_of_squares = values
        .par_chunks(n * BLOCK_ROWS)
        .enumerate()
        .map(|(b, block)| {
            let mut sum = 0f64;
            for (r, row) in block.chunks(n).enumerate() {
                let pair = b * BLOCK_ROWS + r;
                let m = mean[pair];
                let squares: f64 = row.iter().map(|v| (v.to_f64() - m).powi(2)).sum();
                sum += crate::table::pair_multiplicity(pair) * squares;
            }
            sum
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    progress(BuildProgress {
        stage: "mapping",
        done: 1,
        total: 1,
    });
    MappedDatabase {
        observations: n,
        values,
        mean,
        total_sum_of_squares,
        reference,
        lower,
        upper,
    }
}

/// The median of non-negative f16 values given as bit patterns (the mean of the two middle
/// ones for an even count); reorders them.
fn median_of_nonnegative_f16(bits: &mut [u16]) -> f32 {
    let n = bits.len();
    let mid = n / 2;
    let (left, upper_mid, _) = bits.select_nth_unstable(mid);
    let upper_mid = f16::from_bits(*upper_mid).to_f32();
    if n % 2 == 1 {
        upper_mid
    } else {
        let lower_mid = f16::from_bits(left.iter().copied().max().unwrap_or(0)).to_f32();
        0.5 * (lower_mid + upper_mid)
    }
}

impl MappedDatabase {
    /// Loads rows `[start, start + rows)` transposed, as the columns of `out`
    /// (observations × rows): √w·(m − mean), each pair's values contiguous.
    fn block_transposed(&self, start: usize, rows: usize, out: &mut Mat<f64>, weights: &[f64]) {
        use half::slice::HalfFloatSliceExt;
        let n = self.observations;
        for r in 0..rows {
            let pair = start + r;
            let (w, mean) = (weights[pair], self.mean[pair]);
            let column = out
                .col_mut(r)
                .try_as_col_major_mut()
                .expect("a freshly allocated matrix is column-major")
                .as_slice_mut();
            self.values[pair * n..(pair + 1) * n].convert_to_f64_slice(column);
            for v in column.iter_mut() {
                *v = w * (*v - mean);
            }
        }
    }

    fn blocks(&self) -> usize {
        PAIRS.div_ceil(BLOCK_ROWS)
    }

    /// Z = Ãᵀ Ã Ω in one pass over the data, summed block by block in a fixed order.
    fn gram_product(&self, omega: MatRef<f64>, weights: &[f64]) -> Mat<f64> {
        let (n, l) = (self.observations, omega.ncols());
        let partials: Vec<Mat<f64>> = (0..self.blocks())
            .into_par_iter()
            .map_init(
                || {
                    (
                        Mat::<f64>::zeros(n, BLOCK_ROWS),
                        Mat::<f64>::zeros(BLOCK_ROWS, l),
                    )
                },
                |(xt, y), b| {
                    let start = b * BLOCK_ROWS;
                    let rows = BLOCK_ROWS.min(PAIRS - start);
                    self.block_transposed(start, rows, xt, weights);
                    let xt = xt.as_ref().subcols(0, rows);
                    let mut yb = y.as_mut().subrows_mut(0, rows);
                    matmul(
                        yb.as_mut(),
                        Accum::Replace,
                        xt.transpose(),
                        omega,
                        1.0,
                        Par::Seq,
                    );
                    let mut z = Mat::<f64>::zeros(n, l);
                    matmul(z.as_mut(), Accum::Replace, xt, yb.as_ref(), 1.0, Par::Seq);
                    z
                },
            )
            .collect();
        let mut z = Mat::<f64>::zeros(n, l);
        for p in &partials {
            z += p;
        }
        z
    }

    /// Y = Ã Ω (PAIRS × l), written block by block.
    fn product(&self, omega: MatRef<f64>, weights: &[f64]) -> Mat<f64> {
        let (n, l) = (self.observations, omega.ncols());
        let parts: Vec<Mat<f64>> = (0..self.blocks())
            .into_par_iter()
            .map_init(
                || Mat::<f64>::zeros(n, BLOCK_ROWS),
                |xt, b| {
                    let start = b * BLOCK_ROWS;
                    let rows = BLOCK_ROWS.min(PAIRS - start);
                    self.block_transposed(start, rows, xt, weights);
                    let mut y = Mat::<f64>::zeros(rows, l);
                    let xt = xt.as_ref().subcols(0, rows);
                    matmul(
                        y.as_mut(),
                        Accum::Replace,
                        xt.transpose(),
                        omega,
                        1.0,
                        Par::Seq,
                    );
                    y
                },
            )
            .collect();
        let mut y = Mat::<f64>::zeros(PAIRS, l);
        for (b, part) in parts.iter().enumerate() {
            y.as_mut()
                .subrows_mut(b * BLOCK_ROWS, part.nrows())
                .copy_from(part);
        }
        y
    }
}

/// Orthonormal columns spanning those of `a` (thin QR).
fn orthonormalize(a: &Mat<f64>) -> Mat<f64> {
    a.qr().compute_thin_Q()
}

/// Standard normal draws, seeded (Box–Muller keeps the dependency list short).
fn gaussian_matrix(rows: usize, cols: usize, seed: u64) -> Mat<f64> {
    use rand::Rng;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let mut uniform =
        move || -> f64 { ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64 };
    Mat::from_fn(rows, cols, |_, _| {
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    })
}

/// Builds the basis described by `spec`, reporting progress through `progress`.
pub fn build_basis(spec: &BasisSpec, progress: &(dyn Fn(BuildProgress) + Sync)) -> Basis {
    assert!(
        (1..=BasisSpec::MAX_COMPONENTS).contains(&spec.components),
        "K must be in 1..={}",
        BasisSpec::MAX_COMPONENTS
    );
    let db = generate(&spec.database, progress);
    let n = db.observations;
    // A database with fewer observations than K can't span K components.
    let k = spec.components.min(n);
    let l = (spec.components + spec.oversampling).min(n);
    // √(multiplicity): off-diagonal pairs stand for two entries of the full table.
    let weights: Vec<f64> = (0..PAIRS)
        .map(|p| {
            let (lo, hi) = crate::table::pair_directions(p);
            if lo == hi {
                1.0
            } else {
                std::f64::consts::SQRT_2
            }
        })
        .collect();

    let total = spec.power_iterations + 1;
    let mut omega = orthonormalize(&gaussian_matrix(n, l, spec.database.seed));
    for it in 0..spec.power_iterations {
        progress(BuildProgress {
            stage: "power iterations",
            done: it,
            total,
        });
        omega = orthonormalize(&db.gram_product(omega.as_ref(), &weights));
    }
    progress(BuildProgress {
        stage: "power iterations",
        done: spec.power_iterations,
        total,
    });

    // Rayleigh–Ritz: Y = ÃΩ, YᵀY = V Λ Vᵀ, U = Y V Λ^{-1/2}.
    let y = db.product(omega.as_ref(), &weights);
    let mut gram = Mat::<f64>::zeros(l, l);
    matmul(
        gram.as_mut(),
        Accum::Replace,
        y.transpose(),
        y.as_ref(),
        1.0,
        Par::rayon(0),
    );
    let eigen = gram
        .self_adjoint_eigen(Side::Lower)
        .expect("the eigendecomposition of a small symmetric matrix converges");
    let (vectors, values) = (eigen.U(), eigen.S().column_vector());
    // faer sorts eigenvalues in ascending order; components are taken largest first.
    let order: Vec<usize> = (0..l).rev().take(k).collect();
    let lambda_floor = values[l - 1].max(f64::MIN_POSITIVE) * 1e-14;
    let mut projector = Mat::<f64>::zeros(l, k);
    let mut variances = vec![0.0; k];
    for (col, &i) in order.iter().enumerate() {
        let lambda = values[i].max(lambda_floor);
        variances[col] = lambda / n as f64;
        for r in 0..l {
            projector[(r, col)] = vectors[(r, i)] / lambda.sqrt();
        }
    }
    let kept: f64 = order.iter().map(|&i| values[i].max(0.0)).sum();
    let residual_variance = ((db.total_sum_of_squares - kept)
        / (n as f64 * crate::table::ENTRIES as f64))
        .max(super::MIN_RESIDUAL_VARIANCE);
    progress(BuildProgress {
        stage: "power iterations",
        done: total,
        total,
    });

    let kk = k;
    let mut data = vec![0f32; Basis::stored_len(kk)];
    let (head, rows) = data.split_at_mut(4 * PAIRS);
    head[..PAIRS].copy_from_slice(&db.reference);
    for (dst, m) in head[PAIRS..2 * PAIRS].iter_mut().zip(&db.mean) {
        *dst = *m as f32;
    }
    head[2 * PAIRS..3 * PAIRS].copy_from_slice(&db.lower);
    head[3 * PAIRS..].copy_from_slice(&db.upper);
    rows.par_chunks_mut(kk * BLOCK_ROWS)
        .enumerate()
        .for_each(|(b, chunk)| {
            let start = b * BLOCK_ROWS;
            let count = chunk.len() / kk;
            let mut u = Mat::<f64>::zeros(count, kk);
            matmul(
                u.as_mut(),
                Accum::Replace,
                y.as_ref().subrows(start, count),
                projector.as_ref(),
                1.0,
                Par::Seq,
            );
            for r in 0..count {
                let inv_w = 1.0 / weights[start + r];
                for c in 0..kk {
                    chunk[r * kk + c] = (u[(r, c)] * inv_w) as f32;
                }
            }
        });
    Basis::from_owned(kk, n, variances, residual_variance, data)
}
