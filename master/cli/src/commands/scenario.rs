//! `hevo scenario`: check a scenario file and draw its world before evolving anything on it.
//! `check` compiles the file (every error names the file, the key and the line), builds a few
//! samples of every variant and refuses a world whose robot starts inside a wall, as every
//! evaluator does; `draw` writes one sample's world, start and goal as an SVG picture, a
//! refused world's too.

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use hevo_sim_core::CtrnnTopology;
use hevo_sim_core::Scenario;
use hevo_sim_core::{Evaluator, Policy, Sample, TaskConfig};
use hevo_sim_core::{InputGroup, SensorFrame};
use std::path::PathBuf;
use std::sync::Arc;

/// `hevo scenario`.
#[derive(Debug, Args)]
pub struct ScenarioArgs {
    /// What to do with the scenario.
    #[command(subcommand)]
    pub command: ScenarioCommand,
}

/// `hevo scenario` subcommands.
#[derive(Debug, Subcommand)]
pub enum ScenarioCommand {
    /// Compile scenario files, build samples of every variant, and print what each holds.
    Check(CheckArgs),
    /// Draw one sample's world (walls, lights, start, teammate, goal) as SVG.
    Draw(DrawArgs),
}

/// `hevo scenario check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// Scenario files, or names of shipped scenarios.
    #[arg(required = true)]
    pub files: Vec<String>,
    /// Samples built per variant.
    #[arg(long, default_value_t = 20)]
    pub samples: u32,
}

/// `hevo scenario draw`.
#[derive(Debug, Args)]
pub struct DrawArgs {
    /// A scenario file, or the name of a shipped scenario.
    pub file: String,
    /// The sample's seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The variant (from 0); drawn from the seed when absent.
    #[arg(long)]
    pub variant: Option<u32>,
    /// The SVG file to write.
    #[arg(long, default_value = "scenario.svg")]
    pub out: PathBuf,
}

/// Runs `hevo scenario`.
pub fn scenario(args: ScenarioArgs) -> Result<()> {
    match args.command {
        ScenarioCommand::Check(args) => {
            for file in &args.files {
                let task = load(file)?;
                crate::outln!("{}", check(&task, args.samples)?);
            }
            Ok(())
        }
        ScenarioCommand::Draw(args) => draw(&args),
    }
}

/// A scenario's task by file path (ending in `.toml`) or shipped name.
fn load(file: &str) -> Result<TaskConfig> {
    let task = if file.ends_with(".toml") {
        TaskConfig::from_scenario(Arc::new(hevo_engine::inputs::read_scenario(file)?))
    } else {
        TaskConfig::shipped(file).with_context(|| {
            format!(
                "'{file}' is neither a scenario file (a path ending in .toml) nor one of {}",
                Scenario::shipped_names().join(", ")
            )
        })?
    };
    task.validate()
        .with_context(|| format!("{file}: invalid settings"))?;
    Ok(task)
}

/// A policy that does not move: one cycle of it shows the world as a sample starts.
struct Still;

impl Policy for Still {
    fn reset(&mut self) {}

    fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        // Wheel outputs in [0, 1] map to [-v_max, v_max]: 0.5 is standing still.
        [0.5, 0.5]
    }
}

/// The first cycle of a sample, traced; of any world, a refused one too, to draw it.
fn first_cycle(task: &TaskConfig, sample: Sample) -> Result<hevo_sim_core::Trace> {
    let mut one_cycle = task.clone();
    one_cycle.max_cycles = Some(1);
    let evaluator = Evaluator::for_drawing(one_cycle)?;
    Ok(evaluator.evaluate_traced(&mut Still, sample))
}

/// What the scenario holds, after building `samples` samples of each variant: the
/// evaluator's own refusals (every error names the file, the key and the line), with the
/// starts checked on that many worlds.
fn check(task: &TaskConfig, samples: u32) -> Result<String> {
    let scenario = &task.scenario;
    let evaluator = Evaluator::new(task.clone())?;
    evaluator.check_starts(u64::from(samples))?;
    let (low, high) = task.fitness_range();
    let mut text = format!(
        "{}: ok ({} variant(s), {} samples each built)\n  max cycles {}, fitness in [{low}, {high}]",
        scenario.name(),
        scenario.n_variants(),
        samples,
        task.max_cycles()
    );
    if scenario.n_variants() > 1 {
        let names: Vec<String> = scenario.variants.iter().map(|v| v.name.clone()).collect();
        text.push_str(&format!("\n  variants: {}", names.join("; ")));
    }
    // The regions of the first sample's world (generators may leave one out of a sample).
    let env = evaluator.environment(Sample::seeded(0));
    let regions: Vec<String> = hevo_sim_core::named_regions(task, &env)
        .into_iter()
        .map(|region| region.name)
        .collect();
    if !regions.is_empty() {
        text.push_str(&format!("\n  regions: {}", regions.join(", ")));
    }
    if !scenario.solids.is_empty() {
        text.push_str(&format!(
            "\n  solid rectangles: {} besides the world's own",
            scenario.solids.len()
        ));
    }
    if !scenario.movers.is_empty() {
        let names: Vec<&str> = scenario.movers.iter().map(|m| m.name.as_str()).collect();
        text.push_str(&format!("\n  movers: {}", names.join(", ")));
    }
    if !scenario.box_groups.is_empty() {
        text.push_str(&format!("\n  boxes: {}", scenario.box_radii().len()));
    }
    let runs_files: Vec<String> = scenario
        .robot_groups
        .iter()
        .filter_map(|group| {
            let path = group.controller_file()?;
            Some(format!("{} runs {path}", group.name))
        })
        .collect();
    if !runs_files.is_empty() {
        text.push_str(&format!("\n  controller files: {}", runs_files.join("; ")));
    }
    text.push_str(&endings_summary(task));
    text.push_str(&inputs_summary(scenario));
    if !scenario.stages.is_empty() {
        text.push_str(&format!(
            "\n  stages: {}",
            scenario.stage_names().join(", ")
        ));
    }
    if scenario.has_phases() {
        let phases: Vec<String> = scenario
            .phases
            .iter()
            .map(|phase| match &phase.child {
                hevo_sim_core::ChildRef::Name(child) => {
                    format!("{} (child {child})", phase.name)
                }
                hevo_sim_core::ChildRef::Index(idx) => {
                    format!("{} (child {idx})", phase.name)
                }
            })
            .collect();
        text.push_str(&format!(
            "\n  derived fitness over the phases: {}",
            phases.join(", ")
        ));
    }
    Ok(text)
}

