//! MuJoCo, an engine the twin did not write, plays each machine as a real machine runs
//! (scripts/mujoco_machine.py, tests/mujoco/README.md): the URDF rebuilt with hidden values,
//! stiff loop closures, RK4 at 0.1 ms, its own controller with an excitation in its reference,
//! and a logger that writes only what a real machine logs. `twin::calibration::calibrate` fits
//! the twin's built-in scenario to those columns from the URDF's nominal values, and must return
//! what MuJoCo was given, with intervals that cover it, and say the model fits; a model with a
//! parameter left wrong must say it does not.
//!
//! Each machine is played once without noise; the noisy runs add seeded Gaussian noise to the
//! logged positions (σ as scripts/bench-calibration: 1e-4 rad on angles, 1e-5 m on the ram,
//! 1e-6 m on the feed table, 1e-2 rad/s on the tachometer) and, where said, drop rows at
//! random. Needs MuJoCo: `eval "$(scripts/test-tools)"` (scripts/test does), else the test fails
//! saying so.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use twin::calibration::{calibrate, Calibration, CalibrationOptions, FitParameter};
use twin::data::RunData;
use twin::{Scenario, ScenarioBuilder};

/// Seconds of data per machine.
const DURATION: f64 = 5.0;
/// Noise seeds the coverage tests draw.
const SEEDS: u64 = 30;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn tools_python() -> PathBuf {
    match std::env::var_os("TWIN_TOOLS_PYTHON") {
        Some(path) if !path.is_empty() => PathBuf::from(path),
        _ => panic!(
            "TWIN_TOOLS_PYTHON is not set: MuJoCo plays the machine in this test; run \
             `eval \"$(scripts/test-tools)\"` first (scripts/test does), then cargo test"
        ),
    }
}

/// A machine as MuJoCo plays it and the twin is set up for it.
struct Machine {
    name: &'static str,
    urdf: &'static str,
    /// The hidden values: key, truth (the URDF's value is the fit's start).
    hidden: &'static [(&'static str, f64)],
    /// The machine's own controller and its excitation (scripts/mujoco_machine.py's options).
    controller: &'static [&'static str],
    /// Every column the logger can write; a case logs some of them.
    columns: &'static [&'static str],
    /// Per logged signal, its noise σ.
    noise: &'static [(&'static str, f64)],
    scenario: fn() -> ScenarioBuilder,
}

const WHITWORTH: Machine = Machine {
    name: "whitworth",
    urdf: "urdf/whitworth.urdf",
    hidden: &[
        ("urdf.link.ram.mass", 6.0),
        ("urdf.joint.crank.damping", 0.3),
    ],
    // A crank-speed PI (the twin's crank-pi gains) to −2π rad/s with ±2 rad/s of multisine.
    controller: &[
        "--controller",
        "speed-pi",
        "--gain",
        "inertia=1.5",
        "--gain",
        "natural_frequency=30",
        "--reference",
        "crank=multisine:amp=2,fmin=0.2,fmax=3,tones=8,seed=2,offset=-2*pi",
    ],
    columns: &[
        "effort.crank",
        "crank.position",
        "crank.velocity",
        "ram.position",
    ],
    noise: &[
        ("crank.position", 1e-4),
        ("crank.velocity", 1e-2),
        ("ram.position", 1e-5),
    ],
    scenario: || Scenario::builtin("whitworth-crank-pi").unwrap(),
};

const ARM: Machine = Machine {
    name: "arm",
    urdf: "urdf/arm.urdf",
    hidden: &[
        ("urdf.link.forearm.mass", 5.6),
        ("urdf.link.hand.mass", 3.2),
        ("urdf.joint.elbow.damping", 0.45),
    ],
    // Joint PIDs with the nominal gravity compensation, multisine references.
    controller: &[
        "--controller",
        "pid",
        "--reference",
        "shoulder=multisine:amp=0.2,fmin=0.2,fmax=1.5,tones=6,seed=1,offset=-1.4",
        "--reference",
        "elbow=multisine:amp=0.35,fmin=0.2,fmax=1.5,tones=6,seed=2,offset=0.6",
        "--reference",
        "wrist=multisine:amp=0.5,fmin=0.2,fmax=1.5,tones=6,seed=3,offset=0.3",
    ],
    columns: &[
        "effort.shoulder",
        "effort.elbow",
        "effort.wrist",
        "shoulder.position",
        "elbow.position",
        "wrist.position",
    ],
    noise: &[
        ("shoulder.position", 1e-4),
        ("elbow.position", 1e-4),
        ("wrist.position", 1e-4),
    ],
    scenario: arm_scenario,
};

