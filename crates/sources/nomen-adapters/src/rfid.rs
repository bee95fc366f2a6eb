//! RFID reader tag reports → `rssi` messages: Impinj Speedway Connect and the Zebra FX IoT
//! Connector.
//!
//! **Impinj Speedway Connect**, inventory mode, JSON output
//! (<https://support.impinj.com/hc/en-us/articles/360000044739-Impinj-Speedway-Connect-on-reader-software-Data-Integration>):
//! one object per tag report,
//! `{"antennaPort", "epc", "tid", "firstSeenTimestamp", "peakRssi", "isHeartBeat"}`, with the
//! time an RFC 3339 date-time (`2018-06-14T00:15:54.36879Z`) and `peakRssi` in dBm. Heartbeats
//! (`"isHeartBeat": true`) are skipped and counted; `tid` is not read. The location and
//! direction modes' reports are other shapes, not read here.
//!
//! **Zebra FX IoT Connector** data events
//! (<https://zebradevs.github.io/rfid-ziotc-docs/>, tag metadata as described in
//! <https://zebradevs.github.io/rfid-ziotc-docs/migration/RFIDAPI3/tagstorage.html>):
//! `{"data": {"idHex", "antenna", "peakRssi", "phase", "channel", "reads", "eventNum", "format"},
//! "timestamp": "2023-04-13T11:49:33.809+0000", "type": "SIMPLE"}`. `peakRssi` is dBm, `phase`
//! degrees (reported only when every read is reported). The reader must report `ANTENNA` and
//! `RSSI` (its `tagMetaData`); an event without them is an error. `channel`, `reads`,
//! `eventNum`, `TID`/`USER` data are not read.
//!
//! Both: the tag is the EPC in upper-case hex (`E28011606000020528F904FA`), so that one tag
//! has one id whichever reader saw it. The antenna is `<reader>/<port>`
//! ([`RfidConfig::reader`]), the id the registry's antennas must carry. An MQTT payload or a
//! line may hold one report or an array of them. `t` is the report's time in Unix-epoch
//! nanoseconds plus [`RfidConfig::time_offset_ns`].

use crate::decoded::{Collector, Decoded, check_payload_size, for_each_line, payload_place, shift};
use crate::error::{AdapterError, Place, Result};
use crate::json;
use crate::time::parse_datetime_ns;
use nomen_core::{AntennaId, Message, RssiRead, TagId};
use serde_json::{Map, Value};
use std::io::BufRead;
use std::sync::Arc;

/// How an RFID reader's reports map onto the session.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RfidConfig {
    /// The reader's name: antennas are `<reader>/<port>`.
    pub reader: String,
    /// Added to every report time (Unix-epoch ns) to give session time, ns.
    pub time_offset_ns: i64,
}

/// Reason counted for an Impinj heartbeat.
pub const SKIP_HEARTBEAT: &str = "heartbeats";

/// Reads a file of Impinj Speedway Connect JSON reports, one per line.
pub fn read_impinj(input: impl BufRead, source: &str, config: &RfidConfig) -> Result<Decoded> {
    read_lines(input, source, config, impinj_report)
}

/// Decodes one Impinj Speedway Connect payload (a report or an array of reports).
pub fn decode_impinj(payload: &[u8], config: &RfidConfig) -> Result<Decoded> {
    decode_payload(payload, config, impinj_report)
}

/// Reads a file of Zebra IoT Connector data events, one per line.
pub fn read_zebra(input: impl BufRead, source: &str, config: &RfidConfig) -> Result<Decoded> {
    read_lines(input, source, config, zebra_event)
}

/// Decodes one Zebra IoT Connector data-event payload (an event or an array of events).
pub fn decode_zebra(payload: &[u8], config: &RfidConfig) -> Result<Decoded> {
    decode_payload(payload, config, zebra_event)
}

type ReportFn = fn(&Map<String, Value>, &Place, &RfidConfig, &mut Collector) -> Result<()>;

