//! The command line: each verb drives the engine the way a script or a test would.

/// `println!` for a verb's output, returning `StdoutError` from the enclosing function when
/// stdout can't be written: `println!` panics when the reader has gone (`burnish eval … | head`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        writeln!(::std::io::stdout().lock(), $($arg)*).map_err($crate::cli::StdoutError)?
    }};
}

/// `print!` for a verb's output, failing as `outln!` does.
macro_rules! out {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        write!(::std::io::stdout().lock(), $($arg)*).map_err($crate::cli::StdoutError)?
    }};
}

#[cfg(feature = "app")]
mod app_cmd;
mod basis_cmd;
pub mod bench_cmd;
mod calibrate_cmd;
pub mod convert_cmd;
pub mod eval_cmd;
mod reconstruct_cmd;
mod scene_cmds;
mod suggest_cmd;

use crate::basis::BuildProgress;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// A failed write of the command's output to stdout. Only writes to stdout make it (`outln!`,
/// `out!`, the help), so a broken pipe here means the reader of stdout has gone, never that some
/// file write failed.
#[derive(Debug)]
pub(crate) struct StdoutError(pub(crate) std::io::Error);

impl std::fmt::Display for StdoutError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("writing to stdout")
    }
}

impl std::error::Error for StdoutError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.0)
    }
}

/// Whether `e` says the reader of stdout has gone (`burnish … | head`): then the command has
/// nothing left to do, and stops quietly and successfully, as command-line tools do.
fn stdout_closed(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<StdoutError>()
            .is_some_and(|s| s.0.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

#[derive(Parser, Debug)]
#[command(
    name = "burnish",
    version,
    about = "Paint how a material looks; get back a full tabulated BRDF."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Write the guide image of a scene: the object, diffusely shaded, to paint over.
    Guide(scene_cmds::GuideArgs),
    /// Render a scene's object with a BRDF table, as a perfect painter would paint it.
    Render(scene_cmds::RenderArgs),
    /// Rebuild a full BRDF table from paintings of one or more views.
    Reconstruct(reconstruct_cmd::ReconstructArgs),
    /// Rank candidate views by how much painting them would teach: which light and camera next.
    Suggest(suggest_cmd::SuggestArgs),
    /// Score an estimated table against the truth.
    Eval(eval_cmd::EvalArgs),
    /// Convert a material between formats: EXR table, MERL, .bsdf, MaterialX, glTF.
    Convert(convert_cmd::ConvertArgs),
    /// Build (or load from the cache) the PCA basis of the material database.
    Basis(basis_cmd::BasisArgs),
    /// Open the painting app (what `burnish` with no verb does).
    #[cfg(feature = "app")]
    App(app_cmd::AppArgs),
    /// Benchmark: reconstruction error against run time, and the live loop's timings.
    Bench(bench_cmd::BenchArgs),
    /// Choose the prior's constants by leave-families-out cross-validation on the database.
    Calibrate(calibrate_cmd::CalibrateArgs),
}

/// Runs the command line; errors are printed with the file and the problem, exit code 1. A
/// closed stdout ends it quietly with exit code 0.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Guide(args)) => scene_cmds::guide(&args),
        Some(Command::Render(args)) => scene_cmds::render(&args),
        Some(Command::Reconstruct(args)) => reconstruct_cmd::run(&args),
        Some(Command::Suggest(args)) => suggest_cmd::run(&args),
        Some(Command::Eval(args)) => eval_cmd::run(&args),
        Some(Command::Convert(args)) => convert_cmd::run(&args),
        Some(Command::Basis(args)) => basis_cmd::run(&args),
        #[cfg(feature = "app")]
        Some(Command::App(args)) => app_cmd::run(&args),
        Some(Command::Bench(args)) => bench_cmd::run(&args),
        Some(Command::Calibrate(args)) => calibrate_cmd::run(&args),
        #[cfg(feature = "app")]
        None => app_cmd::run(&app_cmd::AppArgs::default()),
        // Built without the window: list the verbs.
        #[cfg(not(feature = "app"))]
        None => <Cli as clap::CommandFactory>::command()
            .print_help()
            .map_err(|e| StdoutError(e).into()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if stdout_closed(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Creates the missing folders above an output file, as users expect of a command line.
pub(crate) fn ensure_parent(path: &std::path::Path) -> anyhow::Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| crate::Error::io(parent, e))?;
    }
    Ok(())
}

/// A progress bar for basis builds, one stage at a time.
pub(crate) fn basis_progress_bar() -> impl Fn(BuildProgress) + Sync {
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:>22} [{bar:40}] {pos}/{len} {elapsed}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let bar = std::sync::Mutex::new(bar);
    move |p: BuildProgress| {
        let bar = bar.lock().unwrap();
        if bar.message() != p.stage {
            bar.set_message(p.stage);
            bar.set_length(p.total as u64);
        }
        bar.set_position(p.done as u64);
        if p.stage == "done" {
            bar.finish();
        }
    }
}
