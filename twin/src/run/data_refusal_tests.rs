//! Every refusal of the data format by its message (each naming what to change), Parquet
//! columns of other types, and malformed files (mutated CSV and Parquet, cut recordings)
//! refused without a panic.

use super::data_tests::{loaded, scratch, small_plant, write};
use super::twin::Twin;
use crate::data::*;
use std::path::Path;
use std::sync::Arc;

/// The message of reading `text` as `name` as `options` ask and binding it to the small plant
/// at 1 ms.
fn refusal(dir: &Path, name: &str, text: &str, options: &ReadOptions) -> String {
    let path = write(dir, name, text);
    match RunData::read_with(&path, options).and_then(|d| d.bind(&small_plant(), 1e-3, 2)) {
        Ok(_) => panic!("{name} was accepted:\n{text}"),
        Err(error) => error.to_string(),
    }
}

#[test]
fn every_refusal_names_the_file_and_the_row_or_column() {
    let dir = scratch("refusals");
    let file = |name: &str| dir.join(name).display().to_string();
    let strict = ReadOptions {
        strict: true,
        ..ReadOptions::default()
    };
    let comma = ReadOptions {
        delimiter: Some(Delimiter::Comma),
        ..ReadOptions::default()
    };
    let cases = (refusal_cases().into_iter())
        .chain(logger_refusal_cases())
        .map(|(name, text, expected)| (name, text, expected, ReadOptions::default()))
        .chain([
            (
                "unknown.csv",
                "time [s],ram_speed [m/s]\n0,1\n0.001,2\n".to_owned(),
                "column \"ram_speed [m/s]\": unknown signal ram_speed (known: effort.crank, \
                 ram_position, crank.position; each signal also as true.<signal>); rename it \
                 with --rename ram_speed=<known>, or read without --strict to leave it out",
                strict,
            ),
            (
                "forced.csv",
                "time [s];ram_position [m]\n0;1\n0.001;2\n".to_owned(),
                "its header is one column with the separator `,` but holds `;`; give \
                 --delimiter ';'",
                comma,
            ),
        ]);
    for (name, text, expected, options) in cases {
        let message = refusal(&dir, name, &text, &options);
        assert!(
            message.starts_with(&format!("{}: ", file(name)))
                && message.contains(expected)
                && !message.contains('\n'),
            "{name}: {message}\nexpected: {expected}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unreadable_files_and_bad_renames_are_refused() {
    let dir = scratch("unreadable");
    let file = |name: &str| dir.join(name).display().to_string();
    let binary = dir.join("binary.csv");
    std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x80]).unwrap();
    let message = RunData::read(&binary, &[]).unwrap_err().to_string();
    assert!(
        message.contains("not a CSV file: it is not UTF-8 text"),
        "{message}"
    );
    let missing = RunData::read(&dir.join("missing.csv"), &[])
        .unwrap_err()
        .to_string();
    assert!(missing.starts_with(&format!("cannot read {}: ", file("missing.csv"))));
    let folder = RunData::read(&dir, &[]).unwrap_err().to_string();
    assert!(folder.contains("not a data file"), "{folder}");
    for (args, expected) in [
        ("pos", "give old=new"),
        ("=x", "both names"),
        ("a=b[m]", "brackets"),
    ] {
        let message = parse_renames(&[args.to_owned()]).unwrap_err().to_string();
        assert!(message.starts_with(&format!("--rename `{args}`: ")) && message.contains(expected));
    }
    let unwritable = RunData::default().write_csv(&dir.join("nowhere/run.csv"));
    assert!(unwritable
        .unwrap_err()
        .to_string()
        .contains("does not exist"));
    std::fs::remove_dir_all(&dir).ok();
}

/// A header of the time and the small plant's signals, for the files that go wrong below it.
const HEAD: &str = "time [s],ram_position [m],crank.position [rad]\n";

/// Each malformed file (name, text) with the words its refusal must hold.
fn refusal_cases() -> Vec<(&'static str, String, &'static str)> {
    let mut cases = row_refusal_cases();
    cases.extend(column_refusal_cases());
    cases.extend(whole_file_refusal_cases());
    cases
}

