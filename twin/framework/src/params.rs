//! Parameter tables read from TOML: typed, with one-line errors that name the key path.

use crate::ControllerError;
use serde::de::DeserializeOwned;
use serde_path_to_error::{Path, Segment};
use std::fmt;

/// Reads a controller's parameter struct from its table; unknown keys, wrong types and
/// non-finite numbers are [`ControllerError::BadParameter`] errors naming the controller and the
/// offending entry's key path.
pub fn parse_params<P: DeserializeOwned>(
    controller: &str,
    params: &toml::Table,
) -> Result<P, ControllerError> {
    deserialize_table(params).map_err(|error| ControllerError::BadParameter {
        controller: controller.to_string(),
        key: error.key,
        value: error.value,
        reason: error.reason,
    })
}

/// Why a table does not deserialise: where, what was written there when one value is at fault,
/// and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct TableError {
    /// Dotted key path of the offending entry (`gains.0`); empty for the table itself (a missing
    /// field, whose name the reason gives).
    pub key: String,
    /// The offending value, for a value that is not a finite number.
    pub value: Option<String>,
    /// What is wrong: serde's message (`invalid type: …`, `unknown field …`) or `must be a finite
    /// number`.
    pub reason: String,
}

impl fmt::Display for TableError {
    /// `` `key` = value: reason ``, `` `key`: reason ``, or the reason alone for the table.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.key.as_str(), &self.value) {
            ("", _) => f.write_str(&self.reason),
            (key, Some(value)) => write!(f, "`{key}` = {value}: {}", self.reason),
            (key, None) => write!(f, "`{key}`: {}", self.reason),
        }
    }
}

/// Deserialises a table, with a one-line message that names the offending key path (see
/// [`deserialize_table`]).
pub fn from_table<P: DeserializeOwned>(table: &toml::Table) -> Result<P, String> {
    deserialize_table(table).map_err(|error| error.to_string())
}

/// Deserialises a table, with an error that names the offending key path. Stricter than TOML
/// itself: every number must be finite (TOML allows `inf` and `nan`, no physical parameter does),
/// and an array must have exactly the length its field takes (the TOML deserialiser would
/// silently drop extra elements of a fixed-size array).
pub fn deserialize_table<P: DeserializeOwned>(table: &toml::Table) -> Result<P, TableError> {
    check_finite(table, &mut Vec::new())?;
    // Through the value: it checks array lengths, and the error carries the key path. (Line
    // numbers would be those of a re-serialised table, not of the user's file.)
    serde_path_to_error::deserialize(toml::Value::Table(table.clone()))
        .map_err(|error| describe_path_error(&error))
}

/// The key path and serde's message, with its wording for a too-long array made plain.
fn describe_path_error(error: &serde_path_to_error::Error<toml::de::Error>) -> TableError {
    let message = error.inner().message().trim().replace('\n', " ");
    let reason = match message.strip_prefix("invalid length ") {
        Some(rest) if rest.contains("fewer elements in array") => {
            let found = rest.split(',').next().unwrap_or(rest);
            format!("has {found} elements, more than it takes")
        }
        _ => message,
    };
    TableError {
        key: dotted(error.path()),
        value: None,
        reason,
    }
}

/// A serde path in the dotted form of the finiteness check (`gains.1`, not serde's `gains[1]`);
/// empty for the table itself (a missing field, whose name the message gives).
fn dotted(path: &Path) -> String {
    path.iter()
        .map(|segment| match segment {
            Segment::Seq { index } => index.to_string(),
            Segment::Map { key } => key.clone(),
            Segment::Enum { variant } => variant.clone(),
            Segment::Unknown => "?".to_string(),
        })
        .collect::<Vec<_>>()
        .join(".")
}

/// Rejects NaN and infinities anywhere in the table, naming the key.
fn check_finite(table: &toml::Table, path: &mut Vec<String>) -> Result<(), TableError> {
    for (key, value) in table {
        path.push(key.clone());
        check_finite_value(value, path)?;
        path.pop();
    }
    Ok(())
}

fn check_finite_value(value: &toml::Value, path: &mut Vec<String>) -> Result<(), TableError> {
    match value {
        toml::Value::Float(x) if !x.is_finite() => Err(TableError {
            key: path.join("."),
            value: Some(x.to_string()),
            reason: "must be a finite number".into(),
        }),
        toml::Value::Table(table) => check_finite(table, path),
        toml::Value::Array(items) => {
            for (index, item) in items.iter().enumerate() {
                path.push(index.to_string());
                check_finite_value(item, path)?;
                path.pop();
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// The first `chars` characters of `text`, with `…` when it was longer: long inputs quoted in a
/// one-line message.
pub fn shortened(text: &str, chars: usize) -> String {
    match text.char_indices().nth(chars) {
        Some((end, _)) => format!("{}…", &text[..end]),
        None => text.to_string(),
    }
}

/// A TOML error on one line: where it is (`line N: <that line>`) and what is wrong.
pub fn describe_toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) if span.start < text.len() => {
            let line_number = text[..span.start].matches('\n').count() + 1;
            let line = text.lines().nth(line_number - 1).unwrap_or("").trim();
            // A long line (a generated file, a hostile input) is quoted by its start only.
            let line = shortened(line, 80);
            format!("line {line_number} (`{line}`): {message}")
        }
        _ => message,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn from_table_keeps_its_one_line_messages() {
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Pair {
            gains: [f64; 2],
        }
        let pair: Pair = from_table(&table("gains = [1.0, 2.0]")).unwrap();
        assert_eq!(pair.gains, [1.0, 2.0]);
        let message = |text: &str| from_table::<Pair>(&table(text)).unwrap_err();
        assert_eq!(
            message("gains = [1.0, inf]"),
            "`gains.1` = inf: must be a finite number"
        );
        assert_eq!(
            message("gains = [1.0, 2.0, 3.0]"),
            "`gains`: has 3 elements, more than it takes"
        );
        assert_eq!(message(""), "missing field `gains`");
        let error = deserialize_table::<Pair>(&table("gains = [1.0, \"x\"]")).unwrap_err();
        assert_eq!(error.key, "gains.1");
    }

    #[test]
    fn parameter_message_renders_key_value_and_reason() {
        assert_eq!(
            crate::parameter_message("natural_frequency", Some("-1"), "must be > 0"),
            "params.natural_frequency = -1: must be > 0"
        );
        assert_eq!(
            crate::parameter_message("lathe", None, "reaches only 1 W"),
            "params.lathe: reaches only 1 W"
        );
        assert_eq!(
            crate::parameter_message("", None, "unknown"),
            "params: unknown"
        );
    }
}
