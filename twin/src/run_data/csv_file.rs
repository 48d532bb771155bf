//! The CSV form of a run's table: comma separated, a header row of `name [unit]` cells, one row
//! per time; a cell may be quoted (`"…"`, a quote doubled inside), values are written with
//! Rust's shortest round-trip form of an `f64`.

use super::{DataError, RawTable, RunData};

/// Parses the CSV `bytes` of `file` into its columns: a header of bracketed units, then rows
/// of as many numeric cells (blank lines are skipped; a byte-order mark and CRLF line ends are
/// accepted).
pub(super) fn parse(file: &str, bytes: &[u8]) -> Result<RawTable, DataError> {
    let format = |reason: String| DataError::Format {
        file: file.to_owned(),
        reason,
    };
    let text = std::str::from_utf8(bytes)
        .map_err(|_| format("not a CSV file: it is not UTF-8 text".into()))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate();
    let Some((_, header)) = lines.by_ref().find(|(_, line)| !line.trim().is_empty()) else {
        return Err(format(
            "not a CSV file: it is empty (its first line is the header, e.g. \
             `time [s],ram_position [m]`)"
                .into(),
        ));
    };
    let headers = split_cells(header)
        .ok_or_else(|| format("not a CSV file: its header has an unclosed quote".into()))?;
    let columns = headers
        .iter()
        .enumerate()
        .map(|(i, text)| split_header(file, i, text))
        .collect::<Result<Vec<_>, _>>()?;
    let mut values = vec![Vec::new(); columns.len()];
    let mut rows = Vec::new();
    for (index, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let row = index + 1;
        let row_error = |reason: String| DataError::Row {
            file: file.to_owned(),
            row,
            reason,
        };
        let cells = split_cells(line).ok_or_else(|| row_error("an unclosed quote".into()))?;
        if cells.len() != headers.len() {
            return Err(row_error(format!(
                "{} cells where the header has {}",
                cells.len(),
                headers.len()
            )));
        }
        for ((cell, column), header) in cells.iter().zip(&mut values).zip(&headers) {
            let value = number(cell).map_err(|reason| DataError::Cell {
                file: file.to_owned(),
                row,
                column: header.trim().to_owned(),
                reason,
            })?;
            column.push(value);
        }
        rows.push(row);
    }
    Ok(RawTable {
        columns,
        values,
        rows,
    })
}

/// A cell's number; an empty cell and one that is not a number are refused.
fn number(cell: &str) -> Result<f64, String> {
    let cell = cell.trim();
    if cell.is_empty() {
        return Err("empty cell".into());
    }
    cell.parse::<f64>()
        .map_err(|_| format!("`{}` is not a number", shorten(cell)))
}

/// A cell quoted in a message: at most 40 characters.
fn shorten(cell: &str) -> String {
    const MAX: usize = 40;
    if cell.chars().count() <= MAX {
        cell.to_owned()
    } else {
        format!("{}…", cell.chars().take(MAX).collect::<String>())
    }
}

/// A header cell's name and unit: `name [unit]`, both non-empty.
pub(super) fn split_header(
    file: &str,
    index: usize,
    text: &str,
) -> Result<(String, String), DataError> {
    let text = text.trim();
    let error = |reason: String| DataError::Column {
        file: file.to_owned(),
        column: text.to_owned(),
        reason,
    };
    if text.is_empty() {
        return Err(DataError::Format {
            file: file.to_owned(),
            reason: format!("column {} has no name in the header", index + 1),
        });
    }
    let parsed = text
        .strip_suffix(']')
        .and_then(|rest| rest.rsplit_once('['))
        .map(|(name, unit)| (name.trim(), unit.trim()))
        .filter(|(name, unit)| !name.is_empty() && !unit.is_empty());
    match parsed {
        Some((name, unit)) => Ok((name.to_owned(), unit.to_owned())),
        None => Err(error(format!(
            "no unit: give it in brackets after the name, e.g. \"{} [m]\"",
            shorten(text.split('[').next().unwrap_or(text).trim())
        ))),
    }
}

/// The cells of a line, unquoted; `None` for an unclosed quote.
fn split_cells(line: &str) -> Option<Vec<String>> {
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut chars = line.chars().peekable();
    let mut quoted = false;
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                cell.push('"');
            }
            ('"', true) => quoted = false,
            ('"', false) if cell.trim().is_empty() => {
                cell.clear();
                quoted = true;
            }
            (',', false) => cells.push(std::mem::take(&mut cell)),
            _ => cell.push(c),
        }
    }
    cells.push(cell);
    (!quoted).then_some(cells)
}

/// A header cell, quoted when it holds a comma or a quote.
fn cell_text(text: &str) -> String {
    if text.contains([',', '"']) || text.trim() != text {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// The table as CSV bytes; refuses columns of another length than `time`, and names with a
/// line break.
pub(super) fn to_bytes(data: &RunData) -> Result<Vec<u8>, String> {
    use std::fmt::Write;
    check_shape(data)?;
    let mut headers = vec!["time [s]".to_owned()];
    headers.extend(data.columns.iter().map(RunData::header));
    if let Some(bad) = headers.iter().find(|h| h.contains(['\n', '\r'])) {
        return Err(format!("the column name {bad:?} holds a line break"));
    }
    let header: Vec<String> = headers.iter().map(|h| cell_text(h)).collect();
    let width = 24 * (1 + data.columns.len());
    let mut text = String::with_capacity(width * (data.time.len() + 1));
    text.push_str(&header.join(","));
    text.push('\n');
    for (k, time) in data.time.iter().enumerate() {
        let _ = write!(text, "{time}");
        for column in &data.columns {
            let _ = write!(text, ",{}", column.values[k]);
        }
        text.push('\n');
    }
    Ok(text.into_bytes())
}

/// Refuses a table whose columns do not each hold one value per time.
pub(super) fn check_shape(data: &RunData) -> Result<(), String> {
    match data
        .columns
        .iter()
        .find(|c| c.values.len() != data.time.len())
    {
        None => Ok(()),
        Some(column) => Err(format!(
            "column {} has {} values for {} times",
            column.name,
            column.values.len(),
            data.time.len()
        )),
    }
}
