//! Sensor faults injected into a simulated scene's messages: lost IMU samples (at random or in
//! bursts), a camera gone dark, wrong, drifting and jumping IMU clocks, UWB outliers, duplicated
//! and late messages.
//!
//! Sans-IO: [`inject`] takes the messages in the order they are delivered (a simulated
//! recording sorted by time, as written), their ground truth, one [`Fault`] and a seed, and
//! returns the faulty messages in their new delivery order with the truth that still describes
//! them. Each device draws from its own named stream (`faults/<fault>/<device>`, see
//! [`crate::rng::stream`]), so one device's faults do not depend on the others'.
//!
//! Faults that need the simulator itself (a wearable moved to another person, one taken off and
//! left on a table) are part of the scenario: [`crate::scenario::WearChange`].

use crate::error::{Result, SimError};
use crate::rng::{SimRng, stream};
use nomen_core::{Message, SessionTime, TrackId};
use rand::Rng;
use rand_distr::{Distribution, Exp};
use serde::Serialize;
use std::collections::BTreeMap;

/// The amount added to the track ids a camera reports after it was dark: its body tracker starts
/// over and gives every person a new id, one that no earlier track carried.
pub const TRACK_ID_OFFSET_AFTER_DARK: u64 = 1 << 32;

/// One fault, at one level.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "fault")]
pub enum Fault {
    /// Every IMU sample is lost with probability `fraction`, independently.
    ImuLoss {
        /// Probability that a sample is lost, `0..=1`.
        fraction: f64,
    },
    /// Each IMU loses its samples in bursts: lossy and clean periods alternate, with
    /// exponentially distributed lengths, lossy ones `mean_burst_s` long on average and clean ones
    /// as long as makes `fraction` of the time lossy.
    ImuBurstLoss {
        /// Long-run share of the time an IMU is lossy, `0..=1`.
        fraction: f64,
        /// Mean length of a burst of loss, s (> 0).
        mean_burst_s: f64,
    },
    /// A camera sends nothing from `start_s` for `duration_s`; its body tracker then starts over
    /// with new track ids ([`TRACK_ID_OFFSET_AFTER_DARK`]). The truth of the frames it did not
    /// send is dropped.
    CameraDark {
        /// The camera.
        camera: String,
        /// Session time the camera goes dark, s.
        start_s: f64,
        /// How long it stays dark, s (≥ 0).
        duration_s: f64,
    },
    /// Every IMU's clock is off by `offset_s` more than it was, forward or backward (a fair coin
    /// per device): its stamps move by ±`offset_s`.
    ClockOffset {
        /// Size of the added offset, s (≥ 0).
        offset_s: f64,
    },
    /// Every IMU's clock runs fast or slow (a fair coin per device) by `drift_ppm`: a stamp `t`
    /// moves by ±`drift_ppm`·10⁻⁶·`t`.
    ClockDrift {
        /// Size of the added drift, ppm (≥ 0).
        drift_ppm: f64,
    },
    /// Every IMU's clock jumps once by ±`jump_s` (a fair coin per device), at an instant drawn
    /// uniformly in the middle half of the device's samples; the stamps after it keep the jump.
    ClockJump {
        /// Size of the jump, s (≥ 0).
        jump_s: f64,
    },
    /// A share of the UWB fixes are thrown `size_m` away from where the system put them, in a
    /// horizontal direction drawn uniformly; the same share of raw ranges read `size_m` long.
    UwbOutliers {
        /// Size of an outlier, m (≥ 0).
        size_m: f64,
        /// Probability that a fix or range is an outlier, `0..=1`.
        share: f64,
    },
    /// Every sensor message is delivered twice with probability `share` (the copy right after).
    Duplicates {
        /// Probability that a message is duplicated, `0..=1`.
        share: f64,
    },
    /// Every sensor message is delivered `delay_s` after its place in time order with
    /// probability `share`.
    Late {
        /// Probability that a message is late, `0..=1`.
        share: f64,
        /// How late, s (≥ 0).
        delay_s: f64,
    },
}

