//! `twin frf`: a scenario's frequency response from one joint's effort to one of its signals, as
//! a tap test or a shaker measures it. The twin runs the scenario (its controller as the scenario
//! says) with an effort from outside the machine added on the joint
//! ([`twin::Twin::with_joint_effort`]), the output is sampled, and the response is estimated by H1
//! with Welch averaging ([`estimate`](crate::frequency_response::estimate)); the peak's mode is
//! fitted ([`fit`](crate::frequency_response::fit)).
//!
//! Excitations, each held over a sample period: `impulse`, a one-sample pulse of the amplitude
//! at the start of each segment, no window (the response dies within its segment); `chirp`, a
//! linear sweep over the band once per segment, Hann window; `noise`, uniform white noise within
//! ± the amplitude (seeded), Hann window, segments overlapping by half. Each runs one segment
//! first, unexcited, to settle (not averaged): a scenario that starts with a move (a controller
//! taking its axes to their targets) is measured where it comes to rest. The response is taken
//! about the operating point: each segment's output less its level before the tap (impulse) or
//! its mean (chirp, noise), so an axis held away from zero leaks nothing into the lowest lines.

use crate::flags::SetFlag;
use crate::frequency_response::estimate::{h1_estimate, Complex, FrfLine, Segments, Window};
use crate::frequency_response::file;
use crate::frequency_response::fit::{fit_mode, ModalFit};
use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;
use twin::recordings::{write_figures, Plot2D, PlotAxis, PlotGeometry, PlotLayer};
use twin::{Observer, ObserverError, StepView, Twin};

