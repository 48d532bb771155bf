//! Machines: what each mechanism measures in its own words (task-space and process signals), the
//! process loads it suffers, its drives (or the scenario's ideal ones, [`actuators`]), and the
//! figures a run of it is judged by.

mod actuators;
mod arm;
mod catalogue;
mod error;
mod feed_axis;
mod force_table;
mod generic;
mod joint_drives;
mod lathe;
mod machine;
mod milling;
mod parts;
mod platform;
mod points;
mod whitworth;
mod with_points;

pub use actuators::{ActuatorKind, ActuatorSpec, ActuatorSpecs};
pub use catalogue::build;
pub use error::MachineError;
pub use force_table::ForceTable;
pub use generic::GENERIC;
pub use machine::{effort_unit, Excitation, Machine, Stability};
pub use points::{PointAt, PointSpec, PointSpecs, SpringSpec};
