//! Position error of multilateration and tag filtering on the LIAS UWB recordings, against
//! their motion-capture (dynamic) or surveyed (static) truth.
//!
//! Sans-IO: the caller parses the files with `nomen_fit::load` (`parse_uwb_csv`,
//! `parse_mocap_csv`) and passes the recordings; the `lias_report` example does the reading and
//! prints the table. The true tag position is the rigid-body pose times the tag offset
//! (`nomen_fit::uwb::UwbSetup`), the pose interpolated from the mocap with the quaternion
//! convention `nomen_fit::uwb::check_quat_convention` decides.
//!
//! The LIAS anchors all sit at 1.04 m and the tags at 0.97 m, 7 cm below their plane, where the
//! height is unobservable from ranges; the trolley runs on a flat floor, so positions are solved
//! in the plane at the tag's median true height ([`HeightConstraint::Fixed`]) and errors are
//! horizontal.

use crate::load::UwbRecording;
use crate::uwb::{RangeErrors, UwbSetup};
use nalgebra::{Isometry3, Point3};
use nomen_core::SessionTime;
use nomen_rtls::multilat::{
    AnchorRange, HeightConstraint, MultilaterationConfig, RangeBias, RangeTruth, solve_twr,
};
use nomen_rtls::track::{FixOutcome, TagFilterConfig, TagTrack};
use nomen_rtls::{Result, RtlsError};
use serde::{Deserialize, Serialize};

/// Summary of a set of errors, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Number of errors.
    pub num: usize,
    /// Root mean square, m.
    pub rmse_m: f64,
    /// Median, m.
    pub p50_m: f64,
    /// 90th percentile, m.
    pub p90_m: f64,
    /// 95th percentile, m.
    pub p95_m: f64,
    /// Largest, m.
    pub max_m: f64,
}

impl ErrorStats {
    /// Statistics of non-negative errors (non-finite ones are left out); `None` if none remain.
    pub fn from_errors(errors: &[f64]) -> Option<Self> {
        let mut v: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| {
            let pos = p * (v.len() - 1) as f64;
            let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
            v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
        };
        Some(Self {
            num: v.len(),
            rmse_m: (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt(),
            p50_m: q(0.5),
            p90_m: q(0.9),
            p95_m: q(0.95),
            max_m: v[v.len() - 1],
        })
    }
}

/// One solved position of one tag.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TagEstimate {
    /// Row time, s (recording clock).
    pub t_s: f64,
    /// Tag index.
    pub tag: usize,
    /// Solved position, m.
    pub position_m: Point3<f64>,
    /// Its covariance diagonal, m².
    pub variance_m2: [f64; 3],
}

/// Solves every (row, tag) of `uwb` with at least `min_anchors` ranges, biases removed.
/// Returns the estimates and the number of (row, tag) slots that could not be solved.
pub fn locate_recording(
    uwb: &UwbRecording,
    setup: &UwbSetup,
    bias: &RangeBias,
    tag_heights_m: &[f64],
    config: &MultilaterationConfig,
    min_anchors: usize,
) -> (Vec<TagEstimate>, usize) {
    let mut out = Vec::new();
    let mut num_failed = 0;
    let mut last: Vec<Option<Point3<f64>>> = vec![None; uwb.num_tags];
    for row in &uwb.rows {
        for (tag, last_position) in last.iter_mut().enumerate() {
            let ranges: Vec<AnchorRange> = (0..uwb.num_anchors)
                .filter_map(|a| {
                    let r = uwb.range_m(row, a, tag)?;
                    let anchor = setup.anchors_m.get(a)?;
                    Some(AnchorRange {
                        anchor_m: Point3::from(*anchor),
                        range_m: bias.correct(a, r),
                    })
                })
                .collect();
            if ranges.len() < min_anchors {
                num_failed += 1;
                continue;
            }
            let cfg = MultilaterationConfig {
                height: tag_heights_m
                    .get(tag)
                    .map_or(config.height, |z| HeightConstraint::Fixed(*z)),
                ..*config
            };
            match solve_twr(&ranges, *last_position, &cfg) {
                Ok(s) => {
                    *last_position = Some(s.position_m);
                    out.push(TagEstimate {
                        t_s: row.t_s,
                        tag,
                        position_m: s.position_m,
                        variance_m2: [
                            s.covariance_m2[(0, 0)],
                            s.covariance_m2[(1, 1)],
                            s.covariance_m2[(2, 2)],
                        ],
                    });
                }
                Err(_) => num_failed += 1,
            }
        }
    }
    (out, num_failed)
}

