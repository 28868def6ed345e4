//! Fuzzes the scene file reader (SCENE.md TOML). Any text gives a scene within range or an
//! error naming the file; a scene that parses saves to TOML that parses back to it.
#![no_main]

use burnish::scene::Scene;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("dir/fuzz.toml");
    match Scene::parse(text, path) {
        Ok(scene) => {
            assert_eq!(scene.check(), Ok(()));
            let again = Scene::parse(&scene.to_toml(), path).expect("a saved scene reads back");
            assert_eq!(again, scene, "a saved scene reads back unchanged");
        }
        Err(e) => assert!(e.to_string().starts_with("dir/fuzz.toml"), "{e}"),
    }
});