impl Fault {
    /// The fault's short name, as in the streams it draws from (`imu_loss`, `camera_dark`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            Fault::ImuLoss { .. } => "imu_loss",
            Fault::ImuBurstLoss { .. } => "imu_burst_loss",
            Fault::CameraDark { .. } => "camera_dark",
            Fault::ClockOffset { .. } => "clock_offset",
            Fault::ClockDrift { .. } => "clock_drift",
            Fault::ClockJump { .. } => "clock_jump",
            Fault::UwbOutliers { .. } => "uwb_outliers",
            Fault::Duplicates { .. } => "duplicates",
            Fault::Late { .. } => "late",
        }
    }

    /// Checks that every level is finite and in its range; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let share = |name: &str, v: f64| {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(invalid(self, name, v, "in [0, 1]"))
            }
        };
        let non_negative = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(invalid(self, name, v, "finite and ≥ 0"))
            }
        };
        match self {
            Fault::ImuLoss { fraction } => share("fraction", *fraction),
            Fault::ImuBurstLoss {
                fraction,
                mean_burst_s,
            } => {
                share("fraction", *fraction)?;
                if mean_burst_s.is_finite() && *mean_burst_s > 0.0 {
                    Ok(())
                } else {
                    Err(invalid(
                        self,
                        "mean_burst_s",
                        *mean_burst_s,
                        "finite and > 0",
                    ))
                }
            }
            Fault::CameraDark {
                start_s,
                duration_s,
                ..
            } => {
                if !start_s.is_finite() {
                    return Err(invalid(self, "start_s", *start_s, "finite"));
                }
                non_negative("duration_s", *duration_s)
            }
            Fault::ClockOffset { offset_s } => non_negative("offset_s", *offset_s),
            Fault::ClockDrift { drift_ppm } => non_negative("drift_ppm", *drift_ppm),
            Fault::ClockJump { jump_s } => non_negative("jump_s", *jump_s),
            Fault::UwbOutliers { size_m, share: p } => {
                non_negative("size_m", *size_m)?;
                share("share", *p)
            }
            Fault::Duplicates { share: p } => share("share", *p),
            Fault::Late { share: p, delay_s } => {
                share("share", *p)?;
                non_negative("delay_s", *delay_s)
            }
        }
    }
}

fn invalid(fault: &Fault, field: &str, value: f64, range: &str) -> SimError {
    SimError::InvalidFault(format!(
        "{}.{field} must be {range}, got {value}",
        fault.name()
    ))
}

/// What [`inject`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct FaultCounts {
    /// Sensor messages dropped.
    pub num_dropped: usize,
    /// Sensor messages whose time or content changed.
    pub num_altered: usize,
    /// Copies added.
    pub num_duplicated: usize,
    /// Messages delivered late.
    pub num_delayed: usize,
    /// Truth messages dropped with the messages they describe.
    pub num_truth_dropped: usize,
}

/// A scene's messages after a fault.
#[derive(Debug, Clone)]
pub struct FaultedMessages {
    /// Sensor messages in delivery order.
    pub recording: Vec<Message>,
    /// The ground truth of what was delivered.
    pub truth: Vec<Message>,
    /// What changed.
    pub counts: FaultCounts,
}

