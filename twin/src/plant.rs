//! The URDF's physical values as scenario values (`[plant]`, or `urdf.…` keys in `set`/`--set`):
//! a study can sweep or draw a link's mass, inertia and centre of mass and a joint's damping,
//! friction, effort limit and spring stiffness without editing the URDF.
//!
//! ```toml
//! [plant.link.ram]
//! mass = 5.5          # kg; alone it scales izz with it (the same body, denser)
//! [plant.joint.crank]
//! damping = 0.02      # N·m·s/rad (N·s/m on a prismatic joint)
//! effort_limit = 30.0 # N·m (N)
//! [plant.joint.tool_x]
//! stiffness = 1.2e6   # N/m (N·m/rad): a joint's <spring>
//! ```

use crate::mechanism::Mechanism;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Values replacing the URDF's, by link and joint name.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantValues {
    pub link: BTreeMap<String, LinkValues>,
    pub joint: BTreeMap<String, JointValues>,
}

/// A link's mass properties; each one given replaces the URDF's `<inertial>` value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinkValues {
    /// kg. Without `izz`, the URDF's izz is scaled by mass / URDF mass (same shape).
    pub mass: Option<f64>,
    /// Moment of inertia about z through the centre of mass, kg·m².
    pub izz: Option<f64>,
    /// Centre of mass in the link's frame, m.
    pub com: Option<[f64; 2]>,
}

/// A joint's dynamics and drive limit; each one given replaces the URDF's value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointValues {
    /// Viscous damping, N·m·s/rad or N·s/m.
    pub damping: Option<f64>,
    /// Dry friction, N·m or N.
    pub friction: Option<f64>,
    /// Largest |effort|, N·m or N; only on a joint the URDF already drives.
    pub effort_limit: Option<f64>,
    /// Stiffness of the joint's `<spring>`, N/m or N·m/rad; only on a joint that has one.
    pub stiffness: Option<f64>,
}

impl PlantValues {
    /// Checks the values' ranges (names are checked against the URDF by [`PlantValues::apply`]).
    pub fn validate(&self) -> Result<(), String> {
        let positive = |key: String, value: Option<f64>| match value {
            Some(v) if !(v.is_finite() && v > 0.0) => Err(format!("{key} must be > 0, got {v}")),
            _ => Ok(()),
        };
        let non_negative = |key: String, value: Option<f64>| match value {
            Some(v) if !(v.is_finite() && v >= 0.0) => Err(format!("{key} must be ≥ 0, got {v}")),
            _ => Ok(()),
        };
        for (name, link) in &self.link {
            positive(format!("plant.link.{name}.mass"), link.mass)?;
            positive(format!("plant.link.{name}.izz"), link.izz)?;
            if link.com.is_some_and(|c| !c.iter().all(|x| x.is_finite())) {
                return Err(format!("plant.link.{name}.com must be finite"));
            }
        }
        for (name, joint) in &self.joint {
            non_negative(format!("plant.joint.{name}.damping"), joint.damping)?;
            non_negative(format!("plant.joint.{name}.friction"), joint.friction)?;
            non_negative(format!("plant.joint.{name}.stiffness"), joint.stiffness)?;
            positive(
                format!("plant.joint.{name}.effort_limit"),
                joint.effort_limit,
            )?;
        }
        Ok(())
    }

    /// The number a `[plant]` key stands for in `mechanism` (the URDF's, or the value written
    /// over it): `link.<name>.mass`/`izz`/`com.0`/`com.1`, `joint.<name>.damping`/`friction`/`effort_limit`/
    /// `stiffness`; `None` for any other key, or where the URDF has no such value.
    pub fn current(mechanism: &Mechanism, key: &[&str]) -> Option<f64> {
        match key {
            ["link", name, field] => {
                let link = mechanism.links.iter().find(|l| l.name == *name)?;
                let inertial = link.inertial.as_ref()?;
                match *field {
                    "mass" => Some(inertial.mass),
                    "izz" => Some(inertial.izz),
                    _ => None,
                }
            }
            ["link", name, "com", index] => {
                let link = mechanism.links.iter().find(|l| l.name == *name)?;
                let com = link.inertial.as_ref()?.centre_of_mass;
                com.get(index.parse::<usize>().ok()?).copied()
            }
            ["joint", name, field] => {
                let joint = mechanism.joints.iter().find(|j| j.name == *name)?;
                match *field {
                    "damping" => Some(joint.damping),
                    "friction" => Some(joint.friction),
                    "effort_limit" => joint.effort_limit,
                    "stiffness" => joint.spring.as_ref().map(|s| s.stiffness),
                    _ => None,
                }
            }
            _ => None,
        }
    }

    /// Writes the values into the mechanism read from the URDF; a name the URDF lacks, a link
    /// without `<inertial>` or a limit on an undriven joint is an error naming the key.
    pub fn apply(&self, mechanism: &mut Mechanism) -> Result<(), String> {
        for (name, values) in &self.link {
            let link = mechanism
                .links
                .iter_mut()
                .find(|l| &l.name == name)
                .ok_or_else(|| format!("plant.link.{name}: the URDF has no such link"))?;
            let inertial = link.inertial.as_mut().ok_or_else(|| {
                format!("plant.link.{name}: the link has no <inertial> (the fixed root)")
            })?;
            if let Some(mass) = values.mass {
                *inertial = inertial.with_mass(mass);
            }
            if let Some(izz) = values.izz {
                inertial.izz = izz;
            }
            if let Some(com) = values.com {
                inertial.centre_of_mass = com;
            }
        }
        for (name, values) in &self.joint {
            let joint = mechanism
                .joints
                .iter_mut()
                .find(|j| &j.name == name)
                .ok_or_else(|| format!("plant.joint.{name}: the URDF has no such joint"))?;
            joint.damping = values.damping.unwrap_or(joint.damping);
            joint.friction = values.friction.unwrap_or(joint.friction);
            if let Some(limit) = values.effort_limit {
                if joint.effort_limit.is_none() {
                    return Err(format!(
                        "plant.joint.{name}.effort_limit: the URDF does not drive this joint \
                         (give it a <limit effort> there first)"
                    ));
                }
                joint.effort_limit = Some(limit);
            }
            if let Some(stiffness) = values.stiffness {
                let spring = joint.spring.as_mut().ok_or_else(|| {
                    format!(
                        "plant.joint.{name}.stiffness: the URDF joint has no <spring> (give it \
                         one there first)"
                    )
                })?;
                spring.stiffness = stiffness;
            }
        }
        Ok(())
    }
}
