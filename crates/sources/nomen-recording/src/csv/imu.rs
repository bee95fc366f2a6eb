//! IMU CSV import.

use super::units::{AccelUnit, GyroUnit, MagUnit, TimeFormat, TimeUnit, split_unit};
use super::{CsvImport, CsvInput, CsvOptions};
use crate::error::Result;
use csv::StringRecord;
use nalgebra::Vector3;
use nomen_core::{DeviceId, ImuSample, Message};
use std::io::Read;

/// What an IMU column measures, and in which unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImuQuantity {
    /// Specific force.
    Accel(AccelUnit),
    /// Angular rate.
    Gyro(GyroUnit),
    /// Magnetic field.
    Mag(MagUnit),
}

impl ImuQuantity {
    fn slot(self) -> usize {
        match self {
            ImuQuantity::Accel(_) => 0,
            ImuQuantity::Gyro(_) => 1,
            ImuQuantity::Mag(_) => 2,
        }
    }

    /// Factor from the column's unit to nomen's (m/s², rad/s, µT).
    fn to_si(self) -> f64 {
        match self {
            ImuQuantity::Accel(u) => u.to_mps2(),
            ImuQuantity::Gyro(u) => u.to_radps(),
            ImuQuantity::Mag(u) => u.to_ut(),
        }
    }
}

/// One sensor column of an IMU CSV file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImuColumn {
    /// The column name exactly as in the file's first row.
    pub column: String,
    /// What it measures and in which unit.
    pub quantity: ImuQuantity,
    /// The sensor axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
}

/// How to read an IMU CSV file: which column holds what, in which unit, for which device.
///
/// The accelerometer needs all three axes; the gyroscope is optional (all three or none: a file
/// without gyroscope columns is an accelerometer-only device, whose samples carry no
/// `gyro_radps`); the magnetometer too (all three or none; a row whose three magnetometer cells
/// are empty has no magnetometer reading). Columns the spec does not name are ignored.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuCsvSpec {
    /// The device the samples belong to.
    pub device: DeviceId,
    /// Name of the time column.
    pub time_column: String,
    /// How the time column is read.
    pub time_format: TimeFormat,
    /// Added to every time after conversion (maps the file's clock onto the session clock).
    pub time_offset_ns: i64,
    /// The sensor columns.
    pub columns: Vec<ImuColumn>,
}

impl ImuCsvSpec {
    /// Infers the spec from column names that carry their units, e.g. the x-io export
    /// `Time (s), Gyroscope X (deg/s), ..., Accelerometer X (g), ..., Magnetometer X (uT), ...`
    /// or `t_ms, accel_x_mps2, gyro_x_dps, ...`.
    ///
    /// A column is an IMU column when a word of its name starts with `acc`, `gyro` or `mag` and
    /// an axis `x`/`y`/`z` follows (as its own word or glued on: `gyroX`); the time column is
    /// `t`, `time` or `timestamp`. Other columns are ignored. A quantity column without a
    /// recognised unit is an error: units are never guessed.
    pub fn infer(device: DeviceId, column_names: &[String]) -> std::result::Result<Self, String> {
        let (time, columns) = infer_columns(column_names, &[])?;
        let (name, unit) = time.ok_or_else(no_time_column)?;
        let unit = unit
            .as_deref()
            .and_then(TimeUnit::parse)
            .ok_or_else(|| format!("time column '{name}' has no unit such as '(s)' or '_ms'"))?;
        Ok(Self {
            device,
            time_column: name,
            time_format: TimeFormat::Epoch(unit),
            time_offset_ns: 0,
            columns,
        })
    }
}

fn no_time_column() -> String {
    "no time column ('t', 'time' or 'timestamp' with a unit)".to_owned()
}

