//! What the benchmarks share for `cargo test`, which builds them and runs each once to check
//! that it still works (criterion's test mode): the test-mode check and a basis small enough
//! to build in seconds there.

use burnish::basis::{Basis, BasisSpec, build_basis};
use burnish::materials::database::DatabaseSpec;

/// Whether this run only checks that the benchmarks work: `cargo test` passes no `--bench`
/// (`cargo bench` does), the rule by which criterion picks its test mode.
pub fn test_mode() -> bool {
    let has = |flag: &str| std::env::args().any(|a| a == flag);
    !has("--bench") || has("--test")
}

/// A basis of `k` components from 24 materials and one power iteration: meaningless as a
/// material space, but the same shapes and code paths as the default one, in a few seconds.
pub fn check_basis_spec(k: usize) -> BasisSpec {
    BasisSpec {
        database: DatabaseSpec { seed: 7, size: 24 },
        components: k,
        oversampling: 4,
        power_iterations: 1,
    }
}

pub fn check_basis(k: usize) -> Basis {
    build_basis(&check_basis_spec(k), &|_| {})
}