fn read_lines(
    input: impl BufRead,
    source: &str,
    config: &RfidConfig,
    each: ReportFn,
) -> Result<Decoded> {
    let source: Arc<str> = Arc::from(source);
    let mut out = Collector::default();
    for_each_line(input, &source, |text, at| {
        for (at, report) in json::objects(&json::parse(text.as_bytes(), at)?, at)? {
            each(report, &at, config, &mut out)?;
        }
        Ok(())
    })?;
    out.into_file()
}

fn decode_payload(payload: &[u8], config: &RfidConfig, each: ReportFn) -> Result<Decoded> {
    let at = payload_place();
    check_payload_size(payload, &at)?;
    let mut out = Collector::default();
    for (at, report) in json::objects(&json::parse(payload, &at)?, &at)? {
        each(report, &at, config, &mut out)?;
    }
    Ok(out.into_payload())
}

fn impinj_report(
    report: &Map<String, Value>,
    at: &Place,
    config: &RfidConfig,
    out: &mut Collector,
) -> Result<()> {
    if let Some(v) = json::optional(report, "isHeartBeat")
        && json::boolean(v, &at.at("isHeartBeat"))?
    {
        out.skipped.add(SKIP_HEARTBEAT);
        return Ok(());
    }
    let epc = json::text(json::required(report, "epc", at)?, &at.at("epc"))?;
    let port = json::unsigned(
        json::required(report, "antennaPort", at)?,
        &at.at("antennaPort"),
    )?;
    let rssi_dbm = json::number(json::required(report, "peakRssi", at)?, &at.at("peakRssi"))?;
    let ns = report_time(report, "firstSeenTimestamp", at)?;
    let read = RssiRead {
        t: shift(ns, config.time_offset_ns, &at.at("firstSeenTimestamp"))?,
        tag: TagId::new(epc.to_ascii_uppercase()),
        antenna: AntennaId::new(format!("{}/{port}", config.reader)),
        rssi_dbm,
        phase_rad: None,
    };
    out.push(Message::Rssi(read), at)
}

fn zebra_event(
    event: &Map<String, Value>,
    at: &Place,
    config: &RfidConfig,
    out: &mut Collector,
) -> Result<()> {
    let data_at = at.at("data");
    let data = json::object(json::required(event, "data", at)?, &data_at)?;
    let epc = json::text(
        json::required(data, "idHex", &data_at)?,
        &data_at.at("idHex"),
    )?;
    let metadata = |name: &str| {
        json::required(data, name, &data_at).map_err(|_| {
            AdapterError::shape(
                &data_at,
                format!(
                    "missing field '{name}' (the reader reports it when ANTENNA and RSSI are in \
                     its tagMetaData)"
                ),
            )
        })
    };
    let port = json::unsigned(metadata("antenna")?, &data_at.at("antenna"))?;
    let rssi_dbm = json::number(metadata("peakRssi")?, &data_at.at("peakRssi"))?;
    let phase_rad = match json::optional(data, "phase") {
        // The IoT Connector reports phase in degrees.
        Some(v) => Some(json::number(v, &data_at.at("phase"))?.to_radians()),
        None => None,
    };
    let ns = report_time(event, "timestamp", at)?;
    let read = RssiRead {
        t: shift(ns, config.time_offset_ns, &at.at("timestamp"))?,
        tag: TagId::new(epc.to_ascii_uppercase()),
        antenna: AntennaId::new(format!("{}/{port}", config.reader)),
        rssi_dbm,
        phase_rad,
    };
    out.push(Message::Rssi(read), at)
}

/// The date-time in field `name`, Unix-epoch ns.
fn report_time(obj: &Map<String, Value>, name: &str, at: &Place) -> Result<i64> {
    let t_at = at.at(name);
    let stamp = json::text(json::required(obj, name, at)?, &t_at)?;
    parse_datetime_ns(stamp, 0).ok_or_else(|| {
        AdapterError::shape(
            &t_at,
            format!("'{stamp}' is not a date-time like 2018-06-14T00:15:54.36879Z"),
        )
    })
}
