//! The parallel turning lathe (Sudhakara & Landers, ACC 2003): one spindle carrying a stepped
//! part, two tools on prismatic slides cutting it at once.
//!
//! Each step the machine reads the spindle speed ω and each slide's travel and speed, and works
//! out the cut with `models::lathe`:
//! - feed per revolution f_i = 2π v_i / ω (slide speed over spindle speed in rev/s);
//! - cutting speed V_i = ω D_i / 2 and cutting force Sudhakara eq (1), F_i = K_i d_i^β V_i^γ f_i^α,
//!   while the tool is in the material;
//! - spindle power Sudhakara eq (4), P = Σ V_i F_i.
//!
//! A tool is in the material while its slide is at or beyond the furthest point it has reached
//! (the machined shoulder), which starts `approach_gaps` into the feed travel: the tools meet the
//! part after an air gap, and a slide that backs off cuts air until it is back on the shoulder.
//! Below 1 rad/s of spindle speed nothing is cut (feed per revolution has no meaning there).
//!
//! The cutting force acts on the slide against its feed and, tangentially at the cut diameter, on
//! the part against its rotation: a torque F_i D_i / 2 on the spindle.

use super::error::MachineError;
use super::machine::Machine;
use super::parts::{joint, process_params};
use crate::mechanism::{JointMotion, Mechanism};
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use framework::{SignalSpec, Unit};
use models::lathe::{Lathe, LatheParams, TOOLS};
use serde::Deserialize;
use std::f64::consts::TAU;

const MACHINE: &str = "lathe";
const SLIDES: [&str; TOOLS] = ["slide_1", "slide_2"];
/// Below this spindle speed the tools do not cut, rad/s.
const MIN_CUTTING_SPINDLE_SPEED: f64 = 1.0;
/// A feed within this fraction of f_max from 0 or f_max counts as sitting on a limit of
/// Sudhakara eq (20).
const FEED_LIMIT_BAND: f64 = 0.01;

/// The `[process]` table of a lathe scenario.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// The lathe as built: cutting law, diameters and depths, N_s, P_max, f_max (Table 1). The
    /// machine cuts with the tools' law and judges the run against P_max and f_max.
    lathe: LatheParams,
    /// Feed travel of each tool through air before it meets the part, m.
    approach_gaps: [f64; TOOLS],
    /// The power counts as settled within this fraction of P_max.
    settle_band: f64,
}

impl Default for ProcessParams {
    fn default() -> Self {
        Self {
            lathe: LatheParams::default(),
            approach_gaps: [1e-3, 1e-3],
            settle_band: 0.02,
        }
    }
}

/// One tool's cut in the current step.
#[derive(Debug, Clone, Copy, Default)]
struct Cut {
    in_material: bool,
    /// m/rev.
    feed: f64,
    /// N.
    force: f64,
    /// m/s.
    cutting_speed: f64,
}

pub struct ParallelLathe {
    lathe: Lathe,
    settle_band: f64,
    spindle_joint: usize,
    /// +1 when the spindle joint turns about +z, −1 about −z.
    spindle_sign: f64,
    part_link: usize,
    slide_joints: [usize; TOOLS],
    slide_links: [usize; TOOLS],
    /// Each slide's URDF axis, in the slide's frame.
    feed_axes: [[f64; 2]; TOOLS],
    /// Unit vector from the spindle axis towards each tool, world frame.
    tool_directions: [[f64; 2]; TOOLS],
    /// The spindle axis in the world, m.
    spindle_centre: [f64; 2],
    /// The machined shoulder of each tool along its slide travel, m.
    shoulders: [f64; TOOLS],
    cuts: [Cut; TOOLS],
    /// Process-fault factor on the cutting forces (1: none).
    process_factor: f64,
    power: f64,
    record: CutRecord,
}

