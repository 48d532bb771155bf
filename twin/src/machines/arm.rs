//! The machining robot of Ilyukhin, Poduraev & Tatarintseva (DAAAM 2014): a planar three-joint arm
//! (`shoulder`, `elbow`, `wrist`) carrying a milling spindle (`spindle`, the cutter link) along a
//! part contour whose cast stock varies in depth.
//!
//! **Drives take current commands.** Each arm joint is moved by a DC servo drive of
//! [`models::drive`] (motor, gearbox, PI current loop, current command clipped to the motor's
//! protection limit). The controller's effort for a joint is that drive's **current command, in
//! A**; `drive` integrates the drive's electrical dynamics over the physics step and hands the
//! twin the joint torque `G·k_t·i` (N·m) it produces. The actuators stay `EffortKind::Torque` with
//! the URDF effort limit in N·m, and the machine requires that limit to be the drive's peak joint
//! torque `G·k_t·I_max` (checked when built), so the URDF still says what the joint can take. The
//! twin clips the command to that number before the drive; as every arm drive has `G·k_t` well
//! above 1 N·m/A, that clip never acts on a current command within the drive's limit — the drive's
//! own current limit is the one that binds.
//!
//! **Ideal drives.** A scenario may make a joint's drive ideal, `[actuators.<joint>]` (or
//! `[actuators."*"]`, all three) `kind = "effort"`: the controller's effort for that joint is then
//! the joint torque itself, in N·m, clipped to the URDF effort limit and applied as it is (the
//! `[process.drives]` entry is still checked, but its peak torque need not match the URDF's). No
//! drive, no current: the joint's `<joint>_current` reads 0 A, and its `peak_current` and
//! `at_limit_fraction` figures are 0. `drive_power = "off"` frees these joints too. The arm's
//! controllers command currents through their `torque_per_ampere` (`G·k_t`): set it to 1 N·m/A
//! for them to command torques.
//!
//! **Spindle.** The spindle is not a controller actuator: its own speed-controlled drive
//! ([`spindle`]) turns it, applying the motor torque as a couple on the cutter and the opposite
//! couple on the hand (the stator's reaction). Its current is measured like the others.
//!
//! **Process.** Every step the tool point (the cutter link's origin) is projected on the contour
//! ([`models::arm::path::ContourPath`]); the radial depth of cut is the stock's depth there plus
//! how far the tool has strayed into the stock, the path speed the tool's velocity along the
//! contour, and [`models::arm::milling::Cutter::load`] gives the tooth-period mean force on the
//! tool (applied at the spindle axis; the multibody carries its reaction to the joints as
//! `Jᵀ(q)·F`, Ilyukhin eq (1)) and the torque resisting the spindle (a couple on the cutter). With
//! the stock on the right of travel a counter-clockwise spindle mills up, a clockwise one down.
//!
//! Signals measured by the controller: `shoulder_current`, `elbow_current`, `wrist_current`,
//! `spindle_current` (A) and the tool point `tool_x`, `tool_y` (m). Diagnostics: the tool's
//! `path_deviation` (m), `path_position` (m), `radial_depth` (m), `cutting_force` (N) and
//! `spindle_load_torque` (N·m). Figures: see [`figures`].
//!
//! # Model notes
//!
//! | part | value |
//! | --- | --- |
//! | upper arm / forearm / hand | 0.40 / 0.36 / 0.12 m; 9.0 / 5.0 / 3.5 kg; izz 0.15 / 0.06 / 0.01 kg·m² |
//! | cutter (spindle rotor, holder, 10 mm two-flute end mill) | 0.4 kg, izz 2·10⁻⁴ kg·m² |
//! | shoulder / elbow / wrist drive | k_t 0.035 / 0.025 / 0.02 N·m/A, gear 120 / 120 / 50: 4.2 / 3.0 / 1.0 N·m/A, 84 / 60 / 20 N·m at 20 A |
//! | every arm motor | R 0.3 Ω, L 0.5 mH, k_e = k_t, 48 V, 20 A limit, current loop 2000 rad/s sampled at 10 kHz |
//! | spindle | 6,000 rpm counter-clockwise (up milling), k_t 0.06 N·m/A direct, R 0.15 Ω, L 0.2 mH, 20 A, speed loop 60 rad/s |
//! | cut | K_t 700 N/mm², K_n 210 N/mm² (cast aluminium), axial depth 5 mm, f_z 0.1 mm at 20 mm/s |
//! | contour | 140 mm line at y = −0.25 m from x = 0.36 m, 30 mm-radius quarter arc turning down, 40 mm down: 227 mm |
//! | stock | 1 mm radial, 3.5 mm from 60 to 100 mm of path (15 mm ramps), none before 10 or after 210 mm |
//!
//! At 20 mm/s the 3.5 mm stock asks the shoulder for ≈ 21 A (gravity ≈ 13 A of it, the up-milling
//! pull into the stock the rest), beyond its 20 A; elsewhere ≈ 15 A. Rotor inertias are not
//! modelled (they would add G²·J_m to each joint), nor gear losses.
//!
//! **Tuning of the correction** (`arm-milling`): the joint servos are computed-torque loops with a
//! triple pole at ω = 80 rad/s (`controllers::arm::servo`: the arm's mass matrix at every pose, so
//! the design holds stretched out as at the contour). With the paper's `T_K2 = 1/ω_c` the
//! shoulder current peaks at 18.08 A, 0.5 % over the 18 A tolerance; `T_K2` = 50 ms keeps it at
//! 18.0 A at the same finishing time, so the scenario sets it. `T_K1` = 2 ms, `T_K3` = 20 ms,
//! `T_K4` = 5 ms (the paper prints none). The fastest constant path speed with no current over 18 A
//! on this contour is 14 mm/s (17.9 A; 14.5 mm/s gives 18.1 A).
//!
//! **Constant V0 fails hard.** In up milling the cut pulls the tool into the stock, on top of
//! gravity: once the shoulder is clipped at 20 A the arm sags into the part, the cut deepens, the
//! load grows, and the tool is dragged in until the deep zone ends (tens of mm). A chip from the
//! tool's motion into the stock as well would resist the plunge only as a damper (the guide's arm
//! notes: 64 mm instead of 61 mm), so the runaway is the process's, not a gap in the model; the
//! figures beyond a full-width slot say that the path is lost, not by how much a cell would gouge.

