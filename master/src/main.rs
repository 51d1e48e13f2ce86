//! The `hevo` command (in progress).
fn main() {}
