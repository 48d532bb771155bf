//! The recording as one observer among others: every `recording.every`-th step and the last one
//! to the `.rrd` file, every event as it happens, the run's start and end as events and its
//! summary as a text document.
//!
//! What is plotted with what follows the signals' specs ([`framework::SignalSpec`]): every
//! value naming the same plot in the same unit is drawn on it, whatever produced it, so that a
//! reference or a command meets what it commands.

use super::layout::SignalLayout;
use super::observer::{Findings, Observer, ObserverError, StepView};
use super::spectra::{Spectra, SpectraPlan};
use super::summary::RunSummary;
use crate::mechanism::{Pose2, Shape};
use crate::physics::Collision;
use crate::recording::{
    BackgroundRecorder, ColumnRole, LiveViewer, PlotSpec, PlotTab, Recorder, RecordingLayout,
    SeriesColumn, SeriesRole, SeriesSpec,
};
use crate::scene::Scene;
use framework::{EventLevel, SignalSpec, Unit};
use std::path::PathBuf;

/// Records a run to a file (and a live viewer, if any).
pub struct RecordingObserver {
    path: PathBuf,
    /// The layout without the plots, which come with the run's [`SignalLayout`].
    layout: RecordingLayout,
    /// Per plant signal: whether a sensor makes its measurement differ from its true value.
    sensed: Vec<bool>,
    /// Per plant signal: whether its measurement is its true value at each control update (no
    /// sensor, no sensor fault).
    plain: Vec<bool>,
    /// The run's first event: scenario, controller, parameters digest.
    start_text: String,
    /// The file's writer, on a thread of its own.
    recorder: Option<BackgroundRecorder>,
    /// Per scene marker: where its x and y come from in `values`.
    marker_sources: Vec<MarkerValues>,
    values: Vec<f64>,
    markers: Vec<[f64; 2]>,
    /// The links' poses, then the bodies'.
    poses: Vec<Pose2>,
    /// Every crash so far: where, and the pair.
    collisions: Vec<([f64; 2], String)>,
    last_step: usize,
    last_time: f64,
    /// The run's spectra and lobe diagram, drawn at its end.
    spectra: Spectra,
}

/// A marker's position from the recorded values: `origin + scale·(x, y)`.
#[derive(Debug, Clone, Copy)]
struct MarkerValues {
    x: Option<usize>,
    y: Option<usize>,
    scale: f64,
    origin: [f64; 2],
}

/// What the recording is made of, besides the run's layout.
pub struct RecordingParts {
    pub path: PathBuf,
    pub app: String,
    /// Follows from the run's inputs, so that the same inputs write the same bytes.
    pub recording_id: String,
    pub scenario_toml: String,
    pub links: Vec<(String, Vec<Shape>)>,
    /// The scenario's bodies: name and shapes in the body's frame.
    pub bodies: Vec<(String, Vec<Shape>)>,
    pub scene: Scene,
    pub sensed: Vec<bool>,
    pub plain: Vec<bool>,
    pub start_text: String,
    pub live: Option<LiveViewer>,
    pub spectra: SpectraPlan,
}

impl RecordingObserver {
    pub fn new(parts: RecordingParts) -> Self {
        Self {
            path: parts.path,
            layout: RecordingLayout {
                app: parts.app,
                recording_id: parts.recording_id,
                scenario_toml: parts.scenario_toml,
                links: parts.links,
                bodies: parts.bodies,
                unlabelled_bodies: false,
                scene: Some(parts.scene),
                plots: Vec::new(),
                figures: Vec::new(),
                live: parts.live,
            },
            sensed: parts.sensed,
            plain: parts.plain,
            start_text: parts.start_text,
            recorder: None,
            marker_sources: Vec::new(),
            values: Vec::new(),
            markers: Vec::new(),
            poses: Vec::new(),
            collisions: Vec::new(),
            last_step: 0,
            last_time: 0.0,
            spectra: Spectra::new(parts.spectra),
        }
    }

    /// Ends the recording with the run's outcome: an event with its status and headline figures,
    /// and the summary as a text document; then completes the file.
    pub fn finish_with(&mut self, summary: &RunSummary) -> Result<Findings, ObserverError> {
        if let Some(recorder) = self.recorder.as_mut() {
            let (level, text) = end_event(summary);
            let step = step_index(self.last_step);
            recorder.event(step, self.last_time, level, &text)?;
            recorder.summary(&summary_markdown(summary))?;
            for (name, plot) in self.spectra.figures() {
                recorder.figure(&name, &plot)?;
            }
        }
        self.finish()
    }
}

