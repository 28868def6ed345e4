//! `burnish app` (and `burnish` alone): the painting window.

use crate::app::AppConfig;
use crate::scene::Scene;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Default)]
pub struct AppArgs {
    /// A session file to open.
    #[arg(long)]
    pub session: Option<PathBuf>,
    /// The first view's scene (SCENE.md); the default sphere view without it.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Basis components K.
    #[arg(long)]
    pub components: Option<usize>,
    /// Materials in the basis database.
    #[arg(long)]
    pub materials: Option<usize>,
    /// Don't autosave to the recovery file.
    #[arg(long)]
    pub no_autosave: bool,
    /// Reopen the recovery file a crash left, without asking.
    #[arg(long, conflicts_with = "no_autosave")]
    pub recover: bool,
}

pub fn run(args: &AppArgs) -> anyhow::Result<()> {
    let mut config = AppConfig {
        session: args.session.clone(),
        autosave: !args.no_autosave,
        recover: args.recover,
        ..AppConfig::default()
    };
    if let Some(path) = &args.scene {
        config.scene = Scene::load(path)?;
    }
    if let Some(k) = args.components {
        anyhow::ensure!(
            (1..=crate::basis::BasisSpec::MAX_COMPONENTS).contains(&k),
            "--components {k}: K must be 1 to {}",
            crate::basis::BasisSpec::MAX_COMPONENTS
        );
        config.basis_settings.components = k;
    }
    if let Some(m) = args.materials {
        anyhow::ensure!(
            m >= 8,
            "--materials {m}: the database needs at least 8 materials"
        );
        config.basis_settings.materials = m;
    }
    crate::app::run(config)
}