/// The time column (name, unit if given) and the sensor columns of a file whose columns are
/// named `column_names`, with units from a units file (`given`, per column; missing entries
/// give none) winning over the names'.
#[allow(clippy::type_complexity)]
fn infer_columns(
    column_names: &[String],
    given: &[Option<String>],
) -> std::result::Result<(Option<(String, Option<String>)>, Vec<ImuColumn>), String> {
    let any_unit = |u: &str| {
        TimeUnit::parse(u).is_some()
            || AccelUnit::parse(u).is_some()
            || GyroUnit::parse(u).is_some()
            || MagUnit::parse(u).is_some()
    };
    let mut time = None;
    let mut columns = Vec::new();
    for (i, name) in column_names.iter().enumerate() {
        let (base, unit) = split_unit(name, any_unit);
        let unit = match given.get(i) {
            Some(Some(u)) => Some(u.as_str()),
            _ => unit,
        };
        if matches!(base.as_str(), "t" | "time" | "timestamp") {
            time = Some((name.clone(), unit.map(str::to_owned)));
            continue;
        }
        let Some((slot, axis)) = quantity_and_axis(&base) else {
            continue;
        };
        let unit = unit.unwrap_or_default();
        let quantity = match slot {
            0 => AccelUnit::parse(unit).map(ImuQuantity::Accel),
            1 => GyroUnit::parse(unit).map(ImuQuantity::Gyro),
            _ => MagUnit::parse(unit).map(ImuQuantity::Mag),
        }
        .ok_or_else(|| {
            let example = ["(m/s^2) or (g)", "(rad/s) or (deg/s)", "(uT) or (gauss)"][slot];
            if unit.is_empty() {
                format!(
                    "column '{name}' has no unit: add one such as {example}, or give it in a \
                     units file"
                )
            } else {
                format!("column '{name}': unknown unit '{unit}', expected e.g. {example}")
            }
        })?;
        columns.push(ImuColumn {
            column: name.clone(),
            quantity,
            axis,
        });
    }
    Ok((time, columns))
}

/// Which quantity (0 accel, 1 gyro, 2 mag) and axis a lower-case base column name names.
fn quantity_and_axis(base: &str) -> Option<(usize, usize)> {
    let words: Vec<&str> = base
        .split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    let axis_of = |s: &str| match s {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    };
    let (i, slot) = words.iter().enumerate().find_map(|(i, w)| {
        let slot = if w.starts_with("acc") {
            0
        } else if w.starts_with("gyr") {
            1
        } else if w.starts_with("mag") {
            2
        } else {
            return None;
        };
        Some((i, slot))
    })?;
    let word = words.get(i)?;
    // Axis glued on (`accx`, `gyroz`), as long as the word is not itself a full name ending in
    // x/y/z.
    if let Some(last) = word.get(word.len().saturating_sub(1)..)
        && let Some(axis) = axis_of(last)
        && matches!(
            &word[..word.len() - 1],
            "acc" | "accel" | "gyr" | "gyro" | "mag"
        )
    {
        return Some((slot, axis));
    }
    words[i + 1..]
        .iter()
        .find_map(|w| axis_of(w))
        .map(|a| (slot, a))
}

/// Imports an IMU CSV file with an explicit spec.
pub fn import_imu(
    input: impl Read,
    source: &str,
    spec: &ImuCsvSpec,
    options: &CsvOptions,
) -> Result<CsvImport> {
    let mut csv = CsvInput::new(input, source, options)?;
    csv.time_format = Some(spec.time_format);
    import_with(csv, spec)
}

/// Imports an IMU CSV file whose column names (or units file) give their units, as
/// [`ImuCsvSpec::infer`] reads them; a time column without a unit takes the options' or, when
/// its first cell is one, is read as date-times. Returns the inferred spec too.
pub fn import_imu_auto(
    input: impl Read,
    source: &str,
    device: DeviceId,
    options: &CsvOptions,
) -> Result<(ImuCsvSpec, CsvImport)> {
    let mut csv = CsvInput::new(input, source, options)?;
    let (time, columns) = infer_columns(&csv.headers, &csv.units).map_err(|e| csv.error(1, &e))?;
    let (time_column, unit) = time.ok_or_else(|| csv.error(1, &no_time_column()))?;
    let col = csv
        .headers
        .iter()
        .position(|h| *h == time_column)
        .unwrap_or_default();
    let time_format = csv.time_format(col, unit.as_deref(), None)?;
    let spec = ImuCsvSpec {
        device,
        time_column,
        time_format,
        time_offset_ns: 0,
        columns,
    };
    let imported = import_with(csv, &spec)?;
    Ok((spec, imported))
}

