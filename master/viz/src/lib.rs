//! Pictures of what evolved: SVG replays of single traced samples (the robot's path through the
//! world, coloured by the controller that drove it, and a team's other robots), fitness plots of evolutionary runs and a
//! MAP-Elites run's archive heatmap and QD-score curves ([`archive`]), read
//! from run directories through `hevo_rundir`'s format, without the engine. The pictures share
//! one small SVG writer, so escaping, number formatting, palette and fonts are decided in one
//! place. A traced sample can also be written as a table ([`trace_table`], CSV or JSON). The
//! paper's report, which uses these pictures, is hevo-report's.
pub mod archive;
pub mod plot;
pub mod replay;
pub mod svg;
pub mod trace_table;

pub use archive::{archive_heatmap_svg, qd_plot_svg, read_qd_logs};
pub use plot::{RunLog, fitness_plot_svg, read_run_logs};
pub use replay::{
    IrCone, ReplayOptions, replay_scene_transform, replay_svg, scenario_svg, team_member_poses,
};
