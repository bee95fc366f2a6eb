//! The header line of a recording.

use crate::error::{Pos, RecordingError, Result};
use nomen_core::Registry;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The `format` value of every nomen recording header.
pub const FORMAT_NAME: &str = "nomen-recording";

/// The format version this crate reads and writes (see `FORMAT.md`).
pub const FORMAT_VERSION: u32 = 1;

/// Line 1 of a recording: format version, the registry the messages refer to, free-form metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Format version; [`FORMAT_VERSION`] for everything this crate writes.
    pub version: u32,
    /// The registry that every id in the recording must be listed in, or `None` for a file that
    /// carries no registry (engine results, converted data): its ids are not checked.
    pub registry: Option<Registry>,
    /// Free-form metadata: generator, seed, scene name, ... Keys are written sorted.
    pub meta: Map<String, Value>,
}

impl Header {
    /// A version-1 header whose messages are checked against `registry`.
    pub fn new(registry: Registry) -> Self {
        Self {
            version: FORMAT_VERSION,
            registry: Some(registry),
            meta: Map::new(),
        }
    }

    /// A version-1 header without a registry: readers do not check ids (`"registry":null`).
    pub fn without_registry() -> Self {
        Self {
            version: FORMAT_VERSION,
            registry: None,
            meta: Map::new(),
        }
    }

    /// Adds one metadata entry (builder style).
    pub fn with_meta(mut self, key: impl Into<String>, value: impl Into<Value>) -> Self {
        self.meta.insert(key.into(), value.into());
        self
    }

    /// The header as one JSON line, without the newline.
    pub fn to_json_line(&self) -> String {
        let raw = RawHeaderOut {
            kind: "header",
            format: FORMAT_NAME,
            version: self.version,
            registry: self.registry.as_ref(),
            meta: &self.meta,
        };
        // Serialising plain structs and maps with string keys into a String cannot fail.
        serde_json::to_string(&raw).unwrap_or_default()
    }

    /// Parses and checks a header line (`at` is used for errors).
    pub(crate) fn parse(line: &[u8], at: &Pos) -> Result<Self> {
        let bad = |problem: String| RecordingError::Header {
            at: at.clone(),
            problem,
        };
        const EXPECTED: &str = r#"expected a header line {"type":"header","format":"nomen-recording","version":1,...}"#;
        let value: Value = serde_json::from_slice(line).map_err(|e| {
            bad(format!(
                "missing header: line 1 is not json ({}); {EXPECTED}",
                crate::error::json_detail(&e)
            ))
        })?;
        let Value::Object(mut obj) = value else {
            return Err(bad(format!(
                "missing header: line 1 is not a json object; {EXPECTED}"
            )));
        };
        match obj.get("type").and_then(Value::as_str) {
            Some("header") => {}
            Some(other) if crate::reader::MESSAGE_TYPES.contains(&other) => {
                return Err(bad(format!(
                    "missing header: line 1 is a '{other}' message; {EXPECTED}"
                )));
            }
            // Another file's JSON: its content is not repeated.
            Some(_) => {
                return Err(bad(format!(
                    "missing header: line 1's 'type' is not one of a recording; {EXPECTED}"
                )));
            }
            None => {
                return Err(bad(format!(
                    "missing header: line 1 has no 'type' field; {EXPECTED}"
                )));
            }
        }
        match obj.get("format") {
            Some(Value::String(f)) if f == FORMAT_NAME => {}
            Some(other) => {
                return Err(bad(format!(
                    "not a nomen recording: header format is {other}, expected \"{FORMAT_NAME}\""
                )));
            }
            None => return Err(bad("header has no 'format' field".to_owned())),
        }
        let version = match obj.get("version").and_then(Value::as_u64) {
            Some(v) if v == u64::from(FORMAT_VERSION) => FORMAT_VERSION,
            Some(v) => {
                return Err(bad(format!(
                    "unsupported format version {v} (this reader reads version {FORMAT_VERSION})"
                )));
            }
            None => {
                return Err(bad(
                    "header has no unsigned integer 'version' field".to_owned()
                ));
            }
        };
        let registry = match obj.remove("registry") {
            None | Some(Value::Null) => None,
            Some(v) => {
                let registry = Registry::deserialize(v)
                    .map_err(|e| bad(format!("bad registry in header: {e}")))?;
                registry
                    .validate()
                    .map_err(|e| bad(format!("invalid registry in header: {e}")))?;
                Some(registry)
            }
        };
        let meta = match obj.remove("meta") {
            None | Some(Value::Null) => Map::new(),
            Some(Value::Object(m)) => m,
            Some(_) => return Err(bad("header 'meta' is not a json object".to_owned())),
        };
        Ok(Self {
            version,
            registry,
            meta,
        })
    }
}

#[derive(Serialize)]
struct RawHeaderOut<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    format: &'static str,
    version: u32,
    registry: Option<&'a Registry>,
    meta: &'a Map<String, Value>,
}
