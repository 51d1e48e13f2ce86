//! The light-flash sensors: the two lateral e-puck IR sensors (left = +90 deg, right = -90 deg)
//! in ambient-light mode. [`LightModel`] draws a raw ambient reading from the measured curves in
//! `data/epuck-light-calibration.csv` (lower raw = more light; rows 0-13 cm, the 13 cm row being
//! effectively dark) given the distance to a lit light, and [`FlashDetector`] turns the raw
//! readings into the two held flash inputs the networks see: 1 for 15 cycles after a flash is
//! detected on that side, then 0.

use std::sync::OnceLock;

use super::calibration::{CalibrationError, CalibrationTable, MeanStd, ResampledCurve};
use super::ir::IR_ANGLES;
use crate::config::{LightConfig, N_LIGHT};
use crate::math::rng::{SimRng, standard_normal};

/// Angles of the two light sensors from the heading, radians (left, right): the lateral IR
/// sensors', which they are in ambient-light mode.
pub const LIGHT_ANGLES: [f32; N_LIGHT] = [IR_ANGLES[1], IR_ANGLES[2]];

/// Index of the left (+90 deg) light sensor.
pub const LEFT: usize = 0;
/// Index of the right (-90 deg) light sensor.
pub const RIGHT: usize = 1;

/// The calibration curves' names, in side order (left, right).
pub const LIGHT_CURVE_NAMES: [&str; N_LIGHT] = ["l", "r"];

const BUILTIN_LIGHT_CSV: &str = include_str!("../../data/epuck-light-calibration.csv");

/// The ambient-light model of the two lateral sensors.
#[derive(Debug, Clone, PartialEq)]
pub struct LightModel {
    sides: [ResampledCurve; N_LIGHT],
}

impl LightModel {
    /// The model built from the embedded e-puck light calibration table, parsed once per
    /// process.
    pub fn builtin() -> &'static LightModel {
        static BUILTIN: OnceLock<LightModel> = OnceLock::new();
        BUILTIN.get_or_init(|| {
            // The embedded table is part of the source; a unit test parses it, so this cannot
            // fail in a tested build.
            LightModel::from_csv(BUILTIN_LIGHT_CSV)
                .expect("the embedded light calibration table is valid")
        })
    }

    /// Builds a model from a calibration CSV with `mean_l`, `std_l`, `mean_r`, `std_r` columns;
    /// the farthest row is taken as the dark reading.
    pub fn from_csv(text: &str) -> Result<LightModel, CalibrationError> {
        let table = CalibrationTable::parse(text)?;
        let left = table.resample(table.curve(LIGHT_CURVE_NAMES[LEFT])?);
        let right = table.resample(table.curve(LIGHT_CURVE_NAMES[RIGHT])?);
        Ok(LightModel {
            sides: [left, right],
        })
    }

    /// Draws one raw ambient reading of side `side` (`LEFT` or `RIGHT`: 0 or 1):
    /// mean(d) + std(d) * N(0, 1), interpolated between table rows, where d is the distance to
    /// a lit light. With no lit light (`None`), NaN, or a light beyond the table (13 cm), the
    /// farthest, dark row is used. An out-of-range side reads +infinity, which never counts as
    /// a flash, and draws nothing.
    #[inline]
    pub fn read_raw(
        &self,
        side: usize,
        distance_to_lit_light_m: Option<f32>,
        rng: &mut SimRng,
    ) -> f32 {
        let Some(curve) = self.sides.get(side) else {
            return f32::INFINITY;
        };
        let point = match distance_to_lit_light_m {
            Some(distance_m) => curve.at(distance_m),
            // No lit light reads the farthest row: what `at` gives for infinity (a test holds
            // the two equal, bit for bit), without the interpolation, in most cycles of a run.
            None => curve.farthest(),
        };
        point.mean + point.std * standard_normal(rng)
    }

    /// Raw readings of both sides (left drawn first).
    #[inline]
    pub fn read_raw_both(
        &self,
        distances_to_lit_light_m: [Option<f32>; N_LIGHT],
        rng: &mut SimRng,
    ) -> [f32; N_LIGHT] {
        [
            self.read_raw(LEFT, distances_to_lit_light_m[LEFT], rng),
            self.read_raw(RIGHT, distances_to_lit_light_m[RIGHT], rng),
        ]
    }

    /// Mean and standard deviation of side `side`'s raw reading with a lit light at
    /// `distance_m`, or `None` for an out-of-range side.
    #[cfg(test)]
    pub fn mean_std(&self, side: usize, distance_m: f32) -> Option<MeanStd> {
        self.sides.get(side).map(|curve| curve.at(distance_m))
    }

    /// Mean and standard deviation of side `side`'s raw reading in the dark (what a light
    /// sensor reads with no light lit; `hevo export` uses it).
    pub fn dark(&self, side: usize) -> Option<MeanStd> {
        self.sides.get(side).map(ResampledCurve::farthest)
    }
}

