//! `twin shadow`: the twin beside a running machine. Fed the machine's commands and
//! measurements (live over OPC UA with a map file, or a logged run played in), it estimates the
//! machine's state and tracked parameters, tests the innovations, reports anomalies with the
//! parameter that explains them, records it all and publishes it on its own OPC UA server.

mod args;
mod command;
mod feed;
mod publish;
mod report;

pub use args::ShadowArgs;
pub use command::shadow;
