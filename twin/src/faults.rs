//! Fault injection: the scenario's `[[faults]]` entries, each acting from `start` to `end` (s;
//! no end: to the run's end). The controller never sees a fault, only its effect.
//!
//! | kind | on | `value` |
//! |---|---|---|
//! | `sensor_stuck` | `signal` | the reading held (none: the last reading before the onset) |
//! | `sensor_bias` | `signal` | offset added, signal unit |
//! | `sensor_drift` | `signal` | offset growing at this rate, unit/s |
//! | `sensor_noise` | `signal` | σ of extra white Gaussian noise, signal unit |
//! | `sensor_dropout` | `signal` | — (the last reading before the onset is held) |
//! | `sensor_delay` | `signal` | added transport delay, s |
//! | `actuator_effectiveness` | `joint` | factor k on the effort the drive gets (0: dead) |
//! | `actuator_stuck` | `joint` | effort held (none: the last command before the onset) |
//! | `actuator_limit` | `joint` | lowered effort limit, N·m or N |
//! | `link_mass` | `link` | new mass, kg (izz scaled with it), reached over `ramp` s |
//! | `joint_damping` | `joint` | new viscous damping, reached over `ramp` s |
//! | `joint_friction` | `joint` | new dry friction, reached over `ramp` s |
//! | `collision` | `joint` | effort from outside on the joint (an obstacle hit), N·m or N |
//! | `tool_breakage` | — | — (the process forces vanish) |
//! | `hard_spot` | — | factor k on the process forces |
//!
//! Sensor faults act on the readings at control updates, after the sensor model; actuator
//! faults on each new command after the limits; plant and process faults before each step. A
//! plant fault's value returns to the URDF's at `end`.

use crate::mechanism::{Inertial, Mechanism};
use crate::sensors::Noise;
use framework::{Actuator, Event, EventKind};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// One `[[faults]]` entry.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// Names the fault in events (default `<kind>_<index>`).
    pub name: Option<String>,
    pub kind: FaultKind,
    /// The measured signal of a sensor fault.
    pub signal: Option<String>,
    /// The actuated joint of an actuator fault, or the joint of a damping/friction fault.
    pub joint: Option<String>,
    /// The link of a mass fault.
    pub link: Option<String>,
    pub value: Option<f64>,
    /// Onset, s.
    pub start: f64,
    /// End, s; none: to the run's end.
    pub end: Option<f64>,
    /// Plant faults: the time over which the value moves from the URDF's to `value`, s.
    #[serde(default)]
    pub ramp: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    SensorStuck,
    SensorBias,
    SensorDrift,
    SensorNoise,
    SensorDropout,
    SensorDelay,
    ActuatorEffectiveness,
    ActuatorStuck,
    ActuatorLimit,
    LinkMass,
    JointDamping,
    JointFriction,
    Collision,
    ToolBreakage,
    HardSpot,
}

/// What a kind acts on, and what its value must be.
enum Subject {
    Signal,
    Actuator,
    Link,
    Joint,
    Process,
}

/// Whether a kind's value is required, optional or absent, and its least value.
enum ValueRule {
    Required { least: f64, inclusive: bool },
    Optional,
    Absent,
}

impl FaultKind {
    /// The kind as the scenario spells it (`sensor_stuck`).
    fn name(self) -> String {
        serde_json::to_value(self)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default()
    }

    fn subject(self) -> Subject {
        use FaultKind::*;
        match self {
            SensorStuck | SensorBias | SensorDrift | SensorNoise | SensorDropout | SensorDelay => {
                Subject::Signal
            }
            ActuatorEffectiveness | ActuatorStuck | ActuatorLimit => Subject::Actuator,
            LinkMass => Subject::Link,
            JointDamping | JointFriction | Collision => Subject::Joint,
            ToolBreakage | HardSpot => Subject::Process,
        }
    }

    fn value_rule(self) -> ValueRule {
        use FaultKind::*;
        let at_least = |least, inclusive| ValueRule::Required { least, inclusive };
        match self {
            SensorStuck | ActuatorStuck => ValueRule::Optional,
            SensorDropout | ToolBreakage => ValueRule::Absent,
            SensorBias | SensorDrift | Collision => at_least(f64::NEG_INFINITY, true),
            SensorNoise | SensorDelay | ActuatorLimit | LinkMass => at_least(0.0, false),
            ActuatorEffectiveness | JointDamping | JointFriction | HardSpot => at_least(0.0, true),
        }
    }
}