/// Applies `fault` to `recording` (sensor messages in delivery order) and its `truth`, drawing
/// from streams of `seed`. Messages the fault does not touch keep their order; a late message
/// moves to where its time plus the delay falls.
///
/// # Errors
/// [`SimError::InvalidFault`] if a level is out of its range ([`Fault::validate`]).
pub fn inject(
    fault: &Fault,
    recording: &[Message],
    truth: &[Message],
    seed: u64,
) -> Result<FaultedMessages> {
    fault.validate()?;
    let mut counts = FaultCounts::default();
    let mut streams = Streams::new(seed, fault.name());
    // Each output message with its delivery instant (ns) and input position (the tie-break).
    let mut out: Vec<(i64, usize, Message)> = Vec::with_capacity(recording.len());
    let mut truth_out = truth.to_vec();
    match fault {
        Fault::ImuLoss { fraction } => {
            for (i, m) in recording.iter().enumerate() {
                if let Message::Imu(s) = m
                    && streams.get(s.device.as_str()).random_bool(*fraction)
                {
                    counts.num_dropped += 1;
                    continue;
                }
                out.push((m.t().as_ns(), i, m.clone()));
            }
        }
        Fault::ImuBurstLoss {
            fraction,
            mean_burst_s,
        } => {
            let mut bursts: BTreeMap<&str, Bursts> = BTreeMap::new();
            for (i, m) in recording.iter().enumerate() {
                if let Message::Imu(s) = m {
                    let device = s.device.as_str();
                    let t_s = s.t.as_secs_f64();
                    let b = bursts.entry(device).or_insert_with(|| {
                        Bursts::new(*fraction, *mean_burst_s, t_s, streams.get(device))
                    });
                    if b.is_lossy_at(t_s, streams.get(device)) {
                        counts.num_dropped += 1;
                        continue;
                    }
                }
                out.push((m.t().as_ns(), i, m.clone()));
            }
        }
        Fault::CameraDark {
            camera,
            start_s,
            duration_s,
        } => {
            let (start, end) = (secs_ns(*start_s), secs_ns(start_s + duration_s));
            let is_dark = |t: SessionTime| (start..end).contains(&t.as_ns());
            let renumber = |t: SessionTime, track: &mut TrackId| {
                if t.as_ns() >= end && *duration_s > 0.0 {
                    track.0 = track.0.saturating_add(TRACK_ID_OFFSET_AFTER_DARK);
                }
            };
            for (i, m) in recording.iter().enumerate() {
                let mut m = m.clone();
                if let Message::Skeleton(s) = &mut m
                    && s.camera.as_str() == camera
                {
                    if is_dark(s.t) {
                        counts.num_dropped += 1;
                        continue;
                    }
                    if s.t.as_ns() >= end && *duration_s > 0.0 {
                        counts.num_altered += 1;
                    }
                    renumber(s.t, &mut s.track);
                }
                out.push((m.t().as_ns(), i, m));
            }
            let before = truth_out.len();
            truth_out.retain(|m| match m {
                Message::TruthSkeleton(s) => s.camera.as_str() != camera || !is_dark(s.t),
                _ => true,
            });
            counts.num_truth_dropped = before - truth_out.len();
            for m in &mut truth_out {
                if let Message::TruthSkeleton(s) = m
                    && s.camera.as_str() == camera
                {
                    renumber(s.t, &mut s.track);
                }
            }
        }
        Fault::ClockOffset { offset_s } => {
            let mut shifts: BTreeMap<&str, i64> = BTreeMap::new();
            for (i, m) in recording.iter().enumerate() {
                let mut m = m.clone();
                if let Message::Imu(s) = &mut m {
                    let device = recording_device(recording, i);
                    let shift = *shifts
                        .entry(device)
                        .or_insert_with(|| signed(streams.get(device)) * secs_ns(*offset_s));
                    s.t = SessionTime(s.t.as_ns().saturating_add(shift));
                    counts.num_altered += usize::from(shift != 0);
                }
                out.push((recording[i].t().as_ns(), i, m));
            }
        }
        Fault::ClockDrift { drift_ppm } => {
            let mut rates: BTreeMap<&str, f64> = BTreeMap::new();
            for (i, m) in recording.iter().enumerate() {
                let mut m = m.clone();
                if let Message::Imu(s) = &mut m {
                    let device = recording_device(recording, i);
                    let rate = *rates
                        .entry(device)
                        .or_insert_with(|| signed(streams.get(device)) as f64 * drift_ppm * 1e-6);
                    let shift = secs_ns(rate * s.t.as_secs_f64());
                    s.t = SessionTime(s.t.as_ns().saturating_add(shift));
                    counts.num_altered += usize::from(shift != 0);
                }
                out.push((recording[i].t().as_ns(), i, m));
            }
        }
        Fault::ClockJump { jump_s } => {
            // Each IMU's span of stamps, to place its jump in the middle half.
            let mut spans: BTreeMap<&str, (i64, i64)> = BTreeMap::new();
            for m in recording {
                if let Message::Imu(s) = m {
                    let t = s.t.as_ns();
                    let span = spans.entry(s.device.as_str()).or_insert((t, t));
                    *span = (span.0.min(t), span.1.max(t));
                }
            }
            let jumps: BTreeMap<&str, (i64, i64)> = spans
                .into_iter()
                .map(|(device, (first, last))| {
                    let rng = streams.get(device);
                    let quarter = (last - first) / 4;
                    let at = first + quarter + rng.random_range(0..=2 * quarter.max(0));
                    (device, (at, signed(rng) * secs_ns(*jump_s)))
                })
                .collect();
            for (i, m) in recording.iter().enumerate() {
                let mut m = m.clone();
                if let Message::Imu(s) = &mut m
                    && let Some((at, jump)) = jumps.get(s.device.as_str())
                    && s.t.as_ns() >= *at
                {
                    s.t = SessionTime(s.t.as_ns().saturating_add(*jump));
                    counts.num_altered += usize::from(*jump != 0);
                }
                out.push((recording[i].t().as_ns(), i, m));
            }
        }
        Fault::UwbOutliers { size_m, share } => {
            for (i, original) in recording.iter().enumerate() {
                let mut m = original.clone();
                let source = source_of(original).unwrap_or("");
                match &mut m {
                    Message::RtlsFix(f) => {
                        let rng = streams.get(source);
                        if rng.random_bool(*share) {
                            let heading_rad = rng.random_range(0.0..std::f64::consts::TAU);
                            f.position_m.x += size_m * heading_rad.cos();
                            f.position_m.y += size_m * heading_rad.sin();
                            counts.num_altered += 1;
                        }
                    }
                    Message::UwbRange(r) if streams.get(source).random_bool(*share) => {
                        r.range_m += size_m;
                        counts.num_altered += 1;
                    }
                    _ => {}
                }
                out.push((m.t().as_ns(), i, m));
            }
        }
        Fault::Duplicates { share } => {
            for (i, m) in recording.iter().enumerate() {
                out.push((m.t().as_ns(), i, m.clone()));
                if let Some(source) = source_of(m)
                    && streams.get(source).random_bool(*share)
                {
                    out.push((m.t().as_ns(), i, m.clone()));
                    counts.num_duplicated += 1;
                }
            }
        }
        Fault::Late { share, delay_s } => {
            let delay = secs_ns(*delay_s);
            for (i, m) in recording.iter().enumerate() {
                let mut at = m.t().as_ns();
                if let Some(source) = source_of(m)
                    && streams.get(source).random_bool(*share)
                {
                    at = at.saturating_add(delay);
                    counts.num_delayed += 1;
                }
                out.push((at, i, m.clone()));
            }
        }
    }
    out.sort_by_key(|(at, i, _)| (*at, *i));
    Ok(FaultedMessages {
        recording: out.into_iter().map(|(_, _, m)| m).collect(),
        truth: truth_out,
        counts,
    })
}

