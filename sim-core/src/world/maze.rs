//! The authors' layout format (JBotEvolver's `W`/`S`/`L` lines), read only by tests: the
//! double T-maze in `data/double-t-maze.txt` is the reference the shipped scenario map
//! (`scenarios/maps/double_t_maze.toml`) is checked against, cell by cell, wall by wall,
//! path by path and light by light. Parsing is strict: a malformed line is an error naming
//! its line number.

use crate::geometry::cells::{Cell, CellMap};
use std::sync::OnceLock;

/// The layout file shipped with hevo (a copy of `shared/data/double-t-maze.txt`).
pub const BUILTIN_MAZE: &str = include_str!("../../data/double-t-maze.txt");

/// A light in the stem.
#[derive(Debug, Clone, PartialEq)]
pub struct MazeLight {
    /// Position in metres.
    pub position: [f32; 2],
    /// The light configurations in which this light flashes.
    pub configurations: Vec<u32>,
}

/// The parsed maze.
#[derive(Debug, Clone)]
pub struct MazeLayout {
    /// Cells and walls.
    pub map: CellMap,
    /// For each light configuration, the cell indices of the correct path from the entrance
    /// to the goal (the last cell).
    pub paths: Vec<Vec<usize>>,
    /// The lights of the stem.
    pub lights: Vec<MazeLight>,
}

/// A problem in a maze layout file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("maze layout line {line}: {message}")]
pub struct MazeError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

use super::corridor::MAZE_WALL_THICKNESS;
use crate::config::MAZE_CELL_SIZE;