impl ParallelLathe {
    pub fn new(mechanism: &Mechanism, process: &toml::Table) -> Result<Self, MachineError> {
        let bad = |reason: String| MachineError::BadParameters {
            machine: MACHINE.into(),
            reason,
        };
        let params: ProcessParams = process_params(MACHINE, process)?;
        let lathe = Lathe::new(params.lathe).map_err(|e| bad(e.to_string()))?;
        for (i, gap) in params.approach_gaps.iter().enumerate() {
            if !(gap.is_finite() && *gap >= 0.0) {
                return Err(bad(format!(
                    "approach_gaps[{i}] must be finite and ≥ 0 (got {gap})"
                )));
            }
        }
        if !(params.settle_band.is_finite() && params.settle_band > 0.0) {
            return Err(bad(format!(
                "settle_band must be finite and > 0 (got {})",
                params.settle_band
            )));
        }

        let spindle_joint = joint(MACHINE, mechanism, "spindle")?;
        let spindle_sign = match mechanism.joints[spindle_joint].motion {
            JointMotion::Revolute { sign } => sign,
            _ => return Err(bad("joint `spindle` must be revolute or continuous".into())),
        };
        let poses = mechanism.zero_pose();
        let part_link = mechanism.joints[spindle_joint].child;
        let centre = poses[part_link];
        let mut slide_joints = [0; TOOLS];
        let mut slide_links = [0; TOOLS];
        let mut feed_axes = [[0.0; 2]; TOOLS];
        let mut tool_directions = [[0.0; 2]; TOOLS];
        for i in 0..TOOLS {
            slide_joints[i] = joint(MACHINE, mechanism, SLIDES[i])?;
            let slide = &mechanism.joints[slide_joints[i]];
            feed_axes[i] = match slide.motion {
                JointMotion::Prismatic { axis } => axis,
                _ => return Err(bad(format!("joint `{}` must be prismatic", SLIDES[i]))),
            };
            slide_links[i] = slide.child;
            let tip = poses[slide.child];
            let offset = [tip.x - centre.x, tip.y - centre.y];
            let distance = offset[0].hypot(offset[1]);
            if distance <= 0.0 {
                return Err(bad(format!(
                    "the tool of `{}` sits on the spindle axis: no side to cut from",
                    SLIDES[i]
                )));
            }
            tool_directions[i] = [offset[0] / distance, offset[1] / distance];
        }
        Ok(Self {
            settle_band: params.settle_band,
            record: CutRecord::default(),
            lathe,
            spindle_joint,
            spindle_sign,
            part_link,
            slide_joints,
            slide_links,
            feed_axes,
            tool_directions,
            spindle_centre: [centre.x, centre.y],
            shoulders: params.approach_gaps,
            cuts: [Cut::default(); TOOLS],
            process_factor: 1.0,
            power: 0.0,
        })
    }
}

