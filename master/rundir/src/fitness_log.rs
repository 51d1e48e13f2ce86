//! A run's fitness log, `fitness.csv`: one [`FitnessRow`] per generation, written by the runner
//! and read (with errors naming the line and column) by the plots, the report and the
//! dashboard.

/// One generation's line of a `fitness.csv` log (also kept in run checkpoints).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitnessRow {
    /// Generation number, from 0.
    pub generation: u32,
    /// Fitness of the generation's best genome.
    pub best: f64,
    /// Population mean fitness.
    pub mean: f64,
    /// Population minimum fitness.
    pub min: f64,
    /// Population maximum fitness.
    pub max: f64,
    /// Population standard deviation of fitness.
    pub std: f64,
}

/// A fitness log's text: the header, then one line per row.
pub fn fitness_csv(rows: &[FitnessRow]) -> String {
    let mut text = String::from(FITNESS_CSV_HEADER);
    text.push('\n');
    for row in rows {
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            row.generation, row.best, row.mean, row.min, row.max, row.std
        ));
    }
    text
}

/// The header a fitness log starts with.
pub const FITNESS_CSV_HEADER: &str = "generation,best,mean,min,max,std";
const COLUMNS: [&str; 6] = ["generation", "best", "mean", "min", "max", "std"];

/// A problem in a fitness log. Lines and columns count from 1.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitnessLogError {
    /// No header line.
    #[error("the fitness log is empty; expected the header `{FITNESS_CSV_HEADER}`")]
    Empty,
    /// The header lacks a required column.
    #[error("line {line}: the header has no column `{column}`; expected `{FITNESS_CSV_HEADER}`")]
    MissingColumn {
        /// Line of the header.
        line: usize,
        /// The missing column's name.
        column: &'static str,
    },
    /// The header names a column twice.
    #[error("line {line}, column {column}: the header names `{name}` a second time")]
    DuplicateColumn {
        /// Line of the header.
        line: usize,
        /// Position of the second occurrence.
        column: usize,
        /// The repeated name.
        name: String,
    },
    /// A row has more or fewer fields than the header.
    #[error(
        "line {line}: expected {expected} comma-separated fields like the header, found {found}"
    )]
    FieldCount {
        /// The row's line.
        line: usize,
        /// Fields in the header.
        expected: usize,
        /// Fields in the row.
        found: usize,
    },
    /// A field is not a valid value.
    #[error("line {line}, column {column} ({name}): `{value}` is not {expected}")]
    BadValue {
        /// The row's line.
        line: usize,
        /// The field's position.
        column: usize,
        /// The column's name.
        name: &'static str,
        /// The field as written.
        value: String,
        /// What the column holds.
        expected: &'static str,
    },
    /// Generations must increase from row to row.
    #[error(
        "line {line}, column {column} (generation): generation {generation} does not follow generation {previous}"
    )]
    GenerationOrder {
        /// The row's line.
        line: usize,
        /// The generation column's position.
        column: usize,
        /// This row's generation.
        generation: u32,
        /// The previous row's generation.
        previous: u32,
    },
}

