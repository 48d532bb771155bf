//! A linear-motor feed axis of a micro-milling machine, after Rubio, Ibeas & Luo ("P-PI and super
//! twisting sliding mode control schemes comparison for high-precision CNC machining"; their
//! equations restart in each section, cited here as II.(n)): a table on one prismatic joint
//! `table`, `m ẍ + b ẋ = F` (II.(1)) with m and b in the URDF, driven through the chain of their
//! Fig. 1, and loaded by the micro-milling cut of [`models::feed_axis::micromilling`] (II.(2)–(4)).
//!
//! **Drive.** The controller's force command F* (N) is the amplifier's input through the voltage
//! `u_c = F*/(k_t·K_a)`; the current amplifier gives `i = k_t·u_c`, limited to ±`current_limit`,
//! and the motor pushes the table with `F_m = K_a·i`. The amplifier is taken as static (its current
//! loop far faster than the position loop), as in the paper's model
//! ([`models::current_amplifier`], the drive a generic machine's joint takes with `kind =
//! "current-amplifier"`). Defaults: the paper's
//! `k_t` = 2 A/V and `K_a` = 50 N/A (§V); a peak current of 10 A, the order of a linear motor of
//! this force constant (500 N peak, which the URDF's `<limit effort>` matches). The current is the
//! machine's measured signal `table_current` (A), the current that flowed over the last step.
//! `[actuators.table] kind = "effort"` makes the drive ideal: the force command is the table's
//! force, clipped to the URDF effort limit only, with no current (`table_current`, `peak_current`
//! and `current_limited_fraction` read 0).
//!
//! **Cut.** With `[process] cutting = true` the cut's force on the table along its axis,
//! [`MicroMillingCut::force_on_axis`] at the step's start time and the table's velocity, acts as a
//! load for the step and is recorded as the diagnostic `cutting_force` (N; zero without the cut).
//! `[process.cut]` holds its parameters (SI; defaults: the paper's cutting conditions).
//!
//! **Tracking** is judged outside the machine: the scenario's `[[metrics]]` take the true errors
//! `reference − table.position` and `reference_rate − table.velocity` (the programmed path is the
//! scenario's `[reference]`, handed to the controller unchanged) and report their largest
//! magnitude and σ, the columns of Table I (see `twin::evaluate`).

use super::actuators::{kind_of, ActuatorKind, ActuatorSpecs};
use super::error::MachineError;
use super::joint_drives::{JointDrives, JointMotor};
use super::machine::{default_joint_signals, Machine};
use super::parts::{joint, process_params};
use crate::mechanism::{Joint, JointMotion, Mechanism, Pose2};
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use framework::{SignalSpec, Unit};
use models::current_amplifier::{AmplifierParams, CurrentAmplifier};
use models::feed_axis::micromilling::{MicroMillingCut, MicroMillingParams};
use serde::Deserialize;

const MACHINE: &str = "feed_axis";
const TABLE_JOINT: &str = "table";

/// The `[process]` table of a feed-axis scenario (SI units).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// The micro-milling cut loads the table.
    cutting: bool,
    /// The cut's parameters.
    cut: MicroMillingParams,
    /// k_t, A/V.
    amplifier_gain: f64,
    /// K_a, N/A.
    force_constant: f64,
    /// Peak current of the amplifier, A.
    current_limit: f64,
}

impl Default for ProcessParams {
    fn default() -> Self {
        Self {
            cutting: false,
            cut: MicroMillingParams::default(),
            amplifier_gain: 2.0,
            force_constant: 50.0,
            current_limit: 10.0,
        }
    }
}

/// How the amplifier has served the run.
#[derive(Debug, Clone, Default)]
struct AmplifierFigures {
    peak_current: f64,
    steps: usize,
    limited_steps: usize,
}