/// The device of the IMU sample at `recording[i]` ("" for anything else), borrowed from the
/// input so that per-device maps can outlive the clones.
fn recording_device(recording: &[Message], i: usize) -> &str {
    match recording.get(i) {
        Some(Message::Imu(s)) => s.device.as_str(),
        _ => "",
    }
}

/// The id of a sensor message's source (camera, device, tag); `None` for outputs and truth.
fn source_of(m: &Message) -> Option<&str> {
    match m {
        Message::Skeleton(s) => Some(s.camera.as_str()),
        Message::Imu(s) => Some(s.device.as_str()),
        Message::RtlsFix(f) => Some(f.tag.as_str()),
        Message::UwbRange(r) => Some(r.tag.as_str()),
        Message::Rssi(r) => Some(r.tag.as_str()),
        Message::Identified(_)
        | Message::TagCorrection(_)
        | Message::TruthSkeleton(_)
        | Message::TruthTag(_) => None,
    }
}

/// Seconds to nanoseconds, saturating.
fn secs_ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

/// +1 or −1, a fair coin.
fn signed(rng: &mut SimRng) -> i64 {
    if rng.random_bool(0.5) { 1 } else { -1 }
}

/// One random stream per source, named `faults/<fault>/<source>`; sources are borrowed from the
/// input messages, so looking one up allocates nothing.
struct Streams<'a> {
    seed: u64,
    fault: &'static str,
    by_source: BTreeMap<&'a str, SimRng>,
}

impl<'a> Streams<'a> {
    fn new(seed: u64, fault: &'static str) -> Self {
        Self {
            seed,
            fault,
            by_source: BTreeMap::new(),
        }
    }

    fn get(&mut self, source: &'a str) -> &mut SimRng {
        let (seed, fault) = (self.seed, self.fault);
        self.by_source
            .entry(source)
            .or_insert_with(|| stream(seed, &format!("faults/{fault}/{source}")))
    }
}

/// Alternating clean and lossy periods of one device (a two-state Gilbert–Elliott channel in
/// continuous time).
struct Bursts {
    is_lossy: bool,
    /// Session time the current period ends, s.
    end_s: f64,
    lossy: Option<Exp<f64>>,
    clean: Option<Exp<f64>>,
}