mod figures;
mod spindle;

use super::actuators::{kind_of, ActuatorKind, ActuatorSpecs};
use super::error::MachineError;
use super::joint_drives::{JointDrives, JointMotor};
use super::machine::{effort_unit, Machine};
use super::parts::{joint, link, process_params};
use super::points::LinkPoint;
use crate::mechanism::Mechanism;
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use figures::{Figures, Sample};
use framework::{Actuator, SignalSpec, Unit};
use models::arm::milling::{CutLoad, Cutter, CutterParams, MillingMode, Stock};
use models::arm::path::{Contour, ContourPath, Projection};
use models::drive::{Drive, DriveParams};
use serde::Deserialize;
use spindle::{Spindle, SpindleParams};

const MACHINE: &str = "arm";
const JOINTS: [&str; 3] = ["shoulder", "elbow", "wrist"];
/// Lever of the couples that carry the spindle torques, m.
const COUPLE_ARM: f64 = 0.01;
/// Velocity step of the cut's finite-difference slope, m/s (the cut is linear in speed).
const CUT_VELOCITY_STEP: f64 = 1e-6;

/// `[process.drives]`: one drive per arm joint.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ArmDrives {
    shoulder: DriveParams,
    elbow: DriveParams,
    wrist: DriveParams,
}

/// A 48 V servo motor of `torque_constant` N·m/A behind a gear of `gear_ratio`, 20 A peak.
fn servo(torque_constant: f64, gear_ratio: f64) -> DriveParams {
    DriveParams {
        torque_constant,
        back_emf_constant: torque_constant,
        resistance: 0.3,
        inductance: 0.5e-3,
        gear_ratio,
        supply_voltage: 48.0,
        current_limit: 20.0,
        current_bandwidth: 2000.0,
        current_loop_period: 1e-4,
    }
}

