//! The reports: `hevo report` writes REPRODUCTION.md from run directories, the paper's
//! figures beside hevo's ([`reproduction`]), with what chance does to a solve rate measured on
//! finite samples ([`sampling`]); `hevo report --study` writes the algorithm study's page from
//! a study file ([`study`]). It reads run directories through `hevo_rundir`'s format and
//! draws its fitness-curve pictures with hevo-viz; the pictures themselves know nothing of the
//! paper.

pub mod reproduction;
pub mod sampling;
pub mod study;

pub use reproduction::{PAPER, PaperResult, ReportError, write_report};
pub use study::{StudyFile, write_study_report};
