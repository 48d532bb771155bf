//! The recording's spectra and lobe diagram, read back from the file: a milling run's spectrum
//! with its chatter frequency and tooth-passing harmonics (against the run's own spectrum metrics
//! and a direct Fourier sum of the tool's displacement), its operating point on the lobes (against
//! the scenario and `models::milling::stability`), a spectrum on any machine whose scenario has a
//! spectral metric, and the same bytes from the same inputs.

use models::milling::stability::{limiting_depth, SemiDiscretization, ToolModes};
use std::f64::consts::TAU;
use std::path::Path;
use twin::recordings::{inspect, FigureLayer, RecordingContents};
use twin::{Findings, Observer, ObserverError, RunSummary, SignalLayout, StepView, Twin};
use twin_tests::{builtin, scratch, Configure};

const SCENARIO: &str = "milling-constant-15000";
const SPECTRUM: &str = "/figures/spectrum_tool_y_position/data";
const LOBES: &str = "/figures/lobes/data";
/// The scenario's spectral window starts here, s.
const FROM: f64 = 0.4;

/// Every step's value of some true signals.
struct Trace {
    names: Vec<&'static str>,
    indices: Vec<usize>,
    samples: Vec<(f64, Vec<f64>)>,
}

impl Trace {
    fn of(names: &[&'static str]) -> Self {
        Self {
            names: names.to_vec(),
            indices: Vec::new(),
            samples: Vec::new(),
        }
    }

    /// Signal `k`'s values from `from` s on.
    fn values(&self, k: usize, from: f64) -> Vec<f64> {
        let window = self.samples.iter().filter(|(t, _)| *t >= from);
        window.map(|(_, v)| v[k]).collect()
    }
}

impl Observer for Trace {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        for name in &self.names {
            self.indices
                .push(layout.signal(name).ok_or("no such signal")?);
        }
        Ok(())
    }
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let values = self.indices.iter().map(|&i| view.signals[i]).collect();
        self.samples.push((view.time, values));
        Ok(())
    }
    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings::default())
    }
}

/// Runs the milling scenario at axial depth `depth` (m) for `duration` s, recording to `path`,
/// with the tool's y displacement and the spindle speed traced.
fn milling_run(depth: f64, duration: f64, path: &Path) -> (RunSummary, Trace) {
    let loaded = builtin(SCENARIO)
        .with("process.cut.axial_depth", depth)
        .duration(duration)
        .loaded();
    let mut trace = Trace::of(&["tool_y.position", "spindle.velocity"]);
    let summary = Twin::new(loaded)
        .and_then(|t| t.run_with(Some(path), &mut [&mut trace]))
        .unwrap_or_else(|e| panic!("{e}"));
    (summary, trace)
}

fn metric(summary: &RunSummary, name: &str) -> f64 {
    summary
        .metrics
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no metric {name}"))
        .1
}

fn layer<'a>(contents: &'a RecordingContents, entity: &str) -> &'a FigureLayer {
    contents.figure_layers.get(entity).unwrap_or_else(|| {
        let known: Vec<&String> = contents.figure_layers.keys().collect();
        panic!("no figure layer {entity} among {known:?}")
    })
}

/// The amplitude at `frequency` (Hz) of `samples` taken every `period` s, Hann-windowed, mean
/// removed, by a direct Fourier sum: what the spectrum's bin there reads.
fn direct_amplitude(samples: &[f64], period: f64, frequency: f64) -> f64 {
    let n = samples.len();
    let mean = samples.iter().sum::<f64>() / n as f64;
    let (mut re, mut im, mut weights) = (0.0, 0.0, 0.0);
    for (k, x) in samples.iter().enumerate() {
        let w = 0.5 - 0.5 * (TAU * k as f64 / (n - 1) as f64).cos();
        let (s, c) = (TAU * frequency * k as f64 * period).sin_cos();
        re += w * (x - mean) * c;
        im -= w * (x - mean) * s;
        weights += w;
    }
    2.0 * re.hypot(im) / weights
}

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance * b.abs().max(1e-300)
}