pub struct FeedAxis {
    table_joint: usize,
    table_link: usize,
    /// The link carrying the guide-ways, the joint frame on it and the axis in that frame.
    guide_link: usize,
    guide_frame: Pose2,
    axis: [f64; 2],
    /// Index of the table's actuator among the actuated joints.
    table_actuator: usize,
    /// The actuated joints' drives: the table's through its amplifier, unless the scenario makes
    /// it ideal (`[actuators]`).
    drives: JointDrives,
    amplifier: AmplifierFigures,
    cut: Option<MicroMillingCut>,
    cutting_force: f64,
    /// Process-fault factor on the cutting forces (1: none).
    process_factor: f64,
    cutting_force_peak: f64,
}

impl FeedAxis {
    pub fn new(
        mechanism: &Mechanism,
        process: &toml::Table,
        actuators: &ActuatorSpecs,
    ) -> Result<Self, MachineError> {
        let bad = |reason: String| MachineError::BadParameters {
            machine: MACHINE.into(),
            reason,
        };
        let params: ProcessParams = process_params(MACHINE, process)?;
        let amplifier = CurrentAmplifier::new(AmplifierParams {
            amplifier_gain: params.amplifier_gain,
            force_constant: params.force_constant,
            current_limit: params.current_limit,
        })
        .map_err(|e| bad(e.to_string()))?;
        // Checked whether or not it cuts: a bad [process.cut] is an error either way.
        let cut = MicroMillingCut::new(params.cut).map_err(|e| bad(format!("cut: {e}")))?;

        let table_joint = joint(MACHINE, mechanism, TABLE_JOINT)?;
        let table = &mechanism.joints[table_joint];
        let JointMotion::Prismatic { axis } = table.motion else {
            return Err(MachineError::MissingPart {
                machine: MACHINE.into(),
                what: "prismatic joint",
                name: TABLE_JOINT.into(),
            });
        };
        let actuated = mechanism.actuated_joints();
        let table_actuator = (actuated.iter())
            .position(|&j| j == table_joint)
            .ok_or_else(|| MachineError::MissingPart {
                machine: MACHINE.into(),
                what: "actuated joint (<limit effort> > 0)",
                name: TABLE_JOINT.into(),
            })?;
        let ideal = kind_of(actuators, TABLE_JOINT) == ActuatorKind::Effort;
        let motors = (actuated.into_iter())
            .map(|j| {
                (
                    j,
                    (j == table_joint && !ideal).then_some(JointMotor::CurrentAmplifier(amplifier)),
                )
            })
            .collect();
        Ok(Self {
            table_joint,
            table_link: table.child,
            guide_link: table.parent,
            guide_frame: table.origin,
            axis,
            table_actuator,
            drives: JointDrives::with_motors(mechanism, motors),
            amplifier: AmplifierFigures::default(),
            cut: params.cutting.then_some(cut),
            cutting_force: 0.0,
            process_factor: 1.0,
            cutting_force_peak: 0.0,
        })
    }

    /// The table amplifier's current, A, and whether it was at its limit (0 and no when the
    /// drive is ideal).
    fn table_current(&self) -> (f64, bool) {
        (self.drives.currents().nth(self.table_actuator)).unwrap_or((0.0, false))
    }
}

impl Machine for FeedAxis {
    fn signals(&self) -> Vec<SignalSpec> {
        vec![SignalSpec::new(
            "table_current",
            Unit::Ampere,
            "table current",
        )]
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        vec![SignalSpec::new(
            "cutting_force",
            Unit::Newton,
            "cutting force",
        )]
    }

    fn reference(&self) -> Option<[SignalSpec; 3]> {
        Some([
            SignalSpec::new("reference", Unit::Micrometre, "table position"),
            SignalSpec::new(
                "reference_rate",
                Unit::MicrometrePerSecond,
                "table velocity",
            ),
            SignalSpec::new(
                "reference_acceleration",
                Unit::MetrePerSecondSquared,
                "table acceleration",
            ),
        ])
    }

    /// The table moves micrometres: its position and velocity are shown in µm and µm/s, on the
    /// plots of the reference.
    fn joint_signals(&self, joint: &Joint) -> [SignalSpec; 2] {
        if joint.name != "table" {
            return default_joint_signals(joint);
        }
        [
            SignalSpec::new("table.position", Unit::Micrometre, "table position"),
            SignalSpec::new(
                "table.velocity",
                Unit::MicrometrePerSecond,
                "table velocity",
            ),
        ]
    }

