//! Calibration against a truth the tests hide in the data: runs made by the twin with perturbed
//! masses, damping, friction and a sensor bias (noise-free, then noisy over many seeds), fitted
//! back from the nominal scenario; and every refusal of the check.

use std::path::{Path, PathBuf};
use twin::calibration::{
    calibrate, compare, Calibration, CalibrationError, CalibrationOptions, FitParameter,
    StartStates,
};
use twin::data::RunData;
use twin::RunTable;
use twin::{Scenario, ScenarioBuilder, Twin};

/// A folder of its own under the system's temporary folder, for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-calibration-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `builder` under its controller and reads back the CSV the run wrote.
fn record(builder: ScenarioBuilder, file: &Path) -> RunData {
    let loaded = builder.build(&controllers::builtin()).unwrap();
    let mut table = RunTable::new(Some(file.to_path_buf()), None);
    let summary = Twin::new(loaded)
        .unwrap()
        .run_with(None, &mut [&mut table])
        .unwrap();
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    RunData::read(file, &[]).unwrap()
}

/// The Whitworth's crank-speed loop, `seconds` long, with an ideal crank encoder (its 10,000
/// counts per turn would be noise the noise-free tests do not want).
fn whitworth(seconds: f64) -> ScenarioBuilder {
    Scenario::builtin("whitworth-crank-pi")
        .unwrap()
        .duration(seconds)
        .set("sensors.\"crank.position\".resolution", 0.0)
        .unwrap()
}

fn hide(mut builder: ScenarioBuilder, truth: &[(&str, f64)]) -> ScenarioBuilder {
    for (key, value) in truth {
        builder = builder.set(key, *value).unwrap();
    }
    builder
}

fn fit(keys: &[&str]) -> Vec<FitParameter> {
    keys.iter()
        .map(|key| FitParameter {
            key: key.to_string(),
            start: None,
            bounds: None,
            per_run: false,
        })
        .collect()
}

fn run_calibration(
    builder: &ScenarioBuilder,
    data: &[RunData],
    validate: &[RunData],
    options: &CalibrationOptions,
) -> Result<Calibration, CalibrationError> {
    calibrate(
        builder,
        &controllers::builtin(),
        data,
        validate,
        options,
        &mut |_| {},
    )
}

fn estimate(result: &Calibration, key: &str) -> f64 {
    result
        .estimates
        .iter()
        .find(|e| e.key == key)
        .unwrap()
        .estimate
}

#[test]
fn replaying_its_own_run_reproduces_it() {
    let dir = folder("replay");
    let data = record(whitworth(2.0), &dir.join("run.csv"));
    let comparison = compare(
        &whitworth(2.0),
        &controllers::builtin(),
        &data,
        &CalibrationOptions::default(),
    )
    .unwrap();
    assert!(!comparison.signals.is_empty());
    for fit in &comparison.signals {
        assert!(
            fit.fit_percent > 99.999,
            "{}: {}",
            fit.signal,
            fit.fit_percent
        );
    }
}

#[test]
fn noise_free_whitworth_data_return_the_hidden_values() {
    let dir = folder("whitworth-truth");
    let truth = [
        ("urdf.link.ram.mass", 6.2),
        ("urdf.joint.crank.damping", 0.08),
        ("urdf.link.slotted_link.izz", 0.21),
        ("sensors.\"crank.position\".bias", 2e-3),
    ];
    let data = record(hide(whitworth(3.0), &truth), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&truth.map(|(key, _)| key)),
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&whitworth(3.0), &[data], &[], &options).unwrap();
    for (key, value) in truth {
        let found = estimate(&result, key);
        assert!(
            ((found - value) / value).abs() <= 1e-6,
            "{key}: {found} for {value}"
        );
    }
    for fit in &result.runs[0].after {
        assert!(
            fit.fit_percent > 99.9999,
            "{}: {}",
            fit.signal,
            fit.fit_percent
        );
    }
}

