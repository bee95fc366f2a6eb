//! Clock offset between two position streams of one moving point: a tagged person's key joint
//! seen by a camera (*source*, in the camera frame) and the tag's fixes (*target*, in the RTLS
//! frame).
//!
//! The frames differ by an unknown transform, so every candidate offset is scored by the
//! residual of a transform refitted at that offset: target samples at `t` are paired with the
//! source interpolated at `t + offset`, Umeyama fits the pairs, the worst `trim_fraction` of the
//! residuals (NLOS fixes, tracking glitches) are dropped and the fit repeated, and the score is
//! the RMS of the kept residuals. The search is a grid over `±max_offset_s` at `coarse_step_s`,
//! then a grid at `fine_step_s` over one coarse step either side of the best. Only motion makes
//! the offset observable: a person standing still gives a flat curve (see
//! [`ClockOffsetFit::contrast`]).

use crate::error::{CalibError, Result, check_positive};
use crate::fit::{FitKind, SimilarityTransform, fit_pairs};
use nalgebra::Point3;
use nomen_core::SessionTime;
use serde::{Deserialize, Serialize};

/// A position at a time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimedPoint {
    /// Time on the stream's own clock.
    pub t: SessionTime,
    /// Position in the stream's own frame, metres.
    pub position_m: Point3<f64>,
}

/// Clock-offset search settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClockSearchConfig {
    /// Half-width of the search, s. Default 2 s (Belmonte-Hernández measured offsets up to
    /// 0.5 s between wearables and cameras; 2 s leaves a margin).
    pub max_offset_s: f64,
    /// Coarse grid step, s. Default 0.04 s (a little more than one 30 Hz camera frame).
    pub coarse_step_s: f64,
    /// Fine grid step, s. Default 0.002 s.
    pub fine_step_s: f64,
    /// Source samples further apart than this are not interpolated across, s. Default 0.25 s.
    pub max_gap_s: f64,
    /// Fraction of the largest residuals dropped before scoring, `0..0.9`. Default 0.2 (NLOS
    /// fixes are ~5 % in the LIAS fit; 20 % leaves room for body shadowing).
    pub trim_fraction: f64,
    /// Fewest pairs an offset needs to be scored. Default 10.
    pub min_pairs: usize,
    /// Transform family fitted at each offset.
    pub kind: FitKind,
}

impl Default for ClockSearchConfig {
    fn default() -> Self {
        Self {
            max_offset_s: 2.0,
            coarse_step_s: 0.04,
            fine_step_s: 0.002,
            max_gap_s: 0.25,
            trim_fraction: 0.2,
            min_pairs: 10,
            kind: FitKind::Rigid,
        }
    }
}

impl ClockSearchConfig {
    fn validate(&self) -> Result<()> {
        check_positive("max_offset_s", self.max_offset_s)?;
        check_positive("coarse_step_s", self.coarse_step_s)?;
        check_positive("fine_step_s", self.fine_step_s)?;
        check_positive("max_gap_s", self.max_gap_s)?;
        if !(0.0..0.9).contains(&self.trim_fraction) {
            return Err(CalibError::InvalidParameter {
                name: "trim_fraction",
                reason: format!("must be in 0..0.9, got {}", self.trim_fraction),
            });
        }
        Ok(())
    }
}

/// One point of the search curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OffsetScore {
    /// Candidate offset, s.
    pub offset_s: f64,
    /// Trimmed RMS residual, m (`inf` when too few pairs).
    pub residual_m: f64,
}

/// The result of [`estimate_clock_offset`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClockOffsetFit {
    /// Source stamp minus target stamp of the same instant, ns: the source stamped `t + offset`
    /// describes what the target stamped `t` describes. Add it to target stamps to put them on
    /// the source clock.
    pub offset_ns: i64,
    /// Trimmed RMS residual at the best offset, m.
    pub residual_m: f64,
    /// Pairs at the best offset.
    pub num_pairs: usize,
    /// `target_from_source` fitted at the best offset (trimmed).
    pub target_from_source: SimilarityTransform,
    /// The coarse and fine curves, in search order.
    pub curve: Vec<OffsetScore>,
}

