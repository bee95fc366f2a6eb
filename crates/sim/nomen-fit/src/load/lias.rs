//! UWB range tables and motion-capture tables in the LIAS-CUHKSZ planar-dataset layout.

use crate::error::{FitError, Result};
use crate::table::CsvText;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use nomen_core::time::{days_from_civil, days_in_month};
use serde::{Deserialize, Serialize};

/// Layout of a headerless UWB range table: a time column then `num_anchors × num_tags` ranges,
/// anchor-major (`a0-t0, a0-t1, …, a1-t0, …`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbCsvFormat {
    /// Number of anchors.
    pub num_anchors: usize,
    /// Number of tags.
    pub num_tags: usize,
    /// The value that marks a missing range (LIAS writes `0.0`).
    pub missing_value_m: f64,
    /// Whether the first line is a header to skip.
    pub has_header: bool,
}

impl UwbCsvFormat {
    /// LIAS planar dataset: 8 anchors × 3 tags, `0.0` = missing, no header.
    pub fn lias() -> Self {
        Self {
            num_anchors: 8,
            num_tags: 3,
            missing_value_m: 0.0,
            has_header: false,
        }
    }
}

/// One row of ranges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbRow {
    /// Time on the recording's clock, s (see [`parse_local_time_s`]).
    pub t_s: f64,
    /// Ranges, m, index `anchor · num_tags + tag`; `None` = missing.
    pub ranges_m: Vec<Option<f64>>,
}

/// A UWB range table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbRecording {
    /// Source name.
    pub name: String,
    /// Number of anchors.
    pub num_anchors: usize,
    /// Number of tags.
    pub num_tags: usize,
    /// Rows in file order.
    pub rows: Vec<UwbRow>,
    /// Lines skipped because some range fields were empty. In the LIAS files such a row has its
    /// values shifted left by one anchor block and empty fields at the end (the logger dropped a
    /// packet), so no range in it can be attributed to an anchor.
    pub skipped_lines: Vec<u64>,
}

impl UwbRecording {
    /// The range between `anchor` and `tag` in `row`, `None` when missing or out of bounds.
    pub fn range_m(&self, row: &UwbRow, anchor: usize, tag: usize) -> Option<f64> {
        if tag >= self.num_tags {
            return None;
        }
        row.ranges_m
            .get(anchor * self.num_tags + tag)
            .copied()
            .flatten()
    }
}

/// Parses a local time `YYYY-MM-DD H:MM:SS.fff` (or a plain number of seconds) into seconds
/// since 1970-01-01 00:00 *on the same local clock*: no time zone is applied, which is right
/// because only differences between files recorded on one clock are used.
pub fn parse_local_time_s(s: &str) -> Option<f64> {
    if let Ok(v) = s.parse::<f64>() {
        return v.is_finite().then_some(v);
    }
    let (date, time) = s.trim().split_once(' ')?;
    let mut d = date.split('-');
    let y: i64 = d.next()?.parse().ok()?;
    let mo: i64 = d.next()?.parse().ok()?;
    let day: i64 = d.next()?.parse().ok()?;
    // Years of the Gregorian calendar's four digits: further out is a corrupt field, and the
    // day count below would overflow (a year of 10^14 did).
    if d.next().is_some()
        || !(1..=9999).contains(&y)
        || !(1..=12).contains(&mo)
        || !(1..=days_in_month(y, mo)).contains(&day)
    {
        return None;
    }
    let mut t = time.trim().split(':');
    let h: i64 = t.next()?.parse().ok()?;
    let mi: i64 = t.next()?.parse().ok()?;
    let sec: f64 = t.next()?.parse().ok()?;
    if t.next().is_some()
        || !(0..24).contains(&h)
        || !(0..60).contains(&mi)
        || !(0.0..61.0).contains(&sec)
    {
        return None;
    }
    Some((days_from_civil(y, mo, day) * 86_400 + h * 3600 + mi * 60) as f64 + sec)
}

/// Parses a UWB range table (LIAS layout, see [`UwbCsvFormat`]).
pub fn parse_uwb_csv(text: &str, name: &str, format: &UwbCsvFormat) -> Result<UwbRecording> {
    let num_ranges = format.num_anchors * format.num_tags;
    if num_ranges == 0 {
        return Err(FitError::InvalidArgument(
            "uwb format with no anchors or no tags".into(),
        ));
    }
    let mut csv = CsvText::new(text, name, format.has_header);
    if format.has_header {
        csv.headers()?;
    }
    let mut rows = Vec::new();
    let mut skipped_lines = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    while let Some(row) = csv.next_row()? {
        row.expect_len(1 + num_ranges)?;
        let time = row.str(0, "time")?;
        let t_s = parse_local_time_s(time)
            .ok_or_else(|| row.error(format!("column 'time': '{time}' is not a time")))?;
        // Equal times occur in the LIAS logs themselves (two rows in one millisecond); going
        // back does not.
        if t_s < last_t {
            return Err(row.error(format!(
                "column 'time': {time} is before the row before (out of order)"
            )));
        }
        last_t = t_s;
        if (1..=num_ranges).any(|i| row.str(i, "range").is_ok_and(str::is_empty)) {
            skipped_lines.push(row.line);
            continue;
        }
        let mut ranges_m = Vec::with_capacity(num_ranges);
        for i in 0..num_ranges {
            let label = format!("a{}-t{}", i / format.num_tags, i % format.num_tags);
            let r = row.f64(1 + i, &label)?;
            if r == format.missing_value_m {
                ranges_m.push(None);
            } else if !(0.0..=1000.0).contains(&r) {
                return Err(row.error(format!(
                    "column '{label}': range {r} m is outside 0..=1000 m"
                )));
            } else {
                ranges_m.push(Some(r));
            }
        }
        rows.push(UwbRow { t_s, ranges_m });
    }
    Ok(UwbRecording {
        name: name.to_owned(),
        num_anchors: format.num_anchors,
        num_tags: format.num_tags,
        rows,
        skipped_lines,
    })
}

