//! What one scenario's twin reads and writes, its actuators and plant signals with their SI
//! units, and what a data column is to it.

use super::units;
use crate::recording::ColumnRole;

/// What one scenario's twin reads and writes: its actuators and plant signals with their SI
/// units, from a `Simulator` or a run's `SignalLayout` (made by the run: `run/table.rs`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlantColumns {
    /// Per actuator: its joint and its command's SI unit (`N`, `N·m`, or `A` for a drive that
    /// takes a current).
    pub actuators: Vec<(String, String)>,
    /// Per plant signal: its name and SI unit.
    pub signals: Vec<(String, String)>,
}

impl PlantColumns {
    /// What the column `name` is to this plant: its role and its index among the actuators
    /// (a command) or the signals (a measured or true signal); `None` for a name it lacks.
    pub fn role_of(&self, name: &str) -> Option<(ColumnRole, usize)> {
        let signal = |name: &str| self.signals.iter().position(|(s, _)| s == name);
        if let Some(k) = signal(name) {
            return Some((ColumnRole::Measured, k));
        }
        if let Some(joint) = name.strip_prefix("effort.") {
            let actuator = self.actuators.iter().position(|(a, _)| a == joint);
            if let Some(a) = actuator {
                return Some((ColumnRole::Command, a));
            }
        }
        let k = signal(name.strip_prefix("true.")?)?;
        Some((ColumnRole::True, k))
    }

    /// Binds a column given by name and unit (a live machine's mapped node): its role, its
    /// index among the actuators or signals and the factor that takes its values to SI; the
    /// refusal says which names or units fit.
    pub fn bind_column(&self, name: &str, unit: &str) -> Result<(ColumnRole, usize, f64), String> {
        let (role, index) = self.role_of(name).ok_or_else(|| {
            let signals = self.signals.iter().map(|(s, _)| s.as_str());
            let efforts = self.actuators.iter().map(|(a, _)| format!("effort.{a}"));
            let known: Vec<String> = efforts.chain(signals.map(str::to_owned)).collect();
            format!(
                "`{name}` is not a column of this plant (known: {})",
                known.join(", ")
            )
        })?;
        let si = match role {
            ColumnRole::Command => &self.actuators[index].1,
            ColumnRole::Measured | ColumnRole::True => &self.signals[index].1,
        };
        let factor = units::factor(unit, name, si)?;
        Ok((role, index, factor))
    }

    /// The column name of the actuator or signal `name` in `role`: `effort.<actuator>`,
    /// `<signal>` or `true.<signal>`.
    pub fn column_name(role: ColumnRole, name: &str) -> String {
        match role {
            ColumnRole::Command => format!("effort.{name}"),
            ColumnRole::Measured => name.to_owned(),
            ColumnRole::True => format!("true.{name}"),
        }
    }
}