impl Machine for ParallelLathe {
    fn signals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("feed_1", Unit::MillimetrePerRev, "tool 1 feed"),
            SignalSpec::new("feed_2", Unit::MillimetrePerRev, "tool 2 feed"),
            SignalSpec::new("cutting_force_1", Unit::Newton, "cutting force"),
            SignalSpec::new("cutting_force_2", Unit::Newton, "cutting force"),
            SignalSpec::new("spindle_power", Unit::Kilowatt, "spindle power"),
        ]
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        vec![SignalSpec::new(
            "cutting_torque",
            Unit::NewtonMetre,
            "spindle cutting torque",
        )]
    }

    fn scene(&self) -> Scene {
        let params = self.lathe.params();
        side_view(
            [params.tools[0].diameter, params.tools[1].diameter],
            self.shoulders,
        )
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        let spindle_speed = state.joint_velocities[self.spindle_joint];
        let turning = spindle_speed > MIN_CUTTING_SPINDLE_SPEED;
        let mut torque = 0.0;
        for i in 0..TOOLS {
            let travel = state.joint_positions[self.slide_joints[i]];
            let in_material = travel >= self.shoulders[i];
            if in_material {
                self.shoulders[i] = travel;
            }
            let tool = self.lathe.params().tools[i];
            let (feed, cutting_speed) = if turning {
                (
                    TAU * state.joint_velocities[self.slide_joints[i]] / spindle_speed,
                    tool.cutting_speed(spindle_speed),
                )
            } else {
                (0.0, 0.0)
            };
            let force = if in_material && turning {
                self.process_factor * tool.cutting_force(cutting_speed, feed)
            } else {
                0.0
            };
            torque += 0.5 * tool.diameter * force;
            self.cuts[i] = Cut {
                in_material,
                feed,
                force,
                cutting_speed,
            };
        }
        let [a, b] = self.cuts;
        self.power = a.cutting_speed * a.force + b.cutting_speed * b.force;
        signals.copy_from_slice(&[a.feed, b.feed, a.force, b.force, self.power]);
        diagnostics[0] = torque;
        self.record.observe(
            time,
            &self.cuts,
            self.power,
            self.lathe.params(),
            self.settle_band,
        );
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.process_factor = factor;
        true
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        for i in 0..TOOLS {
            let force = self.cuts[i].force;
            if force == 0.0 {
                continue;
            }
            let slide = &state.link_poses[self.slide_links[i]];
            let [ax, ay] = self.feed_axes[i];
            let feed = slide.rotate(ax, ay);
            loads.push(Load {
                link: self.slide_links[i],
                force: [-force * feed[0], -force * feed[1]],
                point: [slide.x, slide.y],
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            });
            // Tangential at the cut diameter, against the surface speed of the turning part.
            let [ux, uy] = self.tool_directions[i];
            let radius = 0.5 * self.lathe.params().tools[i].diameter;
            let surface = [-self.spindle_sign * uy, self.spindle_sign * ux];
            loads.push(Load {
                link: self.part_link,
                force: [-force * surface[0], -force * surface[1]],
                point: [
                    self.spindle_centre[0] + radius * ux,
                    self.spindle_centre[1] + radius * uy,
                ],
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            });
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        self.record
            .metrics(self.cuts, self.power, self.lathe.params().max_spindle_power)
    }
}

/// What the run is judged by: when both tools first cut, the settled forces and power, the time
/// to settle and how long each feed sat on a limit of Sudhakara eq (20).
#[derive(Debug, Clone, Default)]
struct CutRecord {
    /// Time both tools first cut, and their forces then.
    engaged: Option<(f64, [f64; TOOLS])>,
    /// Start of the current stretch with the power within the settle band, after engagement.
    in_band_since: Option<f64>,
    samples_cutting: usize,
    samples_on_feed_limit: [usize; TOOLS],
}

impl CutRecord {
    fn observe(
        &mut self,
        time: f64,
        cuts: &[Cut; TOOLS],
        power: f64,
        lathe: &LatheParams,
        settle_band: f64,
    ) {
        if self.engaged.is_none() && cuts.iter().all(|c| c.in_material && c.force > 0.0) {
            self.engaged = Some((time, cuts.map(|c| c.force)));
        }
        if self.engaged.is_none() {
            return;
        }
        self.samples_cutting += 1;
        let band = FEED_LIMIT_BAND * lathe.max_feed;
        for (count, cut) in self.samples_on_feed_limit.iter_mut().zip(cuts) {
            *count += usize::from(cut.feed <= band || cut.feed >= lathe.max_feed - band);
        }
        let settled =
            (power - lathe.max_spindle_power).abs() <= settle_band * lathe.max_spindle_power;
        self.in_band_since = match (settled, self.in_band_since) {
            (true, None) => Some(time),
            (true, since) => since,
            (false, _) => None,
        };
    }

    fn metrics(&self, cuts: [Cut; TOOLS], power: f64, max_power: f64) -> Vec<(String, f64)> {
        let (engaged_at, initial) = self.engaged.unwrap_or((f64::NAN, [f64::NAN; TOOLS]));
        let settle_time = self.in_band_since.map_or(f64::NAN, |t| t - engaged_at);
        let share = |count: usize| count as f64 / self.samples_cutting.max(1) as f64;
        let mut metrics = vec![("engaged_at".to_string(), engaged_at)];
        for (i, force) in initial.into_iter().enumerate() {
            metrics.push((format!("initial_force/tool_{}", i + 1), force));
        }
        for (i, cut) in cuts.into_iter().enumerate() {
            metrics.push((format!("settled_force/tool_{}", i + 1), cut.force));
        }
        metrics.push(("settled_power".into(), power));
        metrics.push(("power_error".into(), power - max_power));
        metrics.push(("time_to_settle".into(), settle_time));
        for i in 0..TOOLS {
            metrics.push((
                format!("feed_saturated_fraction/tool_{}", i + 1),
                share(self.samples_on_feed_limit[i]),
            ));
        }
        metrics
    }
}

