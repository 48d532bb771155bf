//! Milling spindle-speed controllers (Kaliński & Galewski 2013) and their speed loop.

pub mod spindle_constant;
pub mod spindle_optimal_linear;
pub mod spindle_programme;
pub mod spindle_speed;