/// Turns raw light readings into the two held flash inputs.
///
/// Each cycle, a side whose raw reading is below its threshold counts as a detected flash and
/// (re)arms that side's counter to `hold_cycles`. The side's input is 1 while its counter is
/// above 0, and the counter goes down by one after each cycle's output. So a flash detected in
/// exactly one cycle gives exactly `hold_cycles` (15) consecutive inputs of 1, starting in the
/// cycle of the detection; detections in several cycles keep the input at 1 until
/// `hold_cycles` cycles after the last one.
#[derive(Debug, Clone, PartialEq)]
pub struct FlashDetector {
    threshold_raw: [f32; N_LIGHT],
    hold_cycles: u32,
    remaining: [u32; N_LIGHT],
}

impl FlashDetector {
    /// A detector with the given per-side thresholds and hold length, nothing detected yet.
    pub fn new(threshold_raw: [f32; N_LIGHT], hold_cycles: u32) -> FlashDetector {
        FlashDetector {
            threshold_raw,
            hold_cycles,
            remaining: [0; N_LIGHT],
        }
    }

    /// A detector with the configuration's thresholds and hold length.
    pub fn from_config(config: &LightConfig) -> FlashDetector {
        FlashDetector::new(config.threshold_raw, config.hold_cycles)
    }

    /// Feeds one cycle's raw readings (left, right) and returns the cycle's inputs, each 0 or 1.
    /// A NaN reading is not a detection.
    #[inline]
    pub fn update(&mut self, raw: [f32; N_LIGHT]) -> [f32; N_LIGHT] {
        let mut inputs = [0.0; N_LIGHT];
        for side in 0..N_LIGHT {
            if raw[side] < self.threshold_raw[side] {
                self.remaining[side] = self.hold_cycles;
            }
            if self.remaining[side] > 0 {
                inputs[side] = 1.0;
                self.remaining[side] -= 1;
            }
        }
        inputs
    }

    /// Forgets any held flash, as at the start of a sample.
    #[cfg(test)]
    pub fn reset(&mut self) {
        self.remaining = [0; N_LIGHT];
    }