impl Default for ArmDrives {
    /// Shoulder 0.035 N·m/A × 120, elbow 0.025 × 120, wrist 0.02 × 50 (model notes above).
    fn default() -> Self {
        Self {
            shoulder: servo(0.035, 120.0),
            elbow: servo(0.025, 120.0),
            wrist: servo(0.02, 50.0),
        }
    }
}

/// The `[process]` table of an arm scenario (SI units).
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// The part contour the tool must follow (the robot program's, unless a scenario changes one).
    contour: Contour,
    stock: Stock,
    cutter: CutterParams,
    spindle: SpindleParams,
    drives: ArmDrives,
    /// Permissible motor current, A, the figures compare peaks with (default 18 A).
    current_tolerance: Option<f64>,
    /// The figures' deep zone: where the stock is deeper than this, m (default: half way between
    /// the shallowest cut and the deepest).
    deep_zone_depth: Option<f64>,
    /// Whether the arm's power stages are on (the default) or off.
    drive_power: DrivePower,
    /// Whether the spindle's power stage is on (the default) or off: off, the spindle turns
    /// free on its bearing (a machine whose spindle is idle while its axes move).
    spindle_power: DrivePower,
}

/// The arm joints' power stages. `on`: the controller's current commands drive the motors —
/// a zero command is *not* a free joint: the current loop holds i = 0 against the back-EMF
/// (k_e·G·q̇, 4.2 V per rad/s at the shoulder) until the 48 V supply runs out, beyond
/// 11.4 rad/s at the shoulder, and from there the back-EMF drives a braking current.
/// `off`: amplifiers disabled (the spindle's too), windings open: no current, no torque, the
/// joints swing free (those with an ideal drive too).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
enum DrivePower {
    #[default]
    On,
    Off,
}

/// The paper's permissible motor current (its Fig. 2), A.
const PAPER_CURRENT_TOLERANCE: f64 = 18.0;

pub struct Arm {
    /// Where the shoulder turns, world frame, m.
    shoulder: [f64; 2],
    spindle_joint: usize,
    hand: usize,
    /// The tool point, `tool_x`, `tool_y`: the cutter's origin.
    tool: LinkPoint,
    /// The arm joints' actuators: a DC servo each, or ideal where the scenario makes it so.
    drives: JointDrives,
    drive_power: DrivePower,
    spindle_power: DrivePower,
    spindle: Spindle,
    contour: ContourPath,
    stock: Stock,
    cutter: Cutter,
    deep_zone_depth: f64,
    spindle_speed: f64,
    cut: CutLoad,
    cut_force: [f64; 2],
    /// Process-fault factor on the cutting forces (1: none).
    process_factor: f64,
    /// ∂cut_force/∂(tool velocity), N·s/m.
    cut_damping: [[f64; 2]; 2],
    spindle_torque: f64,
    figures: Figures,
    time: f64,
}

