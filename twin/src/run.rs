//! `Twin::run`, the one door in. Data flows one way each step:
//! world → state → machine signals → sensors → controller → efforts (clipped) → world,
//! with the recording watching from the side.

use crate::energy::mechanical_energy;
use crate::machines::{self, Machine, MachineError};
use crate::mechanism::{JointMotion, Mechanism};
use crate::physics::{Load, MechanismState, Physics, SolverSettings};
use crate::recording::{
    EventLevel, LiveViewer, Recorder, RecordingError, RecordingLayout, SeriesGroup,
};
use crate::scenario::{LoadedScenario, ScenarioError};
use crate::sensors::{Noise, Sensor};
use crate::urdf::{self, UrdfError};
use controllers::{
    Actuator, Controller, ControllerError, EffortKind, Measurement, PlantInterface, Registry,
};
use std::path::Path;
use std::time::Instant;
use thiserror::Error;

/// Everything that stops a run before it starts.
#[derive(Debug, Error)]
pub enum TwinError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error(transparent)]
    Urdf(#[from] UrdfError),
    /// A machine's checks cover the scenario's `[process]` table and the URDF's geometry: both
    /// files are named.
    #[error("{scenario} (URDF {urdf}): {source}")]
    Machine {
        scenario: String,
        urdf: String,
        source: MachineError,
    },
    /// A controller's parameters are the scenario's; its plant check also concerns the URDF.
    #[error("{context}: {source}")]
    Controller {
        context: String,
        source: ControllerError,
    },
    #[error("{source_name}: sensors.\"{signal}\": no such measured signal (known: {known})")]
    UnknownSensor {
        source_name: String,
        signal: String,
        known: String,
    },
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

/// Why a run stopped early: the first signal that left its bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    pub step: usize,
    pub time: f64,
    pub signal: String,
    pub value: f64,
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "run diverged at step {} (t = {:.6} s): {} = {}",
            self.step, self.time, self.signal, self.value
        )
    }
}

/// A run stopped on request (SIGINT/SIGTERM in the CLI) before its end.
#[derive(Debug, Clone, PartialEq)]
pub struct Interruption {
    /// The signal number that asked for the stop (2: SIGINT, 15: SIGTERM).
    pub signal: usize,
    /// The last step simulated and recorded, and its time, s.
    pub step: usize,
    pub time: f64,
}

impl std::fmt::Display for Interruption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self.signal {
            2 => "SIGINT".to_string(),
            15 => "SIGTERM".to_string(),
            other => format!("signal {other}"),
        };
        write!(
            f,
            "interrupted by {name} at step {} (t = {:.6} s)",
            self.step, self.time
        )
    }
}

/// A flag a run polls once per step: 0 goes on, any other value (a signal number) stops it.
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicUsize>;

/// What a run reports.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    pub scenario: String,
    pub controller: String,
    pub dt: f64,
    pub steps: usize,
    pub wall_s: f64,
    pub steps_per_s: f64,
    pub metrics: Vec<(String, f64)>,
    pub failure: Option<Divergence>,
    /// Set when the run was stopped on request before its end.
    pub interrupted: Option<Interruption>,
    /// What went wrong beside the run without failing it (a live viewer that did not take it).
    pub warnings: Vec<String>,
    /// FNV-1a digest of every recorded sample's bits: equal digests, identical series.
    pub series_digest: u64,
}

impl RunSummary {
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }
}

/// A scenario bound to its mechanism, machine and controller, ready to run.
pub struct Twin {
    loaded: LoadedScenario,
    mechanism: Mechanism,
    machine: Box<dyn Machine>,
    controller: Box<dyn Controller>,
    plant: PlantInterface,
    /// Per plant signal: its sensor, if the scenario gives one.
    sensors: Vec<Option<Sensor>>,
    /// Tree joint index of each actuator on a joint; the machine's own actuators follow them.
    actuated: Vec<usize>,
    /// Tree joints with a coordinate (not fixed).
    movable: Vec<usize>,
    /// A viewer to stream the run to, besides the recording file.
    live: Option<LiveViewer>,
    /// Movable joints the controller measures (the machine may hide some, e.g. a planar base).
    sensed: Vec<usize>,
    /// Polled every step; see [`Twin::with_stop_flag`].
    stop: Option<StopFlag>,
}

