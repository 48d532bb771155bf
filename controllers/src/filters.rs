//! The first-order filters of `models::filters`, and their errors as a controller's bad
//! parameters.

use framework::ControllerError;
pub use models::filters::{FilterError, FirstOrderFilter};

/// A filter's error as a controller's bad parameter.
pub trait FilterParameter {
    /// The error as a bad parameter of `controller`, whose entry `key` set the time constant.
    fn for_parameter(&self, controller: &str, key: &str) -> ControllerError;
}

impl FilterParameter for FilterError {
    fn for_parameter(&self, controller: &str, key: &str) -> ControllerError {
        let (value, reason) = match *self {
            Self::NotPositive { value, .. } => (value, "must be finite and > 0"),
            Self::Negative { value, .. } => (value, "must be finite and ≥ 0"),
        };
        ControllerError::parameter(controller, key, value, reason)
    }
}
