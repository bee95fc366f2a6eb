//! Position-only trackers (overhead people counters, 2D/3D centroid trackers) → `skeleton`
//! messages with one joint.
//!
//! Such a tracker gives one point per track and time: the head seen from above, or the
//! centroid of the person's blob, in its own units. nomen's recording has no point message: a
//! point-only track is a `skeleton` of the tracker (a camera of the registry, whose
//! `world_from_camera` places the tracker's frame) with a single joint,
//! [`TrackerConfig::joint`]: `head` for head trackers, `pelvis` for centroid trackers. The
//! joint is `tracked`, with the tracker's `confidence` if it gives one (else 1). A 2D point gets
//! the z [`TrackerConfig::z_m`] (metres, in the tracker's frame). The engine compares a
//! location tag with the joint its registry entry names (and falls back to the pelvis), so a
//! registry for a head tracker lists tags at `head`.
//!
//! Input, one point per row, as CSV (a header row, then rows; `,`, `;` or tab separated) or as
//! JSON lines (one object per line), with the same names:
//!
//! | column / key | meaning |
//! | --- | --- |
//! | `t`, `time` or `timestamp` | the time: a number in the unit of its name (`t_ms`, `t (s)`, `time_us`) or of [`TrackerConfig::time_unit`], or a date-time (`2019-09-12T14:03:21.250Z`; no zone: UTC) |
//! | `track`, `track_id` or `id` | the track, a non-negative integer |
//! | `x`, `y`, optional `z` | the point in the tracker's units, times [`TrackerConfig::scale_m_per_unit`] |
//! | optional `confidence` | the tracker's confidence in `0..=1` |
//!
//! Other columns are not read. An empty cell (CSV) or `null` (JSON) for `z` or `confidence` is
//! absent; for the others it is an error.

use crate::decoded::{Collector, Decoded, check_payload_size, for_each_line, payload_place, shift};
use crate::error::{AdapterError, Place, Result};
use crate::json;
use crate::time::parse_datetime_ns;
use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, Joint, JointObservation, Message, SkeletonObservation, TrackId};
use nomen_recording::csv::TimeUnit;
use serde_json::{Map, Value};
use std::io::BufRead;
use std::sync::Arc;

/// How a position-only tracker maps onto the session.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerConfig {
    /// The tracker's id (a camera of the registry).
    pub camera: CameraId,
    /// Metres per tracker unit (1 for metres, 0.001 for millimetres, a fitted 0.0153 for a
    /// counter's own units).
    pub scale_m_per_unit: f64,
    /// Unit of a time column whose name carries none; `None`: such a column is an error.
    pub time_unit: Option<TimeUnit>,
    /// The joint the point stands for: [`Joint::Head`] or [`Joint::Pelvis`].
    pub joint: Joint,
    /// z of a 2D point, metres in the tracker's frame.
    pub z_m: f64,
    /// Added to every time (after conversion to ns) to give session time, ns.
    pub time_offset_ns: i64,
}

const TIME_NAMES: [&str; 3] = ["t", "time", "timestamp"];
const TRACK_NAMES: [&str; 3] = ["track", "track_id", "id"];