impl Arm {
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
        let joints = [
            joint(MACHINE, mechanism, JOINTS[0])?,
            joint(MACHINE, mechanism, JOINTS[1])?,
            joint(MACHINE, mechanism, JOINTS[2])?,
        ];
        let servos = joint_drives(mechanism, joints, &params.drives, actuators).map_err(bad)?;
        let servos = servos.into_iter().map(|s| s.map(JointMotor::DcServo));
        let drives = JointDrives::with_motors(mechanism, joints.into_iter().zip(servos).collect());
        let spindle_joint = joint(MACHINE, mechanism, "spindle")?;
        if mechanism.joints[spindle_joint].effort_limit.is_some() {
            return Err(bad(
                "the spindle joint must not be actuated in the URDF: its own drive turns it".into(),
            ));
        }
        actuated_in_order(mechanism, joints).map_err(bad)?;
        let cutter_link = link(MACHINE, mechanism, "cutter")?;
        let rotor_inertia = mechanism.links[cutter_link].inertial.map_or(0.0, |i| i.izz);
        let spindle = Spindle::new(params.spindle, rotor_inertia).map_err(bad)?;
        let contour = ContourPath::new(&params.contour).map_err(|e| bad(e.to_string()))?;
        let cutter = Cutter::new(params.cutter).map_err(|e| bad(e.to_string()))?;
        params
            .stock
            .validate(params.cutter.diameter)
            .map_err(|e| bad(e.to_string()))?;
        let tolerance = params.current_tolerance.unwrap_or(PAPER_CURRENT_TOLERANCE);
        if !(tolerance > 0.0 && tolerance.is_finite()) {
            return Err(bad(format!(
                "current_tolerance must be finite and > 0 (got {tolerance})"
            )));
        }
        let shallowest = params
            .stock
            .depth
            .iter()
            .map(|p| p[1])
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let deep_zone_depth = params
            .deep_zone_depth
            .unwrap_or((shallowest + params.stock.deepest()) / 2.0);
        let motors = JOINTS
            .iter()
            .chain(["spindle"].iter())
            .map(|m| m.to_string())
            .collect();
        let shoulder = mechanism.zero_pose()[mechanism.joints[joints[0]].child];
        Ok(Self {
            shoulder: [shoulder.x, shoulder.y],
            spindle_joint,
            hand: link(MACHINE, mechanism, "hand")?,
            tool: LinkPoint::origin(cutter_link),
            drives,
            drive_power: params.drive_power,
            spindle_power: params.spindle_power,
            spindle,
            figures: Figures::new(motors, tolerance, contour.length()),
            contour,
            stock: params.stock,
            cutter,
            deep_zone_depth,
            spindle_speed: 0.0,
            cut: CutLoad::default(),
            cut_force: [0.0; 2],
            process_factor: 1.0,
            cut_damping: NO_DAMPING,
            spindle_torque: 0.0,
            time: 0.0,
        })
    }

    /// The cut's force on the tool (world) at the tool's `velocity`, and its slope ∂F/∂v: the
    /// cut is a damper of thousands of N·s/m on the tool, integrated with the motion.
    fn update_cut(&mut self, seen: &Projection, radial_depth: f64, velocity: [f64; 2]) {
        // Counter-clockwise with the stock on the right of travel: up milling.
        let mode = if self.spindle_speed >= 0.0 {
            MillingMode::Up
        } else {
            MillingMode::Down
        };
        let cut_at = |velocity: [f64; 2]| -> (CutLoad, [f64; 2]) {
            let right = [seen.tangent[1], -seen.tangent[0]];
            let path_speed = velocity[0] * seen.tangent[0] + velocity[1] * seen.tangent[1];
            let mut cut = self
                .cutter
                .load(mode, radial_depth, path_speed, self.spindle_speed);
            cut.along *= self.process_factor;
            cut.towards_stock *= self.process_factor;
            cut.torque *= self.process_factor;
            let force = [
                cut.along * seen.tangent[0] + cut.towards_stock * right[0],
                cut.along * seen.tangent[1] + cut.towards_stock * right[1],
            ];
            (cut, force)
        };
        (self.cut, self.cut_force) = cut_at(velocity);
        let step = CUT_VELOCITY_STEP;
        for axis in 0..2 {
            let mut nudged = velocity;
            nudged[axis] += step;
            let (_, force) = cut_at(nudged);
            for ((slope, nudged_force), force) in
                self.cut_damping.iter_mut().zip(force).zip(self.cut_force)
            {
                slope[axis] = (nudged_force - force) / step;
            }
        }
    }

    /// The arm motors' and the spindle's currents, A, and whether each is at its limit.
    fn currents(&self) -> ([f64; 4], [bool; 4]) {
        let mut currents = [0.0; 4];
        let mut at_limit = [false; 4];
        for (k, (current, limited)) in self.drives.currents().enumerate() {
            (currents[k], at_limit[k]) = (current, limited);
        }
        currents[3] = self.spindle.drive.current();
        at_limit[3] = self.spindle.drive.at_limit();
        (currents, at_limit)
    }
}

/// Refuses a URDF that actuates other joints than the arm's `joints`, or them in another order:
/// the drives take the commands in the URDF's actuator order.
fn actuated_in_order(mechanism: &Mechanism, joints: [usize; 3]) -> Result<(), String> {
    let actuated = mechanism.actuated_joints();
    if actuated == joints {
        return Ok(());
    }
    let names: Vec<&str> = (actuated.iter())
        .map(|&j| mechanism.joints[j].name.as_str())
        .collect();
    Err(format!(
        "the URDF must actuate {} in that order and no other joint (it actuates: {}); give the \
         others no <limit effort>",
        JOINTS.join(", "),
        names.join(", ")
    ))
}

