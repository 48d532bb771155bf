//! Controllers for any mechanism: they need nothing of a machine but its joints' signals and
//! actuators, and the model-based ones the mechanism's equations of motion the engine lends.

pub mod computed_torque;
pub mod joint_pid;
mod joint_reference;
pub mod lqr;
mod model;
pub mod point_reference;
pub mod replay;
