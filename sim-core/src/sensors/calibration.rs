//! Measured calibration tables shared by the IR proximity and the light sensor models. A table is
//! a CSV file with `#` comment lines, a header `distance_cm,mean_<curve>...,std_<curve>...` and one
//! row per measured distance. It is parsed once into per-curve mean and standard deviation columns,
//! and each curve is then resampled onto a uniform 1 mm distance grid so that a per-cycle lookup
//! is one index computation and one linear interpolation, with no search and no allocation.

use thiserror::Error;

/// Spacing of the uniform distance grid the curves are resampled onto, in metres. The measured
/// rows lie on multiples of 0.5 cm, so a 1 mm grid reproduces the piecewise-linear interpolation
/// between the rows exactly while keeping the grid small (121 points for 12 cm).
pub const GRID_STEP_M: f32 = 0.001;

/// The largest distance a table may list, in centimetres. Sensor tables cover a few centimetres;
/// the limit keeps a mistyped distance from asking for an enormous grid.
pub const MAX_TABLE_DISTANCE_CM: f64 = 100.0;

/// Why a calibration CSV could not be used. Line and column numbers count from 1 and refer to
/// the text as given, comment lines included.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// The text has no header line (only comments or blank lines).
    #[error("the calibration table has no header line")]
    MissingHeader,
    /// The first header column is not `distance_cm`.
    #[error(
        "line {line}, column {column}: the first column must be `distance_cm`, found `{found}`"
    )]
    BadDistanceHeader {
        line: usize,
        column: usize,
        found: String,
    },
    /// A header column is neither `mean_<curve>` nor `std_<curve>`.
    #[error(
        "line {line}, column {column}: column name `{found}` is neither `mean_<curve>` nor `std_<curve>`"
    )]
    BadColumnName {
        line: usize,
        column: usize,
        found: String,
    },
    /// A header column name appears twice.
    #[error("line {line}, column {column}: column `{name}` appears twice")]
    DuplicateColumn {
        line: usize,
        column: usize,
        name: String,
    },
    /// A curve has a mean column but no standard deviation column, or the other way round.
    #[error("line {line}: curve `{curve}` has no `{missing}` column")]
    UnpairedColumn {
        line: usize,
        curve: String,
        missing: String,
    },
    /// A data row has a different number of fields than the header.
    #[error("line {line}: expected {expected} comma-separated fields, found {found}")]
    WrongFieldCount {
        line: usize,
        expected: usize,
        found: usize,
    },
    /// A field is not a finite number.
    #[error("line {line}, column {column} (`{column_name}`): `{text}` is not a finite number")]
    BadNumber {
        line: usize,
        column: usize,
        column_name: String,
        text: String,
    },
    /// A distance is negative or larger than [`MAX_TABLE_DISTANCE_CM`].
    #[error(
        "line {line}, column 1 (`distance_cm`): distance {distance_cm} cm is outside 0..={MAX_TABLE_DISTANCE_CM} cm"
    )]
    DistanceOutOfRange { line: usize, distance_cm: f64 },
    /// A distance is not greater than the previous row's.
    #[error(
        "line {line}, column 1 (`distance_cm`): distance {distance_cm} cm is not greater than the previous row's {previous_cm} cm"
    )]
    DistanceNotIncreasing {
        line: usize,
        distance_cm: f64,
        previous_cm: f64,
    },
    /// A standard deviation is negative.
    #[error(
        "line {line}, column {column} (`{column_name}`): standard deviation {value} is negative"
    )]
    NegativeStd {
        line: usize,
        column: usize,
        column_name: String,
        value: f32,
    },
    /// The table has fewer than two data rows, so there is nothing to interpolate.
    #[error("the calibration table has {rows} data rows; at least 2 are needed")]
    TooFewRows { rows: usize },
    /// A sensor model needs a curve the table does not have.
    #[error("the calibration table has no `mean_{curve}`/`std_{curve}` columns")]
    MissingCurve { curve: String },
    /// An IR curve's mean at contact is not above its mean at the farthest distance, so readings
    /// cannot be mapped onto [0, 1].
    #[error(
        "curve `{curve}`: the mean at contact ({contact_mean}) is not above the mean at the farthest distance ({far_mean})"
    )]
    CurveNotDecreasing {
        curve: String,
        contact_mean: f32,
        far_mean: f32,
    },
}

/// One measured curve of a table: the mean and standard deviation of the raw reading at each of
/// the table's distances.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredCurve {
    /// The curve's name, the part after `mean_` / `std_` in the header.
    pub name: String,
    /// Mean raw reading at each table distance.
    pub mean: Vec<f32>,
    /// Standard deviation of the raw reading at each table distance.
    pub std: Vec<f32>,
}

