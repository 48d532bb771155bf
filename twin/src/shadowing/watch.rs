//! The shadow itself: fed the machine's commands and measurements as they arrive, it keeps the
//! estimate, tests the innovations and says what changed ([`Shadow`]), with what one processed
//! measurement time gives ([`ShadowStep`]) and the account of an anomaly ([`Anomaly`]).

use super::anomaly::Anomaly;
use super::detector::{self, Detector};
use super::detector::{AnomalyChange, DetectorView};
use super::error::ShadowError;
use super::filter::Filter;
use super::filter::Innovation;
use super::intake::{Intake, IntakeCounts, Sample, SampleKind};
use super::options::ShadowOptions;
use crate::data::PlantColumns;
use crate::mechanism::{Pose2, Shape};
use crate::run::Twin;
use crate::scenario::LoadedScenario;
use crate::scene::Scene;

/// Longest span between two samples the model is propagated over, s; after a longer one the
/// state is taken up afresh from the next samples.
pub const MAX_GAP: f64 = 1.0;

/// What one processed measurement time gives.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowStep {
    /// Source time, s since the first sample.
    pub time: f64,
    /// The signals measured now (indices into [`Shadow::watched`]) and their values, SI.
    pub measured: Vec<(usize, f64)>,
    /// The innovations of those signals.
    pub innovation: Innovation,
    /// Every watched signal as the corrected estimate gives it, SI.
    pub estimate: Vec<f64>,
    /// Each tracked parameter's estimate and standard deviation.
    pub parameters: Vec<(f64, f64)>,
    /// The detector's statistics.
    pub detector: DetectorView,
    /// Whether the detector is still learning the healthy statistics.
    pub learning: bool,
    /// An anomaly opened or closed now.
    pub change: Option<AnomalyChange>,
    /// The links' poses at the corrected estimate.
    pub poses: Vec<Pose2>,
    /// The links' poses where the joint positions measured now put the mechanism, when they
    /// place it (every independent coordinate's position measured).
    pub measured_poses: Option<Vec<Pose2>>,
}

/// A twin watching a machine.
pub struct Shadow {
    filter: Filter,
    detector: Detector,
    intake: Intake,
    columns: PlantColumns,
    watched: Vec<String>,
    parameters: Vec<String>,
    /// Per actuator, the command in force and its time (s since the first sample).
    commands: Vec<f64>,
    command_times: Vec<f64>,
    /// A command came too late to be used: the state is taken up again at the next step.
    stale: bool,
    /// Whether a sample has been processed.
    started: bool,
    /// The filter's time, s since the first sample.
    time: f64,
    /// The first sample's source time, s.
    origin: Option<f64>,
    /// Seconds the intake holds samples behind the slowest live stream.
    latency: f64,
    scenario_name: String,
    /// The machine's control period, s (the scenario's, or its step).
    control_period: f64,
    /// Spans longer than [`MAX_GAP`] without a sample.
    gaps: u64,
}

impl Shadow {
    /// A shadow of `loaded`'s machine, at its initial state, watching `options.signals`.
    pub fn new(loaded: LoadedScenario, options: &ShadowOptions) -> Result<Self, ShadowError> {
        options.check()?;
        let parts = Twin::new(loaded)?.model_parts()?;
        let columns = PlantColumns::of_layout(&parts.layout);
        let watched = watched_signals(&parts.layout.signals, &options.signals)?;
        let scenario = parts.scenario.clone();
        let names: Vec<String> = options.signals.clone();
        let mut model = super::model::Model::new(parts, watched);
        check_predicted(&mut model, &names)?;
        let knobs = options
            .parameters
            .iter()
            .map(|p| super::options::knob(&model, &p.key))
            .collect::<Result<Vec<_>, _>>()?;
        let noise = super::options::noise(options, &scenario, &names)?;
        let defaults = default_drifts(&knobs, &noise, &model);
        let (drift, knob_sigmas) = super::options::drifts(options, &defaults);
        let acceleration = acceleration_noise(&mut model, options.process_noise)?;
        let tuning = super::options::tuning(acceleration, drift, knob_sigmas, noise);
        let filter = Filter::new(model, knobs, tuning);
        let parameters: Vec<String> = options.parameters.iter().map(|p| p.key.clone()).collect();
        let detector = Detector::new(detector::DetectorSetup {
            signals: names.clone(),
            knobs: parameters.clone(),
            false_alarms_per_hour: options.false_alarms_per_hour,
            learn: options.learn,
        });
        Ok(Self {
            commands: vec![0.0; columns.actuators.len()],
            command_times: vec![f64::NEG_INFINITY; columns.actuators.len()],
            stale: false,
            started: false,
            filter,
            detector,
            intake: Intake::default(),
            columns,
            watched: names,
            parameters,
            time: 0.0,
            origin: None,
            latency: options.latency,
            scenario_name: scenario.name.clone(),
            control_period: scenario.control_period.unwrap_or(scenario.dt),
            gaps: 0,
        })
    }