impl Bursts {
    fn new(fraction: f64, mean_burst_s: f64, t_s: f64, rng: &mut SimRng) -> Self {
        let mean_clean_s = mean_burst_s * (1.0 - fraction) / fraction.max(f64::MIN_POSITIVE);
        let mut b = Self {
            // The stationary state: lossy with probability `fraction`.
            is_lossy: rng.random_bool(fraction),
            end_s: t_s,
            lossy: Exp::new(1.0 / mean_burst_s).ok(),
            clean: Exp::new(1.0 / mean_clean_s).ok(),
        };
        b.end_s = t_s + b.draw_length_s(rng);
        b
    }

    /// The length of a period in the current state, s (infinite when the other state never
    /// comes: no loss, or nothing but loss).
    fn draw_length_s(&self, rng: &mut SimRng) -> f64 {
        let exp = if self.is_lossy {
            &self.lossy
        } else {
            &self.clean
        };
        match exp {
            Some(e) if self.is_lossy && self.clean.is_some() => e.sample(rng),
            Some(e) if !self.is_lossy && self.lossy.is_some() => e.sample(rng),
            _ => f64::INFINITY,
        }
    }

    fn is_lossy_at(&mut self, t_s: f64, rng: &mut SimRng) -> bool {
        // Bounded: a period is at least a few ns long on average, and the loop ends once a
        // period passes `t_s` (an infinite one at once).
        while self.end_s <= t_s {
            self.is_lossy = !self.is_lossy;
            self.end_s += self.draw_length_s(rng);
        }
        self.is_lossy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};
    use nomen_core::sensor::{ImuSample, RtlsFix, UwbRange};
    use nomen_core::skeleton::{Joints, SkeletonObservation};
    use nomen_core::{AnchorId, CameraId, DeviceId, TagId, TruthSkeleton};

    const SEEDS: [u64; 8] = [0, 1, 2, 3, 42, 1000, 123_456_789, u64::MAX];

    fn t(s: f64) -> SessionTime {
        SessionTime(secs_ns(s))
    }

    fn imu(device: &str, t_s: f64) -> Message {
        Message::Imu(ImuSample {
            t: t(t_s),
            device: DeviceId::new(device),
            accel_mps2: Vector3::new(0.0, 0.0, 9.81),
            gyro_radps: Some(Vector3::zeros()),
            mag_ut: None,
            orientation_wxyz: None,
        })
    }

    fn skeleton(camera: &str, track: u64, t_s: f64) -> Message {
        Message::from(SkeletonObservation {
            t: t(t_s),
            camera: CameraId::new(camera),
            track: TrackId(track),
            joints: Joints::default(),
        })
    }

    fn truth_skeleton(camera: &str, track: u64, t_s: f64) -> Message {
        Message::from(TruthSkeleton {
            t: t(t_s),
            camera: CameraId::new(camera),
            track: TrackId(track),
            person: format!("p{track}"),
            subject: None,
            joints_world_m: Joints::default(),
        })
    }

    /// Two IMUs at 100 Hz, two cameras at 30 Hz with two tracks, a tag's fixes at 10 Hz and its
    /// ranges to one anchor, for `duration_s`, sorted by time.
    fn scene(duration_s: f64) -> (Vec<Message>, Vec<Message>) {
        let mut rec = Vec::new();
        let mut truth = Vec::new();
        let n = (duration_s * 100.0) as usize;
        for k in 0..n {
            let ts = k as f64 / 100.0;
            rec.push(imu("imu_a", ts));
            rec.push(imu("imu_b", ts + 0.003));
            if k % 10 == 0 {
                rec.push(Message::RtlsFix(RtlsFix {
                    t: t(ts),
                    tag: TagId::new("tag"),
                    position_m: Point3::new(1.0, 2.0, 1.0),
                    quality: None,
                    covariance_m2: None,
                }));
                rec.push(Message::UwbRange(UwbRange {
                    t: t(ts),
                    tag: TagId::new("tag"),
                    anchor: AnchorId::new("a0"),
                    range_m: 3.0,
                }));
            }
        }
        for k in 0..(duration_s * 30.0) as usize {
            let ts = k as f64 / 30.0;
            for cam in ["cam_a", "cam_b"] {
                for track in [1, 2] {
                    rec.push(skeleton(cam, track, ts));
                    truth.push(truth_skeleton(cam, track, ts));
                }
            }
        }
        rec.sort_by_key(|m| m.t());
        (rec, truth)
    }

