//! The twin's vocabulary, beneath both the engine (`twin`) and the controllers (`controllers`), as
//! Drake's `systems/framework` sits beneath `systems/controllers`.
//!
//! A controller acts on a machine only through joint efforts (torques on revolute joints, forces on
//! prismatic joints). It sees a [`Measurement`]: named sensor, task-space, process and reference
//! signals, laid out by the [`PlantInterface`] it is bound to at [`Controller::reset`]. Signals
//! carry their units ([`SignalSpec`], [`Unit`]); what a controller has to say goes out as
//! [`Event`]s. Controllers are chosen by name from a [`Registry`], and read their parameters from
//! TOML tables with [`parse_params`].
//!
//! The modules are private; every type has one path, from this crate's root.

#![warn(missing_docs)]

mod controller;
mod event;
mod params;
mod plant_model;
mod registry;
mod signal;

pub use controller::{
    parameter_message, Actuator, Controller, ControllerError, Measurement, PlantInterface,
};
pub use event::{Event, EventKind, EventLevel};
pub use params::{
    describe_toml_error, deserialize_table, from_table, parse_params, shortened, TableError,
};
pub use plant_model::{Coordinate, Dynamics, EffortKind, LoggedEfforts, ScenarioFiles};
pub use registry::{Constructor, Entry, Registry, ANY_MACHINE};
pub use signal::{signal_names, SignalSpec, Unit};