#[derive(Debug, Error)]
pub enum FrfError {
    #[error("{flag}: {reason}")]
    Argument { flag: &'static str, reason: String },
    #[error("the run diverged: {0}; lower --amplitude or check the scenario")]
    Diverged(String),
    #[error("cannot write {path}: {reason}")]
    Output { path: PathBuf, reason: String },
    #[error(transparent)]
    Recording(#[from] twin::RecordingError),
}

fn argument(flag: &'static str, reason: impl std::fmt::Display) -> FrfError {
    FrfError::Argument {
        flag,
        reason: reason.to_string(),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Excitation {
    Impulse,
    Chirp,
    Noise,
}

/// `twin frf` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Set a scenario value (as `twin run --set`), after `--controller`")))]
pub struct FrfArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// The joint excited: its effort (N on a prismatic joint, N·m on a revolute one).
    #[arg(long)]
    pub input: String,
    /// The plant signal measured (e.g. `tool_x.position`).
    #[arg(long)]
    pub output: String,
    #[arg(long, value_enum, default_value_t = Excitation::Impulse)]
    pub excitation: Excitation,
    /// Segments averaged (Welch).
    #[arg(long, default_value_t = 8)]
    pub averages: usize,
    /// Frequencies written and swept, Hz (default 0 to the Nyquist frequency).
    #[arg(long, num_args = 2, value_names = ["F1", "F2"], allow_hyphen_values = true)]
    pub band: Option<Vec<f64>>,
    /// Peak effort, N or N·m (default: a tenth of the joint's actuator limit, 100 without one).
    #[arg(long, allow_hyphen_values = true)]
    pub amplitude: Option<f64>,
    /// Sampling rate, Hz: the physics step must divide its period.
    #[arg(long, default_value_t = 10_000.0, allow_hyphen_values = true)]
    pub rate: f64,
    /// Samples per segment, a power of two (resolution = rate / segment).
    #[arg(long, default_value_t = 4096)]
    pub segment: usize,
    /// Seed of the noise excitation.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Replace the scenario's controller (`passive`: the plant open loop, as the linear model
    /// describes it).
    #[arg(long)]
    pub controller: Option<String>,
    #[command(flatten)]
    pub values: SetFlag,
    /// Folder for frf.csv and frf.rrd.
    #[arg(long, default_value = "frf")]
    pub out_dir: PathBuf,
}

/// A measured frequency response and the mode fitted at its peak.
#[derive(Debug, Clone)]
pub struct FrfResult {
    pub lines: Vec<FrfLine>,
    /// `Err` says why no mode could be fitted.
    pub mode: Result<ModalFit, String>,
    pub input: String,
    pub output: String,
    pub amplitude: f64,
    /// The linear model's response at the lines (`twin linearize` at t = 0), or why it is not
    /// comparable with this measurement.
    pub linear: Result<Vec<Complex>, String>,
}

/// Runs `twin frf`: the measurement, its files and a summary for the terminal.
pub fn run(args: &FrfArgs, registry: &framework::Registry) -> Result<String, FrfError> {
    let result = measure(args, registry)?;
    let files = write(&result, &args.out_dir)?;
    let mut out = summary(&result);
    for file in files {
        let _ = writeln!(out, "wrote {}", file.display());
    }
    Ok(out)
}

/// The plan of a measurement: sample period, segments and the total samples.
struct Plan {
    period: f64,
    segments: Segments,
    samples: usize,
    band: [f64; 2],
}

fn plan(args: &FrfArgs) -> Result<Plan, FrfError> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        return Err(argument(
            "--rate",
            format!("must be > 0 Hz, got {}", args.rate),
        ));
    }
    if !(args.segment.is_power_of_two() && (64..=1 << 20).contains(&args.segment)) {
        return Err(argument(
            "--segment",
            format!(
                "must be a power of two from 64 to 2^20 samples, got {}",
                args.segment
            ),
        ));
    }
    if !(1..=1000).contains(&args.averages) {
        return Err(argument(
            "--averages",
            format!("must be 1 to 1000, got {}", args.averages),
        ));
    }
    let nyquist = args.rate / 2.0;
    let resolution = args.rate / args.segment as f64;
    let band = match args.band.as_deref() {
        Some(&[low, high]) => [low, high],
        _ => [0.0, nyquist],
    };
    if !(band[0].is_finite() && band[1].is_finite() && 0.0 <= band[0] && band[0] < band[1]) {
        return Err(argument(
            "--band",
            format!(
                "must be F1 F2 with 0 ≤ F1 < F2, got {} {}",
                band[0], band[1]
            ),
        ));
    }
    if band[1] > nyquist {
        return Err(argument(
            "--band",
            format!(
                "{} Hz is above the Nyquist frequency {nyquist} Hz of --rate {}; lower F2 or \
                 raise --rate",
                band[1], args.rate
            ),
        ));
    }
    if band[1] - band[0] < 2.0 * resolution {
        return Err(argument(
            "--band",
            format!(
                "{}–{} Hz is narrower than two lines of the resolution {resolution} Hz (--rate / \
                 --segment); widen it or lengthen --segment",
                band[0], band[1]
            ),
        ));
    }
    let (window, hop) = match args.excitation {
        Excitation::Impulse => (Window::Rectangular, args.segment),
        Excitation::Chirp => (Window::Hann, args.segment),
        Excitation::Noise => (Window::Hann, args.segment / 2),
    };
    let settle = args.segment;
    let segments = Segments {
        first: settle,
        segment: args.segment,
        hop,
        count: args.averages,
        window,
    };
    Ok(Plan {
        period: 1.0 / args.rate,
        samples: settle + (args.averages - 1) * hop + args.segment,
        segments,
        band,
    })
}

/// The excitation's samples, each held over a sample period.
fn excitation(args: &FrfArgs, plan: &Plan, amplitude: f64) -> Vec<f64> {
    let n = plan.segments.segment;
    let settle = plan.segments.first;
    let mut noise = twin::Noise::new(args.seed);
    (0..plan.samples)
        .map(|k| match args.excitation {
            _ if k < settle => 0.0,
            Excitation::Impulse => {
                if (k - settle).is_multiple_of(n) {
                    amplitude
                } else {
                    0.0
                }
            }
            Excitation::Chirp => {
                // Linear sweep f(t) = f1 + (f2 − f1)·t/T_seg, restarted every segment.
                let t = (k % n) as f64 * plan.period;
                let length = n as f64 * plan.period;
                let [f1, f2] = plan.band;
                amplitude * (TAU * (f1 * t + (f2 - f1) * t * t / (2.0 * length))).sin()
            }
            Excitation::Noise => amplitude * (2.0 * noise.uniform() - 1.0),
        })
        .collect()
}

/// Samples one plant signal every `every` steps.
struct Sampler {
    signal: usize,
    every: usize,
    values: Vec<f64>,
}

impl Observer for Sampler {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.step.is_multiple_of(self.every) {
            self.values.push(view.signals[self.signal]);
        }
        Ok(())
    }
}

