//! Empty: cargo considers a crate's build dependencies only when it has a build script, and the
//! build dependencies unify the proc-macro crates' features (syn's above all).
fn main() {}
