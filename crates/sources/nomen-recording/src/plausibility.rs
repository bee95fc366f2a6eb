//! Plausibility of a stream's time stamps and units, beyond what each message checks alone: a
//! camera whose frames come ten times faster or slower than the rate it declares, an IMU above
//! 10 kHz or below 5 Hz (every `t` in milliseconds instead of nanoseconds looks like both), and
//! accelerations whose magnitude is 1 where gravity alone gives 9.81 m/s² (a column in g).
//!
//! [`Plausibility`] is sans-IO: push messages in file order; it judges each source once it has
//! seen [`NUM_INTERVALS`] intervals (or, at [`Plausibility::finish`], at least
//! [`MIN_INTERVALS`]) from the median, which gaps and dropped frames do not move. Each
//! [`Finding`] says what was probably meant (`the times are probably in milliseconds`).

use nomen_core::{Message, Registry};
use std::collections::BTreeMap;
use std::fmt;

/// Intervals (and IMU samples) a source is judged on: its first 64.
pub const NUM_INTERVALS: usize = 64;
/// The fewest intervals a source is judged on at the end of a stream.
pub const MIN_INTERVALS: usize = 8;
/// A camera rate off the declared one by this factor or more is implausible: 10.
pub const MAX_RATE_FACTOR: f64 = 10.0;
/// The fastest plausible skeleton stream of a camera that declares no rate, Hz: 1 kHz.
pub const MAX_CAMERA_HZ: f64 = 1_000.0;
/// The plausible IMU rates, Hz: 5 Hz to 10 kHz (wearable IMUs stream 10 Hz to 2 kHz; below
/// 5 Hz the samples cannot follow the steps of a walk, about two a second).
pub const IMU_RATE_RANGE_HZ: (f64, f64) = (5.0, 10_000.0);
/// The plausible median magnitude of an IMU's accelerations, m/s²: 3 to 30. Gravity alone is
/// 9.81; walking, running and jumping move the median by a few m/s². A median of 1 is gravity
/// in g, of 1000 gravity in milli-g.
pub const ACCEL_MEDIAN_RANGE_MPS2: (f64, f64) = (3.0, 30.0);

/// What is implausible about one source.
#[derive(Debug, Clone, PartialEq)]
pub enum Finding {
    /// A camera or an IMU whose time stamps give an implausible rate.
    Rate {
        /// `camera` or `imu`.
        kind: &'static str,
        /// The camera or the device.
        source: String,
        /// The rate the time stamps give, Hz (from the median interval).
        observed_hz: f64,
        /// The median interval, ns.
        median_interval_ns: f64,
        /// Intervals the median is of.
        num_intervals: usize,
        /// The rate the registry declares (cameras), Hz.
        declared_hz: Option<f64>,
        /// What the time stamps should be multiplied by to give a plausible rate: 1e6 when
        /// they are milliseconds where nanoseconds were meant; `None` when no power of a
        /// thousand does.
        factor: Option<f64>,
    },
    /// An IMU whose accelerations' median magnitude is not gravity's.
    Gravity {
        /// The device.
        source: String,
        /// Median acceleration magnitude, m/s².
        median_mps2: f64,
        /// Samples the median is of.
        num_samples: usize,
        /// The unit the values are probably in (`g`, `milli-g`), when one explains them.
        probable_unit: Option<&'static str>,
    },
}

impl Finding {
    /// The source (camera or device) the finding is about.
    pub fn source(&self) -> &str {
        match self {
            Finding::Rate { source, .. } | Finding::Gravity { source, .. } => source,
        }
    }
}

