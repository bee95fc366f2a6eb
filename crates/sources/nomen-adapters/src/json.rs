//! Reading fields of a parsed JSON value with errors that name the field's place.

use crate::error::{AdapterError, Place, Result};
use serde_json::{Map, Value};

/// Parses one JSON value (a line or a payload) at `at`.
pub(crate) fn parse(text: &[u8], at: &Place) -> Result<Value> {
    serde_json::from_slice(text).map_err(|e| AdapterError::from_json(at, &e))
}

/// The value as an object.
pub(crate) fn object<'a>(value: &'a Value, at: &Place) -> Result<&'a Map<String, Value>> {
    value.as_object().ok_or_else(|| {
        AdapterError::shape(at, format!("expected an object, found {}", kind(value)))
    })
}

/// A payload that is one object or an array of objects, as `(item place, object)` pairs.
pub(crate) fn objects<'a>(
    value: &'a Value,
    at: &Place,
) -> Result<Vec<(Place, &'a Map<String, Value>)>> {
    match value {
        Value::Array(items) => items
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let at = at.at(format!("[{i}]"));
                object(v, &at).map(|o| (at, o))
            })
            .collect(),
        Value::Object(o) => Ok(vec![(at.clone(), o)]),
        other => Err(AdapterError::shape(
            at,
            format!(
                "expected an object or an array of objects, found {}",
                kind(other)
            ),
        )),
    }
}

/// The field `name` of `obj`, which must be present and not null.
pub(crate) fn required<'a>(
    obj: &'a Map<String, Value>,
    name: &str,
    at: &Place,
) -> Result<&'a Value> {
    match obj.get(name) {
        Some(Value::Null) | None => Err(AdapterError::shape(at, format!("missing field '{name}'"))),
        Some(v) => Ok(v),
    }
}

/// The field `name` of `obj` if present and not null.
pub(crate) fn optional<'a>(obj: &'a Map<String, Value>, name: &str) -> Option<&'a Value> {
    obj.get(name).filter(|v| !v.is_null())
}

/// A JSON number, or a string holding one (vendors send `" 4.00"`); finite.
pub(crate) fn number(value: &Value, at: &Place) -> Result<f64> {
    let parsed = match value {
        Value::Number(n) => n.as_f64(),
        Value::String(s) => s.trim().parse::<f64>().ok(),
        _ => None,
    };
    parsed.filter(|v| v.is_finite()).ok_or_else(|| {
        AdapterError::shape(
            at,
            format!("expected a finite number, found {}", short(value)),
        )
    })
}

/// A JSON string, not empty after trimming.
pub(crate) fn text<'a>(value: &'a Value, at: &Place) -> Result<&'a str> {
    match value {
        Value::String(s) if !s.trim().is_empty() => Ok(s.trim()),
        Value::String(_) => Err(AdapterError::shape(at, "empty string")),
        other => Err(AdapterError::shape(
            at,
            format!("expected a string, found {}", short(other)),
        )),
    }
}

/// A string id, or a number used as one (a tag id of `30331`).
pub(crate) fn id(value: &Value, at: &Place) -> Result<String> {
    match value {
        Value::Number(n) => Ok(n.to_string()),
        other => text(other, at).map(str::to_owned),
    }
}

/// A non-negative integer (a JSON integer or a string holding one).
pub(crate) fn unsigned(value: &Value, at: &Place) -> Result<u64> {
    let parsed = match value {
        Value::Number(n) => n.as_u64(),
        Value::String(s) => s.trim().parse::<u64>().ok(),
        _ => None,
    };
    parsed.ok_or_else(|| {
        AdapterError::shape(
            at,
            format!("expected a non-negative integer, found {}", short(value)),
        )
    })
}

/// A boolean.
pub(crate) fn boolean(value: &Value, at: &Place) -> Result<bool> {
    value.as_bool().ok_or_else(|| {
        AdapterError::shape(
            at,
            format!("expected true or false, found {}", short(value)),
        )
    })
}

fn kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// The value in a few characters, for an error message.
fn short(value: &Value) -> String {
    match value {
        Value::Array(_) | Value::Object(_) => kind(value).to_owned(),
        other => {
            let s = other.to_string();
            if s.chars().count() > 40 {
                format!("{}…", s.chars().take(40).collect::<String>())
            } else {
                s
            }
        }
    }
}
