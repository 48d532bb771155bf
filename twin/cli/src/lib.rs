//! The applications built on the twin engine: the studies behind `twin sweep`, the seed papers'
//! reproductions behind `twin reproduce`, and the offline analyses behind `twin analyze`. The
//! `twin` binary (`main.rs`) is their command line.

pub mod analysis;
pub mod frf;
pub mod reproduce;
pub mod study;
