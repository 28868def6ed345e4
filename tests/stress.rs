//! Property tests of the sparse table and the solver under hostile input (issue 5): random
//! add/replace/remove sequences, one sample, duplicates, black and saturated paint, NaN, ±Inf and
//! negative values, values from 1e-6 to 1e6 (and up to f64::MAX), nearly collinear basis rows,
//! K above the observed bin count, and regularisation from 0 to 1e300.
//!
//! Properties: every bin value, coefficient and reconstructed ρ is finite and ρ ≥ 0; bad samples
//! are refused and change nothing; the reconstruction is reciprocal bit for bit; the same
//! operations give bit-identical results run after run and under 1, 2 or 3 threads; the
//! incremental solver equals a batch build from the final samples (within stated tolerances,
//! and bit for bit after an exact rebuild).
//!
//! Each test prints the worst condition number it saw and the configuration behind it
//! (`cargo test --test stress -- --nocapture`).

mod common;

use burnish::basis::Basis;
use burnish::solver::{
    BinChange, Policy, Reconstruction, Regularization, SampleKey, SampleRejected, Solution, Solver,
    SparseTable,
};
use burnish::table::{
    DIRECTIONS, DirIndex, PAIRS, PHI_BINS, PairIndex, pair_directions, pair_index,
};
use common::small_basis;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestCaseResult, TestRunner};
use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

const K: usize = 20;

fn basis() -> Arc<Basis> {
    small_basis(K)
}

/// 1/ε: the cap `Solution::condition_number` puts on a singular matrix.
const CONDITION_CAP: f64 = 1.0 / f64::EPSILON;

// ---------------------------------------------------------------------------------------------
// Operations and their strategies
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
enum Op {
    Set {
        key: SampleKey,
        d_l: DirIndex,
        d_v: DirIndex,
        rho: [f64; 3],
    },
    Remove(SampleKey),
    RemoveView(u32),
    SetPolicy(Policy),
}

/// Few views and pixels, so that keys are repainted, moved between bins and removed often.
fn key() -> impl Strategy<Value = SampleKey> {
    (0..3u32, 0..24u32).prop_map(|(view, pixel)| SampleKey { view, pixel })
}

/// Direction index of polar bin `theta`, azimuth bin `phi`.
fn direction(theta: usize, phi: usize) -> DirIndex {
    (theta * PHI_BINS + phi) as DirIndex
}

/// A 3 × 3 patch of neighbouring view bins under one light bin: their basis rows are nearly
/// collinear, so observing only them leaves the normal matrix close to rank one.
fn collinear_bin() -> impl Strategy<Value = (DirIndex, DirIndex)> {
    (0..3usize, 0..3usize).prop_map(|(t, p)| (direction(20, 4), direction(10 + t, 7 + p)))
}

fn bin() -> impl Strategy<Value = (DirIndex, DirIndex)> {
    let any_direction = 0..DIRECTIONS as DirIndex;
    prop_oneof![
        3 => (any_direction.clone(), any_direction),
        // A handful of bins shared by many keys: duplicates and multi-sample bins.
        2 => prop::sample::select(vec![(0, 0), (5, 900), (900, 5), (1619, 1619)]),
        2 => collinear_bin(),
    ]
}

/// One channel: mostly log-uniform over 1e-6..1e6, with black, saturation, the extremes of
/// f64 and arbitrary bit patterns (which may be rejected).
fn channel() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => (-6.0f64..=6.0).prop_map(|e| 10f64.powf(e)),
        1 => Just(0.0),
        1 => Just(1.0),
        1 => Just(1e6),
        1 => prop::sample::select(vec![-0.0, 5e-324, f64::MIN_POSITIVE, 1e300, f64::MAX]),
        1 => any::<f64>(),
    ]
}

/// A value no sample may have.
fn bad_channel() -> impl Strategy<Value = f64> {
    prop::sample::select(vec![
        f64::NAN,
        -f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        -5e-324,
        -1e-6,
        -1.0,
        -f64::MAX,
    ])
}

