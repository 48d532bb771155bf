//! Analyses of a machine's reduced model, behind `twin analyze` and `twin reproduce lathe`: the
//! lathe's power loop and its phase plane ([`lathe`]), and a milling scenario's stability lobes
//! checked by time-domain runs ([`milling`]).

pub mod error;
mod files;
pub mod lathe;
pub mod milling;

pub use error::AnalysisError;
