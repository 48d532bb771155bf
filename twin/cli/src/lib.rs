//! The `twin` command line and the applications built on the twin engine: one module per
//! command (its clap arguments and its body), the studies behind `twin sweep`, the seed papers'
//! reproductions behind `twin reproduce`, and the offline analyses behind `twin analyze`.
//! [`command_line`] ties the commands together; the `twin` binary (`main.rs`) only parses,
//! dispatches and exits.

pub mod analysis;
pub mod analyze;
pub mod bench;
pub mod calibrate;
pub mod command_line;
pub mod compare;
pub mod data_flags;
mod engine_option;
pub mod failure;
mod fit_figures;
mod fit_options;
mod fit_tables;
pub mod flags;
pub mod fmu;
pub mod frequency_response;
pub mod frf;
pub mod linearize;
pub mod list;
pub mod machine_link;
pub mod opcua;
pub mod papers;
mod reference;
pub mod reproduce;
pub mod run;
pub mod run_report;
pub mod salvage;
pub mod serve;
pub mod shadow;
mod signals;
pub mod study;
pub mod sweep;
pub mod usage;