impl MeasuredCurve {
    /// The average of several curves measured at the same distances: the mean of their means,
    /// and as spread the root mean square of their standard deviations (the pooled within-sensor
    /// noise, so an average sensor is as noisy as a typical one rather than as the spread between
    /// sensors). Curves with a different row count than the first are ignored.
    pub fn pooled(name: &str, curves: &[&MeasuredCurve]) -> MeasuredCurve {
        let rows = curves.first().map_or(0, |curve| curve.mean.len());
        let same_length: Vec<&MeasuredCurve> = curves
            .iter()
            .copied()
            .filter(|curve| curve.mean.len() == rows && curve.std.len() == rows)
            .collect();
        let count = same_length.len().max(1) as f64;
        let mut mean = Vec::with_capacity(rows);
        let mut std = Vec::with_capacity(rows);
        for row in 0..rows {
            let mean_sum: f64 = same_length
                .iter()
                .map(|curve| f64::from(curve.mean[row]))
                .sum();
            let variance_sum: f64 = same_length
                .iter()
                .map(|curve| f64::from(curve.std[row]).powi(2))
                .sum();
            mean.push((mean_sum / count) as f32);
            std.push((variance_sum / count).sqrt() as f32);
        }
        MeasuredCurve {
            name: name.to_string(),
            mean,
            std,
        }
    }
}

/// A parsed calibration table: the measured distances and one [`MeasuredCurve`] per curve, in
/// header order (of the `mean_` columns).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationTable {
    distances_cm: Vec<f64>,
    curves: Vec<MeasuredCurve>,
}

/// Where a header column's values go: the distance, or a curve's mean or standard deviation.
#[derive(Debug, Clone, Copy)]
enum ColumnRole {
    Distance,
    Mean(usize),
    Std(usize),
}

impl CalibrationTable {
    /// Parses a calibration CSV. Lines whose first non-blank character is `#`, and blank lines,
    /// are skipped; the first other line is the header.
    pub fn parse(text: &str) -> Result<CalibrationTable, CalibrationError> {
        let mut content_lines = text
            .lines()
            .enumerate()
            .map(|(index, line)| (index + 1, line.trim()))
            .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'));

        let (header_line, header) = content_lines
            .next()
            .ok_or(CalibrationError::MissingHeader)?;
        let column_names: Vec<&str> = header.split(',').map(str::trim).collect();
        let (roles, curve_names) = parse_header(header_line, &column_names)?;

        let mut distances_cm: Vec<f64> = Vec::new();
        let mut means: Vec<Vec<f32>> = vec![Vec::new(); curve_names.len()];
        let mut stds: Vec<Vec<f32>> = vec![Vec::new(); curve_names.len()];
        for (line, row) in content_lines {
            let fields: Vec<&str> = row.split(',').map(str::trim).collect();
            if fields.len() != column_names.len() {
                return Err(CalibrationError::WrongFieldCount {
                    line,
                    expected: column_names.len(),
                    found: fields.len(),
                });
            }
            for (column_index, (field, role)) in fields.iter().zip(&roles).enumerate() {
                let column = column_index + 1;
                let bad_number = || CalibrationError::BadNumber {
                    line,
                    column,
                    column_name: column_names[column_index].to_string(),
                    text: (*field).to_string(),
                };
                match *role {
                    ColumnRole::Distance => {
                        let distance_cm: f64 = field.parse().map_err(|_| bad_number())?;
                        if !distance_cm.is_finite() {
                            return Err(bad_number());
                        }
                        if !(0.0..=MAX_TABLE_DISTANCE_CM).contains(&distance_cm) {
                            return Err(CalibrationError::DistanceOutOfRange { line, distance_cm });
                        }
                        if let Some(&previous_cm) = distances_cm.last()
                            && distance_cm <= previous_cm
                        {
                            return Err(CalibrationError::DistanceNotIncreasing {
                                line,
                                distance_cm,
                                previous_cm,
                            });
                        }
                        distances_cm.push(distance_cm);
                    }
                    ColumnRole::Mean(curve) => {
                        let value: f32 = field.parse().map_err(|_| bad_number())?;
                        if !value.is_finite() {
                            return Err(bad_number());
                        }
                        means[curve].push(value);
                    }
                    ColumnRole::Std(curve) => {
                        let value: f32 = field.parse().map_err(|_| bad_number())?;
                        if !value.is_finite() {
                            return Err(bad_number());
                        }
                        if value < 0.0 {
                            return Err(CalibrationError::NegativeStd {
                                line,
                                column,
                                column_name: column_names[column_index].to_string(),
                                value,
                            });
                        }
                        stds[curve].push(value);
                    }
                }
            }
        }
        if distances_cm.len() < 2 {
            return Err(CalibrationError::TooFewRows {
                rows: distances_cm.len(),
            });
        }
        let curves = curve_names
            .into_iter()
            .zip(means)
            .zip(stds)
            .map(|((name, mean), std)| MeasuredCurve { name, mean, std })
            .collect();
        Ok(CalibrationTable {
            distances_cm,
            curves,
        })
    }

