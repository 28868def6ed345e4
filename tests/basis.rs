//! The basis: its algebra, its determinism, and a cache that is never trusted blind.

use burnish::basis::{BasisCache, BasisSpec, CacheOutcome, build_basis};
use burnish::materials::database::DatabaseSpec;
use burnish::table::{PairIndex, pair_multiplicity};

fn tiny_spec() -> BasisSpec {
    BasisSpec {
        database: DatabaseSpec { seed: 3, size: 12 },
        components: 4,
        oversampling: 6,
        power_iterations: 2,
    }
}

#[test]
fn components_are_orthonormal_over_the_full_table_and_sorted() {
    let basis = build_basis(&tiny_spec(), &|_| {});
    let k = basis.components();
    assert_eq!(k, 4);
    let mut gram = vec![0f64; k * k];
    for p in PairIndex::all() {
        let w = pair_multiplicity(p);
        let row = basis.row(p);
        for i in 0..k {
            for j in 0..k {
                gram[i * k + j] += w * row[i] as f64 * row[j] as f64;
            }
        }
    }
    for i in 0..k {
        for j in 0..k {
            let expected = if i == j { 1.0 } else { 0.0 };
            assert!(
                (gram[i * k + j] - expected).abs() < 1e-4,
                "gram[{i}][{j}] = {}",
                gram[i * k + j]
            );
        }
    }
    let v = basis.variances();
    assert!(
        v.windows(2).all(|w| w[0] >= w[1]) && v[k - 1] > 0.0,
        "{v:?}"
    );
    assert!(
        basis
            .lowers()
            .iter()
            .zip(basis.uppers())
            .all(|(l, u)| l <= u)
    );
    assert!(
        basis
            .references()
            .iter()
            .all(|r| r.is_finite() && *r >= 0.0)
    );
}

#[test]
fn the_build_is_bit_identical_across_thread_counts() {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let a = one.install(|| build_basis(&tiny_spec(), &|_| {}));
    let b = two.install(|| build_basis(&tiny_spec(), &|_| {}));
    assert_eq!(a.variances(), b.variances());
    assert!(
        a.rows()
            .iter()
            .zip(b.rows())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
    assert!(
        a.references()
            .iter()
            .zip(b.references())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
}

#[test]
fn a_stale_truncated_or_corrupt_cache_is_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let cache = BasisCache::at(dir.path().to_path_buf());
    let spec = tiny_spec();
    let stages = std::sync::Mutex::new(Vec::new());
    let (built, outcome) = cache
        .load_or_build(&spec, false, &|p| stages.lock().unwrap().push(p.stage))
        .unwrap();
    assert_eq!(outcome, CacheOutcome::Built);
    {
        let stages = stages.lock().unwrap();
        assert!(
            stages.iter().any(|s| s.starts_with("pass 1")) && stages.last() == Some(&"done"),
            "progress is reported: {stages:?}"
        );
    }

    let (loaded, outcome) = cache.load_or_build(&spec, false, &|_| {}).unwrap();
    assert_eq!(outcome, CacheOutcome::Loaded);
    assert_eq!(loaded.variances(), built.variances());
    assert!(
        loaded
            .rows()
            .iter()
            .zip(built.rows())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
    assert_eq!(loaded.means(), built.means());

    let path = cache.path_for(&spec);
    let pristine = std::fs::read(&path).unwrap();
    type Corruption = Box<dyn Fn(&mut Vec<u8>)>;
    let corruptions: [(&str, Corruption); 4] = [
        (
            "checksum",
            Box::new(|b: &mut Vec<u8>| {
                let i = b.len() / 2;
                b[i] ^= 0x40;
            }),
        ),
        (
            "truncated",
            Box::new(|b: &mut Vec<u8>| b.truncate(b.len() - 1000)),
        ),
        ("truncated", Box::new(|b: &mut Vec<u8>| b.truncate(100))),
        ("stale", Box::new(|b: &mut Vec<u8>| b[8] = 99)),
    ];
    for (expected, corrupt) in corruptions {
        let mut bytes = pristine.clone();
        corrupt(&mut bytes);
        std::fs::write(&path, &bytes).unwrap();
        match cache.load_or_build(&spec, false, &|_| {}).unwrap() {
            (rebuilt, CacheOutcome::Rebuilt { reason }) => {
                assert!(
                    reason.contains(expected),
                    "expected '{expected}' in: {reason}"
                );
                assert!(
                    reason.contains(&path.display().to_string()),
                    "the reason names the file: {reason}"
                );
                assert_eq!(rebuilt.variances(), built.variances());
            }
            (_, other) => panic!("corruption '{expected}' was not detected: {other:?}"),
        }
        assert_eq!(
            std::fs::read(&path).unwrap(),
            pristine,
            "the rebuilt cache replaced the bad one"
        );
    }

    // Another spec's file at this spec's path is stale, not trusted.
    let other = BasisSpec {
        components: 3,
        ..spec
    };
    let (_, _) = cache.load_or_build(&other, false, &|_| {}).unwrap();
    std::fs::copy(cache.path_for(&other), &path).unwrap();
    let (_, outcome) = cache.load_or_build(&spec, false, &|_| {}).unwrap();
    assert!(
        matches!(outcome, CacheOutcome::Rebuilt { ref reason } if reason.contains("stale")),
        "{outcome:?}"
    );

    // A forced rebuild rebuilds.
    let (_, outcome) = cache.load_or_build(&spec, true, &|_| {}).unwrap();
    assert_eq!(outcome, CacheOutcome::Built);
}
