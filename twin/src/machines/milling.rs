//! High-speed milling with a slender ball-end tool, after Kaliński & Galewski 2013, §3 (cited
//! as K(n)): the tool's first bending mode in the machine's plane (the tip on the prismatic joints
//! `tool_x` and `tool_y`, springs and dampers from the URDF) under the regenerative cut of
//! [`models::milling`], Kaliński eqs (11)–(13), and the spindle (revolute `spindle`, driven by
//! torque) whose instantaneous angle sets which flutes cut and the regenerative delay. The
//! workpiece feeds at `v_f` along x.
//!
//! Each step the cut is evaluated at the step's start from the tool's deflection and the spindle's
//! angle and speed; its force acts on the tool tip with its stiffness ∂F/∂u (so the chip follows
//! the tool within the step) and its drag on the spindle as tangential forces at the cutting
//! edges. Signals the machine adds: `regenerative_delay` (s, the time since the flute ahead passed
//! the same angle), and the diagnostics `cutting_force_x`, `cutting_force_y` (N),
//! `spindle_cutting_torque` (N·m), `chip_thickness` (m, the thickest chip) and `flutes_cutting`.

use super::error::MachineError;
use super::machine::{default_joint_signals, Excitation, Machine, Stability};
use super::parts::{joint, process_params};
use super::points::LinkPoint;
use crate::mechanism::{Joint, JointMotion, Mechanism};
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use framework::{SignalSpec, Unit};
use models::milling::stability::{CutGeometry, ToolModes};
use models::milling::{CutForces, MillingCut, MillingCutParams, MAX_FLUTES};
use serde::Deserialize;

const MACHINE: &str = "milling";

/// The `[process]` table of a milling scenario.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// The tool is in the cut (false: the spindle and tool run in air).
    cutting: bool,
    cut: MillingCutParams,
}

impl Default for ProcessParams {
    fn default() -> Self {
        Self {
            cutting: true,
            cut: MillingCutParams::default(),
        }
    }
}

/// The tool's deflection joints and where their axes point in the world.
#[derive(Debug, Clone, Copy)]
struct ToolJoints {
    x: usize,
    y: usize,
    axis_x: [f64; 2],
    axis_y: [f64; 2],
    /// The tool's tip, where the cut acts: the y slide's origin.
    tip: LinkPoint,
}

pub struct Milling {
    spindle: usize,
    spindle_link: usize,
    tool: ToolJoints,
    /// The tool's modes, for the lobe diagram (none without springs).
    modes: Option<ToolModes>,
    cut: Option<MillingCut>,
    forces: CutForces,
    delay: f64,
}

impl Milling {
    pub fn new(mechanism: &Mechanism, process: &toml::Table) -> Result<Self, MachineError> {
        let params: ProcessParams = process_params(MACHINE, process)?;
        let cut = MillingCut::new(params.cut).map_err(|e| MachineError::BadParameters {
            machine: MACHINE.into(),
            reason: format!("cut.{e}"),
        })?;
        let spindle = joint(MACHINE, mechanism, "spindle")?;
        if !matches!(
            mechanism.joints[spindle].motion,
            JointMotion::Revolute { .. }
        ) {
            return Err(missing("revolute joint", "spindle"));
        }
        let tool = tool_joints(mechanism, mechanism.joints[spindle].parent)?;
        Ok(Self {
            spindle,
            spindle_link: mechanism.joints[spindle].child,
            modes: tool_modes(mechanism, &tool),
            tool,
            cut: params.cutting.then_some(cut),
            forces: CutForces::default(),
            delay: 0.0,
        })
    }
}

/// The tool tip's deflection in the world, m.
fn deflection(tool: &ToolJoints, state: &MechanismState) -> [f64; 2] {
    let (qx, qy) = (state.joint_positions[tool.x], state.joint_positions[tool.y]);
    let [ax, ay] = [tool.axis_x, tool.axis_y];
    [ax[0] * qx + ay[0] * qy, ax[1] * qx + ay[1] * qy]
}

fn missing(what: &'static str, name: &str) -> MachineError {
    MachineError::MissingPart {
        machine: MACHINE.into(),
        what,
        name: name.into(),
    }
}

