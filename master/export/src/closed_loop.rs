//! The closed loop: sim-core's simulator driving the exported C in place of its own
//! controller. The C runs as a child process (`hevo_loop`, built from `loop.c` by the export's
//! Makefile) that answers one line per control cycle; [`CProgram`] is a sim-core `Policy` that
//! passes each cycle's readings to it and the wheels back. So the outcome of a sample is that
//! of the code that would run on the robot, judged by the same simulator on the same seeds as
//! `hevo eval`.
//!
//! Per cycle the program gets raw IR readings (recovered from sim-core's inputs as the test
//! vectors' are, [`crate::vectors::ir_raw_for`]), the light inputs after the flash detector
//! (sim-core keeps no raw ambient readings to replay online; the detector is checked by the
//! vectors) and the near-robot flag.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

use hevo_sim_core::SensorFrame;
use hevo_sim_core::{Controller, ControllerFile};
use hevo_sim_core::{Evaluator, Outcome, Policy, Sample, TaskConfig};
use hevo_sim_core::{N_IR, N_LIGHT};

use crate::ExportError;
use crate::model::ExportModel;
use crate::vectors::{ir_gains, ir_raw_for};

/// Runs `make -s -C dir TARGET` (the export's Makefile); its output, or why it failed.
pub fn make(dir: &Path, target: &str) -> Result<String, ExportError> {
    let output = Command::new("make")
        .arg("-s")
        .arg("-C")
        .arg(dir)
        .arg(target)
        .stdin(Stdio::null())
        .output()
        .map_err(|cause| ExportError::Io {
            path: dir.to_path_buf(),
            cause,
        })?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    if !output.status.success() {
        return Err(ExportError::Unsupported(format!(
            "`make -C {} {target}` failed: {text}",
            dir.display()
        )));
    }
    Ok(text)
}

/// Builds the closed-loop program in an export directory with its Makefile; returns its path.
pub fn build_program(dir: &Path) -> Result<PathBuf, ExportError> {
    make(dir, "hevo_loop")?;
    Ok(dir.join("hevo_loop"))
}

/// The exported controller as a sim-core policy, one child process.
#[derive(Debug)]
pub struct CProgram {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    live_ir: bool,
    n_nodes: usize,
    root_children: Vec<String>,
    /// The IR gains the next reset sends.
    gains: [f32; N_IR],
    path: Vec<usize>,
    root_choice: Option<usize>,
    line: String,
    /// The first thing that went wrong; a policy step cannot return it.
    error: Option<String>,
}

impl CProgram {
    /// Starts `program` for the controller of `model`.
    pub fn start(program: &Path, model: &ExportModel) -> Result<CProgram, ExportError> {
        let mut child = Command::new(program)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|cause| ExportError::Io {
                path: program.to_path_buf(),
                cause,
            })?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(ExportError::Unsupported(
                "the child process has no pipes".into(),
            ));
        };
        let root_children = model.nodes[0]
            .children
            .iter()
            .map(|&c| {
                let path = &model.nodes[c].path;
                path.rsplit('/').next().unwrap_or(path).to_string()
            })
            .collect();
        Ok(CProgram {
            child,
            stdin,
            stdout: BufReader::new(stdout),
            live_ir: model.live[0],
            n_nodes: model.nodes.len(),
            root_children,
            gains: [1.0; N_IR],
            path: Vec::new(),
            root_choice: None,
            line: String::new(),
            error: None,
        })
    }

    /// Sends one line and reads the answer into `self.line`.
    fn ask(&mut self, message: &str) -> Result<(), String> {
        self.stdin
            .write_all(message.as_bytes())
            .and_then(|()| self.stdin.flush())
            .map_err(|err| format!("writing to the program: {err}"))?;
        self.line.clear();
        match self.stdout.read_line(&mut self.line) {
            Ok(0) => Err("the program ended".into()),
            Ok(_) => Ok(()),
            Err(err) => Err(format!("reading from the program: {err}")),
        }
    }

    fn fail(&mut self, problem: String) {
        self.error.get_or_insert(problem);
    }

    fn try_step(&mut self, frame: &SensorFrame) -> Result<[f32; 2], String> {
        let mut message = String::from("S");
        for sensor in 0..N_IR {
            let input = frame.inputs[sensor];
            let raw = if self.live_ir {
                ir_raw_for(input, self.gains[sensor])
                    .ok_or_else(|| format!("no raw reading gives IR input {sensor} = {input:e}"))?
            } else {
                0.0
            };
            message.push_str(&format!(" {:x}", raw.to_bits()));
        }
        for &value in &frame.inputs[N_IR..N_IR + N_LIGHT + 1] {
            message.push_str(&format!(" {:x}", value.to_bits()));
        }
        message.push('\n');
        self.ask(&message)?;
        let mut words = self.line.split_whitespace();
        let mut next = |what: &str| {
            words
                .next()
                .ok_or_else(|| format!("the answer {:?} lacks {what}", self.line.trim()))
                .map(str::to_string)
        };
        let bits = |text: String| {
            u32::from_str_radix(&text, 16)
                .map(f32::from_bits)
                .map_err(|_| format!("{text:?} is not a float's bits"))
        };
        let left = bits(next("the left wheel")?)?;
        let right = bits(next("the right wheel")?)?;
        let root: i64 = next("the root's choice")?
            .parse()
            .map_err(|_| "the root's choice is not a number".to_string())?;
        let path_len: usize = next("the path's length")?
            .parse()
            .map_err(|_| "the path's length is not a number".to_string())?;
        let mut path = Vec::with_capacity(path_len);
        for _ in 0..path_len {
            path.push(
                next("a path node")?
                    .parse()
                    .map_err(|_| "a path node is not a number".to_string())?,
            );
        }
        self.root_choice = usize::try_from(root).ok();
        self.path = path;
        Ok([left, right])
    }
}

