//! A shadow's recording, opening on a watch view: the mechanism posed by the estimate (and in
//! grey where the measured joint positions put it, when they place it), the tests against their
//! thresholds with the open anomaly's span, and the tracked parameters with their 95 %
//! intervals; further tabs hold per watched signal the measurement and the estimate, the
//! residual and the normalised innovations. Anomalies and connection events are in the log.

use super::detector::AnomalyChange;
use super::error::ShadowError;
use super::watch::{Shadow, ShadowStep};
use crate::mechanism::{Pose2, Shape};
use crate::recording::{
    LiveViewer, PlotSpec, PlotTab, Recorder, RecordingLayout, SeriesRole, SeriesSpec,
};
use framework::{EventLevel, Unit};
use std::path::Path;

/// A shadow's `.rrd`, written as the shadow goes (atomically, as a run's).
pub struct ShadowRecording {
    recorder: Recorder,
    values: Vec<f64>,
    steps: i64,
    watched: usize,
    knobs: usize,
    /// The links' poses at the estimate, then (with `ghost`) where the measurements last put
    /// them.
    poses: Vec<Pose2>,
    ghost: bool,
    /// Whether an anomaly is open (one at a time: it closes when every test is released).
    open: bool,
}

/// One plotted series.
fn series(name: String, role: SeriesRole, value: usize) -> SeriesSpec {
    SeriesSpec {
        name,
        role,
        value,
        column: None,
    }
}

/// Where the anomaly flag (1 while one is open, else 0) is among the values, after the
/// parameters' estimates and bounds.
fn alarm_index(watched: usize, parameters: usize) -> usize {
    5 * watched + 1 + 4 * parameters
}

/// The plots, their series indexing the values [`ShadowRecording::push`] lays out: measured,
/// estimate, residual, normalised innovation and CUSUM per signal, the NIS, drift per
/// parameter, then estimate, lower and upper bound per parameter, then the anomaly flag.
fn plots(shadow: &Shadow) -> Vec<PlotSpec> {
    let w = shadow.watched().len();
    let p = shadow.parameters().len();
    let units = shadow.watched_units();
    let mut plots = Vec::new();
    for (s, (name, unit)) in shadow.watched().iter().zip(&units).enumerate() {
        plots.push(PlotSpec {
            tab: PlotTab::Tracking,
            name: name.clone(),
            unit: *unit,
            series: vec![
                series(format!("{name} measured"), SeriesRole::Measured, s),
                series(format!("{name} estimate"), SeriesRole::True, w + s),
            ],
        });
        plots.push(PlotSpec {
            tab: PlotTab::Process,
            name: format!("{name} residual"),
            unit: *unit,
            series: vec![series(
                format!("{name} residual"),
                SeriesRole::Other,
                2 * w + s,
            )],
        });
    }
    let each = |offset: usize, label: &'static str| {
        (shadow.watched().iter().enumerate())
            .map(move |(s, name)| series(format!("{name} {label}"), SeriesRole::Other, offset + s))
    };
    plots.push(PlotSpec {
        tab: PlotTab::Diagnostics,
        name: "normalised innovations".into(),
        unit: Unit::Dimensionless,
        series: each(3 * w, "ν/√S").collect(),
    });
    let mut tests: Vec<SeriesSpec> = each(4 * w, "CUSUM / h").collect();
    tests.push(series(
        "NIS window / threshold".into(),
        SeriesRole::Other,
        5 * w,
    ));
    tests.extend((shadow.parameters().iter().enumerate()).map(|(j, key)| {
        series(
            format!("{key} drift / threshold"),
            SeriesRole::Other,
            5 * w + 1 + j,
        )
    }));
    tests.push(series(
        "anomaly open (1)".into(),
        SeriesRole::Reference,
        alarm_index(w, p),
    ));
    plots.push(PlotSpec {
        tab: PlotTab::Watch,
        name: "anomaly tests (alarm above 1)".into(),
        unit: Unit::Dimensionless,
        series: tests,
    });
    plots.extend(parameter_plots(shadow, 5 * w + 1 + p));
    plots
}

/// One plot per parameter: its estimate and 95 % bounds, from value `base` on (three per
/// parameter).
fn parameter_plots(shadow: &Shadow, base: usize) -> Vec<PlotSpec> {
    let mut plots = Vec::new();
    for (j, key) in shadow.parameters().iter().enumerate() {
        plots.push(PlotSpec {
            tab: PlotTab::Watch,
            name: format!("{key} (SI)"),
            unit: Unit::Dimensionless,
            series: vec![
                series(format!("{key} estimate"), SeriesRole::True, base + 3 * j),
                series(
                    format!("{key} 95 % low"),
                    SeriesRole::Other,
                    base + 3 * j + 1,
                ),
                series(
                    format!("{key} 95 % high"),
                    SeriesRole::Other,
                    base + 3 * j + 2,
                ),
            ],
        });
    }
    plots
}