/// Malformed rows: an empty or non-numeric cell, time not increasing, a cell missing.
fn row_refusal_cases() -> Vec<(&'static str, String, &'static str)> {
    vec![
        (
            "empty.csv",
            format!("{HEAD}0,1,2\n0.001,,2\n"),
            "row 3, column \"ram_position [m]\": empty cell",
        ),
        (
            "nan.csv",
            format!("{HEAD}0,1,2\n0.001,1,NaN\n"),
            "row 3, column \"crank.position [rad]\": NaN is not a finite number",
        ),
        (
            "word.csv",
            format!("{HEAD}0,1,abc\n"),
            "row 2, column \"crank.position [rad]\": `abc` is not a number",
        ),
        (
            "time.csv",
            format!("{HEAD}0,1,2\n0.002,1,2\n0.001,1,2\n"),
            "row 4: time 0.001 s is not after the row before's 0.002 s",
        ),
        (
            "cells.csv",
            format!("{HEAD}0,1,2\n0.001,1\n"),
            "row 3: 2 cells where the header has 3",
        ),
    ]
}

/// Malformed columns: no time, a signal twice, a unit missing or not fitting its signal.
fn column_refusal_cases() -> Vec<(&'static str, String, &'static str)> {
    vec![
        (
            "notime.csv",
            "t [s],ram_position [m]\n0,1\n0.001,2\n".to_owned(),
            "no `time [s]` column",
        ),
        (
            "twice.csv",
            "time [s],ram_position [m],ram_position [mm]\n0,1,2\n".to_owned(),
            "column \"ram_position [mm]\": a second column named ram_position",
        ),
        (
            "nounit.csv",
            "time [s],ram_position\n0,1\n0.001,2\n".to_owned(),
            "column \"ram_position\": no unit: give it in brackets after the name, e.g. \
             \"ram_position [m]\", or in a units row under the header",
        ),
        (
            "run.csv",
            "time [s],ram_position [deg]\n0,1\n0.001,2\n".to_owned(),
            "column \"ram_position [deg]\": unit deg does not fit ram_position, which is in m \
             (give m, mm or µm)",
        ),
        (
            "timeunit.csv",
            "time [mm],ram_position [m]\n0,1\n".to_owned(),
            "column \"time [mm]\": unit mm does not fit time, which is in s (give s or ms)",
        ),
    ]
}

/// Files refused as a whole: too little data, not a data file, not CSV, Parquet or a recording.
fn whole_file_refusal_cases() -> Vec<(&'static str, String, &'static str)> {
    vec![
        (
            "short.csv",
            format!("{HEAD}0,1,2\n0.0005,1,2\n"),
            "1 samples at the control period 0.001 s (0.0005 s of data); 2 are needed",
        ),
        (
            "one.csv",
            format!("{HEAD}0,1,2\n"),
            "1 rows of data; at least two are needed",
        ),
        (
            "run.txt",
            format!("{HEAD}0,1,2\n"),
            "not a data file by its extension (`.txt`)",
        ),
        (
            "blank.csv",
            "\n\n".to_owned(),
            "not a CSV file: it is empty",
        ),
        (
            "quote.csv",
            "time [s],\"ram_position [m]\n0,1\n".to_owned(),
            "not a CSV file: its header has an unclosed quote",
        ),
        (
            "garbage.parquet",
            format!("{HEAD}0,1,2\n"),
            "not a Parquet file of numbers",
        ),
        (
            "garbage.rrd",
            format!("{HEAD}0,1,2\n"),
            "not a twin run's recording",
        ),
    ]
}

