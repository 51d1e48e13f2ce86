//! The infrared proximity sensor model. Given the distance from one of the four IR sensors to
//! the nearest surface in its cone (the world computes it), it reads the measured e-puck
//! calibration curves (`data/epuck-ir-calibration.csv`: two robots, four sensors each, mean and
//! standard deviation of the raw value at 0-12 cm), maps the reading to a network input in
//! [0, 1] and applies the sample's fixed offset noise.
//!
//! The default reading model ([`IrMapping::AverageTable`], model version 4) is that of
//! JBotEvolver's `EpuckIRSensor`, the paper's simulator. With nothing in the cone, or the
//! nearest surface 12 cm away or more, the input is exactly 0 and no noise is drawn. Nearer, a
//! raw value is drawn from the sensor's own curve, mean(d) + std(d) N(0, 1) (interpolated
//! linearly between table rows), turned back into a distance d' through the average of the 8
//! measured curves (its means made non-increasing with distance), as a robot calibrated once
//! with the average table would, and mapped to `1 - d' / 12 cm`; the offset noise then
//! multiplies it by `1 + offset` and it is clamped to [0, 1]. A sensor whose own curve differs
//! from the average therefore reads systematically off, and a wall 8-9 cm away reads about
//! 0.2-0.3 on most curves.
//!
//! Two alternatives stay selectable as `ir.mapping`, for comparison with earlier models:
//! `linear_distance` (model 3: as the default, after a baseline correction that moves each
//! sensor's empty reading plus four noise standard deviations onto the average curve's) and
//! `linear_raw` (model 1: `input = clamp((raw - floor) / (ceil - floor), 0, 1)`, where `ceil`
//! is the curve's mean at contact and `floor` its mean at 12 cm). With both, a surface 12 cm
//! away or more, and an empty cone, read the curve's 12 cm row, so such a sensor reads a noisy
//! value near 0 (under `linear_distance` exactly 0 in 99.997 % of cycles). See
//! `docs/model.md`, section 3.1, and `docs/decisions/model/0013-ir-reading-average-table.md`.
//!
//! The per-sample choices (which measured curve models each sensor, and its offset noise) live
//! in [`IrSensorSetup`], drawn once per sample from the sample's sensor-setup stream; the
//! per-cycle read draws at most one standard normal from the noise stream (none when the
//! default mapping reads 0 for want of a surface within 12 cm).

use std::sync::OnceLock;

use rand::RngExt;
use serde::{Deserialize, Serialize};

use super::calibration::{CalibrationError, CalibrationTable, MeasuredCurve, ResampledCurve};
use crate::config::{CurveChoice, IrConfig, IrMapping};
use crate::math::rng::{SimRng, standard_normal};

/// Number of infrared proximity sensors: front-left (+17 deg), left (+90 deg), right (-90 deg),
/// front-right (-17 deg), in input order.
pub const N_IR: usize = 4;

/// Angles of the four IR sensors from the heading, radians, in input order.
pub const IR_ANGLES: [f32; N_IR] = [
    17.0 * std::f32::consts::PI / 180.0,
    std::f32::consts::FRAC_PI_2,
    -std::f32::consts::FRAC_PI_2,
    -17.0 * std::f32::consts::PI / 180.0,
];

/// The measured curves' names, in curve-index order: robot 1 sensors 0, 2, 5, 7, then robot 2.
pub const IR_CURVE_NAMES: [&str; N_MEASURED_IR_CURVES] = [
    "r1s0", "r1s2", "r1s5", "r1s7", "r2s0", "r2s2", "r2s5", "r2s7",
];

/// Number of measured IR curves in the calibration table.
pub const N_MEASURED_IR_CURVES: usize = 8;

/// Curve index of the average of the measured curves (see `MeasuredCurve::pooled`). Any
/// curve index at or above it also selects the average curve.
pub const MEAN_IR_CURVE: u8 = N_MEASURED_IR_CURVES as u8;

/// Number of curves an [`IrModel`] holds: the measured ones plus their average.
const N_IR_CURVES: usize = N_MEASURED_IR_CURVES + 1;

/// Curve indices for [`CurveChoice::SameRobot`], per robot, in IR input order (front-left,
/// left, right, front-right). On the e-puck ring sensor 0 looks about 17 deg right of the
/// heading, 2 is the right side (-90 deg), 5 the left side (+90 deg) and 7 about 17 deg left, so
/// the inputs map to sensors 7, 5, 2, 0: curves r1s7, r1s5, r1s2, r1s0 for robot 1 and the same
/// sensors of robot 2.
pub const SAME_ROBOT_CURVES: [[u8; N_IR]; 2] = [[3, 2, 1, 0], [7, 6, 5, 4]];

const BUILTIN_IR_CSV: &str = include_str!("../../data/epuck-ir-calibration.csv");

