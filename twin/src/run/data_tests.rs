//! The data format's round trips (CSV, Parquet, a recording), a run's rows written when it is
//! interrupted, and the unit conversions and resampling checked against hand values.

use super::simulator::Simulator;
use super::table::RunTable;
use super::twin::{StopFlag, Twin};
use crate::data::sha256_hex;
use crate::data::*;
use crate::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(super) fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-data-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

pub(super) fn loaded(duration: f64) -> crate::scenario::LoadedScenario {
    Scenario::builtin("whitworth-crank-pi")
        .expect("built-in")
        .duration(duration)
        .build(&controllers::builtin())
        .expect("builds")
}

/// The Whitworth crank-PI scenario's plant.
fn whitworth_plant() -> PlantColumns {
    PlantColumns::of_simulator(&Simulator::new(loaded(0.1)).expect("simulator"))
}

/// A small plant: one torque, a ram position and a crank angle.
pub(super) fn small_plant() -> PlantColumns {
    let pair = |a: &str, b: &str| (a.to_owned(), b.to_owned());
    PlantColumns {
        actuators: vec![pair("crank", "N·m")],
        signals: vec![pair("ram_position", "m"), pair("crank.position", "rad")],
    }
}

pub(super) fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path
}

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn a_run_written_as_csv_and_parquet_reads_back_bit_identical() {
    let dir = scratch("round-trip");
    let (csv, parquet) = (dir.join("run.csv"), dir.join("run.parquet"));
    let mut table = RunTable::new(Some(csv.clone()), Some(parquet.clone()));
    let summary = Twin::new(loaded(0.2))
        .expect("twin")
        .run_with(None, &mut [&mut table])
        .expect("runs");
    assert!(summary.failure.is_none());
    let written = table.data();
    assert_eq!(
        written.time.len(),
        201,
        "one row per control update, t = 0 … 0.2 s"
    );
    let headers: Vec<String> = written.columns.iter().map(RunData::header).collect();
    for expected in [
        "effort.crank [N·m]",
        "crank.position [rad]",
        "ram_position [m]",
        "true.ram_velocity [m/s]",
    ] {
        assert!(
            headers.iter().any(|h| h == expected),
            "{expected} in {headers:?}"
        );
    }
    let plant = whitworth_plant();
    for path in [&csv, &parquet] {
        let read = RunData::read(path, &[]).expect("reads back");
        assert_eq!(read.source, path.display().to_string());
        assert_eq!(read.digest.len(), 64);
        assert!(same_bits(&read.time, &written.time));
        assert_eq!(read.columns.len(), written.columns.len());
        for (a, b) in read.columns.iter().zip(&written.columns) {
            assert_eq!((&a.name, &a.unit), (&b.name, &b.unit));
            assert!(same_bits(&a.values, &b.values), "{}", a.name);
        }
        let trace = read.bind(&plant, 1e-3, 10).expect("binds");
        assert!(!trace.rate.resampled);
        assert_eq!(trace.samples, 201);
        assert!(trace
            .commands
            .iter()
            .chain(&trace.measured)
            .all(Option::is_some));
        let ram = plant
            .signals
            .iter()
            .position(|(s, _)| s == "ram_position")
            .unwrap();
        let column = read.column("true.ram_position").expect("column");
        assert!(same_bits(
            trace.truth[ram].as_ref().unwrap(),
            &column.values
        ));
    }
    assert_eq!(
        written.digest,
        sha256_hex(&std::fs::read(&csv).expect("csv"))
    );
    // Written again, a file is the same bytes.
    let again = dir.join("again.csv");
    RunData::read(&csv, &[]).unwrap().write_csv(&again).unwrap();
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&csv).unwrap());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_recording_reads_back_as_the_runs_table() {
    let dir = scratch("recording");
    let (rrd, csv) = (dir.join("run.rrd"), dir.join("run.csv"));
    let mut table = RunTable::new(Some(csv.clone()), None);
    // 0.6 s: the crank turns past half a turn, so its wrapped angle must be unwrapped.
    Twin::new(loaded(0.6))
        .expect("twin")
        .run_with(Some(&rrd), &mut [&mut table])
        .expect("runs");
    let from_csv = RunData::read(&csv, &[]).expect("csv");
    let from_rrd = RunData::read(&rrd, &[]).expect("rrd");
    assert_eq!(from_rrd.time.len(), from_csv.time.len());
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
    assert!(from_rrd
        .time
        .iter()
        .zip(&from_csv.time)
        .all(|(a, b)| close(*a, *b)));
    for column in &from_csv.columns {
        let other = from_rrd
            .column(&column.name)
            .unwrap_or_else(|| panic!("{} not in the recording", column.name));
        assert_eq!(other.unit, column.unit, "{}", column.name);
        let worst = (column.values.iter().zip(&other.values))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let fits = (column.values.iter().zip(&other.values)).all(|(a, b)| close(*a, *b));
        assert!(fits, "{}: off by {worst:e}", column.name);
    }
    assert_eq!(from_rrd.columns.len(), from_csv.columns.len());
    let crank = from_rrd.column("true.crank.position").unwrap();
    assert!(crank.values.iter().any(|v| v.abs() > std::f64::consts::PI));
    // The recording binds like the CSV.
    let trace = from_rrd.bind(&whitworth_plant(), 1e-3, 10).expect("binds");
    assert_eq!(trace.samples, 601);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn every_built_in_scenarios_recording_binds_as_its_csv() {
    let dir = scratch("every-scenario");
    let registry = controllers::builtin();
    for (name, _) in crate::scenario::BUILTIN {
        let builder = || -> crate::scenario::ScenarioBuilder {
            let scenario = Scenario::builtin(name).expect("built-in");
            let periods = scenario.clone().build(&registry).expect("builds").scenario;
            let duration = 30.0 * periods.control_period();
            scenario
                .duration(duration)
                .set("recording.every", 1_usize)
                .expect("key")
        };
        let (rrd, csv) = (
            dir.join(format!("{name}.rrd")),
            dir.join(format!("{name}.csv")),
        );
        let mut table = RunTable::new(Some(csv.clone()), None);
        let loaded = builder().build(&registry).expect("builds");
        let period = loaded.scenario.control_period();
        Twin::new(loaded)
            .expect("twin")
            .run_with(Some(&rrd), &mut [&mut table])
            .expect("runs");
        let plant = PlantColumns::of_simulator(
            &Simulator::new(builder().build(&registry).unwrap()).expect("simulator"),
        );
        let bind = |path: &Path| {
            let data = RunData::read(path, &[]).unwrap_or_else(|e| panic!("{e}"));
            data.bind(&plant, period, 2)
                .unwrap_or_else(|e| panic!("{e}"))
        };
        let (from_csv, from_rrd) = (bind(&csv), bind(&rrd));
        assert_eq!(from_rrd.samples, from_csv.samples, "{name}");
        let close = |a: &[f64], b: &[f64]| {
            let scale = a.iter().map(|v| v.abs()).fold(1.0, f64::max);
            a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * scale)
        };
        let lists = [
            ("command", &from_csv.commands, &from_rrd.commands),
            ("measured", &from_csv.measured, &from_rrd.measured),
            ("true", &from_csv.truth, &from_rrd.truth),
        ];
        for (what, csv_lists, rrd_lists) in lists {
            for (k, (a, b)) in csv_lists.iter().zip(rrd_lists).enumerate() {
                let a = a.as_deref().expect("the CSV has every column");
                // Only a signal with a sensor fault but no sensor lacks a measured series.
                let Some(b) = b.as_deref() else {
                    assert_eq!(what, "measured", "{name}: {what} {k} not in the recording");
                    continue;
                };
                assert!(close(a, b), "{name}: {what} {k}: {a:?} vs {b:?}");
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_interrupted_run_still_writes_its_rows() {
    let dir = scratch("interrupted");
    let csv = dir.join("run.csv");
    let mut table = RunTable::new(Some(csv.clone()), None);
    let stop: StopFlag = Arc::new(std::sync::atomic::AtomicUsize::new(2));
    let summary = Twin::new(loaded(0.2))
        .expect("twin")
        .with_stop_flag(stop)
        .run_with(None, &mut [&mut table])
        .expect("runs");
    assert!(summary.interrupted.is_some());
    let read = RunData::read(&csv, &[]).expect("written");
    assert_eq!(read.time, table.data().time);
    assert!(!read.time.is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn units_convert_to_si_and_renames_apply_first() {
    let dir = scratch("units");
    let text = "time [ms],pos [mm],crank.position [deg],effort.crank [N.mm]\n\
                0,1,180,2000\n\
                1,-2.5,90,-500\n";
    let path = write(&dir, "units.csv", text);
    let renames = parse_renames(&["pos=ram_position".to_owned()]).unwrap();
    let data = RunData::read(&path, &renames).expect("reads");
    assert_eq!(data.time, [0.0, 1e-3]);
    assert_eq!(data.column("ram_position").unwrap().unit, "mm");
    let trace = data.bind(&small_plant(), 1e-3, 2).expect("binds");
    assert_eq!(trace.measured[0].as_deref(), Some(&[1e-3, -2.5e-3][..]));
    let angle = trace.measured[1].as_deref().unwrap();
    assert_eq!(angle, [std::f64::consts::PI, std::f64::consts::FRAC_PI_2]);
    assert_eq!(trace.commands[0].as_deref(), Some(&[2.0, -0.5][..]));
    assert!(trace.truth.iter().all(Option::is_none));
    // ASCII spellings and the twin's own display units.
    for (unit, si, value) in [
        ("um", "m", 1e-6),
        ("m/s^2", "m/s²", 1.0),
        ("rpm", "rad/s", std::f64::consts::TAU / 60.0),
        ("kN", "N", 1e3),
        ("rad/s^2", "rad/s²", 1.0),
        ("N.m", "N·m", 1.0),
    ] {
        assert_eq!(
            crate::data::units::factor(unit, "x", si),
            Ok(value),
            "{unit}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn irregular_rows_are_resampled_linearly_and_commands_held_or_bridged_across_a_gap() {
    let dir = scratch("irregular");
    let text = "time [s],ram_position [m],true.ram_position [m],effort.crank [N·m]\n\
                0,0,10,1\n\
                0.0015,3,13,2\n\
                0.002,4,14,3\n\
                0.0041,8.2,18.2,4\n";
    let data = RunData::read(&write(&dir, "irregular.csv", text), &[]).unwrap();
    let trace = data.bind(&small_plant(), 1e-3, 2).unwrap();
    assert!(trace.rate.resampled);
    assert_eq!(trace.samples, 5, "0 … 4 ms");
    assert_eq!(trace.start_time, 0.0);
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
    let measured = trace.measured[0].as_deref().unwrap();
    assert!(close(measured, &[0.0, 2.0, 4.0, 6.0, 8.0]), "{measured:?}");
    let truth = trace.truth[0].as_deref().unwrap();
    assert!(close(truth, &[10.0, 12.0, 14.0, 16.0, 18.0]), "{truth:?}");
    // The last command at or before each grid time, where the rows are at most 1.5 periods
    // apart; across the 2.1 ms gap, between the rows around it (linear: no row beyond).
    let commands = trace.commands[0].as_deref().unwrap();
    assert!(
        close(commands, &[1.0, 1.0, 3.0, 3.0 + 1.0 / 2.1, 3.0 + 2.0 / 2.1]),
        "{commands:?}"
    );
    // The rows' own places on the grid, where a fit compares.
    assert!(close(trace.rows.as_deref().unwrap(), &[0.0, 1.5, 2.0, 4.1]));
    assert!(close(
        trace.logged[0].as_deref().unwrap(),
        &[0.0, 3.0, 4.0, 8.2]
    ));
    let rate = trace.rate;
    assert!((rate.mean_period - 0.0041 / 3.0).abs() < 1e-15);
    assert!((rate.min_period - 0.0005).abs() < 1e-15);
    assert!((rate.max_period - 0.0021).abs() < 1e-15);
    std::fs::remove_dir_all(&dir).ok();
}

/// The twin's own file, to which every logger's way of writing it must read back, bit for bit.
const PLAIN: &str = "time [s],ram_position [m],crank.position [rad],effort.crank [N·m]\n\
                     0,0.25,1.5,2\n\
                     0.001,0.5,-1.25,3\n\
                     0.002,-0.75,1e-3,-4.5\n";

/// `text` read as `name` with `options` and bound to the small plant at 1 ms.
fn bound_with(dir: &Path, name: &str, text: &str, options: &ReadOptions) -> Trace {
    let path = write(dir, name, text);
    let data = RunData::read_with(&path, options).unwrap_or_else(|e| panic!("{name}: {e}"));
    data.bind(&small_plant(), 1e-3, 2)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn same_trace(a: &Trace, b: &Trace) -> bool {
    let lists = |t: &Trace| -> Vec<Option<Vec<f64>>> {
        (t.commands.iter().chain(&t.measured).chain(&t.truth))
            .cloned()
            .collect()
    };
    let same = |a: &Option<Vec<f64>>, b: &Option<Vec<f64>>| match (a, b) {
        (Some(a), Some(b)) => same_bits(a, b),
        (a, b) => a.is_none() && b.is_none(),
    };
    a.samples == b.samples
        && a.start_time.to_bits() == b.start_time.to_bits()
        && lists(a).iter().zip(&lists(b)).all(|(a, b)| same(a, b))
}

#[test]
fn a_loggers_ways_of_writing_the_table_read_as_the_twins_own() {
    let dir = scratch("logger-ways");
    let plain = bound_with(&dir, "plain.csv", PLAIN, &ReadOptions::default());
    let cases = [
        (
            "semicolon.csv",
            "# Logger X-200, firmware 3.1\n\
             # started 2024-05-02 10:14\n\
             time;ram_position;crank.position;effort.crank\n\
             s;m;rad;N·m\n\
             0;0,25;1,5;2\n\
             # a pause in the logging\n\
             0,001;0,5;-1,25;3\n\
             0,002;-0,75;1e-3;-4,5\n",
        ),
        (
            "tab.csv",
            "time (ms)\tram_position (mm)\tcrank.position (rad)\teffort.crank (N.mm)\n\
             0\t250\t1,5\t2000\n\
             1\t500\t-1,25\t3000\n\
             2\t-750\t0,001\t-4500\n",
        ),
        (
            "quoted.csv",
            "\"time [s]\",\"ram_position [m]\",\"crank.position [rad]\",\"effort.crank [N·m]\"\n\
             \"0\",\"0.25\",1.5,\"2\"\n\
             0.001,\"0.5\",\"-1.25\",3\n\
             \"0.002\",-0.75,\"1e-3\",\"-4.5\"\n",
        ),
        (
            "quoted-semicolon.csv",
            "time;\"ram_position\";crank.position;effort.crank\n\
             [s];[m];(rad);\"N·m\"\n\
             \"0\";\"0,25\";1,5;2\n\
             0,001;\"0,5\";-1,25;3\n\
             0,002;-0,75;0,001;-4,5\n",
        ),
        (
            "units-row-and-brackets.csv",
            "\u{feff}time [s],ram_position,crank.position [rad],effort.crank\r\n\
             ,m,,N·m\r\n\
             0,0.25,1.5,2\r\n\r\n\
             0.001,0.5,-1.25,3\r\n\
             0.002,-0.75,0.001,-4.5\r\n",
        ),
    ];
    for (name, text) in cases {
        let trace = bound_with(&dir, name, text, &ReadOptions::default());
        assert!(same_trace(&trace, &plain), "{name}: {trace:?}\n{plain:?}");
        assert!(trace.left_out.is_empty(), "{name}: {:?}", trace.left_out);
    }
    // The tab file's separator given rather than found: the same table.
    let tab = ReadOptions {
        delimiter: Some(Delimiter::Tab),
        ..ReadOptions::default()
    };
    let text = cases[1].1;
    assert!(same_trace(&bound_with(&dir, "tab.csv", text, &tab), &plain));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_separator_is_the_one_the_header_holds_most_of() {
    let dir = scratch("separator");
    let read = |name: &str, text: &str| {
        let data = RunData::read(&write(&dir, name, text), &[]).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = data.columns.iter().map(|c| c.name.as_str()).collect();
        (names.join("|"), data.column("b").map(|c| c.values.clone()))
    };
    // A comma inside a `;` file's header is part of a name; the `;` file's decimal comma reads.
    let (names, b) = read("semicolon.csv", "time [s];a,x [1];b [1]\n0;1;2,5\n");
    assert_eq!((names.as_str(), b), ("a,x|b", Some(vec![2.5])));
    // A quoted separator does not count.
    let (names, b) = read("quoted.csv", "time [s],\"a;x;y [1]\",b [1]\n0,1,2.5\n");
    assert_eq!((names.as_str(), b), ("a;x;y|b", Some(vec![2.5])));
    // Tab wins a tie, and `,` is the separator of a header without any.
    let (names, _) = read("tie.csv", "time [s]\ta;b [1]\n0\t1\n");
    assert_eq!(names, "a;b");
    let (names, _) = read("one.csv", "time [s]\n0\n");
    assert_eq!(names, "");
    // Given, the separator is taken as given.
    for (given, expected) in [(",", ','), ("comma", ','), (";", ';'), ("tab", '\t')] {
        let delimiter: Delimiter = given.parse().expect("a separator");
        assert_eq!(delimiter.separator(), expected);
    }
    let refused = "|".parse::<Delimiter>().unwrap_err();
    assert_eq!(refused, "`|` is not a separator; give `,`, `;` or `tab`");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn columns_the_plant_does_not_know_are_left_out_with_a_note_or_refused_when_strict() {
    let dir = scratch("unknown-columns");
    let text = "# spindle test\n\
                time;temperature;ram_position;status;true.spindle_speed;effort.table;mode\n\
                s;°C;mm;1;rpm;N;\n\
                0;21,5;250;0x0037;1200;3;RUN\n\
                0,001;21,5;500;0x0037;1200;3;\n\
                0,002;21,6;-750;0x0036;1201;3;STOP\n";
    let path = write(&dir, "logger.csv", text);
    let file = path.display().to_string();
    let data = RunData::read(&path, &[]).expect("reads");
    assert_eq!(data.unread.len(), 2, "status and mode are not numbers");
    assert_eq!(data.unread[0].row, Some(4));
    let trace = data.bind(&small_plant(), 1e-3, 2).expect("binds");
    let left_out = [
        "temperature [°C]",
        "true.spindle_speed [rpm]",
        "effort.table [N]",
        "status [1]",
        "mode",
    ];
    assert_eq!(trace.left_out, left_out);
    assert_eq!(trace.measured[0].as_deref(), Some(&[0.25, 0.5, -0.75][..]));
    assert_eq!(
        left_out_note(&trace.source, &trace.left_out).as_deref(),
        Some(
            format!(
                "{file}: left out 5 columns the scenario does not know: temperature [°C], \
                 true.spindle_speed [rpm], effort.table [N], status [1], mode (--strict refuses \
                 them)"
            )
            .as_str()
        )
    );
    assert_eq!(left_out_note(&file, &[]), None);
    assert_eq!(
        left_out_note(&file, &["x [1]".to_owned()]),
        Some(format!(
            "{file}: left out 1 column the scenario does not know: x [1] (--strict refuses it)"
        ))
    );
    // Left out of the data itself, for a caller that binds later.
    let mut pruned = data.clone();
    assert_eq!(
        pruned.leave_out_unknown(&small_plant()).expect("known"),
        left_out
    );
    assert_eq!(pruned.columns.len(), 1);
    assert!(pruned.unread.is_empty());
    let again = pruned.bind(&small_plant(), 1e-3, 2).expect("binds");
    assert!(again.left_out.is_empty() && same_trace(&again, &trace));
    // Strict, the first one is refused, naming the fix.
    let strict = ReadOptions {
        strict: true,
        ..ReadOptions::default()
    };
    let data = RunData::read_with(&path, &strict).expect("reads");
    let message = data.bind(&small_plant(), 1e-3, 2).unwrap_err().to_string();
    assert!(
        message.starts_with(&format!(
            "{file}: column \"temperature [°C]\": unknown signal temperature"
        )) && message.contains("--rename temperature=<known>, or read without --strict"),
        "{message}"
    );
    let mut data = data;
    assert!(data.leave_out_unknown(&small_plant()).is_err());
    // A column the plant knows with a cell that is not a number is refused all the same.
    let text = "time [s],ram_position [m],mode\n0,1,RUN\n0.001,x,RUN\n";
    let data = RunData::read(&write(&dir, "known.csv", text), &[]).expect("reads");
    let message = data.bind(&small_plant(), 1e-3, 2).unwrap_err().to_string();
    assert!(
        message.ends_with("row 3, column \"ram_position [m]\": `x` is not a number"),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
