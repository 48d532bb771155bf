//! Virtual commissioning with `twin serve`: a PLC written in Python (asyncua, from
//! `scripts/test-tools`) closes a PD loop on the Whitworth crank around `twin serve --lockstep`,
//! and its tracking is checked against the same law run inside the twin as a [`Controller`].
//!
//! The law: u = KP·(r − x) + KD·(ṙ − v) on the crank's measured angle x and rate v, following
//! the ramp r = RATE·t (one turn per second, clockwise), gravity off, so that a PD needs no
//! feedforward: J ≈ 1.5 kg·m² crank-side, KP = J·ω² and KD = 2·J·ω for ω = 30 rad/s, critically
//! damped (the scenario's own crank-pi design); the start saturates the 300 N·m drive for 20 ms.
//!
//! The bound. In lockstep the network adds exactly one control period T of delay: the command
//! the PLC writes at update k (from the measurement at k) acts from update k + 1. So:
//! - the law run inside the twin with its command held back one period must give the PLC's
//!   tracking-error history to the bit (≤ 1e-9 rad: the same arithmetic on the same samples);
//! - the undelayed law inside the twin (the law the PLC is meant to run) differs by the delay
//!   only. The delayed loop does what the undelayed one did a period earlier (exactly so while
//!   the start saturates the drive: it starts one period late), while the reference has moved
//!   on by |RATE|·T: its error is the undelayed error shifted by a period plus at most
//!   |RATE|·T, until the feedback draws both to the same steady error. So the two RMS tracking
//!   errors may differ by at most |RATE|·T = 6.3 mrad.
//!
//! Measured: the PLC and the delayed law bit-identical (0 rad apart); RMS tracking error 17.05
//! mrad (PLC) vs 16.42 mrad (undelayed, in the twin), 0.63 mrad apart, nearly all of it from the
//! start (peaks 94.9 vs 89.8 mrad, 5.1 mrad apart); after 0.5 s, 8.42 vs 8.40 mrad.

mod common;

use common::{finished, free_port, scratch, tools_python};
use framework::{Controller, ControllerError, Measurement, PlantInterface};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};
use twin::{LoadedScenario, Scenario, Twin};

const SCENARIO: &str = "whitworth-crank-pi";
const GRAVITY_OFF: &str = "gravity=[0.0, 0.0]";
const JOINT: &str = "crank";
/// The reference's rate, rad/s: one turn per second, clockwise.
const RATE: f64 = -std::f64::consts::TAU;
/// N·m/rad: J·ω² with J = 1.5 kg·m², ω = 30 rad/s.
const KP: f64 = 1350.0;
/// N·m·s/rad: 2·J·ω.
const KD: f64 = 90.0;
/// Simulated time, s: two turns, 2000 control periods of T = 1 ms.
const DURATION: f64 = 2.0;
const PERIOD: f64 = 0.001;
const PERIODS: usize = 2000;

/// A `twin serve` run, killed if the test fails before it ends (a lockstep server without its
/// client would wait for ever).
struct Served(Option<Child>);

impl Served {
    /// The server's output once it has ended; killed (and the test failed by its output) if it
    /// outlives the client by more than a few seconds.
    fn ended(mut self) -> std::process::Output {
        let mut server = self.0.take().expect("a server");
        let start = Instant::now();
        while server.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(10));
        }
        server.kill().ok();
        server.wait_with_output().unwrap()
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        if let Some(server) = self.0.as_mut() {
            server.kill().ok();
            server.wait().ok();
        }
    }
}

/// The PLC's law as a controller of the twin, its command held back one period or not; the
/// tracking error r − x of each control update goes to `errors`.
struct PdLaw {
    delayed: bool,
    /// The command computed at the last update (what a delayed law applies now).
    held: f64,
    position: usize,
    velocity: usize,
    actuator: usize,
    errors: Arc<Mutex<Vec<f64>>>,
}

impl Controller for PdLaw {
    fn name(&self) -> &str {
        "plc-pd"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.position = plant.signal(&format!("{JOINT}.position"))?;
        self.velocity = plant.signal(&format!("{JOINT}.velocity"))?;
        self.actuator = plant.actuator(JOINT)?;
        self.held = 0.0;
        Ok(())
    }