/// Values are laid out as: joint positions, joint velocities, commanded efforts, applied efforts,
/// the plant's true signals, their measurements, the controller's internals, the diagnostics.
struct Offsets {
    velocities: usize,
    commanded: usize,
    applied: usize,
    signals: usize,
    measured: usize,
    internals: usize,
    diagnostics: usize,
}

impl Offsets {
    fn of(layout: &SignalLayout) -> Self {
        let joints = layout.joints.len();
        let velocities = joints;
        let commanded = velocities + joints;
        let applied = commanded + layout.actuators.len();
        let signals = applied + layout.actuators.len();
        let measured = signals + layout.signals.len();
        let internals = measured + layout.signals.len();
        let diagnostics = internals + layout.internals.len();
        Self {
            velocities,
            commanded,
            applied,
            signals,
            measured,
            internals,
            diagnostics,
        }
    }
}

/// Where a series comes from, which decides its plot's tab.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    Joint,
    Effort,
    Machine,
    Reference,
    Measured,
    Internal,
    Diagnostic,
}

/// The plots, in order of first appearance, each gathering the series of one name and unit.
#[derive(Default)]
struct PlotPlan {
    plots: Vec<(PlotSpec, Vec<Source>)>,
}

impl PlotPlan {
    fn add(
        &mut self,
        spec: &SignalSpec,
        name: &str,
        role: SeriesRole,
        source: Source,
        value: usize,
    ) {
        let index = match self
            .plots
            .iter()
            .position(|(plot, _)| plot.name == spec.plot && plot.unit == spec.unit)
        {
            Some(index) => index,
            None => {
                self.plots.push((
                    PlotSpec {
                        tab: PlotTab::Process,
                        name: spec.plot.clone(),
                        unit: spec.unit,
                        series: Vec::new(),
                    },
                    Vec::new(),
                ));
                self.plots.len() - 1
            }
        };
        let (plot, sources) = &mut self.plots[index];
        let name = if plot.series.iter().any(|s| s.name == name) {
            format!("{name} ({})", source_label(source))
        } else {
            name.to_owned()
        };
        plot.series.push(SeriesSpec {
            name,
            role,
            value,
            column: None,
        });
        sources.push(source);
    }

    /// The plots with their tabs: an effort's plot is on `efforts`; a reference or controller
    /// value drawn with a simulated or measured one is `tracking`; otherwise the tab of the
    /// plot's first series.
    fn finish(self) -> Vec<PlotSpec> {
        self.plots
            .into_iter()
            .map(|(mut plot, sources)| {
                let has = |wanted: &[Source]| sources.iter().any(|s| wanted.contains(s));
                plot.tab = if has(&[Source::Effort]) {
                    PlotTab::Efforts
                } else if has(&[Source::Reference, Source::Internal])
                    && has(&[
                        Source::Machine,
                        Source::Joint,
                        Source::Measured,
                        Source::Diagnostic,
                    ])
                {
                    PlotTab::Tracking
                } else {
                    match sources[0] {
                        Source::Joint => PlotTab::Joints,
                        Source::Internal => PlotTab::Controller,
                        Source::Diagnostic => PlotTab::Diagnostics,
                        _ => PlotTab::Process,
                    }
                };
                plot
            })
            .collect()
    }
}

fn source_label(source: Source) -> &'static str {
    match source {
        Source::Joint => "joint",
        Source::Effort => "effort",
        Source::Machine => "machine",
        Source::Reference => "scenario",
        Source::Measured => "measured",
        Source::Internal => "controller",
        Source::Diagnostic => "check",
    }
}

/// What an effort in `unit` is called on its plot.
fn effort_quantity(unit: Unit) -> &'static str {
    match unit {
        Unit::Ampere => "current",
        Unit::NewtonMetre => "torque",
        Unit::Newton => "force",
        _ => "effort",
    }
}

/// The plots of a run: the plant's signals (and their measurements where a sensor changes
/// them) and the reference, the joints, the efforts (per actuator, commanded with applied), the
/// controller's internals and the diagnostics; each series marked with the run's column it
/// carries (`plain`: per plant signal, whether its measurement is its true value).
pub(super) fn plan(layout: &SignalLayout, sensed: &[bool], plain: &[bool]) -> Vec<PlotSpec> {
    let at = Offsets::of(layout);
    let mut plan = PlotPlan::default();
    plan_plant_signals(&mut plan, layout, sensed, &at);
    plan_joints_and_efforts(&mut plan, layout, &at);
    let specs = &layout.specs;
    for (k, spec) in specs.internals.iter().enumerate() {
        let role = if spec.name == "reference" {
            SeriesRole::Reference
        } else if spec.name.contains("command") {
            SeriesRole::Commanded
        } else {
            SeriesRole::Other
        };
        plan.add(spec, &spec.name, role, Source::Internal, at.internals + k);
    }
    for (k, spec) in specs.diagnostics.iter().enumerate() {
        let value = at.diagnostics + k;
        plan.add(
            spec,
            &spec.name,
            SeriesRole::Other,
            Source::Diagnostic,
            value,
        );
    }
    let mut plots = plan.finish();
    for series in plots.iter_mut().flat_map(|plot| &mut plot.series) {
        series.column = run_column(series.value, layout, &at, plain);
    }
    plots
}

