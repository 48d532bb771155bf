//! `twin frf` on the milling tool (the virtual tap test) and the lobes from its frequency
//! responses: the tool's modal values come back, and the lobes agree with the model's.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use twin_cli::analysis::milling::{analyze, LobeRequest};
use twin_cli::flags::SetFlag;
use twin_cli::frf::{measure, write, Excitation, FrfArgs, FrfError};

const SCENARIO: &str = "milling-constant-15000";

/// The tap test's command: `--set process.cutting=false`, the tool out of the workpiece.
fn tap(joint: &str, excitation: Excitation) -> FrfArgs {
    FrfArgs {
        scenario: SCENARIO.into(),
        input: joint.into(),
        output: format!("{joint}.position"),
        excitation,
        averages: 8,
        band: None,
        amplitude: None,
        rate: 10_000.0,
        segment: 4096,
        seed: 1,
        controller: None,
        values: SetFlag {
            set: vec!["process.cutting=false".into()],
        },
        out_dir: PathBuf::from("unused"),
    }
}

/// The model's modal values from the URDF: (natural frequency Hz, damping ratio) of a tool joint
/// whose carried mass is `mass`.
fn model(mass: f64) -> (f64, f64) {
    let (k, c) = (1.3669e6, 11.064);
    ((k / mass).sqrt() / TAU, c / (2.0 * (k * mass).sqrt()))
}

/// The x joint carries the 1 mg carrier and the tip; the y joint the tip.
const MASS_X: f64 = 0.05598 + 1e-6;
const MASS_Y: f64 = 0.05598;

fn assert_mode(joint: &str, excitation: Excitation, mass: f64, zeta_tolerance: f64) {
    let band = (excitation == Excitation::Chirp).then(|| vec![400.0, 1200.0]);
    let args = FrfArgs {
        band,
        ..tap(joint, excitation)
    };
    let result = measure(&args, &controllers::builtin()).unwrap();
    let fit = result.mode.unwrap();
    let (fn_model, zeta_model) = model(mass);
    let fn_error = fit.natural_frequency_hz / fn_model - 1.0;
    let zeta_error = fit.damping_ratio / zeta_model - 1.0;
    println!("{joint} {excitation:?}: f_n {fn_error:+.2e}, ζ {zeta_error:+.2e}");
    assert!(
        fn_error.abs() < 0.01,
        "{joint}: f_n {}",
        fit.natural_frequency_hz
    );
    assert!(
        zeta_error.abs() < zeta_tolerance,
        "{joint}: ζ {}",
        fit.damping_ratio
    );
}

#[test]
fn the_tap_test_recovers_the_tools_modes() {
    assert_mode("tool_x", Excitation::Impulse, MASS_X, 0.05);
    assert_mode("tool_y", Excitation::Impulse, MASS_Y, 0.05);
    // Noise through a Hann window: its leakage widens the peak slightly.
    assert_mode("tool_y", Excitation::Noise, MASS_Y, 0.05);
    // A chirp repeated each segment, swept slowly enough over the mode (400–1200 Hz in 0.41 s)
    // that its ringing stays under the Hann window with the sweep.
    assert_mode("tool_x", Excitation::Chirp, MASS_X, 0.05);
}

#[test]
fn an_impulse_response_has_unit_coherence_and_the_static_compliance() {
    let result = measure(&tap("tool_x", Excitation::Impulse), &controllers::builtin()).unwrap();
    let dc = result.lines[0];
    assert_eq!(dc.frequency_hz, 0.0);
    // Static compliance 1/k.
    assert!(
        (dc.response.re * 1.3669e6 - 1.0).abs() < 1e-3,
        "{:?}",
        dc.response
    );
    assert!(result.lines.iter().all(|l| l.coherence > 0.999));
    // The same inputs, the same bytes.
    let again = measure(&tap("tool_x", Excitation::Impulse), &controllers::builtin()).unwrap();
    assert_eq!(
        twin_cli::frequency_response::file::to_csv(&result.lines),
        twin_cli::frequency_response::file::to_csv(&again.lines)
    );
}

