//! Brush presets: small TOML files naming a brush, its settings and optionally a tip image.
//! The format is described in brushes/README.md.

use super::dab::TipMask;
use super::settings::BrushSettings;
use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// A named brush as the palette offers it.
#[derive(Clone, Debug, PartialEq)]
pub struct BrushPreset {
    pub name: String,
    pub settings: BrushSettings,
    /// The tip image that replaces the round dab, if the preset names one.
    pub tip: Option<Arc<TipMask>>,
}

/// A preset file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PresetFile {
    name: String,
    tip: Option<String>,
    brush: BrushSettings,
}

/// Reads one preset file. Errors name the file and the problem: unreadable or bad TOML,
/// unknown keys, a missing `[brush]` table, settings out of range, a tip that cannot be read.
pub fn load_preset(path: &Path) -> Result<BrushPreset> {
    let text = crate::bounded_read::read_text_at_most(path, PRESET_LIMIT, "a brush preset")?;
    parse_preset(&text, path, TipMask::load_png)
}

/// The most bytes a preset file may have; a real one has a few hundred.
const PRESET_LIMIT: u64 = 1 << 20;

/// [`load_preset`] of a preset's text, as if read from `path` (which names it in errors);
/// `load_tip` reads the tip image the preset names, given its path beside the preset.
pub fn parse_preset(
    text: &str,
    path: &Path,
    load_tip: impl FnOnce(&Path) -> Result<TipMask>,
) -> Result<BrushPreset> {
    let file: PresetFile = toml::from_str(text)
        .map_err(|e| Error::invalid(path, format!("not a valid brush preset: {e}")))?;
    let name = file.name.trim();
    if name.is_empty() {
        return Err(Error::invalid(path, "the preset's name is empty"));
    }
    file.brush
        .check()
        .map_err(|problem| Error::invalid(path, format!("[brush] {problem}")))?;
    let tip = match &file.tip {
        None => None,
        Some(tip) => {
            let tip_path = path.parent().unwrap_or(Path::new(".")).join(tip);
            let mask = load_tip(&tip_path)
                .map_err(|e| Error::invalid(path, format!("tip \"{tip}\": {e}")))?;
            Some(Arc::new(mask))
        }
    };
    Ok(BrushPreset {
        name: name.to_owned(),
        settings: file.brush,
        tip,
    })
}

/// Reads every `*.toml` preset in `dir`, in file-name order. Presets that cannot be read are
/// skipped and reported; an unreadable directory is one error and no presets.
pub fn load_presets(dir: &Path) -> (Vec<BrushPreset>, Vec<Error>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) => return (Vec::new(), vec![Error::io(dir, e)]),
    };
    let mut errors = Vec::new();
    let mut paths = Vec::new();
    for entry in entries {
        match entry {
            Ok(entry) => {
                let path = entry.path();
                if path.extension().is_some_and(|e| e == "toml") && path.is_file() {
                    paths.push(path);
                }
            }
            Err(e) => errors.push(Error::io(dir, e)),
        }
    }
    paths.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    let mut presets = Vec::new();
    for path in paths {
        match load_preset(&path) {
            Ok(preset) => presets.push(preset),
            Err(e) => errors.push(e),
        }
    }
    (presets, errors)
}
