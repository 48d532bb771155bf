//! What a recorded signal is: its name, the unit a person reads it in and the plot it belongs on.
//! Values stay SI inside the twin; a [`Unit`] converts them once, for display.

/// The unit a signal is shown in. Every variant converts from the SI value the twin computes
/// ([`Unit::from_si`]); [`Unit::label`] is what a plot shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Metres, shown in m.
    Metre,
    /// Metres, shown in mm.
    Millimetre,
    /// Metres, shown in µm.
    Micrometre,
    /// Metres per second, shown in m/s.
    MetrePerSecond,
    /// Metres per second, shown in mm/s.
    MillimetrePerSecond,
    /// Metres per second, shown in µm/s.
    MicrometrePerSecond,
    /// Metres per second squared, shown in m/s².
    MetrePerSecondSquared,
    /// Feed per revolution (SI m/rev), shown in mm/rev.
    MillimetrePerRev,
    /// Radians, shown in rad.
    Radian,
    /// Radians, shown in degrees (°), unwrapped.
    Degree,
    /// An angle wrapped to (−180°, 180°]: a turning joint's angle that would otherwise grow
    /// without bound and flatten every other angle on its plot.
    DegreeWrapped,
    /// Radians per second, shown in rad/s.
    RadianPerSecond,
    /// Radians per second squared, shown in rad/s².
    RadianPerSecondSquared,
    /// Revolutions per minute (SI rad/s), shown in rpm.
    Rpm,
    /// Newtons, shown in N.
    Newton,
    /// Newton-metres, shown in N·m.
    NewtonMetre,
    /// Watts, shown in W.
    Watt,
    /// Watts, shown in kW.
    Kilowatt,
    /// Joules, shown in J.
    Joule,
    /// Newton-seconds, shown in N·s.
    NewtonSecond,
    /// Amperes, shown in A.
    Ampere,
    /// Seconds, shown in s.
    Second,
    /// Seconds, shown in ms.
    Millisecond,
    /// A ratio, count, index or mode number.
    Dimensionless,
}

impl Unit {
    /// The label shown after a series name, e.g. `mm/rev`.
    pub fn label(self) -> &'static str {
        match self {
            Unit::Metre => "m",
            Unit::Millimetre => "mm",
            Unit::Micrometre => "µm",
            Unit::MetrePerSecond => "m/s",
            Unit::MillimetrePerSecond => "mm/s",
            Unit::MicrometrePerSecond => "µm/s",
            Unit::MetrePerSecondSquared => "m/s²",
            Unit::MillimetrePerRev => "mm/rev",
            Unit::Radian => "rad",
            Unit::Degree | Unit::DegreeWrapped => "°",
            Unit::RadianPerSecond => "rad/s",
            Unit::RadianPerSecondSquared => "rad/s²",
            Unit::Rpm => "rpm",
            Unit::Newton => "N",
            Unit::NewtonMetre => "N·m",
            Unit::Watt => "W",
            Unit::Kilowatt => "kW",
            Unit::Joule => "J",
            Unit::NewtonSecond => "N·s",
            Unit::Ampere => "A",
            Unit::Second => "s",
            Unit::Millisecond => "ms",
            Unit::Dimensionless => "1",
        }
    }

    /// The SI unit the twin's values of this unit are in (`m` for a signal shown in µm).
    pub fn si_label(self) -> &'static str {
        match self {
            Unit::Metre | Unit::Millimetre | Unit::Micrometre => "m",
            Unit::MetrePerSecond | Unit::MillimetrePerSecond | Unit::MicrometrePerSecond => "m/s",
            Unit::MetrePerSecondSquared => "m/s²",
            Unit::MillimetrePerRev => "m/rev",
            Unit::Radian | Unit::Degree | Unit::DegreeWrapped => "rad",
            Unit::RadianPerSecond | Unit::Rpm => "rad/s",
            Unit::RadianPerSecondSquared => "rad/s²",
            Unit::Newton => "N",
            Unit::NewtonMetre => "N·m",
            Unit::Watt | Unit::Kilowatt => "W",
            Unit::Joule => "J",
            Unit::NewtonSecond => "N·s",
            Unit::Ampere => "A",
            Unit::Second | Unit::Millisecond => "s",
            Unit::Dimensionless => "1",
        }
    }

    /// The displayed value of an SI value.
    pub fn from_si(self, value: f64) -> f64 {
        use std::f64::consts::PI;
        match self {
            Unit::DegreeWrapped => {
                let turns = ((value - PI) / std::f64::consts::TAU).ceil();
                (value - std::f64::consts::TAU * turns).to_degrees()
            }
            _ => value * self.scale(),
        }
    }

    /// Displayed units per SI unit.
    fn scale(self) -> f64 {
        match self {
            Unit::Millimetre | Unit::MillimetrePerSecond | Unit::MillimetrePerRev => 1e3,
            Unit::Millisecond => 1e3,
            Unit::Micrometre | Unit::MicrometrePerSecond => 1e6,
            Unit::Degree | Unit::DegreeWrapped => 180.0 / std::f64::consts::PI,
            Unit::Rpm => 60.0 / std::f64::consts::TAU,
            Unit::Kilowatt => 1e-3,
            _ => 1.0,
        }
    }
}

/// A recorded signal: its name in the machine's words, its display unit and the plot it joins.
/// Signals naming the same plot with the same unit are drawn together, whatever produced them
/// (a reference, the machine, a sensor, the controller): that is how a command meets what it
/// commands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SignalSpec {
    /// The signal's name in the recording, e.g. `ram_position` or `crank.velocity`.
    pub name: String,
    /// The unit it is shown in; its values stay SI.
    pub unit: Unit,
    /// The plot's title without the unit, in the machine's words (`ram position`, `feed`).
    pub plot: String,
}

impl SignalSpec {
    /// A signal `name` shown in `unit` on the plot titled `plot`.
    pub fn new(name: impl Into<String>, unit: Unit, plot: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            unit,
            plot: plot.into(),
        }
    }
}

/// The names of `specs`, in order.
pub fn signal_names(specs: &[SignalSpec]) -> Vec<String> {
    specs.iter().map(|s| s.name.clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_units_convert_from_si() {
        assert_eq!(Unit::Micrometre.from_si(2.5e-6), 2.5);
        assert!((Unit::Rpm.from_si(std::f64::consts::TAU) - 60.0).abs() < 1e-12);
        assert_eq!(Unit::Kilowatt.from_si(2.0e4), 20.0);
        assert!((Unit::MillimetrePerRev.from_si(5e-4) - 0.5).abs() < 1e-12);
        // −19 rad wraps to −19 + 6π ≈ −0.150 rad.
        let wrapped = Unit::DegreeWrapped.from_si(-19.0);
        assert!((wrapped - (-19.0 + 6.0 * std::f64::consts::PI).to_degrees()).abs() < 1e-9);
        assert!((Unit::DegreeWrapped.from_si(std::f64::consts::PI) - 180.0).abs() < 1e-9);
        assert_eq!(Unit::Newton.from_si(3.0), 3.0);
    }
}