impl Policy for CProgram {
    fn reset(&mut self) {
        let gains: Vec<String> = self
            .gains
            .iter()
            .map(|g| format!("{:x}", g.to_bits()))
            .collect();
        let message = format!("R {} 0 0 0\n", gains.join(" "));
        if let Err(problem) = self.ask(&message) {
            self.fail(problem);
        }
        self.path.clear();
        self.root_choice = None;
    }

    fn step(&mut self, frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        if self.error.is_some() {
            return [0.5, 0.5];
        }
        match self.try_step(frame) {
            Ok(wheels) => wheels,
            Err(problem) => {
                self.fail(problem);
                [0.5, 0.5]
            }
        }
    }

    fn root_choice(&self) -> Option<usize> {
        self.root_choice
    }

    fn active_path(&self) -> &[usize] {
        &self.path
    }

    fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    fn root_child_index(&self, name: &str) -> Option<usize> {
        self.root_children.iter().position(|child| child == name)
    }
}

impl Drop for CProgram {
    fn drop(&mut self) {
        let _ = self.stdin.write_all(b"Q\n");
        let _ = self.stdin.flush();
        let _ = self.child.wait();
    }
}

/// The outcomes of the same samples with the exported C and with sim-core's controller.
#[derive(Debug, Clone)]
pub struct ClosedLoopReport {
    /// With the exported C in the loop.
    pub exported: Vec<Outcome>,
    /// With sim-core's own controller (what `hevo eval` computes).
    pub simulated: Vec<Outcome>,
}

impl ClosedLoopReport {
    /// Samples solved by the exported C.
    pub fn exported_solved(&self) -> usize {
        self.exported.iter().filter(|o| o.solved).count()
    }

    /// Samples solved by sim-core's controller.
    pub fn simulated_solved(&self) -> usize {
        self.simulated.iter().filter(|o| o.solved).count()
    }

    /// Samples whose outcomes are equal in every field, the fitness to the bit.
    pub fn identical(&self) -> usize {
        self.exported
            .iter()
            .zip(&self.simulated)
            .filter(|(a, b)| a.fitness.to_bits() == b.fitness.to_bits() && a == b)
            .count()
    }
}

/// Evaluates `samples` with the program in the loop and with sim-core's controller, over
/// `threads` threads (one program process each).
pub fn run(
    program: &Path,
    file: &ControllerFile,
    task: &TaskConfig,
    samples: &[Sample],
    threads: usize,
) -> Result<ClosedLoopReport, ExportError> {
    let model = ExportModel::new(file, task)?;
    let evaluator =
        Evaluator::new(task.clone()).map_err(|err| ExportError::Task(err.to_string()))?;
    let chunk = samples.len().div_ceil(threads.max(1)).max(1);
    let results: Vec<Result<Vec<(Outcome, Outcome)>, ExportError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = samples
            .chunks(chunk)
            .map(|chunk| {
                let (evaluator, model) = (&evaluator, &model);
                scope.spawn(move || -> Result<Vec<(Outcome, Outcome)>, ExportError> {
                    let mut exported = CProgram::start(program, model)?;
                    let mut simulated = Controller::new(file, None)?;
                    let mut outcomes = Vec::with_capacity(chunk.len());
                    for &sample in chunk {
                        exported.gains = ir_gains(task, sample.seed);
                        let by_c = evaluator.evaluate(&mut exported, sample);
                        if let Some(problem) = exported.error.take() {
                            return Err(ExportError::Unsupported(format!(
                                "closed loop, sample seed {}: {problem}",
                                sample.seed
                            )));
                        }
                        let by_sim = evaluator.evaluate(&mut simulated, sample);
                        outcomes.push((by_c, by_sim));
                    }
                    Ok(outcomes)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|handle| {
                handle.join().unwrap_or_else(|_| {
                    Err(ExportError::Unsupported(
                        "a closed-loop thread panicked".into(),
                    ))
                })
            })
            .collect()
    });
    let mut report = ClosedLoopReport {
        exported: Vec::with_capacity(samples.len()),
        simulated: Vec::with_capacity(samples.len()),
    };
    for result in results {
        for (by_c, by_sim) in result? {
            report.exported.push(by_c);
            report.simulated.push(by_sim);
        }
    }
    Ok(report)
}
