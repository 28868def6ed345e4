//! Building the basis: the leading principal components of the mapped database by randomized
//! subspace iteration (Halko, Martinsson & Tropp 2011), streamed.
//!
//! A database that fits in [`KEEP_BUDGET_BYTES`] is tabulated once and held between passes;
//! a larger one is never held: every pass regenerates its materials (they depend on
//! (seed, index) alone), a batch at a time, so memory does not grow with the database's size.
//! Pass 1 gathers each entry's mean, spread and range and the sketch Y = ÃΩ; every further
//! pass computes Z = ÃᵀQ for the current orthonormal range Q and, but for the last,
//! Y = ÃZ; the last pass's Z gives the small matrix QᵀÃ whose SVD finishes the basis. Ã is
//! the centred, mapped database with each row weighted by √(pair multiplicity).
//!
//! Every product runs over fixed blocks of table rows, and every sum across blocks is taken in
//! block order, in f64, so the result does not depend on the number of threads.

use super::{Basis, MAP_EPSILON, MIN_RESIDUAL_VARIANCE, cos_weight_polar};
use crate::materials::Brdf;
use crate::materials::database::{DatabaseSpec, material};
use crate::materials::tabulate_mapped;
use crate::table::{PAIRS, PairIndex};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par, Side};
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
    /// Largest database supported.
    pub const MAX_MATERIALS: usize = 20_000;
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

/// Table rows processed together; also the unit of deterministic reduction.
const BLOCK_ROWS: usize = 4096;
/// Materials tabulated together on each pass.
const MATERIAL_BATCH: usize = 16;
/// Names of the passes, for progress.
const PASS_NAMES: [&str; 6] = [
    "pass 1: statistics and sketch",
    "pass 2: subspace iteration",
    "pass 3: subspace iteration",
    "pass 4: subspace iteration",
    "pass 5: subspace iteration",
    "pass 6: subspace iteration",
];

/// Where the database's materials come from: index → BRDF, deterministic.
pub type MaterialSource<'a> = &'a (dyn Fn(usize) -> Box<dyn Brdf> + Sync);

/// ln(ρc + ε) of every pair of one material (c as in the map, ε = [`MAP_EPSILON`]).
fn log_table(brdf: &dyn Brdf) -> Vec<[f32; 3]> {
    // f32 logarithms: the values are stored and multiplied in f32 precision anyway, and an
    // anisotropic material takes four million of them per pass.
    tabulate_mapped(brdf, |t_l, t_v, rho| {
        let c = cos_weight_polar(t_l, t_v) as f32;
        rho.map(|r| (r.max(0.0) * c + MAP_EPSILON as f32).ln())
    })
}

/// Per-pair running statistics of ln(ρc + ε) over the database (Chan et al.'s pairwise
/// update of mean and sum of squared deviations, one batch at a time).
struct EntryStats {
    count: f64,
    mean: Vec<f64>,
    m2: Vec<f64>,
    lower: Vec<f32>,
    upper: Vec<f32>,
}

impl EntryStats {
    fn new() -> Self {
        Self {
            count: 0.0,
            mean: vec![0.0; PAIRS],
            m2: vec![0.0; PAIRS],
            lower: vec![f32::INFINITY; PAIRS],
            upper: vec![f32::NEG_INFINITY; PAIRS],
        }
    }
}

/// √(pair multiplicity): off-diagonal pairs stand for two entries of the full table.
fn row_weights() -> Vec<f64> {
    PairIndex::all()
        .map(|p| crate::table::pair_multiplicity(p).sqrt())
        .collect()
}

fn blocks() -> usize {
    PAIRS.div_ceil(BLOCK_ROWS)
}

fn block_range(b: usize) -> std::ops::Range<usize> {
    b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(PAIRS)
}

/// One batch of materials, mapped: `tables[j][pair][channel]` = ln(ρc + ε).
struct Batch<'t> {
    /// Index of the batch's first observation column (3 per material).
    first_column: usize,
    tables: Vec<&'t [[f32; 3]]>,
}

