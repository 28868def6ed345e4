//! `burnish convert`: a material from one format to another, chosen by the extensions.

use crate::export::{BsdfSettings, ExportOptions, Format, export, load_table};
use anyhow::bail;
use std::path::PathBuf;
use std::time::Instant;

/// Whether a `.bsdf` is written isotropic.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Symmetry {
    /// Isotropic when the table departs from its rotation average by under 2%.
    #[default]
    Auto,
    Isotropic,
    Anisotropic,
}

#[derive(clap::Args, Debug)]
#[command(
    after_help = "Formats by extension: .exr (the table image), .binary (MERL), .bsdf \
(RGL tabulated BRDF for Mitsuba 3, pbrt-v4 and Falcor), and for output only .mtlx (MaterialX \
standard_surface) and .gltf (glTF 2.0 material), which are analytic fits whose error is printed."
)]
pub struct ConvertArgs {
    /// The material to read: an EXR table, a MERL binary or a .bsdf.
    #[arg(long = "in", value_name = "FILE")]
    pub input: PathBuf,
    /// Where to write it; the extension picks the format.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// .bsdf: add spectra and wavelengths, as pbrt-v4 and Mitsuba's spectral variants need
    /// (Mitsuba's RGB variants then refuse the file).
    #[arg(long)]
    pub spectral: bool,
    /// .bsdf: isotropic or anisotropic.
    #[arg(long, value_enum, default_value_t = Symmetry::Auto)]
    pub symmetry: Symmetry,
    /// .bsdf: sample-space resolution of each slice (default 64 isotropic, 32 anisotropic).
    #[arg(long, value_parser = clap::value_parser!(u16).range(4..=256))]
    pub grid: Option<u16>,
    /// .mtlx and .gltf: the material's name (default: the output's file name).
    #[arg(long)]
    pub name: Option<String>,
}

pub fn run(args: &ConvertArgs) -> anyhow::Result<()> {
    let Some(output) = Format::from_path(&args.out) else {
        bail!(
            "{}: unknown output format: the extension must be one of .{}",
            args.out.display(),
            Format::extensions().join(", .")
        );
    };
    let start = Instant::now();
    let table = load_table(&args.input)?;
    outln!(
        "read {} in {:.0} ms",
        args.input.display(),
        start.elapsed().as_secs_f64() * 1e3
    );
    let options = ExportOptions {
        bsdf: BsdfSettings {
            isotropic: match args.symmetry {
                Symmetry::Auto => None,
                Symmetry::Isotropic => Some(true),
                Symmetry::Anisotropic => Some(false),
            },
            spectral: args.spectral,
            grid: args.grid.map(usize::from),
            description: format!(
                "Burnish {}: {}",
                env!("CARGO_PKG_VERSION"),
                args.input.file_name().map_or_else(
                    || args.input.display().to_string(),
                    |n| n.to_string_lossy().into()
                )
            ),
        },
        name: args.name.clone(),
    };
    let start = Instant::now();
    super::ensure_parent(&args.out)?;
    let report = export(&args.out, &table, &options)?;
    outln!(
        "wrote {} ({}) in {:.0} ms: {report}",
        args.out.display(),
        output.label(),
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
