//! A fitted [`StandardSurface`] as a MaterialX document: one `standard_surface` shader
//! node (MaterialX 1.38 standard library) and the `surfacematerial` that uses it.
//!
//! Parameter mapping: `specular_roughness` r and `specular_anisotropy` a give the GGX α of
//! MaterialX's `mx_roughness_anisotropy`: α_t = r²/√(1 − a) along the tangent turned by
//! `specular_rotation` (a fraction of a full turn), α_b = r²√(1 − a); so r = (α_x α_y)^¼ and
//! a = 1 − α_b/α_t with α_t the larger α. `coat_roughness` is √α, `sheen` 1 with the sheen
//! colour (weight folded in) and `sheen_roughness` the Charlie r as MaterialX's sheen BSDF
//! takes it. The IORs are 1.5 and every colour is linear Rec. 709.

use super::standard_surface::{IOR, StandardSurface};
use crate::error::Result;
use crate::fs_atomic::write_atomically;
use std::f64::consts::{FRAC_PI_2, TAU};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// The (roughness, anisotropy, rotation in turns) MaterialX takes for GGX α_x, α_y along a
/// tangent turned by `rotation` radians.
pub fn roughness_anisotropy(alpha_x: f64, alpha_y: f64, rotation: f64) -> (f64, f64, f64) {
    let (tangent, bitangent, rotation) = if alpha_x >= alpha_y {
        (alpha_x, alpha_y, rotation)
    } else {
        (alpha_y, alpha_x, rotation + FRAC_PI_2)
    };
    let roughness = (tangent * bitangent).sqrt().sqrt();
    // MaterialX clamps a to 0.98.
    let anisotropy = (1.0 - bitangent / tangent).clamp(0.0, 0.98);
    (roughness, anisotropy, rotation.rem_euclid(TAU) / TAU)
}

/// Escapes text for an XML attribute value.
fn escape(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '&' => "&amp;".into(),
            '<' => "&lt;".into(),
            '>' => "&gt;".into(),
            '"' => "&quot;".into(),
            '\'' => "&apos;".into(),
            c if c.is_control() => " ".into(),
            c => c.to_string(),
        })
        .collect()
}

/// A MaterialX name: letters, digits and underscores, not starting with a digit.
fn node_name(text: &str) -> String {
    let mut name: String = text
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
        name.insert_str(0, "m_");
    }
    name
}

/// The document's text.
pub fn document(name: &str, m: &StandardSurface) -> String {
    let (roughness, anisotropy, rotation) = roughness_anisotropy(m.alpha_x, m.alpha_y, m.rotation);
    let sheen_max = m.sheen_color.iter().cloned().fold(0.0, f64::max);
    let sheen_color = if sheen_max > 0.0 {
        m.sheen_color.map(|c| c / sheen_max)
    } else {
        [1.0; 3]
    };
    let shader = format!("SR_{}", node_name(name));
    let material = node_name(name);
    let mut inputs = String::new();
    let mut input = |n: &str, t: &str, v: String| {
        let _ = writeln!(
            inputs,
            "    <input name=\"{n}\" type=\"{t}\" value=\"{v}\" />"
        );
    };
    let f = |x: f64| format!("{:.6}", x);
    let c = |x: [f64; 3]| format!("{:.6}, {:.6}, {:.6}", x[0], x[1], x[2]);
    input("base", "float", f(1.0));
    input("base_color", "color3", c(m.base_color));
    input("metalness", "float", f(m.metalness));
    input("specular", "float", f(m.specular));
    input("specular_color", "color3", c([1.0; 3]));
    input("specular_roughness", "float", f(roughness));
    input("specular_IOR", "float", f(IOR));
    input("specular_anisotropy", "float", f(anisotropy));
    input("specular_rotation", "float", f(rotation));
    input("sheen", "float", f(sheen_max.min(1.0)));
    input("sheen_color", "color3", c(sheen_color));
    input("sheen_roughness", "float", f(m.sheen_roughness));
    input("coat", "float", f(m.coat));
    input("coat_color", "color3", c([1.0; 3]));
    input("coat_roughness", "float", f(m.coat_alpha.sqrt()));
    input("coat_IOR", "float", f(IOR));
    format!(
        "<?xml version=\"1.0\"?>\n\
         <!-- {}: an analytic approximation fitted by Burnish to a painted BRDF table -->\n\
         <materialx version=\"1.38\" colorspace=\"lin_rec709\">\n  \
         <standard_surface name=\"{shader}\" type=\"surfaceshader\">\n{inputs}  \
         </standard_surface>\n  \
         <surfacematerial name=\"{material}\" type=\"material\">\n    \
         <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"{shader}\" />\n  \
         </surfacematerial>\n\
         </materialx>\n",
        escape(name).replace("--", "- -"),
    )
}

/// Writes the document atomically.
pub fn write(path: &Path, name: &str, m: &StandardSurface) -> Result<()> {
    let text = document(name, m);
    write_atomically(path, |w| w.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anisotropy_maps_back_to_the_alphas() {
        let (r, a, turns) = roughness_anisotropy(0.4, 0.1, 0.3);
        let r2 = r * r;
        let aspect = (1.0 - a).sqrt();
        assert!((r2 / aspect - 0.4).abs() < 1e-9 && (r2 * aspect - 0.1).abs() < 1e-9);
        assert!((turns * TAU - 0.3).abs() < 1e-12);
        // The larger α along the bitangent turns the tangent a quarter.
        let (_, _, turns) = roughness_anisotropy(0.1, 0.4, 0.3);
        assert!((turns * TAU - 0.3 - FRAC_PI_2).abs() < 1e-12);
        let (r, a, _) = roughness_anisotropy(0.09, 0.09, 0.0);
        assert!((r - 0.3).abs() < 1e-12 && a == 0.0);
    }

    #[test]
    fn names_are_escaped() {
        let doc = document("a <b> & \"c\" 1", &StandardSurface::default());
        assert!(doc.contains("name=\"SR_a__b_____c__1\""), "{doc}");
        assert!(doc.contains("a &lt;b&gt; &amp; &quot;c&quot; 1"), "{doc}");
        assert!(doc.contains("<input name=\"specular_roughness\""));
    }
}
