//! Light-flash sensing: detection thresholds, how long a flash is held, how long a light stays
//! lit. The sensor model is [`crate::sensors::light`].

use serde::{Deserialize, Serialize};

/// Number of light-flash inputs: left, right.
pub const N_LIGHT: usize = 2;

/// Light sensing and flash configuration.
///
/// The default thresholds come from the calibration table. The right sensor reads about 40
/// units higher than the left one throughout (dark: left 3960.65 +- 0.48, right 4001.31 +-
/// 0.46), so one threshold cannot serve both sides: 3955 would detect a lit light at 6 cm on the
/// right in only 42% of cycles. Each side's threshold therefore sits just below its own dark row:
///
/// * left 3955 (11.8 dark standard deviations below 3960.65): a dark left side triggers with
///   probability 1e-32 per cycle; a lit light 6 cm away (mean 3930.3 +- 17.5) is detected in
///   92.1% of cycles, at 6.25 cm (a robot centred in a 0.2 m corridor) 91.8%, at 7 cm 90.6%;
/// * right 3995 (13.6 dark standard deviations below 4001.31): false trigger 1e-42 per cycle;
///   a lit light at 6 cm (3959.92 +- 23.4) is detected in 93.3% of cycles, at 7 cm 92.4%.
///
/// A light stays lit for `flash_cycles` = 5 cycles once triggered. A robot passing at 6 cm
/// misses a flash only if all 5 reads miss: probability 0.079^5 = 3.1e-6 on the left and
/// 0.067^5 = 1.4e-6 on the right; the worst case between 6 and 8 cm is 7.3e-6 (left, 7 cm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LightConfig {
    /// How many cycles a side's input stays 1 after the last cycle a flash was detected on it.
    pub hold_cycles: u32,
    /// Per side (left, right): a raw reading below this counts as a detected flash.
    pub threshold_raw: [f32; N_LIGHT],
    /// How many control cycles a light stays lit once the world triggers it.
    pub flash_cycles: u32,
}

impl Default for LightConfig {
    fn default() -> Self {
        LightConfig {
            hold_cycles: 15,
            threshold_raw: [3955.0, 3995.0],
            flash_cycles: 5,
        }
    }
}