    fn imu_times(messages: &[Message], device: &str) -> Vec<i64> {
        messages
            .iter()
            .filter_map(|m| match m {
                Message::Imu(s) if s.device.as_str() == device => Some(s.t.as_ns()),
                _ => None,
            })
            .collect()
    }

    fn count(messages: &[Message], pred: impl Fn(&Message) -> bool) -> usize {
        messages.iter().filter(|m| pred(m)).count()
    }

    fn is_imu(m: &Message) -> bool {
        matches!(m, Message::Imu(_))
    }

    #[test]
    fn no_fault_level_changes_nothing() {
        let (rec, truth) = scene(5.0);
        let faults = [
            Fault::ImuLoss { fraction: 0.0 },
            Fault::ImuBurstLoss {
                fraction: 0.0,
                mean_burst_s: 1.0,
            },
            Fault::CameraDark {
                camera: "cam_a".into(),
                start_s: 1.0,
                duration_s: 0.0,
            },
            Fault::ClockOffset { offset_s: 0.0 },
            Fault::ClockDrift { drift_ppm: 0.0 },
            Fault::ClockJump { jump_s: 0.0 },
            Fault::UwbOutliers {
                size_m: 5.0,
                share: 0.0,
            },
            Fault::Duplicates { share: 0.0 },
            Fault::Late {
                share: 1.0,
                delay_s: 0.0,
            },
        ];
        for fault in &faults {
            for seed in SEEDS {
                let out = inject(fault, &rec, &truth, seed).expect("valid fault");
                assert_eq!(out.recording, rec, "{fault:?}");
                assert_eq!(out.truth, truth, "{fault:?}");
            }
        }
    }

    #[test]
    fn random_imu_loss_drops_the_fraction_of_samples_and_nothing_else() {
        let (rec, truth) = scene(60.0);
        let num_imu = count(&rec, is_imu);
        for fraction in [0.2, 0.5, 0.8] {
            for seed in SEEDS {
                let out = inject(&Fault::ImuLoss { fraction }, &rec, &truth, seed).expect("valid");
                let kept = count(&out.recording, is_imu);
                let lost = 1.0 - kept as f64 / num_imu as f64;
                // 12 000 samples: the binomial standard deviation is below 0.005.
                assert!((lost - fraction).abs() < 0.03, "{fraction}: lost {lost}");
                assert_eq!(out.counts.num_dropped, num_imu - kept);
                assert_eq!(out.recording.len(), rec.len() - out.counts.num_dropped);
                assert_eq!(out.truth, truth);
            }
        }
    }

    /// Mean length of the runs of consecutive lost samples of `device` (100 Hz in [`scene`]).
    fn mean_gap_run(out: &[Message], device: &str) -> f64 {
        let times = imu_times(out, device);
        let gaps: Vec<i64> = times
            .windows(2)
            .map(|w| (w[1] - w[0]) / 10_000_000 - 1)
            .filter(|g| *g > 0)
            .collect();
        gaps.iter().sum::<i64>() as f64 / gaps.len().max(1) as f64
    }

    #[test]
    fn bursty_imu_loss_drops_the_fraction_in_long_runs() {
        let (rec, truth) = scene(600.0);
        let num_imu = count(&rec, is_imu);
        for fraction in [0.2, 0.5, 0.8] {
            for seed in SEEDS {
                let fault = Fault::ImuBurstLoss {
                    fraction,
                    mean_burst_s: 1.0,
                };
                let out = inject(&fault, &rec, &truth, seed).expect("valid");
                let lost = 1.0 - count(&out.recording, is_imu) as f64 / num_imu as f64;
                // Hundreds of bursts per device over 600 s: the share is within a few points.
                assert!((lost - fraction).abs() < 0.1, "{fraction}: lost {lost}");
                // Bursts of 1 s at 100 Hz: runs of about 100 samples (random loss: about 1).
                let run = mean_gap_run(&out.recording, "imu_a");
                assert!(run > 30.0, "{fraction}: mean run {run} samples");
                let random =
                    inject(&Fault::ImuLoss { fraction }, &rec, &truth, seed).expect("valid");
                assert!(mean_gap_run(&random.recording, "imu_a") < 10.0);
            }
        }
    }

