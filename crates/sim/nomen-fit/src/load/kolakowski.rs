//! RSSI tables with tag positions (Kolakowski's `*_df.csv` layout) and anchor lists.

use crate::error::{FitError, Result};
use crate::table::{CsvText, column};
use nalgebra::Vector3;
use nomen_core::sensor::RSSI_RANGE_DBM;
use serde::{Deserialize, Serialize};

/// Which columns hold the tag position and the per-anchor RSSI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiCsvFormat {
    /// Tag x column, m.
    pub x_column: String,
    /// Tag y column, m.
    pub y_column: String,
    /// Tag z column, m; when `None` the tag is at `tag_height_m`.
    pub z_column: Option<String>,
    /// Tag height when there is no z column, m.
    pub tag_height_m: f64,
    /// One RSSI column per anchor (dBm, empty = no reading), in the order of the anchor list.
    pub rssi_columns: Vec<String>,
}

impl RssiCsvFormat {
    /// Kolakowski 2021: `,ts,x,heading,y,rssi_1..rssi_6`, tag on a lanyard at 1.3 m.
    pub fn kolakowski() -> Self {
        Self {
            x_column: "x".into(),
            y_column: "y".into(),
            z_column: None,
            tag_height_m: 1.3,
            rssi_columns: (1..=6).map(|i| format!("rssi_{i}")).collect(),
        }
    }
}

/// One row: where the tag was and what each anchor heard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiRow {
    /// Line in the source, for reports.
    pub line: u64,
    /// Tag position, m.
    pub tag_position_m: Vector3<f64>,
    /// RSSI per anchor, dBm; `None` = no reading.
    pub rssi_dbm: Vec<Option<f64>>,
}

/// An RSSI table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiRecording {
    /// Source name.
    pub name: String,
    /// Rows in file order.
    pub rows: Vec<RssiRow>,
}

/// A receiving anchor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiAnchor {
    /// The id as written in the anchor file.
    pub id: String,
    /// Position, m.
    pub position_m: Vector3<f64>,
}

/// Parses an RSSI table described by `format`.
pub fn parse_rssi_csv(text: &str, name: &str, format: &RssiCsvFormat) -> Result<RssiRecording> {
    let mut csv = CsvText::new(text, name, true);
    let headers = csv.headers()?;
    let x_col = column(&headers, &format.x_column, name)?;
    let y_col = column(&headers, &format.y_column, name)?;
    let z_col = format
        .z_column
        .as_deref()
        .map(|c| column(&headers, c, name))
        .transpose()?;
    let rssi_cols = format
        .rssi_columns
        .iter()
        .map(|c| column(&headers, c, name))
        .collect::<Result<Vec<_>>>()?;
    let mut rows = Vec::new();
    while let Some(row) = csv.next_row()? {
        row.expect_len(headers.len())?;
        let x = row.coordinate_m(x_col, &format.x_column)?;
        let y = row.coordinate_m(y_col, &format.y_column)?;
        let z = match (z_col, &format.z_column) {
            (Some(c), Some(n)) => row.coordinate_m(c, n)?,
            _ => format.tag_height_m,
        };
        let mut rssi_dbm = Vec::with_capacity(rssi_cols.len());
        for (c, n) in rssi_cols.iter().zip(&format.rssi_columns) {
            let v = row.f64_opt(*c, n)?;
            if let Some(v) = v
                && !(RSSI_RANGE_DBM.0..=RSSI_RANGE_DBM.1).contains(&v)
            {
                return Err(row.error(format!(
                    "column '{n}': {v} dBm is outside {}..={} dBm",
                    RSSI_RANGE_DBM.0, RSSI_RANGE_DBM.1
                )));
            }
            rssi_dbm.push(v);
        }
        rows.push(RssiRow {
            line: row.line,
            tag_position_m: Vector3::new(x, y, z),
            rssi_dbm,
        });
    }
    Ok(RssiRecording {
        name: name.to_owned(),
        rows,
    })
}

/// Parses an anchor list `id,x,y,z` (metres) with a header.
pub fn parse_anchors_csv(text: &str, name: &str) -> Result<Vec<RssiAnchor>> {
    let mut csv = CsvText::new(text, name, true);
    let headers = csv.headers()?;
    let cols = ["id", "x", "y", "z"]
        .map(|c| column(&headers, c, name))
        .into_iter()
        .collect::<Result<Vec<_>>>()?;
    let mut anchors = Vec::new();
    while let Some(row) = csv.next_row()? {
        row.expect_len(headers.len())?;
        let id = row.str(cols[0], "id")?.to_owned();
        if id.is_empty() {
            return Err(row.error("column 'id' is empty"));
        }
        anchors.push(RssiAnchor {
            id,
            position_m: Vector3::new(
                row.coordinate_m(cols[1], "x")?,
                row.coordinate_m(cols[2], "y")?,
                row.coordinate_m(cols[3], "z")?,
            ),
        });
    }
    if anchors.is_empty() {
        return Err(FitError::insufficient(name, "no anchors"));
    }
    Ok(anchors)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = ",ts,x,heading,y,rssi_1,rssi_2,rssi_3,rssi_4,rssi_5,rssi_6";

    #[test]
    fn empty_rssi_is_no_reading() {
        let text = format!("{HEADER}\n3,1.6e18,4.2,4.19,3.64,-52.0,-53.0,-57.5,-49.4,,\n");
        let rec = parse_rssi_csv(&text, "c.csv", &RssiCsvFormat::kolakowski()).unwrap();
        let r = &rec.rows[0];
        assert_eq!(r.rssi_dbm[4], None);
        assert_eq!(r.rssi_dbm[0], Some(-52.0));
        assert_eq!(r.tag_position_m.z, 1.3);
    }

    #[test]
    fn non_numeric_rssi_names_line_and_column() {
        let text = format!(
            "{HEADER}\n0,1.6e18,4.2,4.19,3.64,-52,-53,-57,-49,-60,-61\n1,1.6e18,4.2,4.19,3.64,-52,weak,-57,-49,-60,-61\n"
        );
        let err = parse_rssi_csv(&text, "c.csv", &RssiCsvFormat::kolakowski())
            .unwrap_err()
            .to_string();
        assert_eq!(err, "c.csv:3: column 'rssi_2': 'weak' is not a number");
    }

    #[test]
    fn centi_dbm_is_rejected() {
        let text = format!("{HEADER}\n0,1.6e18,4.2,4.19,3.64,-5200,-53,-57,-49,-60,-61\n");
        let err = parse_rssi_csv(&text, "c.csv", &RssiCsvFormat::kolakowski())
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("c.csv:2: column 'rssi_1'"), "{err}");
    }
}
