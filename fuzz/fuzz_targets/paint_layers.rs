//! Fuzzes the paint layer readers: a session view's colour and coverage EXRs, and a
//! painting imported as EXR or PNG. The first byte picks the canvas side (1 to 64), the
//! second where the rest splits into the two layers. Results are checked: the right size,
//! finite colours, coverage in [0, 1]; errors name the entry or the file.
#![no_main]

use burnish::scene::decode_painting;
use burnish::session::decode_paint_layers;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let [side, split, rest @ ..] = data else {
        return;
    };
    let side = 1 + (*side as usize % 64);
    let split = (*split as usize * rest.len() / 255).min(rest.len());
    let (colour, coverage) = rest.split_at(split);
    match decode_paint_layers(colour, coverage, side) {
        Ok(layers) => {
            assert_eq!(layers.coverage.len(), side * side);
            assert_eq!(layers.colour.pixels.len(), side * side);
            assert!(layers.coverage.iter().all(|c| (0.0..=1.0).contains(c)));
            assert!(layers.colour.pixels.iter().flatten().all(|c| c.is_finite()));
        }
        Err(e) => assert!(
            e.starts_with("colour.exr") || e.starts_with("coverage.exr"),
            "{e}"
        ),
    }
    for name in ["fuzz.exr", "fuzz.png"] {
        match decode_painting(rest, Path::new(name), side) {
            Ok(image) => {
                assert_eq!((image.width, image.height), (side, side));
                assert_eq!(image.pixels.len(), side * side);
            }
            Err(e) => assert!(e.to_string().starts_with(name), "{e}"),
        }
    }
});