/// Each machine's plant values, hidden in a noise-free run and fitted back from the nominal
/// scenario: (scenario, seconds, the truth, what else the scenario needs).
fn recovered(
    scenario: &str,
    seconds: f64,
    truth: &[(&str, f64)],
    setup: &[(&str, f64)],
    states: StartStates,
) -> Calibration {
    let dir = folder(scenario);
    let mut nominal = Scenario::builtin(scenario).unwrap().duration(seconds);
    for (key, value) in setup {
        nominal = nominal.set(key, *value).unwrap();
    }
    let data = record(hide(nominal.clone(), truth), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&truth.iter().map(|(key, _)| *key).collect::<Vec<_>>()),
        states,
        ..CalibrationOptions::default()
    };
    run_calibration(&nominal, &[data], &[], &options).unwrap()
}

fn assert_recovered(result: &Calibration, truth: &[(&str, f64)], tolerance: f64) {
    for (key, value) in truth {
        let found = estimate(result, key);
        assert!(
            ((found - value) / value).abs() <= tolerance,
            "{key}: {found} for {value} ({:?})",
            result.estimates
        );
    }
}

#[test]
fn noise_free_runs_of_every_machine_return_their_hidden_values() {
    let arm = [
        ("urdf.link.forearm.mass", 5.75),
        ("urdf.joint.elbow.damping", 0.45),
        // The centre of mass along the forearm, 0.16 m in the URDF: one number of the pair.
        ("urdf.link.forearm.com.0", 0.175),
    ];
    let dir = folder("arm-com");
    let nominal = Scenario::builtin("arm-milling").unwrap().duration(1.0);
    let hidden = (nominal.clone().set("urdf.link.forearm.com", [0.0, 0.0]))
        .map(|b| hide(b, &arm))
        .unwrap();
    let data = record(hidden, &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&arm.map(|(key, _)| key)),
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&nominal, &[data], &[], &options).unwrap();
    assert_recovered(&result, &arm, 1e-6);

    let feed = [
        ("urdf.link.table.mass", 11.5),
        ("urdf.joint.table.damping", 270.0),
    ];
    let ideal = [("sensors.\"table.position\".resolution", 0.0)];
    let result = recovered(
        "feed-axis-micromilling",
        0.5,
        &feed,
        &ideal,
        StartStates::Automatic,
    );
    assert_recovered(&result, &feed, 1e-6);

    // Before and into the first cut: once both tools cut, the tool's contact makes the cost
    // non-smooth and the solve stops in a kink short of the truth.
    let lathe = [
        ("urdf.link.slide_1.mass", 230.0),
        ("urdf.link.part.izz", 0.09),
    ];
    let result = recovered("lathe-turning", 0.5, &lathe, &[], StartStates::Automatic);
    assert_recovered(&result, &lathe, 1e-6);

    // The tyres' saturation slip and the chassis mass, from the wheel encoders and currents.
    let platform = [
        ("process.tyre.saturation_slip", 0.12),
        ("urdf.link.chassis.mass", 3.2),
    ];
    let ideal = [
        ("sensors.\"left_wheel.position\".resolution", 0.0),
        ("sensors.\"right_wheel.position\".resolution", 0.0),
    ];
    let result = recovered(
        "platform-path",
        3.0,
        &platform,
        &ideal,
        StartStates::Automatic,
    );
    assert_recovered(&result, &platform, 1e-6);
    assert_eq!(
        result.segments, 1,
        "the floor joints are not logged: whole runs"
    );

    // The teeth entering and leaving the cut make the milling cost non-smooth: the solve stops
    // in a kink near the truth (measured 1.6e-5 off on the stiffness, 2.0e-4 on the damping).
    let milling = [
        ("urdf.joint.tool_x.stiffness", 1.5e6),
        ("urdf.joint.tool_x.damping", 13.0),
    ];
    let result = recovered("milling-z04", 0.05, &milling, &[], StartStates::Fixed);
    assert_recovered(&result, &milling, 1e-3);
}