fn import_with<R: Read>(mut csv: CsvInput<R>, spec: &ImuCsvSpec) -> Result<CsvImport> {
    let find_exact = |name: &str| -> Result<usize> {
        csv.headers.iter().position(|h| h == name).ok_or_else(|| {
            csv.error(
                1,
                &format!("missing column '{name}' ({})", csv.columns_listing()),
            )
        })
    };
    let time_col = find_exact(&spec.time_column)?;
    // cols[slot][axis] = (column index, factor to SI).
    let mut cols: [[Option<(usize, f64)>; 3]; 3] = [[None; 3]; 3];
    for c in &spec.columns {
        let idx = find_exact(&c.column)?;
        let slot = c.quantity.slot();
        let cell = cols
            .get_mut(slot)
            .and_then(|row| row.get_mut(c.axis))
            .ok_or_else(|| {
                csv.error(
                    1,
                    &format!("column '{}': axis {} is not 0, 1 or 2", c.column, c.axis),
                )
            })?;
        if cell.is_some() {
            return Err(csv.error(
                1,
                &format!(
                    "column '{}' repeats an axis already read from another column",
                    c.column
                ),
            ));
        }
        *cell = Some((idx, c.quantity.to_si()));
    }
    let names = ["accelerometer", "gyroscope", "magnetometer"];
    let mut full = [None; 3];
    for (slot, row) in cols.iter().enumerate() {
        let n = row.iter().flatten().count();
        full[slot] = match (n, slot) {
            (3, _) => Some([row[0], row[1], row[2]].map(|c| c.unwrap_or((0, 0.0)))),
            (0, 1 | 2) => None,
            _ => {
                return Err(csv.error(
                    1,
                    &format!("the {} needs x, y and z columns, found {n}", names[slot]),
                ));
            }
        };
    }
    let Some(accel) = full[0] else {
        return Err(csv.error(1, "the accelerometer needs x, y and z columns"));
    };
    let gyro = full[1];
    let mag = full[2];

    let mut record = StringRecord::new();
    while let Some(line) = csv.next_row(&mut record)? {
        let t = csv.time(
            &record,
            time_col,
            spec.time_format,
            spec.time_offset_ns,
            line,
        )?;
        let vector = |cols: [(usize, f64); 3]| -> Result<Vector3<f64>> {
            let mut v = Vector3::zeros();
            for (axis, (col, k)) in cols.into_iter().enumerate() {
                v[axis] = csv.number(&record, col, line)? * k;
            }
            Ok(v)
        };
        let accel_mps2 = vector(accel)?;
        let gyro_radps = gyro.map(vector).transpose()?;
        let mag_ut = match mag {
            Some(m)
                if m.iter()
                    .all(|(c, _)| record.get(*c).unwrap_or_default().is_empty()) =>
            {
                None
            }
            Some(m) => Some(vector(m)?),
            None => None,
        };
        let msg = Message::Imu(ImuSample {
            t,
            device: spec.device.clone(),
            accel_mps2,
            gyro_radps,
            mag_ut,
            orientation_wxyz: None,
        });
        csv.push(msg, line)?;
    }
    Ok(csv.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xio_and_snake_case_names_are_recognised() {
        assert_eq!(quantity_and_axis("gyroscope x"), Some((1, 0)));
        assert_eq!(quantity_and_axis("accelerometer z"), Some((0, 2)));
        assert_eq!(quantity_and_axis("magnetometer y"), Some((2, 1)));
        assert_eq!(quantity_and_axis("accel_x"), Some((0, 0)));
        assert_eq!(quantity_and_axis("gyroz"), Some((1, 2)));
        assert_eq!(quantity_and_axis("temperature"), None);
    }

    #[test]
    fn a_gyro_column_without_unit_is_refused() {
        let names: Vec<String> = ["t_s", "gyro_x", "gyro_y (rad/s)"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let err = ImuCsvSpec::infer(DeviceId::new("d"), &names).unwrap_err();
        assert!(err.contains("'gyro_x' has no unit"), "{err}");
    }
}
