//! Fuzzes the MERL binary reader: any bytes give a BRDF of the exact MERL size or an error
//! naming the file.
#![no_main]

use burnish::table::merl::MerlBrdf;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    match MerlBrdf::from_bytes(data, Path::new("fuzz.binary")) {
        Ok(merl) => {
            // Every entry reads as a finite, non-negative ρ.
            for i in (0..burnish::table::merl::MERL_ENTRIES).step_by(997) {
                assert!(merl.rho(i).iter().all(|v| v.is_finite() && *v >= 0.0));
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.binary"), "{e}"),
    }
});
