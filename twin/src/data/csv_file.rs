//! The CSV form of a run's table, read as a machine's logger writes it: cells separated by `,`,
//! `;` or tab (the one the header holds most of, unless given; with `;` and tab a number may
//! have a decimal comma, `0,25`), quoted or not (`"…"`, a quote doubled inside); `#` comment
//! lines anywhere; a header of `name [unit]` or `name (unit)` cells, or of bare names with a
//! units row under it (`time,torque` then `s,N·m`); then one row per time. Written as the twin
//! writes it: comma separated, `name [unit]` headers, values in Rust's shortest round-trip form
//! of an `f64`.

use super::error::DataError;
use super::measured::RunData;
use super::options::Delimiter;
use super::reading::RawTable;

/// How the file's lines are cut into cells: the separator, and whether it was given
/// (`--delimiter`) or read from the header.
#[derive(Debug, Clone, Copy)]
struct Cutting<'a> {
    file: &'a str,
    delimiter: Delimiter,
    given: bool,
}

/// Parses the CSV `bytes` of `file` into its columns: comment and blank lines skipped, a
/// header, an optional units row, then rows of as many cells (a byte-order mark and CRLF line
/// ends are accepted). A cell that is not a number leaves its column unread, not the file
/// refused: only a column the plant knows needs numbers.
pub(super) fn parse(
    file: &str,
    bytes: &[u8],
    delimiter: Option<Delimiter>,
) -> Result<RawTable, DataError> {
    let format = |reason: String| DataError::Format {
        file: file.to_owned(),
        reason,
    };
    let text = std::str::from_utf8(bytes)
        .map_err(|_| format("not a CSV file: it is not UTF-8 text".into()))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = (text.lines().enumerate())
        .map(|(index, line)| (index + 1, line))
        .filter(|(_, line)| !(line.trim().is_empty() || line.trim_start().starts_with('#')))
        .peekable();
    let Some((_, header)) = lines.next() else {
        return Err(format(
            "not a CSV file: it is empty (its first line that is not a `#` comment is the \
             header, e.g. `time [s],ram_position [m]`)"
                .into(),
        ));
    };
    let cutting = Cutting {
        file,
        delimiter: delimiter.unwrap_or_else(|| detect(header)),
        given: delimiter.is_some(),
    };
    let headers = cutting
        .cells(header)
        .ok_or_else(|| format("not a CSV file: its header has an unclosed quote".into()))?;
    cutting.check_header(&headers)?;
    let mut columns = (headers.iter().enumerate())
        .map(|(i, text)| split_header(file, i, text))
        .collect::<Result<Vec<_>, _>>()?;
    if columns.iter().any(|(_, unit)| unit.is_empty()) {
        if let Some(&(row, line)) = lines.peek() {
            if cutting.units_row(&mut columns, row, line)? {
                lines.next();
            }
        }
    }
    let mut table = RawTable::new(columns);
    for (row, line) in lines {
        cutting.read_row(&mut table, row, line)?;
    }
    Ok(table)
}

/// The separator the header holds most of, outside quotes: tab before `;` before `,` on a tie,
/// `,` when it holds none.
fn detect(header: &str) -> Delimiter {
    let all = [Delimiter::Comma, Delimiter::Semicolon, Delimiter::Tab];
    let mut counts = [0_usize; 3];
    let mut quoted = false;
    for c in header.chars() {
        if c == '"' {
            quoted = !quoted;
        } else if let Some(k) = all.iter().position(|d| d.separator() == c && !quoted) {
            counts[k] += 1;
        }
    }
    match (0..all.len()).max_by_key(|&k| (counts[k], k)) {
        Some(k) if counts[k] > 0 => all[k],
        _ => Delimiter::Comma,
    }
}

