//! Readers for vendor formats (Azure Kinect body tracking, position-only trackers, Pozyx and Sewio RTLS, Impinj and Zebra RFID) that turn files and MQTT payloads into nomen recording messages.
//!
//! Every reader is sans-IO: it takes bytes (`BufRead`/`Read` for a file, `&[u8]` for one MQTT
//! payload) and returns [`Decoded`] — the messages and what was skipped on purpose, per reason —
//! or an [`AdapterError`] that names the input, the line and the item (`tags.jsonl:3:
//! [1].data.coordinates: missing field 'z'`). Nothing panics on data; lines and payloads longer
//! than [`MAX_LINE_BYTES`] and documents longer than [`azure_kinect::MAX_DOCUMENT_BYTES`] are
//! refused. Every message passes [`nomen_core::Message::validate`]; a file's messages come
//! sorted by time, two messages of one source at one time refused.
//!
//! | format | module | file reader | payload decoder | messages |
//! | --- | --- | --- | --- | --- |
//! | Azure Kinect offline processor JSON | [`azure_kinect`] | [`read_azure_kinect`] | [`decode_azure_kinect_frame`] | `skeleton` |
//! | position-only tracker (CSV, JSON lines) | [`tracker`] | [`read_tracker`] | [`decode_tracker`] | `skeleton` (one joint) |
//! | Pozyx MQTT positioning stream | [`rtls`] | [`read_pozyx`] | [`decode_pozyx`] | `rtls_fix` |
//! | Sewio WebSocket / UDP feed | [`rtls`] | [`read_sewio`] | [`decode_sewio`] | `rtls_fix` |
//! | Impinj Speedway Connect JSON | [`rfid`] | [`read_impinj`] | [`decode_impinj`] | `rssi` |
//! | Zebra FX IoT Connector data events | [`rfid`] | [`read_zebra`] | [`decode_zebra`] | `rssi` |
//!
//! Units are converted once, here: millimetres to metres (Kinect, Pozyx), a tracker's units by
//! its scale, degrees to radians (Zebra phase). Times become nanoseconds: Unix-epoch times for
//! the RTLS and RFID feeds, device time for the Kinect, plus a configured offset.
//!
//! ```
//! use nomen_adapters::{RtlsConfig, decode_pozyx};
//! use nomen_core::Message;
//!
//! let payload = br#"[{"tagId":"30331","timestamp":1615984968.5,"success":true,
//!     "data":{"coordinates":{"x":1200,"y":-350,"z":1100}}}]"#;
//! let decoded = decode_pozyx(payload, &RtlsConfig::default()).unwrap();
//! let Message::RtlsFix(fix) = &decoded.messages[0] else { unreachable!() };
//! assert_eq!(fix.position_m.x, 1.2); // millimetres to metres
//! ```

pub mod azure_kinect;
mod decoded;
mod error;
mod json;
pub mod rfid;
pub mod rtls;
pub mod time;
pub mod tracker;

pub use azure_kinect::{AzureKinectConfig, decode_azure_kinect_frame, read_azure_kinect};
pub use decoded::{Decoded, MAX_LINE_BYTES, Skipped};
pub use error::{AdapterError, Place, Result};
pub use rfid::{RfidConfig, decode_impinj, decode_zebra, read_impinj, read_zebra};
pub use rtls::{RtlsConfig, decode_pozyx, decode_sewio, read_pozyx, read_sewio};
pub use tracker::{TrackerConfig, decode_tracker, read_tracker};