fn rho() -> impl Strategy<Value = [f64; 3]> {
    prop_oneof![
        6 => [channel(), channel(), channel()],
        2 => channel().prop_map(|v| [v; 3]),
        1 => Just([0.0; 3]),
        2 => (0..3usize, bad_channel(), [channel(), channel(), channel()]).prop_map(
            |(c, bad, mut rgb)| {
                rgb[c] = bad;
                rgb
            }
        ),
    ]
}

fn policy() -> impl Strategy<Value = Policy> {
    prop::sample::select(vec![Policy::Mean, Policy::Min, Policy::Max])
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        10 => (key(), bin(), rho()).prop_map(|(key, (d_l, d_v), rho)| Op::Set { key, d_l, d_v, rho }),
        3 => key().prop_map(Op::Remove),
        1 => (0..3u32).prop_map(Op::RemoveView),
        1 => policy().prop_map(Op::SetPolicy),
    ]
}

/// Regularisations the API accepts, from vanishing to overwhelming.
fn regularization() -> impl Strategy<Value = Regularization> {
    let extremes = vec![0.0, 1e-300, 1e-12, 1e-3, 1.0, 1e3, 1e12, 1e300];
    prop_oneof![
        1 => Just(Regularization::Auto),
        1 => Just(Regularization::Gcv),
        1 => prop::sample::select(extremes.clone()).prop_map(|lambda| Regularization::Ridge { lambda }),
        1 => (-300.0f64..300.0).prop_map(|e| Regularization::Ridge { lambda: 10f64.powf(e) }),
        1 => prop::sample::select(extremes).prop_map(|alpha| Regularization::Prior { alpha }),
        1 => (-300.0f64..300.0).prop_map(|e| Regularization::Prior { alpha: 10f64.powf(e) }),
    ]
}

/// Parameters no parser lets through but the API can be handed.
fn hostile_regularization() -> impl Strategy<Value = Regularization> {
    let values = vec![
        -1.0,
        -1e-300,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        5e-324,
    ];
    prop_oneof![
        prop::sample::select(values.clone()).prop_map(|lambda| Regularization::Ridge { lambda }),
        prop::sample::select(values).prop_map(|alpha| Regularization::Prior { alpha }),
    ]
}

/// Cases come from a fixed seed, so that a run (CI's included) is repeatable; set
/// PROPTEST_RNG_SEED to explore others (and the fuzz target explores without end).
fn runner(cases: u32) -> TestRunner {
    let base = Config::with_source_file(file!());
    let rng_seed = if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
        base.rng_seed
    } else {
        proptest::test_runner::RngSeed::Fixed(0x0b_u64 << 56 | 0x5eed)
    };
    TestRunner::new(Config {
        cases,
        // Shrinking replays whole sessions; a few hundred steps find a small case.
        max_shrink_iters: 512,
        rng_seed,
        ..base
    })
}