    /// The plant signals of `loaded` a shadow can watch: those its model predicts from the
    /// mechanism's state (joint positions and velocities, the machine's task-space signals),
    /// not those that need the machine's history or a controller's reference.
    pub fn watchable(loaded: LoadedScenario) -> Result<Vec<String>, ShadowError> {
        let parts = Twin::new(loaded)?.model_parts()?;
        let signals = parts.layout.signals.clone();
        let all: Vec<usize> = (0..signals.len()).collect();
        let mut model = super::model::Model::new(parts, all);
        let mut values = vec![0.0; signals.len()];
        let x0 = model.x0.clone();
        model
            .measure(&x0, 0.0, &mut values)
            .map_err(|e| super::model::diverged(0.0, e))?;
        let reference = model.layout.reference_range();
        Ok(signals
            .into_iter()
            .zip(values)
            .enumerate()
            .filter(|(i, (_, value))| value.is_finite() && !reference.contains(i))
            .map(|(_, (name, _))| name)
            .collect())
    }

    /// The plant's actuators and signals, with their SI units (what samples are bound to).
    pub fn columns(&self) -> &PlantColumns {
        &self.columns
    }

    /// The watched signals, in the order of [`ShadowStep`]'s lists.
    pub fn watched(&self) -> &[String] {
        &self.watched
    }

    /// The tracked parameters' keys.
    pub fn parameters(&self) -> &[String] {
        &self.parameters
    }

    /// The display unit of each watched signal.
    pub fn watched_units(&self) -> Vec<framework::Unit> {
        let model = &self.filter.model;
        (model.watched.iter())
            .map(|&i| model.layout.specs.signals[i].unit)
            .collect()
    }

    /// The mechanism's links as the recording draws them (name, shapes in the link's frame).
    pub fn links(&self) -> Vec<(String, Vec<Shape>)> {
        (self.filter.model.mechanism.links.iter())
            .map(|l| (l.name.clone(), l.visuals.clone()))
            .collect()
    }

    /// The mechanism view's frame and drawings, as a run of the scenario shows them (without
    /// its markers, which follow signals the shadow does not estimate).
    pub fn scene(&self) -> Scene {
        let model = &self.filter.model;
        let mut scene = crate::run::framed(model.scene(), &model.mechanism, &[]);
        scene.markers.clear();
        scene
    }

    /// Whether the watched signals include every independent coordinate's position, so that
    /// the measurements alone place the mechanism ([`ShadowStep::measured_poses`]).
    pub fn measurements_place_the_mechanism(&self) -> bool {
        let model = &self.filter.model;
        let measured: Vec<usize> = (model.watched.iter())
            .filter_map(|&s| model.layout.position_joint(s))
            .collect();
        model.coordinates.iter().all(|j| measured.contains(j))
    }

    /// The scenario's name.
    pub fn scenario_name(&self) -> &str {
        &self.scenario_name
    }

    /// The machine's control period as the scenario gives it, s: how often its commands and
    /// measurements change.
    pub fn control_period(&self) -> f64 {
        self.control_period
    }

    /// Seconds since the first sample of source time `source` (s), the first setting the origin.
    fn since_origin(&mut self, source: f64) -> f64 {
        source - *self.origin.get_or_insert(source)
    }

    /// Takes actuator `actuator`'s command `value` (SI) at source time `time` (s).
    pub fn command(&mut self, actuator: usize, time: f64, value: f64) {
        if actuator < self.commands.len() && value.is_finite() && time.is_finite() {
            let time = self.since_origin(time);
            let sample = Sample {
                kind: SampleKind::Command(actuator),
                time,
                value,
            };
            if !self.intake.push(sample) {
                // Too late for the span it governed; still the newest command, it is in force.
                if time > self.command_times[actuator] {
                    (self.commands[actuator], self.command_times[actuator]) = (value, time);
                }
                self.stale = true;
            }
        }
    }

    /// Takes plant signal `signal`'s measurement `value` (SI) at source time `time` (s); a
    /// signal not watched is ignored.
    pub fn measurement(&mut self, signal: &str, time: f64, value: f64) {
        let Some(watched) = self.watched.iter().position(|s| s == signal) else {
            return;
        };
        if value.is_finite() && time.is_finite() {
            let time = self.since_origin(time);
            self.intake.push(Sample {
                kind: SampleKind::Measurement(watched),
                time,
                value,
            });
        }
    }

