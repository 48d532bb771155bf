//! Controllers for any mechanism: they need nothing of a machine but its joints' signals and
//! actuators, or a logged run's efforts.

pub mod joint_pid;
mod joint_reference;
pub mod replay;