/// Reads a tracker file: JSON lines if its first non-blank character is `{`, else CSV.
pub fn read_tracker(input: impl BufRead, source: &str, config: &TrackerConfig) -> Result<Decoded> {
    check_config(config, &Place::new(&Arc::from(source)))?;
    let source: Arc<str> = Arc::from(source);
    let mut out = Collector::default();
    let mut csv_header: Option<(Vec<String>, char)> = None;
    let mut is_json: Option<bool> = None;
    for_each_line(input, &source, |text, at| {
        // A byte-order mark (as spreadsheet programs write) is not part of the first name.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let is_json = *is_json.get_or_insert_with(|| text.starts_with('{'));
        if is_json {
            let value = json::parse(text.as_bytes(), at)?;
            return point(json::object(&value, at)?, at, config, &mut out);
        }
        let Some((names, sep)) = &csv_header else {
            let sep = [',', ';', '\t']
                .into_iter()
                .find(|c| text.contains(*c))
                .unwrap_or(',');
            let names = split(text, sep).map(|s| s.to_lowercase()).collect();
            csv_header = Some((names, sep));
            return Ok(());
        };
        let cells: Vec<&str> = split(text, *sep).collect();
        if cells.len() != names.len() {
            return Err(AdapterError::shape(
                at,
                format!("row has {} fields, the header {}", cells.len(), names.len()),
            ));
        }
        let row: Map<String, Value> = names
            .iter()
            .zip(cells)
            .map(|(n, c)| {
                let v = if c.is_empty() {
                    Value::Null
                } else {
                    Value::String(c.to_owned())
                };
                (n.clone(), v)
            })
            .collect();
        point(&row, at, config, &mut out)
    })?;
    out.into_file()
}

/// Decodes one tracker payload: one JSON object with the keys of a JSON line.
pub fn decode_tracker(payload: &[u8], config: &TrackerConfig) -> Result<Decoded> {
    let at = payload_place();
    check_config(config, &at)?;
    check_payload_size(payload, &at)?;
    let mut out = Collector::default();
    let value = json::parse(payload, &at)?;
    point(json::object(&value, &at)?, &at, config, &mut out)?;
    Ok(out.into_payload())
}

fn check_config(config: &TrackerConfig, at: &Place) -> Result<()> {
    if !(config.scale_m_per_unit.is_finite() && config.scale_m_per_unit > 0.0) {
        return Err(AdapterError::shape(
            at,
            format!(
                "scale {} m per unit is not a positive number",
                config.scale_m_per_unit
            ),
        ));
    }
    Ok(())
}

/// The cells of a CSV line, trimmed, surrounding double quotes removed.
fn split(line: &str, sep: char) -> impl Iterator<Item = &str> {
    line.split(sep).map(|c| {
        let c = c.trim();
        c.strip_prefix('"')
            .and_then(|c| c.strip_suffix('"'))
            .unwrap_or(c)
    })
}

/// The key of `row` whose name is one of [`TIME_NAMES`], with the unit its name carries
/// (`t_ms`, `t (ms)`, `t [ms]`); the names are tried in their order.
fn find_time(row: &Map<String, Value>) -> Option<(&str, Option<&str>)> {
    TIME_NAMES.iter().find_map(|name| {
        row.keys().find_map(|k| {
            let key = k.trim();
            if key.to_lowercase() == *name {
                return Some((k.as_str(), None));
            }
            let (base, unit) = if let Some(rest) = key.strip_suffix(')') {
                rest.rsplit_once('(')?
            } else if let Some(rest) = key.strip_suffix(']') {
                rest.rsplit_once('[')?
            } else {
                key.rsplit_once('_')?
            };
            let unit = unit.trim();
            (base.trim().to_lowercase() == *name && TimeUnit::parse(unit).is_some())
                .then_some((k.as_str(), Some(unit)))
        })
    })
}

/// The key of `row` (and its value) named by the first of `names` that it has.
fn find<'a>(row: &'a Map<String, Value>, names: &[&str]) -> Option<(&'a str, &'a Value)> {
    names.iter().find_map(|name| {
        row.iter()
            .find(|(k, _)| k.trim().to_lowercase() == *name)
            .map(|(k, v)| (k.as_str(), v))
    })
}

fn require<'a>(
    row: &'a Map<String, Value>,
    names: &[&str],
    at: &Place,
) -> Result<(&'a str, &'a Value)> {
    match find(row, names) {
        Some((_, Value::Null)) | None => Err(AdapterError::shape(
            at,
            format!("missing '{}' ({})", names.join("' or '"), keys(row)),
        )),
        Some(found) => Ok(found),
    }
}

