//! Fitness plots of evolutionary runs as SVG: each run's best and population-mean fitness per
//! generation, and across runs the mean of the best with the band from the lowest to the
//! highest run's best. It also reads the `fitness.csv` log every run writes, with errors that
//! name the line and column, so a damaged log is easy to find. Runs may have different
//! lengths: a run still in progress simply ends earlier.

use crate::svg::{INK, PALETTE, SvgDocument, Tag, num_with, text_width};
use hevo_rundir::{self as rundir, FitnessRow, RunDirError};
use std::collections::BTreeMap;
use std::path::Path;

/// One run's log, with the name the plot's legend gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunLog {
    /// Legend label, e.g. `run 3`.
    pub label: String,
    /// Its generations, in order.
    pub rows: Vec<FitnessRow>,
}

/// Every run's fitness log under a node directory (see [`rundir::fitness_logs`]), each
/// labelled `run <k>` for the legend.
pub fn read_run_logs(node_dir: &Path) -> Result<Vec<RunLog>, RunDirError> {
    Ok(rundir::fitness_logs(node_dir)?
        .into_iter()
        .map(|(run, rows)| RunLog {
            label: format!("run {run}"),
            rows,
        })
        .collect())
}

/// Picture size and plot-area margins, pixels; sized for a README at about 700 px.
const WIDTH: f64 = 800.0;
const PLOT_LEFT: f64 = 78.0;
const PLOT_RIGHT: f64 = WIDTH - 24.0;
const PLOT_TOP: f64 = 54.0;
const PLOT_BOTTOM: f64 = PLOT_TOP + 380.0;
const PAD: f64 = 16.0;
const TITLE_FONT: f64 = 20.0;
const AXIS_FONT: f64 = 15.0;
const TICK_FONT: f64 = 13.0;
const LEGEND_FONT: f64 = 14.0;
const GRID_COLOUR: &str = "#e6e6e6";
const AGGREGATE_COLOUR: &str = "#000000";

/// Colours for runs beyond the shared palette (Paul Tol's indigo, wine and olive): the paper
/// runs most nodes 10 times, and a tenth run drawn in the first run's colour would be one
/// line in the legend.
const EXTRA_RUN_COLOURS: [&str; 3] = ["#332288", "#882255", "#999933"];

/// Run colours: the shared palette without black, which marks the across-run mean, then the
/// extra colours, so ten runs get ten colours; more wrap around.
pub(crate) fn run_colour(run: usize) -> &'static str {
    let colours: Vec<&'static str> = PALETTE
        .iter()
        .copied()
        .filter(|c| *c != AGGREGATE_COLOUR)
        .chain(EXTRA_RUN_COLOURS)
        .collect();
    colours[run % colours.len()]
}