/// A noisy Whitworth run: every fitted signal's sensor with Gaussian noise of its σ.
fn noisy_whitworth(seconds: f64, seed: u64, truth: &[(&str, f64)]) -> ScenarioBuilder {
    let mut builder = hide(whitworth(seconds), truth).seed(seed);
    for (signal, sigma) in NOISE {
        builder = builder
            .set(&format!("sensors.\"{signal}\".noise"), sigma)
            .unwrap();
    }
    builder
}

const NOISE: [(&str, f64); 3] = [
    ("crank.position", 1e-3),
    ("crank.velocity", 5e-3),
    ("ram.position", 1e-4),
];

fn noisy_options(keys: &[&str]) -> CalibrationOptions {
    CalibrationOptions {
        parameters: fit(keys),
        signals: NOISE.map(|(signal, _)| signal.to_string()).to_vec(),
        ..CalibrationOptions::default()
    }
}

#[test]
fn intervals_cover_the_truth_in_at_least_90_percent_of_40_noisy_runs() {
    let dir = folder("coverage");
    let truth = [
        ("urdf.link.ram.mass", 5.9),
        ("urdf.joint.crank.damping", 0.06),
    ];
    let options = noisy_options(&truth.map(|(key, _)| key));
    let mut covered = [0; 2];
    for seed in 0..40 {
        let file = dir.join(format!("run-{seed}.csv"));
        let data = record(noisy_whitworth(3.0, seed, &truth), &file);
        let result = run_calibration(&whitworth(3.0), &[data], &[], &options).unwrap();
        assert_eq!(
            result.start_states, 6,
            "three 1 s segments, the crank's state in each"
        );
        for (count, (key, value)) in covered.iter_mut().zip(truth) {
            let e = result.estimates.iter().find(|e| e.key == key).unwrap();
            *count += usize::from(e.interval[0] <= value && value <= e.interval[1]);
        }
    }
    assert!(
        covered.iter().all(|&c| c >= 36),
        "covered of 40: {covered:?}"
    );
}

#[test]
fn a_run_with_another_excitation_is_predicted_after_the_fit() {
    let dir = folder("validation");
    let truth = [
        ("urdf.link.ram.mass", 5.9),
        ("urdf.joint.crank.damping", 0.06),
    ];
    let data = record(noisy_whitworth(3.0, 1, &truth), &dir.join("run.csv"));
    let other = noisy_whitworth(3.0, 2, &truth)
        .set("controller.params.crank_speed", -10.0)
        .unwrap();
    let validation = record(other, &dir.join("validation.csv"));
    let options = noisy_options(&truth.map(|(key, _)| key));
    let result = run_calibration(&whitworth(3.0), &[data], &[validation], &options).unwrap();
    let run = &result.validation[0];
    for (before, after) in run.before.iter().zip(&run.after) {
        assert!(
            after.fit_percent >= 99.0,
            "{}: {}",
            after.signal,
            after.fit_percent
        );
        assert!(after.fit_percent >= before.fit_percent, "{}", after.signal);
    }
}

#[test]
fn a_per_run_parameter_is_fitted_in_each_run_and_a_shared_one_once() {
    let dir = folder("per-run");
    let runs: Vec<RunData> = [5.4, 6.6]
        .iter()
        .enumerate()
        .map(|(k, mass)| {
            let truth = [
                ("urdf.link.ram.mass", *mass),
                ("urdf.joint.crank.damping", 0.06),
            ];
            record(
                hide(whitworth(2.0), &truth),
                &dir.join(format!("run-{k}.csv")),
            )
        })
        .collect();
    let mut parameters = fit(&["urdf.link.ram.mass", "urdf.joint.crank.damping"]);
    parameters[0].per_run = true;
    let options = CalibrationOptions {
        parameters,
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&whitworth(2.0), &runs, &[], &options).unwrap();
    let masses: Vec<f64> = (result.estimates.iter())
        .filter(|e| e.key == "urdf.link.ram.mass")
        .map(|e| e.estimate)
        .collect();
    assert_eq!(masses.len(), 2);
    assert!(
        (masses[0] / 5.4 - 1.0).abs() < 1e-6 && (masses[1] / 6.6 - 1.0).abs() < 1e-6,
        "{masses:?}"
    );
    assert!((estimate(&result, "urdf.joint.crank.damping") / 0.06 - 1.0).abs() < 1e-6);
}