/// `tool_x` on the spindle's fixed parent and `tool_y` on `tool_x`'s child, both prismatic with
/// unrotated frames: the tip's deflection is then `q_x·axis_x + q_y·axis_y`.
fn tool_joints(mechanism: &Mechanism, frame: usize) -> Result<ToolJoints, MachineError> {
    let x = joint(MACHINE, mechanism, "tool_x")?;
    let y = joint(MACHINE, mechanism, "tool_y")?;
    let (jx, jy) = (&mechanism.joints[x], &mechanism.joints[y]);
    let (JointMotion::Prismatic { axis: axis_x }, JointMotion::Prismatic { axis: axis_y }) =
        (jx.motion, jy.motion)
    else {
        return Err(missing("prismatic joints", "tool_x, tool_y"));
    };
    if jx.parent != frame || jy.parent != jx.child {
        return Err(missing(
            "chain frame → tool_x → tool_y (tool_x on the spindle's parent link)",
            "tool_x, tool_y",
        ));
    }
    if jx.origin.angle != 0.0 || jy.origin.angle != 0.0 {
        return Err(missing("unrotated joint frames (rpy 0)", "tool_x, tool_y"));
    }
    Ok(ToolJoints {
        x,
        y,
        axis_x,
        axis_y,
        tip: LinkPoint::origin(jy.child),
    })
}