/// The refusals of a logger's ways (name, text, the words the refusal must hold): each says
/// what to change, with an example that fits the column.
fn logger_refusal_cases() -> Vec<(&'static str, String, &'static str)> {
    let no_unit = "no unit: give it in brackets after the name, e.g.";
    vec![
        (
            "timeunit-missing.csv",
            "# logged\ntime,ram_position [m]\n0,1\n0.001,2\n".to_owned(),
            "column \"time\": no unit: give it in brackets after the name, e.g. \"time [s]\", \
             or in a units row under the header",
        ),
        (
            "effort-unit.csv",
            "time [s],effort.crank\n0,1\n0.001,2\n".to_owned(),
            "column \"effort.crank\": no unit: give it in brackets after the name, e.g. \
             \"effort.crank [N·m]\"",
        ),
        (
            "units-row-gap.csv",
            "time;ram_position;crank.position\ns;;rad\n0;1;2\n0,001;1;2\n".to_owned(),
            no_unit,
        ),
        (
            "units-clash.csv",
            "time [s],ram_position\nms,m\n0,1\n0.001,2\n".to_owned(),
            "column \"time [s]\": its unit is s in the header but ms in the units row (row 2); \
             give one",
        ),
        (
            "separator.csv",
            "time [s];ram_position [m]\n0;1\n0.001,1\n".to_owned(),
            "row 3: 1 cells where the header has 2, cut at the separator `;`, as the header's; \
             if the file has another separator, give it with --delimiter",
        ),
        (
            "decimal.csv",
            "time [s],ram_position [m]\n0,1\n0.001,0,5\n".to_owned(),
            "row 3: 3 cells where the header has 2, cut at the separator `,`",
        ),
        (
            "thousands.csv",
            "time [s];ram_position [mm]\n0;1\n0,001;1.234,5\n".to_owned(),
            "row 3, column \"ram_position [mm]\": `1.234,5` is not a number",
        ),
        (
            "bracket.csv",
            "time [s,ram_position [m]\n0,1\n0.001,2\n".to_owned(),
            "column \"time [s\": its brackets do not close around a unit at its end; write it \
             as \"time [s]\"",
        ),
        (
            "units-row-width.csv",
            "time,ram_position\ns\n0,1\n".to_owned(),
            "row 2: the units row has 1 cells where the header has 2",
        ),
        (
            "comments-only.csv",
            "# a logger's preamble\n\n# and nothing else\n".to_owned(),
            "not a CSV file: it is empty (its first line that is not a `#` comment is the header",
        ),
        (
            "signal-unit.csv",
            "time (ms);crank.position (grad)\n0;1\n1;2\n".to_owned(),
            "column \"crank.position [grad]\": unit grad is not known; crank.position is in rad \
             (give rad or deg)",
        ),
    ]
}