    #[test]
    fn a_dark_camera_sends_nothing_then_new_tracks_and_its_truth_follows() {
        let (rec, truth) = scene(20.0);
        let fault = Fault::CameraDark {
            camera: "cam_a".into(),
            start_s: 5.0,
            duration_s: 10.0,
        };
        for seed in SEEDS {
            let out = inject(&fault, &rec, &truth, seed).expect("valid");
            for (messages, what) in [(&out.recording, "recording"), (&out.truth, "truth")] {
                let cam_a: Vec<(i64, u64)> = messages
                    .iter()
                    .filter_map(|m| match m {
                        Message::Skeleton(s) if s.camera.as_str() == "cam_a" => {
                            Some((s.t.as_ns(), s.track.0))
                        }
                        Message::TruthSkeleton(s) if s.camera.as_str() == "cam_a" => {
                            Some((s.t.as_ns(), s.track.0))
                        }
                        _ => None,
                    })
                    .collect();
                assert!(!cam_a.is_empty());
                for (t_ns, track) in cam_a {
                    assert!(!(secs_ns(5.0)..secs_ns(15.0)).contains(&t_ns), "{what}");
                    // After the dark span, no track id of before comes back.
                    assert_eq!(t_ns >= secs_ns(15.0), track >= TRACK_ID_OFFSET_AFTER_DARK);
                }
            }
            // The other camera and the wearables are untouched: 10 s of 30 Hz, two tracks gone.
            assert_eq!(out.counts.num_dropped, 300 * 2);
            assert_eq!(out.counts.num_truth_dropped, 300 * 2);
            let cam_b =
                |m: &Message| matches!(m, Message::Skeleton(s) if s.camera.as_str() == "cam_b");
            assert_eq!(count(&out.recording, cam_b), count(&rec, cam_b));
            assert_eq!(count(&out.recording, is_imu), count(&rec, is_imu));
        }
    }

    #[test]
    fn a_clock_offset_moves_every_stamp_of_a_device_by_the_offset_and_keeps_the_order() {
        let (rec, truth) = scene(10.0);
        let mut signs = Vec::new();
        for seed in SEEDS {
            let out =
                inject(&Fault::ClockOffset { offset_s: 1.0 }, &rec, &truth, seed).expect("valid");
            for device in ["imu_a", "imu_b"] {
                let before = imu_times(&rec, device);
                let after = imu_times(&out.recording, device);
                assert_eq!(before.len(), after.len());
                let shift = after[0] - before[0];
                assert_eq!(shift.abs(), 1_000_000_000);
                assert!(before.iter().zip(&after).all(|(b, a)| a - b == shift));
                signs.push(shift > 0);
            }
            // Delivery order stays the true one: the message list is in its old order.
            let kinds: Vec<&str> = out.recording.iter().map(Message::type_name).collect();
            let old: Vec<&str> = rec.iter().map(Message::type_name).collect();
            assert_eq!(kinds, old);
        }
        // Both directions occur over the seeds and devices.
        assert!(signs.iter().any(|s| *s) && signs.iter().any(|s| !*s));
    }

    #[test]
    fn a_drifting_clock_moves_stamps_in_proportion_to_time() {
        let (rec, truth) = scene(60.0);
        for seed in SEEDS {
            let out =
                inject(&Fault::ClockDrift { drift_ppm: 200.0 }, &rec, &truth, seed).expect("valid");
            let before = imu_times(&rec, "imu_a");
            let after = imu_times(&out.recording, "imu_a");
            for (b, a) in before.iter().zip(&after) {
                let expected = 200e-6 * *b as f64;
                assert!(((a - b).abs() as f64 - expected).abs() <= 1.0);
            }
        }
    }

    #[test]
    fn a_clock_jump_moves_the_stamps_after_one_instant_in_the_middle_half() {
        let (rec, truth) = scene(40.0);
        for seed in SEEDS {
            let out = inject(&Fault::ClockJump { jump_s: 0.5 }, &rec, &truth, seed).expect("valid");
            let before = imu_times(&rec, "imu_b");
            let after = imu_times(&out.recording, "imu_b");
            let moved: Vec<bool> = before.iter().zip(&after).map(|(b, a)| a != b).collect();
            let first = moved.iter().position(|m| *m).expect("the clock jumps");
            assert!(moved[first..].iter().all(|m| *m), "the jump stays");
            let n = before.len();
            assert!(
                first >= n / 4 - 1 && first <= 3 * n / 4 + 1,
                "at {first} of {n}"
            );
            assert_eq!((after[first] - before[first]).abs(), 500_000_000);
        }
    }

