//! Machine models of the twin: analytic kinematics, process and disturbance models, references.
//! Pure math in SI units; nothing here knows the simulator or the recording.

pub mod arm_milling;
pub mod arm_path;
pub mod drive;
pub mod lathe;
pub mod micromilling;
pub mod milling;
pub mod milling_stability;
pub mod platform_path;
pub mod reference;
pub mod serial_chain;
pub mod tyre;
pub mod velocity_profile;
pub mod whitworth;
pub mod whitworth_dynamics;
