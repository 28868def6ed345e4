fn main() -> std::process::ExitCode {
    burnish::cli::run()
}
