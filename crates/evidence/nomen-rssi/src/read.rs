//! Checking RSSI values at ingest: finite, plausible dBm, and an explicit conversion for readers
//! that report dBm×100 (several UHF RFID readers do: −6550 means −65.5 dBm).

use crate::error::{Result, RssiError};
use nomen_core::RssiRead;
use nomen_core::sensor::RSSI_RANGE_DBM;
use serde::{Deserialize, Serialize};

/// The unit the reader reports RSSI in. Nothing is guessed: a value outside the plausible dBm
/// range is rejected unless the unit says how to convert it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RssiUnit {
    /// dBm (nomen's unit; what recordings carry).
    #[default]
    Dbm,
    /// Hundredths of a dBm (a reader quirk): divided by 100 at ingest.
    CentiDbm,
}

/// The read's RSSI in dBm after the unit conversion, or an error naming the tag, antenna and
/// time: NaN/inf, or a value outside `RSSI_RANGE_DBM` (with a hint when it looks like dBm×100).
pub fn checked_rssi_dbm(read: &RssiRead, unit: RssiUnit) -> Result<f64> {
    let raw = read.rssi_dbm;
    if !raw.is_finite() {
        return Err(RssiError::NonFiniteRssi {
            tag: read.tag.to_string(),
            antenna: read.antenna.to_string(),
            t_s: read.t.as_secs_f64(),
        });
    }
    let v = match unit {
        RssiUnit::Dbm => raw,
        RssiUnit::CentiDbm => raw / 100.0,
    };
    let (lo, hi) = RSSI_RANGE_DBM;
    // A read already in dBm, divided by 100, lands between −1.5 and +0.3 dBm: inside the range,
    // but no receiver sees that much power from a tag; read as dBm, it is plausible.
    let is_dbm_already = unit == RssiUnit::CentiDbm && (lo..=hi).contains(&raw);
    if (lo..=hi).contains(&v) && !is_dbm_already {
        return Ok(v);
    }
    let hint = if is_dbm_already {
        format!("; it looks like dBm already ({raw} dBm): the unit is dBm, not dBm×100")
    } else if unit == RssiUnit::Dbm && (lo..=hi).contains(&(raw / 100.0)) {
        format!(
            "; it looks like dBm×100 ({} dBm): set rssi_unit = \"centi_dbm\"",
            raw / 100.0
        )
    } else {
        format!(" (plausible: {lo}..={hi} dBm)")
    };
    Err(RssiError::ImplausibleRssi {
        tag: read.tag.to_string(),
        antenna: read.antenna.to_string(),
        t_s: read.t.as_secs_f64(),
        value: raw,
        hint,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::{AntennaId, DeviceId, SessionTime};

    fn read(v: f64) -> RssiRead {
        RssiRead {
            t: SessionTime::from_ns(1_500_000_000),
            tag: DeviceId::new("epc1"),
            antenna: AntennaId::new("ant0"),
            rssi_dbm: v,
            phase_rad: None,
        }
    }

    #[test]
    fn centi_dbm_is_rejected_with_a_hint_or_converted_when_declared() {
        let err = checked_rssi_dbm(&read(-6550.0), RssiUnit::Dbm)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("dBm×100") && err.contains("epc1") && err.contains("ant0"),
            "{err}"
        );
        assert!(err.contains("1.500 s"), "{err}");
        let v = checked_rssi_dbm(&read(-6550.0), RssiUnit::CentiDbm).ok();
        assert_eq!(v, Some(-65.5));
        // A dBm value declared as centi-dBm becomes -0.655 dBm: plausible, so accepted; the unit
        // is the caller's explicit claim.
        assert_eq!(
            checked_rssi_dbm(&read(-65.5), RssiUnit::Dbm).ok(),
            Some(-65.5)
        );
    }

    #[test]
    fn nan_rssi_is_rejected_naming_the_read() {
        let err = checked_rssi_dbm(&read(f64::NAN), RssiUnit::Dbm)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("not finite") && err.contains("epc1"), "{err}");
        assert!(checked_rssi_dbm(&read(f64::INFINITY), RssiUnit::CentiDbm).is_err());
        // Reads already in dBm, declared as dBm×100: refused with the hint, not taken as -0.6 dBm.
        let err = checked_rssi_dbm(&read(-60.0), RssiUnit::CentiDbm)
            .unwrap_err()
            .to_string();
        assert!(err.contains("looks like dBm already"), "{err}");
        // Far outside either unit: no dBm×100 hint.
        let err = checked_rssi_dbm(&read(1e9), RssiUnit::Dbm)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            !err.contains("dBm×100") && err.contains("plausible"),
            "{err}"
        );
    }
}
