//! IMU CSV recordings with a header: BROAD, x-io, or any file described by an [`ImuCsvFormat`].

use crate::error::{FitError, Result};
use crate::table::{CsvText, column};
use nalgebra::Vector3;
use nomen_core::sensor::{MAX_ACCEL_MPS2, MAX_GYRO_RADPS, MAX_MAG_UT};
use serde::{Deserialize, Serialize};

/// Standard gravity, m/s² per g (CGPM 1901); used to convert accelerometers that report in g.
pub const STANDARD_GRAVITY_MPS2: f64 = 9.806_65;

/// Unit of a gyroscope column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GyroUnit {
    /// rad/s (BROAD).
    RadPerS,
    /// °/s (x-io); converted to rad/s at ingest.
    DegPerS,
}

/// Unit of an accelerometer column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AccelUnit {
    /// m/s² (BROAD).
    MetresPerS2,
    /// Multiples of standard gravity (x-io); converted to m/s² at ingest with 9.80665.
    StandardGravity,
}

/// Which header columns hold what, and in which unit. Magnetometers are always µT.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuCsvFormat {
    /// Time column, seconds.
    pub time_s: String,
    /// Accelerometer x, y, z columns.
    pub accel: [String; 3],
    /// Unit of the accelerometer columns.
    pub accel_unit: AccelUnit,
    /// Gyroscope x, y, z columns.
    pub gyro: [String; 3],
    /// Unit of the gyroscope columns.
    pub gyro_unit: GyroUnit,
    /// Magnetometer x, y, z columns (µT), if any.
    pub mag: Option<[String; 3]>,
    /// A column that is 1 while the sensor moves and 0 at rest (BROAD's `movement`), if any.
    pub movement: Option<String>,
    /// Ground-truth orientation `world_from_sensor` w, x, y, z columns (NaN allowed), if any.
    pub truth_quat_wxyz: Option<[String; 4]>,
}

fn names<const N: usize>(prefix: &str, suffixes: [&str; N]) -> [String; N] {
    suffixes.map(|s| format!("{prefix}{s}"))
}

impl ImuCsvFormat {
    /// BROAD (Laidig et al. 2021) as converted to CSV: SI units, `movement` column, ground truth.
    pub fn broad() -> Self {
        Self {
            time_s: "t_s".into(),
            accel: names("acc_", ["x", "y", "z"]),
            accel_unit: AccelUnit::MetresPerS2,
            gyro: names("gyr_", ["x", "y", "z"]),
            gyro_unit: GyroUnit::RadPerS,
            mag: Some(names("mag_", ["x", "y", "z"])),
            movement: Some("movement".into()),
            truth_quat_wxyz: Some(names("gt_q", ["w", "x", "y", "z"])),
        }
    }

    /// x-io Technologies Fusion example `sensor_data.csv`: gyroscope in °/s, accelerometer in g,
    /// magnetometer in µT, no movement flag.
    pub fn xio() -> Self {
        Self {
            time_s: "Time (s)".into(),
            accel: ["X", "Y", "Z"].map(|a| format!("Accelerometer {a} (g)")),
            accel_unit: AccelUnit::StandardGravity,
            gyro: ["X", "Y", "Z"].map(|a| format!("Gyroscope {a} (deg/s)")),
            gyro_unit: GyroUnit::DegPerS,
            mag: Some(["X", "Y", "Z"].map(|a| format!("Magnetometer {a} (uT)"))),
            movement: None,
            truth_quat_wxyz: None,
        }
    }
}

/// One IMU sample in SI units, sensor frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuRow {
    /// Time, s, from the file's own origin.
    pub t_s: f64,
    /// Specific force, m/s².
    pub accel_mps2: Vector3<f64>,
    /// Angular rate, rad/s.
    pub gyro_radps: Vector3<f64>,
    /// Magnetic field, µT.
    pub mag_ut: Option<Vector3<f64>>,
    /// The file's movement flag, if it has one.
    pub is_moving: Option<bool>,
    /// Ground-truth `world_from_sensor` as `[w, x, y, z]`; `None` where markers were lost.
    pub truth_quat_wxyz: Option<[f64; 4]>,
}

/// An IMU recording: the samples of one file, time non-decreasing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuRecording {
    /// Source name (file path).
    pub name: String,
    /// The samples.
    pub rows: Vec<ImuRow>,
}

impl ImuRecording {
    /// Sample rate from the median sample interval, Hz (`None` with fewer than two samples or a
    /// zero median interval).
    pub fn rate_hz(&self) -> Option<f64> {
        let dt: Vec<f64> = self.rows.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
        let median = crate::stats::median(&dt)?;
        (median > 0.0).then(|| 1.0 / median)
    }
}

