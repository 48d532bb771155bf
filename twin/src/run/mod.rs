//! `Twin::run`, the one door in. Each step runs sense → control → actuate → observe → step
//! ([`session`]): world → state → machine signals → sensors → controller → efforts (clipped,
//! through the drives) → observers (the recording, the scenario's evaluators, the caller's) →
//! world.

mod evaluate;
mod layout;
mod observer;
mod operating;
mod plant_model;
mod record;
mod session;
mod simulator;
mod spectra;
mod stats;
mod summary;
mod table;
mod twin;
mod whole_run;

pub use layout::SignalLayout;
pub use observer::{Findings, Observer, ObserverError, StepView};
pub use operating::LinearizeError;
pub(crate) use operating::ModelParts;
pub use simulator::{Simulator, StepError};
pub use summary::{
    to_json, to_table, write_json, Divergence, FailureKind, Interruption, RunSummary,
};
pub use table::RunTable;
pub(crate) use twin::framed;
pub use twin::{SetpointSource, StopFlag, Twin, TwinError};

#[cfg(test)]
mod data_refusal_tests;
#[cfg(test)]
mod data_tests;