/// Runs the scenario under the excitation and estimates the response.
pub fn measure(args: &FrfArgs, registry: &framework::Registry) -> Result<FrfResult, FrfError> {
    let plan = plan(args)?;
    let duration = plan.samples as f64 * plan.period;
    let loaded = load(args, registry, duration)?;
    let dt = loaded.scenario.dt;
    let every = (plan.period / dt).round();
    if !(every >= 1.0 && (every * dt - plan.period).abs() <= 1e-9 * plan.period) {
        return Err(argument(
            "--rate",
            format!(
                "its period {} s is not a whole number of the scenario's steps (dt = {dt} s)",
                plan.period
            ),
        ));
    }
    let every = every as usize;
    let twin = Twin::new(loaded).map_err(|e| argument("scenario", e))?;
    let signal =
        (twin.plant().signals.iter().position(|s| *s == args.output)).ok_or_else(|| {
            argument(
                "--output",
                format!(
                    "the scenario has no signal `{}` (known: {})",
                    args.output,
                    twin.plant().signals.join(", ")
                ),
            )
        })?;
    let amplitude = amplitude(args, &twin)?;
    let samples = excitation(args, &plan, amplitude);
    let efforts: Vec<f64> = samples
        .iter()
        .flat_map(|&u| std::iter::repeat_n(u, every))
        .collect();
    let twin = twin
        .with_joint_effort(&args.input, efforts)
        .map_err(|e| argument("--input", e))?;
    let mut sampler = Sampler {
        signal,
        every,
        values: Vec::with_capacity(plan.samples + 1),
    };
    let summary =
        (twin.run_with(None, &mut [&mut sampler])).map_err(|e| argument("scenario", e))?;
    if let Some(failure) = summary.failure {
        return Err(FrfError::Diverged(failure.to_string()));
    }
    if sampler.values.len() < plan.samples {
        return Err(argument("scenario", "the run stopped before its end"));
    }
    let lines = h1_estimate(
        &samples,
        &sampler.values,
        plan.period,
        plan.segments,
        plan.band,
    );
    Ok(FrfResult {
        mode: fit_mode(&lines),
        linear: linear_response(args, registry, duration, &lines),
        lines,
        input: args.input.clone(),
        output: args.output.clone(),
        amplitude,
    })
}

/// The scenario with the command's `--set` values, over `duration`.
fn load(
    args: &FrfArgs,
    registry: &framework::Registry,
    duration: f64,
) -> Result<twin::LoadedScenario, FrfError> {
    let mut scenario = twin::Scenario::open(&args.scenario).map_err(|e| argument("scenario", e))?;
    if let Some(name) = &args.controller {
        scenario = scenario.controller(name);
    }
    for assignment in &args.values.set {
        scenario = scenario
            .assign(assignment)
            .map_err(|e| argument("--set", e))?;
    }
    (scenario.duration(duration).build(registry)).map_err(|e| argument("scenario", e))
}