impl FaultSpec {
    /// Checks times, the subject field the kind needs (and no other) and the value's range.
    pub fn validate(&self, index: usize, duration: f64) -> Result<(), String> {
        let name = format!("faults.{index}");
        if !(self.start.is_finite() && self.start >= 0.0) {
            return Err(format!("{name}.start must be ≥ 0, got {}", self.start));
        }
        if let Some(end) = self
            .end
            .filter(|end| !(end.is_finite() && *end > self.start))
        {
            return Err(format!(
                "{name}.end ({end}) must be after start ({})",
                self.start
            ));
        }
        if self.start > duration {
            return Err(format!(
                "{name}.start ({} s) is after the run's end ({duration} s)",
                self.start
            ));
        }
        if !(self.ramp.is_finite() && self.ramp >= 0.0) {
            return Err(format!("{name}.ramp must be ≥ 0, got {}", self.ramp));
        }
        let (needed, field) = match self.kind.subject() {
            Subject::Signal => (Some("signal"), &self.signal),
            Subject::Actuator | Subject::Joint => (Some("joint"), &self.joint),
            Subject::Link => (Some("link"), &self.link),
            Subject::Process => (None, &None),
        };
        if let Some(needed) = needed.filter(|_| field.is_none()) {
            return Err(format!("{name}: {} needs `{needed}`", self.kind.name()));
        }
        let given = [
            ("signal", &self.signal),
            ("joint", &self.joint),
            ("link", &self.link),
        ];
        if let Some((extra, _)) = given
            .iter()
            .find(|(f, v)| v.is_some() && Some(*f) != needed)
        {
            return Err(format!("{name}: `{extra}` does not apply to this kind"));
        }
        match (self.kind.value_rule(), self.value) {
            (ValueRule::Required { .. }, None) => Err(format!("{name} needs a value")),
            (ValueRule::Absent, Some(_)) => Err(format!("{name}: this kind takes no value")),
            (ValueRule::Required { least, inclusive }, Some(v))
                if !v.is_finite() || v < least || (!inclusive && v == least) =>
            {
                let relation = if inclusive { "≥" } else { ">" };
                Err(format!(
                    "{name}.value must be finite and {relation} {least}, got {v}"
                ))
            }
            (_, Some(v)) if !v.is_finite() => Err(format!("{name}.value must be finite")),
            _ => Ok(()),
        }
    }

    fn label(&self, index: usize) -> String {
        (self.name.clone()).unwrap_or_else(|| format!("{}_{index}", self.kind.name()))
    }
}

/// Where a bound fault acts.
#[derive(Debug, Clone)]
enum Target {
    Signal(usize),
    Actuator(usize),
    Link {
        link: usize,
        urdf: Inertial,
    },
    Joint {
        joint: usize,
        damping: f64,
        friction: f64,
    },
    Process,
}

/// A fault bound to the run, with what it holds between steps.
#[derive(Debug, Clone)]
struct Fault {
    spec: FaultSpec,
    name: String,
    target: Target,
    active: bool,
    /// The reading or command held by a stuck or dropout fault.
    held: Option<f64>,
    /// Plant faults: the last value applied.
    applied: Option<f64>,
    noise: Noise,
    /// Readings (time, value) for an added delay.
    history: VecDeque<(f64, f64)>,
}

/// The run's faults.
#[derive(Debug, Clone)]
pub struct FaultSet {
    faults: Vec<Fault>,
    process_factor: f64,
}

/// What a plant change asks of the physics (and the energy model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlantChange {
    Link {
        link: usize,
        inertial: Inertial,
    },
    Joint {
        joint: usize,
        damping: f64,
        friction: f64,
    },
}

