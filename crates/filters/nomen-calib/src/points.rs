//! Point pairs for calibration from known points (Belmonte-Hernández's tool: 6–10 points
//! measured in both frames).
//!
//! Text format: a header line naming six columns, then one pair a line, comma-separated, in
//! metres. The header must contain `source_x, source_y, source_z, target_x, target_y,
//! target_z` in any order (`camera_*` and `world_*` are accepted as aliases). Blank lines and
//! lines starting with `#` are skipped.

use crate::error::{CalibError, Result};
use nalgebra::Point3;
use nomen_core::bounded::{KIB_BYTES, Limits, MIB_BYTES};

/// The limits a point-pair file is read within: lines of at most 64 KiB, 16 MiB in all
/// (a pair is a line of six numbers; calibrations use 6 to 10 pairs).
pub const POINTS_LIMITS: Limits = Limits::text("a point-pair file", 64 * KIB_BYTES, 16 * MIB_BYTES);

/// A pair of the same physical point in two frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointPair {
    /// In the source frame (the camera), m.
    pub source_m: Point3<f64>,
    /// In the target frame (the world / RTLS), m.
    pub target_m: Point3<f64>,
    /// One-based line number in the input.
    pub line: usize,
}

const NAMES: [[&str; 2]; 6] = [
    ["source_x", "camera_x"],
    ["source_y", "camera_y"],
    ["source_z", "camera_z"],
    ["target_x", "world_x"],
    ["target_y", "world_y"],
    ["target_z", "world_z"],
];

/// Parses the point-pair text; errors read `source_name:line: what is wrong`.
pub fn parse_point_pairs(text: &str, source_name: &str) -> Result<Vec<PointPair>> {
    let err = |line: usize, reason: String| CalibError::Parse {
        source_name: source_name.to_owned(),
        line,
        reason,
    };
    let mut columns: Option<[usize; 6]> = None;
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let s = raw.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = s.split(',').map(str::trim).collect();
        let Some(cols) = columns else {
            let mut cols = [0usize; 6];
            for (k, names) in NAMES.iter().enumerate() {
                cols[k] = fields
                    .iter()
                    .position(|f| names.contains(&f.to_ascii_lowercase().as_str()))
                    .ok_or_else(|| err(line, format!("header has no column '{}'", names[0])))?;
            }
            columns = Some(cols);
            continue;
        };
        let mut v = [0.0; 6];
        for (k, &c) in cols.iter().enumerate() {
            let f = fields.get(c).ok_or_else(|| {
                err(
                    line,
                    format!("expected {} fields, found {}", c + 1, fields.len()),
                )
            })?;
            let x: f64 = f.parse().map_err(|_| {
                err(
                    line,
                    format!("column '{}': '{f}' is not a number", NAMES[k][0]),
                )
            })?;
            if !x.is_finite() {
                return Err(err(line, format!("column '{}' is not finite", NAMES[k][0])));
            }
            if x.abs() > nomen_core::skeleton::MAX_COORDINATE_M {
                return Err(err(
                    line,
                    format!(
                        "column '{}' = {f} m is beyond any room (at most {} m from the origin)",
                        NAMES[k][0],
                        nomen_core::skeleton::MAX_COORDINATE_M
                    ),
                ));
            }
            v[k] = x;
        }
        out.push(PointPair {
            source_m: Point3::new(v[0], v[1], v[2]),
            target_m: Point3::new(v[3], v[4], v[5]),
            line,
        });
    }
    if columns.is_none() {
        return Err(err(1, "no header line".into()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_are_read_in_any_column_order() {
        let text = "# surveyed\nworld_x,world_y,world_z,camera_x,camera_y,camera_z\n1,2,3,4,5,6\n\n7,8,9,10,11,12\n";
        let pairs = parse_point_pairs(text, "p.csv").unwrap();
        assert_eq!(pairs.len(), 2);
        assert_eq!(pairs[0].source_m, Point3::new(4.0, 5.0, 6.0));
        assert_eq!(pairs[0].target_m, Point3::new(1.0, 2.0, 3.0));
        assert_eq!(pairs[1].line, 5);
    }

    #[test]
    fn bad_number_names_file_line_and_column() {
        let text = "source_x,source_y,source_z,target_x,target_y,target_z\n1,2,x,4,5,6\n";
        let e = parse_point_pairs(text, "p.csv").unwrap_err().to_string();
        assert!(e.starts_with("p.csv:2: column 'source_z'"), "{e}");
        // Finite but beyond any room: named, not dropped later as an outlier.
        let text =
            "source_x,source_y,source_z,target_x,target_y,target_z\n1,2,3,4,5,6\n1,2,3,1e300,5,6\n";
        let e = parse_point_pairs(text, "p.csv").unwrap_err().to_string();
        assert!(
            e.starts_with("p.csv:3: column 'target_x' = 1e300 m is beyond any room"),
            "{e}"
        );
    }
}
