//! A fitted [`StandardSurface`] as a glTF 2.0 material (a `.gltf` JSON file with one
//! material and no meshes): the PBR metallic-roughness core plus `KHR_materials_specular`,
//! `KHR_materials_sheen`, `KHR_materials_clearcoat` and `KHR_materials_anisotropy`.
//!
//! Parameter mapping (the extensions' specifications): `roughnessFactor` r gives α = r² along
//! the bitangent; `anisotropyStrength` s raises the tangent's α to α + (1 − α)s², the tangent
//! turned by `anisotropyRotation` radians; so r = √α_b and s = √((α_t − α_b)/(1 − α_b)) with
//! α_t the larger α. `clearcoatRoughnessFactor` is √α of the coat; `sheenRoughnessFactor` is
//! √r of the Charlie roughness (the reference viewer squares it); `specularFactor` scales the
//! dielectric F₀ = 0.04 (IOR 1.5). Colours are linear.

use super::standard_surface::StandardSurface;
use crate::error::Result;
use crate::fs_atomic::write_atomically;
use serde_json::{Value, json};
use std::f64::consts::{FRAC_PI_2, PI};
use std::io::Write as _;
use std::path::Path;

/// (roughnessFactor, anisotropyStrength, anisotropyRotation) for GGX α_x, α_y along a
/// tangent turned by `rotation` radians.
pub fn roughness_anisotropy(alpha_x: f64, alpha_y: f64, rotation: f64) -> (f64, f64, f64) {
    let (tangent, bitangent, rotation) = if alpha_x >= alpha_y {
        (alpha_x, alpha_y, rotation)
    } else {
        (alpha_y, alpha_x, rotation + FRAC_PI_2)
    };
    let strength = if bitangent < 1.0 {
        ((tangent - bitangent) / (1.0 - bitangent))
            .clamp(0.0, 1.0)
            .sqrt()
    } else {
        0.0
    };
    (bitangent.sqrt(), strength, rotation.rem_euclid(PI))
}

/// Rounds for a readable file (six decimals is below any rendering difference).
fn r6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

/// The glTF document.
pub fn document(name: &str, m: &StandardSurface) -> Value {
    let (roughness, strength, rotation) = roughness_anisotropy(m.alpha_x, m.alpha_y, m.rotation);
    let mut extensions = serde_json::Map::new();
    let mut used = vec!["KHR_materials_specular"];
    extensions.insert(
        "KHR_materials_specular".into(),
        json!({ "specularFactor": r6(m.specular) }),
    );
    if m.sheen_color.iter().any(|&c| c > 0.0) {
        used.push("KHR_materials_sheen");
        extensions.insert(
            "KHR_materials_sheen".into(),
            json!({
                "sheenColorFactor": m.sheen_color.map(r6),
                "sheenRoughnessFactor": r6(m.sheen_roughness.sqrt()),
            }),
        );
    }
    if m.coat > 0.0 {
        used.push("KHR_materials_clearcoat");
        extensions.insert(
            "KHR_materials_clearcoat".into(),
            json!({
                "clearcoatFactor": r6(m.coat),
                "clearcoatRoughnessFactor": r6(m.coat_alpha.sqrt()),
            }),
        );
    }
    if strength > 0.0 {
        used.push("KHR_materials_anisotropy");
        extensions.insert(
            "KHR_materials_anisotropy".into(),
            json!({
                "anisotropyStrength": r6(strength),
                "anisotropyRotation": r6(rotation),
            }),
        );
    }
    let b = m.base_color.map(r6);
    json!({
        "asset": {
            "version": "2.0",
            "generator": format!("Burnish {}", env!("CARGO_PKG_VERSION")),
        },
        "extensionsUsed": used,
        "materials": [{
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [b[0], b[1], b[2], 1.0],
                "metallicFactor": r6(m.metalness),
                "roughnessFactor": r6(roughness),
            },
            "extensions": extensions,
        }],
    })
}

/// Writes the document atomically, pretty-printed.
pub fn write(path: &Path, name: &str, m: &StandardSurface) -> Result<()> {
    let text = serde_json::to_string_pretty(&document(name, m)).expect("a JSON value serialises");
    write_atomically(path, |w| w.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anisotropy_maps_back_to_the_alphas() {
        let (r, s, rot) = roughness_anisotropy(0.5, 0.1, 0.2);
        let alpha = r * r;
        assert!((alpha - 0.1).abs() < 1e-12);
        assert!((alpha + (1.0 - alpha) * s * s - 0.5).abs() < 1e-12);
        assert!((rot - 0.2).abs() < 1e-12);
        let (_, s, _) = roughness_anisotropy(0.3, 0.3, 0.0);
        assert_eq!(s, 0.0);
    }

    #[test]
    fn extensions_appear_only_when_used() {
        let plain = document("plain", &StandardSurface::default());
        let used = plain["extensionsUsed"].as_array().unwrap();
        assert_eq!(used.len(), 1);
        assert!(plain["materials"][0]["extensions"]["KHR_materials_sheen"].is_null());
        let cloth = document(
            "cloth",
            &StandardSurface {
                sheen_color: [0.2, 0.1, 0.4],
                coat: 0.5,
                alpha_x: 0.4,
                alpha_y: 0.1,
                ..Default::default()
            },
        );
        let ext = &cloth["materials"][0]["extensions"];
        assert_eq!(ext["KHR_materials_sheen"]["sheenColorFactor"][2], 0.4);
        assert!(
            ext["KHR_materials_clearcoat"]["clearcoatFactor"]
                .as_f64()
                .unwrap()
                > 0.0
        );
        assert!(
            ext["KHR_materials_anisotropy"]["anisotropyStrength"]
                .as_f64()
                .unwrap()
                > 0.0
        );
        assert_eq!(cloth["asset"]["version"], "2.0");
    }
}
