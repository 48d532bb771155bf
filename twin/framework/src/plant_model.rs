//! What the engine lends a controller besides its signals, at reset: the mechanism's equations of
//! motion ([`Dynamics`], for a law that inverts or linearises them) and the data files its
//! parameters name ([`ScenarioFiles`], read at the engine's edge). A controller bound to a real
//! machine, or in a unit test, may be lent neither.

use std::fmt;

/// What an actuated joint takes as effort.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffortKind {
    /// N·m on a revolute or continuous joint.
    Torque,
    /// N on a prismatic joint.
    Force,
}

impl fmt::Display for EffortKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Torque => "torque (a revolute joint)",
            Self::Force => "force (a prismatic joint)",
        })
    }
}

/// One independent coordinate of the mechanism: a joint whose position and velocity are state.
#[derive(Debug, Clone, PartialEq)]
pub struct Coordinate {
    /// The joint, as the URDF names it (its signals are `<joint>.position`, `<joint>.velocity`).
    pub joint: String,
    /// Whether it turns (rad, a torque moves it) or slides (m, a force moves it).
    pub kind: EffortKind,
}

/// The mechanism's equations of motion as the engine integrates them, on its independent
/// coordinates (a tree's joints; a closed loop's joints less those its loops determine, the
/// actuated ones kept where the loops allow): `M(q)·q̈ + h(q, q̇) = τ`, with gravity, the joints'
/// springs and viscous damping in h. Left out: dry friction, joint stops and the machine's
/// process loads (a scenario's point forces and springs).
pub trait Dynamics: Send + Sync {
    /// The independent coordinates, in the order of every slice below.
    fn coordinates(&self) -> &[Coordinate];

    /// q̈ at the state (q, q̇) under `efforts` (one per actuator, in the order of
    /// [`PlantInterface::actuators`](crate::PlantInterface::actuators), N·m or N), into
    /// `acceleration`; an error (one line) where the loops do not close.
    fn acceleration(
        &self,
        position: &[f64],
        velocity: &[f64],
        efforts: &[f64],
        acceleration: &mut [f64],
    ) -> Result<(), String>;

    /// The independent coordinates where the run starts (the scenario's `[initial]`, 0 where it
    /// gives none), in [`Dynamics::coordinates`]' order; `None` where the plant does not say.
    fn start(&self) -> Option<Vec<f64>> {
        None
    }

    /// The scenario's points (`[points.<name>]`) [`Dynamics::point`] places, by name.
    fn points(&self) -> Vec<String> {
        Vec::new()
    }

    /// Where the scenario's point `name` (`[points.<name>]`) is with the independent
    /// coordinates at `position`: [x, y] in the machine's plane, m; an error (one line) naming
    /// the point if there is none, or where the loops do not close.
    fn point(&self, name: &str, position: &[f64]) -> Result<[f64; 2], String> {
        let _ = position;
        Err(format!("the plant's equations know no point `{name}`"))
    }
}

/// The efforts a logged run commanded, per actuator, on the control period's grid: row k holds
/// over `[start_time + k·period, start_time + (k+1)·period)`.
#[derive(Debug, Clone, PartialEq)]
pub struct LoggedEfforts {
    /// The file, as the engine found it.
    pub source: String,
    /// Time of the first row, s.
    pub start_time: f64,
    /// The grid's step (the scenario's control period), s.
    pub period: f64,
    /// Per actuator (the plant's order), one effort per row, SI (N·m or N).
    pub efforts: Vec<Vec<f64>>,
}

/// The data files a controller's parameters name, found beside the scenario and read as the
/// engine reads measured runs (units converted to SI, every refusal one line naming the file and
/// the row or column).
pub trait ScenarioFiles: Send + Sync {
    /// A run's table (the format `twin run --csv` writes): its `effort.<joint>` column for every
    /// actuator, held from row to row onto the control period's grid.
    fn efforts(&self, file: &str) -> Result<LoggedEfforts, String>;

    /// A table of `time` and `position` rows, the position converted to `unit` (`rad` or `m`):
    /// `[time s, position]` per row, times strictly increasing.
    fn positions(&self, file: &str, unit: &str) -> Result<Vec<[f64; 2]>, String>;
}