#[test]
fn the_calibrated_scenario_runs_with_the_fitted_values() {
    let dir = folder("calibrated");
    let truth = [("urdf.link.ram.mass", 6.2)];
    let data = record(hide(whitworth(1.0), &truth), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&["urdf.link.ram.mass"]),
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&whitworth(1.0), &[data], &[], &options).unwrap();
    let text = &result.calibrated_toml;
    assert!(
        text.starts_with("# Calibrated by `twin calibrate`"),
        "{text}"
    );
    assert!(text.contains("sha256"), "{text}");
    let builder = Scenario::from_toml(text, "calibrated.toml", None).unwrap();
    assert_eq!(
        builder.number("urdf.link.ram.mass"),
        Some(estimate(&result, "urdf.link.ram.mass"))
    );
    let loaded = builder.build(&controllers::builtin()).unwrap();
    assert!(Twin::new(loaded)
        .unwrap()
        .run(None)
        .unwrap()
        .failure
        .is_none());
}

fn refusal(builder: &ScenarioBuilder, data: &RunData, options: &CalibrationOptions) -> String {
    let error = run_calibration(builder, std::slice::from_ref(data), &[], options).unwrap_err();
    let message = error.to_string();
    assert!(!message.contains('\n'), "one line: {message}");
    message
}

#[test]
fn the_check_refuses_what_the_data_cannot_determine() {
    let dir = folder("refusals");
    let data = record(whitworth(1.0), &dir.join("run.csv"));
    let options = |keys: &[&str]| CalibrationOptions {
        parameters: fit(keys),
        ..CalibrationOptions::default()
    };
    // Open loop, the controller's gains never act.
    let message = refusal(
        &whitworth(1.0),
        &data,
        &options(&["controller.params.natural_frequency"]),
    );
    assert!(
        message.contains("controller.params.natural_frequency has no effect"),
        "{message}"
    );

    let mut bounded = options(&["urdf.link.ram.mass"]);
    bounded.parameters[0].bounds = Some([6.0, 7.0]);
    let message = refusal(&whitworth(1.0), &data, &bounded);
    assert!(
        message.contains("the start 5 lies outside the bounds [6, 7]"),
        "{message}"
    );

    let mut twice = options(&["urdf.link.ram.mass", "urdf.link.ram.mass"]);
    twice.parameters[1].start = Some(5.5);
    let message = refusal(&whitworth(1.0), &data, &twice);
    assert!(message.contains("given twice"), "{message}");

    let message = refusal(
        &whitworth(1.0),
        &data,
        &options(&["urdf.link.no_such_link.mass"]),
    );
    assert!(message.contains("no_such_link"), "{message}");

    let short = record(whitworth(0.002), &dir.join("short.csv"));
    let message = refusal(
        &whitworth(0.002),
        &short,
        &options(&["urdf.link.ram.mass", "urdf.joint.crank.damping"]),
    );
    assert!(message.contains("samples"), "{message}");
    let eight = record(whitworth(0.007), &dir.join("eight.csv"));
    let message = refusal(&whitworth(0.007), &eight, &options(&["urdf.link.ram.mass"]));
    assert!(
        message.contains("8 samples at the control period 0.001 s; a fit needs at least 10"),
        "{message}"
    );

    let mut segments = options(&["urdf.link.ram.mass"]);
    segments.segment = Some(-1.0);
    let message = refusal(&whitworth(1.0), &data, &segments);
    assert!(message.contains("--segment -1"), "{message}");
}

