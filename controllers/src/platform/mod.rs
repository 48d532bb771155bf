//! Two-wheeled platform controllers (Kalinski et al. 2013) with their model and guidance.

pub mod energy_optimal;
pub mod guidance;
pub mod model;
pub mod pid;
