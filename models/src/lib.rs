//! Machine models of the twin: analytic kinematics, process and disturbance models, references.
//! Pure math in SI units; nothing here knows the simulator or the recording.
//!
//! One module per machine, named as the machine is everywhere in the twin ([`whitworth`], [`arm`],
//! [`platform`], [`feed_axis`], [`lathe`], [`milling`]), then the models they share: drives
//! ([`drive`], [`gear_motor`], [`current_amplifier`], their [`data_sheet`]s), first-order filters ([`filters`]), references ([`reference`](mod@reference), [`velocity_profile`]) and the
//! independent serial-chain dynamics the engine is checked against ([`serial_chain`]).

#![warn(missing_docs)]

pub mod arm;
pub mod feed_axis;
pub mod filters;
pub mod lathe;
pub mod milling;
pub mod platform;
pub mod whitworth;

pub mod current_amplifier;
pub mod data_sheet;
pub mod drive;
pub mod gear_motor;
pub mod reference;
pub mod serial_chain;
pub mod velocity_profile;