#[test]
fn parameters_the_data_cannot_tell_apart_are_named() {
    // Without gravity the upper arm's mass m and inertia I act on the arm only through its
    // inertia about the shoulder, I + m·d²: the data determine that sum and nothing else.
    let dir = folder("confounded");
    let arm = Scenario::builtin("arm-milling")
        .unwrap()
        .duration(0.5)
        .set("gravity", [0.0, 0.0])
        .unwrap();
    let data = record(arm.clone(), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&["urdf.link.upper_arm.mass", "urdf.link.upper_arm.izz"]),
        ..CalibrationOptions::default()
    };
    let message = refusal(&arm, &data, &options);
    assert!(
        message
            .contains("urdf.link.upper_arm.mass and urdf.link.upper_arm.izz cannot be told apart")
            || message.contains(
                "urdf.link.upper_arm.izz and urdf.link.upper_arm.mass cannot be told apart"
            ),
        "{message}"
    );
    assert!(message.contains("is determined"), "{message}");
}

#[test]
fn an_open_loop_replay_needs_every_command_and_a_map_renames_a_log() {
    let dir = folder("commands");
    record(whitworth(0.5), &dir.join("run.csv"));
    let text = std::fs::read_to_string(dir.join("run.csv")).unwrap();
    // The machine's log: its own name for the motor torque; without it, no command at all.
    let renamed = dir.join("renamed.csv");
    std::fs::write(
        &renamed,
        text.replacen("effort.crank [N·m]", "motor [N·m]", 1),
    )
    .unwrap();
    let without: String = text
        .lines()
        .map(|line| {
            line.split(',')
                .enumerate()
                .filter(|(i, _)| *i != 1)
                .map(|(_, c)| c)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect::<Vec<_>>()
        .join("\n");
    let missing = dir.join("missing.csv");
    std::fs::write(&missing, without).unwrap();
    let registry = controllers::builtin();
    let data = RunData::read(&missing, &[]).unwrap();
    let message = compare(
        &whitworth(0.5),
        &registry,
        &data,
        &CalibrationOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        message.contains("no column effort.crank [N·m]"),
        "{message}"
    );
    let map = [("motor".to_string(), "effort.crank".to_string())];
    let data = RunData::read(&renamed, &map).unwrap();
    let comparison = compare(
        &whitworth(0.5),
        &registry,
        &data,
        &CalibrationOptions::default(),
    )
    .unwrap();
    assert!(comparison.signals.iter().all(|s| s.fit_percent > 99.999));
}

#[test]
fn several_starts_keep_the_best_and_say_which() {
    let dir = folder("starts");
    let truth = [("urdf.link.ram.mass", 6.2)];
    let data = record(hide(whitworth(1.0), &truth), &dir.join("run.csv"));
    let mut parameters = fit(&["urdf.link.ram.mass"]);
    parameters[0].bounds = Some([1.0, 20.0]);
    let options = CalibrationOptions {
        parameters,
        starts: 3,
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&whitworth(1.0), &[data], &[], &options).unwrap();
    let starts: std::collections::BTreeSet<usize> =
        result.iterations.iter().map(|i| i.start).collect();
    assert_eq!(starts.len(), 3, "every start solved");
    let best = |start: usize| {
        let costs = result
            .iterations
            .iter()
            .filter(|i| i.start == start)
            .map(|i| i.cost);
        costs.fold(f64::INFINITY, f64::min)
    };
    assert!((0..3).all(|s| best(result.best_start) <= best(s)));
    assert!((estimate(&result, "urdf.link.ram.mass") / 6.2 - 1.0).abs() < 1e-6);
}

#[test]
fn a_parameter_the_run_hardly_excites_is_warned_of() {
    // The sliding block's inertia (5e-4 kg·m² beside a 1.5 kg·m² crank side) in 30 ms from rest.
    let dir = folder("weak");
    let data = record(noisy_whitworth(0.03, 3, &[]), &dir.join("run.csv"));
    let options = noisy_options(&["urdf.link.block.izz"]);
    let result = run_calibration(&whitworth(0.03), &[data], &[], &options).unwrap();
    let warned = (result.warnings.iter())
        .any(|w| w.contains("urdf.link.block.izz is poorly determined: its 95 % interval"));
    assert!(warned, "{:?} {:?}", result.warnings, result.estimates);
}

/// A copy of the CSV `from` keeping `columns` (and `time`) and the rows `keep` says, each kept
/// column with seeded Gaussian noise of its σ in `noise` (none for the others).
fn logged(
    from: &Path,
    to: &Path,
    columns: &[&str],
    noise: &[(&str, f64)],
    keep: impl Fn(usize) -> bool,
) -> RunData {
    let mut state = 0x2545_F491_4F6C_DD1D_u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let text = twin_tests::logged_csv(from, columns, noise, &mut uniform, &|r, _, _| keep(r));
    std::fs::write(to, text).unwrap();
    RunData::read(to, &[]).unwrap()
}

/// The noise of the shaper's logged columns: σ 1e-4 rad, 1e-2 rad/s, 1e-5 m.
const LOGGED_NOISE: [(&str, f64); 3] = [
    ("crank.position", 1e-4),
    ("crank.velocity", 1e-2),
    ("ram.position", 1e-5),
];

fn logged_options(keys: &[&str]) -> CalibrationOptions {
    CalibrationOptions {
        parameters: fit(keys),
        noise: LOGGED_NOISE
            .map(|(s, sigma)| (s.to_string(), sigma))
            .to_vec(),
        ..CalibrationOptions::default()
    }
}

/// The twin's own shaper, its log cut to the columns a shaper logs (torque with the encoder and
/// tachometer, or with the encoder and the ram's scale, or with the ram's scale alone), noise
/// added on logging, with a tenth of its rows dropped, or logged every 10 ms: the hidden values
/// within 1e-3, intervals covering them, the verdict `fits`.
#[test]
fn the_twins_own_runs_cut_to_what_a_shaper_logs_return_the_truth() {
    let dir = folder("columns");
    let truth = [
        ("urdf.link.ram.mass", 6.0),
        ("urdf.joint.crank.damping", 0.3),
    ];
    let full = dir.join("full.csv");
    record(hide(whitworth(5.0), &truth), &full);
    let options = logged_options(&truth.map(|(key, _)| key));
    type Case<'a> = (&'a str, &'a [&'a str], Box<dyn Fn(usize) -> bool>);
    let cases: [Case; 5] = [
        (
            "tachometer",
            &["crank.position", "crank.velocity"],
            Box::new(|_| true),
        ),
        (
            "ram",
            &["crank.position", "ram.position"],
            Box::new(|_| true),
        ),
        ("ram alone", &["ram.position"], Box::new(|_| true)),
        (
            "rows dropped",
            &["crank.position", "ram.position"],
            Box::new(|r| r % 10 != 7),
        ),
        (
            "100 Hz",
            &["crank.position", "ram.position"],
            Box::new(|r| r % 10 == 0),
        ),
    ];
    for (case, columns, keep) in cases {
        let mut all = vec!["effort.crank"];
        all.extend(columns);
        let data = logged(
            &full,
            &dir.join(format!("{case}.csv")),
            &all,
            &LOGGED_NOISE,
            keep,
        );
        let result = run_calibration(&whitworth(5.0), &[data], &[], &options).unwrap();
        println!("{case}: {}", result.verdict.line());
        assert!(result.verdict.fits, "{case}: {:?}", result.verdict);
        assert!(result.segments > 1, "{case}: {} segments", result.segments);
        for (key, value) in truth {
            let e = result.estimates.iter().find(|e| e.key == key).unwrap();
            assert!(
                ((e.estimate - value) / value).abs() < 1e-3,
                "{case}: {key} = {}",
                e.estimate
            );
            assert!(
                e.interval[0] <= value && value <= e.interval[1],
                "{case}: {key} {:?} misses {value}",
                e.interval
            );
        }
    }
}