/// The unit a time in nanoseconds multiplied by `factor` was written in: `milliseconds` for
/// 1e6.
pub fn time_unit_of_factor(factor: f64) -> &'static str {
    match factor {
        f if f < 1e-1 => "picoseconds",
        f if f < 1e2 => "nanoseconds",
        f if f < 1e5 => "microseconds",
        f if f < 1e8 => "milliseconds",
        _ => "seconds",
    }
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Finding::Rate {
                kind,
                source,
                observed_hz,
                median_interval_ns,
                num_intervals,
                declared_hz,
                factor,
            } => {
                match declared_hz {
                    Some(d) => write!(f, "{kind} '{source}' declares {d} Hz, but its time stamps")?,
                    None => write!(f, "{kind} '{source}': its time stamps")?,
                }
                write!(
                    f,
                    " give {} Hz (every {} ns, the median of {num_intervals} intervals)",
                    sig(*observed_hz),
                    sig(*median_interval_ns)
                )?;
                match factor {
                    Some(k) => write!(
                        f,
                        ": the times are probably in {}, where a recording's t is in nanoseconds \
                         (multiply them by {})",
                        time_unit_of_factor(*k),
                        sig(*k)
                    ),
                    None if *kind == "imu" && *observed_hz < IMU_RATE_RANGE_HZ.0 => write!(
                        f,
                        ": an IMU slower than {} Hz cannot follow the steps of a walk; the \
                         times are probably wrong (a recording's t is in nanoseconds), or the \
                         device sends summaries rather than samples",
                        sig(IMU_RATE_RANGE_HZ.0)
                    ),
                    None => write!(
                        f,
                        ": the times or the declared rate are wrong (a recording's t is in \
                         nanoseconds)"
                    ),
                }
            }
            Finding::Gravity {
                source,
                median_mps2,
                num_samples,
                probable_unit,
            } => {
                write!(
                    f,
                    "imu '{source}': its accelerations' median magnitude is {} m/s² over {num_samples} \
                     samples, where gravity alone gives 9.81",
                    sig(*median_mps2)
                )?;
                match probable_unit {
                    Some(unit) => write!(f, ": they are probably in {unit}; accel_mps2 is in m/s²"),
                    None => write!(f, ": accel_mps2 is in m/s²"),
                }
            }
        }
    }
}

/// A number with four significant digits at most, without an exponent for everyday sizes.
fn sig(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e7 || x.abs() < 1e-3) {
        format!("{x:.3e}")
    } else {
        let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{x:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    }
}

/// The first intervals of one source.
#[derive(Debug, Default)]
struct Track {
    last_t: Option<i64>,
    intervals: Vec<i64>,
    is_judged: bool,
}

impl Track {
    /// Adds time `t`; true when the track has its [`NUM_INTERVALS`].
    fn push(&mut self, t: i64) -> bool {
        if self.is_judged {
            return false;
        }
        match self.last_t {
            // Several tracks of one frame share its time; a message out of order is not an
            // interval.
            Some(last) if t <= last => {}
            Some(last) => {
                self.intervals.push(t - last);
                self.last_t = Some(t);
            }
            None => self.last_t = Some(t),
        }
        self.intervals.len() >= NUM_INTERVALS
    }
}

/// The first accelerations of one IMU.
#[derive(Debug, Default)]
struct Accel {
    magnitudes: Vec<f64>,
    is_judged: bool,
}

/// Judges the rates of cameras and IMUs and the units of IMU accelerations of a stream.
#[derive(Debug, Default)]
pub struct Plausibility {
    declared_hz: BTreeMap<String, f64>,
    /// Camera → the first intervals of its frames.
    cameras: BTreeMap<String, Track>,
    /// IMU → the first intervals of its samples.
    imus: BTreeMap<String, Track>,
    /// IMU → the magnitudes of its first accelerations.
    accels: BTreeMap<String, Accel>,
}

impl Plausibility {
    /// A check against the cameras' declared rates of `registry` (none: only absolute bounds).
    pub fn new(registry: Option<&Registry>) -> Self {
        let declared_hz = registry
            .map(|r| {
                r.cameras
                    .iter()
                    .filter_map(|c| {
                        let hz = c.fps_hz.filter(|hz| hz.is_finite() && *hz > 0.0)?;
                        Some((c.id.as_str().to_owned(), hz))
                    })
                    .collect()
            })
            .unwrap_or_default();
        Self {
            declared_hz,
            ..Self::default()
        }
    }