/// The linear model's G(j·2πf) from the input's effort to the output at each line, when it
/// describes what was measured: the plant open loop (controller `passive`: a controller would
/// close the loop the model leaves open), the input an actuator and the output a state signal.
fn linear_response(
    args: &FrfArgs,
    registry: &framework::Registry,
    duration: f64,
    lines: &[FrfLine],
) -> Result<Vec<Complex>, String> {
    let loaded = load(args, registry, duration).map_err(|e| e.to_string())?;
    if loaded.scenario.controller.name != "passive" {
        return Err(format!(
            "the controller `{}` closes the loop (`--controller passive` measures the plant \
             the model describes)",
            loaded.scenario.controller.name
        ));
    }
    let model = Twin::new(loaded)
        .map_err(|e| e.to_string())?
        .linearize(0.0)
        .map_err(|e| e.to_string())?;
    let input = (model.inputs.iter().position(|c| c.name == args.input)).ok_or_else(|| {
        format!(
            "`{}` is no input of the linear model (not an actuator)",
            args.input
        )
    })?;
    let output = (model.outputs.iter().position(|c| c.name == args.output))
        .ok_or_else(|| format!("`{}` is no output of the linear model", args.output))?;
    lines
        .iter()
        .map(|line| {
            let omega = TAU * line.frequency_hz;
            let response = model.frequency_response(omega);
            let [re, im] = response.ok_or_else(|| format!("a pole at {} Hz", line.frequency_hz))?
                [output][input];
            Ok(Complex::new(re, im))
        })
        .collect()
}

/// The excitation's peak: within the joint's actuator limit if it has an actuator.
fn amplitude(args: &FrfArgs, twin: &Twin) -> Result<f64, FrfError> {
    let limit = (twin.plant().actuators.iter())
        .find(|a| a.joint == args.input)
        .map(|a| a.effort_limit);
    let amplitude = args
        .amplitude
        .unwrap_or_else(|| limit.map_or(100.0, |l| 0.1 * l));
    if !(amplitude.is_finite() && amplitude > 0.0) {
        return Err(argument(
            "--amplitude",
            format!("must be > 0 (N or N·m), got {amplitude}"),
        ));
    }
    if let Some(limit) = limit.filter(|&l| amplitude > l) {
        return Err(argument(
            "--amplitude",
            format!(
                "{amplitude} exceeds the actuator limit {limit} of joint `{}`; lower it",
                args.input
            ),
        ));
    }
    Ok(amplitude)
}

/// Writes `frf.csv` and `frf.rrd` (Bode plots and coherence) into `dir`.
pub fn write(result: &FrfResult, dir: &Path) -> Result<Vec<PathBuf>, FrfError> {
    std::fs::create_dir_all(dir).map_err(|e| FrfError::Output {
        path: dir.to_path_buf(),
        reason: e.to_string(),
    })?;
    let files = [dir.join("frf.csv"), dir.join("frf.rrd")];
    let csv = file::to_csv(&result.lines);
    twin::OutputFile::create(&files[0])
        .and_then(|f| f.commit(csv.as_bytes()))
        .map_err(|e| FrfError::Output {
            path: e.path,
            reason: e.reason,
        })?;
    let title = format!("frf {} → {}", result.input, result.output);
    let legend = match result.linear {
        Ok(_) => "blue: measured (H1); orange: the linear model (twin linearize)\n",
        Err(_) => "blue: measured (H1)\n",
    };
    let notes = format!("{legend}{}", summary(result));
    write_figures(&files[1], &title, &notes, &bode(result))?;
    Ok(files.to_vec())
}

const MEASURED: [u8; 3] = [31, 119, 180];
const LINEAR_MODEL: [u8; 3] = [255, 127, 14];

/// A named, coloured curve of (frequency Hz, value) points.
type Curve<'a> = (&'a str, [u8; 3], Vec<[f64; 2]>);

/// The Bode diagram and the coherence against frequency: magnitude in dB (re 1 SI unit per N
/// or N·m) and phase in degrees, the linear model's drawn over the measured where it applies.
fn bode(result: &FrfResult) -> Vec<Plot2D> {
    let curve = |values: &mut dyn Iterator<Item = f64>| -> Vec<[f64; 2]> {
        (result.lines.iter().zip(values))
            .map(|(l, value)| [l.frequency_hz, value])
            .collect()
    };
    let decibels = |z: &Complex| 20.0 * z.abs().log10();
    let degrees = |z: &Complex| z.arg().to_degrees();
    let measured: Vec<Complex> = result.lines.iter().map(|l| l.response).collect();
    let linear = result.linear.as_ref().ok();
    let with_model = |f: &dyn Fn(&Complex) -> f64| {
        let mut layers = vec![("measured", MEASURED, curve(&mut measured.iter().map(f)))];
        if let Some(linear) = linear {
            layers.push((
                "linear_model",
                LINEAR_MODEL,
                curve(&mut linear.iter().map(f)),
            ));
        }
        layers
    };
    let coherence = curve(&mut result.lines.iter().map(|l| l.coherence));
    vec![
        figure(
            result,
            "magnitude [dB re 1 SI unit per N or N·m]",
            with_model(&decibels),
        ),
        figure(result, "phase [°]", with_model(&degrees)),
        figure(
            result,
            "coherence γ² [-]",
            vec![("coherence", MEASURED, coherence)],
        ),
    ]
}