/// The drives of the arm joints (`joints`, in [`JOINTS`]' order), each checked; `None` where the
/// scenario's `[actuators]` makes a joint's drive ideal. A drive's peak joint torque must be the
/// URDF's effort limit, which says what the joint can take.
fn joint_drives(
    mechanism: &Mechanism,
    joints: [usize; 3],
    params: &ArmDrives,
    actuators: &ActuatorSpecs,
) -> Result<Vec<Option<Drive>>, String> {
    let drive_params = [params.shoulder, params.elbow, params.wrist];
    let mut drives = Vec::new();
    for ((&j, name), drive) in joints.iter().zip(JOINTS).zip(drive_params) {
        let drive = Drive::new(drive).map_err(|e| format!("drives.{name}: {e}"))?;
        if kind_of(actuators, name) == ActuatorKind::Effort {
            drives.push(None);
            continue;
        }
        let peak = drive.params().peak_torque();
        match mechanism.joints[j].effort_limit {
            Some(limit) if (limit - peak).abs() <= 0.01 * peak => {}
            other => {
                return Err(format!(
                    "drives.{name}: the URDF effort limit ({other:?} N·m) must be the drive's \
                     peak joint torque G·k_t·I_max = {peak} N·m (or make the joint's drive ideal: \
                     [actuators.{name}] kind = \"effort\")"
                ))
            }
        }
        drives.push(Some(drive));
    }
    Ok(drives)
}

/// A torque `torque` (N·m, counter-clockwise) on `link` as a couple about `centre`.
fn couple(link: usize, centre: [f64; 2], torque: f64, loads: &mut Vec<Load>) {
    let f = torque / (2.0 * COUPLE_ARM);
    loads.push(Load {
        link,
        force: [0.0, f],
        point: [centre[0] + COUPLE_ARM, centre[1]],
        damping: NO_DAMPING,
        stiffness: NO_STIFFNESS,
    });
    loads.push(Load {
        link,
        force: [0.0, -f],
        point: [centre[0] - COUPLE_ARM, centre[1]],
        damping: NO_DAMPING,
        stiffness: NO_STIFFNESS,
    });
}