const FEED_AXIS: Machine = Machine {
    name: "feed-axis",
    urdf: "urdf/feed_axis.urdf",
    hidden: &[
        ("urdf.link.table.mass", 11.5),
        ("urdf.joint.table.damping", 270.0),
    ],
    // A table position PID, a ±5 mm multisine reference.
    controller: &[
        "--controller",
        "pid",
        "--gain",
        "bandwidth=50",
        "--reference",
        "table=multisine:amp=0.005,fmin=0.5,fmax=10,tones=8,seed=4",
    ],
    columns: &["effort.table", "table.position"],
    noise: &[("table.position", 1e-6)],
    scenario: feed_axis_scenario,
};

/// The arm with ideal drives (its actuators take the logged torques) and its spindle's power
/// off (MuJoCo drives no spindle: it turns free).
fn arm_scenario() -> ScenarioBuilder {
    (Scenario::builtin("arm-milling").unwrap())
        .set("actuators.\"*\".kind", "effort")
        .and_then(|b| b.set("process.spindle_power", "off"))
        .unwrap()
}

/// The feed axis in the air (MuJoCo cuts nothing), at MuJoCo's control period.
fn feed_axis_scenario() -> ScenarioBuilder {
    let mut builder = Scenario::builtin("feed-axis-micromilling").unwrap();
    for (key, value) in [("dt", 1e-3), ("control_period", 1e-3)] {
        builder = builder.set(key, value).unwrap();
    }
    builder.set("process.cutting", false).unwrap()
}