impl Twin {
    /// Builds the twin with a controller from `registry` (the scenario names it).
    pub fn new(loaded: LoadedScenario, registry: &Registry) -> Result<Self, TwinError> {
        let spec = &loaded.scenario.controller;
        let controller =
            registry
                .build(&spec.name, &spec.params)
                .map_err(|source| TwinError::Controller {
                    context: loaded.source.clone(),
                    source,
                })?;
        Self::with_controller(loaded, controller)
    }

    /// Builds the twin around a controller the caller made (a user's own, for example).
    pub fn with_controller(
        loaded: LoadedScenario,
        mut controller: Box<dyn Controller>,
    ) -> Result<Self, TwinError> {
        let scenario = &loaded.scenario;
        let mechanism = urdf::load_str(&loaded.urdf_text, &loaded.urdf_source)?;
        let machine = machines::build(
            &scenario.machine,
            &mechanism,
            &scenario.process,
            scenario.reference,
        )
        .map_err(|source| TwinError::Machine {
            scenario: loaded.source.clone(),
            urdf: loaded.urdf_source.clone(),
            source,
        })?;
        let movable: Vec<usize> = (0..mechanism.joints.len())
            .filter(|&j| mechanism.joints[j].motion.is_movable())
            .collect();
        let actuated = mechanism.actuated_joints();
        let hidden = machine.unmeasured_joints();
        let sensed: Vec<usize> = movable
            .iter()
            .copied()
            .filter(|&j| !hidden.contains(&mechanism.joints[j].name))
            .collect();

        let mut signals = Vec::new();
        for &j in &sensed {
            signals.push(format!("{}.position", mechanism.joints[j].name));
            signals.push(format!("{}.velocity", mechanism.joints[j].name));
        }
        signals.extend(machine.signal_names());
        if scenario.reference.is_some() {
            signals.extend(
                ["reference", "reference_rate", "reference_acceleration"].map(String::from),
            );
        }
        let mut actuators = joint_actuators(&mechanism, &actuated);
        actuators.extend(machine.extra_actuators());
        let plant = PlantInterface {
            machine: scenario.machine.clone(),
            signals,
            actuators,
        };

        let mut sensors: Vec<Option<Sensor>> = vec![None; plant.signals.len()];
        for (name, spec) in &scenario.sensors {
            let index = plant
                .signals
                .iter()
                .position(|s| s == name)
                .ok_or_else(|| TwinError::UnknownSensor {
                    source_name: loaded.source.clone(),
                    signal: name.clone(),
                    known: plant.signals.join(", "),
                })?;
            sensors[index] = Some(Sensor::new(*spec, scenario.control_period()));
        }
        controller
            .reset(&plant)
            .map_err(|source| TwinError::Controller {
                context: format!("{} (URDF {})", loaded.source, loaded.urdf_source),
                source,
            })?;
        Ok(Self {
            loaded,
            mechanism,
            machine,
            controller,
            plant,
            sensors,
            actuated,
            movable,
            sensed,
            live: None,
            stop: None,
        })
    }

    /// Streams the recorded run to a live viewer too (`twin run --connect URL | --spawn`).
    pub fn with_live_viewer(mut self, live: LiveViewer) -> Self {
        self.live = Some(live);
        self
    }

    /// Stops the run at the next step once `flag` holds a non-zero value (the CLI stores the
    /// signal number there): the recording is finished and the summary says where it stopped.
    pub fn with_stop_flag(mut self, flag: StopFlag) -> Self {
        self.stop = Some(flag);
        self
    }

