//! Milling after Kaliński & Galewski (2013, §3): the regenerative cut of a slender tool
//! ([`cut`]) and its stability lobes ([`stability`]).

pub mod cut;
pub mod stability;

pub use cut::{force_direction, CutForces, MillingCut, MillingCutParams, MillingError, MAX_FLUTES};
