//! The Parquet form of a run's table: one column per CSV column with the same `name [unit]`
//! names, Float64 when written; Float32, Int64 and Int32 columns are read too, as `f64`.

use std::sync::Arc;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type, Int32Type, Int64Type};
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;

use super::csv_file::{check_shape, split_header};
use super::error::DataError;
use super::measured::RunData;
use super::reading::RawTable;

/// Parses the Parquet `bytes` of `file` into its columns; a column with a null or of values
/// that are not numbers is kept unread.
pub(super) fn parse(file: &str, bytes: bytes::Bytes) -> Result<RawTable, DataError> {
    let format = |reason: String| DataError::Format {
        file: file.to_owned(),
        reason: format!("not a Parquet file of numbers: {}", one_line(&reason)),
    };
    let builder =
        ParquetRecordBatchReaderBuilder::try_new(bytes).map_err(|e| format(e.to_string()))?;
    let fields: Vec<String> = (builder.schema().fields().iter())
        .map(|f| f.name().clone())
        .collect();
    let columns = fields
        .iter()
        .enumerate()
        .map(|(i, name)| split_header(file, i, name))
        .collect::<Result<Vec<_>, _>>()?;
    let reader = builder.build().map_err(|e| format(e.to_string()))?;
    let mut table = RawTable::new(columns);
    for batch in reader {
        let batch = batch.map_err(|e| format(e.to_string()))?;
        let first_row = table.rows.len();
        for (k, array) in batch.columns().iter().enumerate().take(table.columns.len()) {
            if table.unread[k].is_some() {
                table.values[k].resize(first_row + array.len(), f64::NAN);
                continue;
            }
            if let Err((at, reason)) = append(&mut table.values[k], array.as_ref()) {
                table.unread[k] = Some((at.map(|at| first_row + at + 2), reason));
                table.values[k].resize(first_row + array.len(), f64::NAN);
            }
        }
        table
            .rows
            .extend((first_row..first_row + batch.num_rows()).map(|k| k + 2));
    }
    Ok(table)
}

/// Appends `array`'s values as `f64`; refuses a null (its index) and a type that is not
/// numbers.
fn append(column: &mut Vec<f64>, array: &dyn Array) -> Result<(), (Option<usize>, String)> {
    if let Some(k) = (0..array.len()).find(|&k| array.is_null(k)) {
        return Err((Some(k), "empty cell".into()));
    }
    match array.data_type() {
        DataType::Float64 => column.extend(array.as_primitive::<Float64Type>().values()),
        DataType::Float32 => column
            .extend((array.as_primitive::<Float32Type>().values().iter()).map(|&v| f64::from(v))),
        DataType::Int64 => {
            column.extend((array.as_primitive::<Int64Type>().values().iter()).map(|&v| v as f64))
        }
        DataType::Int32 => column
            .extend((array.as_primitive::<Int32Type>().values().iter()).map(|&v| f64::from(v))),
        other => {
            return Err((
                None,
                format!("its values are {other}, not numbers (give Float64, Float32 or Int64)"),
            ))
        }
    }
    Ok(())
}

/// The table as Parquet bytes: `time [s]` and every column as non-null Float64.
pub(crate) fn to_bytes(data: &RunData) -> Result<Vec<u8>, String> {
    check_shape(data)?;
    let mut names = vec!["time [s]".to_owned()];
    names.extend(data.columns.iter().map(RunData::header));
    let schema = Arc::new(Schema::new(
        (names.iter())
            .map(|name| Field::new(name, DataType::Float64, false))
            .collect::<Vec<_>>(),
    ));
    let mut arrays: Vec<ArrayRef> = vec![Arc::new(Float64Array::from(data.time.clone()))];
    arrays.extend(
        (data.columns.iter()).map(|c| Arc::new(Float64Array::from(c.values.clone())) as ArrayRef),
    );
    let batch = RecordBatch::try_new(schema.clone(), arrays).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    let mut writer = ArrowWriter::try_new(&mut bytes, schema, None).map_err(|e| e.to_string())?;
    writer.write(&batch).map_err(|e| e.to_string())?;
    writer.close().map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// A decoder's message on one line.
fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