impl Batch<'_> {
    fn columns(&self) -> usize {
        3 * self.tables.len()
    }

    /// Rows `range` of the batch as a (rows × columns) matrix: √w·(m − mean), or √w·m when
    /// `mean` is `None`.
    fn block(
        &self,
        range: std::ops::Range<usize>,
        weights: &[f64],
        mean: Option<&[f64]>,
    ) -> Mat<f64> {
        Mat::from_fn(range.len(), self.columns(), |r, col| {
            let pair = range.start + r;
            let m = self.tables[col / 3][pair][col % 3] as f64;
            weights[pair] * (m - mean.map_or(0.0, |mean| mean[pair]))
        })
    }
}

/// Mapped tables held between passes up to this many bytes (a material takes 15.7 MB, so up
/// to 400 materials; the default 2,000 are streamed): tabulating is most of a pass's cost, so a database that fits is
/// tabulated once; a larger one is regenerated on every pass and memory stays flat.
pub const KEEP_BUDGET_BYTES: usize = 6 << 30;

/// The database as the passes read it: regenerated from `source` on every pass, or kept
/// from the first when `keep` is set.
struct Database<'a> {
    source: MaterialSource<'a>,
    size: usize,
    keep: bool,
    kept: Vec<Vec<[f32; 3]>>,
}

impl<'a> Database<'a> {
    fn new(source: MaterialSource<'a>, size: usize, keep: bool) -> Self {
        Self {
            source,
            size,
            keep,
            kept: Vec::new(),
        }
    }

    /// Runs `work` on every batch of the database in order, tabulating each batch in
    /// parallel unless it was kept. The values are the same either way.
    fn for_each_batch(
        &mut self,
        stage: &'static str,
        progress: &(dyn Fn(BuildProgress) + Sync),
        mut work: impl FnMut(&Batch),
    ) {
        let size = self.size;
        progress(BuildProgress {
            stage,
            done: 0,
            total: size,
        });
        for start in (0..size).step_by(MATERIAL_BATCH) {
            let end = (start + MATERIAL_BATCH).min(size);
            if self.kept.len() >= end {
                work(&Batch {
                    first_column: 3 * start,
                    tables: self.kept[start..end].iter().map(Vec::as_slice).collect(),
                });
            } else {
                let source = self.source;
                let tables: Vec<Vec<[f32; 3]>> = (start..end)
                    .into_par_iter()
                    .map(|i| log_table(source(i).as_ref()))
                    .collect();
                work(&Batch {
                    first_column: 3 * start,
                    tables: tables.iter().map(Vec::as_slice).collect(),
                });
                if self.keep {
                    self.kept.extend(tables);
                }
            }
            progress(BuildProgress {
                stage,
                done: end,
                total: size,
            });
        }
    }
}

