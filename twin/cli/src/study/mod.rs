//! Studies: many runs of one scenario over grid axes (a Cartesian product of values) and
//! random axes (values drawn per run), run in parallel and scored against specs.
//!
//! Run `i` of a study with `G` grid points and `S` samples per point is grid point `i / S`
//! (the last grid axis varies fastest) and sample `i % S`. Its seed — the scenario's sensor
//! noise and its random draws — comes from (study seed, `i`) alone ([`axis::run_seed`]), so
//! `--only i` repeats it bit for bit, on any machine, in any shard.
//!
//! Every axis value is a scenario value set as `set` sets it, in the order the axes are
//! given; the key `controller` switches the controller (its parameters start from defaults).

pub mod axis;
mod definition;
mod error;
mod execute;
mod files;
mod merge;
mod plots;
mod results;

pub use definition::{RunPlan, Study, StudyDefinition};
pub use error::StudyError;
pub use execute::{run_study, RecordMode, Shard, StudyOptions, StudyOutcome};
pub use merge::{merge, Merged};
pub use results::{report_table, Spec};
