//! The inverted Whitworth quick-return linkage: its closed-form kinematics ([`geometry`]) and its
//! reduced crank dynamics ([`dynamics`]).

pub mod dynamics;
pub mod geometry;

pub use geometry::{Geometry, GeometryError, Jacobian, Pose, Stroke};