/// Runs each tag's estimates through a [`TagTrack`] (their own covariance as the fix noise) and
/// returns the filtered positions (same order; gated fixes keep the prediction).
pub fn filter_estimates(
    estimates: &[TagEstimate],
    num_tags: usize,
    config: &TagFilterConfig,
) -> Result<Vec<TagEstimate>> {
    let mut tracks: Vec<TagTrack> = (0..num_tags)
        .map(|_| TagTrack::new(*config))
        .collect::<Result<_>>()?;
    let mut out = Vec::with_capacity(estimates.len());
    for e in estimates {
        let Some(track) = tracks.get_mut(e.tag) else {
            continue;
        };
        let t = SessionTime::from_secs_f64(e.t_s).ok_or_else(|| RtlsError::InvalidParameter {
            name: "t_s",
            reason: format!("time {} s is not representable", e.t_s),
        })?;
        // Floor the noise at a centimetre so a near-exact solve cannot freeze the filter.
        let r = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::from(
            e.variance_m2.map(|v| v.max(1e-4)),
        ));
        let outcome = track.update(t, &e.position_m, Some(&r))?;
        if outcome == FixOutcome::Ignored {
            continue;
        }
        if let Some(s) = track.state_at(t) {
            out.push(TagEstimate {
                position_m: s.position_m,
                ..*e
            });
        }
    }
    Ok(out)
}

/// Horizontal errors of estimates against `truth(t_s, tag)` (estimates without truth skipped).
pub fn horizontal_errors(
    estimates: &[TagEstimate],
    truth: &dyn Fn(f64, usize) -> Option<Point3<f64>>,
) -> Vec<f64> {
    estimates
        .iter()
        .filter_map(|e| {
            let p = truth(e.t_s, e.tag)?;
            Some((e.position_m.xy() - p.xy()).norm())
        })
        .collect()
}

/// The true tag position for a body pose.
pub fn tag_in_world(
    setup: &UwbSetup,
    world_from_body: &Isometry3<f64>,
    tag: usize,
) -> Option<Point3<f64>> {
    let offset = setup.tag_offsets_body_m.get(tag)?;
    Some(world_from_body * Point3::from(*offset))
}

/// Range-truth samples from `nomen_fit`'s range errors (for [`nomen_rtls::multilat::estimate_range_bias`]).
pub fn range_truths(errors: &RangeErrors) -> Vec<RangeTruth> {
    errors
        .samples
        .iter()
        .map(|s| RangeTruth {
            anchor: s.anchor,
            measured_m: s.true_range_m + s.error_m,
            true_m: s.true_range_m,
        })
        .collect()
}

/// How ranges are de-biased in a report row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BiasMode {
    /// Ranges as measured.
    None,
    /// One constant removed.
    Constant,
    /// A constant plus one term per anchor removed.
    PerAnchor,
}

/// One row of the LIAS report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LiasRow {
    /// Recording name.
    pub recording: String,
    /// Static or dynamic.
    pub is_dynamic: bool,
    /// Bias handling.
    pub bias: BiasMode,
    /// Whether the bias was estimated on this same recording.
    pub is_in_sample: bool,
    /// (row, tag) slots not solved (too few ranges, no convergence).
    pub num_unsolved: usize,
    /// Errors of the raw multilateration, horizontal, m.
    pub raw: Option<ErrorStats>,
    /// Errors after the tag Kalman filter, horizontal, m.
    pub filtered: Option<ErrorStats>,
}

