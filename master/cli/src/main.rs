//! The `hevo` binary: everything lives in the library (`hevo_cli::cli`).
fn main() -> std::process::ExitCode {
    hevo_cli::cli::main()
}