    /// The first sample's source time (s), once one has come.
    pub fn origin(&self) -> Option<f64> {
        self.origin
    }

    /// The newest sample's time, s since the first.
    pub fn newest(&self) -> Option<f64> {
        self.origin.map(|_| self.intake.newest())
    }

    /// How many spans longer than [`MAX_GAP`] had no sample (the state was taken up afresh).
    pub fn gaps(&self) -> u64 {
        self.gaps
    }

    /// What the intake did so far.
    pub fn counts(&self) -> IntakeCounts {
        self.intake.counts
    }

    /// Live: the arrival clock now (seconds on a steady clock), by which a silent stream is
    /// told from one whose batch is still coming. Without it (a logged run) silence is measured
    /// in data time.
    pub fn arrival_clock(&mut self, now: f64) {
        self.intake.clock = Some(now);
    }

    /// Processes the samples that are `latency` behind the slowest live stream (each command and
    /// signal is a stream; one silent for a second stops holding the others back).
    pub fn advance(&mut self) -> Result<Vec<ShadowStep>, ShadowError> {
        let until = self.intake.watermark() - self.latency;
        self.process(until)
    }

    /// Processes every sample taken (at the end of a logged run, whose streams are complete).
    pub fn flush(&mut self) -> Result<Vec<ShadowStep>, ShadowError> {
        self.process(f64::INFINITY)
    }

    /// Processes the samples every live stream has reached (at the end of a live watch). The
    /// newer ones are left out: a stream whose last batch had not come would leave them
    /// replayed under a stale command, which the parameters would then absorb.
    pub fn finish(&mut self) -> Result<Vec<ShadowStep>, ShadowError> {
        self.process(self.intake.watermark())
    }

    /// The anomalies found so far: those closed, then the one still open.
    pub fn anomalies(&self) -> Vec<Anomaly> {
        let mut all = self.detector.closed.clone();
        all.extend(self.detector.open().cloned());
        all
    }

    /// The thresholds in use (CUSUM h, NIS window and drift, in standard deviations), once
    /// learnt.
    pub fn thresholds(&self) -> Option<[f64; 3]> {
        (!self.detector.learning()).then(|| self.detector.thresholds())
    }

    /// Each tracked parameter's estimate and standard deviation now.
    pub fn estimates(&self) -> Vec<(f64, f64)> {
        (0..self.parameters.len())
            .map(|j| self.filter.knob_estimate(j))
            .collect()
    }
}

impl Shadow {
    /// Processes the samples up to `until` (s since the first sample).
    fn process(&mut self, until: f64) -> Result<Vec<ShadowStep>, ShadowError> {
        let samples = self.intake.release(until);
        let mut steps = Vec::new();
        let mut next = 0;
        while let Some(first) = samples.get(next) {
            let time = first.time;
            if !std::mem::replace(&mut self.started, true) {
                // The first samples place the machine (joined mid-run, a crank many turns on):
                // the parameters are held until the state is acquired.
                self.filter.hold = true;
                self.detector.resume_after(time, 0.0);
            } else if time - self.time > MAX_GAP {
                // Nothing came for a while (a lost connection): the state is anyone's guess,
                // the parameters are not; the next samples set the state again.
                self.stale = false;
                self.reacquire(time);
                self.gaps += 1;
            } else {
                if time > self.time {
                    self.filter
                        .predict(&self.commands, self.time, time - self.time)?;
                }
                if std::mem::take(&mut self.stale) {
                    // A command came after the span it governed was processed under another:
                    // the parameters are held and the tests paused until the innovations
                    // show the state caught up again.
                    self.filter.hold = true;
                    self.detector.resume_after(time, 0.0);
                }
            }
            self.time = self.time.max(time);
            let mut observed = Vec::new();
            while let Some(sample) = samples.get(next).filter(|s| s.time == time) {
                match sample.kind {
                    SampleKind::Command(a) => {
                        (self.commands[a], self.command_times[a]) = (sample.value, time)
                    }
                    SampleKind::Measurement(w) => observed.push((w, sample.value)),
                }
                next += 1;
            }
            if !observed.is_empty() {
                steps.push(self.correct(time, observed)?);
            }
        }
        Ok(steps)
    }

    /// Takes the state up afresh from the next samples at `time` (after a gap, or a command
    /// that came too late to be used): the positions and velocities loosened, the parameters
    /// held and the tests paused until the innovations are back in their learnt band.
    fn reacquire(&mut self, time: f64) {
        self.filter.loosen();
        self.filter.hold = true;
        self.detector.resume_after(time, detector::REACQUIRE);
    }

