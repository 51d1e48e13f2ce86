//! Pictures of a MAP-Elites run, as SVG: its archive as a heatmap (each cell of the grid
//! coloured by its elite's fitness, empty cells grey, the axes named by the descriptor's
//! quantities) and the QD-score and coverage of a node's runs per generation. They read the
//! `archive.json` and `qd.csv` of `hevo_rundir::archive`.

use crate::plot::{axis_range, nice_step, run_colour, tick_label};
use crate::svg::{INK, SvgDocument, Tag, num_with, points, text_width};
use hevo_rundir::archive::{ArchiveFile, QD_CSV, QdRow, parse_qd_csv};
use std::path::Path;

const PAD: f64 = 16.0;
const TITLE_FONT: f64 = 20.0;
const AXIS_FONT: f64 = 15.0;
const TICK_FONT: f64 = 13.0;
const EMPTY_COLOUR: &str = "#eeeeee";

/// Every run's `qd.csv` under a node directory, in run order, each labelled `run <k>`; runs
/// without one are left out, a log that does not parse is an error naming its file.
pub fn read_qd_logs(node_dir: &Path) -> Result<Vec<(String, Vec<QdRow>)>, String> {
    let runs = hevo_rundir::run_dirs(node_dir)
        .map_err(|e| format!("cannot read {}: {e}", node_dir.display()))?;
    let mut logs = Vec::new();
    for (run, dir) in runs {
        let path = dir.join(QD_CSV);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let rows = parse_qd_csv(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        logs.push((format!("run {run}"), rows));
    }
    Ok(logs)
}

/// A colour for a share in [0, 1] on a perceptually ordered ramp (viridis' end points and
/// three stops between), dark for low fitness and yellow for high.
fn ramp(share: f64) -> String {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let position = share.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let idx = (position.floor() as usize).min(STOPS.len() - 2);
    let t = position - idx as f64;
    let channel =
        |c: usize| (STOPS[idx][c] + t * (STOPS[idx + 1][c] - STOPS[idx][c])).round() as u8;
    format!("#{:02x}{:02x}{:02x}", channel(0), channel(1), channel(2))
}

/// The archive of a grid of one or two descriptor values as a heatmap: one value is drawn as a
/// single row. The grid's cells are square where they fit; the colour bar runs from the lowest
/// to the highest elite's fitness. Each cell carries its data (`data-cell`, `data-fitness`).
pub fn archive_heatmap_svg(title: &str, archive: &ArchiveFile) -> Result<String, String> {
    archive.check()?;
    let (x_bins, y_bins) = match archive.bins.as_slice() {
        [x] => (*x, 1),
        [x, y] => (*x, *y),
        more => {
            return Err(format!(
                "a heatmap draws grids of 1 or 2 descriptor values; this archive has {}",
                more.len()
            ));
        }
    };
    let (left, top) = (96.0, 54.0);
    let cell = (560.0 / f64::from(x_bins.max(y_bins))).clamp(1.0, 40.0);
    let (grid_width, grid_height) = (cell * f64::from(x_bins), cell * f64::from(y_bins));
    let bar_left = left + grid_width + 36.0;
    let width = (bar_left + 110.0).max(2.0 * PAD + text_width(title, TITLE_FONT));
    let height = top + grid_height + 64.0;
    let (low, high) = archive
        .elites
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
            (lo.min(e.fitness), hi.max(e.fitness))
        });
    let share = |fitness: f64| {
        if high > low {
            (fitness - low) / (high - low)
        } else {
            1.0
        }
    };

    let mut doc = SvgDocument::new(width, height, "archive-heatmap");
    doc.heading(title, PAD, TITLE_FONT);
    doc.open(Tag::new("g").class("cells"));
    doc.leaf(
        Tag::new("rect")
            .class("grid")
            .num("x", left)
            .num("y", top)
            .num("width", grid_width)
            .num("height", grid_height)
            .attr("fill", EMPTY_COLOUR)
            .attr("stroke", INK)
            .attr("data-cells", archive.n_cells().to_string())
            .attr("data-filled", archive.elites.len().to_string()),
    );
    for elite in &archive.elites {
        let x_bin = elite.bins[0];
        let y_bin = elite.bins.get(1).copied().unwrap_or(0);
        // The second value grows upwards, as a y axis does.
        let y = top + grid_height - cell * f64::from(y_bin + 1);
        doc.leaf(
            Tag::new("rect")
                .class("elite")
                .num("x", left + cell * f64::from(x_bin))
                .num("y", y)
                .num("width", cell)
                .num("height", cell)
                .attr("fill", ramp(share(elite.fitness)))
                .attr("data-cell", elite.cell.to_string())
                .attr("data-fitness", num_with(elite.fitness, 6)),
        );
    }
    doc.close();

    // Axes: the ranges' ends and round values between, named by the descriptor's quantities.
    doc.open(Tag::new("g").class("axes").attr("fill", INK));
    let axis_ticks = |lo: f64, hi: f64| {
        let step = nice_step(hi - lo, 5.0);
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        (first..=last)
            .map(|i| i as f64 * step)
            .map(|v| (v, tick_label(v, step)))
            .collect::<Vec<_>>()
    };
    let [x_lo, x_hi] = archive.ranges[0];
    for (value, label) in axis_ticks(x_lo, x_hi) {
        let x = left + (value - x_lo) / (x_hi - x_lo) * grid_width;
        doc.text(
            Tag::new("text")
                .class("x-tick-label")
                .num("x", x)
                .num("y", top + grid_height + 18.0)
                .num("font-size", TICK_FONT)
                .attr("text-anchor", "middle"),
            &label,
        );
    }
    doc.text(
        Tag::new("text")
            .class("axis-label")
            .num("x", left + 0.5 * grid_width)
            .num("y", top + grid_height + 42.0)
            .num("font-size", AXIS_FONT)
            .attr("text-anchor", "middle"),
        &archive.descriptor[0],
    );
    if let (Some([y_lo, y_hi]), Some(name)) = (archive.ranges.get(1), archive.descriptor.get(1)) {
        for (value, label) in axis_ticks(*y_lo, *y_hi) {
            let y = top + grid_height - (value - y_lo) / (y_hi - y_lo) * grid_height;
            doc.text(
                Tag::new("text")
                    .class("y-tick-label")
                    .num("x", left - 8.0)
                    .num("y", y + 4.5)
                    .num("font-size", TICK_FONT)
                    .attr("text-anchor", "end"),
                &label,
            );
        }
        let centre = [26.0, top + 0.5 * grid_height];
        doc.text(
            Tag::new("text")
                .class("axis-label")
                .num("x", centre[0])
                .num("y", centre[1])
                .num("font-size", AXIS_FONT)
                .attr("text-anchor", "middle")
                .attr(
                    "transform",
                    format!("rotate(-90 {} {})", centre[0], centre[1]),
                ),
            name,
        );
    }
    doc.close();

    // The colour bar: fitness from the lowest elite's (bottom) to the highest's (top).
    doc.open(Tag::new("g").class("colour-bar"));
    let bar_height = grid_height.max(120.0);
    const STEPS: usize = 32;
    for step in 0..STEPS {
        let share = step as f64 / (STEPS - 1) as f64;
        doc.leaf(
            Tag::new("rect")
                .num("x", bar_left)
                .num(
                    "y",
                    top + bar_height * (1.0 - (step + 1) as f64 / STEPS as f64),
                )
                .num("width", 16.0)
                .num("height", bar_height / STEPS as f64 + 0.5)
                .attr("fill", ramp(share)),
        );
    }
    let label = |value: f64| {
        if value.is_finite() {
            format!("{value:.3}")
        } else {
            "none".into()
        }
    };
    for (y, value) in [(top + 10.0, high), (top + bar_height, low)] {
        doc.text(
            Tag::new("text")
                .class("colour-bar-label")
                .num("x", bar_left + 22.0)
                .num("y", y)
                .num("font-size", TICK_FONT)
                .attr("fill", INK),
            &label(value),
        );
    }
    doc.text(
        Tag::new("text")
            .class("colour-bar-title")
            .num("x", bar_left)
            .num("y", top - 10.0)
            .num("font-size", TICK_FONT)
            .attr("fill", INK),
        "fitness",
    );
    doc.close();
    Ok(doc.finish())
}