impl ClockOffsetFit {
    /// Median residual over the coarse curve divided by the best residual: near 1 the offset is
    /// not observable (no motion); a clear minimum gives several.
    pub fn contrast(&self) -> f64 {
        let mut v: Vec<f64> = self
            .curve
            .iter()
            .map(|s| s.residual_m)
            .filter(|r| r.is_finite())
            .collect();
        v.sort_by(f64::total_cmp);
        let median = crate::fit::percentile_sorted(&v, 0.5);
        median / self.residual_m
    }
}

/// Linear interpolation of a time-sorted stream at `t_ns`; `None` outside it or across a gap.
fn interpolate(stream: &[TimedPoint], t_ns: i64, max_gap_ns: i64) -> Option<Point3<f64>> {
    let i = stream.partition_point(|p| p.t.as_ns() < t_ns);
    let b = stream.get(i)?;
    if b.t.as_ns() == t_ns {
        return Some(b.position_m);
    }
    let a = stream.get(i.checked_sub(1)?)?;
    let span = b.t.as_ns() - a.t.as_ns();
    if span <= 0 || span > max_gap_ns {
        return None;
    }
    let f = (t_ns - a.t.as_ns()) as f64 / span as f64;
    Some(a.position_m + (b.position_m - a.position_m) * f)
}

/// Pairs `(source at t + offset, target at t)` over the target samples.
pub fn pairs_at_offset(
    source_sorted: &[TimedPoint],
    target: &[TimedPoint],
    offset_ns: i64,
    max_gap_s: f64,
) -> Vec<(Point3<f64>, Point3<f64>)> {
    let max_gap_ns = (max_gap_s * 1e9) as i64;
    target
        .iter()
        .filter(|p| p.position_m.iter().all(|v| v.is_finite()))
        .filter_map(|p| {
            interpolate(
                source_sorted,
                p.t.as_ns().saturating_add(offset_ns),
                max_gap_ns,
            )
            .map(|s| (s, p.position_m))
        })
        .collect()
}

/// Fit, drop the worst `trim` fraction, refit; returns the transform and the kept RMS.
pub(crate) fn trimmed_fit(
    pairs: &[(Point3<f64>, Point3<f64>)],
    kind: FitKind,
    trim: f64,
) -> Option<(SimilarityTransform, f64)> {
    let first = fit_pairs(pairs, kind).ok()?;
    let mut scored: Vec<(f64, usize)> = pairs
        .iter()
        .enumerate()
        .map(|(i, (x, y))| ((y - first.apply(x)).norm(), i))
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let keep = ((1.0 - trim) * pairs.len() as f64).ceil() as usize;
    let kept: Vec<_> = scored
        .iter()
        .take(keep.max(3))
        .map(|&(_, i)| pairs[i])
        .collect();
    let second = fit_pairs(&kept, kind).ok()?;
    let sum2: f64 = kept
        .iter()
        .map(|(x, y)| (y - second.apply(x)).norm_squared())
        .sum();
    Some((second, (sum2 / kept.len() as f64).sqrt()))
}