/// Orthonormal columns spanning those of the tall matrix `y`, by Cholesky–QR twice in its
/// eigen form: G = YᵀY summed block by block in block order, Y ← Y·V·S^-½. A library QR of
/// a tall matrix splits its work by thread count, and with it the rounding; this doesn't.
fn orthonormalize(y: &mut Mat<f64>) {
    let l = y.ncols();
    for _ in 0..2 {
        let partials: Vec<Mat<f64>> = (0..blocks())
            .into_par_iter()
            .map(|b| {
                let range = block_range(b);
                let rows = y.as_ref().subrows(range.start, range.len());
                let mut g = Mat::<f64>::zeros(l, l);
                matmul(
                    g.as_mut(),
                    Accum::Replace,
                    rows.transpose(),
                    rows,
                    1.0,
                    Par::Seq,
                );
                g
            })
            .collect();
        let mut gram = Mat::<f64>::zeros(l, l);
        for g in &partials {
            gram += g;
        }
        let eigen = gram
            .self_adjoint_eigen(Side::Lower)
            .expect("the eigendecomposition of a small symmetric matrix converges");
        let (vectors, values) = (eigen.U(), eigen.S().column_vector());
        let top = values[l - 1].max(f64::MIN_POSITIVE);
        // A direction the sketch doesn't reach gets a huge but finite scale, not a NaN.
        let transform = Mat::<f64>::from_fn(l, l, |r, c| {
            vectors[(r, c)] / values[c].max(top * 1e-15).sqrt()
        });
        y.par_row_chunks_mut(BLOCK_ROWS).for_each(|mut rows| {
            let mut out = Mat::<f64>::zeros(rows.nrows(), l);
            matmul(
                out.as_mut(),
                Accum::Replace,
                rows.as_ref(),
                transform.as_ref(),
                1.0,
                Par::Seq,
            );
            rows.copy_from(&out);
        });
    }
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

/// Z = (batch columns)ᵀ Q over all rows, summed block by block in block order.
fn batch_transpose_product(
    batch: &Batch,
    q: MatRef<f64>,
    weights: &[f64],
    mean: &[f64],
) -> Mat<f64> {
    let (cols, l) = (batch.columns(), q.ncols());
    let partials: Vec<Mat<f64>> = (0..blocks())
        .into_par_iter()
        .map(|b| {
            let range = block_range(b);
            let a = batch.block(range.clone(), weights, Some(mean));
            let mut z = Mat::<f64>::zeros(cols, l);
            matmul(
                z.as_mut(),
                Accum::Replace,
                a.transpose(),
                q.subrows(range.start, range.len()),
                1.0,
                Par::Seq,
            );
            z
        })
        .collect();
    let mut z = Mat::<f64>::zeros(cols, l);
    for p in &partials {
        z += p;
    }
    z
}

/// y += (batch block) · z, every row block on its own (each owns its rows of y).
fn accumulate_product(
    y: &mut Mat<f64>,
    batch: &Batch,
    z: MatRef<f64>,
    weights: &[f64],
    mean: Option<&[f64]>,
) {
    let l = y.ncols();
    let parts: Vec<(usize, Mat<f64>)> = (0..blocks())
        .into_par_iter()
        .map(|b| {
            let range = block_range(b);
            let a = batch.block(range.clone(), weights, mean);
            let mut part = Mat::<f64>::zeros(range.len(), l);
            matmul(part.as_mut(), Accum::Replace, a.as_ref(), z, 1.0, Par::Seq);
            (range.start, part)
        })
        .collect();
    for (start, part) in parts {
        let mut rows = y.as_mut().subrows_mut(start, part.nrows());
        rows += &part;
    }
}

/// Centres the sketch `y` = √w·MΩ of the uncentred database, whose entries' means pass 1
/// learns only as it goes: ÃΩ = √w·(M − mean·1ᵀ)Ω = √w·MΩ − √w·mean·(1ᵀΩ).
fn centre_sketch(y: &mut Mat<f64>, omega: MatRef<f64>, weights: &[f64], mean: &[f64]) {
    let omega_sums: Vec<f64> = (0..omega.ncols())
        .map(|c| omega.col(c).iter().sum())
        .collect();
    y.par_row_chunks_mut(BLOCK_ROWS)
        .enumerate()
        .for_each(|(b, mut rows)| {
            for r in 0..rows.nrows() {
                let pair = b * BLOCK_ROWS + r;
                let shift = weights[pair] * mean[pair];
                for (c, sum) in omega_sums.iter().enumerate() {
                    rows[(r, c)] -= shift * sum;
                }
            }
        });
}

/// Builds the basis described by `spec`, reporting progress through `progress`.
pub fn build_basis(spec: &BasisSpec, progress: &(dyn Fn(BuildProgress) + Sync)) -> Basis {
    let seed = spec.database.seed;
    let source = move |i: usize| material(seed, i).brdf;
    build_basis_from(&source, spec, progress)
}

/// Builds a basis of `spec.components` components from `spec.database.size` materials of
/// `source` (the seed of `spec` seeds the random sketch only).
pub fn build_basis_from(
    source: MaterialSource,
    spec: &BasisSpec,
    progress: &(dyn Fn(BuildProgress) + Sync),
) -> Basis {
    let bytes = spec.database.size * PAIRS * std::mem::size_of::<[f32; 3]>();
    build(source, spec, progress, bytes <= KEEP_BUDGET_BYTES)
}

/// [`build_basis_from`], holding the mapped database between passes when `keep` is set.
fn build(
    source: MaterialSource,
    spec: &BasisSpec,
    progress: &(dyn Fn(BuildProgress) + Sync),
    keep: bool,
) -> Basis {
    crate::solver::sequential_dense_algebra();
    assert!(
        (1..=BasisSpec::MAX_COMPONENTS).contains(&spec.components),
        "K must be in 1..={}",
        BasisSpec::MAX_COMPONENTS
    );
    let size = spec.database.size;
    assert!((1..=BasisSpec::MAX_MATERIALS).contains(&size));
    let n = 3 * size;
    // A database with fewer observations than K can't span K components.
    let k = spec.components.min(n);
    let l = (spec.components + spec.oversampling).min(n);
    let weights = row_weights();
    let passes = 1 + spec.power_iterations.clamp(1, PASS_NAMES.len() - 1);
    let omega = gaussian_matrix(n, l, spec.database.seed);
    let mut database = Database::new(source, size, keep);

    // Pass 1: per-pair statistics, and the uncentred sketch ÃΩ (centred afterwards).
    let mut stats = EntryStats::new();
    let mut y = Mat::<f64>::zeros(PAIRS, l);
    database.for_each_batch(PASS_NAMES[0], progress, |batch| {
        let cols = batch.columns();
        let omega_b = omega.as_ref().subrows(batch.first_column, cols);
        accumulate_product(&mut y, batch, omega_b, &weights, None);
        let nb = cols as f64;
        let na = stats.count;
        stats
            .mean
            .par_iter_mut()
            .zip(stats.m2.par_iter_mut())
            .zip(stats.lower.par_iter_mut())
            .zip(stats.upper.par_iter_mut())
            .enumerate()
            .with_min_len(4096)
            .for_each(|(pair, (((mean, m2), lower), upper))| {
                let (mut sum, mut lo, mut hi) = (0f64, *lower, *upper);
                for t in &batch.tables {
                    for &v in &t[pair] {
                        sum += v as f64;
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
                let mean_b = sum / nb;
                let mut m2_b = 0f64;
                for t in &batch.tables {
                    for &v in &t[pair] {
                        m2_b += (v as f64 - mean_b).powi(2);
                    }
                }
                let delta = mean_b - *mean;
                let total = na + nb;
                *mean += delta * nb / total;
                *m2 += m2_b + delta * delta * na * nb / total;
                *lower = lo;
                *upper = hi;
            });
        stats.count += nb;
    });
    centre_sketch(&mut y, omega.as_ref(), &weights, &stats.mean);
    orthonormalize(&mut y);
    let mut q = y;

    // Subspace iteration; the last pass keeps Z = ÃᵀQ for the Rayleigh–Ritz step.
    let mut z_all = Mat::<f64>::zeros(n, l);
    for pass in 1..passes {
        let last = pass + 1 == passes;
        let mut y_next = if last {
            Mat::<f64>::zeros(0, 0)
        } else {
            Mat::<f64>::zeros(PAIRS, l)
        };
        database.for_each_batch(PASS_NAMES[pass], progress, |batch| {
            let z = batch_transpose_product(batch, q.as_ref(), &weights, &stats.mean);
            if last {
                z_all
                    .as_mut()
                    .subrows_mut(batch.first_column, batch.columns())
                    .copy_from(&z);
            } else {
                accumulate_product(&mut y_next, batch, z.as_ref(), &weights, Some(&stats.mean));
            }
        });
        if !last {
            orthonormalize(&mut y_next);
            q = y_next;
        }
    }

    // Rayleigh–Ritz: B = QᵀÃ = Zᵀ; BBᵀ = ZᵀZ = V S² Vᵀ; the components are QV.
    let mut gram = Mat::<f64>::zeros(l, l);
    matmul(
        gram.as_mut(),
        Accum::Replace,
        z_all.transpose(),
        z_all.as_ref(),
        1.0,
        Par::Seq,
    );
    let eigen = gram
        .self_adjoint_eigen(Side::Lower)
        .expect("the eigendecomposition of a small symmetric matrix converges");
    let (vectors, values) = (eigen.U(), eigen.S().column_vector());
    // faer sorts eigenvalues in ascending order; components are taken largest first.
    let order: Vec<usize> = (0..l).rev().take(k).collect();
    let mut rotation = Mat::<f64>::zeros(l, k);
    let mut squared_singular = vec![0.0; k];
    let mut variances = vec![0.0; k];
    let floor = values[l - 1].max(f64::MIN_POSITIVE) * 1e-14;
    for (col, &i) in order.iter().enumerate() {
        squared_singular[col] = values[i].max(floor);
        variances[col] = squared_singular[col] / n as f64;
        for r in 0..l {
            rotation[(r, col)] = vectors[(r, i)];
        }
    }

    // Reference: e^mean − ε, so that the stored mean of the mapped values is (nearly) zero
    // and the per-pair scale sits where the database's values do.
    let reference: Vec<f64> = stats
        .mean
        .iter()
        .map(|&m| (m.exp() - MAP_EPSILON).max(0.0))
        .collect();
    let mut data = vec![0f32; Basis::stored_len(k)];
    let (head, rows) = data.split_at_mut(super::ROWS);
    let (ref_out, rest) = head.split_at_mut(PAIRS);
    let (mean_out, rest) = rest.split_at_mut(PAIRS);
    let (lower_out, rest) = rest.split_at_mut(PAIRS);
    let (upper_out, residual_out) = rest.split_at_mut(PAIRS);
    for pair in 0..PAIRS {
        let log_reference = (reference[pair] + MAP_EPSILON).ln();
        ref_out[pair] = reference[pair] as f32;
        mean_out[pair] = (stats.mean[pair] - log_reference) as f32;
        lower_out[pair] = (stats.lower[pair] as f64 - log_reference) as f32;
        upper_out[pair] = (stats.upper[pair] as f64 - log_reference) as f32;
    }
    let mut residual = vec![0f64; PAIRS];
    rows.par_chunks_mut(k * BLOCK_ROWS)
        .zip(residual.par_chunks_mut(BLOCK_ROWS))
        .enumerate()
        .for_each(|(b, (chunk, residual))| {
            let start = b * BLOCK_ROWS;
            let count = chunk.len() / k;
            let mut u = Mat::<f64>::zeros(count, k);
            matmul(
                u.as_mut(),
                Accum::Replace,
                q.as_ref().subrows(start, count),
                rotation.as_ref(),
                1.0,
                Par::Seq,
            );
            for r in 0..count {
                let pair = start + r;
                let inv_w = 1.0 / weights[pair];
                let mut explained = 0f64;
                for c in 0..k {
                    let row = u[(r, c)] * inv_w;
                    chunk[r * k + c] = row as f32;
                    explained += squared_singular[c] * row * row;
                }
                // What K components leave of this entry's spread over the database.
                residual[r] = ((stats.m2[pair] - explained) / n as f64).max(0.0);
            }
        });
    let weighted_residual: f64 = PairIndex::all()
        .zip(&residual)
        .map(|(p, r)| crate::table::pair_multiplicity(p) * r)
        .sum();
    let residual_variance =
        (weighted_residual / crate::table::ENTRIES as f64).max(MIN_RESIDUAL_VARIANCE);
    for (out, r) in residual_out.iter_mut().zip(&residual) {
        *out = r.max(MIN_RESIDUAL_VARIANCE) as f32;
    }
    progress(BuildProgress {
        stage: "done",
        done: size,
        total: size,
    });
    Basis::from_owned(k, n, variances, residual_variance, data)
}

/// A basis the library tests build in a second: K = 4 over 20 materials.
#[cfg(test)]
pub(crate) const SMALL_TEST_SPEC: BasisSpec = BasisSpec {
    database: DatabaseSpec { seed: 11, size: 20 },
    components: 4,
    oversampling: 4,
    power_iterations: 2,
};

/// The basis of [`SMALL_TEST_SPEC`], built once for every library test that only reads it.
#[cfg(test)]
pub(crate) fn small_test_basis() -> std::sync::Arc<crate::basis::Basis> {
    static BASIS: std::sync::OnceLock<std::sync::Arc<crate::basis::Basis>> =
        std::sync::OnceLock::new();
    BASIS
        .get_or_init(|| std::sync::Arc::new(build_basis(&SMALL_TEST_SPEC, &|_| {})))
        .clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The small test basis against the database's principal components computed directly:
    /// each entry's statistics from the tabulated materials, and the components from the
    /// eigenvectors of the observations' n × n Gram matrix (n = 60, so it is exact), with none
    /// of the build's sketch, passes or blocks.
    #[test]
    fn the_basis_is_the_databases_principal_components() {
        use crate::basis::{RANGE_MARGIN, cos_weight};
        use crate::materials::tabulate;
        use crate::table::{ENTRIES, pair_multiplicity};
        let spec = SMALL_TEST_SPEC;
        let basis = small_test_basis();
        let size = spec.database.size;
        let n = 3 * size;
        let tables: Vec<crate::table::SymTable> = (0..size)
            .map(|i| tabulate(material(spec.database.seed, i).brdf.as_ref()))
            .collect();
        // x_p: ln(ρc + ε) of every observation (material, channel) at pair p.
        let observations = |p: usize, x: &mut Vec<f64>| {
            let c = cos_weight(PairIndex::from_index(p));
            x.clear();
            for t in &tables {
                for rho in t.pairs()[p] {
                    x.push((rho.max(0.0) as f64 * c + MAP_EPSILON).ln());
                }
            }
        };
        let mut x = Vec::with_capacity(n);
        let mut mean = vec![0.0; PAIRS];
        let mut m2 = vec![0.0; PAIRS];
        let mut gram = Mat::<f64>::zeros(n, n);
        for p in 0..PAIRS {
            observations(p, &mut x);
            let mu = x.iter().sum::<f64>() / n as f64;
            mean[p] = mu;
            m2[p] = x.iter().map(|v| (v - mu).powi(2)).sum();
            let lower = x.iter().copied().fold(f64::INFINITY, f64::min);
            let upper = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let reference = (mu.exp() - MAP_EPSILON).max(0.0);
            let log_reference = (reference + MAP_EPSILON).ln();
            let close = |stored: f32, exact: f64| (stored as f64 - exact).abs() < 1e-4;
            assert!(close(basis.references()[p], reference), "reference {p}");
            assert!(close(basis.means()[p], mu - log_reference), "mean {p}");
            assert!(close(basis.lowers()[p], lower - log_reference), "lower {p}");
            assert!(close(basis.uppers()[p], upper - log_reference), "upper {p}");
            let w = pair_multiplicity(PairIndex::from_index(p));
            for j in 0..n {
                let dj = w * (x[j] - mu);
                for k in 0..=j {
                    gram[(j, k)] += dj * (x[k] - mu);
                }
            }
        }
        assert!(basis.lowers().iter().all(|l| *l - RANGE_MARGIN < 0.0));
        let eigen = gram.self_adjoint_eigen(Side::Lower).unwrap();
        let (vectors, values) = (eigen.U(), eigen.S().column_vector());
        let k = basis.components();
        assert_eq!((k, basis.observations()), (spec.components, n));
        // Component c: Ã v / s over the weighted centred database, stored without √w.
        let top: Vec<usize> = (0..n).rev().take(k).collect();
        for (c, &i) in top.iter().enumerate() {
            let variance = values[i] / n as f64;
            let relative = (basis.variances()[c] - variance).abs() / variance;
            assert!(
                relative < 1e-3,
                "variance {c}: {} against {variance}",
                basis.variances()[c]
            );
        }
        let mut exact_rows = vec![0.0; PAIRS * k];
        for p in 0..PAIRS {
            observations(p, &mut x);
            for (c, &i) in top.iter().enumerate() {
                let s = values[i].sqrt();
                exact_rows[p * k + c] = (0..n)
                    .map(|j| (x[j] - mean[p]) * vectors[(j, i)])
                    .sum::<f64>()
                    / s;
            }
        }
        for c in 0..k {
            let dot: f64 = (0..PAIRS)
                .map(|p| basis.rows()[p * k + c] as f64 * exact_rows[p * k + c])
                .sum();
            let sign = dot.signum();
            let worst = (0..PAIRS)
                .map(|p| (basis.rows()[p * k + c] as f64 - sign * exact_rows[p * k + c]).abs())
                .fold(0.0, f64::max);
            let largest = (0..PAIRS)
                .map(|p| exact_rows[p * k + c].abs())
                .fold(0.0, f64::max);
            // Both are orthonormal over the full table: their inner product is ±1.
            let inner: f64 = (0..PAIRS)
                .map(|p| {
                    pair_multiplicity(PairIndex::from_index(p))
                        * basis.rows()[p * k + c] as f64
                        * exact_rows[p * k + c]
                })
                .sum();
            // The sketch (8 directions for 60 observations) leaves the later components a
            // little off: measured 1 − |inner product| 5e-8 to 4e-5, worst entry 0.4–1.3%.
            assert!(
                1.0 - inner.abs() < 1e-3,
                "component {c}: inner product {inner}"
            );
            assert!(
                worst < 5e-2 * largest,
                "component {c}: {worst} of {largest}"
            );
        }
        // What K components leave of each entry, and its full-table mean.
        let mut weighted = 0.0;
        let mut worst_residual = 0.0f64;
        for p in 0..PAIRS {
            let explained: f64 = top
                .iter()
                .enumerate()
                .map(|(c, &i)| values[i] * exact_rows[p * k + c].powi(2))
                .sum();
            let residual = ((m2[p] - explained) / n as f64).max(0.0);
            weighted += pair_multiplicity(PairIndex::from_index(p)) * residual;
            let stored = basis.residuals()[p] as f64;
            let exact = residual.max(MIN_RESIDUAL_VARIANCE);
            // Measured against the entry's whole variance, which the components take most of.
            let total = m2[p] / n as f64;
            worst_residual = worst_residual.max((stored - exact).abs() / total.max(1e-6));
        }
        // Measured: 1.8%, from the sketch's later components.
        assert!(
            worst_residual < 0.05,
            "residuals off by {worst_residual} of the variance"
        );
        let residual_variance = (weighted / ENTRIES as f64).max(MIN_RESIDUAL_VARIANCE);
        let relative = (basis.residual_variance() - residual_variance).abs() / residual_variance;
        assert!(
            relative < 1e-3,
            "{} against {residual_variance}",
            basis.residual_variance()
        );
    }

    /// Holding the tables between passes changes the cost, never the basis.
    #[test]
    fn a_kept_database_gives_the_streamed_basis_bit_for_bit() {
        let spec = SMALL_TEST_SPEC;
        let seed = spec.database.seed;
        let source = move |i: usize| material(seed, i).brdf;
        let streamed = build(&source, &spec, &|_| {}, false);
        let kept = build(&source, &spec, &|_| {}, true);
        assert_eq!(streamed.variances(), kept.variances());
        for pair in [0, 1234, PAIRS / 2, PAIRS - 1].map(PairIndex::from_index) {
            assert_eq!(streamed.row(pair), kept.row(pair), "pair {pair}");
        }
        assert_eq!(streamed.residuals(), kept.residuals());
    }

    /// The sketch's draws are a standard normal's: finite, and their mean, variance, fourth
    /// moment and share within one σ those of N(0, 1), to a few of their standard errors over
    /// 20,000 draws. A seed gives one matrix, and another seed another.
    #[test]
    fn the_sketch_draws_a_standard_normal() {
        let draws = gaussian_matrix(200, 100, 3);
        let x: Vec<f64> = (0..100)
            .flat_map(|c| draws.col(c).iter().copied().collect::<Vec<_>>())
            .collect();
        assert!(x.iter().all(|v| v.is_finite()));
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let moment = |k: i32| x.iter().map(|v| (v - mean).powi(k)).sum::<f64>() / n;
        let within_one = x.iter().filter(|v| v.abs() < 1.0).count() as f64 / n;
        // Standard errors: 0.007, 0.01, 0.07 and 0.003.
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((moment(2) - 1.0).abs() < 0.04, "variance {}", moment(2));
        assert!((moment(4) - 3.0).abs() < 0.3, "fourth moment {}", moment(4));
        assert!(
            (within_one - 0.6827).abs() < 0.015,
            "within one σ {within_one}"
        );
        assert_eq!(gaussian_matrix(200, 100, 3), draws);
        assert_ne!(gaussian_matrix(200, 100, 4), draws);
    }

    /// The two products over one batch, against their sums written out: Z = ÃᵀQ over every
    /// row, and Y + ÃZ (centred) or Y + √w·M·Z (uncentred) on rows at the blocks' edges; and
    /// pass 1's sketch, centred once the means are known, equal to the centred product.
    #[test]
    fn the_batch_products_are_the_weighted_sums_written_out() {
        let tables: Vec<Vec<[f32; 3]>> = (0..2)
            .map(|j| {
                (0..PAIRS)
                    .map(|p| {
                        let x = ((p * 7 + j * 13) % 101) as f32 / 50.0 - 1.0;
                        [x, 0.5 * x + j as f32, -x * x]
                    })
                    .collect()
            })
            .collect();
        let batch = Batch {
            first_column: 3,
            tables: tables.iter().map(Vec::as_slice).collect(),
        };
        let weights = row_weights();
        let mean: Vec<f64> = (0..PAIRS).map(|p| (p % 17) as f64 / 17.0).collect();
        let entry = |p: usize, col: usize| f64::from(tables[col / 3][p][col % 3]);
        let close = |got: f64, want: f64, scale: f64| (got - want).abs() <= 1e-9 * scale;
        let l = 3;
        let q = gaussian_matrix(PAIRS, l, 5);
        let z = batch_transpose_product(&batch, q.as_ref(), &weights, &mean);
        assert_eq!((z.nrows(), z.ncols()), (6, l));
        for col in 0..6 {
            for c in 0..l {
                let terms = (0..PAIRS).map(|p| weights[p] * (entry(p, col) - mean[p]) * q[(p, c)]);
                let (want, scale) = terms.fold((0.0, 0.0), |(s, a), t| (s + t, a + t.abs()));
                assert!(close(z[(col, c)], want, scale), "Z[{col}, {c}]");
            }
        }
        // The centred sketch of the whole batch: the uncentred one, centred afterwards.
        let omega = gaussian_matrix(6, l, 8);
        let mut centred_after = Mat::<f64>::zeros(PAIRS, l);
        accumulate_product(&mut centred_after, &batch, omega.as_ref(), &weights, None);
        centre_sketch(&mut centred_after, omega.as_ref(), &weights, &mean);
        let mut centred = Mat::<f64>::zeros(PAIRS, l);
        accumulate_product(&mut centred, &batch, omega.as_ref(), &weights, Some(&mean));
        for p in 0..PAIRS {
            for c in 0..l {
                let (got, want) = (centred_after[(p, c)], centred[(p, c)]);
                assert!((got - want).abs() < 1e-9 * want.abs().max(1.0), "{p} {c}");
            }
        }
        let start = gaussian_matrix(PAIRS, l, 6);
        let factors = gaussian_matrix(6, l, 7);
        for centred in [true, false] {
            let mut y = start.clone();
            accumulate_product(
                &mut y,
                &batch,
                factors.as_ref(),
                &weights,
                centred.then_some(mean.as_slice()),
            );
            for p in [0, 1, BLOCK_ROWS - 1, BLOCK_ROWS, PAIRS / 2, PAIRS - 1] {
                let shift = if centred { mean[p] } else { 0.0 };
                for c in 0..l {
                    let terms =
                        (0..6).map(|col| weights[p] * (entry(p, col) - shift) * factors[(col, c)]);
                    let (sum, scale) = terms.fold((0.0, 0.0), |(s, a), t| (s + t, a + t.abs()));
                    let want = start[(p, c)] + sum;
                    assert!(
                        close(y[(p, c)], want, scale + start[(p, c)].abs()),
                        "Y[{p}, {c}], centred {centred}"
                    );
                }
            }
        }
    }

    /// More power iterations than there are passes are clamped to the passes there are, each
    /// reported under its name, from none of the database done to all of it; and a sketch
    /// without oversampling still gives K components.
    #[test]
    fn power_iterations_are_clamped_to_the_named_passes() {
        let spec = BasisSpec {
            database: DatabaseSpec { seed: 3, size: 2 },
            components: 2,
            oversampling: 0,
            power_iterations: 9,
        };
        let seen = std::sync::Mutex::new(Vec::new());
        let basis = build_basis(&spec, &|p| seen.lock().unwrap().push(p));
        assert_eq!(basis.components(), 2);
        let seen = seen.into_inner().unwrap();
        let mut stages: Vec<&str> = seen.iter().map(|p| p.stage).collect();
        stages.dedup();
        let mut want = PASS_NAMES.to_vec();
        want.push("done");
        assert_eq!(stages, want);
        for name in PASS_NAMES {
            let reports: Vec<(usize, usize)> = seen
                .iter()
                .filter(|p| p.stage == name)
                .map(|p| (p.done, p.total))
                .collect();
            assert_eq!(reports, [(0, 2), (2, 2)], "{name}");
        }
    }
}
