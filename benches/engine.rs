//! Micro-benchmarks of the live loop (issue figures): one 500-pixel dab to new coefficients,
//! the full table from coefficients, lazy evaluation of a view's entries, and loading the
//! default basis from its cache; and the time per dab against its changed pixel count
//! (50, 500, 5000) and K (10, 20, 40). Uses the default bases (built and cached on first run);
//! under `cargo test`, which runs each benchmark once, a tiny basis at K = 20 only.

mod common;

use burnish::basis::{Basis, BasisCache, BasisSpec};
use burnish::solver::{Regularization, SampleKey, Solver, SparseTable};
use burnish::table::{DIRECTIONS, DirIndex, PairIndex};
use common::{check_basis, check_basis_spec, test_mode};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::collections::BTreeMap;
use std::hint::black_box;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The K to measure at; in test mode only K = 20, so that one small basis is built.
fn ks(all: &'static [usize]) -> &'static [usize] {
    if test_mode() { &[20] } else { all }
}

fn default_basis(k: usize) -> Arc<Basis> {
    if test_mode() {
        static BUILT: Mutex<BTreeMap<usize, Arc<Basis>>> = Mutex::new(BTreeMap::new());
        let mut built = BUILT.lock().expect("not poisoned");
        return built
            .entry(k)
            .or_insert_with(|| Arc::new(check_basis(k)))
            .clone();
    }
    let cache = BasisCache::default_location().expect("a cache folder");
    cache
        .load_or_build(&BasisSpec::default_for(k), false, &|_| {})
        .expect("basis")
        .0
}

/// A pixel's bins as a guide view fixes them: 20,000 pixels over ~6,000 bins.
fn pixel_bins(pixel: u32) -> (DirIndex, DirIndex) {
    let h = pixel as u64 * 2_654_435_761 % 6007;
    (
        (h * 7 % DIRECTIONS as u64) as DirIndex,
        (h * 13 / 7 % DIRECTIONS as u64) as DirIndex,
    )
}

fn engine(c: &mut Criterion) {
    for &k in ks(&[20, 40]) {
        let basis = default_basis(k);
        let mut table = SparseTable::default();
        let mut solver = Solver::new(basis.clone(), Regularization::Gcv);
        let mut changes = Vec::new();
        for pixel in 0..20_000u32 {
            let (d_l, d_v) = pixel_bins(pixel);
            table
                .set_sample(
                    SampleKey { view: 0, pixel },
                    d_l,
                    d_v,
                    [0.2, 0.3, 0.4],
                    &mut changes,
                )
                .unwrap();
        }
        solver.apply_all(&changes);
        changes.clear();

        let mut stroke = 0u32;
        c.bench_function(&format!("dab_500_pixels_to_coefficients_k{k}"), |b| {
            b.iter(|| {
                stroke += 1;
                let value = 0.1 + 0.05 * (stroke % 7) as f64;
                for i in 0..500u32 {
                    let pixel = (stroke * 500 + i) % 20_000;
                    let (d_l, d_v) = pixel_bins(pixel);
                    let key = SampleKey { view: 0, pixel };
                    table
                        .set_sample(key, d_l, d_v, [value, value, 0.5 * value], &mut changes)
                        .unwrap();
                }
                solver.apply_all(&changes);
                changes.clear();
                black_box(solver.solve())
            })
        });

        let solution = solver.solve();
        let recon = solution.reconstruction(basis.clone());
        c.bench_function(&format!("full_table_from_coefficients_k{k}"), |b| {
            b.iter(|| black_box(recon.materialize()))
        });
        let pairs: Vec<PairIndex> = PairIndex::all().step_by(5).take(262_144).collect();
        let mut out = Vec::new();
        c.bench_function(&format!("lazy_eval_262144_entries_k{k}"), |b| {
            b.iter(|| {
                recon.eval_pairs(&pairs, &mut out);
                black_box(out.len())
            })
        });
        c.bench_function(&format!("rebuild_normal_equations_k{k}"), |b| {
            b.iter(|| solver.rebuild())
        });
    }

    // In test mode, the small basis stored in a scratch folder (removed on return).
    let scratch = test_mode().then(|| tempfile::tempdir().expect("a temporary folder"));
    let (cache, spec) = match &scratch {
        Some(dir) => {
            let cache = BasisCache::at(dir.path().to_path_buf());
            let spec = check_basis_spec(20);
            cache.store(&spec, &default_basis(20)).expect("stored");
            (cache, spec)
        }
        None => (
            BasisCache::default_location().expect("a cache folder"),
            BasisSpec::default_for(20),
        ),
    };
    c.bench_function("basis_cache_load_k20", |b| {
        b.iter(|| black_box(cache.load(&spec).expect("valid cache").expect("cached")))
    });
}

/// A solver holding a painted view of 20,000 pixels.
fn painted(k: usize) -> (SparseTable, Solver) {
    let mut table = SparseTable::default();
    let mut solver = Solver::new(default_basis(k), Regularization::Auto);
    let mut changes = Vec::new();
    for pixel in 0..20_000u32 {
        let (d_l, d_v) = pixel_bins(pixel);
        let key = SampleKey { view: 0, pixel };
        table
            .set_sample(key, d_l, d_v, [0.2, 0.3, 0.4], &mut changes)
            .unwrap();
    }
    solver.apply_all(&changes);
    (table, solver)
}

/// Time per dab (set the samples, update the normal equations, solve) against the number of
/// changed pixels and K: the cost is O(changed bins · K²) plus the K × K solve.
fn dab_scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("dab_to_coefficients");
    for &k in ks(&[10, 20, 40]) {
        let (mut table, mut solver) = painted(k);
        let mut changes = Vec::new();
        for pixels in [50u32, 500, 5000] {
            let mut stroke = 0u32;
            group.bench_with_input(
                BenchmarkId::new(format!("k{k}"), pixels),
                &pixels,
                |b, &pixels| {
                    b.iter(|| {
                        stroke += 1;
                        let value = 0.1 + 0.05 * (stroke % 7) as f64;
                        for i in 0..pixels {
                            let pixel = (stroke * pixels + i) % 20_000;
                            let (d_l, d_v) = pixel_bins(pixel);
                            let key = SampleKey { view: 0, pixel };
                            table
                                .set_sample(
                                    key,
                                    d_l,
                                    d_v,
                                    [value, value, 0.5 * value],
                                    &mut changes,
                                )
                                .unwrap();
                        }
                        solver.apply_all(&changes);
                        changes.clear();
                        black_box(solver.solve())
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(Duration::from_secs(4));
    targets = engine, dab_scaling
}
criterion_main!(benches);