/// Order of the four quaternion columns of a motion-capture table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum QuatOrder {
    /// Scalar first: `w, x, y, z` (what the LIAS README documents).
    Wxyz,
    /// Scalar last: `x, y, z, w`.
    Xyzw,
}

/// A constant half turn between the mocap rigid-body frame and the frame the tag offsets are
/// given in (`world_from_tags = world_from_body · flip`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BodyFlip {
    /// The frames coincide.
    None,
    /// Half turn about the body x axis (y and z reversed).
    X,
    /// Half turn about the body y axis (x and z reversed).
    Y,
    /// Half turn about the body z axis (x and y reversed).
    Z,
}

impl BodyFlip {
    /// The rotation.
    pub fn rotation(self) -> UnitQuaternion<f64> {
        let pi = std::f64::consts::PI;
        match self {
            Self::None => UnitQuaternion::identity(),
            Self::X => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pi),
            Self::Y => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pi),
            Self::Z => UnitQuaternion::from_axis_angle(&Vector3::z_axis(), pi),
        }
    }
}

/// How to turn the four raw quaternion columns into `world_from_tags`, the rotation that
/// places the tag offsets: `q` read in `order`, inverted if `is_inverse`, times `flip`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct QuatConvention {
    /// Column order.
    pub order: QuatOrder,
    /// When true the quaternion is `body_from_world` and is inverted.
    pub is_inverse: bool,
    /// Constant half turn from the mocap body frame to the tag-offset frame.
    pub flip: BodyFlip,
}

impl QuatConvention {
    /// All sixteen candidates (2 orders × inverse or not × 4 flips), in a fixed order.
    pub fn all() -> Vec<Self> {
        let mut out = Vec::with_capacity(16);
        for order in [QuatOrder::Wxyz, QuatOrder::Xyzw] {
            for is_inverse in [false, true] {
                for flip in [BodyFlip::None, BodyFlip::X, BodyFlip::Y, BodyFlip::Z] {
                    out.push(Self {
                        order,
                        is_inverse,
                        flip,
                    });
                }
            }
        }
        out
    }

    /// The README's documented reading: scalar first, `world_from_body`, no flip.
    pub fn documented() -> Self {
        Self {
            order: QuatOrder::Wxyz,
            is_inverse: false,
            flip: BodyFlip::None,
        }
    }

    /// `world_from_tags` from the four raw columns, `None` for a zero-norm quaternion.
    pub fn world_from_body(&self, raw: [f64; 4]) -> Option<UnitQuaternion<f64>> {
        let q = match self.order {
            QuatOrder::Wxyz => Quaternion::new(raw[0], raw[1], raw[2], raw[3]),
            QuatOrder::Xyzw => Quaternion::new(raw[3], raw[0], raw[1], raw[2]),
        };
        if q.norm().is_nan() || q.norm() <= 1e-9 {
            return None;
        }
        let u = UnitQuaternion::from_quaternion(q);
        let u = if self.is_inverse { u.inverse() } else { u };
        Some(u * self.flip.rotation())
    }

    /// A short label, e.g. `wxyz · Rx(π)` or `xyzw inverted`.
    pub fn label(&self) -> String {
        let mut s = match self.order {
            QuatOrder::Wxyz => "wxyz",
            QuatOrder::Xyzw => "xyzw",
        }
        .to_owned();
        if self.is_inverse {
            s.push_str(" inverted");
        }
        match self.flip {
            BodyFlip::None => {}
            BodyFlip::X => s.push_str(" · Rx(π)"),
            BodyFlip::Y => s.push_str(" · Ry(π)"),
            BodyFlip::Z => s.push_str(" · Rz(π)"),
        }
        s
    }
}

/// One motion-capture sample of a rigid body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MocapRow {
    /// Time on the recording's clock, s.
    pub t_s: f64,
    /// Rigid-body origin in the world (anchor) frame, m.
    pub position_m: Vector3<f64>,
    /// The four quaternion columns as written; interpret with a [`QuatConvention`].
    pub quat_raw: [f64; 4],
}

/// A motion-capture table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MocapRecording {
    /// Source name.
    pub name: String,
    /// Rows, time non-decreasing.
    pub rows: Vec<MocapRow>,
}

