//! The `hevo-worker` binary: everything lives in the library (`hevo_worker::cli`).
fn main() -> std::process::ExitCode {
    hevo_worker::cli::main()
}