    /// As plc.py computes it, operation for operation.
    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        let error = RATE * measurement.time - measurement.get(self.position);
        let effort = KP * error + KD * (RATE - measurement.get(self.velocity));
        let mut errors = self.errors.lock().unwrap_or_else(PoisonError::into_inner);
        errors.push(error);
        efforts[self.actuator] = if self.delayed {
            std::mem::replace(&mut self.held, effort)
        } else {
            effort
        };
    }
}

/// The served scenario: the crank without gravity, DURATION long.
fn loaded() -> LoadedScenario {
    Scenario::builtin(SCENARIO)
        .unwrap()
        .duration(DURATION)
        .assign(GRAVITY_OFF)
        .unwrap()
        .build(&controllers::builtin())
        .unwrap()
}

/// The tracking errors of the law run inside the twin, at each control update.
fn in_twin(delayed: bool) -> Vec<f64> {
    let errors = Arc::new(Mutex::new(Vec::new()));
    let law = PdLaw {
        delayed,
        held: 0.0,
        position: 0,
        velocity: 0,
        actuator: 0,
        errors: errors.clone(),
    };
    let summary = Twin::with_controller(loaded(), Box::new(law))
        .unwrap()
        .run(None)
        .unwrap();
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let errors = errors.lock().unwrap_or_else(PoisonError::into_inner);
    errors.clone()
}

/// One field of plc.py's history, as numbers.
fn series(history: &serde_json::Value, key: &str) -> Vec<f64> {
    let values = history[key].as_array().unwrap();
    values.iter().map(|v| v.as_f64().unwrap()).collect()
}

/// The PLC's tracking errors: `twin serve --lockstep` with plc.py closing the loop.
fn python_loop(dir: &Path) -> Vec<f64> {
    let python = tools_python();
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let duration = DURATION.to_string();
    let server = Command::new(env!("CARGO_BIN_EXE_twin"))
        .args(["serve", SCENARIO, "--lockstep", "--opcua", &url])
        .args([
            "--duration",
            &duration,
            "--set",
            GRAVITY_OFF,
            "--out",
            "run.rrd",
        ])
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("twin serve starts");
    let server = Served(Some(server));
    let law = [KP, KD, RATE].map(|v| v.to_string());
    let plc = finished(
        Command::new(python)
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/serve/plc.py"))
            .args([&url, "whitworth", JOINT])
            .args(&law)
            .arg(PERIODS.to_string())
            .arg(dir.join("plc.json")),
    );
    let served = server.ended();
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert!(
        plc.status.success(),
        "plc.py: {}\nserver: {stderr}",
        String::from_utf8_lossy(&plc.stderr)
    );
    assert!(served.status.success(), "server: {stderr}");
    let history: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("plc.json")).unwrap()).unwrap();
    let times = series(&history, "time");
    assert_eq!(times.len(), PERIODS);
    for (k, time) in times.iter().enumerate() {
        assert!(
            (time - k as f64 * PERIOD).abs() < 1e-12,
            "update {k} at {time} s"
        );
    }
    series(&history, "error")
}

fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

#[test]
fn a_python_plc_tracks_as_the_law_inside_the_twin_one_period_later() {
    let dir = scratch("serve-plc", "pd");
    let plc = python_loop(&dir);
    let delayed = in_twin(true);
    let undelayed = in_twin(false);
    // The in-twin run has one more update, at its end, that the PLC does not advance past.
    assert_eq!(delayed.len(), PERIODS + 1);
    let worst = (plc.iter().zip(&delayed))
        .map(|(p, d)| (p - d).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-9,
        "PLC vs in-twin law one period late: {worst} rad apart"
    );
    let (rms_plc, rms_twin) = (rms(&plc), rms(&undelayed[..PERIODS]));
    let bound = RATE.abs() * PERIOD;
    println!("RMS tracking error, rad: PLC {rms_plc:.6}, in the twin {rms_twin:.6}");
    assert!(
        (rms_plc - rms_twin).abs() <= bound,
        "PLC {rms_plc} rad, in the twin {rms_twin} rad: more than |RATE|·T = {bound} rad apart"
    );
    // A sensible loop: once started it follows the two turns within 20 mrad (32 encoder counts).
    let settled = rms(&plc[PERIODS / 4..]);
    assert!(settled < 0.02, "RMS error after 0.5 s: {settled} rad");
    common::verify(&dir.join("run.rrd"));
}