/// Searches the clock offset between `source` and `target` (see the module docs).
pub fn estimate_clock_offset(
    source: &[TimedPoint],
    target: &[TimedPoint],
    config: &ClockSearchConfig,
) -> Result<ClockOffsetFit> {
    config.validate()?;
    let mut src: Vec<TimedPoint> = source
        .iter()
        .filter(|p| p.position_m.iter().all(|v| v.is_finite()))
        .copied()
        .collect();
    src.sort_by_key(|p| p.t);
    let score = |offset_s: f64| -> (OffsetScore, Option<(SimilarityTransform, usize)>) {
        let offset_ns = (offset_s * 1e9).round() as i64;
        let pairs = pairs_at_offset(&src, target, offset_ns, config.max_gap_s);
        if pairs.len() < config.min_pairs.max(3) {
            return (
                OffsetScore {
                    offset_s,
                    residual_m: f64::INFINITY,
                },
                None,
            );
        }
        match trimmed_fit(&pairs, config.kind, config.trim_fraction) {
            Some((t, r)) => (
                OffsetScore {
                    offset_s,
                    residual_m: r,
                },
                Some((t, pairs.len())),
            ),
            None => (
                OffsetScore {
                    offset_s,
                    residual_m: f64::INFINITY,
                },
                None,
            ),
        }
    };
    let mut curve = Vec::new();
    let mut best: Option<(OffsetScore, SimilarityTransform, usize)> = None;
    let num_coarse = (config.max_offset_s / config.coarse_step_s).round() as i64;
    let num_fine = (config.coarse_step_s / config.fine_step_s).ceil() as i64;
    for pass in 0..2 {
        let offsets: Vec<f64> = if pass == 0 {
            (-num_coarse..=num_coarse)
                .map(|k| k as f64 * config.coarse_step_s)
                .collect()
        } else {
            let Some(centre) = best.as_ref().map(|b| b.0.offset_s) else {
                break;
            };
            (-num_fine..=num_fine)
                .filter(|&k| k != 0)
                .map(|k| centre + k as f64 * config.fine_step_s)
                .filter(|o| o.abs() <= config.max_offset_s + 1e-12)
                .collect()
        };
        for offset_s in offsets {
            let (s, fit) = score(offset_s);
            curve.push(s);
            if let Some((t, n)) = fit
                && best.as_ref().is_none_or(|b| s.residual_m < b.0.residual_m)
            {
                best = Some((s, t, n));
            }
        }
    }
    let Some((s, t, n)) = best else {
        return Err(CalibError::TooFewPoints {
            what: "clock offset search",
            needed: config.min_pairs.max(3),
            got: 0,
        });
    };
    Ok(ClockOffsetFit {
        offset_ns: (s.offset_s * 1e9).round() as i64,
        residual_m: s.residual_m,
        num_pairs: n,
        target_from_source: t,
        curve,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    /// A point walking a rounded figure in a room, at time `s` seconds.
    fn walk(s: f64) -> Point3<f64> {
        Point3::new(
            2.0 * (0.4 * s).cos() + 0.3 * (1.7 * s).sin(),
            1.5 * (0.55 * s).sin(),
            1.0 + 0.1 * (3.0 * s).sin(),
        )
    }

    #[test]
    fn known_offset_and_transform_are_recovered() {
        let target_from_source = SimilarityTransform {
            scale: 1.0,
            isometry: Isometry3::from_parts(
                Translation3::new(4.0, 0.2, 1.6),
                UnitQuaternion::from_euler_angles(-1.5, 0.0, 0.3),
            ),
        };
        let offset_s = 0.734;
        // Camera at 30 Hz: what it saw at true time s is stamped s + offset, in its own frame.
        let source: Vec<TimedPoint> = (0..1800)
            .map(|k| {
                let s = k as f64 / 30.0;
                TimedPoint {
                    t: SessionTime::from_secs_f64(s + offset_s).unwrap(),
                    position_m: target_from_source.inverse().apply(&walk(s)),
                }
            })
            .collect();
        // Fixes at 10 Hz on the true clock, every 17th one an NLOS outlier.
        let target: Vec<TimedPoint> = (0..600)
            .map(|k| {
                let s = 0.05 + k as f64 / 10.0;
                let mut p = walk(s);
                if k % 17 == 0 {
                    p.x += 1.5;
                }
                TimedPoint {
                    t: SessionTime::from_secs_f64(s).unwrap(),
                    position_m: p,
                }
            })
            .collect();
        let fit = estimate_clock_offset(&source, &target, &ClockSearchConfig::default()).unwrap();
        assert!(
            (fit.offset_ns as f64 * 1e-9 - offset_s).abs() < 0.003,
            "{}",
            fit.offset_ns
        );
        let angle = fit
            .target_from_source
            .rotation()
            .angle_to(&target_from_source.rotation());
        assert!(angle < 1e-3, "{angle}");
        assert!(fit.contrast() > 5.0, "{}", fit.contrast());
    }
}