/// Parses a `fitness.csv` log. The header must name the six columns of
/// [`FITNESS_CSV_HEADER`], in any order (extra columns are ignored, so a later writer may add
/// some); blank lines and `#` comments are skipped; generations must increase. An incomplete
/// last line, as a run being written may leave, is reported like any other bad line.
pub fn parse_fitness_csv(text: &str) -> Result<Vec<FitnessRow>, FitnessLogError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| (index + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'));
    let (header_line, header) = lines.next().ok_or(FitnessLogError::Empty)?;
    let header_fields: Vec<&str> = header.split(',').map(str::trim).collect();
    for (position, name) in header_fields.iter().enumerate() {
        if header_fields[..position].contains(name) {
            return Err(FitnessLogError::DuplicateColumn {
                line: header_line,
                column: position + 1,
                name: name.to_string(),
            });
        }
    }
    let mut positions = [0usize; 6];
    for (slot, column) in positions.iter_mut().zip(COLUMNS) {
        *slot = header_fields
            .iter()
            .position(|name| *name == column)
            .ok_or(FitnessLogError::MissingColumn {
                line: header_line,
                column,
            })?;
    }

    let mut rows: Vec<FitnessRow> = Vec::new();
    for (line, content) in lines {
        let fields: Vec<&str> = content.split(',').map(str::trim).collect();
        if fields.len() != header_fields.len() {
            return Err(FitnessLogError::FieldCount {
                line,
                expected: header_fields.len(),
                found: fields.len(),
            });
        }
        let generation_column = positions[0];
        let generation: u32 =
            fields[generation_column]
                .parse()
                .map_err(|_| FitnessLogError::BadValue {
                    line,
                    column: generation_column + 1,
                    name: "generation",
                    value: fields[generation_column].to_string(),
                    expected: "a whole number of generations",
                })?;
        let mut values = [0.0f64; 5];
        for (value, (&position, name)) in values
            .iter_mut()
            .zip(positions[1..].iter().zip(&COLUMNS[1..]))
        {
            *value = fields[position]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| FitnessLogError::BadValue {
                    line,
                    column: position + 1,
                    name,
                    value: fields[position].to_string(),
                    expected: "a finite number",
                })?;
        }
        if let Some(previous) = rows.last()
            && generation <= previous.generation
        {
            return Err(FitnessLogError::GenerationOrder {
                line,
                column: generation_column + 1,
                generation,
                previous: previous.generation,
            });
        }
        let [best, mean, min, max, std] = values;
        rows.push(FitnessRow {
            generation,
            best,
            mean,
            min,
            max,
            std,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic_rows(generations: u32) -> Vec<FitnessRow> {
        (0..generations)
            .map(|g| {
                let best = 0.1 + 0.8 * (1.0 - (-(f64::from(g)) / 30.0).exp());
                FitnessRow {
                    generation: g,
                    best,
                    mean: best / 2.0,
                    min: 0.0,
                    max: best,
                    std: 0.1,
                }
            })
            .collect()
    }

    #[test]
    fn csv_round_trips() {
        let rows = synthetic_rows(12);
        let parsed = parse_fitness_csv(&fitness_csv(&rows)).expect("valid log");
        assert_eq!(parsed.len(), 12);
        for (a, b) in parsed.iter().zip(&rows) {
            assert_eq!(a.generation, b.generation);
            assert!((a.best - b.best).abs() < 1e-12 && (a.std - b.std).abs() < 1e-12);
        }
        // Reordered and extra columns, CRLF line ends, blank lines and a byte-order mark.
        let text = "\u{feff}best,generation,std,mean,min,max,wall_seconds\r\n1.5,0,0.1,1,0.5,1.5,3\r\n\r\n2,1,0.1,1,0.5,2,4\r\n";
        let parsed = parse_fitness_csv(text).expect("valid log");
        assert_eq!(
            parsed[1],
            FitnessRow {
                generation: 1,
                best: 2.0,
                mean: 1.0,
                min: 0.5,
                max: 2.0,
                std: 0.1
            }
        );
    }

    #[test]
    fn csv_errors_name_the_line_and_column() {
        let header = FITNESS_CSV_HEADER;
        assert_eq!(parse_fitness_csv("\n \n"), Err(FitnessLogError::Empty));
        let err = parse_fitness_csv("generation,best,mean,min,max\n0,1,1,1,1\n").unwrap_err();
        assert_eq!(
            err,
            FitnessLogError::MissingColumn {
                line: 1,
                column: "std"
            }
        );
        assert!(err.to_string().starts_with("line 1:"), "{err}");

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n1,0.5,abc,0,1,0\n")).unwrap_err();
        assert!(
            matches!(
                err,
                FitnessLogError::BadValue {
                    line: 3,
                    column: 3,
                    name: "mean",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("line 3, column 3 (mean)"), "{err}");

        let err = parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n1,0.5,0.4\n")).unwrap_err();
        assert_eq!(
            err,
            FitnessLogError::FieldCount {
                line: 3,
                expected: 6,
                found: 3
            }
        );
        assert!(err.to_string().starts_with("line 3:"));

        let err = parse_fitness_csv(&format!("{header}\n-1,1,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::BadValue {
                line: 2,
                column: 1,
                name: "generation",
                ..
            }
        ));

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n0,NaN,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::BadValue {
                line: 3,
                column: 2,
                name: "best",
                ..
            }
        ));

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n\n0,1,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::GenerationOrder {
                line: 4,
                generation: 0,
                previous: 0,
                ..
            }
        ));

        let err = parse_fitness_csv("generation,best,best,mean,min,max,std\n").unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::DuplicateColumn {
                line: 1,
                column: 3,
                ..
            }
        ));
    }
}