/// A tick step of 1, 2 or 5 times a power of ten giving about `target` ticks over `span`.
pub(crate) fn nice_step(span: f64, target: f64) -> f64 {
    let raw = (span / target).max(f64::MIN_POSITIVE);
    let magnitude = 10f64.powf(raw.log10().floor());
    let fraction = raw / magnitude;
    let nice = if fraction <= 1.0 {
        1.0
    } else if fraction <= 2.0 {
        2.0
    } else if fraction <= 5.0 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// Axis bounds snapped outward to whole tick steps, and the step. A flat range is widened so
/// the line sits inside the plot rather than on its edge.
pub(crate) fn axis_range(low: f64, high: f64, target_ticks: f64) -> (f64, f64, f64) {
    let (mut low, mut high) = (low, high);
    if !(low.is_finite() && high.is_finite()) {
        return (0.0, 1.0, 0.2);
    }
    if high - low < 1e-9 {
        let pad = if low.abs() > 1e-9 {
            0.1 * low.abs()
        } else {
            0.5
        };
        low -= pad;
        high += pad;
    }
    let step = nice_step(high - low, target_ticks);
    let snapped_low = (low / step - 1e-9).floor() * step;
    let snapped_high = (high / step + 1e-9).ceil() * step;
    (snapped_low, snapped_high, step)
}

/// A tick label with as many decimals as the step needs.
pub(crate) fn tick_label(value: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let text = format!("{value:.decimals$}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".to_string()
    } else {
        text
    }
}

/// Across-run statistics of the best fitness at one generation.
#[derive(Debug, Clone, Copy)]
struct Aggregate {
    generation: u32,
    mean: f64,
    low: f64,
    high: f64,
    runs: usize,
}

/// Mean, lowest and highest best fitness across the runs that reached each generation.
fn aggregate_best(runs: &[RunLog]) -> Vec<Aggregate> {
    let mut by_generation: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
    for run in runs {
        for row in run.rows.iter().filter(|r| r.best.is_finite()) {
            by_generation
                .entry(row.generation)
                .or_default()
                .push(row.best);
        }
    }
    by_generation
        .into_iter()
        .map(|(generation, values)| Aggregate {
            generation,
            mean: values.iter().sum::<f64>() / values.len() as f64,
            low: values.iter().copied().fold(f64::INFINITY, f64::min),
            high: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            runs: values.len(),
        })
        .collect()
}

/// Splits the across-run statistics into stretches of consecutive generations that at least
/// two runs reached: a mean over one run would only repeat that run's line.
fn aggregate_segments(aggregates: &[Aggregate]) -> Vec<Vec<Aggregate>> {
    let mut segments: Vec<Vec<Aggregate>> = Vec::new();
    let mut current: Vec<Aggregate> = Vec::new();
    for aggregate in aggregates {
        let continues = current
            .last()
            .is_some_and(|last| aggregate.generation == last.generation + 1);
        if aggregate.runs >= 2 && (current.is_empty() || continues) {
            current.push(*aggregate);
        } else {
            if !current.is_empty() {
                segments.push(std::mem::take(&mut current));
            }
            if aggregate.runs >= 2 {
                current.push(*aggregate);
            }
        }
    }
    if !current.is_empty() {
        segments.push(current);
    }
    segments
}

/// Maps data values to plot pixels.
#[derive(Debug, Clone, Copy)]
struct Axes {
    x_min: f64,
    x_max: f64,
    y_min: f64,
    y_max: f64,
}

impl Axes {
    fn x(&self, generation: f64) -> f64 {
        PLOT_LEFT + (generation - self.x_min) / (self.x_max - self.x_min) * (PLOT_RIGHT - PLOT_LEFT)
    }

    fn y(&self, value: f64) -> f64 {
        PLOT_BOTTOM - (value - self.y_min) / (self.y_max - self.y_min) * (PLOT_BOTTOM - PLOT_TOP)
    }
}

/// One legend entry: how its line looks, and its words.
#[derive(Debug, Clone)]
enum LegendStyle {
    Run(usize),
    Best,
    Mean,
    AggregateMean,
    Band,
}

/// Draws the fitness of every run by generation. Rows with a non-finite value are left out;
/// with no rows at all the picture says so instead of failing. With `planned_generations` (a
/// run still evolving), the generation axis reaches the planned end, so a live curve shows how
/// far it has to go.
pub fn fitness_plot_svg(title: &str, runs: &[RunLog], planned_generations: Option<u32>) -> String {
    let finite_row = |row: &&FitnessRow| row.best.is_finite() && row.mean.is_finite();
    let aggregates = aggregate_best(runs);
    let segments = aggregate_segments(&aggregates);

    let mut y_low = f64::INFINITY;
    let mut y_high = f64::NEG_INFINITY;
    let mut last_generation = 0u32;
    let mut any_data = false;
    for row in runs.iter().flat_map(|r| r.rows.iter()).filter(finite_row) {
        y_low = y_low.min(row.best.min(row.mean));
        y_high = y_high.max(row.best.max(row.mean));
        last_generation = last_generation.max(row.generation);
        any_data = true;
    }
    // The last generation's index is one less than the count.
    let last_generation = last_generation.max(planned_generations.unwrap_or(0).saturating_sub(1));
    let (y_min, y_max, y_step) = if any_data {
        axis_range(y_low, y_high, 6.0)
    } else {
        (0.0, 1.0, 0.2)
    };
    let x_step = nice_step(f64::from(last_generation.max(1)), 8.0)
        .max(1.0)
        .round();
    let x_max = (f64::from(last_generation.max(1)) / x_step).ceil() * x_step;
    let axes = Axes {
        x_min: 0.0,
        x_max,
        y_min,
        y_max,
    };

    // The legend flows under the plot; it is laid out first so the height is known.
    let mut legend: Vec<(LegendStyle, String)> = runs
        .iter()
        .enumerate()
        .map(|(i, run)| (LegendStyle::Run(i), run.label.clone()))
        .collect();
    legend.push((LegendStyle::Best, "best of generation".to_string()));
    legend.push((LegendStyle::Mean, "population mean".to_string()));
    if !segments.is_empty() {
        legend.push((
            LegendStyle::AggregateMean,
            "mean of the runs' best".to_string(),
        ));
        legend.push((
            LegendStyle::Band,
            "lowest to highest run's best".to_string(),
        ));
    }
    let legend_top = PLOT_BOTTOM + 76.0;
    let mut slots: Vec<(f64, usize)> = Vec::new();
    let (mut x, mut row) = (PAD, 0usize);
    for (index, (style, words)) in legend.iter().enumerate() {
        // The style key starts on its own row, apart from the run names.
        let starts_key = matches!(style, LegendStyle::Best) && index > 0;
        let width = 36.0 + text_width(words, LEGEND_FONT) + 22.0;
        if (starts_key || x + width > WIDTH - PAD) && x > PAD {
            row += 1;
            x = PAD;
        }
        slots.push((x, row));
        x += width;
    }
    let height = legend_top + (row + 1) as f64 * 24.0 + PAD - 8.0;

    let mut doc = SvgDocument::new(WIDTH, height, "fitness-plot");
    doc.heading(title, PAD, TITLE_FONT);

    // Grid, ticks and axes.
    doc.open(Tag::new("g").class("axes").attr("fill", INK));
    doc.leaf(
        Tag::new("rect")
            .class("plot-area")
            .num("x", PLOT_LEFT)
            .num("y", PLOT_TOP)
            .num("width", PLOT_RIGHT - PLOT_LEFT)
            .num("height", PLOT_BOTTOM - PLOT_TOP)
            .attr("fill", "#ffffff")
            .attr("stroke", "none")
            .attr("data-x-min", num_with(axes.x_min, 6))
            .attr("data-x-max", num_with(axes.x_max, 6))
            .attr("data-y-min", num_with(axes.y_min, 6))
            .attr("data-y-max", num_with(axes.y_max, 6)),
    );
    let y_ticks = ((y_max - y_min) / y_step).round() as usize;
    for i in 0..=y_ticks {
        let value = y_min + i as f64 * y_step;
        let y = axes.y(value);
        doc.leaf(
            Tag::new("line")
                .class("grid")
                .num("x1", PLOT_LEFT)
                .num("y1", y)
                .num("x2", PLOT_RIGHT)
                .num("y2", y)
                .attr("stroke", GRID_COLOUR)
                .attr("stroke-width", "1"),
        );
        doc.leaf(
            Tag::new("line")
                .class("tick")
                .num("x1", PLOT_LEFT - 5.0)
                .num("y1", y)
                .num("x2", PLOT_LEFT)
                .num("y2", y)
                .attr("stroke", INK),
        );
        doc.text(
            Tag::new("text")
                .class("y-tick-label")
                .num("x", PLOT_LEFT - 8.0)
                .num("y", y + 4.5)
                .num("font-size", TICK_FONT)
                .attr("text-anchor", "end"),
            &tick_label(value, y_step),
        );
    }
    let x_ticks = (x_max / x_step).round() as usize;
    for i in 0..=x_ticks {
        let value = i as f64 * x_step;
        let x = axes.x(value);
        doc.leaf(
            Tag::new("line")
                .class("tick")
                .num("x1", x)
                .num("y1", PLOT_BOTTOM)
                .num("x2", x)
                .num("y2", PLOT_BOTTOM + 5.0)
                .attr("stroke", INK),
        );
        doc.text(
            Tag::new("text")
                .class("x-tick-label")
                .num("x", x)
                .num("y", PLOT_BOTTOM + 20.0)
                .num("font-size", TICK_FONT)
                .attr("text-anchor", "middle"),
            &tick_label(value, x_step),
        );
    }
    doc.leaf(
        Tag::new("path")
            .class("axis-line")
            .attr(
                "d",
                format!(
                    "M{} {} L{} {} L{} {}",
                    PLOT_LEFT, PLOT_TOP, PLOT_LEFT, PLOT_BOTTOM, PLOT_RIGHT, PLOT_BOTTOM
                ),
            )
            .attr("fill", "none")
            .attr("stroke", INK)
            .attr("stroke-width", "1.5"),
    );
    doc.text(
        Tag::new("text")
            .class("axis-label")
            .num("x", 0.5 * (PLOT_LEFT + PLOT_RIGHT))
            .num("y", PLOT_BOTTOM + 44.0)
            .num("font-size", AXIS_FONT)
            .attr("text-anchor", "middle"),
        "generation",
    );
    let y_label_centre = [22.0, 0.5 * (PLOT_TOP + PLOT_BOTTOM)];
    doc.text(
        Tag::new("text")
            .class("axis-label")
            .num("x", y_label_centre[0])
            .num("y", y_label_centre[1])
            .num("font-size", AXIS_FONT)
            .attr("text-anchor", "middle")
            .attr(
                "transform",
                format!("rotate(-90 {} {})", y_label_centre[0], y_label_centre[1]),
            ),
        "fitness",
    );
    doc.close();

    // Data: band under everything, then each run's mean and best, then the across-run mean.
    doc.open(
        Tag::new("g")
            .class("data")
            .attr("fill", "none")
            .attr("stroke-linejoin", "round"),
    );
    for (segment_index, segment) in segments.iter().enumerate() {
        let mut outline: Vec<[f64; 2]> = segment
            .iter()
            .map(|a| [axes.x(f64::from(a.generation)), axes.y(a.high)])
            .collect();
        outline.extend(
            segment
                .iter()
                .rev()
                .map(|a| [axes.x(f64::from(a.generation)), axes.y(a.low)]),
        );
        doc.leaf(
            Tag::new("polygon")
                .class("aggregate-band")
                .attr("data-segment", segment_index.to_string())
                .points(&outline)
                .attr("fill", AGGREGATE_COLOUR)
                .attr("fill-opacity", "0.1")
                .attr("stroke", "none"),
        );
    }
    for (run_index, run) in runs.iter().enumerate() {
        let rows: Vec<&FitnessRow> = run.rows.iter().filter(finite_row).collect();
        let colour = run_colour(run_index);
        let mean: Vec<[f64; 2]> = rows
            .iter()
            .map(|r| [axes.x(f64::from(r.generation)), axes.y(r.mean)])
            .collect();
        doc.leaf(
            Tag::new("polyline")
                .class("run-mean")
                .attr("data-run", run_index.to_string())
                .points(&mean)
                .attr("stroke", colour)
                .attr("stroke-width", "1.5")
                .attr("stroke-dasharray", "5 4")
                .attr("stroke-opacity", "0.6"),
        );
    }
    for (run_index, run) in runs.iter().enumerate() {
        let rows: Vec<&FitnessRow> = run.rows.iter().filter(finite_row).collect();
        let best: Vec<[f64; 2]> = rows
            .iter()
            .map(|r| [axes.x(f64::from(r.generation)), axes.y(r.best)])
            .collect();
        doc.leaf(
            Tag::new("polyline")
                .class("run-best")
                .attr("data-run", run_index.to_string())
                .points(&best)
                .attr("stroke", run_colour(run_index))
                .attr("stroke-width", "2"),
        );
    }
    for (segment_index, segment) in segments.iter().enumerate() {
        let line: Vec<[f64; 2]> = segment
            .iter()
            .map(|a| [axes.x(f64::from(a.generation)), axes.y(a.mean)])
            .collect();
        doc.leaf(
            Tag::new("polyline")
                .class("aggregate-mean")
                .attr("data-segment", segment_index.to_string())
                .points(&line)
                .attr("stroke", AGGREGATE_COLOUR)
                .attr("stroke-width", "3.5"),
        );
    }
    doc.close();
    if !any_data {
        doc.text(
            Tag::new("text")
                .class("no-data")
                .num("x", 0.5 * (PLOT_LEFT + PLOT_RIGHT))
                .num("y", 0.5 * (PLOT_TOP + PLOT_BOTTOM))
                .num("font-size", AXIS_FONT)
                .attr("text-anchor", "middle")
                .attr("fill", "#666666"),
            "no generations logged yet",
        );
    }

    // Legend.
    doc.open(Tag::new("g").class("legend-group"));
    for ((style, words), &(x, row)) in legend.iter().zip(&slots) {
        let y = legend_top + row as f64 * 24.0;
        let (x1, x2, line_y) = (x, x + 28.0, y - 5.0);
        let line = |colour: &str, width: &str| {
            Tag::new("line")
                .class("legend-swatch")
                .num("x1", x1)
                .num("y1", line_y)
                .num("x2", x2)
                .num("y2", line_y)
                .attr("stroke", colour)
                .attr("stroke-width", width)
        };
        let class = match style {
            LegendStyle::Run(run) => {
                doc.leaf(line(run_colour(*run), "4").attr("data-run", run.to_string()));
                "legend"
            }
            LegendStyle::Best => {
                doc.leaf(line("#777777", "2"));
                "key-label"
            }
            LegendStyle::Mean => {
                doc.leaf(line("#777777", "1.5").attr("stroke-dasharray", "5 4"));
                "key-label"
            }
            LegendStyle::AggregateMean => {
                doc.leaf(line(AGGREGATE_COLOUR, "3.5"));
                "key-label"
            }
            LegendStyle::Band => {
                doc.leaf(
                    Tag::new("rect")
                        .class("legend-swatch")
                        .num("x", x1)
                        .num("y", line_y - 7.0)
                        .num("width", x2 - x1)
                        .num("height", 14.0)
                        .attr("fill", AGGREGATE_COLOUR)
                        .attr("fill-opacity", "0.1"),
                );
                "key-label"
            }
        };
        doc.text(
            Tag::new("text")
                .class(class)
                .num("x", x + 36.0)
                .num("y", y)
                .num("font-size", LEGEND_FONT)
                .attr("fill", INK),
            words,
        );
    }
    doc.close();
    doc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::svg::read_back::{Element, parse, with_class};

    #[test]
    fn ten_runs_get_ten_colours_none_of_them_the_means_black() {
        let colours: std::collections::BTreeSet<&str> = (0..10).map(run_colour).collect();
        assert_eq!(colours.len(), 10, "{colours:?}");
        assert!(!colours.contains(AGGREGATE_COLOUR));
        assert_eq!(run_colour(10), run_colour(0));
    }

    fn synthetic_run(label: &str, generations: u32, seed: u32) -> RunLog {
        let rows = (0..generations)
            .map(|g| {
                let progress = 1.0 - (-(f64::from(g)) / (25.0 + f64::from(seed) * 7.0)).exp();
                let wobble = (f64::from(g * (seed + 3)) * 0.7).sin() * 0.03;
                let best = 0.1 + 0.8 * progress + wobble;
                let mean = 0.05 + 0.45 * progress + 0.5 * wobble;
                FitnessRow {
                    generation: g,
                    best,
                    mean,
                    min: mean - 0.2,
                    max: best,
                    std: 0.1,
                }
            })
            .collect();
        RunLog {
            label: label.to_string(),
            rows,
        }
    }

    fn render(runs: &[RunLog]) -> Vec<Element> {
        let svg = fitness_plot_svg("Solve maze: 3 runs <test> & more", runs, None);
        parse(&svg).unwrap_or_else(|e| panic!("malformed SVG: {e}"))
    }

    #[test]
    fn each_run_has_one_point_per_generation() {
        let runs = vec![
            synthetic_run("run 0", 60, 0),
            synthetic_run("run 1", 45, 1),
            synthetic_run("run 2", 20, 2),
        ];
        let elements = render(&runs);
        for class in ["run-best", "run-mean"] {
            let lines = with_class(&elements, class);
            assert_eq!(lines.len(), runs.len());
            for line in lines {
                let run = line.number("data-run") as usize;
                let points = line.points();
                assert_eq!(points.len(), runs[run].rows.len(), "{class} of run {run}");
                // x increases with the generation.
                assert!(points.windows(2).all(|p| p[1][0] > p[0][0]));
            }
        }
        // The across-run mean runs while at least two runs have data: up to generation 44.
        let aggregate = with_class(&elements, "aggregate-mean");
        assert_eq!(aggregate.len(), 1);
        assert_eq!(aggregate[0].points().len(), 45);
        assert_eq!(
            with_class(&elements, "aggregate-band")[0].points().len(),
            90
        );
        let labels: Vec<&str> = with_class(&elements, "legend")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert_eq!(labels, ["run 0", "run 1", "run 2"]);
        assert_eq!(
            with_class(&elements, "title")[0].text,
            "Solve maze: 3 runs <test> & more"
        );
    }

    #[test]
    fn y_axis_covers_the_data_and_points_lie_inside_the_plot() {
        let mut runs = vec![synthetic_run("a", 30, 0), synthetic_run("b", 30, 4)];
        runs[1].rows[7].best = 3.7;
        runs[0].rows[2].mean = -1.25;
        let elements = render(&runs);
        let area = with_class(&elements, "plot-area")[0];
        let (y_min, y_max) = (area.number("data-y-min"), area.number("data-y-max"));
        assert!(y_min <= -1.25 && y_max >= 3.7, "[{y_min}, {y_max}]");
        assert!(area.number("data-x-max") >= 29.0);
        let (top, bottom) = (area.number("y"), area.number("y") + area.number("height"));
        for class in ["run-best", "run-mean", "aggregate-mean"] {
            for line in with_class(&elements, class) {
                for [_, y] in line.points() {
                    assert!(
                        y >= top - 0.01 && y <= bottom + 0.01,
                        "{class}: {y} outside [{top}, {bottom}]"
                    );
                }
            }
        }
        // Tick labels run from the axis minimum to its maximum.
        let ticks: Vec<f64> = with_class(&elements, "y-tick-label")
            .iter()
            .map(|e| e.text.parse().expect("number"))
            .collect();
        assert!(
            (ticks[0] - y_min).abs() < 1e-9 && (ticks[ticks.len() - 1] - y_max).abs() < 1e-9,
            "{ticks:?}"
        );
    }

    #[test]
    fn a_live_run_is_drawn_against_its_planned_generations() {
        let runs = [synthetic_run("run 0", 12, 0)];
        let live = fitness_plot_svg("t", &runs, Some(500));
        let elements = parse(&live).expect("well-formed");
        let area = with_class(&elements, "plot-area")[0];
        assert_eq!(area.number("data-x-max"), 500.0);
        // Without a plan the axis ends just past the data, and a plan already passed changes
        // nothing.
        let elements = render(&runs);
        assert!(with_class(&elements, "plot-area")[0].number("data-x-max") < 20.0);
        let past = fitness_plot_svg("t", &runs, Some(5));
        assert_eq!(past, fitness_plot_svg("t", &runs, None));
    }

    #[test]
    fn degenerate_inputs_still_draw() {
        let elements = render(&[]);
        assert_eq!(with_class(&elements, "no-data").len(), 1);
        let flat = RunLog {
            label: "flat".into(),
            rows: vec![FitnessRow {
                generation: 0,
                best: 2.0,
                mean: 2.0,
                min: 2.0,
                max: 2.0,
                std: 0.0,
            }],
        };
        let elements = render(&[flat]);
        let area = with_class(&elements, "plot-area")[0];
        assert!(area.number("data-y-min") < 2.0 && area.number("data-y-max") > 2.0);
        assert!(
            with_class(&elements, "aggregate-mean").is_empty(),
            "one run has no across-run mean"
        );
        let mut broken = synthetic_run("broken", 5, 0);
        broken.rows[2].best = f64::NAN;
        let svg = fitness_plot_svg("t", &[broken], None);
        assert!(!svg.contains("NaN"));
        let elements = parse(&svg).expect("well-formed");
        assert_eq!(with_class(&elements, "run-best")[0].points().len(), 4);
    }

    #[test]
    fn ticks_are_round_numbers() {
        assert_eq!(nice_step(1.0, 5.0), 0.2);
        assert_eq!(nice_step(100.0, 8.0), 20.0);
        assert_eq!(nice_step(7.0, 8.0), 1.0);
        let (low, high, step) = axis_range(0.13, 0.87, 6.0);
        assert!(low.abs() < 1e-9 && (high - 1.0).abs() < 1e-9 && (step - 0.2).abs() < 1e-12);
        let (low, high, step) = axis_range(0.13, 0.87, 8.0);
        assert!(
            (low - 0.1).abs() < 1e-9 && (high - 0.9).abs() < 1e-9 && (step - 0.1).abs() < 1e-12
        );
        assert_eq!(tick_label(0.30000000000000004, 0.1), "0.3");
        assert_eq!(tick_label(-0.0, 0.1), "0");
        assert_eq!(tick_label(500.0, 100.0), "500");
    }
}