impl Machine for Milling {
    fn signals(&self) -> Vec<SignalSpec> {
        vec![SignalSpec::new(
            "regenerative_delay",
            Unit::Millisecond,
            "regenerative delay",
        )]
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("cutting_force_x", Unit::Newton, "cutting force"),
            SignalSpec::new("cutting_force_y", Unit::Newton, "cutting force"),
            SignalSpec::new(
                "spindle_cutting_torque",
                Unit::NewtonMetre,
                "spindle cutting torque",
            ),
            SignalSpec::new("chip_thickness", Unit::Micrometre, "chip thickness"),
            SignalSpec::new("flutes_cutting", Unit::Dimensionless, "flutes cutting"),
        ]
    }

    /// The tool tip's deflection in µm.
    fn joint_signals(&self, joint: &Joint) -> [SignalSpec; 2] {
        let name = joint.name.as_str();
        if name == "tool_x" || name == "tool_y" {
            return [
                SignalSpec::new(
                    format!("{name}.position"),
                    Unit::Micrometre,
                    "tool displacement",
                ),
                SignalSpec::new(
                    format!("{name}.velocity"),
                    Unit::MillimetrePerSecond,
                    "tool velocity",
                ),
            ];
        }
        default_joint_signals(joint)
    }

    fn scene(&self) -> Scene {
        let radius = self.cut.as_ref().map_or(0.006, |c| c.params().tool_radius);
        scene(radius)
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        // The cut at this state, applied over the coming step by `loads`.
        if let Some(cut) = self.cut.as_mut() {
            let angle = state.joint_positions[self.spindle];
            let speed = state.joint_velocities[self.spindle];
            let deflection = deflection(&self.tool, state);
            self.forces = cut.advance(time, angle, speed, deflection);
            self.delay = cut
                .time_at(angle - cut.params().pitch())
                .map_or(0.0, |t| time - t);
        }
        signals[0] = self.delay;
        let radius = self.cut.as_ref().map_or(0.0, |c| c.params().tool_radius);
        diagnostics.copy_from_slice(&[
            self.forces.force[0],
            self.forces.force[1],
            self.forces.spindle_torque(radius),
            self.forces.chip,
            self.forces.flutes_cutting as f64,
        ]);
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.cut.as_mut().map(|c| c.set_factor(factor)).is_some()
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        let Some(cut) = self.cut.as_ref() else {
            return;
        };
        if self.forces.flutes_cutting == 0 {
            return;
        }
        let angle = state.joint_positions[self.spindle];
        let pitch = cut.params().pitch();
        loads.push(Load {
            link: self.tool.tip.link,
            force: self.forces.force,
            point: self.tool.tip.position(state),
            damping: NO_DAMPING,
            stiffness: self.forces.stiffness,
        });
        // The drag on the spindle: each flute's tangential force at its edge, against the
        // edge's motion (clockwise rotation: the edge at n(φ) moves along (cos φ, −sin φ)).
        let (centre, radius) = (
            state.link_poses[self.spindle_link],
            cut.params().tool_radius,
        );
        for j in 0..cut.params().flutes.min(MAX_FLUTES) {
            let tangential = self.forces.tangential[j];
            if tangential == 0.0 {
                continue;
            }
            let (s, c) = (angle + j as f64 * pitch).sin_cos();
            loads.push(Load {
                link: self.spindle_link,
                force: [-tangential * c, tangential * s],
                point: [centre.x + radius * s, centre.y + radius * c],
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            });
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    fn excitation(&self) -> Option<Excitation> {
        let cut = self.cut.as_ref()?;
        Some(Excitation {
            speed_signal: "spindle.velocity".into(),
            per_revolution: cut.params().flutes,
            vibration_signal: "tool_y.position".into(),
        })
    }

    fn stability(&self) -> Option<Stability> {
        let params = self.cut.as_ref()?.params();
        Some(Stability {
            tool: self.modes?,
            cut: CutGeometry {
                flutes: params.flutes,
                cutting_pressure: params.cutting_pressure,
                force_ratio: params.force_ratio,
                entry_angle: params.entry_angle,
                exit_angle: params.exit_angle,
            },
            axial_depth: params.axial_depth,
            speeds: LOBE_SPEEDS,
        })
    }
}

/// Speeds of the lobe diagram when the run does not start at speed, rad/s: 10,000–35,000 rpm
/// (the spindle's rating).
const LOBE_SPEEDS: [f64; 2] = [10_000.0 * RAD_PER_S_PER_RPM, 35_000.0 * RAD_PER_S_PER_RPM];
const RAD_PER_S_PER_RPM: f64 = std::f64::consts::TAU / 60.0;

/// The tool's two modes as the stability analysis takes them: the mass every deflection joint
/// carries, its `<spring>` stiffness and its `<dynamics>` damping.
/// `None` when a joint has no spring (a rigid tool has no lobes).
fn tool_modes(mechanism: &Mechanism, tool: &ToolJoints) -> Option<ToolModes> {
    let mode = |j: usize| -> Option<[f64; 3]> {
        let joint = &mechanism.joints[j];
        let mass = mechanism.carried_mass(joint.child);
        Some([mass, joint.spring?.stiffness, joint.damping])
    };
    let [x, y] = [mode(tool.x)?, mode(tool.y)?];
    Some(ToolModes {
        mass: [x[0], y[0]],
        stiffness: [x[1], y[1]],
        damping: [x[2], y[2]],
    })
}

/// Magnification of the tool tip's deflection in the view: its orbit is drawn 20 times larger.
const ORBIT_MAGNIFICATION: f64 = 20.0;

/// The tool seen along its axis: its circle at rest and the tip's deflection orbit, magnified
/// [`ORBIT_MAGNIFICATION`] times, traced as the run goes (a chattering tool draws a wide orbit).
fn scene(tool_radius: f64) -> Scene {
    const SEGMENTS: usize = 64;
    let circle = |r: f64| -> Vec<[f64; 2]> {
        (0..=SEGMENTS)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / SEGMENTS as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    };
    let reach = 0.02_f64.max(2.0 * tool_radius);
    Scene {
        title: "tool along its axis (m, y up) · tip orbit ×20".into(),
        bounds: Bounds {
            x: [-reach, reach],
            y: [-reach, reach],
        },
        drawings: vec![Drawing {
            name: "tool_at_rest".into(),
            color: colors::WORKPIECE,
            lines: vec![circle(tool_radius)],
            label: "tool at rest".into(),
        }],
        markers: vec![Marker {
            name: "tip_orbit".into(),
            color: colors::TOOL,
            label: "tip ×20".into(),
            source: MarkerSource {
                x: Some("tool_x.position".into()),
                y: Some("tool_y.position".into()),
                scale: ORBIT_MAGNIFICATION,
                origin: [0.0, 0.0],
            },
            trace: true,
        }],
    }
}
