//! What a drive's data sheet must hold: finite, positive values (the gear motor's, the current
//! amplifier's).

use thiserror::Error;

/// A data sheet's field that is zero, negative or not finite.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{name} must be finite and > 0, got {value}")]
pub struct NotPositive {
    /// The field's name.
    pub name: &'static str,
    /// The refused value, in the field's SI unit.
    pub value: f64,
}

/// Checks every `(name, value)` of `fields` is finite and positive; the first that is not is
/// named.
pub fn all_positive(fields: &[(&'static str, f64)]) -> Result<(), NotPositive> {
    match fields.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        Some(&(name, value)) => Err(NotPositive { name, value }),
        None => Ok(()),
    }
}
