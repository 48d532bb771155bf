//! Machine models of the twin: analytic kinematics, process and disturbance models, references.
//! Pure math in SI units; nothing here knows the simulator or the recording.

pub mod lathe;
pub mod micromilling;
pub mod reference;
pub mod velocity_profile;
pub mod whitworth;
pub mod whitworth_dynamics;