    /// The measured distances, in centimetres, strictly increasing.
    #[cfg(test)]
    pub fn distances_cm(&self) -> &[f64] {
        &self.distances_cm
    }

    /// All curves, in the order of their `mean_` columns in the header.
    #[cfg(test)]
    pub fn curves(&self) -> &[MeasuredCurve] {
        &self.curves
    }

    /// The curve called `name`.
    pub fn curve(&self, name: &str) -> Result<&MeasuredCurve, CalibrationError> {
        self.curves
            .iter()
            .find(|curve| curve.name == name)
            .ok_or_else(|| CalibrationError::MissingCurve {
                curve: name.to_string(),
            })
    }

    /// Resamples `curve` (one of this table's curves, or one built from them such as
    /// [`MeasuredCurve::pooled`]) onto the uniform [`GRID_STEP_M`] grid from 0 to the table's
    /// largest distance. Below the first row the first row's values hold, and linear
    /// interpolation joins the rows.
    pub fn resample(&self, curve: &MeasuredCurve) -> ResampledCurve {
        let step_cm = f64::from(GRID_STEP_M) * 100.0;
        let max_cm = self.distances_cm.last().copied().unwrap_or(0.0);
        let last_index = (max_cm / step_cm).round() as usize;
        let row_value =
            |values: &[f32], row: usize| f64::from(values.get(row).copied().unwrap_or(0.0));

        // The grid gets one extra copy of its last point so that a lookup at the very end can
        // still interpolate towards "index + 1" without a special case.
        let mut points = Vec::with_capacity(last_index + 2);
        let mut segment = 0;
        for grid_index in 0..=last_index {
            let distance_cm = (grid_index as f64 * step_cm).min(max_cm);
            while segment + 2 < self.distances_cm.len()
                && self.distances_cm[segment + 1] < distance_cm
            {
                segment += 1;
            }
            let low_cm = self.distances_cm[segment];
            let high_cm = self.distances_cm[segment + 1];
            let fraction = ((distance_cm - low_cm) / (high_cm - low_cm)).clamp(0.0, 1.0);
            let lerp = |values: &[f32]| {
                let low = row_value(values, segment);
                let high = row_value(values, segment + 1);
                (low + (high - low) * fraction) as f32
            };
            points.push(MeanStd {
                mean: lerp(&curve.mean),
                std: lerp(&curve.std),
            });
        }
        let last_point = points.last().copied().unwrap_or(MeanStd {
            mean: 0.0,
            std: 0.0,
        });
        points.push(last_point);
        ResampledCurve {
            inv_step: 1.0 / GRID_STEP_M,
            last_position: last_index as f32,
            points: points.into_boxed_slice(),
        }
    }
}

/// Reads the header into a role per column and the list of curve names.
fn parse_header(
    line: usize,
    column_names: &[&str],
) -> Result<(Vec<ColumnRole>, Vec<String>), CalibrationError> {
    let first = column_names.first().copied().unwrap_or("");
    if first != "distance_cm" {
        return Err(CalibrationError::BadDistanceHeader {
            line,
            column: 1,
            found: first.to_string(),
        });
    }
    let mut roles = vec![ColumnRole::Distance];
    let mut curve_names: Vec<String> = Vec::new();
    let mut has_mean: Vec<bool> = Vec::new();
    let mut has_std: Vec<bool> = Vec::new();
    for (column_index, name) in column_names.iter().enumerate().skip(1) {
        let column = column_index + 1;
        let (is_mean, curve_name) = if let Some(curve) = name.strip_prefix("mean_") {
            (true, curve)
        } else if let Some(curve) = name.strip_prefix("std_") {
            (false, curve)
        } else {
            return Err(CalibrationError::BadColumnName {
                line,
                column,
                found: (*name).to_string(),
            });
        };
        if curve_name.is_empty() {
            return Err(CalibrationError::BadColumnName {
                line,
                column,
                found: (*name).to_string(),
            });
        }
        let curve = match curve_names.iter().position(|known| known == curve_name) {
            Some(curve) => curve,
            None => {
                curve_names.push(curve_name.to_string());
                has_mean.push(false);
                has_std.push(false);
                curve_names.len() - 1
            }
        };
        let seen = if is_mean {
            &mut has_mean[curve]
        } else {
            &mut has_std[curve]
        };
        if *seen {
            return Err(CalibrationError::DuplicateColumn {
                line,
                column,
                name: (*name).to_string(),
            });
        }
        *seen = true;
        roles.push(if is_mean {
            ColumnRole::Mean(curve)
        } else {
            ColumnRole::Std(curve)
        });
    }
    for (curve, name) in curve_names.iter().enumerate() {
        if !has_mean[curve] || !has_std[curve] {
            let prefix = if has_mean[curve] { "std_" } else { "mean_" };
            return Err(CalibrationError::UnpairedColumn {
                line,
                curve: name.clone(),
                missing: format!("{prefix}{name}"),
            });
        }
    }
    Ok((roles, curve_names))
}