/// A Parquet file of columns of the given types and values.
fn parquet_of(path: &Path, columns: Vec<(&str, arrow_array::ArrayRef)>) {
    use arrow_schema::{Field, Schema};
    let fields: Vec<Field> = (columns.iter())
        .map(|(name, array)| Field::new(*name, array.data_type().clone(), true))
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let arrays = columns.into_iter().map(|(_, array)| array).collect();
    let batch = arrow_array::RecordBatch::try_new(schema.clone(), arrays).unwrap();
    let mut bytes = Vec::new();
    let mut writer = parquet::arrow::ArrowWriter::try_new(&mut bytes, schema, None).unwrap();
    writer.write(&batch).unwrap();
    writer.close().unwrap();
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn parquet_columns_of_other_number_types_are_read_and_others_refused() {
    use arrow_array::{Float32Array, Float64Array, Int64Array, StringArray};
    let dir = scratch("parquet-types");
    let path = dir.join("types.parquet");
    parquet_of(
        &path,
        vec![
            ("time [ms]", Arc::new(Int64Array::from(vec![0, 1, 2]))),
            (
                "ram_position [mm]",
                Arc::new(Float32Array::from(vec![0.5, 1.5, 2.5])),
            ),
        ],
    );
    let data = RunData::read(&path, &[]).expect("reads");
    assert_eq!(data.time, [0.0, 1e-3, 2e-3]);
    assert_eq!(data.column("ram_position").unwrap().values, [0.5, 1.5, 2.5]);
    let bound = |path: &Path| RunData::read(path, &[]).and_then(|d| d.bind(&small_plant(), 1.0, 1));
    parquet_of(
        &path,
        vec![
            ("time [s]", Arc::new(Float64Array::from(vec![0.0, 1.0]))),
            ("status", Arc::new(StringArray::from(vec!["RUN", "STOP"]))),
            (
                "ram_position [mm]",
                Arc::new(Float32Array::from(vec![0.5, 1.5])),
            ),
        ],
    );
    let trace = bound(&path).expect("a column of text the plant does not know is left out");
    assert_eq!(trace.left_out, ["status"]);
    assert_eq!(trace.measured[0].as_deref(), Some(&[0.5e-3, 1.5e-3][..]));
    parquet_of(
        &path,
        vec![
            ("time [s]", Arc::new(Float64Array::from(vec![0.0, 1.0]))),
            (
                "ram_position [m]",
                Arc::new(StringArray::from(vec!["a", "b"])),
            ),
        ],
    );
    let message = bound(&path).unwrap_err().to_string();
    assert!(
        message.contains("column \"ram_position [m]\": its values are Utf8, not numbers"),
        "{message}"
    );
    parquet_of(
        &path,
        vec![
            ("time [s]", Arc::new(Float64Array::from(vec![0.0, 1.0]))),
            (
                "ram_position [m]",
                Arc::new(Float64Array::from(vec![Some(1.0), None])),
            ),
        ],
    );
    let message = bound(&path).unwrap_err().to_string();
    assert!(
        message.contains("row 3, column \"ram_position [m]\": empty cell"),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A small deterministic generator (xorshift) for the mutations.
struct Mutator(u64);

impl Mutator {
    fn next(&mut self, below: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % below.max(1) as u64) as usize
    }

    /// `bytes` with a few bytes deleted, replaced or inserted, or cut short.
    fn mutate(&mut self, bytes: &[u8]) -> Vec<u8> {
        const PIECES: [&[u8]; 10] = [
            b",", b"\n", b"\"", b"[", b"]", b"NaN", b"-", b"1e999", b"\xff", b" ",
        ];
        let mut out = bytes.to_vec();
        for _ in 0..1 + self.next(4) {
            let at = self.next(out.len() + 1);
            match self.next(4) {
                0 if at < out.len() => {
                    out.remove(at);
                }
                1 => out
                    .splice(at..at, PIECES[self.next(PIECES.len())].iter().copied())
                    .for_each(drop),
                2 => out.truncate(at),
                _ if at < out.len() => out[at] = self.next(256) as u8,
                _ => {}
            }
        }
        out
    }
}

#[test]
fn malformed_files_are_refused_without_a_panic() {
    let dir = scratch("malformed");
    let csv = "time [s],ram_position [mm],true.crank.position [deg],effort.crank [N·m]\n\
               0,1,2,3\n0.001,1.5,2.5,3\n0.0025,2,3,4\n0.003,2.5,3.5,4\n";
    let parquet_path = dir.join("seed.parquet");
    let seed = RunData::read(&write(&dir, "seed.csv", csv), &[]).unwrap();
    seed.write_parquet(&parquet_path).unwrap();
    let parquet = std::fs::read(&parquet_path).unwrap();
    let mut mutator = Mutator(0x9e37_79b9_7f4a_7c15);
    let plant = small_plant();
    let mut accepted = 0;
    for case in 0..600 {
        let (name, seed) = if case % 3 == 0 {
            ("case.parquet", parquet.as_slice())
        } else {
            ("case.csv", csv.as_bytes())
        };
        let path = dir.join(name);
        std::fs::write(&path, mutator.mutate(seed)).unwrap();
        let result = RunData::read(&path, &[]).and_then(|d| d.bind(&plant, 1e-3, 1));
        match result {
            Ok(trace) => {
                accepted += 1;
                assert!(trace.samples >= 1);
            }
            Err(error) => assert!(!error.to_string().contains('\n'), "{error}"),
        }
    }
    assert!(accepted > 0, "some mutations leave a valid file");
    for cut in [0, 10, 100, 1000, 5000] {
        let path = dir.join("cut.rrd");
        let recording = make_recording(&dir);
        std::fs::write(&path, &recording[..cut.min(recording.len())]).unwrap();
        assert!(RunData::read(&path, &[]).is_err());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A short run's recording, as bytes.
fn make_recording(dir: &Path) -> Vec<u8> {
    let path = dir.join("short.rrd");
    if !path.exists() {
        Twin::new(loaded(0.01)).unwrap().run(Some(&path)).unwrap();
    }
    std::fs::read(&path).unwrap()
}