impl IrConfig {
    /// Draws one sample's sensor setup with this configuration.
    pub fn draw_setup(&self, rng: &mut SimRng) -> IrSensorSetup {
        IrSensorSetup {
            mapping: self.mapping,
            ..IrSensorSetup::draw(rng, self.curve_choice, self.offset_fraction)
        }
    }
}

/// The per-sample choices for the four IR sensors, in IR input order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IrSensorSetup {
    /// Curve index modelling each sensor: 0..8 are [`IR_CURVE_NAMES`], [`MEAN_IR_CURVE`] the
    /// average curve.
    pub curve: [u8; N_IR],
    /// Fixed offset noise of each sensor: the input is multiplied by `1 + offset`.
    pub offset: [f32; N_IR],
    /// How raw readings map to inputs.
    #[serde(default)]
    pub mapping: IrMapping,
}

impl Default for IrSensorSetup {
    /// The average curve on every sensor and no offset noise: an idealised robot.
    fn default() -> Self {
        IrSensorSetup {
            curve: [MEAN_IR_CURVE; N_IR],
            offset: [0.0; N_IR],
            mapping: IrMapping::default(),
        }
    }
}

impl IrSensorSetup {
    /// Draws one sample's setup: first the curves (none drawn for [`CurveChoice::Mean`], one
    /// draw for [`CurveChoice::SameRobot`], one per sensor for [`CurveChoice::Any`]), then one
    /// offset per sensor from U(-offset_fraction, +offset_fraction). A negative fraction counts
    /// as its magnitude, and a non-finite one as 0.
    pub fn draw(
        rng: &mut SimRng,
        curve_choice: CurveChoice,
        offset_fraction: f32,
    ) -> IrSensorSetup {
        let curve = match curve_choice {
            CurveChoice::Any => {
                std::array::from_fn(|_| rng.random_range(0..N_MEASURED_IR_CURVES as u8))
            }
            CurveChoice::SameRobot => SAME_ROBOT_CURVES[rng.random_range(0..2usize)],
            CurveChoice::Mean => [MEAN_IR_CURVE; N_IR],
        };
        let fraction = if offset_fraction.is_finite() {
            offset_fraction.abs()
        } else {
            0.0
        };
        // Drawing u in [0, 1) and scaling, rather than sampling a range, keeps a fraction of 0
        // valid (an empty range would be an error) and always consumes the same draws.
        let offset = std::array::from_fn(|_| (2.0 * rng.random::<f32>() - 1.0) * fraction);
        IrSensorSetup {
            curve,
            offset,
            mapping: IrMapping::default(),
        }
    }
}

/// One curve ready for per-cycle reads: the resampled table and its raw-to-input mapping.
#[derive(Debug, Clone, PartialEq)]
struct IrCurve {
    table: ResampledCurve,
    /// Mean raw value at the farthest distance: maps to input 0.
    floor_raw: f32,
    /// 1 / (mean at contact - floor_raw): maps contact to input 1.
    inv_span: f32,
    /// The sensor's own empty reading for [`IrMapping::LinearDistance`]: its mean at 12 cm
    /// plus four standard deviations (see [`IrModel::map_raw`]).
    baseline: f32,
}

impl IrCurve {
    fn new(table: ResampledCurve, name: &str) -> Result<IrCurve, CalibrationError> {
        let contact_mean = table.contact().mean;
        let far_mean = table.farthest().mean;
        if contact_mean <= far_mean {
            return Err(CalibrationError::CurveNotDecreasing {
                curve: name.to_string(),
                contact_mean,
                far_mean,
            });
        }
        Ok(IrCurve {
            baseline: far_mean + 4.0 * table.farthest().std,
            table,
            floor_raw: far_mean,
            inv_span: 1.0 / (contact_mean - far_mean),
        })
    }
}

/// The IR sensor model: the 8 measured curves and their average, resampled for cheap lookups.
#[derive(Debug, Clone, PartialEq)]
pub struct IrModel {
    curves: [IrCurve; N_IR_CURVES],
    /// The average curve's means on the 1 mm grid, made non-increasing with distance (the
    /// measured tail is not monotonic), for turning a raw reading back into a distance.
    inverse_means: Vec<f32>,
    inverse_step: f32,
    /// The grid's farthest distance, `inverse_step` times the last index, metres.
    max_distance: f32,
    /// Where to start looking in `inverse_means` for a raw reading, by the reading's leading
    /// bits (see [`InverseStarts`]).
    inverse_starts: InverseStarts,
}