/// One figure against frequency, its y window fitted to the finite values of its curves.
fn figure(result: &FrfResult, y_title: &str, curves: Vec<Curve<'_>>) -> Plot2D {
    let finite = curves
        .iter()
        .flat_map(|c| &c.2)
        .map(|p| p[1])
        .filter(|v| v.is_finite());
    let (low, high) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    let pad = 0.05 * (high - low).max(1e-9);
    let frequencies = result.lines.iter().map(|l| l.frequency_hz);
    let (first, last) = frequencies.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), f| {
        (l.min(f), h.max(f))
    });
    let layers = curves
        .into_iter()
        .map(|(name, color, points)| {
            let pieces = points.split(|p| !p[1].is_finite()).map(<[_]>::to_vec);
            let geometry = PlotGeometry::Lines(pieces.filter(|p| p.len() > 1).collect());
            // The curves lie on each other where the model holds: the notes name the colours.
            PlotLayer::new(name, color, 1.5, geometry, Vec::new())
        })
        .collect();
    Plot2D {
        title: y_title.split(" [").next().unwrap_or(y_title).to_string(),
        notes: String::new(),
        x: PlotAxis {
            title: "frequency [Hz]".into(),
            range: [first, last],
        },
        y: PlotAxis {
            title: y_title.into(),
            range: [low - pad, high + pad],
        },
        aspect: Some(0.35),
        layers,
    }
}

/// The measured response against the linear model's, where the measurement is clean (coherence
/// ≥ 0.999): the largest |H − G| / |G|.
pub fn linear_difference(result: &FrfResult) -> Result<f64, String> {
    let linear = result.linear.as_ref().map_err(String::clone)?;
    let clean = (result.lines.iter().zip(linear)).filter(|(l, _)| l.coherence >= 0.999);
    let difference = clean
        .map(|(l, g)| {
            let h = l.response;
            (h.re - g.re).hypot(h.im - g.im) / g.abs()
        })
        .fold(f64::NAN, f64::max);
    match difference.is_nan() {
        true => Err("no line with coherence ≥ 0.999 to compare".to_string()),
        false => Ok(difference),
    }
}

/// What was measured and the fitted mode.
pub fn summary(result: &FrfResult) -> String {
    let mut out = format!(
        "frequency response {} → {} (peak effort {}): {} lines",
        result.input,
        result.output,
        result.amplitude,
        result.lines.len()
    );
    if let (Some(first), Some(last)) = (result.lines.first(), result.lines.last()) {
        let _ = write!(out, ", {} to {} Hz", first.frequency_hz, last.frequency_hz);
    }
    out.push('\n');
    match &result.mode {
        Ok(m) => {
            let _ = writeln!(
                out,
                "mode at the peak (single-mode fit, {} lines {:.1}–{:.1} Hz): f_n {:.3} Hz, ζ \
                 {:.5}; as a receptance: mass {:.6} kg, stiffness {:.6e} N/m, damping {:.4} N·s/m",
                m.lines,
                m.band[0],
                m.band[1],
                m.natural_frequency_hz,
                m.damping_ratio,
                m.mass,
                m.stiffness,
                m.damping
            );
        }
        Err(reason) => {
            let _ = writeln!(out, "no mode fitted: {reason}");
        }
    }
    let _ = match linear_difference(result) {
        Ok(d) => writeln!(
            out,
            "linear model (twin linearize at t = 0): largest |H − G|/|G| {d:.2e} over the lines \
             with coherence ≥ 0.999"
        ),
        Err(reason) => writeln!(out, "linear model not compared: {reason}"),
    };
    out
}