impl Machine for Arm {
    fn signals(&self) -> Vec<SignalSpec> {
        let mut specs: Vec<SignalSpec> = ["shoulder", "elbow", "wrist", "spindle"]
            .iter()
            .map(|m| SignalSpec::new(format!("{m}_current"), Unit::Ampere, format!("{m} current")))
            .collect();
        specs.extend([
            SignalSpec::new("tool_x", Unit::Millimetre, "tool point"),
            SignalSpec::new("tool_y", Unit::Millimetre, "tool point"),
        ]);
        specs
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("path_deviation", Unit::Micrometre, "path deviation"),
            SignalSpec::new("path_position", Unit::Millimetre, "path position"),
            SignalSpec::new("radial_depth", Unit::Millimetre, "radial depth"),
            SignalSpec::new("cutting_force", Unit::Newton, "cutting force"),
            SignalSpec::new(
                "spindle_load_torque",
                Unit::NewtonMetre,
                "spindle load torque",
            ),
        ]
    }

    /// The controller commands each drive's current (A), shown with the current it gets; an
    /// ideal drive's torque (N·m).
    fn command_unit(&self, actuator: &Actuator) -> Unit {
        (self.drives.command_unit(actuator)).unwrap_or_else(|| effort_unit(actuator.kind))
    }

    /// The drive's protection limit, A (the URDF's effort limit is the torque it gives); an ideal
    /// drive's the URDF's effort limit, N·m.
    fn command_limit(&self, actuator: &Actuator) -> f64 {
        self.drives.command_limit(actuator)
    }

    fn scene(&self) -> Scene {
        scene(self.shoulder, &self.contour, &self.stock)
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        let dt = time - self.time;
        self.time = time;
        self.drives.observe_speeds(state);
        self.spindle_speed = state.joint_velocities[self.spindle_joint];
        let (tool, velocity) = self.tool.locate(state);
        let seen = self.contour.project(tool);
        let stock = self.stock.depth_at(seen.along);
        let radial_depth = if stock > 0.0 {
            (stock + seen.right_offset).max(0.0)
        } else {
            0.0
        };
        self.update_cut(&seen, radial_depth, velocity);
        let path_speed = velocity[0] * seen.tangent[0] + velocity[1] * seen.tangent[1];
        let (currents, at_limit) = self.currents();
        signals.copy_from_slice(&[
            currents[0],
            currents[1],
            currents[2],
            currents[3],
            tool[0],
            tool[1],
        ]);
        diagnostics.copy_from_slice(&[
            seen.distance,
            seen.along,
            radial_depth,
            self.cut_force[0].hypot(self.cut_force[1]),
            self.cut.torque,
        ]);
        self.figures.observe(&Sample {
            time,
            dt,
            along: seen.along,
            deviation: seen.distance,
            path_speed,
            in_deep_zone: stock > self.deep_zone_depth,
            currents: &currents.map(f64::abs),
            at_limit: &at_limit,
        });
    }

    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        match self.drive_power {
            DrivePower::On => self.drives.drive(dt, commanded, applied),
            DrivePower::Off => applied.fill(0.0),
        }
        self.spindle_torque = match (self.drive_power, self.spindle_power) {
            (DrivePower::On, DrivePower::On) => self.spindle.step(dt, self.spindle_speed),
            _ => 0.0,
        };
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.process_factor = factor;
        true
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        let centre = self.tool.position(state);
        couple(self.tool.link, centre, self.spindle_torque, loads);
        couple(self.hand, centre, -self.spindle_torque, loads);
        if self.cut.torque != 0.0 || self.cut_force != [0.0; 2] {
            loads.push(Load {
                link: self.tool.link,
                force: self.cut_force,
                point: centre,
                damping: self.cut_damping,
                stiffness: NO_STIFFNESS,
            });
            let resisting = -self.spindle.set_speed().signum() * self.cut.torque;
            couple(self.tool.link, centre, resisting, loads);
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let mut metrics = self.figures.metrics(self.time);
        metrics.push(("deep_zone_depth".into(), self.deep_zone_depth));
        metrics
    }
}