impl MazeLayout {
    /// The shipped layout, parsed once.
    pub fn builtin() -> &'static MazeLayout {
        static LAYOUT: OnceLock<MazeLayout> = OnceLock::new();
        LAYOUT.get_or_init(|| {
            MazeLayout::parse(BUILTIN_MAZE).expect("the shipped maze layout is valid")
        })
    }

    /// Parses a layout file (format documented in the file's own header).
    pub fn parse(text: &str) -> Result<MazeLayout, MazeError> {
        let mut cells = Vec::new();
        let mut raw_paths: Vec<(usize, Vec<usize>)> = Vec::new();
        let mut lights = Vec::new();
        for (line_idx, raw_line) in text.lines().enumerate() {
            let line_no = line_idx + 1;
            let line = raw_line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let error = |message: String| MazeError {
                line: line_no,
                message,
            };
            let fields: Vec<&str> = line.split(';').map(str::trim).collect();
            let number = |idx: usize| -> Result<f32, MazeError> {
                fields
                    .get(idx)
                    .ok_or_else(|| error(format!("missing field {idx}")))?
                    .parse::<f32>()
                    .map_err(|_| error(format!("field {idx} '{}' is not a number", fields[idx])))
            };
            match fields[0] {
                "W" => {
                    if fields.len() != 7 {
                        return Err(error(format!(
                            "a W line has 7 fields, found {}",
                            fields.len()
                        )));
                    }
                    let mut walls = [false; 4];
                    for (side, wall) in walls.iter_mut().enumerate() {
                        *wall = match fields[3 + side] {
                            "0" => false,
                            "1" => true,
                            other => {
                                return Err(error(format!("wall flag '{other}' is not 0 or 1")));
                            }
                        };
                    }
                    let (x, y) = (number(1)?, number(2)?);
                    if x.fract() != 0.0 || y.fract() != 0.0 {
                        return Err(error("cell coordinates must be whole numbers".into()));
                    }
                    cells.push(Cell {
                        at: [x as i32, y as i32],
                        walls,
                    });
                }
                "S" => {
                    let path = fields[1..]
                        .iter()
                        .map(|f| {
                            f.parse::<usize>()
                                .map_err(|_| error(format!("'{f}' is not a cell number")))
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    if path.len() < 2 {
                        return Err(error("a path needs at least two cells".into()));
                    }
                    raw_paths.push((line_no, path));
                }
                "L" => {
                    if fields.len() < 4 {
                        return Err(error(
                            "an L line needs x, y and at least one configuration".into(),
                        ));
                    }
                    let configurations = fields[3..]
                        .iter()
                        .map(|f| {
                            f.parse::<u32>()
                                .map_err(|_| error(format!("'{f}' is not a configuration number")))
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    lights.push(MazeLight {
                        position: [number(1)? * MAZE_CELL_SIZE, number(2)? * MAZE_CELL_SIZE],
                        configurations,
                    });
                }
                other => return Err(error(format!("unknown record type '{other}'"))),
            }
        }
        let n_cells = cells.len();
        let map = CellMap::new(cells, MAZE_CELL_SIZE, MAZE_WALL_THICKNESS);
        for (line, path) in &raw_paths {
            for window in path.windows(2) {
                let (a, b) = (window[0], window[1]);
                if a >= n_cells || b >= n_cells {
                    return Err(MazeError {
                        line: *line,
                        message: format!("cell {} does not exist", a.max(b)),
                    });
                }
                if !map.neighbours(a).any(|n| n == b) {
                    return Err(MazeError {
                        line: *line,
                        message: format!("cells {a} and {b} are not connected by an open border"),
                    });
                }
            }
        }
        let n_configurations = raw_paths.len() as u32;
        if n_configurations == 0 {
            return Err(MazeError {
                line: 0,
                message: "no S (path) lines".into(),
            });
        }
        for light in &lights {
            if let Some(bad) = light
                .configurations
                .iter()
                .find(|&&c| c >= n_configurations)
            {
                return Err(MazeError {
                    line: 0,
                    message: format!(
                        "a light names configuration {bad}, only {n_configurations} exist"
                    ),
                });
            }
        }
        Ok(MazeLayout {
            map,
            paths: raw_paths.into_iter().map(|(_, p)| p).collect(),
            lights,
        })
    }

    /// Number of light configurations (four in the paper's maze).
    pub fn n_configurations(&self) -> u32 {
        self.paths.len() as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_maze_has_four_paths_and_four_lights() {
        let maze = MazeLayout::builtin();
        assert_eq!(maze.n_configurations(), 4);
        assert_eq!(maze.lights.len(), 4);
        assert_eq!(maze.map.cells.len(), 19);
        // Every configuration has exactly one light per row.
        for config in 0..4 {
            let lit: Vec<_> = maze
                .lights
                .iter()
                .filter(|l| l.configurations.contains(&config))
                .collect();
            assert_eq!(lit.len(), 2);
            assert_ne!(lit[0].position[1], lit[1].position[1]);
        }
        // The goals are the four different branch ends.
        let mut goals: Vec<usize> = maze.paths.iter().map(|p| *p.last().unwrap()).collect();
        goals.sort();
        goals.dedup();
        assert_eq!(goals.len(), 4);
    }

    #[test]
    fn a_right_light_means_a_right_turn() {
        // Drive up the stem (+y): a light at x > 0 is on the right. The path's turn at each
        // junction must agree with the side of the light in that row.
        let maze = MazeLayout::builtin();
        for (config, path) in maze.paths.iter().enumerate() {
            let rows: Vec<&MazeLight> = {
                let mut lit: Vec<_> = maze
                    .lights
                    .iter()
                    .filter(|l| l.configurations.contains(&(config as u32)))
                    .collect();
                lit.sort_by(|a, b| a.position[1].total_cmp(&b.position[1]));
                lit
            };
            let mut turns = Vec::new();
            for w in path.windows(3) {
                let [a, b, c] = [w[0], w[1], w[2]].map(|i| maze.map.center(i));
                let (d1, d2) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
                let cross = d1[0] * d2[1] - d1[1] * d2[0];
                if cross.abs() > 1e-6 {
                    turns.push(if cross > 0.0 { "left" } else { "right" });
                }
            }
            let lights: Vec<&str> = rows
                .iter()
                .map(|l| if l.position[0] > 0.0 { "right" } else { "left" })
                .collect();
            assert_eq!(turns, lights, "configuration {config}");
        }
    }

    /// The table of docs/model.md 5.4, written out: which light of each row flashes in each
    /// configuration, and which branch end is its goal. Consistency between lights and turns
    /// (`a_right_light_means_a_right_turn`) does not pin the numbering; this does.
    #[test]
    fn the_configurations_are_the_documented_ones() {
        // (configuration, row 1 light, row 2 light, goal cell); +1 right, -1 left.
        let documented = [
            (0, 1, -1, [3, 1]),
            (1, 1, 1, [3, -3]),
            (2, -1, 1, [-3, 1]),
            (3, -1, -1, [-3, -3]),
        ];
        let maze = MazeLayout::builtin();
        for (config, row_1, row_2, goal) in documented {
            let lit = |y: f32| -> Vec<f32> {
                maze.lights
                    .iter()
                    .filter(|l| {
                        (l.position[1] - y).abs() < 1e-4 && l.configurations.contains(&config)
                    })
                    .map(|l| l.position[0].signum())
                    .collect()
            };
            // Row 1 at y = -1.20 m, row 2 at y = -0.798 m, lights at x = ±0.099 m.
            assert_eq!(
                lit(-1.2),
                vec![row_1 as f32],
                "configuration {config}, row 1"
            );
            assert_eq!(
                lit(-0.798),
                vec![row_2 as f32],
                "configuration {config}, row 2"
            );
            let path = &maze.paths[config as usize];
            assert_eq!(
                maze.map.cells[path[0]].at,
                [0, -5],
                "configuration {config}"
            );
            assert_eq!(
                maze.map.cells[*path.last().unwrap()].at,
                goal,
                "configuration {config}"
            );
        }
        for light in &maze.lights {
            assert!((light.position[0].abs() - 0.099).abs() < 1e-4, "{light:?}");
        }
    }

    #[test]
    fn malformed_files_name_the_line() {
        let err = MazeLayout::parse("# c\nW;0;0;1;1;1\n").unwrap_err();
        assert_eq!(err.line, 2);
        let err = MazeLayout::parse("W;0;0;1;1;1;x\n").unwrap_err();
        assert!(err.message.contains("'x'"));
        let err = MazeLayout::parse("W;0;0;1;1;0;1\nW;0;1;1;1;1;1\nS;0;1\n").unwrap_err();
        assert!(err.message.contains("not connected"), "{err}");
    }
}