impl ShadowRecording {
    /// Starts the recording of `shadow` at `path`; `id` names the run (the same inputs give the
    /// same id, and the same bytes).
    pub fn create(
        path: &Path,
        shadow: &Shadow,
        id: &str,
        live: Option<LiveViewer>,
    ) -> Result<Self, ShadowError> {
        let links = shadow.links();
        // Where the measured joint positions put the mechanism, drawn as bodies beside the
        // estimate's links, when the watched signals place it.
        let measured = match shadow.measurements_place_the_mechanism() {
            true => (links.iter())
                .map(|(name, shapes)| (format!("measured_{name}"), grey(shapes)))
                .collect(),
            false => Vec::new(),
        };
        let mut scene = shadow.scene();
        scene.title = match measured.is_empty() {
            true => format!("{} as the shadow estimates it", scene.title),
            false => format!(
                "{} as the shadow estimates it (grey: where the measured joint positions put it)",
                scene.title
            ),
        };
        let layout = RecordingLayout {
            app: format!("{}-shadow", shadow.scenario_name()),
            recording_id: id.to_string(),
            plots: plots(shadow),
            live,
            links,
            bodies: measured,
            unlabelled_bodies: true,
            scene: Some(scene),
            ..RecordingLayout::default()
        };
        let w = shadow.watched().len();
        let p = shadow.parameters().len();
        Ok(Self {
            recorder: Recorder::create(path, &layout)?,
            values: vec![f64::NAN; alarm_index(w, p) + 1],
            steps: 0,
            watched: w,
            knobs: p,
            poses: Vec::new(),
            ghost: !layout.bodies.is_empty(),
            open: false,
        })
    }

    /// Records one processed step, and its anomaly change as an event.
    pub fn push(&mut self, step: &ShadowStep) -> Result<(), ShadowError> {
        let w = self.watched;
        self.values.fill(f64::NAN);
        for (&(s, value), (residual, variance)) in step.measured.iter().zip(
            step.innovation
                .residual
                .iter()
                .zip(&step.innovation.variance),
        ) {
            self.values[s] = value;
            self.values[2 * w + s] = *residual;
            self.values[3 * w + s] = residual / variance.sqrt();
        }
        self.values[w..2 * w].copy_from_slice(&step.estimate);
        if !step.learning {
            self.values[4 * w..5 * w].copy_from_slice(&step.detector.cusum);
            self.values[5 * w] = step.detector.nis;
            self.values[5 * w + 1..5 * w + 1 + self.knobs].copy_from_slice(&step.detector.drift);
        }
        let base = 5 * w + 1 + self.knobs;
        for (j, (estimate, sigma)) in step.parameters.iter().enumerate() {
            let at = base + 3 * j;
            self.values[at] = *estimate;
            self.values[at + 1] = estimate - 1.96 * sigma;
            self.values[at + 2] = estimate + 1.96 * sigma;
        }
        self.open = match &step.change {
            Some(AnomalyChange::Opened(_)) => true,
            Some(AnomalyChange::Closed(_)) => false,
            None => self.open,
        };
        self.values[alarm_index(w, self.knobs)] = f64::from(u8::from(self.open));
        self.place(step);
        self.recorder
            .push(self.steps, step.time, &self.poses, &self.values, &[])?;
        if let Some(change) = &step.change {
            let (level, text) = describe(change);
            self.recorder.event(self.steps, step.time, level, &text)?;
        }
        self.steps += 1;
        Ok(())
    }

    /// The poses to draw: the estimate's, and the measured ones (held until the next step
    /// that has them; the estimate's until the first).
    fn place(&mut self, step: &ShadowStep) {
        let links = step.poses.len();
        if self.poses.is_empty() {
            self.poses = step.poses.clone();
            if self.ghost {
                self.poses.extend_from_slice(&step.poses);
            }
        }
        self.poses[..links].copy_from_slice(&step.poses);
        if let (true, Some(measured)) = (self.ghost, &step.measured_poses) {
            self.poses[links..].copy_from_slice(measured);
        }
    }

    /// Logs a line (a connection lost or restored) at `time`.
    pub fn note(&mut self, time: f64, level: EventLevel, text: &str) -> Result<(), ShadowError> {
        Ok(self.recorder.event(self.steps, time, level, text)?)
    }

    /// Adds the summary text and completes the file.
    pub fn finish(mut self, summary: &str) -> Result<(), ShadowError> {
        self.recorder.summary(summary)?;
        self.recorder.finish()?;
        Ok(())
    }
}

/// `shapes` without their own colours: drawn in the bodies' neutral grey.
fn grey(shapes: &[Shape]) -> Vec<Shape> {
    let mut shapes = shapes.to_vec();
    for shape in &mut shapes {
        shape.color = None;
    }
    shapes
}

/// An anomaly change as a log line.
pub fn describe(change: &AnomalyChange) -> (EventLevel, String) {
    let (verb, anomaly) = match change {
        AnomalyChange::Opened(a) => ("detected", a),
        AnomalyChange::Closed(a) => ("ended", a),
    };
    // Until it ends, the explanation is the parameter moving most so far; when it ends, the
    // one the anomaly is put on (the summary's and the JSON's).
    let (explained, unexplained) = match change {
        AnomalyChange::Opened(_) => (
            "so far explained by",
            "no tracked parameter explains it yet",
        ),
        AnomalyChange::Closed(_) => ("explained by", "no tracked parameter explains it"),
    };
    let cause = anomaly.attribution.as_ref().map_or_else(
        || unexplained.to_string(),
        |a| {
            format!(
                "{explained} {}: {:.6} → {:.6} (95 % {:.6} … {:.6}, {:+.1} σ)",
                a.parameter, a.before, a.estimate, a.interval[0], a.interval[1], a.shift_sigmas
            )
        },
    );
    let level = match change {
        AnomalyChange::Opened(_) => EventLevel::Warning,
        AnomalyChange::Closed(_) => EventLevel::Info,
    };
    let text = format!(
        "anomaly {verb}: {} from t = {:.3} s, size {:.1} σ; {cause}",
        anomaly.signals.join(", "),
        anomaly.start,
        anomaly.size
    );
    (level, text)
}
