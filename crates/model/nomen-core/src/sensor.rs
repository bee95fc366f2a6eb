//! Messages from wearables and radio systems.

use crate::error::{
    CoreError, Result, check_finite_all, check_finite_all_lazy, check_range, check_range_lazy,
};
use crate::ids::{AnchorId, AntennaId, DeviceId, TagId};
use crate::time::SessionTime;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Sanity bound on accelerometer readings, m/s² (±32 g covers every wearable IMU range).
pub const MAX_ACCEL_MPS2: f64 = 32.0 * 9.81;
/// Sanity bound on gyroscope readings, rad/s (±4000 °/s).
pub const MAX_GYRO_RADPS: f64 = 70.0;
/// Sanity bound on magnetometer readings, µT (Earth's field is 25–65 µT; indoors a few hundred).
pub const MAX_MAG_UT: f64 = 5000.0;

/// One inertial sample, in the sensor's own frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuSample {
    /// Sample time on the session clock.
    pub t: SessionTime,
    /// The IMU.
    pub device: DeviceId,
    /// Specific force (what an accelerometer measures: gravity reaction included), m/s².
    pub accel_mps2: Vector3<f64>,
    /// Angular rate, rad/s; `None` for a device that has no gyroscope (an accelerometer-only
    /// IMU). A device either always or never sends it: the engine takes a device's first
    /// sample as saying which, and refuses a later sample that says otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_radps: Option<Vector3<f64>>,
    /// Magnetic field, µT, if the device has a magnetometer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag_ut: Option<Vector3<f64>>,
    /// The device's own orientation estimate, `world_from_sensor` as `[w, x, y, z]`, if it
    /// computes one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_wxyz: Option<[f64; 4]>,
}

impl ImuSample {
    /// Checks finiteness and plausible ranges.
    pub fn validate(&self) -> Result<()> {
        self.t.check_plausible()?;
        check_finite_all_lazy(|| "accel_mps2".into(), self.accel_mps2.as_slice())?;
        if let Some(g) = &self.gyro_radps {
            check_finite_all_lazy(|| "gyro_radps".into(), g.as_slice())?;
        }
        for (i, v) in self.accel_mps2.iter().enumerate() {
            check_range_lazy(
                || format!("accel_mps2[{i}]"),
                *v,
                -MAX_ACCEL_MPS2,
                MAX_ACCEL_MPS2,
                "m/s²",
            )?;
        }
        for (i, v) in self.gyro_radps.iter().flat_map(|g| g.iter()).enumerate() {
            check_range_lazy(
                || format!("gyro_radps[{i}]"),
                *v,
                -MAX_GYRO_RADPS,
                MAX_GYRO_RADPS,
                "rad/s",
            )?;
        }
        if let Some(m) = &self.mag_ut {
            for (i, v) in m.iter().enumerate() {
                check_range_lazy(|| format!("mag_ut[{i}]"), *v, -MAX_MAG_UT, MAX_MAG_UT, "µT")?;
            }
        }
        if let Some(q) = &self.orientation_wxyz {
            check_finite_all("orientation_wxyz", q)?;
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (n - 1.0).abs() > 0.01 {
                return Err(CoreError::Invalid(format!(
                    "orientation_wxyz has norm {n:.4}, expected a unit quaternion"
                )));
            }
        }
        Ok(())
    }
}

/// One position fix from a real-time location system (UWB, BLE AoA, ...), in the world frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RtlsFix {
    /// Fix time on the session clock.
    pub t: SessionTime,
    /// The tag.
    pub tag: TagId,
    /// Position in the world frame, metres.
    pub position_m: Point3<f64>,
    /// The system's own quality figure in `0..=1`, if it reports one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quality: Option<f64>,
    /// Position covariance, m², row-major 3×3, if the system reports one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance_m2: Option<[[f64; 3]; 3]>,
}

impl RtlsFix {
    /// Checks finiteness, coordinate bounds and a symmetric covariance with non-negative diagonal.
    pub fn validate(&self) -> Result<()> {
        self.t.check_plausible()?;
        for (i, v) in self.position_m.iter().enumerate() {
            check_range_lazy(
                || format!("position_m[{i}]"),
                *v,
                -crate::skeleton::MAX_COORDINATE_M,
                crate::skeleton::MAX_COORDINATE_M,
                "m",
            )?;
        }
        if let Some(q) = self.quality {
            check_range("quality", q, 0.0, 1.0, "")?;
        }
        if let Some(c) = &self.covariance_m2 {
            for (r, row) in c.iter().enumerate() {
                check_finite_all_lazy(|| format!("covariance_m2[{r}]"), row)?;
                if row[r] < 0.0 {
                    return Err(CoreError::Invalid(format!(
                        "covariance_m2[{r}][{r}] is negative"
                    )));
                }
            }
            let is_symmetric = (0..3)
                .flat_map(|r| (0..3).map(move |k| (r, k)))
                .all(|(r, k)| (c[r][k] - c[k][r]).abs() <= 1e-9 * (1.0 + c[r][k].abs()));
            if !is_symmetric {
                return Err(CoreError::Invalid("covariance_m2 is not symmetric".into()));
            }
        }
        Ok(())
    }
}