/// The run's column the value at `value` is, if any: a command, a plant signal's measurement, or
/// its true value (a joint's position and velocity are plant signals when the controller
/// measures the joint).
fn run_column(
    value: usize,
    layout: &SignalLayout,
    at: &Offsets,
    plain: &[bool],
) -> Option<SeriesColumn> {
    let column = |name: &str, roles: Vec<ColumnRole>| {
        Some(SeriesColumn {
            name: name.to_owned(),
            roles,
        })
    };
    let true_signal = |k: usize| {
        let roles = match plain.get(k) {
            Some(true) => vec![ColumnRole::True, ColumnRole::Measured],
            _ => vec![ColumnRole::True],
        };
        column(layout.signals.get(k)?, roles)
    };
    if value < at.commanded {
        let (joint, which) = match value.checked_sub(at.velocities) {
            Some(j) => (j, 1),
            None => (value, 0),
        };
        let spec = &layout.specs.joints.get(joint)?[which];
        layout.signal(&spec.name).and_then(true_signal)
    } else if value < at.applied {
        column(
            layout.actuators.get(value - at.commanded)?,
            vec![ColumnRole::Command],
        )
    } else if (at.signals..at.measured).contains(&value) {
        true_signal(value - at.signals)
    } else if (at.measured..at.internals).contains(&value) {
        let name = layout.signals.get(value - at.measured)?;
        column(name, vec![ColumnRole::Measured])
    } else {
        None
    }
}

/// The machine's signals and the reference, then the measurements a sensor changes. The joints'
/// plant signals are drawn from the joint state instead.
fn plan_plant_signals(plan: &mut PlotPlan, layout: &SignalLayout, sensed: &[bool], at: &Offsets) {
    let signals = &layout.specs.signals;
    let machine = layout.machine_signal_range();
    let reference = layout.reference_range();
    for (k, spec) in signals.iter().enumerate() {
        let value = at.signals + k;
        if machine.contains(&k) {
            plan.add(spec, &spec.name, SeriesRole::True, Source::Machine, value);
        } else if reference.contains(&k) {
            plan.add(
                spec,
                &spec.name,
                SeriesRole::Reference,
                Source::Reference,
                value,
            );
        }
    }
    for (k, spec) in signals.iter().enumerate() {
        if sensed.get(k).copied().unwrap_or(false) {
            let name = format!("{} measured", spec.name);
            let value = at.measured + k;
            plan.add(spec, &name, SeriesRole::Measured, Source::Measured, value);
        }
    }
}

/// Each joint's position and velocity; each actuator's commanded and applied effort, on one plot
/// when they are one quantity (an arm drive's current and torque are two).
fn plan_joints_and_efforts(plan: &mut PlotPlan, layout: &SignalLayout, at: &Offsets) {
    let specs = &layout.specs;
    for (j, [position, velocity]) in specs.joints.iter().enumerate() {
        plan.add(position, &position.name, SeriesRole::True, Source::Joint, j);
        let value = at.velocities + j;
        plan.add(
            velocity,
            &velocity.name,
            SeriesRole::True,
            Source::Joint,
            value,
        );
    }
    for (a, (joint, [commanded, applied])) in
        layout.actuators.iter().zip(&specs.efforts).enumerate()
    {
        let efforts = [
            (
                *commanded,
                SeriesRole::Commanded,
                "commanded",
                at.commanded + a,
            ),
            (*applied, SeriesRole::Applied, "applied", at.applied + a),
        ];
        for (unit, role, what, value) in efforts {
            let plot = format!("{joint} {}", effort_quantity(unit));
            let spec = SignalSpec::new(format!("{joint} {what}"), unit, plot);
            plan.add(&spec, &spec.name, role, Source::Effort, value);
        }
    }
}

