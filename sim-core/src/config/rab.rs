//! The range-and-bearing board (`[rab]`): how far it hears another robot of a team and how
//! noisy its range estimate is. The sensor model is [`crate::sensors::rab`].

use super::{ConfigError, invalid};
use serde::{Deserialize, Serialize};

/// The largest `rab.range_m`: a query reaches this far around every robot in every cycle, so
/// a wider one would make a crowded arena cost nearly a scan of all pairs.
pub const MAX_RAB_RANGE_M: f32 = 5.0;

/// The largest `rab.range_noise`: beyond it a measured range says little about the true one.
pub const MAX_RAB_RANGE_NOISE: f32 = 0.5;

/// Range-and-bearing configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RabConfig {
    /// How far the board hears another robot, metres, centre to centre. The e-puck's board
    /// reaches some 0.8 m at full power.
    pub range_m: f32,
    /// Standard deviation of the multiplicative range noise: a neighbour heard at distance `d`
    /// is measured at `d * (1 + N(0, 1) * range_noise)`, one draw per neighbour heard per
    /// cycle. 0 (the default) draws nothing.
    pub range_noise: f32,
}

impl Default for RabConfig {
    fn default() -> Self {
        RabConfig {
            range_m: 0.8,
            range_noise: 0.0,
        }
    }
}

impl RabConfig {
    /// Whether it is the default: a task or a scenario then leaves `rab` out when serialised,
    /// so the content hashes written before the board existed stay as they were.
    pub fn is_default(&self) -> bool {
        *self == RabConfig::default()
    }

    /// Checks the range and the noise; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.range_m > 0.0 && self.range_m <= MAX_RAB_RANGE_M) {
            return Err(invalid(
                "rab.range_m",
                format!("must be in (0, {MAX_RAB_RANGE_M}], got {}", self.range_m),
            ));
        }
        if !(self.range_noise >= 0.0 && self.range_noise <= MAX_RAB_RANGE_NOISE) {
            return Err(invalid(
                "rab.range_noise",
                format!(
                    "must be in [0, {MAX_RAB_RANGE_NOISE}], got {}",
                    self.range_noise
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_valid_and_a_bad_value_is_refused_by_its_key() {
        assert_eq!(RabConfig::default().validate(), Ok(()));
        assert!(RabConfig::default().is_default());
        for (config, key) in [
            (
                RabConfig {
                    range_m: 0.0,
                    ..RabConfig::default()
                },
                "rab.range_m",
            ),
            (
                RabConfig {
                    range_m: f32::NAN,
                    ..RabConfig::default()
                },
                "rab.range_m",
            ),
            (
                RabConfig {
                    range_m: f32::INFINITY,
                    ..RabConfig::default()
                },
                "rab.range_m",
            ),
            (
                RabConfig {
                    range_noise: -0.1,
                    ..RabConfig::default()
                },
                "rab.range_noise",
            ),
            (
                RabConfig {
                    range_noise: f32::NAN,
                    ..RabConfig::default()
                },
                "rab.range_noise",
            ),
            (
                RabConfig {
                    range_noise: 0.6,
                    ..RabConfig::default()
                },
                "rab.range_noise",
            ),
        ] {
            let error = config.validate().unwrap_err();
            assert_eq!(error.key, key, "{error}");
        }
        let edge = RabConfig {
            range_m: MAX_RAB_RANGE_M,
            range_noise: MAX_RAB_RANGE_NOISE,
        };
        assert_eq!(edge.validate(), Ok(()));
        assert!(!edge.is_default());
    }

    #[test]
    fn an_empty_table_is_the_default_and_an_unknown_key_is_refused() {
        let config: RabConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(config, RabConfig::default());
        let error = serde_json::from_str::<RabConfig>(r#"{"range":1}"#).unwrap_err();
        assert!(error.to_string().contains("range"), "{error}");
    }
}
