//! Parameters of the identity evaluation.

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, Result};

/// Parameters of [`evaluate`](super::evaluate). Plain data, loadable from TOML; every field has
/// its unit in its name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// Radius of Llorca's "near" association (CNA), metres: a subject's label that sits on
    /// another person's skeleton counts as *correct or near* when that person's reference point
    /// (pelvis, else the centroid of its joints; see `METRICS.md`) is at most this far from the
    /// wearer's. Default 1.0 m, the value of the brief (about one arm's length between people).
    pub near_distance_m: f64,
    /// A gap of at least this many seconds between two consecutive observations of a person by
    /// one camera ends an appearance; the next observation starts a new one (a reappearance).
    /// Default 1.0 s.
    pub reappearance_gap_s: f64,
    /// Width of the bins of accuracy over time, seconds. Bin `k` covers
    /// `[k · time_bin_s, (k + 1) · time_bin_s)` on the session clock. Default 1.0 s.
    pub time_bin_s: f64,
    /// How long, in seconds, a correct association must last for Llorca's delay to stop:
    /// `None` (the default) means "until the end of the appearance"; `Some(h)` means every
    /// observation of the appearance within `h` seconds after the candidate frame is correct.
    pub delay_hold_s: Option<f64>,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            near_distance_m: 1.0,
            reappearance_gap_s: 1.0,
            time_bin_s: 1.0,
            delay_hold_s: None,
        }
    }
}

impl EvalConfig {
    /// Checks that every value is finite and in range.
    ///
    /// # Errors
    /// [`EvalError::InvalidConfig`] naming the field.
    pub fn validate(&self) -> Result<()> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(EvalError::InvalidConfig(format!(
                    "{name} must be finite and positive, got {v}"
                )))
            }
        };
        positive("near_distance_m", self.near_distance_m)?;
        positive("reappearance_gap_s", self.reappearance_gap_s)?;
        positive("time_bin_s", self.time_bin_s)?;
        if let Some(h) = self.delay_hold_s
            && !(h.is_finite() && h >= 0.0)
        {
            return Err(EvalError::InvalidConfig(format!(
                "delay_hold_s must be finite and non-negative, got {h}"
            )));
        }
        Ok(())
    }

    /// `reappearance_gap_s` in nanoseconds.
    pub(crate) fn reappearance_gap_ns(&self) -> i64 {
        secs_to_ns(self.reappearance_gap_s)
    }

    /// `time_bin_s` in nanoseconds, at least 1.
    pub(crate) fn time_bin_ns(&self) -> i64 {
        secs_to_ns(self.time_bin_s).max(1)
    }

    /// `delay_hold_s` in nanoseconds; `i64::MAX` for "until the end of the appearance".
    pub(crate) fn delay_hold_ns(&self) -> i64 {
        self.delay_hold_s.map_or(i64::MAX, secs_to_ns)
    }
}

/// Seconds to nanoseconds, saturating (the inputs are validated finite).
fn secs_to_ns(s: f64) -> i64 {
    let ns = (s * 1e9).round();
    if ns >= i64::MAX as f64 {
        i64::MAX
    } else if ns <= i64::MIN as f64 {
        i64::MIN
    } else {
        ns as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_non_positive_values_are_rejected() {
        let config = EvalConfig::default();
        assert!(config.validate().is_ok());
        assert_eq!(config.reappearance_gap_ns(), 1_000_000_000);
        let bad = EvalConfig {
            near_distance_m: 0.0,
            ..EvalConfig::default()
        };
        let err = bad.validate().unwrap_err().to_string();
        assert!(err.contains("near_distance_m"), "{err}");
        let bad = EvalConfig {
            time_bin_s: f64::NAN,
            ..EvalConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}
