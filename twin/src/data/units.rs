//! The units a data file may give its columns in, each with the SI unit it converts to and the
//! factor that does: the twin's own display units (mm, µm, °, rpm, kW, …), a few more a machine's
//! logger writes (m/min, kN, N·mm, mA), and the ASCII spellings of all (`um`, `deg`, `N.m`,
//! `m/s^2`).

use std::f64::consts::{PI, TAU};

const DEGREE: f64 = PI / 180.0;

/// Every spelling known: the spelling, its SI unit (as [`framework::Unit::si_label`] writes it)
/// and the SI value of one of it. The first spelling of each factor is the one a hint names.
const UNITS: &[(&str, &str, f64)] = &[
    ("m", "m", 1.0),
    ("mm", "m", 1e-3),
    ("µm", "m", 1e-6),
    ("μm", "m", 1e-6),
    ("um", "m", 1e-6),
    ("m/s", "m/s", 1.0),
    ("mm/s", "m/s", 1e-3),
    ("µm/s", "m/s", 1e-6),
    ("μm/s", "m/s", 1e-6),
    ("um/s", "m/s", 1e-6),
    ("m/min", "m/s", 1.0 / 60.0),
    ("mm/min", "m/s", 1e-3 / 60.0),
    ("m/s²", "m/s²", 1.0),
    ("m/s^2", "m/s²", 1.0),
    ("m/s2", "m/s²", 1.0),
    ("mm/s²", "m/s²", 1e-3),
    ("mm/s^2", "m/s²", 1e-3),
    ("m/rev", "m/rev", 1.0),
    ("mm/rev", "m/rev", 1e-3),
    ("rad", "rad", 1.0),
    ("deg", "rad", DEGREE),
    ("°", "rad", DEGREE),
    ("rad/s", "rad/s", 1.0),
    ("deg/s", "rad/s", DEGREE),
    ("°/s", "rad/s", DEGREE),
    ("rpm", "rad/s", TAU / 60.0),
    ("rev/min", "rad/s", TAU / 60.0),
    ("rad/s²", "rad/s²", 1.0),
    ("rad/s^2", "rad/s²", 1.0),
    ("rad/s2", "rad/s²", 1.0),
    ("deg/s²", "rad/s²", DEGREE),
    ("deg/s^2", "rad/s²", DEGREE),
    ("N", "N", 1.0),
    ("kN", "N", 1e3),
    ("N·m", "N·m", 1.0),
    ("N.m", "N·m", 1.0),
    ("Nm", "N·m", 1.0),
    ("N*m", "N·m", 1.0),
    ("N·mm", "N·m", 1e-3),
    ("N.mm", "N·m", 1e-3),
    ("Nmm", "N·m", 1e-3),
    ("kN·m", "N·m", 1e3),
    ("kN.m", "N·m", 1e3),
    ("W", "W", 1.0),
    ("kW", "W", 1e3),
    ("J", "J", 1.0),
    ("kJ", "J", 1e3),
    ("N·s", "N·s", 1.0),
    ("N.s", "N·s", 1.0),
    ("Ns", "N·s", 1.0),
    ("A", "A", 1.0),
    ("mA", "A", 1e-3),
    ("s", "s", 1.0),
    ("ms", "s", 1e-3),
    ("1", "1", 1.0),
    ("-", "1", 1.0),
];

/// The SI value of one `unit` for a column of `name`, whose values are in the SI unit `si`; the
/// refusal names the column's signal and the units that fit it.
pub(crate) fn factor(unit: &str, name: &str, si: &str) -> Result<f64, String> {
    let unit = unit.trim();
    match UNITS.iter().find(|(spelling, _, _)| *spelling == unit) {
        Some(&(_, to, factor)) if to == si => Ok(factor),
        // An SI unit the table lacks is taken as written.
        None if unit == si => Ok(1.0),
        Some(_) => Err(format!(
            "unit {unit} does not fit {name}, which is in {si} ({})",
            hint(si)
        )),
        None => Err(format!(
            "unit {unit} is not known; {name} is in {si} ({})",
            hint(si)
        )),
    }
}

/// The refusal of a column of `name` without a unit, giving it its SI unit `si` as the
/// example.
pub(super) fn missing(name: &str, si: &str) -> String {
    format!(
        "no unit: give it in brackets after the name, e.g. \"{name} [{si}]\", or in a units row \
         under the header"
    )
}

/// `values` (in a unit of SI value `factor`) in SI; bit-identical for an SI unit.
pub(super) fn to_si(values: &[f64], factor: f64) -> Vec<f64> {
    if factor == 1.0 {
        values.to_vec()
    } else {
        values.iter().map(|v| v * factor).collect()
    }
}

/// "give m, mm or µm": the units that convert to `si`, one spelling each.
fn hint(si: &str) -> String {
    let mut spellings: Vec<&str> = Vec::new();
    let mut factors: Vec<f64> = Vec::new();
    for &(spelling, to, factor) in UNITS {
        if to == si && !factors.contains(&factor) {
            spellings.push(spelling);
            factors.push(factor);
        }
    }
    match spellings.as_slice() {
        [] => format!("give {si}"),
        [one] => format!("give {one}"),
        [rest @ .., last] => format!("give {} or {last}", rest.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::Unit;

    /// A file written in any unit the twin itself displays reads back to SI: the table agrees
    /// with the display units' own scales.
    #[test]
    fn every_display_unit_reads_back_to_si() {
        use Unit::*;
        let all = [
            Metre,
            Millimetre,
            Micrometre,
            MetrePerSecond,
            MillimetrePerSecond,
            MicrometrePerSecond,
            MetrePerSecondSquared,
            MillimetrePerRev,
            Radian,
            Degree,
            DegreeWrapped,
            RadianPerSecond,
            RadianPerSecondSquared,
            Rpm,
            Newton,
            NewtonMetre,
            Watt,
            Kilowatt,
            Joule,
            NewtonSecond,
            Ampere,
            Second,
            Millisecond,
            Dimensionless,
        ];
        for unit in all {
            let shown = unit.from_si(1.0);
            let back = factor(unit.label(), "x", unit.si_label()).unwrap_or(f64::NAN) * shown;
            assert!((back - 1.0).abs() < 1e-12, "{unit:?}: {}", unit.label());
        }
    }
}
