//! The crate's error type: every problem names the input (file or payload), the line where the
//! format has lines, and the item inside it (`frames[3].bodies[0]`, `[1].data.coordinates`).

use nomen_core::CoreError;
use std::fmt;
use std::sync::Arc;
use thiserror::Error;

/// Where a problem is: the input's name, the 1-based line for line-based formats, and the item
/// within the line or document. Displays as `FILE:LINE: ITEM` (parts that are absent are left
/// out).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Place {
    /// The input's name: a file path, or `payload` for one MQTT payload.
    pub source: Arc<str>,
    /// 1-based line, for inputs read line by line.
    pub line: Option<u64>,
    /// The item inside the line or document, as a JSON path (`[1].data.coordinates`); empty
    /// for the line or document as a whole.
    pub item: String,
}

impl Place {
    /// The whole of `source`.
    pub fn new(source: &Arc<str>) -> Self {
        Self {
            source: Arc::clone(source),
            line: None,
            item: String::new(),
        }
    }

    /// Line `line` of `source`.
    pub fn line(source: &Arc<str>, line: u64) -> Self {
        Self {
            line: Some(line),
            ..Self::new(source)
        }
    }

    /// The item `item` inside this place (a field name, `[3]`, or a dotted path).
    pub fn at(&self, item: impl fmt::Display) -> Self {
        let item = item.to_string();
        let joined = if self.item.is_empty() {
            item
        } else if item.starts_with('[') {
            format!("{}{item}", self.item)
        } else {
            format!("{}.{item}", self.item)
        };
        Self {
            source: Arc::clone(&self.source),
            line: self.line,
            item: joined,
        }
    }
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source)?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if !self.item.is_empty() {
            write!(f, ": {}", self.item)?;
        }
        Ok(())
    }
}

/// Everything that can be wrong with a vendor file or payload. Every variant displays as
/// `FILE:LINE: ITEM: what is wrong` (lower case, no trailing period).
#[derive(Debug, Error)]
pub enum AdapterError {
    /// Reading the input failed.
    #[error("{at}: i/o error: {source}")]
    Io {
        /// Where.
        at: Place,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The input is not valid JSON, or ends before its JSON value does.
    #[error("{at}: invalid json: {detail}")]
    Json {
        /// Where.
        at: Place,
        /// What serde_json says, with the line and column in the input where it has them.
        detail: String,
    },
    /// The JSON or CSV is well formed but not in the vendor's shape: a field is missing, has the
    /// wrong type, or holds a value the format does not allow.
    #[error("{at}: {detail}")]
    Shape {
        /// Where.
        at: Place,
        /// What is wrong.
        detail: String,
    },
    /// A converted message failed [`nomen_core::Message::validate`] (an implausible value for
    /// its unit: often a wrong scale or time unit).
    #[error("{at}: {source}")]
    Invalid {
        /// Where.
        at: Place,
        /// The data-model error.
        #[source]
        source: CoreError,
    },
    /// The input or one of its lines is larger than a reader takes.
    #[error("{at}: {what} is longer than {limit} bytes, the most this reader takes")]
    TooLarge {
        /// Where.
        at: Place,
        /// What is too large (`line`, `document`, `payload`).
        what: &'static str,
        /// The limit, bytes.
        limit: u64,
    },
    /// Two messages of one source (a camera track, a tag, a tag at an antenna) at the same time.
    #[error("{at}: {what} at {t_s:.6} s, already given at {first}")]
    Duplicate {
        /// Where the second one is.
        at: Place,
        /// The source in words (`track 3 of camera 'kinect'`).
        what: String,
        /// Its time on the session clock, s.
        t_s: f64,
        /// Where the first one is.
        first: Box<Place>,
    },
}

impl AdapterError {
    /// Where the problem is.
    pub fn place(&self) -> &Place {
        match self {
            AdapterError::Io { at, .. }
            | AdapterError::Json { at, .. }
            | AdapterError::Shape { at, .. }
            | AdapterError::Invalid { at, .. }
            | AdapterError::TooLarge { at, .. }
            | AdapterError::Duplicate { at, .. } => at,
        }
    }

    pub(crate) fn shape(at: &Place, detail: impl Into<String>) -> Self {
        AdapterError::Shape {
            at: at.clone(),
            detail: detail.into(),
        }
    }

    /// A serde_json error while reading `at`: syntax errors (and a truncated input) as
    /// [`AdapterError::Json`], a well-formed value of the wrong shape as [`AdapterError::Shape`].
    pub(crate) fn from_json(at: &Place, err: &serde_json::Error) -> Self {
        let detail = json_detail(err, at.line.is_none());
        match err.classify() {
            serde_json::error::Category::Data => AdapterError::Shape {
                at: at.clone(),
                detail,
            },
            serde_json::error::Category::Eof => AdapterError::Json {
                at: at.clone(),
                detail: format!("{detail} (truncated?)"),
            },
            serde_json::error::Category::Syntax | serde_json::error::Category::Io => {
                AdapterError::Json {
                    at: at.clone(),
                    detail,
                }
            }
        }
    }
}

/// serde_json's message with its position: `line L column C` for a whole document, `column C`
/// for one line (where the line is already in the place).
fn json_detail(err: &serde_json::Error, is_document: bool) -> String {
    let text = err.to_string();
    let msg = match text.rfind(" at line ") {
        Some(i) if err.line() > 0 => &text[..i],
        _ => text.as_str(),
    };
    match (err.line(), err.column()) {
        (0, _) => msg.to_owned(),
        (line, column) if is_document => format!("{msg} (line {line} column {column})"),
        (_, column) => format!("{msg} (column {column})"),
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, AdapterError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_place_names_file_line_and_item() {
        let file: Arc<str> = Arc::from("tags.jsonl");
        let p = Place::line(&file, 3).at("[1]").at("data").at("coordinates");
        assert_eq!(p.to_string(), "tags.jsonl:3: [1].data.coordinates");
        assert_eq!(Place::new(&file).to_string(), "tags.jsonl");
        assert_eq!(
            Place::new(&file).at("frames[2]").to_string(),
            "tags.jsonl: frames[2]"
        );
    }
}