fn lobes(frf: Option<[PathBuf; 2]>) -> twin_cli::analysis::milling::LobeAnalysis {
    lobes_checked(frf, 21, [0, 0])
}

/// The lobes at `speed_count` speeds over 10,000–25,000 rpm, with `check` = [speeds, depths]
/// time-domain runs.
fn lobes_checked(
    frf: Option<[PathBuf; 2]>,
    speed_count: usize,
    check: [usize; 2],
) -> twin_cli::analysis::milling::LobeAnalysis {
    let rpm = |n: f64| n * TAU / 60.0;
    analyze(
        &LobeRequest {
            scenario: twin::Scenario::builtin(SCENARIO).unwrap(),
            speeds: [rpm(10_000.0), rpm(25_000.0)],
            speed_count,
            max_depth: 3e-3,
            check,
            check_duration: 0.4,
            frf,
        },
        &controllers::builtin(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn lobes_from_the_tap_tests_frfs_agree_with_the_models() {
    let dir = scratch("lobes");
    let registry = controllers::builtin();
    let mut files = Vec::new();
    for joint in ["tool_x", "tool_y"] {
        let result = measure(&tap(joint, Excitation::Impulse), &registry).unwrap();
        let written = write(&result, &dir.as_path().join(joint)).unwrap();
        files.push(written[0].clone());
    }
    let from_frf = lobes(Some([files[0].clone(), files[1].clone()]));
    let (worst, at) = from_frf.frf_deviation().unwrap();
    println!("{}", from_frf.summary());
    assert!(worst < 0.02, "{:.2} % at {at} rpm", 100.0 * worst);
    // Independently: the model's own lobes, computed without FRFs, are the ones compared with.
    let model = lobes(None);
    let (_, reference) = from_frf.from_frf.as_ref().unwrap();
    assert_eq!(&model.lobes, reference);
    assert!(from_frf.lobes.iter().all(|p| p.boundary.is_some()));
    // Without time-domain runs there is no check.csv to write.
    let written = from_frf.write(&dir.as_path().join("no-check")).unwrap();
    let names: Vec<_> = written.iter().map(|p| p.file_name().unwrap()).collect();
    assert_eq!(names, ["lobes.csv", "frf-vs-model.csv", "lobes.rrd"]);
    // The twin's runs of the scenario's tool judge the lobes of its measured responses: a
    // stable and a chattering depth at 10,000 rpm, against the FRF lobes' limit there, which is
    // the model's to 2 %.
    let checked = lobes_checked(Some([files[0].clone(), files[1].clone()]), 2, [1, 2]);
    assert_eq!(checked.checks.len(), 2);
    for c in &checked.checks {
        let point = model
            .lobes
            .iter()
            .find(|p| p.spindle_speed == c.speed)
            .unwrap();
        let model_limit = point.boundary.map_or(f64::INFINITY, |b| b.depth);
        assert!(
            (c.limit / model_limit - 1.0).abs() < 0.02,
            "{} vs {model_limit}",
            c.limit
        );
    }
    let (agree, judged) = checked.agreement();
    assert_eq!((agree, judged), (2, 2), "{}", checked.summary());
    let written = checked.write(&dir.as_path().join("checked")).unwrap();
    assert!(written.iter().any(|p| p.ends_with("check.csv")));
}

fn error(args: &FrfArgs) -> String {
    match measure(args, &controllers::builtin()) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_frf_input_is_refused_naming_the_argument() {
    let base = tap("tool_x", Excitation::Impulse);
    let mut cases = measurement_cases(&base);
    cases.extend(excitation_and_scenario_cases(&base));
    for (args, words) in cases {
        let message = error(&args);
        assert!(!message.contains('\n'), "{message}");
        for word in words {
            assert!(message.contains(word), "`{word}` not in: {message}");
        }
    }
}

/// A bad tap test (arguments, the words its refusal must name).
type Case = (FrfArgs, &'static [&'static str]);

/// Bad measurements: an unknown input or output, a band beyond Nyquist or finer than the
/// segment resolves, a segment not a power of two, no averages, a rate the time step cannot give.
fn measurement_cases(base: &FrfArgs) -> Vec<Case> {
    vec![
        (
            FrfArgs {
                input: "tool_z".into(),
                ..base.clone()
            },
            &["--input", "tool_z", "tool_x"],
        ),
        (
            FrfArgs {
                output: "tool_z.position".into(),
                ..base.clone()
            },
            &["--output", "tool_z.position", "known"],
        ),
        (
            FrfArgs {
                band: Some(vec![10.0, 6000.0]),
                ..base.clone()
            },
            &["--band", "Nyquist", "5000"],
        ),
        (
            FrfArgs {
                band: Some(vec![100.0, 102.0]),
                ..base.clone()
            },
            &["--band", "resolution", "--segment"],
        ),
        (
            FrfArgs {
                segment: 1000,
                ..base.clone()
            },
            &["--segment", "power of two"],
        ),
        (
            FrfArgs {
                averages: 0,
                ..base.clone()
            },
            &["--averages"],
        ),
        (
            FrfArgs {
                rate: 30_000.0,
                ..base.clone()
            },
            &["--rate", "dt"],
        ),
    ]
}

/// Bad excitations and scenarios: an amplitude not finite or over the drive's limit, a misspelt
/// `--set`, an unknown scenario.
fn excitation_and_scenario_cases(base: &FrfArgs) -> Vec<Case> {
    vec![
        (
            FrfArgs {
                amplitude: Some(f64::NAN),
                ..base.clone()
            },
            &["--amplitude"],
        ),
        // The spindle's drive gives at most 12 N·m.
        (
            FrfArgs {
                input: "spindle".into(),
                output: "spindle.velocity".into(),
                amplitude: Some(20.0),
                ..base.clone()
            },
            &["--amplitude", "limit 12", "spindle"],
        ),
        (
            FrfArgs {
                values: SetFlag {
                    set: vec!["process.cuting=false".into()],
                },
                ..base.clone()
            },
            &["process", "cuting", "cutting"],
        ),
        (
            FrfArgs {
                scenario: "no-such-scenario".into(),
                ..base.clone()
            },
            &["scenario", "no-such-scenario"],
        ),
    ]
}

#[test]
fn a_diverging_run_is_named() {
    // The tap (100 N over 0.1 ms: 0.18 m/s) beyond a [health] speed limit of 0.05 m/s, with
    // the spindle nearly still so that only the tool can exceed it.
    let mut args = tap("tool_x", Excitation::Impulse);
    args.values.set.extend(
        [
            "health.max_joint_speed=0.05",
            "initial.spindle.velocity=0",
            "controller.params.speed=1e-3",
        ]
        .map(String::from),
    );
    match measure(&args, &controllers::builtin()) {
        Err(FrfError::Diverged(message)) => {
            assert!(message.contains("tool_x.velocity"), "{message}")
        }
        other => panic!("{:?}", other.map(|r| r.lines.len())),
    }
}

/// An empty folder of this test's own under Cargo's scratch folder for integration tests.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("frf-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn frf_file(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn malformed_frf_files_are_refused_naming_file_line_and_column() {
    let dir = scratch("files");
    let header = twin_cli::frequency_response::file::HEADER;
    let good = format!("{header}\n0,1,0,1,1,0\n");
    let cases = [
        ("missing.csv", None, vec!["missing.csv", "cannot read"]),
        (
            "header.csv",
            Some("f,m\n0,1\n".to_string()),
            vec!["header.csv:1", "header"],
        ),
        (
            "nan.csv",
            Some(format!("{header}\n0,1,0,1,1,0\n2,1,0,1,nan,0\n")),
            vec!["nan.csv:3", "column 5 (real)", "nan"],
        ),
        (
            "short.csv",
            Some(format!("{header}\n0,1,0\n")),
            vec!["short.csv:2", "3 columns"],
        ),
        (
            "order.csv",
            Some(format!("{header}\n5,1,0,1,1,0\n2,1,0,1,1,0\n")),
            vec!["order.csv:3", "column 1"],
        ),
        ("flat.csv", Some(good), vec!["flat.csv", "--frf-x"]),
    ];
    for (name, text, words) in cases {
        let path = match text {
            Some(text) => frf_file(dir.as_path(), name, &text),
            None => dir.as_path().join(name),
        };
        let rpm = |n: f64| n * TAU / 60.0;
        let result = analyze(
            &LobeRequest {
                scenario: twin::Scenario::builtin(SCENARIO).unwrap(),
                speeds: [rpm(10_000.0), rpm(25_000.0)],
                speed_count: 3,
                max_depth: 3e-3,
                check: [0, 0],
                check_duration: 0.4,
                frf: Some([path.clone(), path]),
            },
            &controllers::builtin(),
        );
        let message = result.err().map(|e| e.to_string()).expect("accepted");
        assert!(!message.contains('\n'), "{message}");
        for word in words {
            assert!(message.contains(word), "`{word}` not in: {message}");
        }
    }
}

#[test]
fn the_feed_axis_open_loop_response_is_its_linear_model() {
    // The table under noise, controller off: the measured H1 against `twin linearize`'s
    // 1/(m·s² + b·s), where the coherence says the measurement is clean.
    let args = FrfArgs {
        scenario: "feed-axis-micromilling".into(),
        input: "table".into(),
        output: "table.position".into(),
        excitation: Excitation::Noise,
        band: Some(vec![1.0, 200.0]),
        rate: 1000.0,
        segment: 1024,
        controller: Some("passive".into()),
        ..tap("table", Excitation::Noise)
    };
    let result = measure(&args, &controllers::builtin()).unwrap();
    let difference = twin_cli::frf::linear_difference(&result).unwrap();
    println!("feed axis: largest |H − G|/|G| {difference:.3e}");
    assert!(difference < 0.03, "measured vs linear model: {difference}");
    let quoted = format!("to {:.2} % over 1–200 Hz", 100.0 * difference);
    let guide = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/src/control-design.md"
    ))
    .unwrap();
    assert!(
        guide.contains(&quoted),
        "control-design.md should say `{quoted}`"
    );
    // frf.rrd draws the linear model over the measurement, on the same axes.
    let dir = scratch("bode");
    let written = write(&result, &dir).unwrap();
    let contents = twin::recordings::inspect(&written[1]).unwrap();
    assert_eq!(contents.views_2d, ["magnitude", "phase", "coherence γ²"]);
    let layer = |name: &str| {
        let path = format!("/figures/0/data/{name}");
        let layers = contents.figure_layers.keys().collect::<Vec<_>>();
        (contents.figure_layers.get(&path)).unwrap_or_else(|| panic!("{path} not in {layers:?}"))
    };
    let model = &layer("linear_model").lines;
    assert!(!layer("measured").lines.is_empty());
    let linear = result.linear.as_ref().unwrap();
    let first = [result.lines[0].frequency_hz, 20.0 * linear[0].abs().log10()];
    assert_eq!(model[0][0], first.map(|v| v as f32));
    assert_eq!(
        model.iter().map(Vec::len).sum::<usize>(),
        result.lines.len()
    );
    std::fs::remove_dir_all(&dir).unwrap();
    // With its P-PI on, the loop is closed: no comparison, and the reason names the controller.
    let closed = measure(
        &FrfArgs {
            controller: None,
            ..args
        },
        &controllers::builtin(),
    )
    .unwrap();
    let reason = twin_cli::frf::linear_difference(&closed).unwrap_err();
    assert!(reason.contains("p-pi"), "{reason}");
}
