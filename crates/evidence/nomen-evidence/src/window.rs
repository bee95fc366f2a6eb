//! The synchronised windows every evidence model reads.

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, DeviceId, TrackId};

/// One IMU over one window, resampled by the engine onto the window's grid `t_s`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImuWindow {
    /// The IMU.
    pub device: Option<DeviceId>,
    /// Grid times, session seconds, strictly increasing (the lowest rate in the window).
    pub t_s: Vec<f64>,
    /// Specific force in the sensor frame, m/s² (as measured: gravity included).
    pub accel_mps2: Vec<Vector3<f64>>,
    /// Angular rate in the sensor frame, rad/s.
    pub gyro_radps: Vec<Vector3<f64>>,
    /// Orientation estimate `world_from_sensor` (e.g. Madgwick), world Z up.
    pub world_from_sensor: Vec<UnitQuaternion<f64>>,
}

/// `v` from index `from` on, copied (empty past the end).
fn tail<T: Clone>(v: &[T], from: usize) -> Vec<T> {
    v.get(from..).unwrap_or(&[]).to_vec()
}

impl ImuWindow {
    /// The window from grid point `from` on (empty past the end).
    pub fn tail(&self, from: usize) -> ImuWindow {
        ImuWindow {
            device: self.device.clone(),
            t_s: tail(&self.t_s, from),
            accel_mps2: tail(&self.accel_mps2, from),
            gyro_radps: tail(&self.gyro_radps, from),
            world_from_sensor: tail(&self.world_from_sensor, from),
        }
    }
}

/// One camera track over one window, on the same grid as the [`ImuWindow`] it is compared with.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SkeletonWindow {
    /// The camera.
    pub camera: Option<CameraId>,
    /// The camera's track id.
    pub track: Option<TrackId>,
    /// Grid times, session seconds (equal to the IMU window's).
    pub t_s: Vec<f64>,
    /// Joint positions in the world frame per grid time (filtered by the engine); a joint absent
    /// at a time is missing there.
    pub joints_world_m: Vec<Joints<Point3<f64>>>,
}

impl SkeletonWindow {
    /// The window from grid point `from` on (empty past the end).
    pub fn tail(&self, from: usize) -> SkeletonWindow {
        SkeletonWindow {
            camera: self.camera.clone(),
            track: self.track,
            t_s: tail(&self.t_s, from),
            joints_world_m: tail(&self.joints_world_m, from),
        }
    }
}

/// Per-model similarity for one (IMU, skeleton joint) pair, all on the correlation scale
/// `-1..=1`: De Marchi's Pearson correlations of the magnitude signals, plus an optional learned
/// score; `None` when a signal is missing or constant, or the model did not run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelScores {
    /// Correlation of linear-acceleration magnitudes.
    pub acc: Option<f64>,
    /// Correlation of velocity magnitudes.
    pub vel: Option<f64>,
    /// Correlation of orientation-change magnitudes.
    pub ori: Option<f64>,
    /// A learned model's score ([`crate::PairScorer`], e.g. De Marchi's CNN), mapped to `-1..=1`
    /// (`2p − 1` for a match probability `p`). [`crate::geometric_scores`] leaves it `None`; the
    /// caller fills it when a scorer is configured.
    pub dl: Option<f64>,
}
