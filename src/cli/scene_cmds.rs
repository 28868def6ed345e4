//! `burnish guide` and `burnish render`: a scene's guide image, and the object rendered with a
//! table BRDF exactly as a perfect painter would paint it.

use crate::scene::{GBuffer, Object, Scene, guide_image, render_table, write_image, write_png};
use crate::table::exr_file::read_table_exr;
use anyhow::Context;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct GuideArgs {
    /// The scene file (SCENE.md).
    #[arg(long)]
    pub scene: PathBuf,
    /// Where to write the guide PNG.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// The scene file (SCENE.md).
    #[arg(long)]
    pub scene: PathBuf,
    /// The BRDF table, an EXR as TABLE.md defines it.
    #[arg(long)]
    pub brdf: PathBuf,
    /// Output image: .png (sRGB, clipped) or .exr (linear).
    #[arg(long)]
    pub out: PathBuf,
}

/// Loads a scene and builds its geometry buffer, with what it took.
pub(crate) fn scene_gbuffer(path: &std::path::Path) -> anyhow::Result<(Scene, GBuffer)> {
    let scene = Scene::load(path)?;
    let object = Object::load(&scene.object_source())
        .with_context(|| format!("loading the object of scene {}", path.display()))?;
    let gbuffer = GBuffer::build(&scene, &object);
    Ok((scene, gbuffer))
}

pub fn guide(args: &GuideArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let (_, gbuffer) = scene_gbuffer(&args.scene)?;
    super::ensure_parent(&args.out)?;
    write_png(&args.out, &guide_image(&gbuffer))?;
    outln!(
        "guide written to {} ({} × {}, {} pixels on the object) in {:.0} ms",
        args.out.display(),
        gbuffer.resolution(),
        gbuffer.resolution(),
        gbuffer.covered_count(),
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

pub fn render(args: &RenderArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let table = read_table_exr(&args.brdf)?;
    let (_, gbuffer) = scene_gbuffer(&args.scene)?;
    super::ensure_parent(&args.out)?;
    write_image(&args.out, &render_table(&gbuffer, &table))?;
    outln!(
        "render written to {} in {:.0} ms",
        args.out.display(),
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