/// One raw two-way-ranging measurement between a UWB tag and an anchor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbRange {
    /// Measurement time on the session clock.
    pub t: SessionTime,
    /// The tag.
    pub tag: TagId,
    /// The anchor.
    pub anchor: AnchorId,
    /// Measured range, metres (biased long in practice).
    pub range_m: f64,
}

impl UwbRange {
    /// Checks the range is finite and in `0..=1000` m.
    pub fn validate(&self) -> Result<()> {
        self.t.check_plausible()?;
        check_range("range_m", self.range_m, 0.0, 1000.0, "m")
    }
}

/// Plausible RSSI range, dBm. A reader that reports dBm×100 (a real quirk) lands far outside.
pub const RSSI_RANGE_DBM: (f64, f64) = (-150.0, 30.0);

/// One received-signal-strength reading of a tag at an antenna (passive UHF RFID, BLE).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiRead {
    /// Read time on the session clock.
    pub t: SessionTime,
    /// The tag.
    pub tag: TagId,
    /// The receiving antenna (an RFID reader port or a BLE anchor).
    pub antenna: AntennaId,
    /// Received power, dBm.
    pub rssi_dbm: f64,
    /// Backscatter phase, radians, if the reader reports it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_rad: Option<f64>,
}

impl RssiRead {
    /// Checks the RSSI is a plausible dBm value (rejects dBm×100 and NaN).
    pub fn validate(&self) -> Result<()> {
        self.t.check_plausible()?;
        check_range(
            "rssi_dbm",
            self.rssi_dbm,
            RSSI_RANGE_DBM.0,
            RSSI_RANGE_DBM.1,
            "dBm",
        )?;
        if let Some(p) = self.phase_rad {
            check_range("phase_rad", p, -10.0, 10.0, "rad")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rssi_in_centi_dbm_is_out_of_range() {
        let read = RssiRead {
            t: SessionTime(0),
            tag: TagId::new("tag"),
            antenna: AntennaId::new("a1"),
            rssi_dbm: -6500.0,
            phase_rad: None,
        };
        let err = read.validate().unwrap_err().to_string();
        assert!(err.contains("rssi_dbm") && err.contains("dBm"), "{err}");
    }

    #[test]
    fn imu_with_nan_gyro_names_the_axis() {
        let s = ImuSample {
            t: SessionTime(0),
            device: DeviceId::new("imu"),
            accel_mps2: Vector3::new(0.0, 0.0, 9.81),
            gyro_radps: Some(Vector3::new(0.0, f64::NAN, 0.0)),
            mag_ut: None,
            orientation_wxyz: None,
        };
        assert!(
            s.validate()
                .unwrap_err()
                .to_string()
                .contains("gyro_radps[1]")
        );
    }

    #[test]
    fn accelerometer_only_sample_has_no_gyro_field() {
        let text = r#"{"t":0,"device":"watch","accel_mps2":[0.0,0.0,9.81]}"#;
        let s: ImuSample = serde_json::from_str(text).unwrap();
        assert_eq!(s.gyro_radps, None);
        s.validate().unwrap();
        let back = serde_json::to_string(&s).unwrap();
        assert!(!back.contains("gyro"), "{back}");
        // A gyroscope reading out of range is still refused, on the axis it is on.
        let fast = ImuSample {
            gyro_radps: Some(Vector3::new(0.0, 0.0, -2.0 * MAX_GYRO_RADPS)),
            ..s
        };
        assert!(
            fast.validate()
                .unwrap_err()
                .to_string()
                .contains("gyro_radps[2]")
        );
    }

    #[test]
    fn asymmetric_covariance_is_rejected() {
        let fix = RtlsFix {
            t: SessionTime(0),
            tag: TagId::new("t"),
            position_m: Point3::new(1.0, 2.0, 1.0),
            quality: None,
            covariance_m2: Some([[0.1, 0.2, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]]),
        };
        assert!(fix.validate().is_err());
    }
}
