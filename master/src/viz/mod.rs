//! Pictures of what evolved, written as SVG by hand: replays of single traced samples (the
//! robot's path through the world, coloured by the controller that drove it) and fitness plots
//! of evolutionary runs. Both share one small SVG writer, so escaping, number formatting,
//! palette and fonts are decided in one place.

pub mod plot;
pub mod replay;
pub mod svg;

pub use plot::{FitnessRow, PlotError, RunLog, fitness_plot_svg, parse_fitness_csv, read_run_logs};
pub use replay::{IrCone, ReplayOptions, replay_svg};
