//! `burnish suggest`: which view to paint next, from the paintings so far.

use super::reconstruct_cmd::{
    BasisOptions, PaintingSettings, SOLVE_TIMEOUT, ViewArg, load_basis, paint_views, solve_document,
};
use crate::next_view::CANDIDATE_RESOLUTION;
use crate::paint::UnpaintedPixels;
use crate::solver::{Policy, PriorMean, PriorModel, Regularization};
use anyhow::Context;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
#[command(
    after_help = "Candidates: lights spread over the sky (10° to 80° above the horizon) with the last \
view's camera, a third of them with the camera turned 35° aside and 20° up, all on the last view's object. \
Each is scored by the drop in posterior variance of ρ·cos θ_l·cos θ_v over the table that painting it (as the \
current reconstruction predicts) would bring."
)]
pub struct SuggestArgs {
    /// A view painted so far: its scene file and the painting (PNG or EXR). Repeatable.
    #[arg(long = "view", required = true, value_name = "SCENE.toml=PAINTING")]
    pub views: Vec<ViewArg>,
    /// How many candidate views to rank.
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u16).range(1..=1000))]
    pub candidates: u16,
    /// How many of the best to list.
    #[arg(long, default_value_t = 5)]
    pub show: usize,
    /// Write the best candidate as a scene file here (SCENE.md), ready for `burnish guide`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub basis: BasisOptions,
    /// Regularisation, as for `reconstruct`.
    #[arg(long, default_value = "auto")]
    pub lambda: Regularization,
    /// Where the prior is centred: database, fitted:M[+beckmann][+coat] or fitted (as `reconstruct`
    /// reads it).
    #[arg(long, default_value_t = PriorModel::CALIBRATED.mean)]
    pub prior_mean: PriorMean,
}

pub fn run(args: &SuggestArgs) -> anyhow::Result<()> {
    let settings = PaintingSettings {
        basis: args.basis.settings(args.lambda, Policy::Mean),
        prior_mean: args.prior_mean,
        unpainted: UnpaintedPixels::CountAsShown,
    };
    let mut doc = paint_views(&args.views, &[], &settings)?;
    let basis = load_basis(&args.basis)?;
    solve_document(&mut doc, basis)?;
    let start = Instant::now();
    // The document ranks candidates around its active view: the last one added.
    let ranked = doc
        .settled_ranking(args.candidates as usize, SOLVE_TIMEOUT)
        .context("the ranking of candidate views did not arrive")?;
    outln!(
        "ranked {} candidates (bins found at {CANDIDATE_RESOLUTION}²) in {:.1} s",
        ranked.len(),
        start.elapsed().as_secs_f64()
    );
    for (i, r) in ranked.iter().take(args.show.max(1)).enumerate() {
        let (light, camera) = (&r.scene.light, &r.scene.camera);
        outln!(
            "{}. light elevation {:5.1}°, azimuth {:6.1}°; camera yaw {:5.1}°, pitch {:5.1}°: score {:.4e}, {} bins ({} new)",
            i + 1,
            light.elevation_deg,
            light.azimuth_deg,
            camera.yaw_deg,
            camera.pitch_deg,
            r.score,
            r.bins,
            r.new_bins
        );
    }
    if let (Some(path), Some(best)) = (&args.out, ranked.first()) {
        super::ensure_parent(path)?;
        // Scene::save keeps a relative OBJ path valid from the new file's folder.
        best.scene.save(path)?;
        outln!("wrote the best view to {}", path.display());
    }
    Ok(())
}