/// The mean and standard deviation of a raw reading at one distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanStd {
    /// Mean raw reading.
    pub mean: f32,
    /// Standard deviation of the raw reading.
    pub std: f32,
}

/// One curve resampled onto the uniform [`GRID_STEP_M`] grid, ready for cheap per-cycle lookups.
#[derive(Debug, Clone, PartialEq)]
pub struct ResampledCurve {
    inv_step: f32,
    /// Grid position (distance / step) of the last real grid point.
    last_position: f32,
    /// Grid points 0..=last plus one copy of the last point.
    points: Box<[MeanStd]>,
}

impl ResampledCurve {
    /// Mean and standard deviation at `distance_m`, linearly interpolated. Distances below 0
    /// give the contact value; distances beyond the table, infinity and NaN (no measurable
    /// distance) give the farthest row's value.
    #[inline]
    pub fn at(&self, distance_m: f32) -> MeanStd {
        // NaN means no measurable distance; the branch is never taken in practice, so it is
        // cheaper than NaN-aware `min`/`max`.
        let position = distance_m * self.inv_step;
        let position = if position.is_nan() {
            self.last_position
        } else {
            position.clamp(0.0, self.last_position)
        };
        // Truncation is the floor here because the position is non-negative; a u32 keeps the
        // float conversions cheap (the grid is far smaller), and the padding point makes
        // `index + 1` valid even at the last position.
        let index = position as u32;
        let fraction = position - index as f32;
        let index = index as usize;
        let low = self.points[index];
        let high = self.points[index + 1];
        MeanStd {
            mean: low.mean + (high.mean - low.mean) * fraction,
            std: low.std + (high.std - low.std) * fraction,
        }
    }

    /// Mean and standard deviation at contact (distance 0).
    pub fn contact(&self) -> MeanStd {
        self.points[0]
    }

    /// Mean and standard deviation at the table's farthest distance.
    pub fn farthest(&self) -> MeanStd {
        self.points[self.points.len() - 1]
    }

    /// The farthest distance of the grid, in metres.
    #[cfg(test)]
    pub fn max_distance_m(&self) -> f32 {
        self.last_position / self.inv_step
    }

