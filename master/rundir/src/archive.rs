//! A MAP-Elites run's archive in its run directory, written by the runner after every
//! generation and read by `hevo plot`, `hevo archive export` and the dashboard:
//!
//! - `archive.json` ([`ArchiveFile`]): the grid (the descriptor's quantity names, bins and
//!   ranges) and every elite (its cell, its bin along each value, fitness, descriptor, genes).
//! - `qd.csv` ([`QdRow`]): per generation, the cells filled, the grid's cells, coverage (the
//!   share filled), QD-score (the sum of the elites' fitness) and the best elite's fitness.
//!
//! Both are kept when the run is finished, beside its fitness log, best controller and summary.

use serde::{Deserialize, Serialize};
use std::path::Path;

pub use crate::layout::{ARCHIVE_JSON, QD_CSV};
/// The format tag of [`ArchiveFile`].
pub const ARCHIVE_FORMAT: &str = "hevo.archive/1";
/// The header a `qd.csv` starts with.
pub const QD_CSV_HEADER: &str = "generation,filled,cells,coverage,qd_score,best";

/// A grid archive as saved.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArchiveFile {
    /// [`ARCHIVE_FORMAT`].
    pub format: String,
    /// Generations told when it was written.
    pub generation: u32,
    /// The descriptor's quantities, in order (the grid's axes).
    pub descriptor: Vec<String>,
    /// Bins along each descriptor value.
    pub bins: Vec<u32>,
    /// Each descriptor value's range `[lo, hi]`; values outside were filed in the edge bins.
    pub ranges: Vec<[f64; 2]>,
    /// The elites, by cell.
    pub elites: Vec<ArchiveElite>,
}

/// One filled cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArchiveElite {
    /// The cell's index: row-major over `bins`, the first descriptor value slowest.
    pub cell: u64,
    /// The cell's bin along each descriptor value.
    pub bins: Vec<u32>,
    /// The elite's fitness (the mean over the samples of the generation it was evaluated in).
    pub fitness: f64,
    /// Its behaviour descriptor (the mean over those samples).
    pub descriptor: Vec<f64>,
    /// Its genes: the node's free genome.
    pub genes: Vec<f32>,
}

impl ArchiveFile {
    /// The grid's cells.
    pub fn n_cells(&self) -> u64 {
        self.bins.iter().map(|&b| u64::from(b)).product()
    }

    /// Checks what a reader relies on: the format, one name, bin count and range per
    /// descriptor value, and every elite's bins inside the grid and matching its cell.
    pub fn check(&self) -> Result<(), String> {
        if self.format != ARCHIVE_FORMAT {
            return Err(format!(
                "format `{}`, expected `{ARCHIVE_FORMAT}`",
                self.format
            ));
        }
        let n = self.bins.len();
        if n == 0 || self.ranges.len() != n || self.descriptor.len() != n {
            return Err(format!(
                "{} bin counts, {} ranges and {} descriptor names; expected one each per descriptor value",
                n,
                self.ranges.len(),
                self.descriptor.len()
            ));
        }
        if self.bins.contains(&0) {
            return Err("a bin count of 0".into());
        }
        for elite in &self.elites {
            let cell = elite
                .bins
                .iter()
                .zip(&self.bins)
                .fold(0u64, |cell, (&bin, &n_bins)| {
                    cell.saturating_mul(u64::from(n_bins))
                        .saturating_add(u64::from(bin))
                });
            let inside = elite.bins.len() == n
                && elite
                    .bins
                    .iter()
                    .zip(&self.bins)
                    .all(|(b, n_bins)| b < n_bins);
            if !inside || cell != elite.cell || !elite.fitness.is_finite() {
                return Err(format!(
                    "the elite of cell {} (bins {:?}, fitness {}) is not in a {:?} grid",
                    elite.cell, elite.bins, elite.fitness, self.bins
                ));
            }
        }
        Ok(())
    }

    /// Reads and checks an `archive.json`; the error names the file.
    pub fn read(path: &Path) -> Result<ArchiveFile, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let archive: ArchiveFile =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        archive
            .check()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(archive)
    }
}

/// One generation's line of a `qd.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QdRow {
    /// Generation, from 0.
    pub generation: u32,
    /// Cells filled after it was told.
    pub filled: u64,
    /// The grid's cells.
    pub cells: u64,
    /// QD-score: the sum of the elites' fitness.
    pub qd_score: f64,
    /// The best elite's fitness.
    pub best: f64,
}

