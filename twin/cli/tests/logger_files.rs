//! Files as a machine's logger writes them, read by `twin compare` and `twin calibrate`: `;`
//! separators with decimal commas, comments, a units row, a column the scenario does not know
//! (left out with a note, refused with `--strict`), `--delimiter`, and the one rename flag
//! (`--rename`, `[calibration.rename]`; `--map` and `[calibration.map]` refused).

mod common;

use common::{scratch, twin};
use std::path::Path;
use std::process::Output;

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).to_string()
}

fn ok(output: &Output) -> String {
    let stdout = text(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        text(&output.stderr)
    );
    stdout
}

/// The one line of a refused command, with its exit code.
fn refused(output: &Output, code: i32) -> String {
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    stderr
}

/// `run.csv`, as `twin run --csv` writes it, and `logger.csv`, the same run as a logger writes
/// it: a comment, bare names with a units row, `;` separators, decimal commas, a temperature
/// column and a comment between rows.
fn logged_runs(dir: &Path) {
    let args = [
        "run",
        "whitworth-crank-pi",
        "--duration",
        "0.5",
        "--csv",
        "run.csv",
        "--out",
        "run.rrd",
    ];
    ok(&twin(&args, dir));
    let written = std::fs::read_to_string(dir.join("run.csv")).unwrap();
    let mut lines = written.lines();
    let header: Vec<(&str, &str)> = (lines.next().unwrap().split(','))
        .map(|cell| cell.trim_end_matches(']').split_once(" [").unwrap())
        .collect();
    let names: Vec<&str> = header.iter().map(|(name, _)| *name).collect();
    let units: Vec<&str> = header.iter().map(|(_, unit)| *unit).collect();
    let mut logger = format!(
        "# PLC trace, shaper 2\n{};temperature\n{};°C\n",
        names.join(";"),
        units.join(";")
    );
    for (k, line) in lines.enumerate() {
        let cells = line.replace(',', ";").replace('.', ",");
        logger += &format!("{cells};2{},5\n", k % 3);
        if k == 100 {
            logger += "# tool change\n";
        }
    }
    std::fs::write(dir.join("logger.csv"), logger).unwrap();
}

/// The comparison's figures without the line that names the file.
fn figures(stdout: &str) -> String {
    let named = |line: &&str| line.ends_with(".csv");
    stdout
        .lines()
        .filter(|l| !named(l))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn compare_reads_a_loggers_file_and_notes_the_column_it_leaves_out() {
    let dir = scratch("logger", "compare");
    logged_runs(&dir);
    let compare = |extra: &[&str]| {
        let mut args = vec!["compare", "whitworth-crank-pi", "--data", "logger.csv"];
        args.extend(extra);
        twin(&args, &dir)
    };
    let output = compare(&[]);
    let logged = ok(&output);
    let note = "note: logger.csv: left out 1 column the scenario does not know: temperature \
                [°C] (--strict refuses it)\n";
    assert_eq!(text(&output.stderr), note);
    let plain = ok(&twin(
        &["compare", "whitworth-crank-pi", "--data", "run.csv"],
        &dir,
    ));
    assert!(logged.contains("\nlogger.csv\n"), "{logged}");
    assert_eq!(figures(&logged), figures(&plain));
    assert!(figures(&plain).contains("ram_position"), "{plain}");
    // The separator given, the same; the wrong one given, refused naming the flag.
    assert_eq!(
        figures(&ok(&compare(&["--delimiter", ";"]))),
        figures(&plain)
    );
    let message = refused(&compare(&["--delimiter", ","]), 1);
    assert!(
        message.starts_with("error: logger.csv: its header is one column with the separator `,` but holds `;`; give --delimiter ';'\n"),
        "{message}"
    );
    // Strict, the temperature is refused, in one line saying what to change.
    let message = refused(&compare(&["--strict"]), 1);
    assert!(
        message.starts_with(
            "error: logger.csv: column \"temperature [°C]\": unknown signal temperature"
        ) && message.contains("--rename temperature=<known>, or read without --strict")
            && common::error_lines(&message) == 1,
        "{message}"
    );
    // Renamed into a signal of the plant, its unit must fit.
    let message = refused(&compare(&["--rename", "temperature=ram_position"]), 1);
    assert!(
        message.contains("a second column named ram_position"),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_rename_flag_is_the_same_in_every_command_and_the_old_names_are_refused() {
    let dir = scratch("logger", "rename");
    logged_runs(&dir);
    let renamed = std::fs::read_to_string(dir.join("run.csv"))
        .unwrap()
        .replacen("ram_position [m]", "X1 [m]", 1);
    let renamed = renamed.replacen("time [s]", "t [s]", 1);
    std::fs::write(dir.join("renamed.csv"), renamed).unwrap();
    // Without the renames: no time; with them, X1 is the ram's position.
    let args = ["compare", "whitworth-crank-pi", "--data", "renamed.csv"];
    let message = refused(&twin(&args, &dir), 1);
    assert!(
        message.contains("no `time [s]` column (give one, or rename yours with --rename old=time)"),
        "{message}"
    );
    let mut args = args.to_vec();
    args.extend(["--rename", "t=time", "--rename", "X1=ram_position"]);
    let output = twin(&args, &dir);
    assert!(ok(&output).contains("ram_position"));
    assert_eq!(text(&output.stderr), "");
    for command in ["compare", "calibrate"] {
        let given = [command, "whitworth-crank-pi", "--data", "run.csv"];
        let fit = ["--fit", "urdf.link.ram.mass"];
        let args = |extra: [&'static str; 2]| -> Vec<&str> {
            let fit = if command == "calibrate" {
                &fit[..]
            } else {
                &[]
            };
            [&given[..], fit, &extra[..]].concat()
        };
        let message = refused(&twin(&args(["--map", "a=b"]), &dir), 2);
        assert!(message.contains("--map"), "{command}: {message}");
        let message = refused(&twin(&args(["--rename", "a"]), &dir), 1);
        assert!(
            message
                .starts_with("error: --rename `a`: give old=new, e.g. --rename pos=ram_position"),
            "{command}: {message}"
        );
    }
    let scenario = twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(name, _)| *name == "whitworth-crank-pi")
        .map(|(_, text)| text.to_string())
        .unwrap();
    let table = "\n[calibration]\ndata = [\"renamed.csv\"]\n\n[calibration.fit]\n\"urdf.link.ram.mass\" = {}\n";
    let old = format!("{scenario}{table}\n[calibration.map]\nt = \"time\"\n");
    std::fs::write(dir.join("old.toml"), old).unwrap();
    let message = refused(&twin(&["calibrate", "old.toml"], &dir), 1);
    assert!(
        message.contains("`calibration.map`: the table is now called [calibration.rename]; rename [calibration.map] to it")
            && common::error_lines(&message) == 1,
        "{message}"
    );
    let new =
        format!("{scenario}{table}\n[calibration.rename]\nt = \"time\"\nX1 = \"ram_position\"\n");
    std::fs::write(dir.join("new.toml"), new).unwrap();
    let output = twin(&["calibrate", "new.toml", "--max-iterations", "3"], &dir);
    let report = ok(&output);
    assert!(
        report.contains("urdf.link.ram.mass") && report.contains("ram_position"),
        "{report}"
    );
    assert!(
        !text(&output.stderr).contains("note:"),
        "{}",
        text(&output.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}
