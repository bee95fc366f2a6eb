//! RTLS position feeds → `rtls_fix` messages: Pozyx's MQTT positioning stream and Sewio's
//! WebSocket / UDP feed.
//!
//! **Pozyx** (<https://docs.pozyx.io/enterprise/mqtt-data-structure>): each MQTT packet on the
//! `tags` topic is an array of tag position updates
//! `{"version", "tagId", "timestamp", "success", "data": {"coordinates": {"x", "y", "z"}, ...}}`.
//! `timestamp` is Unix-epoch seconds (a float), coordinates are millimetres in the Pozyx
//! setup's frame. An update with `"success": false` carries no position: it is skipped and
//! counted. `data.metrics`, `data.tagData` (IMU, pressure), `data.anchorData` (RSS per anchor)
//! and `errorCode` are not read.
//!
//! **Sewio** (<https://docs.sewio.net/docs/api-payload-examples-3244434.html>): a WebSocket
//! message `{"body": {"id", "address", "datastreams": [...]}, "resource": "/feeds/<id>"}` or the
//! same object without `body` from the UDP stream. The datastreams `posX`, `posY` and, in 3D
//! setups, `posZ` hold metres as strings (`" 4.00"`), each with its time `at`
//! (`2017-09-06 15:00:12.142`, UTC). The tag is the feed `id`. `clr`, the position's confidence
//! radius in metres (<https://docs.sewio.net/docs/position-confidence-level-3244634.html>),
//! becomes the fix's covariance, `clr²` on each axis (a radius read as a standard deviation; a
//! one-anchor fix has `clr` 9999). Messages without `posX`/`posY` (battery, zones, buttons) are
//! skipped and counted; `numberOfAnchors`, `plan_reference` and sensor streams are not read.
//!
//! Both: the fix's `t` is the vendor's time in Unix-epoch nanoseconds plus
//! [`RtlsConfig::time_offset_ns`]. A fix without a z (a 2D setup) gets [`RtlsConfig::z_m`].

use crate::decoded::{Collector, Decoded, check_payload_size, for_each_line, payload_place, shift};
use crate::error::{AdapterError, Place, Result};
use crate::json;
use crate::time::{epoch_secs_to_ns, parse_datetime_ns};
use nalgebra::Point3;
use nomen_core::{Message, RtlsFix, TagId};
use serde_json::{Map, Value};
use std::io::BufRead;
use std::sync::Arc;

/// How RTLS feeds map onto the session.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RtlsConfig {
    /// Added to every vendor time (Unix-epoch ns) to give session time, ns.
    pub time_offset_ns: i64,
    /// The z of a fix the system gives in 2D, in the RTLS frame, m.
    pub z_m: f64,
}

/// Reason counted for a Pozyx update with `"success": false`.
pub const SKIP_UNSUCCESSFUL: &str = "unsuccessful fixes (success = false)";
/// Reason counted for a Sewio message that carries no position.
pub const SKIP_NOT_A_POSITION: &str = "messages without a position (no posX/posY)";

/// Reads a file of Pozyx MQTT payloads, one per line (as `mosquitto_sub -t tags` prints them).
pub fn read_pozyx(input: impl BufRead, source: &str, config: &RtlsConfig) -> Result<Decoded> {
    read_lines(input, source, config, pozyx_payload)
}

/// Decodes one Pozyx MQTT payload (an array of updates, or one update).
pub fn decode_pozyx(payload: &[u8], config: &RtlsConfig) -> Result<Decoded> {
    decode_payload(payload, config, pozyx_payload)
}

/// Reads a file of Sewio WebSocket (or UDP) messages, one per line.
pub fn read_sewio(input: impl BufRead, source: &str, config: &RtlsConfig) -> Result<Decoded> {
    read_lines(input, source, config, sewio_payload)
}

/// Decodes one Sewio WebSocket or UDP message.
pub fn decode_sewio(payload: &[u8], config: &RtlsConfig) -> Result<Decoded> {
    decode_payload(payload, config, sewio_payload)
}

type PayloadFn = fn(&Value, &Place, &RtlsConfig, &mut Collector) -> Result<()>;

fn read_lines(
    input: impl BufRead,
    source: &str,
    config: &RtlsConfig,
    each: PayloadFn,
) -> Result<Decoded> {
    let source: Arc<str> = Arc::from(source);
    let mut out = Collector::default();
    for_each_line(input, &source, |text, at| {
        each(&json::parse(text.as_bytes(), at)?, at, config, &mut out)
    })?;
    out.into_file()
}

fn decode_payload(payload: &[u8], config: &RtlsConfig, each: PayloadFn) -> Result<Decoded> {
    let at = payload_place();
    check_payload_size(payload, &at)?;
    let mut out = Collector::default();
    each(&json::parse(payload, &at)?, &at, config, &mut out)?;
    Ok(out.into_payload())
}