impl QdRow {
    /// The share of cells filled.
    pub fn coverage(&self) -> f64 {
        self.filled as f64 / self.cells.max(1) as f64
    }
}

/// A `qd.csv`'s text: the header, then one line per row.
pub fn qd_csv(rows: &[QdRow]) -> String {
    let mut text = String::from(QD_CSV_HEADER);
    text.push('\n');
    for row in rows {
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            row.generation,
            row.filled,
            row.cells,
            row.coverage(),
            row.qd_score,
            row.best
        ));
    }
    text
}

/// Parses a `qd.csv` written by [`qd_csv`]; the error names the line and column.
pub fn parse_qd_csv(text: &str) -> Result<Vec<QdRow>, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| (index + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty());
    match lines.next() {
        Some((_, header)) if header == QD_CSV_HEADER => {}
        Some((line, header)) => {
            return Err(format!(
                "line {line}: header `{header}`, expected `{QD_CSV_HEADER}`"
            ));
        }
        None => return Err(format!("empty; expected the header `{QD_CSV_HEADER}`")),
    }
    let columns: Vec<&str> = QD_CSV_HEADER.split(',').collect();
    lines
        .map(|(line, content)| {
            let fields: Vec<&str> = content.split(',').collect();
            if fields.len() != columns.len() {
                return Err(format!(
                    "line {line}: {} fields, expected {}",
                    fields.len(),
                    columns.len()
                ));
            }
            let bad = |column: usize| {
                format!(
                    "line {line}, column {} ({}): `{}` is not a number",
                    column + 1,
                    columns[column],
                    fields[column]
                )
            };
            let whole = |column: usize| fields[column].parse::<u64>().map_err(|_| bad(column));
            let real = |column: usize| {
                fields[column]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad(column))
            };
            Ok(QdRow {
                generation: u32::try_from(whole(0)?).map_err(|_| bad(0))?,
                filled: whole(1)?,
                cells: whole(2)?,
                qd_score: real(4)?,
                best: real(5)?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn archive() -> ArchiveFile {
        ArchiveFile {
            format: ARCHIVE_FORMAT.into(),
            generation: 3,
            descriptor: vec!["final.x".into(), "final.y".into()],
            bins: vec![2, 3],
            ranges: vec![[0.0, 1.0], [-1.0, 1.0]],
            elites: vec![ArchiveElite {
                cell: 5,
                bins: vec![1, 2],
                fitness: 0.5,
                descriptor: vec![0.9, 0.9],
                genes: vec![0.25, -1.5],
            }],
        }
    }

    #[test]
    fn an_archive_reads_back_and_a_misplaced_elite_is_named() {
        let good = archive();
        assert_eq!(good.check(), Ok(()));
        assert_eq!(good.n_cells(), 6);
        let json = serde_json::to_string(&good).unwrap();
        assert_eq!(serde_json::from_str::<ArchiveFile>(&json).unwrap(), good);
        let mut moved = archive();
        moved.elites[0].cell = 4;
        assert!(moved.check().unwrap_err().contains("cell 4"));
        let mut outside = archive();
        outside.elites[0].bins = vec![2, 0];
        outside.elites[0].cell = 6;
        assert!(
            outside
                .check()
                .unwrap_err()
                .contains("not in a [2, 3] grid")
        );
        let mut unnamed = archive();
        unnamed.descriptor.pop();
        assert!(unnamed.check().unwrap_err().contains("1 descriptor names"));
    }

    #[test]
    fn a_qd_log_reads_back_and_a_bad_field_is_named() {
        let rows = vec![
            QdRow {
                generation: 0,
                filled: 3,
                cells: 400,
                qd_score: 1.25,
                best: 0.75,
            },
            QdRow {
                generation: 1,
                filled: 5,
                cells: 400,
                qd_score: 2.5,
                best: 0.875,
            },
        ];
        let text = qd_csv(&rows);
        assert!(text.starts_with(
            "generation,filled,cells,coverage,qd_score,best\n0,3,400,0.0075,1.25,0.75\n"
        ));
        assert_eq!(parse_qd_csv(&text).unwrap(), rows);
        let broken = text.replace("2.5", "x");
        assert_eq!(
            parse_qd_csv(&broken).unwrap_err(),
            "line 3, column 5 (qd_score): `x` is not a number"
        );
        assert!(
            parse_qd_csv("generation,best\n")
                .unwrap_err()
                .starts_with("line 1: header")
        );
    }
}
