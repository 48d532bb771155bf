//! Controllers for any mechanism: they need nothing of a machine but its joints' signals and
//! actuators.

pub mod joint_pid;