    /// Runs the scenario; with `recording`, writes the .rrd there (atomically: a partial file
    /// is renamed into place only once closed). A diverging run stops early and says so in the
    /// summary; its recording is kept, up to and including the failure.
    pub fn run(mut self, recording: Option<&Path>) -> Result<RunSummary, TwinError> {
        let scenario = self.loaded.scenario.clone();
        let dt = scenario.dt;
        let steps = scenario.steps();
        let control_every = scenario.control_every();
        let control_period = scenario.control_period();
        let mut physics = Physics::new(
            &self.mechanism,
            SolverSettings {
                dt,
                gravity: scenario.gravity,
                substeps: scenario.substeps,
            },
        );

        let machine_names = self.machine.signal_names();
        let mut diagnostic_names = self.machine.diagnostic_names();
        diagnostic_names.extend(
            self.mechanism
                .loops
                .iter()
                .map(|l| format!("loop_gap/{}", l.name)),
        );
        diagnostic_names.push("mechanical_energy".into());
        let internal_names = self.controller.internal_names();
        let actuator_names: Vec<String> = self
            .plant
            .actuators
            .iter()
            .map(|a| a.joint.clone())
            .collect();
        let movable_names: Vec<String> = self
            .movable
            .iter()
            .map(|&j| self.mechanism.joints[j].name.clone())
            .collect();

        let mut recorder = match recording {
            None => None,
            Some(path) => Some(Recorder::create(
                path,
                &RecordingLayout {
                    app: scenario.name.clone(),
                    live: self.live.clone(),
                    scenario_toml: self.loaded.toml.clone(),
                    links: self
                        .mechanism
                        .links
                        .iter()
                        .map(|l| (l.name.clone(), l.visuals.clone()))
                        .collect(),
                    series: vec![
                        group("joints/position", &movable_names),
                        group("joints/velocity", &movable_names),
                        group("effort/commanded", &actuator_names),
                        group("effort/applied", &actuator_names),
                        group("task", &machine_names),
                        group("measurement", &self.plant.signals),
                        group("controller", &internal_names),
                        group("diagnostics", &diagnostic_names),
                    ],
                },
            )?),
        };

        let signal_count = self.plant.signals.len();
        let joint_signal_count = 2 * self.sensed.len();
        let mut state = MechanismState::default();
        let mut true_signals = vec![0.0; signal_count];
        let mut measured = vec![0.0; signal_count];
        let mut diagnostics = vec![0.0; diagnostic_names.len()];
        let mut internals = vec![0.0; internal_names.len()];
        let actuator_count = self.plant.actuators.len();
        let mut commanded = vec![0.0; actuator_count];
        let mut limited = vec![0.0; actuator_count];
        let mut applied = vec![0.0; actuator_count];
        let mut saturated = vec![false; actuator_count];
        let mut joint_efforts = vec![0.0; self.mechanism.joints.len()];
        let mut loads: Vec<Load> = Vec::new();
        let mut controller_events: Vec<String> = Vec::new();
        let mut events: Vec<(EventLevel, String)> = Vec::new();
        let mut values: Vec<f64> = Vec::new();
        let mut noise = Noise::new(scenario.seed);
        let mut stats = RunStats::new(actuator_count);
        let mut failure = None;
        let mut interrupted = None;
        let mut digest = Digest::default();

        let started = Instant::now();
        let mut step = 0;
        physics.read_state(&mut state);
        let energy_start = mechanical_energy(&self.mechanism, &state, scenario.gravity);
        while step <= steps {
            let time = step as f64 * dt;
            for (k, &j) in self.sensed.iter().enumerate() {
                true_signals[2 * k] = state.joint_positions[j];
                true_signals[2 * k + 1] = state.joint_velocities[j];
            }
            let machine_count = machine_names.len();
            let machine_diagnostic_count = diagnostics.len() - 1 - self.mechanism.loops.len();
            let (machine_diagnostics, rest) = diagnostics.split_at_mut(machine_diagnostic_count);
            self.machine.measure(
                time,
                &state,
                &mut true_signals[joint_signal_count..joint_signal_count + machine_count],
                machine_diagnostics,
            );
            let (gaps, energy) = rest.split_at_mut(self.mechanism.loops.len());
            gaps.copy_from_slice(&state.loop_gaps);
            energy[0] = mechanical_energy(&self.mechanism, &state, scenario.gravity);
            if let Some(reference) = &scenario.reference {
                let sample = reference.sample(time);
                true_signals[signal_count - 3..].copy_from_slice(&[
                    sample.position,
                    sample.rate,
                    sample.acceleration,
                ]);
            }

            failure = self.check_health(step, time, &state, &true_signals);
            if let Some(signal) = self.stop_requested() {
                interrupted.get_or_insert(Interruption { signal, step, time });
            }
            if step % control_every == 0 && failure.is_none() {
                for (i, sensor) in self.sensors.iter_mut().enumerate() {
                    measured[i] = match sensor {
                        Some(sensor) => sensor.read(true_signals[i], &mut noise),
                        None => true_signals[i],
                    };
                }
                commanded.fill(0.0);
                self.controller.update(
                    &Measurement {
                        time,
                        signals: &measured,
                    },
                    control_period,
                    &mut commanded,
                );
                self.controller.internal_values(&mut internals);
                self.controller.drain_events(&mut controller_events);
                events.extend(controller_events.drain(..).map(|text| {
                    // The controller convention: warnings start with "warning".
                    let level = if text.starts_with("warning") {
                        EventLevel::Warning
                    } else {
                        EventLevel::Info
                    };
                    (level, text)
                }));
                for (a, actuator) in self.plant.actuators.iter().enumerate() {
                    if !commanded[a].is_finite() {
                        failure.get_or_insert(Divergence {
                            step,
                            time,
                            signal: format!("effort/commanded/{}", actuator.joint),
                            value: commanded[a],
                        });
                        continue;
                    }
                    limited[a] = commanded[a].clamp(-actuator.effort_limit, actuator.effort_limit);
                    let now_saturated = limited[a] != commanded[a];
                    if now_saturated != saturated[a] {
                        events.push(if now_saturated {
                            let text = format!(
                                "{} effort saturated at {:+} (commanded {:+.3})",
                                actuator.joint, limited[a], commanded[a]
                            );
                            (EventLevel::Warning, text)
                        } else {
                            let text = format!("{} effort back within its limit", actuator.joint);
                            (EventLevel::Info, text)
                        });
                        saturated[a] = now_saturated;
                    }
                }
            }
            self.machine.drive(dt, &limited, &mut applied);
            stats.observe(&applied, &saturated, &state, energy[0] - energy_start);

            let stopped = failure.is_some() || interrupted.is_some();
            let sampled = step % scenario.recording.every == 0 || stopped;
            // A failed write (a full disk) ends the run here; the partial file is removed.
            if let Some(recorder) = recorder.as_mut() {
                for (level, text) in events.drain(..) {
                    recorder.event(step_index(step), time, level, &text)?;
                }
                if let Some(failure) = &failure {
                    recorder.event(
                        step_index(step),
                        time,
                        EventLevel::Error,
                        &failure.to_string(),
                    )?;
                }
                if let Some(interrupted) = &interrupted {
                    let text = interrupted.to_string();
                    recorder.event(step_index(step), time, EventLevel::Warning, &text)?;
                }
                if sampled {
                    values.clear();
                    values.extend(self.movable.iter().map(|&j| state.joint_positions[j]));
                    values.extend(self.movable.iter().map(|&j| state.joint_velocities[j]));
                    values.extend_from_slice(&commanded);
                    values.extend_from_slice(&applied);
                    values.extend_from_slice(
                        &true_signals[joint_signal_count..joint_signal_count + machine_count],
                    );
                    values.extend_from_slice(&measured);
                    values.extend_from_slice(&internals);
                    values.extend_from_slice(&diagnostics);
                    recorder.push(step_index(step), time, &state.link_poses, &values)?;
                }
            } else {
                events.clear();
            }
            if sampled {
                digest.add(time);
                digest.add_all(&true_signals);
                digest.add_all(&measured);
                digest.add_all(&commanded);
                digest.add_all(&applied);
                digest.add_all(&internals);
                digest.add_all(&diagnostics);
            }
            if stopped || step == steps {
                break;
            }

            joint_efforts.fill(0.0);
            for (a, &j) in self.actuated.iter().enumerate() {
                joint_efforts[j] = applied[a];
            }
            loads.clear();
            self.machine.loads(time, &state, &mut loads);
            physics.step(&joint_efforts, &loads);
            physics.read_state(&mut state);
            step += 1;
        }
        let wall_s = started.elapsed().as_secs_f64();
        let mut warnings = Vec::new();
        if let Some(recorder) = recorder {
            warnings.extend(recorder.finish()?.live_warning);
        }

        let mut metrics = self.machine.metrics();
        metrics.extend(stats.metrics(&self.plant.actuators, &self.mechanism));
        // The controller's estimates at the end (e.g. an odometry pose), by their internal names.
        metrics.extend(
            internal_names
                .iter()
                .zip(&internals)
                .map(|(name, value)| (format!("controller_final/{name}"), *value)),
        );
        Ok(RunSummary {
            scenario: scenario.name.clone(),
            controller: self.controller.name().to_string(),
            dt,
            steps: step,
            wall_s,
            steps_per_s: step as f64 / wall_s.max(1e-12),
            metrics,
            failure,
            interrupted,
            warnings,
            series_digest: digest.0,
        })
    }

