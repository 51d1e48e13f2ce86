//! The `hevo` binary: everything lives in the library (`hevo_master::cli`).
fn main() -> std::process::ExitCode {
    hevo_master::cli::main()
}