/// Evaluates one recording under one bias mode: locate, filter, compare with truth.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_recording(
    uwb: &UwbRecording,
    setup: &UwbSetup,
    truth: &dyn Fn(f64, usize) -> Option<Point3<f64>>,
    bias: &RangeBias,
    bias_mode: BiasMode,
    is_dynamic: bool,
    is_in_sample: bool,
    config: &MultilaterationConfig,
    filter: &TagFilterConfig,
) -> Result<LiasRow> {
    let bias = match bias_mode {
        BiasMode::None => RangeBias::default(),
        BiasMode::Constant => bias.constant_only(),
        BiasMode::PerAnchor => bias.clone(),
    };
    // The platform height per tag: median true height over the recording's rows.
    let heights: Vec<f64> = (0..uwb.num_tags)
        .map(|tag| {
            let mut z: Vec<f64> = uwb
                .rows
                .iter()
                .step_by(10)
                .filter_map(|r| truth(r.t_s, tag).map(|p| p.z))
                .collect();
            z.sort_by(f64::total_cmp);
            z.get(z.len() / 2).copied().unwrap_or(f64::NAN)
        })
        .collect();
    if heights.iter().any(|z| !z.is_finite()) {
        return Err(RtlsError::TooFewMeasurements {
            what: "lias evaluation (no truth for a tag)",
            needed: 1,
            got: 0,
        });
    }
    let (raw, num_unsolved) = locate_recording(uwb, setup, &bias, &heights, config, 3);
    let filtered = filter_estimates(&raw, uwb.num_tags, filter)?;
    Ok(LiasRow {
        recording: uwb.name.clone(),
        is_dynamic,
        bias: bias_mode,
        is_in_sample,
        num_unsolved,
        raw: ErrorStats::from_errors(&horizontal_errors(&raw, truth)),
        filtered: ErrorStats::from_errors(&horizontal_errors(&filtered, truth)),
    })
}

/// The report as a text table (centimetres).
pub fn render_report(rows: &[LiasRow]) -> String {
    let mut out = String::from(
        "LIAS UWB: horizontal position error of TWR multilateration (raw) and after the tag Kalman filter, cm\n",
    );
    out.push_str(&format!(
        "{:<44} {:>7} {:>10} {:>7} | {:>6} {:>6} {:>6} {:>6} | {:>6} {:>6} {:>6}\n",
        "recording", "kind", "bias", "n", "rmse", "p50", "p90", "p95", "f.rmse", "f.p50", "f.p95"
    ));
    let cm = |v: f64| format!("{:.1}", 100.0 * v);
    for r in rows {
        let name = r.recording.rsplit('/').next().unwrap_or(&r.recording);
        let bias = format!(
            "{}{}",
            match r.bias {
                BiasMode::None => "none",
                BiasMode::Constant => "const",
                BiasMode::PerAnchor => "anchor",
            },
            if r.is_in_sample && r.bias != BiasMode::None {
                "*"
            } else {
                ""
            }
        );
        let (n, raw) = r.raw.map_or(
            (
                "0".into(),
                ["-".to_owned(), "-".into(), "-".into(), "-".into()],
            ),
            |s| {
                (
                    s.num.to_string(),
                    [cm(s.rmse_m), cm(s.p50_m), cm(s.p90_m), cm(s.p95_m)],
                )
            },
        );
        let filt = r
            .filtered
            .map_or(["-".to_owned(), "-".into(), "-".into()], |s| {
                [cm(s.rmse_m), cm(s.p50_m), cm(s.p95_m)]
            });
        out.push_str(&format!(
            "{:<44} {:>7} {:>10} {:>7} | {:>6} {:>6} {:>6} {:>6} | {:>6} {:>6} {:>6}\n",
            name,
            if r.is_dynamic { "dynamic" } else { "static" },
            bias,
            n,
            raw[0],
            raw[1],
            raw[2],
            raw[3],
            filt[0],
            filt[1],
            filt[2]
        ));
    }
    out.push_str("* bias estimated on this recording (in-sample)\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_stats_are_percentiles_of_the_finite_errors() {
        let e: Vec<f64> = (1..=100).map(f64::from).chain([f64::NAN]).collect();
        let s = ErrorStats::from_errors(&e).unwrap();
        assert_eq!(s.num, 100);
        assert!((s.p50_m - 50.5).abs() < 1e-12);
        assert!((s.p95_m - 95.05).abs() < 1e-9);
        assert_eq!(s.max_m, 100.0);
        assert!(ErrorStats::from_errors(&[]).is_none());
    }
}