#[test]
fn a_milling_recording_shows_the_chatter_frequency_and_the_tooth_passing_harmonics() {
    let dir = scratch("spectra-chatter");
    let path = dir.join("milling.rrd");
    let (summary, trace) = milling_run(5e-4, 0.8, &path);
    let contents = inspect(&path).unwrap();
    assert!(contents
        .views_2d
        .iter()
        .any(|v| v.starts_with("spectrum of tool_y.position")));

    // The chatter mark: at the run's own chatter frequency (the spectrum's peak), labelled.
    let chatter = metric(&summary, "chatter_frequency");
    let peak = layer(&contents, &format!("{SPECTRUM}/peak"));
    assert_eq!(peak.lines.len(), 1);
    assert!(peak.lines[0]
        .iter()
        .all(|p| close(p[0].into(), chatter, 1e-6)));
    let label = &layer(&contents, &format!("{SPECTRUM}/peak/label")).labels;
    assert_eq!(label, &[format!("chatter {chatter:.1} Hz")]);
    assert!((780.0..810.0).contains(&chatter), "{chatter} Hz");

    // The spectrum's highest point is that peak, its amplitude the metric's (m → µm) and a direct
    // Fourier sum's of the traced displacement over the window.
    let line = &layer(&contents, &format!("{SPECTRUM}/spectrum")).lines;
    let top = line
        .iter()
        .flatten()
        .max_by(|a, b| a[1].total_cmp(&b[1]))
        .unwrap();
    assert!(close(top[0].into(), chatter, 1e-6), "{top:?}");
    let amplitude = f64::from(top[1]);
    assert!(close(
        amplitude,
        1e6 * metric(&summary, "spectrum_peak"),
        1e-6
    ));
    let direct = direct_amplitude(&trace.values(0, FROM), 1e-5, chatter);
    assert!(
        close(amplitude, 1e6 * direct, 1e-5),
        "{amplitude} vs {}",
        1e6 * direct
    );

    // Harmonics k·f_t of the tooth passing over the window (2 flutes), within 100 Hz to 5 kHz.
    let speeds = trace.values(1, FROM);
    let mean_speed = speeds.iter().sum::<f64>() / speeds.len() as f64;
    let tooth = 2.0 * mean_speed / TAU;
    assert!(close(tooth, 500.0, 1e-4), "{tooth}");
    let harmonics = layer(&contents, &format!("{SPECTRUM}/harmonics"));
    let expected = (5000.0 / tooth).floor() as usize;
    assert_eq!(harmonics.lines.len(), expected);
    for (k, line) in harmonics.lines.iter().enumerate() {
        let at = (k + 1) as f64 * tooth;
        assert!(
            line.iter().all(|p| close(p[0].into(), at, 1e-6)),
            "{k}: {line:?}"
        );
    }

    // The run on the lobes: its speed and depth, chattering, above the limit at its speed.
    let run = layer(&contents, &format!("{LOBES}/run/operating_point"));
    let [rpm, depth] = run.points[0].map(f64::from);
    assert!(close(rpm, mean_speed * 60.0 / TAU, 1e-6) && close(depth, 0.5, 1e-6));
    assert_eq!(
        run.labels,
        [format!("this run: {rpm:.0} rpm, 0.500 mm, chatter")]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stable_cut_is_marked_stable_under_lobes_that_match_the_stability_analysis() {
    let dir = scratch("spectra-stable");
    let path = dir.join("milling.rrd");
    let (_, trace) = milling_run(5e-5, 0.8, &path);
    let contents = inspect(&path).unwrap();
    // No chatter mark; the point is stable, 15,000 rpm at 0.05 mm.
    assert!(!contents
        .figure_layers
        .contains_key(&format!("{SPECTRUM}/peak")));
    let run = layer(&contents, &format!("{LOBES}/run/operating_point"));
    assert!(
        run.labels[0].ends_with("0.050 mm, stable"),
        "{:?}",
        run.labels
    );
    let speeds = trace.values(1, FROM);
    let rpm = speeds.iter().sum::<f64>() / speeds.len() as f64 * 60.0 / TAU;
    assert!(close(run.points[0][0].into(), rpm, 1e-6));

    // The lobes: from 0.6 to 1.6 times the starting speed, depths up to twice the run's; each
    // drawn point is the semi-discretization's limit (20 intervals) at its speed.
    let tool = ToolModes {
        mass: [0.05598 + 1e-6, 0.05598],
        stiffness: [1.3669e6; 2],
        damping: [11.064; 2],
    };
    let cut = models::milling::stability::CutGeometry {
        flutes: 2,
        cutting_pressure: 7e8,
        force_ratio: 0.3,
        entry_angle: 0.0,
        exit_angle: std::f64::consts::PI,
    };
    let lobes = layer(&contents, &format!("{LOBES}/lobes"));
    let points: Vec<[f32; 2]> = lobes.lines.iter().flatten().copied().collect();
    assert!(points.len() > 10, "{points:?}");
    let sd = SemiDiscretization { intervals: 20 };
    for point in points.iter().step_by(7) {
        let speed = f64::from(point[0]) * TAU / 60.0;
        assert!((0.6 * 1570.79..=1.6 * 1570.8).contains(&speed), "{point:?}");
        let limit = limiting_depth(&tool, &cut, speed, 1e-4, &sd)
            .unwrap()
            .unwrap();
        assert!(
            close(f64::from(point[1]), limit.depth * 1e3, 1e-3),
            "{point:?} vs {limit:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn any_scenario_with_a_spectral_metric_shows_its_spectrum() {
    let dir = scratch("spectra-any");
    let path = dir.join("whitworth.rrd");
    let extra = r#"
[[metrics]]
name = "ram_peak_frequency"
kind = "spectrum_peak_frequency"
signal = "ram_position"
from = 0.5
frequencies = [0.2, 50.0]
"#;
    let text = format!("{}\n{extra}", builtin_text("whitworth-crank-pi"));
    let loaded = twin::Scenario::from_toml(&text, "whitworth-crank-pi", None)
        .map(|s| s.duration(3.0))
        .unwrap()
        .loaded();
    let summary = twin_tests::run(loaded, Some(&path));
    let contents = inspect(&path).unwrap();
    let title = "spectrum of ram_position, 0.5 s to end";
    assert!(
        contents.views_2d.iter().any(|v| v == title),
        "{:?}",
        contents.views_2d
    );
    let base = "/figures/spectrum_ram_position/data";
    let frequency = metric(&summary, "ram_peak_frequency");
    let peak = layer(&contents, &format!("{base}/peak"));
    assert!(close(peak.lines[0][0][0].into(), frequency, 1e-6));
    let label = &layer(&contents, &format!("{base}/peak/label")).labels;
    assert_eq!(label, &[format!("peak {frequency:.1} Hz")]);
    // No excitation, no lobes; and a scenario without a spectral metric draws no figure.
    assert!(!contents
        .figure_layers
        .keys()
        .any(|k| k.starts_with("/figures/lobes")));
    let plain = dir.join("plain.rrd");
    twin_tests::run(
        builtin("whitworth-crank-pi").duration(0.5).loaded(),
        Some(&plain),
    );
    assert!(inspect(&plain).unwrap().figure_layers.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

fn builtin_text(name: &str) -> &'static str {
    twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap()
        .1
}

#[test]
fn a_milling_recording_is_the_same_bytes_for_the_same_inputs() {
    let dir = scratch("spectra-bytes");
    let [a, b] = ["a.rrd", "b.rrd"].map(|name| {
        let path = dir.join(name);
        milling_run(5e-4, 0.45, &path);
        std::fs::read(&path).unwrap()
    });
    assert!(a.len() > 100_000, "{} bytes", a.len());
    let first_difference = a.iter().zip(&b).position(|(x, y)| x != y);
    assert_eq!((a.len(), first_difference), (b.len(), None));
    let _ = std::fs::remove_dir_all(&dir);
}
