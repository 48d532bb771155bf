//! Range checks of controller parameters: each returns the value, or a
//! [`ControllerError::BadParameter`] that names the key and the value.

use framework::ControllerError;

/// `value` is a finite number (TOML rejects none, a Rust caller may pass any).
pub(crate) fn finite(controller: &str, key: &str, value: f64) -> Result<f64, ControllerError> {
    require(
        controller,
        key,
        value,
        value.is_finite(),
        "must be a finite number",
    )
}

/// `value` is finite and > 0.
pub(crate) fn positive(controller: &str, key: &str, value: f64) -> Result<f64, ControllerError> {
    let value = finite(controller, key, value)?;
    require(controller, key, value, value > 0.0, "must be > 0")
}

/// `value` is finite and ≥ 0.
pub(crate) fn non_negative(
    controller: &str,
    key: &str,
    value: f64,
) -> Result<f64, ControllerError> {
    let value = finite(controller, key, value)?;
    require(controller, key, value, value >= 0.0, "must be ≥ 0")
}

/// `value` when `holds`, else the error naming `key`, the value and `reason`.
pub(crate) fn require(
    controller: &str,
    key: &str,
    value: f64,
    holds: bool,
    reason: &str,
) -> Result<f64, ControllerError> {
    if holds {
        Ok(value)
    } else {
        Err(ControllerError::parameter(controller, key, value, reason))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_key_and_the_value() {
        assert_eq!(positive("c", "k", 2.0), Ok(2.0));
        assert_eq!(non_negative("c", "k", 0.0), Ok(0.0));
        let message = |e: ControllerError| e.to_string();
        assert_eq!(
            message(positive("c", "k", 0.0).unwrap_err()),
            "controller `c`: params.k = 0: must be > 0"
        );
        assert_eq!(
            message(non_negative("c", "a.b", -1.5).unwrap_err()),
            "controller `c`: params.a.b = -1.5: must be ≥ 0"
        );
        assert_eq!(
            message(positive("c", "k", f64::NAN).unwrap_err()),
            "controller `c`: params.k = NaN: must be a finite number"
        );
        assert_eq!(
            message(positive("c", "k", -1e300).unwrap_err()),
            "controller `c`: params.k = -1e300: must be > 0"
        );
    }
}