/// The arm's workspace (its reach around the shoulder) with the part: its finished contour, the
/// cast stock's outline (the contour offset by the stock depth, on the right of travel) and the
/// tool point's trace.
fn scene(shoulder: [f64; 2], contour: &ContourPath, stock: &Stock) -> Scene {
    const SAMPLES: usize = 300;
    /// Upper arm + forearm + hand, m (the model notes').
    const REACH: f64 = 0.88;
    let mut finished = Vec::with_capacity(SAMPLES + 1);
    let mut outline = Vec::with_capacity(SAMPLES + 1);
    for i in 0..=SAMPLES {
        let along = contour.length() * i as f64 / SAMPLES as f64;
        let ([x, y], [tx, ty]) = contour.point(along);
        let depth = stock.depth_at(along);
        finished.push([x, y]);
        outline.push([x + ty * depth, y - tx * depth]);
    }
    let [sx, sy] = shoulder;
    let reach = [[-1.0, -1.0], [1.0, 1.0]].map(|[dx, dy]| [sx + dx * REACH, sy + dy * REACH]);
    let bounds =
        Bounds::around(reach.into_iter().chain(outline.iter().copied()), 0.03).unwrap_or(Bounds {
            x: [-1.0, 1.0],
            y: [-1.0, 1.0],
        });
    Scene {
        title: "arm and part (m, y up)".into(),
        bounds,
        drawings: vec![
            Drawing {
                name: "stock".into(),
                color: colors::WORKPIECE,
                lines: vec![outline],
                label: "stock".into(),
            },
            Drawing {
                name: "contour".into(),
                color: colors::TARGET,
                lines: vec![finished],
                label: "contour".into(),
            },
        ],
        markers: vec![Marker {
            name: "tool_point".into(),
            color: colors::TOOL,
            label: "tool".into(),
            source: MarkerSource::at("tool_x", "tool_y"),
            trace: true,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm_with(drive_power: &str, actuators: &str) -> Arm {
        let text = include_str!("../../../urdf/arm.urdf");
        let mechanism = crate::urdf::load_str(text, "arm.urdf").expect("loads");
        let process: toml::Table = format!("drive_power = \"{drive_power}\"")
            .parse()
            .expect("toml");
        let actuators: ActuatorSpecs = toml::from_str(actuators).expect("toml");
        Arm::new(&mechanism, &process, &actuators).expect("builds")
    }

    fn arm(drive_power: &str) -> Arm {
        arm_with(drive_power, "")
    }

    #[test]
    fn an_ideal_drive_applies_its_command_and_has_no_current() {
        let mut arm = arm_with("on", "elbow.kind = \"effort\"");
        arm.drives.set_speeds(&[3.0, -2.0, 5.0]);
        let shoulder = Actuator {
            joint: "shoulder".into(),
            kind: framework::EffortKind::Torque,
            effort_limit: 84.0,
        };
        let elbow = Actuator {
            joint: "elbow".into(),
            ..shoulder.clone()
        };
        assert_eq!(arm.command_unit(&shoulder), Unit::Ampere);
        assert_eq!(arm.command_limit(&shoulder), 20.0);
        assert_eq!(arm.command_unit(&elbow), Unit::NewtonMetre);
        assert_eq!(arm.command_limit(&elbow), 84.0);
        let mut applied = [0.0; 3];
        for _ in 0..10 {
            arm.drive(1e-3, &[5.0, -37.25, 2.0], &mut applied);
            // The elbow's torque as commanded, bit for bit, beside two drives that lag it.
            assert_eq!(applied[1], -37.25);
            assert_ne!(applied[0], 5.0 * 4.2);
            assert_eq!(arm.currents().0[1], 0.0);
        }
        assert!(arm.currents().0[0] > 0.0);
        // Power off frees the ideal joint too.
        let mut off = arm_with("off", "\"*\".kind = \"effort\"");
        off.drive(1e-3, &[5.0, -37.25, 2.0], &mut applied);
        assert_eq!(applied, [0.0; 3]);
    }

    #[test]
    fn drives_off_are_torque_free_and_a_zero_command_brakes() {
        let mut applied = [0.0; 3];
        // Power off: whatever is commanded, no torque, and the spindle stays unpowered too.
        let mut off = arm("off");
        off.drives.set_speeds(&[3.0, -2.0, 5.0]);
        off.spindle_speed = 100.0;
        for _ in 0..100 {
            off.drive(1e-3, &[20.0, -20.0, 20.0], &mut applied);
            assert_eq!(applied, [0.0; 3]);
            assert_eq!(off.spindle_torque, 0.0);
        }
        // Power on, zero current commanded: below 11.4 rad/s the current loop holds i ≈ 0
        // against the back-EMF; beyond, the 48 V supply runs out and the joint is braked.
        for (speed, braked) in [(2.0, false), (15.0, true)] {
            let mut on = arm("on");
            on.drives.set_speeds(&[speed, 0.0, 0.0]);
            for _ in 0..100 {
                on.drive(1e-3, &[0.0; 3], &mut applied);
            }
            println!(
                "shoulder at {speed} rad/s, zero command: {:.3} N·m",
                applied[0]
            );
            if braked {
                assert!(applied[0] < -1.0, "{speed} rad/s: {} N·m", applied[0]);
            } else {
                assert!(applied[0].abs() < 0.05, "{speed} rad/s: {} N·m", applied[0]);
            }
        }
    }

    #[test]
    fn an_arm_whose_urdf_actuates_other_joints_is_refused_naming_them() {
        let text = include_str!("../../../urdf/arm.urdf")
            .replace("effort=\"60\" velocity=\"3\"", "velocity=\"3\"");
        let mechanism = crate::urdf::load_str(&text, "arm.urdf").expect("loads");
        let actuators: ActuatorSpecs = toml::from_str("elbow.kind = \"effort\"").expect("toml");
        let error = Arm::new(&mechanism, &toml::Table::new(), &actuators)
            .err()
            .expect("refused")
            .to_string();
        assert!(
            error.contains("shoulder, elbow, wrist in that order")
                && error.contains("it actuates: shoulder, wrist"),
            "{error}"
        );
    }
}