    /// How many more cycles each side's input will stay 1 without a new detection.
    #[cfg(test)]
    pub fn remaining(&self) -> [u32; N_LIGHT] {
        self.remaining
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::{Stream, stream_rng};

    /// `read_raw` takes the farthest row for "no lit light" where it used to interpolate at
    /// infinity: the two must be the same bits, or the outcomes of every run would move.
    #[test]
    fn the_dark_row_is_what_the_curve_gives_at_infinity() {
        for curve in &LightModel::builtin().sides {
            let (at_infinity, farthest) = (curve.at(f32::INFINITY), curve.farthest());
            assert_eq!(at_infinity.mean.to_bits(), farthest.mean.to_bits());
            assert_eq!(at_infinity.std.to_bits(), farthest.std.to_bits());
        }
    }

    #[test]
    fn builtin_table_parses_with_the_dark_row_last() {
        let model = LightModel::from_csv(BUILTIN_LIGHT_CSV).unwrap();
        assert_eq!(&model, LightModel::builtin());
        let left_dark = model.dark(LEFT).unwrap();
        let right_dark = model.dark(RIGHT).unwrap();
        assert!((left_dark.mean - 3960.65).abs() < 0.01 && (left_dark.std - 0.477).abs() < 0.001);
        assert!(
            (right_dark.mean - 4001.31).abs() < 0.01 && (right_dark.std - 0.4625).abs() < 0.001
        );
        assert!((model.mean_std(LEFT, 0.06).unwrap().mean - 3930.3).abs() < 0.01);
        assert!(model.dark(2).is_none());
        assert_eq!(
            model.read_raw(2, Some(0.0), &mut stream_rng(1, Stream::Noise)),
            f32::INFINITY
        );
    }

    #[test]
    fn raw_reads_follow_the_calibration_curves() {
        let model = LightModel::builtin();
        let table = CalibrationTable::parse(BUILTIN_LIGHT_CSV).unwrap();
        let mut rng = stream_rng(21, Stream::Noise);
        let draws = 4000;
        for (side, name) in LIGHT_CURVE_NAMES.iter().enumerate() {
            let measured = table.curve(name).unwrap();
            for (row, &distance_cm) in table.distances_cm().iter().enumerate() {
                let distance_m = (distance_cm / 100.0) as f32;
                let reads: Vec<f64> = (0..draws)
                    .map(|_| f64::from(model.read_raw(side, Some(distance_m), &mut rng)))
                    .collect();
                let mean = reads.iter().sum::<f64>() / draws as f64;
                let std =
                    (reads.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / draws as f64).sqrt();
                let expected_mean = f64::from(measured.mean[row]);
                let expected_std = f64::from(measured.std[row]);
                assert!(
                    (mean - expected_mean).abs()
                        < 5.0 * expected_std / (draws as f64).sqrt() + 0.01,
                    "{name} at {distance_cm} cm: mean {mean} vs {expected_mean}"
                );
                assert!(
                    (std - expected_std).abs() < 0.1 * expected_std + 0.01,
                    "{name} at {distance_cm} cm: std {std} vs {expected_std}"
                );
            }
        }
    }

    #[test]
    fn no_light_and_far_light_read_dark() {
        let model = LightModel::builtin();
        let dark = model.dark(LEFT).unwrap();
        for distance in [None, Some(0.5), Some(f32::NAN)] {
            let far = distance.unwrap_or(f32::INFINITY);
            assert_eq!(model.mean_std(LEFT, far).unwrap(), dark);
        }
        // At exactly 13 cm, up to f32 rounding of the grid position.
        let at_13_cm = model.mean_std(LEFT, 0.13).unwrap();
        assert!((at_13_cm.mean - dark.mean).abs() < 1e-3);
        assert!((at_13_cm.std - dark.std).abs() < 1e-4);
    }

    #[test]
    fn a_single_detection_gives_exactly_hold_cycles_of_one() {
        let config = LightConfig::default();
        let mut detector = FlashDetector::from_config(&config);
        let dark = [4000.0, 4100.0];
        let mut outputs = vec![detector.update([3900.0, 4100.0])];
        for _ in 0..40 {
            outputs.push(detector.update(dark));
        }
        let left_ones = outputs
            .iter()
            .take_while(|inputs| inputs[LEFT] == 1.0)
            .count();
        assert_eq!(left_ones, 15);
        assert!(outputs[15..].iter().all(|inputs| inputs[LEFT] == 0.0));
        assert!(outputs.iter().all(|inputs| inputs[RIGHT] == 0.0));
    }

    #[test]
    fn a_new_detection_rearms_and_reset_clears() {
        let mut detector = FlashDetector::new([3955.0, 3995.0], 15);
        let lit = [4000.0, 3900.0];
        let dark = [4000.0, 4100.0];
        let mut ones = 0;
        for cycle in 0..60 {
            let raw = if cycle == 0 || cycle == 5 { lit } else { dark };
            ones += detector.update(raw)[RIGHT] as usize;
        }
        assert_eq!(ones, 20);
        detector.update(lit);
        assert_eq!(detector.remaining(), [0, 14]);
        detector.reset();
        assert_eq!(detector.remaining(), [0, 0]);
        assert_eq!(detector.update(dark), [0.0, 0.0]);
        assert_eq!(detector.update([f32::NAN, f32::NAN]), [0.0, 0.0]);
    }

    #[test]
    fn a_dark_side_does_not_trigger() {
        let model = LightModel::builtin();
        let mut detector = FlashDetector::from_config(&LightConfig::default());
        let mut rng = stream_rng(22, Stream::Noise);
        for _ in 0..100_000 {
            let raw = model.read_raw_both([None, None], &mut rng);
            assert_eq!(detector.update(raw), [0.0, 0.0], "false trigger at {raw:?}");
        }
    }

    #[test]
    fn a_lit_light_at_six_cm_is_detected_within_the_flash() {
        let config = LightConfig::default();
        let model = LightModel::builtin();
        let mut rng = stream_rng(23, Stream::Noise);
        let trials = 100_000;
        for side in [LEFT, RIGHT] {
            for distance_m in [0.06, 0.0625] {
                let mut misses = 0;
                for _ in 0..trials {
                    let detected = (0..config.flash_cycles).any(|_| {
                        model.read_raw(side, Some(distance_m), &mut rng)
                            < config.threshold_raw[side]
                    });
                    misses += usize::from(!detected);
                }
                // The expected miss rate is a few in a million, so a handful at most here.
                assert!(
                    (misses as f64) < 0.001 * trials as f64,
                    "side {side} at {distance_m} m: {misses} misses in {trials}"
                );
                // The per-cycle detection rate matches the documented ~92%.
                let detected = (0..20_000)
                    .filter(|_| {
                        model.read_raw(side, Some(distance_m), &mut rng)
                            < config.threshold_raw[side]
                    })
                    .count();
                let rate = detected as f64 / 20_000.0;
                assert!(
                    (0.89..0.95).contains(&rate),
                    "side {side} at {distance_m} m: rate {rate}"
                );
            }
        }
    }

    #[test]
    fn config_defaults_and_serde() {
        let config: LightConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(config, LightConfig::default());
        assert_eq!(config.hold_cycles, 15);
        assert_eq!(config.flash_cycles, 5);
        assert!(serde_json::from_str::<LightConfig>(r#"{"threshold":1}"#).is_err());
        let custom: LightConfig = serde_json::from_str(r#"{"threshold_raw":[3950,3990]}"#).unwrap();
        assert_eq!(custom.threshold_raw, [3950.0, 3990.0]);
    }

    #[test]
    fn a_table_without_light_curves_is_rejected() {
        let result = LightModel::from_csv("distance_cm,mean_l,std_l\n0,1,1\n13,2,1\n");
        assert!(
            matches!(result, Err(CalibrationError::MissingCurve { ref curve }) if curve == "r")
        );
    }
}