/// The QD-score (top) and coverage (bottom) of every run per generation, one colour per run.
pub fn qd_plot_svg(title: &str, runs: &[(String, Vec<QdRow>)]) -> String {
    const WIDTH: f64 = 800.0;
    const LEFT: f64 = 78.0;
    const RIGHT: f64 = WIDTH - 24.0;
    const PANEL: f64 = 220.0;
    let panels = [(54.0, "QD-score"), (54.0 + PANEL + 56.0, "coverage (%)")];
    let legend_top = panels[1].0 + PANEL + 60.0;
    let height = legend_top + 24.0 * runs.len().div_ceil(6).max(1) as f64 + PAD;
    let last_generation = runs
        .iter()
        .flat_map(|(_, rows)| rows.last())
        .map(|r| r.generation)
        .max()
        .unwrap_or(1)
        .max(1);
    let x_step = nice_step(f64::from(last_generation), 8.0).max(1.0).round();
    let x_max = (f64::from(last_generation) / x_step).ceil() * x_step;
    let x_of = |generation: u32| LEFT + f64::from(generation) / x_max * (RIGHT - LEFT);
    let values: [fn(&QdRow) -> f64; 2] = [|r| r.qd_score, |r| 100.0 * r.coverage()];

    let mut doc = SvgDocument::new(WIDTH, height, "qd-plot");
    doc.heading(title, PAD, TITLE_FONT);
    for ((top, name), value) in panels.into_iter().zip(values) {
        let bottom = top + PANEL;
        let (low, high) = runs
            .iter()
            .flat_map(|(_, rows)| rows.iter().map(value))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        let (y_min, y_max, y_step) = axis_range(low, high, 4.0);
        let y_of = |v: f64| bottom - (v - y_min) / (y_max - y_min) * PANEL;
        doc.open(Tag::new("g").class("axes").attr("fill", INK));
        let ticks = ((y_max - y_min) / y_step).round() as usize;
        for i in 0..=ticks {
            let v = y_min + i as f64 * y_step;
            doc.leaf(
                Tag::new("line")
                    .class("grid")
                    .num("x1", LEFT)
                    .num("y1", y_of(v))
                    .num("x2", RIGHT)
                    .num("y2", y_of(v))
                    .attr("stroke", "#e6e6e6"),
            );
            doc.text(
                Tag::new("text")
                    .class("y-tick-label")
                    .num("x", LEFT - 8.0)
                    .num("y", y_of(v) + 4.5)
                    .num("font-size", TICK_FONT)
                    .attr("text-anchor", "end"),
                &tick_label(v, y_step),
            );
        }
        let x_ticks = (x_max / x_step).round() as usize;
        for i in 0..=x_ticks {
            let g = i as f64 * x_step;
            doc.text(
                Tag::new("text")
                    .class("x-tick-label")
                    .num("x", LEFT + g / x_max * (RIGHT - LEFT))
                    .num("y", bottom + 18.0)
                    .num("font-size", TICK_FONT)
                    .attr("text-anchor", "middle"),
                &tick_label(g, x_step),
            );
        }
        doc.leaf(
            Tag::new("path")
                .class("axis-line")
                .attr(
                    "d",
                    format!("M{LEFT} {top} L{LEFT} {bottom} L{RIGHT} {bottom}"),
                )
                .attr("fill", "none")
                .attr("stroke", INK),
        );
        doc.text(
            Tag::new("text")
                .class("axis-label")
                .num("x", LEFT)
                .num("y", top - 14.0)
                .num("font-size", AXIS_FONT),
            name,
        );
        doc.close();
        doc.open(Tag::new("g").class("data").attr("fill", "none"));
        for (run_idx, (label, rows)) in runs.iter().enumerate() {
            let line: Vec<[f64; 2]> = rows
                .iter()
                .map(|r| [x_of(r.generation), y_of(value(r))])
                .collect();
            doc.leaf(
                Tag::new("polyline")
                    .class("run")
                    .attr("points", points(&line))
                    .attr("stroke", run_colour(run_idx))
                    .attr("stroke-width", "2")
                    .attr("data-run", label),
            );
        }
        doc.close();
    }
    doc.text(
        Tag::new("text")
            .class("axis-label")
            .num("x", 0.5 * (LEFT + RIGHT))
            .num("y", legend_top - 16.0)
            .num("font-size", AXIS_FONT)
            .attr("text-anchor", "middle"),
        "generation",
    );
    doc.open(Tag::new("g").class("legend"));
    for (run_idx, (label, _)) in runs.iter().enumerate() {
        let (x, y) = (
            PAD + 128.0 * (run_idx % 6) as f64,
            legend_top + 24.0 * (run_idx / 6) as f64,
        );
        doc.leaf(
            Tag::new("line")
                .num("x1", x)
                .num("y1", y)
                .num("x2", x + 28.0)
                .num("y2", y)
                .attr("stroke", run_colour(run_idx))
                .attr("stroke-width", "3"),
        );
        doc.text(
            Tag::new("text")
                .num("x", x + 34.0)
                .num("y", y + 5.0)
                .num("font-size", TICK_FONT)
                .attr("fill", INK),
            label,
        );
    }
    doc.close();
    doc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::svg::read_back::{parse, with_class};
    use hevo_rundir::archive::{ARCHIVE_FORMAT, ArchiveElite};

    fn archive(bins: Vec<u32>) -> ArchiveFile {
        let n = bins.len();
        ArchiveFile {
            format: ARCHIVE_FORMAT.into(),
            generation: 4,
            descriptor: ["final.x", "final.y", "final.z"][..n]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            ranges: vec![[-1.0, 1.0]; n],
            elites: vec![
                ArchiveElite {
                    cell: 0,
                    bins: vec![0; n],
                    fitness: 0.25,
                    descriptor: vec![-0.9; n],
                    genes: vec![0.0],
                },
                ArchiveElite {
                    cell: (1..n).fold(3, |c, _| c * u64::from(bins[0]) + 3),
                    bins: vec![3; n],
                    fitness: 1.5,
                    descriptor: vec![0.9; n],
                    genes: vec![0.0],
                },
            ],
            bins,
        }
    }

    #[test]
    fn the_heatmap_colours_each_elite_s_cell_and_names_the_axes() {
        let svg = archive_heatmap_svg("maze: archive", &archive(vec![4, 4])).unwrap();
        let elements = parse(&svg).unwrap();
        let cells = with_class(&elements, "elite");
        assert_eq!(cells.len(), 2);
        // The least fit elite is the ramp's dark end, the fittest its yellow end.
        assert_eq!(cells[0].get("fill"), "#440154");
        assert_eq!(cells[1].get("fill"), "#fde725");
        assert_eq!(cells[1].get("data-fitness"), "1.5");
        // Bins (0, 0) at the bottom left, (3, 3) at the top right.
        assert!(cells[0].number("y") > cells[1].number("y"));
        assert!(cells[0].number("x") < cells[1].number("x"));
        let labels: Vec<&str> = with_class(&elements, "axis-label")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert_eq!(labels, ["final.x", "final.y"]);
        assert_eq!(with_class(&elements, "grid")[0].get("data-filled"), "2");
        // One value: a single row; three: refused, saying why.
        assert!(archive_heatmap_svg("row", &archive(vec![4])).is_ok());
        let error = archive_heatmap_svg("cube", &archive(vec![4, 4, 4])).unwrap_err();
        assert!(error.contains("1 or 2 descriptor values"), "{error}");
    }

    #[test]
    fn the_qd_plot_has_a_line_per_run_in_each_panel() {
        let rows = |scale: f64| {
            (0..5)
                .map(|g| QdRow {
                    generation: g,
                    filled: u64::from(g) * 3,
                    cells: 100,
                    qd_score: scale * f64::from(g),
                    best: 1.0,
                })
                .collect::<Vec<_>>()
        };
        let svg = qd_plot_svg(
            "maze: QD-score",
            &[("run 0".into(), rows(1.0)), ("run 1".into(), rows(2.0))],
        );
        let elements = parse(&svg).unwrap();
        let lines = with_class(&elements, "run");
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[0].get("data-run"), "run 0");
        assert_eq!(lines[0].points().len(), 5);
        // Run 1's QD-score doubles run 0's: its last point is higher on the page.
        assert!(lines[1].points()[4][1] < lines[0].points()[4][1]);
    }
}
