//! `hevo export`: a controller tree and its task as a self-contained C99 library for the
//! e-puck, one call per control cycle (`hevo_step`), no heap, no libm. The float target runs
//! sim-core's network, arbitration and sensor mapping with sim-core's operations in sim-core's
//! order, so that its results are sim-core's bit for bit; the fixed target (for the e-puck1's
//! dsPIC, no FPU) runs them in integers with a sigmoid table. The export also writes test
//! vectors recorded from sim-core (raw readings, network inputs, every node's outputs, the
//! active path, the wheels) and a host harness (`make check`) that compares the C with them;
//! [`closed_loop`] drives the compiled C from sim-core's simulator in place of the Rust
//! controller. The semantics and the measured figures are in `docs/export.md`.

pub mod closed_loop;
mod csource;
pub mod fixed;
pub mod model;
pub mod vectors;

use std::fmt;
use std::path::{Path, PathBuf};

use hevo_sim_core::{ControllerError, ControllerFile};
use hevo_sim_core::{Sample, TaskConfig};

pub use model::ExportModel;

/// Which arithmetic the generated library uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// IEEE single precision (e-puck2, Cortex-M4F): sim-core's results bit for bit.
    Float,
    /// Integers only (e-puck1, dsPIC30F6014A): Q16 values, Q11 weights, a sigmoid table.
    Fixed,
}

impl Target {
    /// The name `--target` takes.
    pub fn name(self) -> &'static str {
        match self {
            Target::Float => "float",
            Target::Fixed => "fixed",
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a controller cannot be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The controller file is invalid.
    #[error(transparent)]
    Controller(#[from] ControllerError),
    /// A node has no genome (an evolving template, not a controller).
    #[error("{path}: the node has no genome; only a complete controller can be exported")]
    FreeNode {
        /// The free node's path.
        path: String,
    },
    /// The tree or the task asks for something the generator does not produce.
    #[error("cannot export: {0}")]
    Unsupported(String),
    /// The task cannot be evaluated (recording the vectors needs it).
    #[error("the task cannot be evaluated: {0}")]
    Task(String),
    /// Recording the vectors found a reading it cannot express as a raw reading.
    #[error("recording test vectors: {0}")]
    Vectors(String),
    /// Writing the files.
    #[error("{path}: {cause}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What went wrong.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
}

/// What to export.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// The arithmetic.
    pub target: Target,
    /// The samples whose cycles the test vectors record.
    pub vector_samples: Vec<Sample>,
    /// A note for the README on where the controller came from (its file), if any.
    pub source_note: Option<String>,
}

/// The generated files, in memory: name and content.
#[derive(Debug, Clone)]
pub struct Bundle {
    /// The model the files were generated from.
    pub model: ExportModel,
    /// Files by name (relative to the output directory).
    pub files: csource::Files,
    /// What the vectors hold.
    pub vectors: vectors::VectorSummary,
    /// Fixed target only: the sigmoid table's largest error.
    pub sigmoid_error: Option<f64>,
}

impl Bundle {
    /// Writes every file into `dir` (created if missing).
    pub fn write(&self, dir: &Path) -> Result<(), ExportError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |cause| ExportError::Io { path, cause }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        for (name, content) in &self.files {
            let path = dir.join(name);
            std::fs::write(&path, content).map_err(io(&path))?;
        }
        Ok(())
    }
}

/// Generates the library for `file` on `task`, with test vectors of `options.vector_samples`.
pub fn export(
    file: &ControllerFile,
    task: &TaskConfig,
    options: &ExportOptions,
) -> Result<Bundle, ExportError> {
    let model = ExportModel::new(file, task)?;
    let recorded = vectors::record(file, task, &model, &options.vector_samples)?;
    let (vector_bytes, summary) = vectors::encode(&model, &recorded);
    let (mut files, sigmoid_error) = csource::generate(&model, options)?;
    files.push((vectors::FILE_NAME.to_string(), vector_bytes));
    files.push((
        "README.md".to_string(),
        csource::readme(&model, options, &summary, sigmoid_error).into_bytes(),
    ));
    Ok(Bundle {
        model,
        files,
        vectors: summary,
        sigmoid_error,
    })
}