    #[test]
    fn uwb_outliers_are_the_given_size_and_share() {
        let (rec, truth) = scene(600.0);
        for seed in SEEDS {
            let fault = Fault::UwbOutliers {
                size_m: 10.0,
                share: 0.2,
            };
            let out = inject(&fault, &rec, &truth, seed).expect("valid");
            let (mut num_fixes, mut num_off) = (0, 0);
            for (a, b) in rec.iter().zip(&out.recording) {
                match (a, b) {
                    (Message::RtlsFix(a), Message::RtlsFix(b)) => {
                        num_fixes += 1;
                        let d = (b.position_m - a.position_m).norm();
                        assert!(d < 1e-9 || (d - 10.0).abs() < 1e-9);
                        assert_eq!(a.position_m.z, b.position_m.z);
                        num_off += usize::from(d > 1.0);
                    }
                    (Message::UwbRange(a), Message::UwbRange(b)) => {
                        let d = b.range_m - a.range_m;
                        assert!(d.abs() < 1e-9 || (d - 10.0).abs() < 1e-9);
                    }
                    (a, b) => assert_eq!(a, b),
                }
            }
            let share = num_off as f64 / num_fixes as f64;
            assert!((share - 0.2).abs() < 0.04, "share {share}");
        }
    }

    #[test]
    fn duplicates_follow_their_original() {
        let (rec, truth) = scene(30.0);
        for seed in SEEDS {
            let out = inject(&Fault::Duplicates { share: 0.3 }, &rec, &truth, seed).expect("valid");
            let share = out.counts.num_duplicated as f64 / rec.len() as f64;
            assert!((share - 0.3).abs() < 0.03, "share {share}");
            assert_eq!(out.recording.len(), rec.len() + out.counts.num_duplicated);
            // Removing each message equal to the one before gives the input back.
            let mut deduped = out.recording.clone();
            deduped.dedup();
            let mut input = rec.clone();
            input.dedup();
            assert_eq!(deduped, input);
        }
    }

    #[test]
    fn late_messages_arrive_after_the_messages_of_their_time_plus_the_delay() {
        let (rec, truth) = scene(30.0);
        for seed in SEEDS {
            let fault = Fault::Late {
                share: 0.1,
                delay_s: 2.0,
            };
            let out = inject(&fault, &rec, &truth, seed).expect("valid");
            assert_eq!(out.recording.len(), rec.len());
            let share = out.counts.num_delayed as f64 / rec.len() as f64;
            assert!((share - 0.1).abs() < 0.02, "share {share}");
            // A message is late when some earlier-delivered message is newer by more than 1.9 s;
            // every late one is, and its stamp is unchanged.
            let mut newest = i64::MIN;
            let mut num_late = 0;
            for m in &out.recording {
                let t = m.t().as_ns();
                if newest - t > 1_900_000_000 {
                    num_late += 1;
                }
                newest = newest.max(t);
            }
            // Late messages of the last two seconds have nothing newer to follow.
            assert!(num_late <= out.counts.num_delayed);
            assert!(num_late as f64 >= 0.9 * out.counts.num_delayed as f64);
            let mut sorted_out = out.recording.clone();
            sorted_out.sort_by_key(|m| m.t());
            assert_eq!(count(&sorted_out, is_imu), count(&rec, is_imu));
        }
    }

    #[test]
    fn levels_out_of_range_are_refused_by_name() {
        let (rec, truth) = scene(1.0);
        for (fault, field) in [
            (Fault::ImuLoss { fraction: 1.5 }, "imu_loss.fraction"),
            (
                Fault::ImuBurstLoss {
                    fraction: 0.5,
                    mean_burst_s: 0.0,
                },
                "imu_burst_loss.mean_burst_s",
            ),
            (
                Fault::ClockOffset { offset_s: f64::NAN },
                "clock_offset.offset_s",
            ),
            (
                Fault::Late {
                    share: 0.5,
                    delay_s: -1.0,
                },
                "late.delay_s",
            ),
        ] {
            let err = inject(&fault, &rec, &truth, 1).expect_err("refused");
            assert!(err.to_string().contains(field), "{err}");
        }
    }
}