/// Where the means fall to a raw reading, by the reading's exponent and leading seven mantissa
/// bits: positive floats order like their bits, and that index splits every octave into 128
/// buckets, as fine where the curve is steep (near, large readings) as where it is flat (far).
/// For each bucket it keeps the grid point at which the means fall to the bucket's largest
/// reading; a smaller reading of the same bucket falls at most one grid point later when no
/// bucket spans two grid points (checked when the table is built), so one comparison gives the
/// binary search's answer without a branch. Empty, which leaves the binary search, when the
/// means are not positive or some bucket spans more.
#[derive(Debug, Clone, PartialEq)]
struct InverseStarts {
    first_bucket: u32,
    starts: Vec<u16>,
}

impl InverseStarts {
    const SHIFT: u32 = 16;

    fn new(means: &[f32]) -> InverseStarts {
        let none = InverseStarts {
            first_bucket: 0,
            starts: Vec::new(),
        };
        let (low, high) = (means[means.len() - 1], means[0]);
        if !(low > 0.0 && high.is_finite()) || means.len() > usize::from(u16::MAX) {
            return none;
        }
        let first_bucket = low.to_bits() >> Self::SHIFT;
        let last_bucket = high.to_bits() >> Self::SHIFT;
        // The readings asked about lie strictly between the last and the first mean.
        let (smallest, largest) = (low.next_up(), high.next_down());
        let fall = |raw: f32| means.partition_point(|&m| m > raw);
        let mut starts = Vec::with_capacity((last_bucket - first_bucket + 1) as usize);
        for bucket in first_bucket..=last_bucket {
            let lowest = f32::from_bits(bucket << Self::SHIFT).max(smallest);
            let highest = f32::from_bits(((bucket + 1) << Self::SHIFT) - 1).min(largest);
            let start = fall(highest);
            if fall(lowest) > start + 1 {
                return none;
            }
            starts.push(start as u16);
        }
        InverseStarts {
            first_bucket,
            starts,
        }
    }

    /// The grid point at which the means fall to the largest reading of `raw`'s bucket, for a
    /// reading strictly between the last and the first mean.
    #[inline(always)]
    fn start(&self, raw: f32) -> Option<usize> {
        let bucket = (raw.to_bits() >> Self::SHIFT).wrapping_sub(self.first_bucket);
        self.starts
            .get(bucket as usize)
            .map(|&start| usize::from(start))
    }
}

