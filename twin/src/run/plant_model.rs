//! What the twin lends its controller at reset (`framework::PlantInterface`): the exact engine's
//! equations of motion on the independent coordinates ([`MechanismDynamics`], the same
//! [`ReducedDynamics`] `twin linearize` differentiates) and the data files beside the scenario
//! ([`ScenarioFolder`], read as `twin calibrate` reads measured runs).

use crate::data::{PlantColumns, RunData};
use crate::mechanism::{Joint, JointMotion, Mechanism};
use crate::physics::{MechanismState, ReducedDynamics};
use framework::{Coordinate, Dynamics, EffortKind, LoggedEfforts, ScenarioFiles};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The mechanism's equations of motion, reduced to its independent coordinates at the scenario's
/// initial state: gravity, the joints' springs and viscous damping (the scenario's `[plant]`
/// values), no process loads. Made when a controller first asks for them.
pub(super) struct MechanismDynamics {
    mechanism: Mechanism,
    /// The scenario's points: name, link, where on the link in the plane (m).
    points: Vec<(String, usize, [f64; 2])>,
    gravity: [f64; 2],
    initial: Vec<(usize, f64, f64)>,
    actuated: Vec<usize>,
    made: OnceLock<(Vec<Coordinate>, Mutex<Evaluation>)>,
}

/// The reduced equations and the buffers one evaluation fills.
struct Evaluation {
    reduced: ReducedDynamics,
    /// The whole mechanism posed for a point.
    posed: MechanismState,
    /// Tree joint of each actuator on a joint (the plant's order); the machine's own follow.
    actuated: Vec<usize>,
    joint_efforts: Vec<f64>,
    state: Vec<f64>,
    rates: Vec<f64>,
}

impl MechanismDynamics {
    /// `mechanism` under `gravity` from its `initial` joint states (tree joint, position,
    /// velocity; the others at rest at zero), its `actuated` joints kept independent where the
    /// loops allow.
    pub(super) fn new(
        mechanism: &Mechanism,
        gravity: [f64; 2],
        initial: &[(usize, f64, f64)],
        actuated: &[usize],
    ) -> Self {
        Self {
            mechanism: mechanism.clone(),
            points: Vec::new(),
            gravity,
            initial: initial.to_vec(),
            actuated: actuated.to_vec(),
            made: OnceLock::new(),
        }
    }

    /// With the scenario's `points` (name, link, where on it in the plane, m).
    pub(super) fn with_points(mut self, points: Vec<(String, usize, [f64; 2])>) -> Self {
        self.points = points;
        self
    }

    /// The coordinates and the equations, made on first use.
    fn made(&self) -> &(Vec<Coordinate>, Mutex<Evaluation>) {
        self.made.get_or_init(|| {
            let mechanism = &self.mechanism;
            let joints = mechanism.joints.len();
            let mut state = MechanismState {
                joint_positions: vec![0.0; joints],
                joint_velocities: vec![0.0; joints],
                ..MechanismState::default()
            };
            for &(j, position, velocity) in &self.initial {
                state.joint_positions[j] = position;
                state.joint_velocities[j] = velocity;
            }
            let reduced =
                ReducedDynamics::new(mechanism, self.gravity, &state, &[], &self.actuated);
            let coordinates: Vec<Coordinate> = (reduced.coordinates().iter())
                .map(|&j| Coordinate {
                    joint: mechanism.joints[j].name.clone(),
                    kind: effort_kind(&mechanism.joints[j]),
                })
                .collect();
            let k = coordinates.len();
            let evaluation = Evaluation {
                reduced,
                posed: MechanismState::default(),
                actuated: self.actuated.clone(),
                joint_efforts: vec![0.0; joints],
                state: vec![0.0; 2 * k],
                rates: vec![0.0; 2 * k],
            };
            (coordinates, Mutex::new(evaluation))
        })
    }
}

impl Dynamics for MechanismDynamics {
    fn coordinates(&self) -> &[Coordinate] {
        &self.made().0
    }

    /// The `[initial]` positions of the independent coordinates.
    fn start(&self) -> Option<Vec<f64>> {
        let coordinates = self.made().0.iter();
        let position = |name: &str| {
            let j = self.mechanism.joint_index(name)?;
            let initial = self.initial.iter().find(|(i, _, _)| *i == j);
            Some(initial.map_or(0.0, |(_, position, _)| *position))
        };
        coordinates.map(|c| position(&c.joint)).collect()
    }