impl Machine {
    /// MuJoCo's run, noise-free, every column the logger can write, in a folder of its own;
    /// `extra` are more of the logger's options (a slower logger).
    fn play(&self, label: &str, extra: &[&str]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "twin-mujoco-{}-{label}-{}",
            self.name,
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let run = dir.join("run.csv");
        let script = repo().join("scripts/mujoco_machine.py");
        let mut args: Vec<String> = vec![
            script.display().to_string(),
            "--urdf".into(),
            repo().join(self.urdf).display().to_string(),
        ];
        for (key, value) in self.hidden {
            args.extend(["--set".into(), format!("{}={value}", &key[5..])]);
        }
        args.extend(self.controller.iter().map(|a| a.to_string()));
        args.extend(
            [
                "--duration",
                &DURATION.to_string(),
                "--dt",
                "0.0001",
                "--control-period",
                "0.001",
                "--log",
                &self.columns.join(","),
                "--out",
                &run.display().to_string(),
            ]
            .map(String::from),
        );
        args.extend(extra.iter().map(|a| a.to_string()));
        let python = tools_python();
        // In the run's folder: MuJoCo logs its warnings to MUJOCO_LOG.TXT in the working folder.
        let out = (Command::new(&python).args(&args).current_dir(&dir).output())
            .unwrap_or_else(|e| panic!("{}: {e}", python.display()));
        assert!(
            out.status.success(),
            "{} {}: {}\n{}",
            python.display(),
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        run
    }

    /// The twin fitted to `data` from the URDF's values, every hidden value at once (or those
    /// of `keys`), each logged signal weighted by its noise σ.
    fn calibrate(&self, data: &Path, keys: &[&str]) -> Calibration {
        let options = CalibrationOptions {
            parameters: (self.hidden.iter())
                .filter(|(key, _)| keys.is_empty() || keys.contains(key))
                .map(|(key, _)| FitParameter {
                    key: key.to_string(),
                    start: None,
                    bounds: None,
                    per_run: false,
                })
                .collect(),
            noise: (self.noise.iter())
                .map(|(s, sigma)| (s.to_string(), *sigma))
                .collect(),
            ..CalibrationOptions::default()
        };
        let run = RunData::read(data, &[]).unwrap_or_else(|e| panic!("{e}"));
        let builder = (self.scenario)().duration(DURATION);
        calibrate(
            &builder,
            &controllers::builtin(),
            &[run],
            &[],
            &options,
            &mut |_| {},
        )
        .unwrap_or_else(|e| panic!("{}: {e}", self.name))
    }

    /// Per hidden value: its error relative to the truth, in standard errors too, and whether
    /// the 95 % interval covers it.
    fn errors(&self, result: &Calibration) -> Vec<(&'static str, f64, f64, bool)> {
        (result.estimates.iter())
            .map(|e| {
                let (key, truth) = *self.hidden.iter().find(|(k, _)| *k == e.key).unwrap();
                let covered = e.interval[0] <= truth && truth <= e.interval[1];
                let error = (e.estimate - truth) / truth;
                let z = (e.estimate - truth) / e.standard_error;
                (key, error, z, covered)
            })
            .collect()
    }

    /// The fit explains the data, and every value is within `tolerance` of its truth with an
    /// interval that covers it.
    fn assert_recovered(&self, case: &str, result: &Calibration, tolerance: f64) {
        println!(
            "{} {case}: {}; {} segments, σ̂² {:.4}",
            self.name,
            result.verdict.line(),
            result.segments,
            result.residual_variance
        );
        for (key, error, z, covered) in self.errors(result) {
            println!("  {key}: {error:+.2e} relative, {z:+.2} standard errors");
            assert!(
                error.abs() <= tolerance,
                "{} {case}: {key} {error:+.2e} from the truth, beyond {tolerance:.0e}",
                self.name
            );
            assert!(
                covered,
                "{} {case}: {key}'s 95 % interval misses the truth ({z:+.2} standard errors)",
                self.name
            );
        }
        assert!(
            result.verdict.fits,
            "{} {case}: {:?}",
            self.name, result.verdict
        );
        assert!(
            result.converged,
            "{} {case}: the solve did not converge",
            self.name
        );
    }
}

/// A copy of the logged run `clean` keeping `columns`, with seeded Gaussian noise of each
/// column's σ and a share `drop` of its rows (never the first or last) left out.
fn logged(machine: &Machine, clean: &Path, columns: &[&str], drop: f64, seed: u64) -> PathBuf {
    let mut random = Draws::new(seed);
    let keep = |r: usize, rows: usize, uniform: &mut twin_tests::Uniform| {
        let dropped = uniform() < drop;
        !(dropped && r > 0 && r + 1 < rows)
    };
    let text = twin_tests::logged_csv(
        clean,
        columns,
        machine.noise,
        &mut || random.uniform(),
        &keep,
    );
    let file = clean.with_file_name(format!(
        "logged-{}-{seed}-{}.csv",
        columns.len(),
        (drop * 100.0) as u32
    ));
    std::fs::write(&file, text).unwrap();
    file
}

/// Seeded uniform draws in [0, 1) (splitmix64).
struct Draws(u64);

impl Draws {
    fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }

    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn whitworth() -> &'static Path {
    static PLAYED: OnceLock<PathBuf> = OnceLock::new();
    PLAYED.get_or_init(|| WHITWORTH.play("1ms", &[]))
}

fn arm() -> &'static Path {
    static PLAYED: OnceLock<PathBuf> = OnceLock::new();
    PLAYED.get_or_init(|| ARM.play("1ms", &[]))
}

fn feed_axis() -> &'static Path {
    static PLAYED: OnceLock<PathBuf> = OnceLock::new();
    PLAYED.get_or_init(|| FEED_AXIS.play("1ms", &[]))
}

/// The shaper's three realistic column sets, each with its commanded torque: the crank encoder
/// and tachometer; the crank encoder and the ram's position; the ram's position alone. The
/// truth within 1e-3 (the bar; measured ~1e-5), every interval covering it.
#[test]
fn whitworth_from_the_columns_a_shaper_logs() {
    let sets: [&[&str]; 3] = [
        &["effort.crank", "crank.position", "crank.velocity"],
        &["effort.crank", "crank.position", "ram.position"],
        &["effort.crank", "ram.position"],
    ];
    for columns in sets {
        let data = logged(&WHITWORTH, whitworth(), columns, 0.0, 1);
        let result = WHITWORTH.calibrate(&data, &[]);
        WHITWORTH.assert_recovered(&columns[1..].join("+"), &result, 1e-3);
    }
}