    fn stop_requested(&self) -> Option<usize> {
        let signal = self
            .stop
            .as_ref()?
            .load(std::sync::atomic::Ordering::Relaxed);
        (signal != 0).then_some(signal)
    }

    fn check_health(
        &self,
        step: usize,
        time: f64,
        state: &MechanismState,
        signals: &[f64],
    ) -> Option<Divergence> {
        let limits = &self.loaded.scenario.health;
        let diverged = |signal: String, value: f64| {
            Some(Divergence {
                step,
                time,
                signal,
                value,
            })
        };
        for (j, joint) in self.mechanism.joints.iter().enumerate() {
            let (q, v) = (state.joint_positions[j], state.joint_velocities[j]);
            if !q.is_finite() {
                return diverged(format!("{}.position", joint.name), q);
            }
            if !v.is_finite() || v.abs() > limits.max_joint_speed {
                return diverged(format!("{}.velocity", joint.name), v);
            }
        }
        for (l, gap) in state.loop_gaps.iter().enumerate() {
            if !gap.is_finite() || *gap > limits.max_loop_gap {
                return diverged(format!("loop_gap/{}", self.mechanism.loops[l].name), *gap);
            }
        }
        for (name, value) in self.plant.signals.iter().zip(signals) {
            if !value.is_finite() {
                return diverged(name.clone(), *value);
            }
        }
        None
    }
}

