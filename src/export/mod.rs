//! Export to the renderers people use, and import of existing materials.
//!
//! - [`rgl`]: the RGL tabulated format (`.bsdf`) of Dupuy & Jakob 2018, read by Mitsuba 3,
//!   pbrt-v4 and Falcor; written from a table and read back as those readers evaluate it.
//! - [`standard_surface`]: an analytic approximation (Autodesk Standard Surface parameters)
//!   fitted to a table, written as MaterialX ([`materialx`]) and glTF 2.0 ([`gltf`]).
//! - [`load_table`] and [`export`] choose the format by the file's extension: `.exr` (the
//!   table image of TABLE.md), `.binary` (MERL), `.bsdf`, `.mtlx`, `.gltf`.

pub mod exact;
pub mod gltf;
pub mod grid;
pub mod materialx;
pub mod ndf;
pub mod rgl;
pub mod spectrum;
pub mod standard_surface;
pub mod tensor;
pub mod warp;

use crate::error::{Error, Result};
use crate::table::SymTable;
use crate::table::exr_file::{read_table_exr, write_table_exr};
use crate::table::merl::MerlBrdf;
use std::path::Path;

pub use rgl::{BsdfReport, BsdfSettings, RglBsdf};
pub use standard_surface::{FitReport, StandardSurface};

/// A material file format, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `.exr`: the 1620 × 1620 table image (TABLE.md).
    ExrTable,
    /// `.binary`: the MERL isotropic binary.
    Merl,
    /// `.bsdf`: the RGL tabulated format.
    RglBsdf,
    /// `.mtlx`: MaterialX `standard_surface` (an analytic fit).
    MaterialX,
    /// `.gltf`: a glTF 2.0 material (an analytic fit).
    Gltf,
}

impl Format {
    pub const ALL: [Format; 5] = [
        Self::ExrTable,
        Self::Merl,
        Self::RglBsdf,
        Self::MaterialX,
        Self::Gltf,
    ];

    /// The format a path's extension names (case-insensitive).
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Self::ALL.into_iter().find(|f| f.extension() == ext)
    }

    pub fn extension(self) -> &'static str {
        match self {
            Self::ExrTable => "exr",
            Self::Merl => "binary",
            Self::RglBsdf => "bsdf",
            Self::MaterialX => "mtlx",
            Self::Gltf => "gltf",
        }
    }

    /// What the format is, for menus and messages.
    pub fn label(self) -> &'static str {
        match self {
            Self::ExrTable => "EXR table",
            Self::Merl => "MERL binary",
            Self::RglBsdf => "RGL tabulated BRDF (Mitsuba 3, pbrt-v4, Falcor)",
            Self::MaterialX => "MaterialX standard_surface (analytic fit)",
            Self::Gltf => "glTF 2.0 material (analytic fit)",
        }
    }

    /// Whether a table can be read from the format (the analytic ones are export only).
    pub fn is_readable(self) -> bool {
        matches!(self, Self::ExrTable | Self::Merl | Self::RglBsdf)
    }

    /// The extensions of the readable formats.
    pub fn readable_extensions() -> Vec<&'static str> {
        Self::ALL
            .into_iter()
            .filter(|f| f.is_readable())
            .map(Self::extension)
            .collect()
    }

    /// The extensions of every format.
    pub fn extensions() -> Vec<&'static str> {
        Self::ALL.into_iter().map(Self::extension).collect()
    }
}

fn format_of(path: &Path) -> Result<Format> {
    Format::from_path(path).ok_or_else(|| {
        Error::invalid(
            path,
            format!(
                "unknown material format: the extension must be one of .{}",
                Format::extensions().join(", .")
            ),
        )
    })
}

/// Reads a material as a table: an EXR table, a MERL binary or a `.bsdf` (evaluated at
/// every pair of bin centres). The table is checked to be finite and ≥ 0.
pub fn load_table(path: &Path) -> Result<SymTable> {
    let table = match format_of(path)? {
        Format::ExrTable => read_table_exr(path)?,
        Format::Merl => crate::materials::tabulate(&MerlBrdf::read(path)?),
        Format::RglBsdf => crate::materials::tabulate(&RglBsdf::read(path)?),
        f @ (Format::MaterialX | Format::Gltf) => {
            return Err(Error::invalid(
                path,
                format!(
                    "a {} is an approximation Burnish writes, not a material it reads; \
                     open an .exr table, a MERL .binary or a .bsdf",
                    f.label()
                ),
            ));
        }
    };
    if !table.is_physical() {
        return Err(Error::invalid(
            path,
            "the material has values that are negative or not finite",
        ));
    }
    Ok(table)
}

/// How [`export`] writes the formats that have choices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportOptions {
    pub bsdf: BsdfSettings,
    /// The material's name in MaterialX and glTF files.
    pub name: Option<String>,
}

/// What [`export`] wrote, with the figures a user needs to judge it.
#[derive(Clone, Debug, PartialEq)]
pub enum ExportReport {
    Table,
    Merl,
    Bsdf(BsdfReport),
    Analytic(FitReport),
}

impl std::fmt::Display for ExportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Table => write!(f, "1620 × 1620 table"),
            Self::Merl => write!(f, "MERL isotropic binary (anisotropy averaged out)"),
            Self::Bsdf(r) => write!(
                f,
                "{} {} .bsdf: {} × {} slices of {} × {}, {:.1} MB (anisotropy {:.1}%)",
                if r.isotropic {
                    "isotropic"
                } else {
                    "anisotropic"
                },
                if r.spectral { "spectral + RGB" } else { "RGB" },
                r.phi_slices,
                r.theta_slices,
                r.grid,
                r.grid,
                r.bytes as f64 / 1e6,
                100.0 * r.anisotropy
            ),
            Self::Analytic(r) => write!(f, "{r}"),
        }
    }
}

/// A name for the material from the output path's file stem.
fn material_name(path: &Path, options: &ExportOptions) -> String {
    options.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "burnish".into())
    })
}

/// Writes a table in the format `path`'s extension names, atomically.
pub fn export(path: &Path, table: &SymTable, options: &ExportOptions) -> Result<ExportReport> {
    match format_of(path)? {
        Format::ExrTable => {
            write_table_exr(path, table)?;
            Ok(ExportReport::Table)
        }
        Format::Merl => {
            MerlBrdf::from_table(table).write(path)?;
            Ok(ExportReport::Merl)
        }
        Format::RglBsdf => Ok(ExportReport::Bsdf(rgl::write_bsdf(
            path,
            table,
            &options.bsdf,
        )?)),
        Format::MaterialX => {
            let fit = standard_surface::fit(table);
            materialx::write(path, &material_name(path, options), &fit.model)?;
            Ok(ExportReport::Analytic(fit))
        }
        Format::Gltf => {
            let fit = standard_surface::fit(table);
            gltf::write(path, &material_name(path, options), &fit.model)?;
            Ok(ExportReport::Analytic(fit))
        }
    }
}
