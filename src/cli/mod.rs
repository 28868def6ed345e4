//! The command line: each verb drives the engine the way a script or a test would.

/// `println!` for a verb's output, through [`write_out`].
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

/// `print!` for a verb's output, through [`write_out`].
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!($($arg)*))?
    };
}

/// `eprintln!` for progress, warnings and errors, through [`write_err`].
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::cli::write_err(format_args!("{}\n", format_args!($($arg)*)))
    };
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

/// A failed write of the command's output to stdout (a full disk behind a redirection).
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

/// Set once the reader of stdout has gone.
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Writes a verb's output to stdout. Once the reader has gone (`burnish eval … | head -1`)
/// the rest of the output is dropped and the verb goes on: what a verb writes to files
/// (`reconstruct --out`, `render --out`) is what the user asked for, and its exit status
/// says whether that was done. `println!` would panic there instead.
pub(crate) fn write_out(text: std::fmt::Arguments) -> Result<(), StdoutError> {
    use std::io::Write as _;
    use std::sync::atomic::Ordering::Relaxed;
    if STDOUT_CLOSED.load(Relaxed) {
        return Ok(());
    }
    match std::io::stdout().lock().write_fmt(text) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            STDOUT_CLOSED.store(true, Relaxed);
            Ok(())
        }
        result => result.map_err(StdoutError),
    }
}

/// Writes progress, a warning or an error to stderr. Nothing is left to tell when stderr
/// itself has gone (`burnish … 2>&-`, a closed pipe), so a failed write is dropped: the verb
/// goes on and its exit status still says how it ended. `eprintln!` would panic there.
pub(crate) fn write_err(text: std::fmt::Arguments) {
    use std::io::Write as _;
    let _ = std::io::stderr().lock().write_fmt(text);
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

/// Runs the command line; errors are printed with the file and the problem, exit code 1.
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
        None => write_out(format_args!(
            "{}",
            <Cli as clap::CommandFactory>::command().render_help()
        ))
        .map_err(Into::into),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("error: {e:#}");
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
