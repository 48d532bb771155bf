//! A measured run's table as read from a file (CSV, Parquet or a twin `.rrd`): its columns, the
//! ones that are not numbers, and their headers as written.

/// A run's table as read from a file (CSV, Parquet or a twin `.rrd`): units as written, but
/// times in seconds (a `time [ms]` column is converted on reading).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunData {
    /// The file's path, as given.
    pub source: String,
    /// SHA-256 of the file's bytes, lower-case hex.
    pub digest: String,
    /// Time of each row, s, strictly increasing.
    pub time: Vec<f64>,
    /// Every column but `time` whose cells are all finite numbers, in the file's order; each has
    /// one value per row.
    pub columns: Vec<DataColumn>,
    /// The columns with a cell that is not a finite number: refused by [`RunData::bind`] if the
    /// plant knows them, else left out like any column it does not know.
    pub unread: Vec<UnreadColumn>,
    /// Whether [`RunData::bind`] refuses the columns the plant does not know (`--strict`)
    /// instead of leaving them out.
    pub strict: bool,
}

/// A column with a cell that is not a finite number (or, in Parquet, values that are not
/// numbers), kept apart from the numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct UnreadColumn {
    /// Its name (after the renames).
    pub name: String,
    /// Its unit as written, empty when none is given.
    pub unit: String,
    /// The first row of a cell that is not a number (counted as [`DataError::Row`](super::DataError::Row) counts);
    /// `None` for a whole column of another type.
    pub row: Option<usize>,
    /// What is wrong with that cell or column.
    pub reason: String,
}

/// One column of a [`RunData`].
#[derive(Debug, Clone, PartialEq)]
pub struct DataColumn {
    /// Its name: `effort.<actuator>`, `<signal>` or `true.<signal>` (or anything, until bound).
    pub name: String,
    /// Its unit, as written in its header's brackets or parentheses or in the units row; empty
    /// when none is given (refused by [`RunData::bind`] if the plant knows the column).
    pub unit: String,
    /// One value per row, in `unit`, finite.
    pub values: Vec<f64>,
}

impl RunData {
    /// The column named `name` (without its unit), if any.
    pub fn column(&self, name: &str) -> Option<&DataColumn> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// A column's header as written: `name [unit]`, or `name` without a unit.
    pub(crate) fn header(column: &DataColumn) -> String {
        header(&column.name, &column.unit)
    }
}

/// A column's header as written: `name [unit]`, or `name` without a unit.
pub(super) fn header(name: &str, unit: &str) -> String {
    match unit {
        "" => name.to_owned(),
        unit => format!("{name} [{unit}]"),
    }
}
