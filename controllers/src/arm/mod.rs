//! Machining-arm path-speed controllers (Ilyukhin et al. 2014) and their joint servos.

pub mod path_speed_adaptive;
pub mod path_speed_constant;
pub mod servo;
