//! What `twin compare` and `twin calibrate` read alike from their options and a scenario's
//! `[calibration]` table: the signals' noise σ and the numbers in the options.

use crate::failure::Failure;
use twin::CalibrationSpec;

/// The signals' noise σ: the table's, with `--noise NAME=SIGMA` on top.
pub fn noise_levels(
    given: &[String],
    spec: &CalibrationSpec,
) -> Result<Vec<(String, f64)>, Failure> {
    let mut noise: Vec<(String, f64)> = spec.noise.clone().into_iter().collect();
    if let Some((name, sigma)) = noise.iter().find(|(_, s)| !(s.is_finite() && *s > 0.0)) {
        return Err(Failure::usage(format!(
            "[calibration.noise] \"{name}\" = {sigma}: σ must be a finite number > 0, in the signal's SI unit (e.g. 1e-4)"
        )));
    }
    for entry in given {
        let context = format!("--noise {entry}");
        let (name, sigma) = entry
            .split_once('=')
            .ok_or_else(|| Failure::usage(format!("{context}: expected NAME=SIGMA")))?;
        let sigma = number(&context, sigma)?;
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(Failure::usage(format!(
                "{context}: σ must be a finite number > 0, in the signal's SI unit (e.g. {name}=1e-4)"
            )));
        }
        noise.retain(|(n, _)| n != name);
        noise.push((name.to_string(), sigma));
    }
    Ok(noise)
}

pub fn number(context: &str, text: &str) -> Result<f64, Failure> {
    match text.trim().parse::<f64>() {
        Ok(value) if value.is_finite() => Ok(value),
        _ => Err(Failure::usage(format!(
            "{context}: `{text}` is not a finite number"
        ))),
    }
}