/// 64-bit FNV-1a over the bit patterns of f64 values.
struct Digest(u64);

impl Default for Digest {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    fn add(&mut self, value: f64) {
        for byte in value.to_bits().to_le_bytes() {
            self.0 = (self.0 ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn add_all(&mut self, values: &[f64]) {
        for &value in values {
            self.add(value);
        }
    }
}

/// An actuator per actuated tree joint: a force on a prismatic joint, else a torque.
fn joint_actuators(mechanism: &Mechanism, actuated: &[usize]) -> Vec<Actuator> {
    actuated
        .iter()
        .map(|&j| {
            let joint = &mechanism.joints[j];
            Actuator {
                joint: joint.name.clone(),
                kind: match joint.motion {
                    JointMotion::Prismatic { .. } => EffortKind::Force,
                    _ => EffortKind::Torque,
                },
                effort_limit: joint.effort_limit.unwrap_or(f64::INFINITY),
            }
        })
        .collect()
}

/// The recording's step index (the run's step counts stay far below i64's range).
fn step_index(step: usize) -> i64 {
    i64::try_from(step).unwrap_or(i64::MAX)
}

fn group(path: &str, names: &[String]) -> SeriesGroup {
    SeriesGroup {
        path: path.into(),
        names: names.to_vec(),
    }
}

/// Running figures every machine gets: effort peaks and saturation, loop closure, energy drift.
struct RunStats {
    samples: usize,
    peak_effort: Vec<f64>,
    saturated_samples: Vec<usize>,
    loop_gap_max: f64,
    energy_drift_max: f64,
}

impl RunStats {
    fn new(actuators: usize) -> Self {
        Self {
            samples: 0,
            peak_effort: vec![0.0; actuators],
            saturated_samples: vec![0; actuators],
            loop_gap_max: 0.0,
            energy_drift_max: 0.0,
        }
    }

    fn observe(
        &mut self,
        applied: &[f64],
        saturated: &[bool],
        state: &MechanismState,
        energy_drift: f64,
    ) {
        self.samples += 1;
        for (a, effort) in applied.iter().enumerate() {
            self.peak_effort[a] = self.peak_effort[a].max(effort.abs());
            self.saturated_samples[a] += usize::from(saturated[a]);
        }
        for gap in &state.loop_gaps {
            self.loop_gap_max = self.loop_gap_max.max(*gap);
        }
        self.energy_drift_max = self.energy_drift_max.max(energy_drift.abs());
    }

    fn metrics(&self, actuators: &[Actuator], mechanism: &Mechanism) -> Vec<(String, f64)> {
        let mut metrics = Vec::new();
        for (a, actuator) in actuators.iter().enumerate() {
            metrics.push((
                format!("peak_effort/{}", actuator.joint),
                self.peak_effort[a],
            ));
            metrics.push((
                format!("saturated_fraction/{}", actuator.joint),
                self.saturated_samples[a] as f64 / self.samples.max(1) as f64,
            ));
        }
        if !mechanism.loops.is_empty() {
            metrics.push(("loop_closure_error_max".into(), self.loop_gap_max));
        }
        metrics.push(("mechanical_energy_drift_max".into(), self.energy_drift_max));
        metrics
    }
}