/// Where each scene marker's coordinates are in the values; a marker naming a signal the run
/// does not have (a reference the scenario leaves out) is dropped from the scene.
fn bind_markers(scene: &mut Scene, layout: &SignalLayout) -> Vec<MarkerValues> {
    let at = Offsets::of(layout);
    let find = |name: &str| {
        layout
            .signal(name)
            .map(|k| at.signals + k)
            .or_else(|| layout.internal(name).map(|k| at.internals + k))
            .or_else(|| layout.diagnostic(name).map(|k| at.diagnostics + k))
    };
    let mut bound = Vec::with_capacity(scene.markers.len());
    scene.markers.retain(|marker| {
        let source = &marker.source;
        let x = source.x.as_deref().map(find);
        let y = source.y.as_deref().map(find);
        if x == Some(None) || y == Some(None) {
            return false;
        }
        bound.push(MarkerValues {
            x: x.flatten(),
            y: y.flatten(),
            scale: source.scale,
            origin: source.origin,
        });
        true
    });
    bound
}

/// The recording's step index (the run's step counts stay far below i64's range).
fn step_index(step: usize) -> i64 {
    i64::try_from(step).unwrap_or(i64::MAX)
}

/// The run's last event: how it ended and its first figures.
fn end_event(summary: &RunSummary) -> (EventLevel, String) {
    const HEADLINE: usize = 4;
    let (level, status) = match (&summary.failure, &summary.interrupted) {
        (Some(failure), _) => (EventLevel::Error, format!("run failed: {failure}")),
        (None, Some(stop)) => (EventLevel::Warning, format!("run stopped: {stop}")),
        (None, None) => (EventLevel::Info, "run ended: ok".to_owned()),
    };
    let figures: Vec<String> = summary
        .metrics
        .iter()
        .take(HEADLINE)
        .map(|(name, value)| format!("{name} = {value:.4e}"))
        .collect();
    let rest = summary.metrics.len().saturating_sub(HEADLINE);
    let more = if rest > 0 {
        format!("; {rest} more in the summary tab")
    } else {
        String::new()
    };
    (level, format!("{status}; {}{more}", figures.join(", ")))
}

/// The summary as Markdown: the table `twin run` prints, verbatim.
fn summary_markdown(summary: &RunSummary) -> String {
    format!(
        "# {}\n\n```\n{}```\n",
        summary.scenario,
        super::summary::recorded_table(summary)
    )
}

impl Observer for RecordingObserver {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.layout.plots = plan(layout, &self.sensed, &self.plain);
        self.layout.figures = self.spectra.start(layout)?;
        if let Some(scene) = self.layout.scene.as_mut() {
            self.marker_sources = bind_markers(scene, layout);
        }
        self.markers = vec![[f64::NAN; 2]; self.marker_sources.len()];
        let mut recorder = BackgroundRecorder::start(Recorder::create(&self.path, &self.layout)?)?;
        recorder.event(0, 0.0, EventLevel::Info, &self.start_text)?;
        self.recorder = Some(recorder);
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let Some(recorder) = self.recorder.as_mut() else {
            return Ok(());
        };
        self.spectra.observe(view)?;
        self.last_step = view.step;
        self.last_time = view.time;
        for event in view.events {
            recorder.event(step_index(view.step), view.time, event.level, &event.text)?;
        }
        if !view.collisions.is_empty() {
            let pair = |c: &Collision| (c.point, format!("{}/{}", c.a, c.b));
            self.collisions.extend(view.collisions.iter().map(pair));
            recorder.collisions(step_index(view.step), view.time, &self.collisions)?;
        }
        if view.sampled {
            let movable = view.layout.movable_joints();
            let values = &mut self.values;
            values.clear();
            values.extend(movable.iter().map(|&j| view.state.joint_positions[j]));
            values.extend(movable.iter().map(|&j| view.state.joint_velocities[j]));
            values.extend_from_slice(view.commanded);
            values.extend_from_slice(view.applied);
            values.extend_from_slice(view.signals);
            values.extend_from_slice(view.measured);
            values.extend_from_slice(view.internals);
            values.extend_from_slice(view.diagnostics);
            let value = |index: Option<usize>| index.map_or(0.0, |i| values[i]);
            for (position, source) in self.markers.iter_mut().zip(&self.marker_sources) {
                *position = [
                    source.origin[0] + source.scale * value(source.x),
                    source.origin[1] + source.scale * value(source.y),
                ];
            }
            self.poses.clear();
            self.poses.extend_from_slice(&view.state.link_poses);
            self.poses.extend_from_slice(view.bodies);
            recorder.push(
                step_index(view.step),
                view.time,
                &self.poses,
                values,
                &self.markers,
            )?;
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        let Some(recorder) = self.recorder.take() else {
            return Ok(Findings::default());
        };
        let outcome = recorder.finish()?;
        Ok(Findings {
            metrics: Vec::new(),
            warnings: outcome.live_warning.into_iter().collect(),
        })
    }
}
