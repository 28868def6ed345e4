//! Fuzzes the sparse table and the incremental solver with operation sequences decoded from raw
//! bytes: samples with arbitrary f64 bit patterns, removals, policy and regularisation changes
//! (any f64 as λ or α), and solves. Asserts that refused samples change nothing, that bin values,
//! coefficients and reconstructed ρ are finite and ≥ 0, that the reconstruction is reciprocal,
//! and that the incremental solver equals a batch build from the final samples.
#![no_main]

use burnish::basis::{Basis, BasisCache, BasisSpec};
use burnish::materials::database::DatabaseSpec;
use burnish::solver::{
    BinChange, Policy, Reconstruction, Regularization, SampleKey, SampleRejected, Solution,
    Solver, SparseTable,
};
use burnish::table::{DIRECTIONS, DirIndex, PHI_BINS, PairIndex, pair_directions, pair_index};
use libfuzzer_sys::fuzz_target;
use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

/// A tiny basis (8 materials, K = 4), built once and cached under the fuzz project's target
/// folder so that every fuzzing process after the first maps it in at once.
fn basis() -> &'static Arc<Basis> {
    static BASIS: OnceLock<Arc<Basis>> = OnceLock::new();
    BASIS.get_or_init(|| {
        let spec = BasisSpec {
            database: DatabaseSpec { seed: 7, size: 8 },
            components: 4,
            oversampling: 4,
            power_iterations: 1,
        };
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/basis-cache");
        let (basis, _) = BasisCache::at(dir)
            .load_or_build(&spec, false, &|_| {})
            .expect("the fuzz basis cache is writable");
        basis
    })
}

/// Reads the fuzzer's bytes; past the end every read gives zeros.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    fn u8(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }
    fn f64_bits(&mut self) -> f64 {
        f64::from_bits(u64::from_le_bytes(std::array::from_fn(|_| self.u8())))
    }
    /// A value: mostly from a list of meaningful ones, else any bit pattern.
    fn value(&mut self) -> f64 {
        const VALUES: [f64; 15] = [
            0.0, -0.0, 1e-6, 1e-3, 0.05, 0.18, 0.5, 1.0, 3.0, 1e3, 1e6, 1e300, f64::MAX, 5e-324,
            f64::NAN,
        ];
        let tag = self.u8();
        match VALUES.get(tag as usize) {
            Some(&v) => v,
            None if tag < 128 => 10f64.powf(f64::from(tag) / 127.0 * 12.0 - 6.0),
            None => self.f64_bits(),
        }
    }
    fn direction(&mut self) -> DirIndex {
        self.u16() % DIRECTIONS as DirIndex
    }
}

type Samples = BTreeMap<SampleKey, (DirIndex, DirIndex, [f64; 3])>;

fn physical(rgb: &[f64; 3]) -> bool {
    rgb.iter().all(|v| v.is_finite() && *v >= 0.0)
}

fn rejection(rho: [f64; 3]) -> Option<SampleRejected> {
    if rho.iter().any(|v| !v.is_finite()) {
        Some(SampleRejected::NotFinite)
    } else if rho.iter().any(|&v| v < 0.0) {
        Some(SampleRejected::Negative)
    } else {
        None
    }
}

fn bins(table: &SparseTable) -> Vec<(PairIndex, [u64; 3])> {
    table
        .observed()
        .map(|(p, v)| (p, v.map(f64::to_bits)))
        .collect()
}

fn solution_bits(s: &Solution) -> (Vec<[u64; 3]>, u64, u64, usize) {
    (
        s.coefficients.iter().map(|r| r.map(f64::to_bits)).collect(),
        s.alpha.to_bits(),
        s.condition_number.to_bits(),
        s.observed_bins,
    )
}

/// Finite coefficients, a condition number in [1, 1/ε], and a finite, non-negative,
/// reciprocal reconstruction on every observed pair and a spread over the table.
fn check_solution(solution: &Solution, table: &SparseTable) {
    let basis = basis();
    assert!(
        solution.coefficients.iter().flatten().all(|x| x.is_finite()),
        "coefficients {:?}",
        solution.coefficients
    );
    assert!(
        (1.0..=1.0 / f64::EPSILON).contains(&solution.condition_number),
        "condition number {}",
        solution.condition_number
    );
    assert_eq!(solution.observed_bins, table.observed_count());
    let recon = Reconstruction::new(basis.clone(), &solution.coefficients);
    let spread = PairIndex::all().step_by(65_537);
    for pair in table.observed().map(|(p, _)| p).chain(spread) {
        let (lo, hi) = pair_directions(pair);
        let rho = recon.eval(lo, hi);
        assert!(rho.iter().all(|v| v.is_finite() && *v >= 0.0), "ρ({lo}, {hi}) = {rho:?}");
        assert_eq!(rho.map(f32::to_bits), recon.eval(hi, lo).map(f32::to_bits));
    }
}

fn regularization(bytes: &mut Bytes) -> Regularization {
    match bytes.u8() % 4 {
        0 => Regularization::Auto,
        1 => Regularization::Gcv,
        2 => Regularization::Prior {
            alpha: bytes.value(),
        },
        _ => Regularization::Ridge {
            lambda: bytes.value(),
        },
    }
}

/// Solves allowed per input, so that long inputs stay cheap.
const MAX_SOLVES: usize = 6;