    /// The mean at every grid point, nearest first, and the grid step in metres.
    pub fn grid_means(&self) -> (Vec<f32>, f32) {
        let n_points = self.points.len() - 1;
        (
            self.points[..n_points].iter().map(|p| p.mean).collect(),
            1.0 / self.inv_step,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL_TABLE: &str = "# a comment\n\
        distance_cm,mean_a,std_a,mean_b,std_b\n\
        \n\
        0,100,2,50,1\n\
        # a comment between rows\n\
        0.5,80,4,40,1\n\
        2,20,1,10,1\n";

    #[test]
    fn parses_comments_header_and_rows() {
        let table = CalibrationTable::parse(SMALL_TABLE).unwrap();
        assert_eq!(table.distances_cm(), &[0.0, 0.5, 2.0]);
        assert_eq!(table.curves().len(), 2);
        let a = table.curve("a").unwrap();
        assert_eq!(a.mean, vec![100.0, 80.0, 20.0]);
        assert_eq!(a.std, vec![2.0, 4.0, 1.0]);
        assert_eq!(table.curve("b").unwrap().mean, vec![50.0, 40.0, 10.0]);
        assert!(matches!(
            table.curve("c"),
            Err(CalibrationError::MissingCurve { .. })
        ));
    }

    #[test]
    fn resampled_curve_hits_rows_and_interpolates_between_them() {
        let table = CalibrationTable::parse(SMALL_TABLE).unwrap();
        let curve = table.resample(table.curve("a").unwrap());
        let close = |x: f32, y: f32| (x - y).abs() < 1e-3;
        assert!(close(curve.at(0.0).mean, 100.0));
        assert!(close(curve.at(0.005).mean, 80.0));
        assert!(close(curve.at(0.005).std, 4.0));
        assert!(close(curve.at(0.02).mean, 20.0));
        // Halfway between the 0 and 0.5 cm rows, and between the 0.5 and 2 cm rows.
        assert!(close(curve.at(0.0025).mean, 90.0));
        assert!(close(curve.at(0.0025).std, 3.0));
        assert!(close(curve.at(0.0125).mean, 50.0));
        // Off-grid distances interpolate too: 0.35 mm is 7% of the way to the 0.5 cm row.
        assert!(close(curve.at(0.00035).mean, 98.6));
        // Outside the table: contact below 0, farthest row beyond, for NaN and for infinity.
        assert_eq!(curve.at(-1.0), curve.contact());
        assert_eq!(curve.at(0.5), curve.farthest());
        assert_eq!(curve.at(f32::NAN), curve.farthest());
        assert_eq!(curve.at(f32::INFINITY), curve.farthest());
        assert!(close(curve.max_distance_m(), 0.02));
    }

    #[test]
    fn pooled_curve_averages_means_and_pools_variances() {
        let table = CalibrationTable::parse(SMALL_TABLE).unwrap();
        let a = table.curve("a").unwrap();
        let b = table.curve("b").unwrap();
        let pooled = MeasuredCurve::pooled("ab", &[a, b]);
        assert_eq!(pooled.mean, vec![75.0, 60.0, 15.0]);
        assert!((pooled.std[0] - (2.5f32).sqrt()).abs() < 1e-6);
        assert!((pooled.std[1] - (8.5f32).sqrt()).abs() < 1e-6);
    }

    fn error_of(text: &str) -> CalibrationError {
        CalibrationTable::parse(text).unwrap_err()
    }

    #[test]
    fn malformed_tables_give_errors_naming_line_and_column() {
        let bad_number = error_of("# c\ndistance_cm,mean_a,std_a\n0,1,1\n1,x,1\n");
        assert_eq!(
            bad_number,
            CalibrationError::BadNumber {
                line: 4,
                column: 2,
                column_name: "mean_a".into(),
                text: "x".into()
            }
        );
        let message = bad_number.to_string();
        assert!(
            message.contains("line 4") && message.contains("column 2"),
            "{message}"
        );

        assert_eq!(
            error_of("distance_cm,mean_a,std_a\n0,1,1\n1,1\n"),
            CalibrationError::WrongFieldCount {
                line: 3,
                expected: 3,
                found: 2
            }
        );
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a\n0,1,1\n1,1,inf\n"),
            CalibrationError::BadNumber {
                line: 3,
                column: 3,
                ..
            }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a\n0,1,1\n1,1,-1\n"),
            CalibrationError::NegativeStd {
                line: 3,
                column: 3,
                ..
            }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a\n1,1,1\n1,1,1\n"),
            CalibrationError::DistanceNotIncreasing { line: 3, .. }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a\n0,1,1\n1e9,1,1\n"),
            CalibrationError::DistanceOutOfRange { line: 3, .. }
        ));
        assert!(matches!(
            error_of("# only\n\n# comments\n"),
            CalibrationError::MissingHeader
        ));
        assert!(matches!(
            error_of("# c\ndistance_mm,mean_a,std_a\n0,1,1\n1,1,1\n"),
            CalibrationError::BadDistanceHeader {
                line: 2,
                column: 1,
                ..
            }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,sd_a\n0,1,1\n1,1,1\n"),
            CalibrationError::BadColumnName {
                line: 1,
                column: 3,
                ..
            }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a,mean_a\n0,1,1,1\n1,1,1,1\n"),
            CalibrationError::DuplicateColumn {
                line: 1,
                column: 4,
                ..
            }
        ));
        assert!(matches!(
            error_of("distance_cm,mean_a,std_a,mean_b\n0,1,1,1\n1,1,1,1\n"),
            CalibrationError::UnpairedColumn { line: 1, .. }
        ));
        assert_eq!(
            error_of("distance_cm,mean_a,std_a\n0,1,1\n"),
            CalibrationError::TooFewRows { rows: 1 }
        );
    }

    #[test]
    fn windows_line_endings_are_accepted() {
        let table =
            CalibrationTable::parse("distance_cm,mean_a,std_a\r\n0,2,1\r\n1,1,1\r\n").unwrap();
        assert_eq!(table.curve("a").unwrap().mean, vec![2.0, 1.0]);
    }
}