/// Where the side view's part starts along x, m: right of the end view the URDF draws.
const SIDE_VIEW_X: f64 = 0.16;
/// Length of part drawn in the side view, m (a 3 s run feeds about 40 mm).
const SIDE_VIEW_LENGTH: f64 = 0.08;

/// Tool `i`'s tip in the side view: along the part axis by its slide's travel, on the part's edge
/// at its cut diameter (tool 1 above the axis, tool 2 below).
fn side_view_point(i: usize, diameter: f64, travel: f64) -> [f64; 2] {
    let side = if i == 0 { 1.0 } else { -1.0 };
    [SIDE_VIEW_X + travel, side * diameter / 2.0]
}

/// The URDF's end view (along the spindle) beside a side view where the feed shows: the part's
/// edges at each tool's cut diameter from where the tool meets it, and each tool tip tracing the
/// length it has turned.
fn side_view(diameters: [f64; TOOLS], starts: [f64; TOOLS]) -> Scene {
    let edges = (0..TOOLS)
        .map(|i| {
            let start = side_view_point(i, diameters[i], starts[i]);
            vec![start, [SIDE_VIEW_X + SIDE_VIEW_LENGTH, start[1]]]
        })
        .collect();
    let radius = diameters[0].max(diameters[1]) / 2.0;
    let markers = (0..TOOLS)
        .map(|i| Marker {
            name: format!("tool_{}", i + 1),
            color: colors::TOOL,
            label: format!("tool {}", i + 1),
            source: MarkerSource {
                x: Some(format!("{}.position", SLIDES[i])),
                y: None,
                scale: 1.0,
                origin: side_view_point(i, diameters[i], 0.0),
            },
            trace: true,
        })
        .collect();
    Scene {
        title: "lathe: end view (left), side view with the feed (right); m, y up".into(),
        bounds: Bounds {
            x: [-0.13, SIDE_VIEW_X + SIDE_VIEW_LENGTH + 0.02],
            y: [-0.14_f64.min(-radius - 0.03), 0.14_f64.max(radius + 0.03)],
        },
        drawings: vec![Drawing {
            name: "part_side_view".into(),
            color: colors::WORKPIECE,
            lines: edges,
            label: "part, side view".into(),
        }],
        markers,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = include_str!("../../../urdf/lathe.urdf");

    fn lathe(process: &str) -> (Mechanism, Result<ParallelLathe, MachineError>) {
        let mechanism = crate::urdf::load_str(URDF, "lathe.urdf").unwrap();
        let table: toml::Table = toml::from_str(process).unwrap();
        let machine = ParallelLathe::new(&mechanism, &table);
        (mechanism, machine)
    }

    /// Joints: spindle, slide_1, slide_2; links: ground, part, slide_1, slide_2.
    fn state(
        mechanism: &Mechanism,
        spindle_speed: f64,
        travel: [f64; 2],
        speed: [f64; 2],
    ) -> MechanismState {
        MechanismState {
            joint_positions: vec![0.0, travel[0], travel[1]],
            joint_velocities: vec![spindle_speed, speed[0], speed[1]],
            link_poses: mechanism.zero_pose(),
            link_velocities: vec![[0.0; 2]; 4],
            link_angular_velocities: vec![0.0; 4],
            loop_gaps: Vec::new(),
            body_poses: Vec::new(),
        }
    }

    fn measure(machine: &mut ParallelLathe, state: &MechanismState) -> [f64; 5] {
        let (mut signals, mut diagnostics) = ([0.0; 5], [0.0; 1]);
        machine.measure(0.0, state, &mut signals, &mut diagnostics);
        signals
    }

    #[test]
    fn nominal_feeds_cut_the_reference_forces_at_p_max_and_load_slides_and_spindle() {
        let (mechanism, machine) = lathe("approach_gaps = [0.0, 0.0]");
        let mut machine = machine.unwrap();
        let model = Lathe::new(LatheParams::default()).unwrap();
        let omega = model.params().spindle_speed;
        let speeds = model.nominal_feeds().map(|f| f * omega / TAU);
        let now = state(&mechanism, omega, [1e-3, 1e-3], speeds);
        let signals = measure(&mut machine, &now);
        let reference = model.reference_forces();
        for i in 0..TOOLS {
            assert!((signals[i] - model.nominal_feeds()[i]).abs() < 1e-15);
            assert!((signals[2 + i] - reference[i]).abs() < 1e-9 * reference[i]);
        }
        assert!((signals[4] - 20e3).abs() < 1e-6);

        let mut loads = Vec::new();
        machine.loads(0.0, &now, &mut loads);
        assert_eq!(loads.len(), 4);
        // Slides feed along −y: the cut pushes them back along +y.
        assert_eq!(loads[0].link, 2);
        assert!((loads[0].force[1] - reference[0]).abs() < 1e-9 * reference[0]);
        // On the part: F_i at radius D_i/2, against the rotation: torque −F_i D_i/2 about z.
        let torque: f64 = loads
            .iter()
            .filter(|l| l.link == 1)
            .map(|l| l.point[0] * l.force[1] - l.point[1] * l.force[0])
            .sum();
        let expected = -(reference[0] * 0.025 + reference[1] * 0.05);
        assert!(
            (torque - expected).abs() < 1e-9 * expected.abs(),
            "{torque}"
        );
    }

    #[test]
    fn tools_cut_only_past_the_air_gap_and_not_while_backing_off() {
        let (mechanism, machine) = lathe("approach_gaps = [2e-3, 2e-3]");
        let mut machine = machine.unwrap();
        let omega = 157.0;
        let forward = [0.01, 0.01];
        let force = |machine: &mut ParallelLathe, travel: f64, speed: f64| {
            measure(machine, &state(&mechanism, omega, [travel; 2], [speed; 2]))[2]
        };
        assert_eq!(force(&mut machine, 1e-3, forward[0]), 0.0, "still in air");
        assert!(force(&mut machine, 3e-3, forward[0]) > 0.0, "past the gap");
        assert_eq!(force(&mut machine, 2.5e-3, -0.01), 0.0, "backing off");
        assert_eq!(
            force(&mut machine, 2.8e-3, forward[0]),
            0.0,
            "back in the groove"
        );
        assert!(
            force(&mut machine, 3.1e-3, forward[0]) > 0.0,
            "on the shoulder again"
        );
        // A stopped spindle cuts nothing (feed per revolution has no meaning).
        let still = measure(&mut machine, &state(&mechanism, 0.0, [4e-3; 2], forward));
        assert_eq!(still, [0.0; 5]);
    }

    #[test]
    fn bad_process_tables_are_refused() {
        for (process, expected) in [
            ("approach_gaps = [0.0, -1.0]", "approach_gaps[1]"),
            ("settle_band = 0.0", "settle_band"),
            ("lathe = { max_feed = 0.0 }", "max_feed"),
            ("spindle = 1", "unknown field"),
        ] {
            let (_, machine) = lathe(process);
            let error = machine.err().unwrap().to_string();
            assert!(error.contains(expected), "{process}: {error}");
        }
        let mut mechanism = crate::urdf::load_str(URDF, "lathe.urdf").unwrap();
        mechanism.joints[1].motion = JointMotion::Revolute { sign: 1.0 };
        let error = ParallelLathe::new(&mechanism, &toml::Table::new())
            .err()
            .unwrap();
        assert!(
            error.to_string().contains("slide_1` must be prismatic"),
            "{error}"
        );
        mechanism.joints[0].name = "chuck".into();
        let error = ParallelLathe::new(&mechanism, &toml::Table::new())
            .err()
            .unwrap();
        assert!(matches!(error, MachineError::MissingPart { .. }), "{error}");
    }
}
