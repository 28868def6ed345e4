//! Fuzzes the OpenEXR readers of BRDF tables (1620 × 1620, finite, non-negative, made
//! reciprocal) and of RGB images in general. Any bytes give a valid result or an error
//! naming the file; a header claiming a huge image in a small file never allocates it.
#![no_main]

use burnish::image_io::decode_exr_rgb;
use burnish::table::exr_file::decode_table_exr;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.exr");
    match decode_exr_rgb(data, path, |_, _| Ok(())) {
        Ok(image) => assert_eq!(image.pixels.len(), image.width * image.height),
        Err(e) => assert!(e.to_string().starts_with("fuzz.exr"), "{e}"),
    }
    match decode_table_exr(data, path) {
        Ok(table) => {
            for pair in table.pairs().iter().step_by(4099) {
                assert!(pair.iter().all(|v| v.is_finite() && *v >= 0.0));
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.exr"), "{e}"),
    }
});