impl FaultSet {
    /// Binds the scenario's faults to the run's signals, actuators, links and joints; a name
    /// the run lacks, or a process fault on a machine without a process, is an error.
    pub fn bind(
        specs: &[FaultSpec],
        signals: &[String],
        actuators: &[Actuator],
        mechanism: &Mechanism,
        has_process: bool,
        seed: u64,
    ) -> Result<Self, String> {
        let mut faults = Vec::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let find = |names: Vec<&String>, name: &Option<String>, what: &str| {
                let name = name.as_deref().unwrap_or_default();
                names
                    .iter()
                    .position(|n| *n == name)
                    .ok_or_else(|| format!("faults.{i}: no {what} `{name}` in this run"))
            };
            let target = match spec.kind.subject() {
                Subject::Signal => Target::Signal(find(
                    signals.iter().collect(),
                    &spec.signal,
                    "measured signal",
                )?),
                Subject::Actuator => Target::Actuator(find(
                    actuators.iter().map(|a| &a.joint).collect(),
                    &spec.joint,
                    "actuated joint",
                )?),
                Subject::Link => {
                    let link = find(
                        mechanism.links.iter().map(|l| &l.name).collect(),
                        &spec.link,
                        "link",
                    )?;
                    let urdf = mechanism.links[link]
                        .inertial
                        .ok_or_else(|| format!("faults.{i}: the link has no <inertial>"))?;
                    Target::Link { link, urdf }
                }
                Subject::Joint => {
                    let joint = find(
                        mechanism.joints.iter().map(|j| &j.name).collect(),
                        &spec.joint,
                        "joint",
                    )?;
                    let urdf = &mechanism.joints[joint];
                    Target::Joint {
                        joint,
                        damping: urdf.damping,
                        friction: urdf.friction,
                    }
                }
                Subject::Process if !has_process => {
                    return Err(format!(
                        "faults.{i}: this machine has no cutting process for a {} fault",
                        spec.kind.name()
                    ))
                }
                Subject::Process => Target::Process,
            };
            faults.push(Fault {
                spec: spec.clone(),
                name: spec.label(i),
                target,
                active: false,
                held: None,
                applied: None,
                noise: Noise::new(seed ^ (0xFA17_0000 + i as u64)),
                history: VecDeque::new(),
            });
        }
        Ok(Self {
            faults,
            process_factor: 1.0,
        })
    }

    /// Whether a sensor fault acts on the plant signal at `index`.
    pub fn reads_signal(&self, index: usize) -> bool {
        (self.faults.iter()).any(|f| matches!(f.target, Target::Signal(i) if i == index))
    }

    /// Starts and ends faults at `time`, with an event for each onset and end.
    pub fn update(&mut self, time: f64, events: &mut Vec<Event>) {
        for fault in &mut self.faults {
            let active = time >= fault.spec.start && fault.spec.end.is_none_or(|end| time < end);
            if active == fault.active {
                continue;
            }
            fault.active = active;
            let name = fault.name.clone();
            events.push(if active {
                let value = fault
                    .spec
                    .value
                    .map_or(String::new(), |v| format!(" (value {v})"));
                Event::warning(
                    EventKind::FaultOnset { name: name.clone() },
                    format!("fault {name} begins: {}{value}", fault.spec.kind.name()),
                )
            } else {
                Event::info(
                    EventKind::FaultCleared { name: name.clone() },
                    format!("fault {name} ends"),
                )
            });
        }
    }

    /// The readings the controller gets, after the sensor faults (at a control update).
    pub fn sensors(&mut self, time: f64, measured: &mut [f64]) {
        for fault in &mut self.faults {
            let Target::Signal(i) = fault.target else {
                continue;
            };
            let reading = measured[i];
            if fault.spec.kind == FaultKind::SensorDelay {
                fault.history.push_back((time, reading));
            }
            let value = fault.spec.value.unwrap_or(0.0);
            if !fault.active {
                fault.held = Some(reading);
                delayed(&mut fault.history, time - value);
                continue;
            }
            measured[i] = match fault.spec.kind {
                FaultKind::SensorStuck => fault.spec.value.or(fault.held).unwrap_or(reading),
                FaultKind::SensorDropout => fault.held.unwrap_or(reading),
                FaultKind::SensorBias => reading + value,
                FaultKind::SensorDrift => reading + value * (time - fault.spec.start),
                FaultKind::SensorNoise => reading + value * fault.noise.gaussian(),
                _ => delayed(&mut fault.history, time - value).unwrap_or(reading),
            };
        }
    }

    /// The efforts the drives get, after the actuator faults (at a control update).
    pub fn actuators(&mut self, limited: &mut [f64]) {
        for fault in &mut self.faults {
            let Target::Actuator(a) = fault.target else {
                continue;
            };
            if !fault.active {
                fault.held = Some(limited[a]);
                continue;
            }
            let value = fault.spec.value.unwrap_or(0.0);
            limited[a] = match fault.spec.kind {
                FaultKind::ActuatorEffectiveness => value * limited[a],
                FaultKind::ActuatorStuck => fault.spec.value.or(fault.held).unwrap_or(limited[a]),
                _ => limited[a].clamp(-value, value),
            };
        }
    }

    /// The process-force factor now, if it changed since the last call.
    pub fn process_factor(&mut self) -> Option<f64> {
        let factor = self
            .faults
            .iter()
            .filter(|f| f.active && matches!(f.target, Target::Process))
            .map(|f| f.spec.value.unwrap_or(0.0))
            .product::<f64>();
        (factor != self.process_factor).then(|| {
            self.process_factor = factor;
            factor
        })
    }

    /// Adds the efforts of the collisions going on to the joints' efforts.
    pub fn collisions(&self, joint_efforts: &mut [f64]) {
        for fault in self.faults.iter().filter(|f| f.active) {
            if let (FaultKind::Collision, Target::Joint { joint, .. }) =
                (fault.spec.kind, &fault.target)
            {
                joint_efforts[*joint] += fault.spec.value.unwrap_or(0.0);
            }
        }
    }

    /// The plant changes due at `time` (a ramp moves a value every step until it arrives).
    pub fn plant(&mut self, time: f64, changes: &mut Vec<PlantChange>) {
        changes.clear();
        for i in 0..self.faults.len() {
            let fault = &self.faults[i];
            let urdf = match fault.target {
                Target::Link { urdf, .. } => urdf.mass,
                Target::Joint {
                    damping, friction, ..
                } => match fault.spec.kind {
                    FaultKind::JointDamping => damping,
                    FaultKind::JointFriction => friction,
                    _ => continue,
                },
                _ => continue,
            };
            let value = match fault.active {
                true => {
                    let ramp = fault.spec.ramp;
                    let share = if ramp > 0.0 {
                        ((time - fault.spec.start) / ramp).min(1.0)
                    } else {
                        1.0
                    };
                    urdf + share * (fault.spec.value.unwrap_or(urdf) - urdf)
                }
                false => urdf,
            };
            if fault.applied == Some(value) || (fault.applied.is_none() && !fault.active) {
                continue;
            }
            self.faults[i].applied = Some(value);
            changes.extend(self.change(i, value));
        }
    }

    /// The whole state of fault `i`'s link or joint, with its new value.
    fn change(&self, i: usize, value: f64) -> Option<PlantChange> {
        match self.faults[i].target {
            Target::Link { link, urdf } => Some(PlantChange::Link {
                link,
                inertial: urdf.with_mass(value),
            }),
            Target::Joint {
                joint,
                damping,
                friction,
            } => {
                // Another fault on the same joint keeps its own value.
                let current = |kind: FaultKind, urdf: f64| {
                    self.faults
                        .iter()
                        .filter(|f| {
                            f.spec.kind == kind
                                && matches!(f.target, Target::Joint { joint: j, .. } if j == joint)
                        })
                        .find_map(|f| f.applied)
                        .unwrap_or(urdf)
                };
                Some(PlantChange::Joint {
                    joint,
                    damping: current(FaultKind::JointDamping, damping),
                    friction: current(FaultKind::JointFriction, friction),
                })
            }
            _ => None,
        }
    }
}

/// The latest reading taken at or before `time` (older ones are dropped).
fn delayed(history: &mut VecDeque<(f64, f64)>, time: f64) -> Option<f64> {
    while history.len() > 1 && history[1].0 <= time + 1e-12 {
        history.pop_front();
    }
    history
        .front()
        .filter(|(t, _)| *t <= time + 1e-12)
        .map(|(_, v)| *v)
}
