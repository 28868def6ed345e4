//! Fuzzes brush presets: the preset TOML and the PNG tip it may name. The input is the TOML
//! text, a zero byte, then the tip's PNG bytes. A preset that loads has settings in range and
//! a tip of bounded size; errors name the preset file.
#![no_main]

use burnish::paint::{MAX_TIP_SIDE, TipMask, parse_preset};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let (text, png) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let Ok(text) = std::str::from_utf8(text) else {
        return;
    };
    let path = Path::new("brushes/fuzz.toml");
    match parse_preset(text, path, |tip| TipMask::from_png(png, tip)) {
        Ok(preset) => {
            assert_eq!(preset.settings.check(), Ok(()));
            assert!(!preset.name.trim().is_empty());
            if let Some(tip) = preset.tip {
                assert!(tip.width() <= MAX_TIP_SIDE && tip.height() <= MAX_TIP_SIDE);
            }
        }
        Err(e) => assert!(e.to_string().starts_with("brushes/fuzz.toml"), "{e}"),
    }
});
