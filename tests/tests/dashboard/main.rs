//! The dashboard end to end, one test binary: a master with its dashboard on, and a headless
//! chromium where a page's behaviour is tested. Each module is one behaviour (`auth`,
//! `cancel`, `csrf`, `errors`, `live`, `replay`), and `cost` is the dashboard's cost as a
//! benchmark (ignored). The helpers they share are `hevo_tests::dashboard` and
//! `hevo_tests::browser`. Run one module with `cargo test -p hevo-tests --test dashboard
//! MODULE::`.

mod auth;
mod cancel;
mod cost;
mod csrf;
mod errors;
mod live;
mod replay;