    /// Takes one message; returns what it makes implausible, once per source and kind.
    pub fn push(&mut self, msg: &Message) -> Option<Finding> {
        let (kind, source) = match msg {
            Message::Skeleton(s) => ("camera", s.camera.as_str()),
            Message::Identified(s) => ("camera", s.camera.as_str()),
            Message::TruthSkeleton(s) => ("camera", s.camera.as_str()),
            Message::Imu(s) => {
                if let Some(accel) = entry(&mut self.accels, s.device.as_str())
                    && !accel.is_judged
                {
                    accel.magnitudes.push(s.accel_mps2.norm());
                    if accel.magnitudes.len() >= NUM_INTERVALS {
                        accel.is_judged = true;
                        if let Some(finding) = judge_accel(s.device.as_str(), &accel.magnitudes) {
                            return Some(finding);
                        }
                    }
                }
                ("imu", s.device.as_str())
            }
            _ => return None,
        };
        let tracks = if kind == "camera" {
            &mut self.cameras
        } else {
            &mut self.imus
        };
        let track = entry(tracks, source)?;
        if !track.push(msg.t().as_ns()) {
            return None;
        }
        track.is_judged = true;
        let declared = self.declared_hz.get(source).copied();
        judge_rate(kind, source, &track.intervals, declared)
    }

    /// Judges the sources not judged yet that have at least [`MIN_INTERVALS`] intervals (or
    /// samples): at the end of a stream.
    pub fn finish(&mut self) -> Vec<Finding> {
        let mut findings = Vec::new();
        for (kind, tracks) in [("camera", &mut self.cameras), ("imu", &mut self.imus)] {
            for (source, track) in tracks {
                if !track.is_judged && track.intervals.len() >= MIN_INTERVALS {
                    track.is_judged = true;
                    let declared = if kind == "camera" {
                        self.declared_hz.get(source.as_str()).copied()
                    } else {
                        None
                    };
                    findings.extend(judge_rate(kind, source, &track.intervals, declared));
                }
            }
        }
        for (source, accel) in &mut self.accels {
            if !accel.is_judged && accel.magnitudes.len() >= MIN_INTERVALS {
                accel.is_judged = true;
                findings.extend(judge_accel(source, &accel.magnitudes));
            }
        }
        findings
    }
}

/// The entry of `source`, made on its first message only (no allocation per message after).
fn entry<'a, T: Default>(map: &'a mut BTreeMap<String, T>, source: &str) -> Option<&'a mut T> {
    if !map.contains_key(source) {
        map.insert(source.to_owned(), T::default());
    }
    map.get_mut(source)
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The power of a thousand (1e-3 to 1e9) that brings `observed_hz` into `range_hz`, if one
/// does; for a camera, the range around its declared rate.
fn plausible_factor(observed_hz: f64, range_hz: (f64, f64)) -> Option<f64> {
    [1e3, 1e6, 1e9, 1e-3]
        .into_iter()
        .find(|k| (range_hz.0..=range_hz.1).contains(&(observed_hz / k)))
}

fn judge_rate(
    kind: &'static str,
    source: &str,
    intervals: &[i64],
    declared_hz: Option<f64>,
) -> Option<Finding> {
    let as_f64: Vec<f64> = intervals.iter().map(|&d| d as f64).collect();
    let median_interval_ns = median(&as_f64);
    let observed_hz = 1e9 / median_interval_ns;
    let (is_implausible, range_hz) = match (kind, declared_hz) {
        ("camera", Some(d)) => (
            observed_hz >= d * MAX_RATE_FACTOR || observed_hz <= d / MAX_RATE_FACTOR,
            (d / 2.0, d * 2.0),
        ),
        ("camera", None) => (observed_hz > MAX_CAMERA_HZ, (5.0, 240.0)),
        _ => (
            !(IMU_RATE_RANGE_HZ.0..=IMU_RATE_RANGE_HZ.1).contains(&observed_hz),
            (10.0, 2_000.0),
        ),
    };
    is_implausible.then(|| Finding::Rate {
        kind,
        source: source.to_owned(),
        observed_hz,
        median_interval_ns,
        num_intervals: intervals.len(),
        declared_hz,
        factor: plausible_factor(observed_hz, range_hz),
    })
}

