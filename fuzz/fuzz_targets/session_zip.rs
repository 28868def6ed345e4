//! Fuzzes the session reader (`.burnish` files and recovery files): a zip archive with a TOML
//! manifest, scene TOML, EXR paint layers and embedded OBJ objects. Any bytes must give a
//! session that passes its own checks or an error naming the file; never a panic, never an
//! allocation out of proportion to the input.
#![no_main]

use burnish::session::Session;
use libfuzzer_sys::fuzz_target;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Where a valid session's embedded objects are extracted: a folder of this process's own.
fn object_cache() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| std::env::temp_dir().join(format!("burnish-fuzz-{}", std::process::id())))
}

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.burnish");
    match Session::from_bytes(data, path, object_cache()) {
        Ok(session) => {
            assert_eq!(session.check(), Ok(()), "an opened session is valid");
        }
        Err(e) => {
            assert!(e.to_string().starts_with("fuzz.burnish"), "{e}");
        }
    }
});
