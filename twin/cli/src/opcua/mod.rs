//! The OPC UA pieces the live commands share: where a server listens and whether it may
//! (`endpoint`), certificates, users and passwords (`security`), and units as OPC UA
//! `EUInformation` (`units`). `twin serve`, the shadow's machine link and its publisher use
//! them alike.

pub(crate) mod endpoint;
pub(crate) mod security;
pub(crate) mod units;

pub use endpoint::{Endpoint, EndpointError};
pub use security::{Security, SecurityError, PASSWORD_ENV};
