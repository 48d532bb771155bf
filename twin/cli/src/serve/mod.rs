//! `twin serve`: a scenario's run as a virtual machine over OPC UA. The client writes the
//! actuators' commands (or, with the scenario's controller inside, its setpoint) and reads the
//! measured signals; the run is paced to the wall clock or advanced in lockstep by the client.

mod address_space;
mod command;
mod controller;
mod error;
mod pacing;
mod publisher;
mod sampling;
mod server;
mod shared;

pub use crate::opcua::{Security, SecurityError, PASSWORD_ENV};
pub use command::{serve, ServeArgs};
pub use error::ServeError;