/// Parses an IMU CSV `text` (with a header) described by `format`. `name` is used in errors.
///
/// Accelerometer and gyroscope values must be finite and inside nomen-core's sanity bounds;
/// ground-truth quaternions may be NaN (markers lost) and become `None`.
pub fn parse_imu_csv(text: &str, name: &str, format: &ImuCsvFormat) -> Result<ImuRecording> {
    let mut csv = CsvText::new(text, name, true);
    let headers = csv.headers()?;
    let col = |c: &str| column(&headers, c, name);
    let t_col = col(&format.time_s)?;
    let acc_cols = [
        col(&format.accel[0])?,
        col(&format.accel[1])?,
        col(&format.accel[2])?,
    ];
    let gyr_cols = [
        col(&format.gyro[0])?,
        col(&format.gyro[1])?,
        col(&format.gyro[2])?,
    ];
    let mag_cols = match &format.mag {
        Some(m) => Some([col(&m[0])?, col(&m[1])?, col(&m[2])?]),
        None => None,
    };
    let mov_col = format.movement.as_deref().map(col).transpose()?;
    let q_cols = match &format.truth_quat_wxyz {
        Some(q) => Some([col(&q[0])?, col(&q[1])?, col(&q[2])?, col(&q[3])?]),
        None => None,
    };
    // Source conventions: BROAD is already SI; x-io reports °/s and g.
    let gyro_scale = match format.gyro_unit {
        GyroUnit::RadPerS => 1.0,
        GyroUnit::DegPerS => std::f64::consts::PI / 180.0,
    };
    let accel_scale = match format.accel_unit {
        AccelUnit::MetresPerS2 => 1.0,
        AccelUnit::StandardGravity => STANDARD_GRAVITY_MPS2,
    };

    let mut rows = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    while let Some(row) = csv.next_row()? {
        row.expect_len(headers.len())?;
        let t_s = row.f64(t_col, &format.time_s)?;
        if t_s < last_t {
            return Err(row.error(format!("time goes backwards ({t_s} s after {last_t} s)")));
        }
        if t_s == last_t {
            return Err(row.error(format!(
                "duplicate time {t_s} s (the row before has it too)"
            )));
        }
        last_t = t_s;
        let vec3 = |cols: [usize; 3], names: &[String; 3], scale: f64, bound: f64, unit: &str| {
            let mut v = Vector3::zeros();
            for i in 0..3 {
                let x = row.f64(cols[i], &names[i])? * scale;
                if x.abs() > bound {
                    return Err(row.error(format!(
                        "column '{}': {x} {unit} is outside ±{bound} {unit}",
                        names[i]
                    )));
                }
                v[i] = x;
            }
            Ok::<_, FitError>(v)
        };
        let accel_mps2 = vec3(acc_cols, &format.accel, accel_scale, MAX_ACCEL_MPS2, "m/s²")?;
        let gyro_radps = vec3(gyr_cols, &format.gyro, gyro_scale, MAX_GYRO_RADPS, "rad/s")?;
        let mag_ut = match (mag_cols, &format.mag) {
            (Some(c), Some(n)) => Some(vec3(c, n, 1.0, MAX_MAG_UT, "µT")?),
            _ => None,
        };
        let is_moving = match (mov_col, &format.movement) {
            (Some(c), Some(n)) => Some(row.f64(c, n)? != 0.0),
            _ => None,
        };
        let truth_quat_wxyz = match (q_cols, &format.truth_quat_wxyz) {
            (Some(c), Some(n)) => {
                let q = [
                    row.f64_or_nan(c[0], &n[0])?,
                    row.f64_or_nan(c[1], &n[1])?,
                    row.f64_or_nan(c[2], &n[2])?,
                    row.f64_or_nan(c[3], &n[3])?,
                ];
                q.iter().all(|v| v.is_finite()).then_some(q)
            }
            _ => None,
        };
        rows.push(ImuRow {
            t_s,
            accel_mps2,
            gyro_radps,
            mag_ut,
            is_moving,
            truth_quat_wxyz,
        });
    }
    Ok(ImuRecording {
        name: name.to_owned(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BROAD_HEADER: &str = "t_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z,mag_x,mag_y,mag_z,gt_qw,gt_qx,gt_qy,gt_qz,gt_px,gt_py,gt_pz,movement";

    #[test]
    fn broad_row_with_lost_markers_has_no_truth() {
        let text =
            format!("{BROAD_HEADER}\n0,0.1,0.0,9.8,0.01,0,0,1,2,3,nan,nan,nan,nan,nan,nan,nan,0\n");
        let rec = parse_imu_csv(&text, "b.csv", &ImuCsvFormat::broad()).unwrap();
        assert_eq!(rec.rows.len(), 1);
        assert!(rec.rows[0].truth_quat_wxyz.is_none());
        assert_eq!(rec.rows[0].is_moving, Some(false));
    }

    #[test]
    fn xio_degrees_and_g_become_si() {
        let text = "Time (s),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g),Magnetometer X (uT),Magnetometer Y (uT),Magnetometer Z (uT)\n0,180,0,0,0,0,1,15,0,-41\n";
        let rec = parse_imu_csv(text, "x.csv", &ImuCsvFormat::xio()).unwrap();
        let r = &rec.rows[0];
        assert!((r.gyro_radps.x - std::f64::consts::PI).abs() < 1e-12);
        assert!((r.accel_mps2.z - 9.80665).abs() < 1e-12);
    }

    #[test]
    fn nan_accelerometer_is_an_error_at_its_line() {
        let text = format!(
            "{BROAD_HEADER}\n0,0.1,0.0,9.8,0.01,0,0,1,2,3,1,0,0,0,0,0,0,0\n0.0035,nan,0.0,9.8,0.01,0,0,1,2,3,1,0,0,0,0,0,0,0\n"
        );
        let err = parse_imu_csv(&text, "b.csv", &ImuCsvFormat::broad())
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("b.csv:3: column 'acc_x'"), "{err}");
    }
}