    /// The filter's update with the values measured at `time`, and the detector's tests.
    fn correct(
        &mut self,
        time: f64,
        observed: Vec<(usize, f64)>,
    ) -> Result<ShadowStep, ShadowError> {
        let innovation = self.filter.update(time, &observed)?;
        let z: Vec<(usize, f64)> = (innovation.signals.iter())
            .zip(innovation.residual.iter().zip(&innovation.variance))
            .map(|(&s, (r, v))| (s, r / v.sqrt()))
            .collect();
        let nis_per_dof = innovation.nis / z.len().max(1) as f64;
        let parameters = self.estimates();
        let change = self.detector.observe(time, &z, nis_per_dof, &parameters);
        self.filter.hold = self.detector.reacquiring();
        let estimate = self.filter.estimate(time)?;
        let (poses, measured_poses) = self.filter.poses(time, &observed)?;
        Ok(ShadowStep {
            time,
            estimate,
            poses,
            measured_poses,
            measured: observed,
            innovation,
            parameters,
            detector: self.detector.view.clone(),
            learning: self.detector.learning(),
            change,
        })
    }
}

/// The plant-signal index of each watched signal, or the one line naming an unknown one.
fn watched_signals(signals: &[String], names: &[String]) -> Result<Vec<usize>, ShadowError> {
    names
        .iter()
        .map(|name| {
            signals.iter().position(|s| s == name).ok_or_else(|| {
                ShadowError::Option(format!(
                    "signal `{name}`: the scenario's plant has no such signal (known: {})",
                    signals.join(", ")
                ))
            })
        })
        .collect()
}

/// Share of its value (or of its scale) a parameter may drift by per √s.
const DRIFT_SHARE: f64 = 0.02;
/// A bias may grow by this many noise σ per √s (a slipped encoder is many σ within seconds).
const BIAS_DRIFT: f64 = 3.0;
/// A joint's effort scale without an effort limit, N·m or N; its speed scale without a velocity
/// limit, rad/s or m/s.
const EFFORT_SCALE: f64 = 10.0;
const SPEED_SCALE: f64 = 1.0;

/// Each knob's default drift per √s, in its own unit: [`DRIFT_SHARE`] of a mass; of a friction
/// or of its scale, a tenth of the joint's effort limit, whichever is larger; of a damping or of
/// its scale, the damping that takes that tenth of the effort at a tenth of the joint's
/// velocity limit, whichever is larger; and [`BIAS_DRIFT`] noise σ for a bias.
fn default_drifts(
    knobs: &[super::model::Knob],
    noise: &[f64],
    model: &super::model::Model,
) -> Vec<f64> {
    let joint = |j: usize| &model.mechanism.joints[j];
    let effort = |j: usize| {
        let limit = joint(j).effort_limit.filter(|l| l.is_finite());
        limit.map_or(EFFORT_SCALE, |l| 0.1 * l)
    };
    let speed = |j: usize| joint(j).velocity_limit.map_or(SPEED_SCALE, |v| 0.1 * v);
    knobs
        .iter()
        .map(|knob| match knob {
            super::model::Knob::LinkMass { nominal, .. } => DRIFT_SHARE * nominal.mass,
            super::model::Knob::JointFriction { joint } => {
                DRIFT_SHARE * model.knob(knob).abs().max(effort(*joint))
            }
            super::model::Knob::JointDamping { joint } => {
                DRIFT_SHARE * model.knob(knob).abs().max(effort(*joint) / speed(*joint))
            }
            super::model::Knob::SensorBias { watched } => BIAS_DRIFT * noise[*watched].sqrt(),
        })
        .collect()
}

/// The acceleration noise density per coordinate: (`share` × the largest acceleration one
/// actuator at its effort limit gives that coordinate)² per second.
fn acceleration_noise(
    model: &mut super::model::Model,
    share: f64,
) -> Result<Vec<f64>, ShadowError> {
    let scales = model
        .acceleration_scales()
        .map_err(|e| super::model::diverged(0.0, e))?;
    Ok(scales
        .iter()
        .map(|a| (share * if *a > 0.0 { *a } else { 1.0 }).powi(2))
        .collect())
}

/// Refuses a watched signal the model cannot predict (not finite at the initial state).
fn check_predicted(model: &mut super::model::Model, names: &[String]) -> Result<(), ShadowError> {
    let mut values = vec![0.0; names.len()];
    let x0 = model.x0.clone();
    model
        .measure(&x0, 0.0, &mut values)
        .map_err(|e| super::model::diverged(0.0, e))?;
    match names.iter().zip(&values).find(|(_, v)| !v.is_finite()) {
        Some((name, _)) => Err(ShadowError::Option(format!(
            "signal `{name}`: the model cannot predict it from the mechanism's state; watch \
             another signal"
        ))),
        None => Ok(()),
    }
}
