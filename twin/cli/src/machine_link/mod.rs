//! The OPC UA plumbing of `twin shadow`, the twin watching a running machine: the machine map
//! ([`map`]: which node carries which of the twin's columns), the link that subscribes to the
//! machine's server and survives its restarts ([`link`]), and the shadow's own server that
//! publishes what the shadow makes of the machine ([`publish`]). Binding the columns and units
//! to a twin is the caller's.

pub mod error;
pub mod link;
pub mod map;
pub mod publish;

pub use error::LinkError;
pub use link::{LinkEvent, LinkOptions, MachineLink};
pub use map::{MachineMap, MappedNode};
pub use publish::{PublishedValue, PublishedVariable, ShadowServer, VariableKind};