/// A logger that loses a tenth of its rows, and one that writes every 10 ms while the control
/// runs at 1 ms: the commands between the rows are bridged, the twin compared at the rows.
#[test]
fn whitworth_with_rows_dropped_and_a_slow_logger() {
    let columns = ["effort.crank", "crank.position", "ram.position"];
    let dropped = logged(&WHITWORTH, whitworth(), &columns, 0.1, 2);
    let result = WHITWORTH.calibrate(&dropped, &[]);
    WHITWORTH.assert_recovered("10 % of rows dropped", &result, 1e-3);
    let slow = WHITWORTH.play("10ms", &["--log-period", "0.01"]);
    let data = logged(&WHITWORTH, &slow, &columns, 0.0, 3);
    let result = WHITWORTH.calibrate(&data, &[]);
    WHITWORTH.assert_recovered("a 100 Hz logger", &result, 1e-3);
}

/// The ram's mass fitted alone while the crank's damping is left at the URDF's 0 (the truth
/// 0.3 N·m·s/rad): the residuals are not the noise, and the calibration says so, with its
/// interval marked as widened.
#[test]
fn a_model_with_a_parameter_left_wrong_does_not_fit() {
    let columns = ["effort.crank", "crank.position", "ram.position"];
    let data = logged(&WHITWORTH, whitworth(), &columns, 0.0, 4);
    let result = WHITWORTH.calibrate(&data, &["urdf.link.ram.mass"]);
    println!("{}\n{:?}", result.verdict.line(), result.verdict.reasons);
    assert!(!result.verdict.fits, "{:?}", result.verdict);
    assert!(
        result.residual_variance > 10.0,
        "σ̂² = {}",
        result.residual_variance
    );
    assert!(result.estimates.iter().all(|e| e.widened));
    assert!(!result.verdict.advice.is_empty());
    let json = result.to_json();
    assert_eq!(json["verdict"], "does not fit");
    assert_eq!(json["parameters"][0]["widened"], true);
}

/// The arm's joint encoders and its drives' commanded torques.
#[test]
fn arm_from_its_encoders_and_commands() {
    let data = logged(&ARM, arm(), ARM.columns, 0.0, 5);
    let result = ARM.calibrate(&data, &[]);
    ARM.assert_recovered("encoders", &result, 1e-3);
}

/// The feed axis's linear encoder and its force command.
#[test]
fn feed_axis_from_its_encoder_and_force() {
    let data = logged(&FEED_AXIS, feed_axis(), FEED_AXIS.columns, 0.0, 6);
    let result = FEED_AXIS.calibrate(&data, &[]);
    FEED_AXIS.assert_recovered("encoder", &result, 1e-3);
}

/// Over [`SEEDS`] noise draws each 95 % interval covers the truth at least 90 % of the time,
/// and the estimates scatter as their standard errors say (the z-scores' RMS within 0.6–1.5).
fn coverage(machine: &Machine, clean: &Path, columns: &[&str]) {
    let mut covered = vec![0usize; machine.hidden.len()];
    let mut z_squares = vec![0.0; machine.hidden.len()];
    for seed in 0..SEEDS {
        let data = logged(machine, clean, columns, 0.0, 100 + seed);
        let result = machine.calibrate(&data, &[]);
        assert!(
            result.verdict.fits,
            "{} seed {seed}: {}",
            machine.name,
            result.verdict.line()
        );
        for (k, (_, _, z, hit)) in machine.errors(&result).into_iter().enumerate() {
            covered[k] += hit as usize;
            z_squares[k] += z * z;
        }
        let _ = std::fs::remove_file(&data);
    }
    for (k, (key, _)) in machine.hidden.iter().enumerate() {
        let rms = (z_squares[k] / SEEDS as f64).sqrt();
        println!(
            "{} {key}: covered {}/{SEEDS}, z RMS {rms:.2}",
            machine.name, covered[k]
        );
        assert!(
            covered[k] as f64 >= 0.9 * SEEDS as f64,
            "{} {key}: the 95 % interval covered the truth {} times in {SEEDS}",
            machine.name,
            covered[k]
        );
        assert!(
            (0.6..=1.5).contains(&rms),
            "{} {key}: z RMS {rms:.2}",
            machine.name
        );
    }
}

#[test]
fn whitworth_intervals_cover_the_truth_in_90_percent_of_30_seeds() {
    coverage(
        &WHITWORTH,
        whitworth(),
        &["effort.crank", "crank.position", "ram.position"],
    );
}

#[test]
fn arm_intervals_cover_the_truth_in_90_percent_of_30_seeds() {
    coverage(&ARM, arm(), ARM.columns);
}

#[test]
fn feed_axis_intervals_cover_the_truth_in_90_percent_of_30_seeds() {
    coverage(&FEED_AXIS, feed_axis(), FEED_AXIS.columns);
}