fn pozyx_payload(
    value: &Value,
    at: &Place,
    config: &RtlsConfig,
    out: &mut Collector,
) -> Result<()> {
    for (at, update) in json::objects(value, at)? {
        let tag = json::id(json::required(update, "tagId", &at)?, &at.at("tagId"))?;
        let success = match json::optional(update, "success") {
            Some(v) => json::boolean(v, &at.at("success"))?,
            None => true,
        };
        if !success {
            out.skipped.add(SKIP_UNSUCCESSFUL);
            continue;
        }
        let t_at = at.at("timestamp");
        let secs = json::number(json::required(update, "timestamp", &at)?, &t_at)?;
        let ns = epoch_secs_to_ns(secs)
            .ok_or_else(|| AdapterError::shape(&t_at, format!("{secs} is not a time")))?;
        let data_at = at.at("data");
        let data = json::object(json::required(update, "data", &at)?, &data_at)?;
        let c_at = data_at.at("coordinates");
        let coordinates = json::object(json::required(data, "coordinates", &data_at)?, &c_at)?;
        let mut p_m = [0.0, 0.0, config.z_m];
        for (v, axis) in p_m.iter_mut().zip(["x", "y", "z"]) {
            // Pozyx coordinates are millimetres; a 2D setup's update may leave z out.
            let value = match (axis, coordinates.get(axis)) {
                ("z", None | Some(Value::Null)) => continue,
                _ => json::required(coordinates, axis, &c_at)?,
            };
            *v = json::number(value, &c_at.at(axis))? / 1000.0;
        }
        let fix = RtlsFix {
            t: shift(ns, config.time_offset_ns, &t_at)?,
            tag: TagId::new(tag),
            position_m: Point3::from(p_m),
            quality: None,
            covariance_m2: None,
        };
        out.push(Message::RtlsFix(fix), &at)?;
    }
    Ok(())
}

fn sewio_payload(
    value: &Value,
    at: &Place,
    config: &RtlsConfig,
    out: &mut Collector,
) -> Result<()> {
    let outer = json::object(value, at)?;
    let (feed, at) = match json::optional(outer, "body") {
        Some(body) => {
            let at = at.at("body");
            (json::object(body, &at)?, at)
        }
        None => (outer, at.clone()),
    };
    let tag = json::id(json::required(feed, "id", &at)?, &at.at("id"))?;
    let ds_at = at.at("datastreams");
    let Some(streams) = json::optional(feed, "datastreams") else {
        out.skipped.add(SKIP_NOT_A_POSITION);
        return Ok(());
    };
    let Value::Array(streams) = streams else {
        return Err(AdapterError::shape(
            &ds_at,
            "expected an array of datastreams",
        ));
    };
    let find = |name: &str| -> Result<Option<(Place, &Map<String, Value>)>> {
        for (i, s) in streams.iter().enumerate() {
            let s_at = ds_at.at(format!("[{i}]"));
            let s = json::object(s, &s_at)?;
            if json::optional(s, "id").and_then(Value::as_str) == Some(name) {
                return Ok(Some((s_at, s)));
            }
        }
        Ok(None)
    };
    let value = |stream: &(Place, &Map<String, Value>)| -> Result<f64> {
        let (s_at, s) = stream;
        json::number(
            json::required(s, "current_value", s_at)?,
            &s_at.at("current_value"),
        )
    };
    let (x, y) = match (find("posX")?, find("posY")?) {
        (None, None) => {
            out.skipped.add(SKIP_NOT_A_POSITION);
            return Ok(());
        }
        (Some(x), Some(y)) => (x, y),
        (Some(_), None) => return Err(AdapterError::shape(&ds_at, "posX without posY")),
        (None, Some(_)) => return Err(AdapterError::shape(&ds_at, "posY without posX")),
    };
    let z_m = match find("posZ")? {
        Some(z) => value(&z)?,
        None => config.z_m,
    };
    let t_at = x.0.at("at");
    let stamp = json::text(json::required(x.1, "at", &x.0)?, &t_at)?;
    let ns = parse_datetime_ns(stamp, 0).ok_or_else(|| {
        AdapterError::shape(
            &t_at,
            format!("'{stamp}' is not a date-time like 2017-09-06 15:00:12.142"),
        )
    })?;
    let covariance_m2 = match find("clr")? {
        Some(clr) => {
            let r_m = value(&clr)?;
            if r_m < 0.0 {
                return Err(AdapterError::shape(&clr.0, format!("negative clr {r_m}")));
            }
            let v = r_m * r_m;
            Some([[v, 0.0, 0.0], [0.0, v, 0.0], [0.0, 0.0, v]])
        }
        None => None,
    };
    let fix = RtlsFix {
        t: shift(ns, config.time_offset_ns, &t_at)?,
        tag: TagId::new(tag),
        position_m: Point3::new(value(&x)?, value(&y)?, z_m),
        quality: None,
        covariance_m2,
    };
    out.push(Message::RtlsFix(fix), &at)
}