/// What ends a sample.
fn endings_summary(task: &TaskConfig) -> String {
    let end = &task.scenario.file.end;
    let mut endings = vec![format!("solved when `{}`", end.solved)];
    if let Some(rule) = &end.wrong_branch {
        let ends = end.wrong_branch_ends || task.end_on_wrong_branch;
        endings.push(format!(
            "a wrong branch (`{rule}`){}",
            if ends { "" } else { ", counted, not ending it" }
        ));
    }
    if let Some(forbidden) = &end.forbidden {
        endings.push(format!("forbidden: `{forbidden}` (as a wrong branch)"));
    }
    if task.end_on_collision {
        endings.push("a collision".into());
    }
    endings.push(format!("{} cycles", task.max_cycles()));
    format!("\n  ends: {}", endings.join("; "))
}

/// The robot's sensors, the inputs a network over all of them reads, and the genome such a
/// network needs (the sizes `hevo run` evolves: a primitive drives two wheels, an arbitrator
/// has an output per child).
fn inputs_summary(scenario: &hevo_sim_core::Scenario) -> String {
    let groups: Vec<InputGroup> = scenario.sensors.groups().collect();
    let n_inputs: usize = groups.iter().map(|group| group.width()).sum();
    let sensors: Vec<String> = groups
        .iter()
        .map(|group| format!("{} ({})", group.name(), group.width()))
        .collect();
    let genes = |n_outputs: usize, n_hidden: usize| {
        CtrnnTopology {
            n_inputs,
            n_hidden,
            n_outputs,
        }
        .n_genes()
    };
    let mut text = format!(
        "\n  sensors: {}; a network over all of them reads {n_inputs} inputs\n  \
         genome over all {n_inputs} inputs: {} / {} / {} genes for a primitive with 3 / 5 / 10 hidden neurons",
        sensors.join(", "),
        genes(2, 3),
        genes(2, 5),
        genes(2, 10),
    );
    if scenario.has_phases() {
        let mut children = Vec::new();
        for phase in &scenario.phases {
            if !children.contains(&&phase.child) {
                children.push(&phase.child);
            }
        }
        text.push_str(&format!(
            "; {} for an arbitrator with 10 over the {} children its phases name",
            genes(children.len(), 10),
            children.len(),
        ));
    }
    text
}

fn draw(args: &DrawArgs) -> Result<()> {
    let task = load(&args.file)?;
    let n_variants = task.scenario.n_variants();
    if let Some(variant) = args.variant
        && variant >= n_variants
    {
        bail!(
            "--variant {variant} is out of range: {} has {n_variants} variant(s)",
            task.name()
        );
    }
    let sample = Sample {
        seed: args.seed,
        variant: args.variant,
    };
    let trace = first_cycle(&task, sample)?;
    let variant = trace.outcome.variant;
    let variant_name = task
        .scenario
        .variant_label(variant)
        .map_or(String::new(), |name| {
            format!(" · variant {variant}, {name}")
        });
    let options = hevo_viz::ReplayOptions {
        title: Some(format!("Scenario: {} · seed {}", task.name(), args.seed)),
        robot_radius: task.params.robot.radius,
        caption: Some([
            format!("{} · seed {}{variant_name}", task.name(), args.seed),
            format!(
                "the world as a sample starts, before any controller drives · {} cycles at most",
                task.max_cycles()
            ),
        ]),
        ..hevo_viz::ReplayOptions::default()
    };
    // The regions of the very world the trace ran in: the same sample, so the same draws.
    let env = Evaluator::for_drawing(task.clone())?.environment(sample);
    let regions = hevo_sim_core::named_regions(&task, &env);
    let svg = hevo_viz::scenario_svg(&trace, &options, &regions);
    hevo_engine::store::write_atomic(&args.out, svg.as_bytes())
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    crate::outln!("{} -> {}", task.name(), args.out.display());
    Ok(())
}
