//! The milling machine (Kaliński & Galewski 2013 §3): the tool's free vibration against its modal
//! values, chatter at 15,000 rpm and its reduction by Z04, the lobes against the twin's own runs,
//! and bad input stopped before the run.

use std::f64::consts::TAU;
use twin::{Findings, Observer, ObserverError, SignalLayout, StepView, Twin};
use twin_cli::analysis::milling::{analyze, LobeRequest};
use twin_tests::{builtin, run, Configure};

const SCENARIO: &str = "milling-constant-15000";
/// The URDF's tool mode normal to the feed: modal mass (kg), stiffness (N/m), damping (N·s/m).
const MASS: f64 = 0.05598;
const STIFFNESS: f64 = 1.3669e6;
const DAMPING: f64 = 11.064;

/// Records one true signal every step.
struct Trace {
    name: &'static str,
    index: usize,
    samples: Vec<(f64, f64)>,
}

impl Observer for Trace {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.index = layout.signal(self.name).ok_or("no such signal")?;
        Ok(())
    }
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        self.samples.push((view.time, view.signals[self.index]));
        Ok(())
    }
    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings::default())
    }
}

#[test]
fn the_tool_rings_at_its_natural_frequency_and_decays_at_its_damping_ratio() {
    // Out of the cut, the tip let go 10 µm off centre at the scenario's step (10 µs, one RK4
    // step): numerical damping would hide or fake chatter.
    let loaded = builtin(SCENARIO)
        .with("process.cutting", false)
        .with("initial.tool_y.position", 1e-5)
        .duration(0.06)
        .loaded();
    let mut trace = Trace {
        name: "tool_y.position",
        index: 0,
        samples: Vec::new(),
    };
    Twin::new(loaded)
        .and_then(|t| t.run_with(None, &mut [&mut trace]))
        .unwrap_or_else(|e| panic!("{e}"));
    let s = &trace.samples;
    // Upward zero crossings (linear between steps) give the damped period; the peaks between
    // them the logarithmic decrement.
    let crossings: Vec<f64> = s
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .collect();
    let peaks: Vec<f64> = s
        .windows(3)
        .filter(|w| w[1].1 > w[0].1 && w[1].1 >= w[2].1 && w[1].1 > 0.0)
        .map(|w| w[1].1)
        .collect();
    let cycles = crossings.len() - 1;
    let frequency = cycles as f64 / (crossings[cycles] - crossings[0]);
    let (first, last) = (peaks[1], peaks[peaks.len() - 1]);
    let decrement = (first / last).ln() / (peaks.len() - 2) as f64;
    let zeta = decrement / (TAU * TAU + decrement * decrement).sqrt();
    let exact_zeta = DAMPING / (2.0 * (STIFFNESS * MASS).sqrt());
    let exact_frequency = (STIFFNESS / MASS).sqrt() * (1.0 - exact_zeta * exact_zeta).sqrt() / TAU;
    println!(
        "tool free vibration at dt = 10 µs: {frequency:.3} Hz vs {exact_frequency:.3} Hz, ζ {zeta:.5} vs {exact_zeta:.5}"
    );
    assert!(cycles >= 40, "{cycles} cycles");
    assert!((frequency / exact_frequency - 1.0).abs() < 0.005);
    assert!((zeta / exact_zeta - 1.0).abs() < 0.02);
}

#[test]
fn constant_15000_rpm_chatters_near_808_hz_and_z04_lowers_the_spectral_peak_by_half() {
    let constant = run(builtin(SCENARIO).loaded(), None);
    let z04 = run(builtin("milling-z04").loaded(), None);
    let metric = |run: &twin::RunSummary, name: &str| run.metric(name).expect(name);
    let frequency = metric(&constant, "chatter_frequency");
    assert!((frequency / 808.0 - 1.0).abs() < 0.05, "{frequency} Hz");
    // Off the tooth-passing harmonics (500 Hz at 15,000 rpm with two flutes): chatter.
    assert!((frequency - 500.0).abs() > 20.0 && (frequency - 1000.0).abs() > 20.0);
    let ratio = metric(&z04, "spectrum_peak") / metric(&constant, "spectrum_peak");
    assert!(ratio <= 0.5, "Z04/constant peak {ratio}");
    assert!(metric(&z04, "displacement_rms") < metric(&constant, "displacement_rms"));
    let [low, high] = [
        metric(&z04, "spindle_speed_min"),
        metric(&z04, "spindle_speed_max"),
    ];
    assert!(
        (low - 15_000.0).abs() < 50.0 && (high - 16_500.0).abs() < 50.0,
        "{low}–{high} rpm"
    );
}

#[test]
fn the_lobes_agree_with_the_twins_own_runs() {
    let rpm = |n: f64| n * TAU / 60.0;
    let analysis = analyze(
        &LobeRequest {
            scenario: builtin(SCENARIO),
            speeds: [rpm(11_000.0), rpm(23_000.0)],
            speed_count: 25,
            max_depth: 3e-3,
            check: [4, 3],
            check_duration: 0.4,
            frf: None,
        },
        &controllers::builtin(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    println!("{}", analysis.summary());
    let (agree, judged) = analysis.agreement();
    assert!(judged >= 8, "{judged} judged");
    assert!(agree as f64 >= 0.9 * judged as f64, "{agree} of {judged}");
    // Both outcomes occur on the grid: the check can fail either way.
    assert!(analysis.checks.iter().any(|c| c.chatter));
    assert!(analysis.checks.iter().any(|c| !c.chatter));
}

#[test]
fn bad_milling_input_is_refused_naming_the_entry() {
    let error = |builder: twin::ScenarioBuilder| match builder.build(&controllers::builtin()) {
        Err(e) => e.to_string(),
        Ok(loaded) => match Twin::new(loaded) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("accepted"),
        },
    };
    let cases = [
        (
            builtin(SCENARIO).with("initial.quill.velocity", 1.0),
            "initial.quill",
        ),
        (
            builtin(SCENARIO).with("plant.joint.spindle.stiffness", 1.0),
            "plant.joint.spindle.stiffness",
        ),
        (builtin(SCENARIO).with("process.cut.flutes", 0), "flutes"),
        (
            builtin(SCENARIO).with("process.cut.exit_angle", -1.0),
            "exit_angle",
        ),
        (
            builtin(SCENARIO).with("controller.params.speed", -5.0),
            "speed",
        ),
        (
            builtin("milling-z04").with("controller.params.rise_time", 0.0),
            "rise_time",
        ),
    ];
    for (builder, needle) in cases {
        let message = error(builder);
        assert!(message.contains(needle), "{needle}: {message}");
    }
}