/// A controller that acts on noisy sensors commands noise too; where the logger drops rows,
/// those commands are lost, and the replay's input is not the machine's. The calibration does
/// not claim a fit it does not have: its verdict says `does not fit`, its intervals widened.
#[test]
fn lost_commands_of_a_noisy_controller_are_not_passed_off_as_a_fit() {
    let dir = folder("lost-commands");
    let truth = [
        ("urdf.link.ram.mass", 6.0),
        ("urdf.joint.crank.damping", 0.3),
    ];
    let mut builder = hide(whitworth(5.0), &truth).seed(11);
    for (signal, sigma) in LOGGED_NOISE {
        builder = builder
            .set(&format!("sensors.\"{signal}\".noise"), sigma)
            .unwrap();
    }
    let full = dir.join("full.csv");
    record(builder, &full);
    let columns = ["effort.crank", "crank.position", "ram.position"];
    let data = logged(&full, &dir.join("dropped.csv"), &columns, &[], |r| {
        r % 10 != 7
    });
    let options = logged_options(&truth.map(|(key, _)| key));
    let result = run_calibration(&whitworth(5.0), &[data], &[], &options).unwrap();
    println!("{}", result.verdict.line());
    assert!(!result.verdict.fits, "{:?}", result.verdict);
    assert!(result.estimates.iter().all(|e| e.widened));
}