    fn acceleration(
        &self,
        position: &[f64],
        velocity: &[f64],
        efforts: &[f64],
        acceleration: &mut [f64],
    ) -> Result<(), String> {
        let (coordinates, evaluation) = self.made();
        let k = coordinates.len();
        if position.len() != k || velocity.len() != k || acceleration.len() != k {
            return Err(format!(
                "the equations of motion take {k} positions, velocities and accelerations"
            ));
        }
        let mut guard = evaluation
            .lock()
            .map_err(|_| "the equations of motion were left mid-evaluation".to_string())?;
        let Evaluation {
            reduced,
            actuated,
            joint_efforts,
            state,
            rates,
            ..
        } = &mut *guard;
        state[..k].copy_from_slice(position);
        state[k..].copy_from_slice(velocity);
        joint_efforts.fill(0.0);
        for (&j, &effort) in actuated.iter().zip(efforts) {
            joint_efforts[j] = effort;
        }
        // Centred on the state asked for, the loops' Newton solves keep the branch it is on.
        (reduced.recenter(state))
            .and_then(|()| reduced.rates(state, joint_efforts, rates))
            .map_err(|e| e.to_string())?;
        acceleration.copy_from_slice(&rates[k..]);
        Ok(())
    }

    fn points(&self) -> Vec<String> {
        self.points
            .iter()
            .map(|(name, _, _)| name.clone())
            .collect()
    }

    fn point(&self, name: &str, position: &[f64]) -> Result<[f64; 2], String> {
        let Some((_, link, at)) = self.points.iter().find(|(n, _, _)| n == name) else {
            return Err(format!(
                "the scenario has no point `{name}` ([points.{name}])"
            ));
        };
        let (coordinates, evaluation) = self.made();
        let k = coordinates.len();
        if position.len() != k {
            return Err(format!("a point's place takes {k} positions"));
        }
        let mut guard = evaluation
            .lock()
            .map_err(|_| "the equations of motion were left mid-evaluation".to_string())?;
        let Evaluation {
            reduced,
            posed,
            state,
            ..
        } = &mut *guard;
        state[..k].copy_from_slice(position);
        state[k..].fill(0.0);
        (reduced.recenter(state))
            .and_then(|()| reduced.read_state(state, posed))
            .map_err(|e| e.to_string())?;
        Ok(posed.link_poses[*link].apply(at[0], at[1]))
    }
}

/// The data files beside a scenario, read for its plant at its control period.
pub(super) struct ScenarioFolder {
    /// Where relative paths start (none: the working folder).
    folder: Option<PathBuf>,
    plant: PlantColumns,
    period: f64,
}

impl ScenarioFolder {
    /// Files found in `folder`, read for `plant` at the control `period`.
    pub(super) fn new(folder: Option<PathBuf>, plant: PlantColumns, period: f64) -> Self {
        Self {
            folder,
            plant,
            period,
        }
    }

    fn path(&self, file: &str) -> PathBuf {
        match &self.folder {
            Some(folder) => folder.join(file),
            None => Path::new(file).to_path_buf(),
        }
    }
}

impl ScenarioFiles for ScenarioFolder {
    fn efforts(&self, file: &str) -> Result<LoggedEfforts, String> {
        let data = RunData::read(&self.path(file), &[]).map_err(|e| e.to_string())?;
        let trace = (data.bind(&self.plant, self.period, 1)).map_err(|e| e.to_string())?;
        let efforts = (trace.commands.into_iter().zip(&self.plant.actuators))
            .map(|(column, (joint, unit))| {
                column.ok_or_else(|| {
                    format!(
                        "{}: no column \"effort.{joint} [{unit}]\"; a replay needs one per actuator",
                        trace.source
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(LoggedEfforts {
            source: trace.source,
            start_time: trace.start_time,
            period: self.period,
            efforts,
        })
    }

    fn positions(&self, file: &str, unit: &str) -> Result<Vec<[f64; 2]>, String> {
        let data = RunData::read(&self.path(file), &[]).map_err(|e| e.to_string())?;
        let source = &data.source;
        if let Some(bad) = data.unread.iter().find(|c| c.name == "position") {
            let row = bad.row.map_or(String::new(), |row| format!("row {row}, "));
            return Err(format!(
                "{source}: {row}column \"position\": {}",
                bad.reason
            ));
        }
        let column = data.column("position").filter(|c| !c.unit.is_empty());
        let column = column.ok_or_else(|| {
            format!("{source}: no column \"position [{unit}]\" (with its unit); a reference table has `time` and `position`")
        })?;
        let wanted = PlantColumns {
            actuators: Vec::new(),
            signals: vec![("position".to_string(), unit.to_string())],
        };
        let (_, _, factor) = (wanted.bind_column("position", &column.unit))
            .map_err(|reason| format!("{source}: column \"position\": {reason}"))?;
        Ok((data.time.iter().zip(&column.values))
            .map(|(&t, &p)| [t, p * factor])
            .collect())
    }
}

/// The effort a joint takes: a force on a prismatic joint, else a torque.
pub(crate) fn effort_kind(joint: &Joint) -> EffortKind {
    match joint.motion {
        JointMotion::Prismatic { .. } => EffortKind::Force,
        _ => EffortKind::Torque,
    }
}