fuzz_target!(|data: &[u8]| {
    let basis = basis();
    let mut bytes = Bytes(data);
    let mut table = SparseTable::new(Policy::Mean);
    let mut solver = Solver::new(basis.clone(), regularization(&mut bytes));
    let mut samples = Samples::new();
    let mut changes: Vec<BinChange> = Vec::new();
    let mut applied = 0usize;
    let mut solves = 0usize;
    // A 3 × 3 patch of neighbouring view bins under one light: nearly collinear basis rows.
    let patch = |i: u8| {
        let (t, p) = (usize::from(i % 3), usize::from(i / 3 % 3));
        (
            (20 * PHI_BINS + 4) as DirIndex,
            ((10 + t) * PHI_BINS + 7 + p) as DirIndex,
        )
    };

    while !bytes.is_empty() {
        changes.clear();
        let tag = bytes.u8();
        let key = |b: &mut Bytes| SampleKey {
            view: u32::from(b.u8() % 4),
            pixel: u32::from(b.u8() % 32),
        };
        match tag % 8 {
            0..=2 => {
                let key = key(&mut bytes);
                let place = bytes.u8();
                let (d_l, d_v) = match place % 4 {
                    0 => (bytes.direction(), bytes.direction()),
                    1 => ((place / 4 % 3) as DirIndex, (place / 16) as DirIndex),
                    _ => patch(place / 4),
                };
                let rho = if tag & 0x80 != 0 {
                    [bytes.value(); 3]
                } else {
                    [bytes.value(), bytes.value(), bytes.value()]
                };
                let expected = rejection(rho);
                let before = expected.map(|_| (bins(&table), table.sample_count()));
                let result = table.set_sample(key, d_l, d_v, rho, &mut changes);
                assert_eq!(result, expected.map_or(Ok(()), Err), "{rho:?}");
                match before {
                    Some(before) => {
                        assert!(changes.is_empty());
                        assert_eq!((bins(&table), table.sample_count()), before);
                    }
                    None => {
                        samples.insert(key, (d_l, d_v, rho));
                    }
                }
            }
            3 | 4 => {
                let key = key(&mut bytes);
                table.remove_sample(key, &mut changes);
                samples.remove(&key);
            }
            5 => {
                let view = u32::from(bytes.u8() % 4);
                table.remove_view(view, &mut changes);
                samples.retain(|k, _| k.view != view);
            }
            6 => {
                let policy = [Policy::Mean, Policy::Min, Policy::Max][usize::from(bytes.u8() % 3)];
                table.set_policy(policy, &mut changes);
            }
            _ => {
                if bytes.u8() % 2 == 0 {
                    solver.set_regularization(regularization(&mut bytes));
                }
                if solves < MAX_SOLVES {
                    solves += 1;
                    check_solution(&solver.solve(), &table);
                }
            }
        }
        assert_eq!(table.sample_count(), samples.len());
        for change in &changes {
            for value in change.before.iter().chain(&change.after) {
                assert!(physical(value), "bin {} reported {value:?}", change.pair);
            }
        }
        solver.apply_all(&changes);
        applied += changes.len();
    }

    // Batch: the final samples alone, inserted in reverse key order.
    let mut fresh_table = SparseTable::new(table.policy());
    let mut fresh_changes = Vec::new();
    for (&key, &(d_l, d_v, rho)) in samples.iter().rev() {
        fresh_table
            .set_sample(key, d_l, d_v, rho, &mut fresh_changes)
            .unwrap();
    }
    assert_eq!(bins(&fresh_table), bins(&table));
    for (pair, value) in table.observed() {
        assert!(physical(&value), "bin {pair} holds {value:?}");
        let inside = samples
            .values()
            .filter(|(d_l, d_v, _)| pair_index(*d_l, *d_v) == pair)
            .count();
        assert_eq!(table.samples_in(pair), inside);
    }
    let mut fresh = Solver::new(basis.clone(), solver.regularization());
    fresh.apply_all(&fresh_changes);

    // N ≤ I (the rows are orthonormal over the full table): the incremental drift is absolute.
    let history = applied.max(1) as f64;
    let ((n1, r1), (n2, r2)) = (solver.normal_equations(), fresh.normal_equations());
    let drift = n1
        .iter()
        .zip(n2)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(drift <= 16.0 * f64::EPSILON * history, "normal matrix drift {drift:e}");
    let r_scale = r2.iter().flatten().fold(1.0f64, |m, v| m.max(v.abs()));
    let r_drift = r1
        .iter()
        .flatten()
        .zip(r2.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        r_drift <= 64.0 * f64::EPSILON * history * r_scale,
        "right-hand side drift {r_drift:e}"
    );

    let (incremental, batch) = (solver.solve(), fresh.solve());
    check_solution(&incremental, &table);
    check_solution(&batch, &fresh_table);
    let well_posed = match solver.regularization() {
        Regularization::Auto => true,
        Regularization::Prior { alpha: v } | Regularization::Ridge { lambda: v } => {
            v.is_finite() && v > 0.0
        }
        Regularization::Gcv => false,
    };
    let bound = 1e3 * batch.condition_number * f64::EPSILON * history;
    if well_posed && bound < 1e-6 {
        let scale = batch
            .coefficients
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in incremental
            .coefficients
            .iter()
            .flatten()
            .zip(batch.coefficients.iter().flatten())
        {
            assert!((a - b).abs() <= bound * scale + 1e-300, "{a} vs {b}");
        }
    }
    solver.rebuild();
    fresh.rebuild();
    assert_eq!(solver.normal_equations(), fresh.normal_equations());
    assert_eq!(solution_bits(&solver.solve()), solution_bits(&fresh.solve()));
});