fn judge_accel(source: &str, magnitudes: &[f64]) -> Option<Finding> {
    let median_mps2 = median(magnitudes);
    if (ACCEL_MEDIAN_RANGE_MPS2.0..=ACCEL_MEDIAN_RANGE_MPS2.1).contains(&median_mps2) {
        return None;
    }
    // A still or walking IMU's median is within a few m/s² of gravity; gravity removed gives a
    // median near 0, which no unit explains and which is not refused.
    let probable_unit = if (0.5..=2.0).contains(&median_mps2) {
        Some("g")
    } else if (500.0..=2000.0).contains(&median_mps2) {
        Some("milli-g")
    } else if median_mps2 < 0.3 {
        return None;
    } else {
        None
    };
    Some(Finding::Gravity {
        source: source.to_owned(),
        median_mps2,
        num_samples: magnitudes.len(),
        probable_unit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};
    use nomen_core::skeleton::Joints;
    use nomen_core::{
        Camera, CameraId, ClockModel, DeviceId, ImuSample, JointObservation, RigidTransform,
        SessionTime, SkeletonObservation, TrackId,
    };

    fn registry(fps_hz: Option<f64>) -> Registry {
        Registry {
            subjects: Vec::new(),
            cameras: vec![Camera {
                id: CameraId::new("kinect"),
                world_from_camera: RigidTransform::IDENTITY,
                scale: 1.0,
                intrinsics: None,
                fps_hz,
                clock: ClockModel::default(),
            }],
            anchors: Vec::new(),
            antennas: Vec::new(),
        }
    }

    fn skeleton(t_ns: i64, track: u64) -> Message {
        let mut joints = Joints::new();
        joints.insert(
            nomen_core::Joint::Head,
            JointObservation::tracked(Point3::new(0.0, 1.7, 2.5)),
        );
        Message::Skeleton(Box::new(SkeletonObservation {
            t: SessionTime(t_ns),
            camera: CameraId::new("kinect"),
            track: TrackId(track),
            joints,
        }))
    }

    fn imu(t_ns: i64, accel_z: f64) -> Message {
        Message::Imu(ImuSample {
            t: SessionTime(t_ns),
            device: DeviceId::new("band"),
            accel_mps2: Vector3::new(0.1, 0.0, accel_z),
            gyro_radps: Some(Vector3::zeros()),
            mag_ut: None,
            orientation_wxyz: None,
        })
    }

    /// Every finding of a 30-fps camera (two tracks a frame) and a 100-Hz IMU over 3 s, their
    /// times divided by `divisor`.
    fn findings(fps_hz: Option<f64>, divisor: i64, accel_z: f64) -> Vec<Finding> {
        let mut check = Plausibility::new(Some(&registry(fps_hz)));
        let mut out = Vec::new();
        for k in 0..300 {
            let t = k * 10_000_000;
            out.extend(check.push(&imu(t / divisor, accel_z)));
            if k % 3 == 0 {
                let t = k / 3 * 33_333_333;
                out.extend(check.push(&skeleton(t / divisor, 1)));
                out.extend(check.push(&skeleton(t / divisor, 2)));
            }
        }
        out.extend(check.finish());
        out
    }

    #[test]
    fn rates_as_declared_and_gravity_in_metres_per_second_squared_pass() {
        assert_eq!(findings(Some(30.0), 1, 9.81), vec![]);
        assert_eq!(findings(None, 1, 9.81), vec![]);
        // Gravity removed (linear acceleration) is no unit mistake.
        assert_eq!(findings(Some(30.0), 1, 0.05), vec![]);
    }

    #[test]
    fn times_in_milliseconds_are_named_as_such() {
        let found = findings(Some(30.0), 1_000_000, 9.81);
        assert_eq!(found.len(), 2, "{found:?}");
        let camera = found.iter().find(|f| f.source() == "kinect").unwrap();
        let Finding::Rate {
            observed_hz,
            factor,
            ..
        } = camera
        else {
            panic!("{camera:?}")
        };
        assert!((*observed_hz - 1e9 / 33.0).abs() < 1.0, "{observed_hz}");
        assert_eq!(*factor, Some(1e6));
        let text = camera.to_string();
        assert!(
            text.starts_with("camera 'kinect' declares 30 Hz, but its time stamps give"),
            "{text}"
        );
        assert!(
            text.contains(
                "the times are probably in milliseconds, where a recording's t is in \
                           nanoseconds (multiply them by 1000000)"
            ),
            "{text}"
        );
        let imu = found.iter().find(|f| f.source() == "band").unwrap();
        assert!(
            imu.to_string().starts_with(
                "imu 'band': its time stamps give 1.000e8 Hz (every 10 ns, the median of 64 \
                 intervals): the times are probably in milliseconds"
            ),
            "{imu}"
        );
    }

    #[test]
    fn a_camera_without_a_declared_rate_is_held_to_1_khz() {
        let found = findings(None, 1_000, 9.81);
        let camera = found.iter().find(|f| f.source() == "kinect").unwrap();
        assert!(
            camera
                .to_string()
                .contains("the times are probably in microseconds"),
            "{camera}"
        );
    }

    #[test]
    fn a_camera_ten_times_slower_than_declared_is_implausible_and_three_times_is_not() {
        assert_eq!(findings(Some(90.0), 1, 9.81), vec![]);
        let found = findings(Some(400.0), 1, 9.81);
        assert_eq!(found.len(), 1, "{found:?}");
        // No power of a thousand explains a factor of 10: the message says so.
        assert!(
            found[0].to_string().ends_with(
                "the times or the declared rate are wrong (a recording's t is in nanoseconds)"
            ),
            "{}",
            found[0]
        );
    }

    #[test]
    fn gravity_of_one_is_named_g_and_of_a_thousand_milli_g() {
        let found = findings(Some(30.0), 1, 1.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(
            found[0].to_string(),
            "imu 'band': its accelerations' median magnitude is 1.005 m/s² over 64 samples, \
             where gravity alone gives 9.81: they are probably in g; accel_mps2 is in m/s²"
        );
        let found = findings(Some(30.0), 1, 1000.0);
        assert!(
            found[0].to_string().contains("probably in milli-g"),
            "{}",
            found[0]
        );
    }

    /// The findings of one IMU sampled every `interval_ns` for 100 samples.
    fn imu_findings(interval_ns: i64) -> Vec<Finding> {
        let mut check = Plausibility::new(None);
        let mut out: Vec<Finding> = (0..100)
            .filter_map(|k| check.push(&imu(k * interval_ns, 9.81)))
            .collect();
        out.extend(check.finish());
        out
    }

    #[test]
    fn an_imu_below_5_hz_is_implausible_and_a_12_5_hz_watch_is_not() {
        assert_eq!(imu_findings(80_000_000), vec![]);
        assert_eq!(imu_findings(100_000_000), vec![]);
        let slow = imu_findings(250_000_000);
        assert_eq!(slow.len(), 1, "{slow:?}");
        let Finding::Rate {
            kind,
            observed_hz,
            factor,
            ..
        } = &slow[0]
        else {
            panic!("{slow:?}")
        };
        assert_eq!((*kind, *factor), ("imu", None));
        assert!((observed_hz - 4.0).abs() < 1e-9, "{observed_hz}");
        let text = slow[0].to_string();
        assert!(
            text.contains("an IMU slower than 5 Hz cannot follow the steps of a walk"),
            "{text}"
        );
        // A 100-Hz IMU stamped in picoseconds (times 1000 times too large) reads 0.1 Hz.
        let picoseconds = imu_findings(10_000_000_000);
        assert!(
            picoseconds[0]
                .to_string()
                .contains("probably in picoseconds"),
            "{picoseconds:?}"
        );
        // Above 10 kHz: a 100-Hz IMU stamped in microseconds reads 100 kHz.
        let microseconds = imu_findings(10_000);
        assert!(
            microseconds[0]
                .to_string()
                .contains("probably in microseconds"),
            "{microseconds:?}"
        );
    }

    #[test]
    fn a_short_stream_is_judged_at_its_end() {
        let mut check = Plausibility::new(None);
        for k in 0..10 {
            assert_eq!(check.push(&imu(k * 10, 9.81)), None);
        }
        let found = check.finish();
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].to_string().contains("median of 9 intervals"));
        // Too few to judge.
        let mut check = Plausibility::new(None);
        for k in 0..5 {
            check.push(&imu(k * 10, 9.81));
        }
        assert_eq!(check.finish(), vec![]);
    }
}