/// The keys of `row` for an error about a missing one, when one of them is a key a tracker
/// writes (a time, a track, `x` or `y`); any other row's keys (the first line of a file that is
/// not a tracker's, for CSV) are not repeated.
fn keys(row: &Map<String, Value>) -> String {
    let is_tracker_key = |k: &str| {
        let base = k.split(['(', '[', '_']).next().unwrap_or(k).trim();
        TIME_NAMES.contains(&base) || TRACK_NAMES.contains(&k) || matches!(base, "x" | "y")
    };
    if row.keys().any(|k| is_tracker_key(k.as_str())) {
        format!(
            "found: {}",
            row.keys()
                .map(String::as_str)
                .collect::<Vec<_>>()
                .join(", ")
        )
    } else {
        format!(
            "none of its {} names is a tracker's t, track, x or y: not a tracker's file? Its \
             content is not shown",
            row.len()
        )
    }
}

fn point(
    row: &Map<String, Value>,
    at: &Place,
    config: &TrackerConfig,
    out: &mut Collector,
) -> Result<()> {
    let (t_key, unit) = find_time(row)
        .ok_or_else(|| AdapterError::shape(at, format!("missing the time 't' ({})", keys(row))))?;
    let t_at = at.at(t_key);
    let ns = time_ns(
        json::required(row, t_key, at)?,
        unit,
        config.time_unit,
        &t_at,
    )?;
    let (track_key, track) = require(row, &TRACK_NAMES, at)?;
    let track = json::unsigned(track, &at.at(track_key))?;
    let coordinate = |name: &str| -> Result<Option<f64>> {
        match find(row, &[name]) {
            Some((_, Value::Null)) | None => Ok(None),
            Some((k, v)) => json::number(v, &at.at(k)).map(Some),
        }
    };
    let (Some(x), Some(y)) = (coordinate("x")?, coordinate("y")?) else {
        let missing = if coordinate("x")?.is_none() { "x" } else { "y" };
        return Err(AdapterError::shape(
            at,
            format!("missing '{missing}' ({})", keys(row)),
        ));
    };
    let k = config.scale_m_per_unit;
    let z_m = coordinate("z")?.map_or(config.z_m, |z| z * k);
    let confidence = coordinate("confidence")?.unwrap_or(1.0);
    let mut joints = Joints::new();
    joints.insert(
        config.joint,
        JointObservation {
            confidence,
            ..JointObservation::tracked(Point3::new(x * k, y * k, z_m))
        },
    );
    let skeleton = SkeletonObservation {
        t: shift(ns, config.time_offset_ns, &t_at)?,
        camera: config.camera.clone(),
        track: TrackId(track),
        joints,
    };
    out.push(Message::Skeleton(Box::new(skeleton)), at)
}

/// A time cell: a number in the name's unit (else the configured one), or a date-time.
fn time_ns(
    value: &Value,
    unit: Option<&str>,
    default: Option<TimeUnit>,
    at: &Place,
) -> Result<i64> {
    let as_text = match value {
        Value::Number(n) => n.to_string(),
        Value::String(s) => s.trim().to_owned(),
        _ => return Err(AdapterError::shape(at, "expected a number or a date-time")),
    };
    if as_text.parse::<f64>().is_err() {
        return parse_datetime_ns(&as_text, 0).ok_or_else(|| {
            AdapterError::shape(
                at,
                format!("'{as_text}' is neither a number nor a date-time"),
            )
        });
    }
    let unit = match unit {
        Some(u) => TimeUnit::parse(u),
        None => default,
    }
    .ok_or_else(|| {
        AdapterError::shape(
            at,
            "the time has no unit: name it like t_s, t_ms, t_us or t_ns, or give the unit (--time-unit)",
        )
    })?;
    unit.cell_to_ns(&as_text)
        .ok_or_else(|| AdapterError::shape(at, format!("'{as_text}' is not a time")))
}