/// The twin's own unmodified run, compared by default (1 s replays from start states the data
/// give): at least 99 % on every signal; the whole run replayed once (`segment` 0) from the same
/// start is said to be so.
#[test]
fn compare_of_the_twins_own_run_is_at_least_99_percent_on_every_signal() {
    let dir = folder("own-compare");
    let builder = Scenario::builtin("whitworth-crank-pi").unwrap();
    let data = record(builder.clone(), &dir.join("run.csv"));
    let registry = controllers::builtin();
    let comparison = compare(&builder, &registry, &data, &CalibrationOptions::default()).unwrap();
    assert_eq!(comparison.segment, 1.0);
    assert!(comparison
        .replays()
        .starts_with("1 s replays (10 segments)"));
    for fit in &comparison.signals {
        assert!(
            fit.fit_percent >= 99.0,
            "{}: {}",
            fit.signal,
            fit.fit_percent
        );
    }
    assert_eq!(comparison.segments.len(), 10);
    let whole = CalibrationOptions {
        segment: Some(0.0),
        ..CalibrationOptions::default()
    };
    let comparison = compare(&builder, &registry, &data, &whole).unwrap();
    assert!(comparison
        .replays()
        .starts_with("one replay of the whole run"));
}

/// `compare` of the calibrated values gives the fit % a calibration reports after its fit, and
/// of the start values, the one it reports before.
#[test]
fn compare_and_calibrate_report_the_same_fit_for_the_same_values() {
    let dir = folder("same-fit");
    let truth = [
        ("urdf.link.ram.mass", 6.0),
        ("urdf.joint.crank.damping", 0.3),
    ];
    let data = record(noisy_whitworth(3.0, 5, &truth), &dir.join("run.csv"));
    let options = noisy_options(&truth.map(|(key, _)| key));
    let result =
        run_calibration(&whitworth(3.0), std::slice::from_ref(&data), &[], &options).unwrap();
    let registry = controllers::builtin();
    let compared = |builder: &ScenarioBuilder| {
        let options = CalibrationOptions {
            signals: options.signals.clone(),
            ..CalibrationOptions::default()
        };
        compare(builder, &registry, &data, &options)
            .unwrap()
            .signals
    };
    let mut calibrated = whitworth(3.0);
    for e in &result.estimates {
        calibrated = calibrated.set(&e.key, e.estimate).unwrap();
    }
    for (fits, report) in [
        (compared(&calibrated), &result.runs[0].after),
        (compared(&whitworth(3.0)), &result.runs[0].before),
    ] {
        for (compare, calibrate) in fits.iter().zip(report) {
            assert_eq!(compare.signal, calibrate.signal);
            assert!(
                (compare.fit_percent - calibrate.fit_percent).abs() < 0.01,
                "{}: compare {} calibrate {}",
                compare.signal,
                compare.fit_percent,
                calibrate.fit_percent
            );
        }
    }
}