/// Parses a LIAS motion-capture table: a header line, then `time, x, y, z, q0, q1, q2, q3`.
pub fn parse_mocap_csv(text: &str, name: &str) -> Result<MocapRecording> {
    let mut csv = CsvText::new(text, name, true);
    csv.headers()?;
    const COLUMNS: [&str; 8] = ["time", "x", "y", "z", "q0", "q1", "q2", "q3"];
    let mut rows = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    while let Some(row) = csv.next_row()? {
        row.expect_len(COLUMNS.len())?;
        let time = row.str(0, "time")?;
        let t_s = parse_local_time_s(time)
            .ok_or_else(|| row.error(format!("column 'time': '{time}' is not a time")))?;
        if t_s < last_t {
            return Err(row.error("time goes backwards"));
        }
        last_t = t_s;
        let v: Vec<f64> = (1..8)
            .map(|i| row.f64(i, COLUMNS[i]))
            .collect::<Result<_>>()?;
        let quat_raw = [v[3], v[4], v[5], v[6]];
        let norm = quat_raw.iter().map(|q| q * q).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > 0.01 {
            return Err(row.error(format!(
                "quaternion has norm {norm:.4}, expected a unit quaternion"
            )));
        }
        rows.push(MocapRow {
            t_s,
            position_m: Vector3::new(v[0], v[1], v[2]),
            quat_raw,
        });
    }
    Ok(MocapRecording {
        name: name.to_owned(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_time_counts_seconds_across_midnight_and_months() {
        let a = parse_local_time_s("2022-08-15 9:42:24.766").unwrap();
        let b = parse_local_time_s("2022-08-15 9:42:25.000").unwrap();
        assert!((b - a - 0.234).abs() < 1e-6);
        let c = parse_local_time_s("2022-08-31 23:59:59.5").unwrap();
        let d = parse_local_time_s("2022-09-01 0:00:00.5").unwrap();
        assert!((d - c - 1.0).abs() < 1e-6);
        assert_eq!(parse_local_time_s("1970-01-02 0:00:00"), Some(86_400.0));
        assert!(parse_local_time_s("2022-13-01 0:00:00").is_none());
    }

    #[test]
    fn dates_the_calendar_lacks_and_years_past_four_digits_are_refused() {
        // A year of 10^14, or i64::MAX, overflowed the day count (a panic with overflow checks,
        // a wrapped time without).
        for s in [
            "100000000000000-08-01 0:00:00",
            "9223372036854775807-08-01 0:00:00",
            "0-01-01 0:00:00",
            "2022-02-29 0:00:00",
            "2022-04-31 0:00:00",
        ] {
            assert_eq!(parse_local_time_s(s), None, "{s}");
        }
        let leap = parse_local_time_s("2024-02-29 0:00:00").unwrap();
        let march = parse_local_time_s("2024-03-01 0:00:00").unwrap();
        assert_eq!(march - leap, 86_400.0);
        assert!(parse_local_time_s("9999-12-31 23:59:59").is_some());
    }

    #[test]
    fn zero_range_is_missing() {
        let fmt = UwbCsvFormat {
            num_anchors: 2,
            num_tags: 1,
            missing_value_m: 0.0,
            has_header: false,
        };
        let rec = parse_uwb_csv("2022-08-15 9:42:24.766,0.0,3.5\n", "u.csv", &fmt).unwrap();
        assert_eq!(rec.rows[0].ranges_m, vec![None, Some(3.5)]);
    }

    #[test]
    fn shifted_row_with_empty_fields_is_skipped_and_counted() {
        let fmt = UwbCsvFormat {
            num_anchors: 2,
            num_tags: 1,
            missing_value_m: 0.0,
            has_header: false,
        };
        let text = "2022-08-15 9:42:24.766,1.0,3.5\n2022-08-15 9:42:24.776,3.5,\n";
        let rec = parse_uwb_csv(text, "u.csv", &fmt).unwrap();
        assert_eq!(rec.rows.len(), 1);
        assert_eq!(rec.skipped_lines, vec![2]);
    }

    #[test]
    fn truncated_uwb_row_names_its_line() {
        let fmt = UwbCsvFormat {
            num_anchors: 2,
            num_tags: 1,
            missing_value_m: 0.0,
            has_header: false,
        };
        let err = parse_uwb_csv(
            "2022-08-15 9:42:24.766,1.0,3.5\n2022-08-15 9:42:24.776,1.0\n",
            "u.csv",
            &fmt,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("u.csv:2: expected 3 fields, found 2"),
            "{err}"
        );
    }

    #[test]
    fn scalar_last_reads_the_same_rotation() {
        let q = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
        let wxyz = [q.w, q.i, q.j, q.k];
        let xyzw = [q.i, q.j, q.k, q.w];
        let scalar_last = QuatConvention {
            order: QuatOrder::Xyzw,
            ..QuatConvention::documented()
        };
        let a = QuatConvention::documented().world_from_body(wxyz).unwrap();
        let b = scalar_last.world_from_body(xyzw).unwrap();
        assert!(a.angle_to(&b) < 1e-12);
    }
}