impl IrModel {
    /// The model built from the embedded e-puck calibration table, parsed once per process.
    pub fn builtin() -> &'static IrModel {
        static BUILTIN: OnceLock<IrModel> = OnceLock::new();
        BUILTIN.get_or_init(|| {
            // The embedded table is part of the source; a unit test parses it, so this cannot
            // fail in a tested build.
            IrModel::from_csv(BUILTIN_IR_CSV).expect("the embedded IR calibration table is valid")
        })
    }

    /// Builds a model from a calibration CSV that has mean and std columns for every curve in
    /// [`IR_CURVE_NAMES`] (other columns are ignored).
    pub fn from_csv(text: &str) -> Result<IrModel, CalibrationError> {
        let table = CalibrationTable::parse(text)?;
        let mut measured: Vec<&MeasuredCurve> = Vec::with_capacity(N_MEASURED_IR_CURVES);
        for name in IR_CURVE_NAMES {
            measured.push(table.curve(name)?);
        }
        let average = MeasuredCurve::pooled("mean", &measured);
        let mut curves = Vec::with_capacity(N_IR_CURVES);
        for curve in measured.iter().copied().chain(std::iter::once(&average)) {
            curves.push(IrCurve::new(table.resample(curve), &curve.name)?);
        }
        let curves: [IrCurve; N_IR_CURVES] =
            curves
                .try_into()
                .map_err(|_| CalibrationError::MissingCurve {
                    curve: "mean".to_string(),
                })?;
        let (mut inverse_means, inverse_step) = curves[N_IR_CURVES - 1].table.grid_means();
        for i in 1..inverse_means.len() {
            inverse_means[i] = inverse_means[i].min(inverse_means[i - 1]);
        }
        Ok(IrModel {
            curves,
            max_distance: inverse_step * (inverse_means.len() - 1) as f32,
            inverse_starts: InverseStarts::new(&inverse_means),
            inverse_means,
            inverse_step,
        })
    }

    /// The distance (metres) at which the average curve's mean (made non-increasing) equals `raw`: 0 above the
    /// contact mean, the table's last distance below the farthest mean; linear between grid
    /// points; plateaus resolve to their nearest end.
    pub fn raw_to_distance(&self, raw: f32) -> f32 {
        let means = &self.inverse_means;
        let last = means.len() - 1;
        if raw.is_nan() || raw >= means[0] {
            return 0.0;
        }
        if raw <= means[last] {
            return last as f32 * self.inverse_step;
        }
        let above = self.first_at_or_below(raw);
        let (near, far) = (means[above - 1], means[above]);
        let fraction = if near > far {
            (near - raw) / (near - far)
        } else {
            0.0
        };
        ((above - 1) as f32 + fraction) * self.inverse_step
    }

    /// What [`IrModel::raw_to_distance`] reads: the average curve's means on the grid (made
    /// non-increasing), the grid step and the grid's farthest distance, metres; for code that
    /// performs the same mapping elsewhere (`hevo export`).
    pub fn inverse_table(&self) -> (&[f32], f32, f32) {
        (&self.inverse_means, self.inverse_step, self.max_distance)
    }

    /// The first grid point whose mean is at or below `raw`, for a reading strictly between
    /// the last and the first mean (the means are non-increasing): what
    /// `inverse_means.partition_point(|&m| m > raw)` gives, found from the bucket's start and
    /// one comparison.
    #[inline]
    fn first_at_or_below(&self, raw: f32) -> usize {
        let means = &self.inverse_means;
        match self.inverse_starts.start(raw) {
            // `means[0] > raw > means[last]` keeps the start inside 1..=last, and the grid
            // point after it exists whenever the mean at the start is still above `raw`.
            Some(start) => start + usize::from(means[start] > raw),
            None => means.partition_point(|&m| m > raw),
        }
    }

    /// The curve for index `curve`; indices past the measured ones select the average curve.
    #[inline]
    fn curve(&self, curve: u8) -> &IrCurve {
        &self.curves[usize::from(curve).min(N_IR_CURVES - 1)]
    }

    /// Draws a raw reading of curve `curve` at `distance_m` from the surface:
    /// mean(d) + std(d) * N(0, 1), interpolated between table rows. `None`, NaN and distances
    /// beyond the table use its farthest (12 cm) row; negative distances the contact row.
    #[inline]
    pub fn read_raw(&self, curve: u8, distance_m: Option<f32>, rng: &mut SimRng) -> f32 {
        let curve = self.curve(curve);
        let point = curve.table.at(distance_m.unwrap_or(f32::INFINITY));
        point.mean + point.std * standard_normal(rng)
    }

    /// Maps a raw reading of curve `curve` to an input in [0, 1]: 1 at the curve's mean at
    /// contact, 0 at its mean at 12 cm (see the module documentation).
    #[inline]
    pub fn raw_to_input(&self, curve: u8, raw: f32) -> f32 {
        let curve = self.curve(curve);
        ((raw - curve.floor_raw) * curve.inv_span).clamp(0.0, 1.0)
    }

    /// One cycle's input of IR sensor `sensor_index` (IR input order) with the nearest surface
    /// in its cone at `distance_m` (`None`: nothing within range): a raw reading drawn from the
    /// sensor's curve, mapped to [0, 1], multiplied by the sample's fixed `1 + offset` and
    /// clamped to [0, 1]. With [`IrMapping::AverageTable`], nothing within 12 cm reads 0 and
    /// draws nothing. An out-of-range sensor index reads 0 and draws nothing.
    #[inline]
    pub fn read(
        &self,
        setup: &IrSensorSetup,
        sensor_index: usize,
        distance_m: Option<f32>,
        rng: &mut SimRng,
    ) -> f32 {
        let (Some(&curve), Some(&offset)) = (
            setup.curve.get(sensor_index),
            setup.offset.get(sensor_index),
        ) else {
            return 0.0;
        };
        // The table's last row is 12 cm; a micrometre's slack keeps 12 cm itself out of
        // range despite the f32 rounding of the grid step.
        let out_of_range = self.max_distance - 1e-6;
        if setup.mapping == IrMapping::AverageTable && distance_m.is_none_or(|d| d >= out_of_range)
        {
            return 0.0;
        }
        let raw = self.read_raw(curve, distance_m, rng);
        let input = self.map_raw(curve, raw, setup.mapping);
        (input * (1.0 + offset)).clamp(0.0, 1.0)
    }

    /// One cycle's inputs of all four IR sensors, in IR input order (draws in that order).
    #[inline(always)]
    pub fn read_all(
        &self,
        setup: &IrSensorSetup,
        distances_m: &[Option<f32>; N_IR],
        rng: &mut SimRng,
    ) -> [f32; N_IR] {
        std::array::from_fn(|sensor_index| {
            self.read(setup, sensor_index, distances_m[sensor_index], rng)
        })
    }

    /// Maps a raw reading of curve `curve` to an input in [0, 1] with the given mapping (before
    /// the per-sample offset noise).
    #[inline]
    pub fn map_raw(&self, curve: u8, raw: f32, mapping: IrMapping) -> f32 {
        match mapping {
            IrMapping::LinearDistance => {
                // Baseline correction first, as the e-puck firmware does at start-up with the
                // ambient reading: the sensor's own empty reading (its mean at 12 cm plus four
                // standard deviations of noise, so an empty cone reads 0 in 99.997 % of cycles)
                // is moved onto the average curve's, so every sensor reads 0 with nothing in
                // range while keeping its own gain, and so its own error, nearer in. The margin
                // costs a bias far out, where the curve is flat: 8 cm reads like about 9.5 cm.
                let average_floor = self.inverse_means[self.inverse_means.len() - 1];
                let corrected = raw - self.curve(curve).baseline + average_floor;
                1.0 - self.raw_to_distance(corrected) / self.max_distance
            }
            IrMapping::LinearRaw => self.raw_to_input(curve, raw),
            IrMapping::AverageTable => 1.0 - self.raw_to_distance(raw) / self.max_distance,
        }
    }

    /// The noise-free input of curve `curve` with a surface at `distance_m`: what a sensor
    /// reads on average, for policies and plots that need the inverse.
    pub fn noise_free_input(&self, curve: u8, distance_m: f32, mapping: IrMapping) -> f32 {
        self.map_raw(curve, self.mean_raw(curve, distance_m), mapping)
    }

    /// The mean raw reading of curve `curve` at `distance_m` (no noise), for tests and plots.
    pub fn mean_raw(&self, curve: u8, distance_m: f32) -> f32 {
        self.curve(curve).table.at(distance_m).mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::{Stream, stream_rng};

    fn builtin_table() -> CalibrationTable {
        CalibrationTable::parse(BUILTIN_IR_CSV).unwrap()
    }

    #[test]
    fn builtin_table_parses_into_all_curves() {
        let model = IrModel::from_csv(BUILTIN_IR_CSV).unwrap();
        assert_eq!(&model, IrModel::builtin());
        let table = builtin_table();
        assert_eq!(table.distances_cm().len(), 15);
        // Spot checks against the CSV: r1s0 at contact, r2s7 at 12 cm.
        assert!((model.mean_raw(0, 0.0) - 3842.55).abs() < 0.01);
        assert!((model.mean_raw(7, 0.12) - 22.01).abs() < 0.01);
    }

    #[test]
    fn raw_reads_follow_the_calibration_curves() {
        let model = IrModel::builtin();
        let table = builtin_table();
        let mut rng = stream_rng(11, Stream::Noise);
        let draws = 4000;
        for (curve_index, name) in IR_CURVE_NAMES.iter().enumerate() {
            let measured = table.curve(name).unwrap();
            for (row, &distance_cm) in table.distances_cm().iter().enumerate() {
                let distance_m = (distance_cm / 100.0) as f32;
                let reads: Vec<f64> = (0..draws)
                    .map(|_| {
                        f64::from(model.read_raw(curve_index as u8, Some(distance_m), &mut rng))
                    })
                    .collect();
                let mean = reads.iter().sum::<f64>() / draws as f64;
                let variance = reads.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / draws as f64;
                let expected_mean = f64::from(measured.mean[row]);
                let expected_std = f64::from(measured.std[row]);
                // 5 standard errors of the mean, plus f32 rounding of values in the thousands.
                let mean_tolerance = 5.0 * expected_std / (draws as f64).sqrt() + 0.01;
                assert!(
                    (mean - expected_mean).abs() < mean_tolerance,
                    "{name} at {distance_cm} cm: mean {mean} vs {expected_mean}"
                );
                assert!(
                    (variance.sqrt() - expected_std).abs() < 0.1 * expected_std + 0.01,
                    "{name} at {distance_cm} cm: std {} vs {expected_std}",
                    variance.sqrt()
                );
            }
        }
    }

    #[test]
    fn reads_between_rows_interpolate_linearly() {
        let model = IrModel::builtin();
        // r1s0: 546.55 at 2 cm, 190.11 at 3 cm; 2.5 cm is halfway.
        assert!((model.mean_raw(0, 0.025) - (546.55 + 190.11) / 2.0).abs() < 0.01);
        // Beyond the table the 12 cm row (0.12 m is a hair below 120 grid steps in f32).
        assert_eq!(model.mean_raw(0, 0.5), model.mean_raw(0, f32::INFINITY));
        assert!((model.mean_raw(0, 0.5) - model.mean_raw(0, 0.12)).abs() < 1e-4);
    }

    #[test]
    fn input_is_one_at_contact_and_zero_from_twelve_cm() {
        let model = IrModel::builtin();
        let mut rng = stream_rng(12, Stream::Noise);
        for curve in 0..=MEAN_IR_CURVE {
            let setup = IrSensorSetup {
                mapping: IrMapping::LinearRaw,
                curve: [curve; N_IR],
                offset: [0.0; N_IR],
            };
            for _ in 0..500 {
                let contact = model.read(&setup, 0, Some(0.0), &mut rng);
                assert!(contact > 0.99, "curve {curve} at contact: {contact}");
                for far in [Some(0.12), Some(0.13), Some(10.0), None, Some(f32::NAN)] {
                    let input = model.read(&setup, 1, far, &mut rng);
                    assert!(input < 0.01, "curve {curve} at {far:?}: {input}");
                }
            }
            // The mean input decreases from contact towards the far end.
            let near = model.raw_to_input(curve, model.mean_raw(curve, 0.01));
            let middle = model.raw_to_input(curve, model.mean_raw(curve, 0.03));
            assert!(
                near > middle && middle > 0.0,
                "curve {curve}: {near} {middle}"
            );
        }
        assert_eq!(model.raw_to_input(0, 1e9), 1.0);
        assert_eq!(model.raw_to_input(0, -1e9), 0.0);
    }

    #[test]
    fn offset_noise_is_fixed_per_sample_and_bounded() {
        let mut rng = stream_rng(13, Stream::SensorSetup);
        let mut smallest: f32 = 0.0;
        let mut largest: f32 = 0.0;
        for _ in 0..10_000 {
            let setup = IrSensorSetup::draw(&mut rng, CurveChoice::Any, 0.05);
            for offset in setup.offset {
                assert!(offset.abs() <= 0.05, "offset {offset}");
                smallest = smallest.min(offset);
                largest = largest.max(offset);
            }
        }
        assert!(smallest < -0.049 && largest > 0.049, "{smallest} {largest}");

        // The same offset scales every read of the sample: the average input of a sensor with
        // offset +4% is 1.04 times that of the same curve without offset.
        let model = IrModel::builtin();
        let with_offset = IrSensorSetup {
            mapping: IrMapping::LinearRaw,
            curve: [0; N_IR],
            offset: [0.04; N_IR],
        };
        let without_offset = IrSensorSetup {
            offset: [0.0; N_IR],
            ..with_offset
        };
        let mut noise = stream_rng(14, Stream::Noise);
        let mut noise_again = stream_rng(14, Stream::Noise);
        for _ in 0..1000 {
            let scaled = model.read(&with_offset, 2, Some(0.02), &mut noise);
            let plain = model.read(&without_offset, 2, Some(0.02), &mut noise_again);
            assert!(
                (scaled - (plain * 1.04).min(1.0)).abs() < 1e-6,
                "{scaled} {plain}"
            );
        }
    }

    #[test]
    fn offset_fraction_edge_cases_do_not_fail() {
        let mut rng = stream_rng(15, Stream::SensorSetup);
        assert_eq!(
            IrSensorSetup::draw(&mut rng, CurveChoice::Mean, 0.0).offset,
            [0.0; N_IR]
        );
        assert_eq!(
            IrSensorSetup::draw(&mut rng, CurveChoice::Mean, f32::NAN).offset,
            [0.0; N_IR]
        );
        let negative = IrSensorSetup::draw(&mut rng, CurveChoice::Mean, -0.05);
        assert!(negative.offset.iter().all(|offset| offset.abs() <= 0.05));
    }

    #[test]
    fn curve_choices_pick_the_documented_curves() {
        let mut rng = stream_rng(16, Stream::SensorSetup);
        let mut seen_any = [[false; N_MEASURED_IR_CURVES]; N_IR];
        let mut seen_robot = [false; 2];
        for _ in 0..2000 {
            let any = IrSensorSetup::draw(&mut rng, CurveChoice::Any, 0.05);
            for (sensor, &curve) in any.curve.iter().enumerate() {
                assert!(curve < MEAN_IR_CURVE);
                seen_any[sensor][usize::from(curve)] = true;
            }
            let same = IrSensorSetup::draw(&mut rng, CurveChoice::SameRobot, 0.05);
            let robot = SAME_ROBOT_CURVES
                .iter()
                .position(|curves| *curves == same.curve)
                .expect("a same-robot setup uses one robot's curves");
            seen_robot[robot] = true;
            let mean = IrSensorSetup::draw(&mut rng, CurveChoice::Mean, 0.05);
            assert_eq!(mean.curve, [MEAN_IR_CURVE; N_IR]);
        }
        assert!(seen_any.iter().flatten().all(|&seen| seen));
        assert_eq!(seen_robot, [true, true]);
        // The same-robot mapping names sensors 7, 5, 2, 0 of one robot.
        let names = SAME_ROBOT_CURVES[1].map(|curve| IR_CURVE_NAMES[usize::from(curve)]);
        assert_eq!(names, ["r2s7", "r2s5", "r2s2", "r2s0"]);
    }

    #[test]
    fn mean_curve_averages_the_measured_curves() {
        let model = IrModel::builtin();
        for distance_m in [0.0, 0.005, 0.02, 0.07, 0.12] {
            let average = (0..MEAN_IR_CURVE)
                .map(|curve| model.mean_raw(curve, distance_m))
                .sum::<f32>()
                / f32::from(MEAN_IR_CURVE);
            assert!((model.mean_raw(MEAN_IR_CURVE, distance_m) - average).abs() < 0.01);
        }
        // Indices past the measured curves fall back to the average curve.
        assert_eq!(
            model.mean_raw(200, 0.02),
            model.mean_raw(MEAN_IR_CURVE, 0.02)
        );
    }

    #[test]
    fn reads_are_reproducible_and_bad_indices_are_harmless() {
        let model = IrModel::builtin();
        let setup = IrConfig::default().draw_setup(&mut stream_rng(17, Stream::SensorSetup));
        let again = IrConfig::default().draw_setup(&mut stream_rng(17, Stream::SensorSetup));
        assert_eq!(setup, again);
        let distances = [Some(0.01), None, Some(0.05), Some(0.0)];
        let first = model.read_all(&setup, &distances, &mut stream_rng(18, Stream::Noise));
        let second = model.read_all(&setup, &distances, &mut stream_rng(18, Stream::Noise));
        assert_eq!(first, second);
        assert!(first.iter().all(|input| (0.0..=1.0).contains(input)));
        assert_eq!(
            model.read(&setup, N_IR, Some(0.0), &mut stream_rng(18, Stream::Noise)),
            0.0
        );
    }

    #[test]
    fn config_defaults_and_serde_names() {
        let config: IrConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(config, IrConfig::default());
        assert_eq!(config.range_m, 0.14);
        assert_eq!(config.cone_deg, 70.0);
        assert_eq!(config.offset_fraction, 0.05);
        assert_eq!(config.curve_choice, CurveChoice::Any);
        let same: IrConfig = serde_json::from_str(r#"{"curve_choice":"same_robot"}"#).unwrap();
        assert_eq!(same.curve_choice, CurveChoice::SameRobot);
        assert_eq!(
            serde_json::to_string(&CurveChoice::Mean).unwrap(),
            r#""mean""#
        );
        assert!(serde_json::from_str::<IrConfig>(r#"{"range":0.1}"#).is_err());
    }

    #[test]
    fn a_table_missing_a_curve_or_not_decreasing_is_rejected() {
        let missing = IrModel::from_csv("distance_cm,mean_r1s0,std_r1s0\n0,10,1\n12,1,1\n");
        assert!(matches!(
            missing,
            Err(CalibrationError::MissingCurve { .. })
        ));

        let mut header = String::from("distance_cm");
        let mut near = String::from("0");
        let mut far = String::from("12");
        for name in IR_CURVE_NAMES {
            header.push_str(&format!(",mean_{name},std_{name}"));
            near.push_str(if name == "r2s2" { ",5,1" } else { ",100,1" });
            far.push_str(",10,1");
        }
        let rising = IrModel::from_csv(&format!("{header}\n{near}\n{far}\n"));
        assert!(matches!(
            rising,
            Err(CalibrationError::CurveNotDecreasing { ref curve, .. }) if curve == "r2s2"
        ));
    }

    /// Asserts that the mean of many reads at each distance is `1 - d / 12 cm` within `tolerance`.
    fn assert_reads_linear_in_distance(
        model: &IrModel,
        setup: &IrSensorSetup,
        distances_cm: &[f32],
        tolerance: f32,
        rng: &mut SimRng,
    ) {
        for &distance_cm in distances_cm {
            let d = distance_cm / 100.0;
            let n = 2000;
            let mean: f32 = (0..n)
                .map(|_| model.read(setup, 0, Some(d), rng))
                .sum::<f32>()
                / n as f32;
            let expected = 1.0 - d / 0.12;
            assert!(
                (mean - expected).abs() < tolerance,
                "at {distance_cm} cm: {mean} vs {expected}"
            );
        }
    }

    #[test]
    fn linear_distance_mapping_recovers_the_distance_on_the_average_curve() {
        let model = IrModel::builtin();
        let setup = IrSensorSetup {
            curve: [MEAN_IR_CURVE; N_IR],
            offset: [0.0; N_IR],
            mapping: IrMapping::LinearDistance,
        };
        let mut rng = crate::math::rng::stream_rng(3, crate::math::rng::Stream::Noise);
        // Near the robot, where the curve is steep, the distance comes back unbiased; far out
        // the noise margin of the baseline correction reads it a little farther.
        assert_reads_linear_in_distance(model, &setup, &[0.5, 1.0, 2.0, 3.0, 5.0], 0.03, &mut rng);
        // Contact reads 1, nothing in range reads (nearly) 0.
        assert!(model.read(&setup, 0, Some(0.0), &mut rng) > 0.99);
        let far: f32 = (0..1000)
            .map(|_| model.read(&setup, 0, None, &mut rng))
            .sum::<f32>()
            / 1000.0;
        assert!(far < 0.1, "{far}");
        // The inverse is monotone in the raw value.
        let mut last = 0.0;
        for raw in (5..4000).rev().step_by(7) {
            let d = model.raw_to_distance(raw as f32);
            assert!(d >= last, "raw {raw}: {d} < {last}");
            last = d;
        }
    }

    #[test]
    fn average_table_mapping_reads_as_jbotevolver_does() {
        let model = IrModel::builtin();
        let setup = IrSensorSetup {
            curve: [MEAN_IR_CURVE; N_IR],
            offset: [0.0; N_IR],
            mapping: IrMapping::AverageTable,
        };
        let mut rng = crate::math::rng::stream_rng(4, crate::math::rng::Stream::Noise);
        // On the average curve the input is 1 - d / 12 cm all the way out, with no noise
        // margin: 9 cm reads about 0.25 (JBotEvolver: 0.250 on its centre ray).
        assert_reads_linear_in_distance(model, &setup, &[1.0, 3.0, 6.0, 9.0], 0.04, &mut rng);
        // Nothing sensed beyond 12 cm, whatever the curve.
        for curve in 0..N_IR_CURVES as u8 {
            let setup = IrSensorSetup {
                curve: [curve; N_IR],
                ..setup
            };
            assert_eq!(model.read(&setup, 0, None, &mut rng), 0.0);
            assert_eq!(model.read(&setup, 0, Some(0.1201), &mut rng), 0.0);
            assert_eq!(model.read(&setup, 0, Some(0.2), &mut rng), 0.0);
        }
        // Where linear_distance's margin reads the average curve's 9 cm as nothing, this
        // mapping still sees the wall.
        let margin = model.noise_free_input(MEAN_IR_CURVE, 0.09, IrMapping::LinearDistance);
        let table = model.noise_free_input(MEAN_IR_CURVE, 0.09, IrMapping::AverageTable);
        assert!(margin < 0.05 && table > 0.2, "{margin} vs {table}");
    }

    /// A table whose means crowd several grid points into one bucket leaves the lookup to the
    /// binary search; one whose means are far apart keeps it.
    #[test]
    fn buckets_spanning_two_grid_points_fall_back_to_the_binary_search() {
        let crowded = InverseStarts::new(&[100.0, 99.99, 99.98, 99.97, 1.0]);
        assert!(crowded.starts.is_empty());
        let sparse = InverseStarts::new(&[512.0, 256.0, 128.0, 64.0]);
        assert!(!sparse.starts.is_empty());
        for raw in [500.0f32, 256.0, 255.9, 200.0, 128.5, 100.0, 64.5] {
            let start = sparse.start(raw).unwrap();
            let means = [512.0f32, 256.0, 128.0, 64.0];
            assert_eq!(
                start + usize::from(means[start] > raw),
                means.partition_point(|&m| m > raw),
                "raw {raw}"
            );
        }
    }

    /// The bucketed lookup finds exactly the grid point the binary search finds: at every
    /// mean, its float neighbours, both ends of every bucket, and a dense sweep across the whole
    /// range of readings.
    #[test]
    fn raw_to_distance_lookup_agrees_with_the_binary_search() {
        let model = IrModel::builtin();
        assert!(
            !model.inverse_starts.starts.is_empty(),
            "the buckets are in use"
        );
        let means = &model.inverse_means;
        let (low, high) = (means[means.len() - 1], means[0]);
        let mut raws: Vec<f32> = Vec::new();
        for &m in means.iter() {
            raws.extend([m, m.next_down(), m.next_up()]);
        }
        let buckets = &model.inverse_starts;
        for bucket in 0..buckets.starts.len() as u32 {
            let first_bits = (buckets.first_bucket + bucket) << InverseStarts::SHIFT;
            let last_bits = first_bits + (1 << InverseStarts::SHIFT) - 1;
            raws.extend([f32::from_bits(first_bits), f32::from_bits(last_bits)]);
        }
        for k in 0..=200_000 {
            raws.push(low + (high - low) * k as f32 / 200_000.0);
        }
        let mut compared = 0;
        for raw in raws.into_iter().filter(|&raw| low < raw && raw < high) {
            assert_eq!(
                model.first_at_or_below(raw),
                means.partition_point(|&m| m > raw),
                "raw {raw}"
            );
            compared += 1;
        }
        assert!(compared > 200_000, "{compared}");
        // Outside the means the lookup is never asked: the ends of the table answer.
        let farthest = (means.len() - 1) as f32 * model.inverse_step;
        for (raw, distance) in [
            (f32::NAN, 0.0),
            (high, 0.0),
            (high + 10.0, 0.0),
            (f32::INFINITY, 0.0),
            (low, farthest),
            (low - 10.0, farthest),
            (-1.0, farthest),
            (f32::NEG_INFINITY, farthest),
        ] {
            assert_eq!(
                model.raw_to_distance(raw).to_bits(),
                distance.to_bits(),
                "raw {raw}"
            );
        }
    }
}