/// Where the logged positions cannot place the mechanism, the runs are replayed whole and a
/// note says why; an asked segment length is refused, naming what to log.
#[test]
fn no_segments_without_the_positions_that_place_the_mechanism_and_a_note_says_so() {
    let dir = folder("no-segments");
    let builder = Scenario::builtin("platform-path").unwrap().duration(2.0);
    let data = record(builder.clone(), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&["urdf.link.chassis.mass"]),
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&builder, std::slice::from_ref(&data), &[], &options).unwrap();
    assert_eq!(result.segments, 1);
    assert!(
        result
            .notes
            .iter()
            .any(|n| n.contains("replayed whole") && n.contains("log them")),
        "{:?}",
        result.notes
    );
    let forced = CalibrationOptions {
        segment: Some(0.5),
        ..options
    };
    let message = run_calibration(&builder, &[data], &[], &forced)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        message.contains("--segment 0.5") && message.contains("--segment 0"),
        "{message}"
    );
}

/// An estimate that ends at its bound is said to sit there, not to be wanted beyond it.
#[test]
fn a_parameter_at_its_bound_is_not_said_to_be_wanted_beyond_it() {
    let dir = folder("bound");
    let data = record(whitworth(1.0), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: vec![FitParameter {
            key: "urdf.joint.crank.damping".into(),
            start: Some(0.1),
            bounds: Some([0.0, 10.0]),
            per_run: false,
        }],
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&whitworth(1.0), &[data], &[], &options).unwrap();
    let warning = (result.warnings.iter())
        .find(|w| w.contains("bound"))
        .cloned()
        .unwrap_or_default();
    assert!(result.estimates[0].at_bound, "{:?}", result.estimates);
    assert!(!warning.contains("want it beyond"), "{warning}");
    assert!(warning.contains("cannot tell"), "{warning}");
}

/// An arm falling from upright with its drives off drifts from a start moved by a step a hundred
/// times as far within a second: the default segment is shorter (0.5 s, measured horizon 0.63 s),
/// a note says why, and the forearm's mass still comes back.
#[test]
fn a_model_that_drifts_fast_gets_shorter_segments_and_a_note() {
    let dir = folder("drift");
    let falling = |mass: f64| {
        (Scenario::builtin("arm-milling").unwrap().duration(2.0))
            .set("process.drive_power", "off")
            .and_then(|b| b.set("initial.shoulder.position", 1.5))
            .and_then(|b| b.set("urdf.link.forearm.mass", mass))
            .unwrap()
    };
    let data = record(falling(5.6), &dir.join("run.csv"));
    let options = CalibrationOptions {
        parameters: fit(&["urdf.link.forearm.mass"]),
        signals: ["shoulder", "elbow", "wrist"]
            .map(|j| format!("{j}.position"))
            .to_vec(),
        ..CalibrationOptions::default()
    };
    let result = run_calibration(&falling(5.0), &[data], &[], &options).unwrap();
    assert!(
        result.segment > 0.0 && result.segment < 1.0,
        "{} s",
        result.segment
    );
    assert!(
        result
            .notes
            .iter()
            .any(|n| n.starts_with("segments of") && n.contains("drift")
                || n.contains("part from a start")),
        "{:?}",
        result.notes
    );
    assert!((estimate(&result, "urdf.link.forearm.mass") / 5.6 - 1.0).abs() < 1e-6);
}