impl Cutting<'_> {
    /// The cells of a line, unquoted; `None` for an unclosed quote.
    fn cells(&self, line: &str) -> Option<Vec<String>> {
        split_cells(line, self.delimiter.separator())
    }

    /// Refuses a header read as one column that holds another separator: the separator given
    /// is not the file's.
    fn check_header(&self, headers: &[String]) -> Result<(), DataError> {
        let [only] = headers else {
            return Ok(());
        };
        let others = [Delimiter::Comma, Delimiter::Semicolon, Delimiter::Tab];
        match others.into_iter().find(|d| only.contains(d.separator())) {
            Some(other) if other != self.delimiter => Err(DataError::Format {
                file: self.file.to_owned(),
                reason: format!(
                    "its header is one column with the separator `{}` but holds `{}`; give \
                     --delimiter '{}'",
                    self.delimiter.name(),
                    other.name(),
                    other.name()
                ),
            }),
            _ => Ok(()),
        }
    }

    /// Takes the line under the header as its units row when it looks like one (no cell a
    /// number but `1`, some cell not empty), giving each column without a unit in the header
    /// its unit; returns whether it did.
    fn units_row(
        &self,
        columns: &mut [(String, String)],
        row: usize,
        line: &str,
    ) -> Result<bool, DataError> {
        let Some(cells) = self.cells(line) else {
            return Ok(false);
        };
        let number = |cell: &String| self.number(cell).is_ok() && cell.trim() != "1";
        let word = |cell: &String| !cell.trim().is_empty() && self.number(cell).is_err();
        if cells.iter().any(number) || !cells.iter().any(word) {
            return Ok(false);
        }
        if cells.len() != columns.len() {
            return Err(DataError::Row {
                file: self.file.to_owned(),
                row,
                reason: format!(
                    "the units row has {}",
                    self.width(cells.len(), columns.len())
                ),
            });
        }
        for ((name, unit), cell) in columns.iter_mut().zip(&cells) {
            let given = unbracketed(cell.trim());
            if unit.is_empty() {
                *unit = given.to_owned();
            } else if !given.is_empty() && given != unit {
                return Err(DataError::Column {
                    file: self.file.to_owned(),
                    column: super::measured::header(name, unit),
                    reason: format!(
                        "its unit is {unit} in the header but {given} in the units row \
                         (row {row}); give one"
                    ),
                });
            }
        }
        Ok(true)
    }

    /// Reads one row's cells into `table`: a cell that is not a number marks its column unread.
    fn read_row(&self, table: &mut RawTable, row: usize, line: &str) -> Result<(), DataError> {
        let row_error = |reason: String| DataError::Row {
            file: self.file.to_owned(),
            row,
            reason,
        };
        let cells = self
            .cells(line)
            .ok_or_else(|| row_error("an unclosed quote".into()))?;
        if cells.len() != table.columns.len() {
            return Err(row_error(self.width(cells.len(), table.columns.len())));
        }
        for (k, cell) in cells.iter().enumerate() {
            let value = self.number(cell).unwrap_or_else(|reason| {
                table.unread[k].get_or_insert((Some(row), reason));
                f64::NAN
            });
            table.values[k].push(value);
        }
        table.rows.push(row);
        Ok(())
    }

    /// "3 cells where the header has 2", with the separator to check.
    fn width(&self, cells: usize, header: usize) -> String {
        let separator = self.delimiter.name();
        let how = match self.given {
            true => format!("the separator `{separator}` given with --delimiter"),
            false => format!("the separator `{separator}`, as the header's"),
        };
        format!(
            "{cells} cells where the header has {header}, cut at {how}; if the file has \
             another separator, give it with --delimiter (`,`, `;` or `tab`)"
        )
    }

    /// A cell's number (with a decimal comma when the separator is `;` or tab); an empty cell
    /// and one that is not a number are refused.
    fn number(&self, cell: &str) -> Result<f64, String> {
        let cell = cell.trim();
        if cell.is_empty() {
            return Err("empty cell".into());
        }
        let decimal_comma = self.delimiter != Delimiter::Comma && cell.contains(',');
        let parsed = match decimal_comma {
            true if cell.contains('.') => None,
            true => cell.replace(',', ".").parse::<f64>().ok(),
            false => cell.parse::<f64>().ok(),
        };
        parsed.ok_or_else(|| format!("`{}` is not a number", shorten(cell)))
    }
}

/// A unit as a units row may write it: `s`, `[s]` or `(s)`.
fn unbracketed(cell: &str) -> &str {
    let inner = (cell.strip_prefix('[').and_then(|c| c.strip_suffix(']')))
        .or_else(|| cell.strip_prefix('(').and_then(|c| c.strip_suffix(')')));
    inner.unwrap_or(cell).trim()
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

/// A header cell's name and unit: `name [unit]`, `name (unit)`, or a bare `name` (its unit
/// empty, given by a units row or refused later if the plant knows the column).
pub(super) fn split_header(
    file: &str,
    index: usize,
    text: &str,
) -> Result<(String, String), DataError> {
    let text = text.trim();
    let nameless = || DataError::Format {
        file: file.to_owned(),
        reason: format!("column {} has no name in the header", index + 1),
    };
    let suffix = |open: char, close: char| {
        let (name, unit) = text.strip_suffix(close)?.rsplit_once(open)?;
        Some((name.trim(), unit.trim()))
    };
    let (name, unit) = (suffix('[', ']'))
        .or_else(|| suffix('(', ')'))
        .unwrap_or((text, ""));
    if name.is_empty() {
        return Err(nameless());
    }
    if name.contains(['[', ']']) {
        let (base, rest) = name.split_once('[').unwrap_or((name, ""));
        let unit = rest.replace(']', "");
        let unit = if unit.trim().is_empty() {
            "unit"
        } else {
            unit.trim()
        };
        return Err(DataError::Column {
            file: file.to_owned(),
            column: text.to_owned(),
            reason: format!(
                "its brackets do not close around a unit at its end; write it as \"{} [{unit}]\"",
                shorten(base.trim())
            ),
        });
    }
    Ok((name.to_owned(), unit.to_owned()))
}

/// The cells of a line cut at `separator`, unquoted; `None` for an unclosed quote.
fn split_cells(line: &str, separator: char) -> Option<Vec<String>> {
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
            (c, false) if c == separator => cells.push(std::mem::take(&mut cell)),
            _ => cell.push(c),
        }
    }
    cells.push(cell);
    (!quoted).then_some(cells)
}

/// A header cell, quoted when it holds a separator or a quote.
fn cell_text(text: &str) -> String {
    if text.contains([',', ';', '\t', '"']) || text.trim() != text {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// The table as CSV bytes; refuses columns of another length than `time`, and names with a
/// line break.
pub(crate) fn to_bytes(data: &RunData) -> Result<Vec<u8>, String> {
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
pub(crate) fn check_shape(data: &RunData) -> Result<(), String> {
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