/// Runs `test` on `cases` values of `strategy` and panics with the minimal failing case.
fn check<S: Strategy>(cases: u32, strategy: S, test: impl Fn(S::Value) -> TestCaseResult)
where
    S::Value: std::fmt::Debug,
{
    if let Err(e) = runner(cases).run(&strategy, test) {
        panic!("{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// The session under test and its model
// ---------------------------------------------------------------------------------------------

type Samples = BTreeMap<SampleKey, (DirIndex, DirIndex, [f64; 3])>;

fn expected_rejection(rho: [f64; 3]) -> Option<SampleRejected> {
    if rho.iter().any(|v| !v.is_finite()) {
        Some(SampleRejected::NotFinite)
    } else if rho.iter().any(|&v| v < 0.0) {
        Some(SampleRejected::Negative)
    } else {
        None
    }
}

fn luminance(rgb: &[f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

fn physical(rgb: &[f64; 3]) -> bool {
    rgb.iter().all(|v| v.is_finite() && *v >= 0.0)
}

/// A sparse table and an incremental solver fed one operation at a time, beside a plain map of
/// the samples they should hold.
struct Session {
    table: SparseTable,
    solver: Solver,
    samples: Samples,
    changes: Vec<BinChange>,
    /// Bin changes fed to the solver so far.
    applied: usize,
}

impl Session {
    fn new(regularization: Regularization) -> Self {
        Self {
            table: SparseTable::new(Policy::Mean),
            solver: Solver::new(basis(), regularization),
            samples: Samples::new(),
            changes: Vec::new(),
            applied: 0,
        }
    }

    fn run(ops: &[Op], regularization: Regularization) -> Result<Self, TestCaseError> {
        let mut session = Self::new(regularization);
        for op in ops {
            session.apply(op)?;
        }
        Ok(session)
    }

    /// Every observed bin and its value, bit for bit.
    fn bins(&self) -> Vec<(PairIndex, [u64; 3])> {
        bins_of(&self.table)
    }

    fn apply(&mut self, op: &Op) -> TestCaseResult {
        self.changes.clear();
        match *op {
            Op::Set { key, d_l, d_v, rho } => {
                let rejection = expected_rejection(rho);
                let before = rejection.map(|_| (self.bins(), self.table.sample_count()));
                let result = self.table.set_sample(key, d_l, d_v, rho, &mut self.changes);
                prop_assert_eq!(result, rejection.map_or(Ok(()), Err), "{:?}", rho);
                match before {
                    Some(before) => {
                        prop_assert!(self.changes.is_empty(), "a refused sample changed bins");
                        prop_assert_eq!(
                            (self.bins(), self.table.sample_count()),
                            before,
                            "a refused sample changed the table"
                        );
                    }
                    None => {
                        self.samples.insert(key, (d_l, d_v, rho));
                    }
                }
            }
            Op::Remove(key) => {
                self.table.remove_sample(key, &mut self.changes);
                self.samples.remove(&key);
            }
            Op::RemoveView(view) => {
                self.table.remove_view(view, &mut self.changes);
                self.samples.retain(|k, _| k.view != view);
            }
            Op::SetPolicy(policy) => self.table.set_policy(policy, &mut self.changes),
        }
        prop_assert_eq!(self.table.sample_count(), self.samples.len());
        for change in &self.changes {
            for value in change.before.iter().chain(&change.after) {
                prop_assert!(physical(value), "bin {} reported {:?}", change.pair, value);
            }
        }
        // The last change of each pair is the bin's state now.
        let mut last = BTreeMap::new();
        for change in &self.changes {
            last.insert(change.pair, change.after);
        }
        for (&pair, after) in &last {
            prop_assert_eq!(bits(self.table.bin_value(pair)), bits(*after));
            check_bin(&self.table, &self.samples, pair)?;
        }
        self.solver.apply_all(&self.changes);
        self.applied += self.changes.len();
        Ok(())
    }

    /// The whole table against the model.
    fn check_table(&self) -> TestCaseResult {
        let pairs: BTreeSet<PairIndex> = self
            .samples
            .values()
            .map(|&(d_l, d_v, _)| pair_index(d_l, d_v))
            .collect();
        let observed: BTreeSet<PairIndex> = self.table.observed().map(|(p, _)| p).collect();
        prop_assert_eq!(&observed, &pairs);
        prop_assert_eq!(self.solver.observed_bins(), pairs.len());
        for &pair in &pairs {
            check_bin(&self.table, &self.samples, pair)?;
        }
        Ok(())
    }
}

fn bits(value: Option<[f64; 3]>) -> Option<[u64; 3]> {
    value.map(|v| v.map(f64::to_bits))
}

fn bins_of(table: &SparseTable) -> Vec<(PairIndex, [u64; 3])> {
    table
        .observed()
        .map(|(p, v)| (p, v.map(f64::to_bits)))
        .collect()
}

/// The bin of `pair` against the samples the model puts there, under the table's policy.
fn check_bin(table: &SparseTable, samples: &Samples, pair: PairIndex) -> TestCaseResult {
    let inside: Vec<[f64; 3]> = samples
        .values()
        .filter(|(d_l, d_v, _)| pair_index(*d_l, *d_v) == pair)
        .map(|&(_, _, rho)| rho)
        .collect();
    let value = table.bin_value(pair);
    prop_assert_eq!(table.samples_in(pair), inside.len());
    let Some(value) = value else {
        prop_assert!(inside.is_empty(), "bin {} lost its samples", pair);
        return Ok(());
    };
    prop_assert!(physical(&value), "bin {} holds {:?}", pair, value);
    match table.policy() {
        Policy::Mean => {
            let n = inside.len() as f64;
            for c in 0..3 {
                let hi = inside.iter().map(|v| v[c]).fold(0.0, f64::max);
                // Summing pre-divided terms cannot overflow; both sums round n times at most.
                let mean: f64 = inside.iter().map(|v| v[c] / n).sum();
                prop_assert!(
                    (value[c] - mean).abs() <= 2.0 * n * f64::EPSILON * hi + 1e-300,
                    "mean {} vs {} in bin {}",
                    value[c],
                    mean,
                    pair
                );
            }
        }
        Policy::Min | Policy::Max => {
            let darkest = table.policy() == Policy::Min;
            prop_assert!(
                // −0 is stored as +0.
                inside
                    .iter()
                    .any(|v| v.map(|c| (c + 0.0).to_bits()) == value.map(f64::to_bits)),
                "the picked colour is one of the samples"
            );
            let y = luminance(&value);
            for v in &inside {
                let other = luminance(v);
                prop_assert!(
                    if darkest { y <= other } else { y >= other },
                    "{:?} picked {:?} over {:?}",
                    table.policy(),
                    value,
                    v
                );
            }
        }
    }
    Ok(())
}

/// A fresh table and solver from `samples` alone, inserted in reverse key order.
fn batch(
    samples: &Samples,
    policy: Policy,
    regularization: Regularization,
) -> (SparseTable, Solver) {
    let mut table = SparseTable::new(policy);
    let mut changes = Vec::new();
    for (&key, &(d_l, d_v, rho)) in samples.iter().rev() {
        table.set_sample(key, d_l, d_v, rho, &mut changes).unwrap();
    }
    let mut solver = Solver::new(basis(), regularization);
    solver.apply_all(&changes);
    (table, solver)
}

// ---------------------------------------------------------------------------------------------
// Solution checks and the worst condition number
// ---------------------------------------------------------------------------------------------

/// The worst condition number a test saw, and what produced it.
#[derive(Default)]
struct Worst {
    condition: f64,
    config: String,
    /// Solves per regularisation family, and how many of them were at the 1/ε cap.
    solves: BTreeMap<&'static str, (usize, usize)>,
}

fn family(regularization: Regularization) -> &'static str {
    match regularization {
        Regularization::Auto => "auto",
        Regularization::Gcv => "gcv",
        Regularization::Prior { .. } => "prior",
        Regularization::Ridge { .. } => "ridge",
    }
}

impl Worst {
    fn note(
        &mut self,
        solution: &Solution,
        regularization: Regularization,
        what: &dyn Fn() -> String,
    ) {
        let entry = self.solves.entry(family(regularization)).or_default();
        entry.0 += 1;
        if solution.condition_number >= CONDITION_CAP {
            entry.1 += 1;
        }
        if solution.condition_number > self.condition {
            self.condition = solution.condition_number;
            self.config = format!(
                "{regularization:?}, α {:e}, {} observed bins: {}",
                solution.alpha,
                solution.observed_bins,
                what()
            );
        }
    }

    fn report(&self, test: &str) {
        println!(
            "{test}: worst condition number {:.3e} ({})",
            self.condition, self.config
        );
        for (family, (solves, capped)) in &self.solves {
            println!("  {family}: {solves} solves, {capped} at the 1/ε cap");
        }
    }
}

/// What every solution must satisfy.
fn check_solution(solution: &Solution, observed: usize) -> TestCaseResult {
    // One coefficient set per band of the localised prior.
    prop_assert_eq!(solution.coefficients.len(), burnish::solver::BANDS * K);
    prop_assert!(
        solution
            .coefficients
            .iter()
            .flatten()
            .all(|x| x.is_finite()),
        "coefficients {:?}",
        solution.coefficients
    );
    let cond = solution.condition_number;
    prop_assert!(
        (1.0..=CONDITION_CAP).contains(&cond),
        "condition number {}",
        cond
    );
    prop_assert_eq!(solution.observed_bins, observed);
    Ok(())
}

fn solution_bits(s: &Solution) -> (Vec<[u64; 3]>, u64, u64, usize) {
    (
        s.coefficients.iter().map(|r| r.map(f64::to_bits)).collect(),
        s.alpha.to_bits(),
        s.condition_number.to_bits(),
        s.observed_bins,
    )
}

/// Pairs to evaluate lazily: every observed one and a fixed spread over the table.
fn probe_pairs(table: &SparseTable) -> Vec<PairIndex> {
    let mut pairs: Vec<PairIndex> = table.observed().map(|(p, _)| p).collect();
    pairs.extend(PairIndex::all().step_by(10_007));
    pairs.push(PairIndex::from_index(PAIRS - 1));
    pairs
}

/// ρ finite and ≥ 0 on `pairs`, in both orders, bit for bit reciprocal and equal to the batch
/// evaluation.
fn check_reconstruction(recon: &Reconstruction, pairs: &[PairIndex]) -> TestCaseResult {
    let mut batch_values = Vec::new();
    recon.eval_pairs(pairs, &mut batch_values);
    for (&pair, batch_value) in pairs.iter().zip(&batch_values) {
        let (lo, hi) = pair_directions(pair);
        let forward = recon.eval(lo, hi);
        let backward = recon.eval(hi, lo);
        prop_assert!(
            forward.iter().all(|v| v.is_finite() && *v >= 0.0),
            "ρ({}, {}) = {:?}",
            lo,
            hi,
            forward
        );
        prop_assert_eq!(forward.map(f32::to_bits), backward.map(f32::to_bits));
        prop_assert_eq!(forward.map(f32::to_bits), batch_value.map(f32::to_bits));
        prop_assert_eq!(
            forward.map(f32::to_bits),
            recon.eval_pair(pair).map(f32::to_bits)
        );
    }
    Ok(())
}

/// Largest |a − b| over two equally long sequences.
fn max_difference<'a>(a: impl Iterator<Item = &'a f64>, b: impl Iterator<Item = &'a f64>) -> f64 {
    a.zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn max_abs<'a>(a: impl Iterator<Item = &'a f64>) -> f64 {
    a.map(|x| x.abs()).fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------------------------
// Properties
// ---------------------------------------------------------------------------------------------

/// Random sessions: the table follows the model exactly, bad samples change nothing, every
/// solution is finite, the incremental solver equals a batch build, and a second run of the
/// same operations gives the same bits.
#[test]
fn random_sessions_stay_finite_exact_and_equal_a_batch_build() {
    let worst = RefCell::new(Worst::default());
    let strategy = (
        prop::collection::vec(op(), 0..48),
        prop::collection::vec(regularization(), 1..4),
    );
    check(160, strategy, |(ops, regularizations)| {
        let mut session = Session::run(&ops, Regularization::Auto)?;
        session.check_table()?;
        let (table, mut scratch) = batch(
            &session.samples,
            session.table.policy(),
            Regularization::Auto,
        );
        prop_assert_eq!(
            bins_of(&table),
            session.bins(),
            "the sparse table is order-independent"
        );

        // Normal equations: N ≤ I in the PSD order (the rows are orthonormal over the full
        // table), so its entries are at most 1 and the drift of add/remove is absolute.
        let ((n1, r1), (n2, r2)) = (
            session.solver.normal_equations(),
            scratch.normal_equations(),
        );
        let history = session.applied.max(1) as f64;
        let n_drift = max_difference(n1.iter(), n2.iter());
        prop_assert!(
            n_drift <= 16.0 * f64::EPSILON * history,
            "normal matrix drift {:e} after {} changes",
            n_drift,
            session.applied
        );
        let r_scale = max_abs(r2.iter().flatten()).max(1.0);
        let r_drift = max_difference(r1.iter().flatten(), r2.iter().flatten());
        prop_assert!(
            r_drift <= 64.0 * f64::EPSILON * history * r_scale,
            "right-hand side drift {:e} (scale {:e}) after {} changes",
            r_drift,
            r_scale,
            session.applied
        );

        let observed = table.observed_count();
        let describe = || {
            format!(
                "{} samples, {} changes applied",
                session.samples.len(),
                session.applied
            )
        };
        for &regularization in &regularizations {
            session.solver.set_regularization(regularization);
            scratch.set_regularization(regularization);
            let (incremental, fresh) = (session.solver.solve(), scratch.solve());
            check_solution(&incremental, observed)?;
            check_solution(&fresh, observed)?;
            worst.borrow_mut().note(&fresh, regularization, &describe);
            // Perturbation bound for (N + Λ) x = r: relative error ≤ cond · relative drift.
            // Only meaningful while that product is small; past it the problem has no digits
            // left to agree on, and only the rebuilt comparison below applies.
            let cond = fresh.condition_number;
            let scale = max_abs(fresh.coefficients.iter().flatten());
            let bound = 1e3 * cond * f64::EPSILON * history;
            if bound < 1e-6 && !matches!(regularization, Regularization::Gcv) {
                let diff = max_difference(
                    incremental.coefficients.iter().flatten(),
                    fresh.coefficients.iter().flatten(),
                );
                prop_assert!(
                    diff <= bound * scale + 1e-300,
                    "{:?}: coefficients differ by {:e} (scale {:e}, cond {:e})",
                    regularization,
                    diff,
                    scale,
                    cond
                );
            }
        }

        // After an exact rebuild the two solvers hold the same bits and solve identically.
        let mut first_run = session.solver.clone();
        session.solver.rebuild();
        scratch.rebuild();
        prop_assert_eq!(
            session.solver.normal_equations(),
            scratch.normal_equations()
        );
        for &regularization in &regularizations {
            session.solver.set_regularization(regularization);
            scratch.set_regularization(regularization);
            prop_assert_eq!(
                solution_bits(&session.solver.solve()),
                solution_bits(&scratch.solve()),
                "{:?} after rebuild",
                regularization
            );
        }

        // The reconstruction of the default solve.
        session.solver.set_regularization(Regularization::Auto);
        let solution = session.solver.solve();
        let recon = solution.reconstruction(basis());
        check_reconstruction(&recon, &probe_pairs(&table))?;

        // The same operations again: same bits without any rebuild.
        let mut again = Session::run(&ops, Regularization::Auto)?;
        prop_assert_eq!(
            again.solver.normal_equations(),
            first_run.normal_equations()
        );
        for &regularization in &regularizations {
            again.solver.set_regularization(regularization);
            first_run.set_regularization(regularization);
            prop_assert_eq!(
                solution_bits(&again.solver.solve()),
                solution_bits(&first_run.solve())
            );
        }
        Ok(())
    });
    worst.borrow().report("random sessions");
}

/// Whole tables: materialised under pools of 1, 2 and 3 threads, the solution and every entry
/// are the same bits; every entry is finite and ≥ 0 and agrees with lazy evaluation.
#[test]
fn materialised_tables_are_physical_and_thread_count_independent() {
    let pools: Vec<rayon::ThreadPool> = [1, 2, 3]
        .iter()
        .map(|&n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        })
        .collect();
    let worst = RefCell::new(Worst::default());
    let strategy = (prop::collection::vec(op(), 1..48), regularization());
    check(10, strategy, |(ops, regularization)| {
        let session = Session::run(&ops, regularization)?;
        let mut reference: Option<(Solution, burnish::table::SymTable)> = None;
        for pool in &pools {
            let (solution, table) = pool.install(|| {
                let solution = session.solver.solve();
                let table = solution.reconstruction(basis()).materialize();
                (solution, table)
            });
            match &reference {
                None => {
                    check_solution(&solution, session.table.observed_count())?;
                    worst.borrow_mut().note(&solution, regularization, &|| {
                        format!("{} samples", session.samples.len())
                    });
                    prop_assert!(table.is_physical(), "every entry finite and ≥ 0");
                    let recon = solution.reconstruction(basis());
                    for pair in probe_pairs(&session.table) {
                        let (lo, hi) = pair_directions(pair);
                        prop_assert_eq!(table.get(lo, hi), recon.eval(hi, lo));
                    }
                    reference = Some((solution, table));
                }
                Some((first_solution, first_table)) => {
                    prop_assert_eq!(solution_bits(&solution), solution_bits(first_solution));
                    let same = table
                        .pairs()
                        .iter()
                        .zip(first_table.pairs())
                        .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits));
                    prop_assert!(
                        same,
                        "{} threads changed the table",
                        pool.current_num_threads()
                    );
                }
            }
        }
        Ok(())
    });
    worst.borrow().report("materialised tables");
}

/// Many keys with one value in one bin: Min and Max give it back exactly, Mean within rounding,
/// even for values whose sum overflows f64, and the solve equals that of a single sample.
#[test]
fn duplicates_equal_one_sample() {
    let strategy = (
        1..200u32,
        prop_oneof![channel(), Just(f64::MAX), Just(1e308)],
        policy(),
        bin(),
    );
    check(64, strategy, |(count, value, policy, (d_l, d_v))| {
        let rho = [value, value * 0.5, value];
        prop_assume!(expected_rejection(rho).is_none());
        let (mut table, mut single) = (SparseTable::new(policy), SparseTable::new(policy));
        let (mut changes, mut single_changes) = (Vec::new(), Vec::new());
        for pixel in 0..count {
            let key = SampleKey {
                view: pixel % 3,
                pixel,
            };
            table.set_sample(key, d_l, d_v, rho, &mut changes).unwrap();
        }
        single
            .set_sample(
                SampleKey { view: 0, pixel: 0 },
                d_l,
                d_v,
                rho,
                &mut single_changes,
            )
            .unwrap();
        let pair = pair_index(d_l, d_v);
        let value = table.bin_value(pair).unwrap();
        prop_assert!(
            physical(&value),
            "{} duplicates of {:?} gave {:?}",
            count,
            rho,
            value
        );
        for c in 0..3 {
            if policy == Policy::Mean {
                // Naive summation of n equal terms is off by at most n/2 ulps of the sum.
                prop_assert!(
                    (value[c] - rho[c]).abs() <= count as f64 * f64::EPSILON * rho[c],
                    "mean of {} × {} is {}",
                    count,
                    rho[c],
                    value[c]
                );
            } else {
                // −0 is stored as +0.
                prop_assert_eq!(value[c].to_bits(), (rho[c] + 0.0).to_bits());
            }
        }
        // The solver sees the bin value only, so its solution is within rounding of one sample's.
        let mut solver = Solver::new(basis(), Regularization::Auto);
        solver.apply_all(&changes);
        let mut one = Solver::new(basis(), Regularization::Auto);
        one.apply_all(&single_changes);
        let (a, b) = (solver.solve(), one.solve());
        check_solution(&a, 1)?;
        let scale = max_abs(b.coefficients.iter().flatten()).max(1e-300);
        let diff = max_difference(
            a.coefficients.iter().flatten(),
            b.coefficients.iter().flatten(),
        );
        prop_assert!(diff <= 1e-12 * scale, "{:e} vs scale {:e}", diff, scale);
        Ok(())
    });
}

/// Paint concentrated on neighbouring bins (nearly collinear rows), fewer observed bins than K,
/// and every regularisation, hostile parameters included: the solution stays finite, and where
/// the Cholesky factorisation applies its backward error is at rounding level.
#[test]
fn ill_conditioned_systems_give_finite_backward_stable_solutions() {
    let worst = RefCell::new(Worst::default());
    let sample = (key(), collinear_bin(), [channel(), channel(), channel()]);
    let strategy = (
        prop::collection::vec(sample, 1..40),
        prop_oneof![3 => regularization(), 1 => hostile_regularization()],
    );
    check(160, strategy, |(samples, regularization)| {
        let mut session = Session::new(regularization);
        for (key, (d_l, d_v), rho) in samples {
            session.apply(&Op::Set { key, d_l, d_v, rho })?;
        }
        let solution = session.solver.solve();
        let observed = session.table.observed_count();
        // At most the 3 × 3 patch: fewer bins than K = 20 components.
        prop_assert!(observed <= 9, "K above the observed bin count");
        let hostile = match regularization {
            Regularization::Ridge { lambda: v } | Regularization::Prior { alpha: v } => {
                !(v.is_finite() && v >= 0.0)
            }
            _ => false,
        };
        prop_assert!(
            solution
                .coefficients
                .iter()
                .flatten()
                .all(|x| x.is_finite()),
            "{:?}: {:?}",
            regularization,
            solution.coefficients
        );
        let cond = solution.condition_number;
        prop_assert!(
            (1.0..=CONDITION_CAP).contains(&cond),
            "condition number {}",
            cond
        );
        if !hostile {
            worst.borrow_mut().note(&solution, regularization, &|| {
                format!("{observed} neighbouring bins of one slice")
            });
        }
        let recon = solution.reconstruction(basis());
        check_reconstruction(&recon, &probe_pairs(&session.table))?;

        // Backward error of the plain ridge solve: ‖(N + λI) x − r‖ against ‖N + λI‖ ‖x‖ + ‖r‖.
        if let Regularization::Ridge { lambda } = regularization
            && !hostile
        {
            let (n, r) = session.solver.normal_equations();
            let x = &solution.coefficients;
            // The localised prior solves for one coefficient set per band: D = BANDS·K rows.
            let d = x.len();
            let m = |i: usize, j: usize| n[i * d + j] + if i == j { lambda } else { 0.0 };
            let m_norm = (0..d)
                .map(|i| (0..d).map(|j| m(i, j).abs()).sum::<f64>())
                .fold(0.0, f64::max);
            for c in 0..3 {
                let x_norm = max_abs(x.iter().map(|row| &row[c]));
                let r_norm = max_abs(r.iter().map(|row| &row[c]));
                let residual = (0..d)
                    .map(|i| ((0..d).map(|j| m(i, j) * x[j][c]).sum::<f64>() - r[i][c]).abs())
                    .fold(0.0, f64::max);
                prop_assert!(
                    residual <= 1e-9 * (m_norm * x_norm + r_norm) + 1e-300,
                    "λ {:e}, channel {}: residual {:e}, ‖M‖ {:e}, ‖x‖ {:e}, ‖r‖ {:e}, cond {:e}",
                    lambda,
                    c,
                    residual,
                    m_norm,
                    x_norm,
                    r_norm,
                    cond
                );
            }
        }
        Ok(())
    });
    worst.borrow().report("ill-conditioned systems");
}

/// One sample painted at every scale from 1e-6 to 1e6 on each policy: finite, physical, and
/// with huge regularisation the reconstruction falls back to the mean material.
#[test]
fn one_sample_at_any_scale_and_overwhelming_regularisation() {
    let strategy = (
        (-6.0f64..=6.0).prop_map(|e| 10f64.powf(e)),
        bin(),
        prop::sample::select(vec![
            Regularization::Prior { alpha: 1e300 },
            Regularization::Ridge { lambda: 1e300 },
        ]),
    );
    let mean = Reconstruction::mean_material(basis());
    check(48, strategy, |(value, (d_l, d_v), huge)| {
        let mut session = Session::new(Regularization::Auto);
        let key = SampleKey { view: 0, pixel: 0 };
        session.apply(&Op::Set {
            key,
            d_l,
            d_v,
            rho: [value; 3],
        })?;
        let solution = session.solver.solve();
        check_solution(&solution, 1)?;
        let recon = solution.reconstruction(basis());
        check_reconstruction(&recon, &probe_pairs(&session.table))?;

        session.solver.set_regularization(huge);
        let solution = session.solver.solve();
        check_solution(&solution, 1)?;
        let scale = max_abs(solution.coefficients.iter().flatten());
        prop_assert!(scale < 1e-250, "{:?} leaves coefficients {:e}", huge, scale);
        let recon = solution.reconstruction(basis());
        for pair in probe_pairs(&session.table) {
            prop_assert_eq!(recon.eval_pair(pair), mean.eval_pair(pair));
        }
        Ok(())
    });
}