    fn scene(&self) -> Scene {
        scene()
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        let velocity = state.joint_velocities[self.table_joint];
        signals[0] = self.table_current().0;
        self.cutting_force = self.process_factor
            * self
                .cut
                .as_ref()
                .map_or(0.0, |cut| cut.force_on_axis(time, velocity));
        self.cutting_force_peak = self.cutting_force_peak.max(self.cutting_force.abs());
        diagnostics[0] = self.cutting_force;
    }

    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        self.drives.drive(dt, commanded, applied);
        let (current, limited) = self.table_current();
        let figures = &mut self.amplifier;
        figures.peak_current = figures.peak_current.max(current.abs());
        figures.steps += 1;
        figures.limited_steps += usize::from(limited);
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.process_factor = factor;
        self.cut.is_some()
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        if self.cutting_force == 0.0 {
            return;
        }
        // Along the table's axis in the world, as the physics applies the motor force.
        let frame = state.link_poses[self.guide_link].compose(&self.guide_frame);
        let [ax, ay] = frame.rotate(self.axis[0], self.axis[1]);
        let table = state.link_poses[self.table_link];
        loads.push(Load {
            link: self.table_link,
            force: [ax * self.cutting_force, ay * self.cutting_force],
            point: [table.x, table.y],
            damping: NO_DAMPING,
            stiffness: NO_STIFFNESS,
        });
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let figures = &self.amplifier;
        let mut metrics = vec![("peak_current".to_string(), figures.peak_current)];
        metrics.push((
            "current_limited_fraction".into(),
            figures.limited_steps as f64 / figures.steps.max(1) as f64,
        ));
        if self.cut.is_some() {
            metrics.push(("cutting_force_peak".into(), self.cutting_force_peak));
        }
        metrics
    }
}

/// Magnification of the table's motion on the view's gauge: 1 µm is drawn as 50 mm.
const GAUGE_MAGNIFICATION: f64 = 5.0e4;
/// Height of the gauge above the table, m.
const GAUGE_HEIGHT: f64 = 0.07;

/// The axis at true scale (base and table, which moves micrometres), with a gauge above it where
/// the reference and the table's position are drawn magnified [`GAUGE_MAGNIFICATION`] times,
/// ticks every µm.
fn scene() -> Scene {
    let gauge = |x: f64| GAUGE_MAGNIFICATION * x;
    let mut lines = vec![vec![
        [gauge(-4e-6), GAUGE_HEIGHT],
        [gauge(4e-6), GAUGE_HEIGHT],
    ]];
    lines.extend((-4..=4).map(|um| {
        let x = gauge(f64::from(um) * 1e-6);
        let half = if um == 0 { 0.012 } else { 0.006 };
        vec![[x, GAUGE_HEIGHT - half], [x, GAUGE_HEIGHT + half]]
    }));
    let magnified = |x: &str| MarkerSource {
        x: Some(x.into()),
        y: None,
        scale: GAUGE_MAGNIFICATION,
        origin: [0.0, GAUGE_HEIGHT],
    };
    Scene {
        title: "feed axis (m, y up) · gauge: position ×50 000, ticks 1 µm".into(),
        bounds: Bounds {
            x: [-0.3, 0.3],
            y: [-0.08, 0.12],
        },
        drawings: vec![Drawing {
            name: "gauge".into(),
            color: colors::WORKPIECE,
            lines,
            label: "±4 µm gauge (×50 000)".into(),
        }],
        markers: vec![
            Marker {
                name: "reference".into(),
                color: colors::TARGET,
                label: "reference".into(),
                source: magnified("reference"),
                trace: false,
            },
            Marker {
                name: "table".into(),
                color: colors::TRUE,
                label: "table".into(),
                source: magnified("table.position"),
                trace: false,
            },
        ],
    }
}
