//! The data format's round trips (CSV, Parquet, a recording), a run's rows written when it is
//! interrupted, and the unit conversions and resampling checked against hand values.

use super::*;
use crate::run::{StopFlag, Twin};
use crate::scenario::Scenario;
use std::path::PathBuf;
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
        assert_eq!(units::factor(unit, "x", si), Ok(value), "{unit}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn irregular_rows_are_resampled_linearly_and_commands_held() {
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
    // The last command at or before each grid time.
    assert_eq!(
        trace.commands[0].as_deref(),
        Some(&[1.0, 1.0, 3.0, 3.0, 3.0][..])
    );
    let rate = trace.rate;
    assert!((rate.mean_period - 0.0041 / 3.0).abs() < 1e-15);
    assert!((rate.min_period - 0.0005).abs() < 1e-15);
    assert!((rate.max_period - 0.0021).abs() < 1e-15);
    std::fs::remove_dir_all(&dir).ok();
}
