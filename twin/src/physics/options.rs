//! The physics' configuration, as a scenario gives it: which engine steps the mechanism
//! (`[solver]`), the rigid bodies beside the machine (`[[bodies]]`: a clamp, a wall, a workpiece, a
//! box), the pairs that touch by design (`[[allowed_contacts]]`), and how contacts are resolved
//! (`[contact]`, rapier engine only).

use crate::mechanism::{convex_hull, polygon_area, Outline, Pose2, Shape};
use serde::Deserialize;

/// Largest RK4 substep count per physics step.
pub const MAX_SUBSTEPS: usize = 64;

/// `[solver]`: the engine and its settings. The exact engine's RK4 substeps stay the scenario's
/// top-level `substeps`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SolverOptions {
    /// Which engine steps the mechanism: exact by default.
    pub engine: Engine,
    /// How the exact engine advances a substep: RK4 by default.
    pub integrator: Integrator,
    /// Rapier substeps per physics step.
    pub rapier_substeps: usize,
    /// Rapier's internal PGS iterations per substep.
    pub rapier_iterations: usize,
    /// Rapier's stabilization (position correction) iterations per substep.
    pub rapier_stabilization_iterations: usize,
}

/// Measured on the Whitworth linkage: 4 substeps, 2 PGS iterations and no stabilization
/// iteration close the loops to 0.67 µm (the guide, *The engines*).
impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            engine: Engine::Exact,
            integrator: Integrator::Rk4,
            rapier_substeps: 4,
            rapier_iterations: 2,
            rapier_stabilization_iterations: 0,
        }
    }
}

/// Which engine steps the mechanism.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Engine {
    /// RK4 on the constrained equations of motion, loop closures to 1e-12.
    #[default]
    Exact,
    /// Rapier's own pipeline: multibody joints, impulse joints for the loops, contacts.
    Rapier,
}

impl Engine {
    /// The name a scenario and `--engine` use.
    pub fn name(self) -> &'static str {
        match self {
            Engine::Exact => "exact",
            Engine::Rapier => "rapier",
        }
    }
}

/// How the exact engine advances the constrained equations over a substep (`[solver]
/// integrator`). Whichever it is, the loops are then closed to 1e-12 m and the velocities
/// projected on them, as after every substep.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Classical Runge–Kutta, fourth order: four evaluations of the equations per substep.
    #[default]
    Rk4,
    /// The explicit midpoint rule, second order: two evaluations.
    Midpoint,
    /// Semi-implicit (symplectic) Euler, first order: one evaluation, the velocity first and
    /// the position with the new velocity (MuJoCo's default integrator is of this kind).
    SemiImplicitEuler,
}

impl Integrator {
    /// The name a scenario uses.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Rk4 => "rk4",
            Integrator::Midpoint => "midpoint",
            Integrator::SemiImplicitEuler => "semi_implicit_euler",
        }
    }
}

/// `[contact]`: how the rapier engine resolves contacts.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ContactOptions {
    /// Coulomb friction coefficient of every contact.
    pub friction: f64,
    /// Restitution coefficient (0: no bounce).
    pub restitution: f64,
}

impl Default for ContactOptions {
    fn default() -> Self {
        Self {
            friction: 0.5,
            restitution: 0.0,
        }
    }
}

/// One `[[bodies]]` entry: a rigid body beside the machine, in the world frame.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Its name in events and `[[allowed_contacts]]`; distinct from every link's.
    pub name: String,
    /// Static (fixed in the world) or free (moved by contacts and gravity).
    #[serde(default)]
    pub kind: BodyKind,
    /// Where its frame is: x, y (m) and angle (rad).
    #[serde(default)]
    pub pose: [f64; 3],
    /// Its shapes, in its frame.
    pub shapes: Vec<BodyShape>,
    /// A free body's mass, kg (its inertia follows from the shapes at uniform density).
    pub mass: Option<f64>,
}

/// Whether a `[[bodies]]` entry moves.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum BodyKind {
    /// Fixed in the world: a clamp, a wall.
    #[default]
    Static,
    /// Moved by contacts and gravity (rapier engine): a box, a workpiece on the table.
    Free,
}

/// A body's shape: exactly one of `size` (a box, full sizes), `radius` (a disc) or `points` (a
/// convex polygon), at `origin` (x, y, angle) in the body's frame.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyShape {
    /// A box's full width and height [x, y], m.
    pub size: Option<[f64; 2]>,
    /// A disc's radius, m.
    pub radius: Option<f64>,
    /// A convex polygon's corners [x, y], m, each once, in either turning sense.
    pub points: Option<Vec<[f64; 2]>>,
    /// Where the shape's frame is in the body's: x, y (m) and angle (rad).
    #[serde(default)]
    pub origin: [f64; 3],
}

/// One `[[allowed_contacts]]` entry: two links or bodies that touch by design (the tool in its
/// stock is a cut, not a crash). Adjacent links are allowed without an entry.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AllowedContact {
    /// One link or body, by name.
    pub a: String,
    /// The other link or body, by name; the pair is allowed in either order.
    pub b: String,
    /// Why, for the reader.
    #[serde(default)]
    pub reason: String,
}

/// The least area of a body's polygon, m² (1 µm²): below, it is a line.
const MIN_POLYGON_AREA: f64 = 1e-12;

impl BodySpec {
    /// Where the body's frame is in the world.
    pub fn placement(&self) -> Pose2 {
        let [x, y, angle] = self.pose;
        Pose2::new(x, y, angle)
    }

    /// Its shapes in its frame, as the mechanism's are (checked by [`BodySpec::validate`]).
    pub fn outlines(&self) -> Vec<Shape> {
        self.shapes
            .iter()
            .map(|shape| {
                let [x, y, angle] = shape.origin;
                let outline = match (&shape.size, shape.radius, &shape.points) {
                    (Some([width, height]), _, _) => Outline::Rectangle {
                        width: *width,
                        height: *height,
                    },
                    (None, Some(radius), _) => Outline::Circle { radius },
                    (None, None, points) => Outline::Polygon {
                        points: convex_hull(points.as_deref().unwrap_or_default()),
                    },
                };
                Shape {
                    origin: Pose2::new(x, y, angle),
                    outline,
                    color: None,
                }
            })
            .collect()
    }

    /// What can be checked before the URDF is read (names are checked against it when the twin
    /// is bound): sizes, the mass, the kind.
    pub fn validate(&self, index: usize) -> Result<(), String> {
        let at = |what: String| format!("bodies.{index} (`{}`): {what}", self.name);
        if self.name.is_empty() {
            return Err(format!("bodies.{index}: give the body a name"));
        }
        if !self.pose.iter().all(|v| v.is_finite()) {
            return Err(at(format!("pose must be finite, got {:?}", self.pose)));
        }
        if self.shapes.is_empty() {
            return Err(at("give it at least one shape".into()));
        }
        for (i, shape) in self.shapes.iter().enumerate() {
            shape
                .validate()
                .map_err(|reason| at(format!("shapes.{i}: {reason}")))?;
        }
        match (self.kind, self.mass) {
            (BodyKind::Free, Some(mass)) if mass.is_finite() && mass > 0.0 => Ok(()),
            (BodyKind::Free, Some(mass)) => Err(at(format!("mass must be > 0, got {mass}"))),
            (BodyKind::Free, None) => Err(at("a free body needs a mass".into())),
            (BodyKind::Static, Some(_)) => Err(at("a static body takes no mass".into())),
            (BodyKind::Static, None) => Ok(()),
        }
    }
}

impl BodyShape {
    fn validate(&self) -> Result<(), String> {
        if !self.origin.iter().all(|v| v.is_finite()) {
            return Err(format!("origin must be finite, got {:?}", self.origin));
        }
        match (&self.size, self.radius, &self.points) {
            (Some([w, h]), None, None) => positive("size", &[*w, *h]),
            (None, Some(r), None) => positive("radius", &[r]),
            (None, None, Some(points)) => {
                if points.len() < 3 {
                    return Err(format!(
                        "points: a polygon needs 3 or more, got {}",
                        points.len()
                    ));
                }
                if !points.iter().flatten().all(|v| v.is_finite()) {
                    return Err("points must be finite".into());
                }
                convex(points)
            }
            _ => {
                Err("give exactly one of size = [w, h], radius = r or points = [[x, y], …]".into())
            }
        }
    }
}

/// A polygon's points must be the corners of a convex polygon with an area, each once (in
/// either turning sense).
fn convex(points: &[[f64; 2]]) -> Result<(), String> {
    let hull = convex_hull(points);
    if hull.len() < 3 || polygon_area(&hull) < MIN_POLYGON_AREA {
        return Err("points: the polygon has no area (its points lie on a line)".into());
    }
    match points.iter().position(|p| !hull.contains(p)) {
        Some(k) => Err(format!(
            "points.{k} {:?} is not a corner of a convex polygon (it lies inside it or on an edge)",
            points[k]
        )),
        None if hull.len() < points.len() => {
            Err("points: a corner is given twice; give each once".into())
        }
        None => Ok(()),
    }
}

fn positive(name: &str, values: &[f64]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite() && *v > 0.0) {
        Ok(())
    } else {
        Err(format!("{name} must be > 0, got {values:?}"))
    }
}

impl SolverOptions {
    /// Every count between its least (1, or 0 for stabilization) and `MAX_SUBSTEPS`, and an
    /// integrator other than RK4 only on the exact engine; else what is wrong, in the scenario's
    /// words.
    pub fn validate(&self) -> Result<(), String> {
        if self.engine == Engine::Rapier && self.integrator != Integrator::Rk4 {
            return Err(format!(
                "solver.integrator = \"{}\" is the exact engine's: the rapier engine integrates \
                 as Rapier does; leave it out or use engine = \"exact\"",
                self.integrator.name()
            ));
        }
        let counts = [
            ("rapier_substeps", self.rapier_substeps, 1),
            ("rapier_iterations", self.rapier_iterations, 1),
            (
                "rapier_stabilization_iterations",
                self.rapier_stabilization_iterations,
                0,
            ),
        ];
        for (name, value, least) in counts {
            if value < least || value > MAX_SUBSTEPS {
                return Err(format!(
                    "solver.{name} must be between {least} and {}, got {value}",
                    MAX_SUBSTEPS
                ));
            }
        }
        Ok(())
    }
}

impl ContactOptions {
    /// Friction ≥ 0 and restitution in [0, 1], both finite; else what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(format!(
                "contact.friction must be ≥ 0, got {}",
                self.friction
            ));
        }
        if !(self.restitution.is_finite() && (0.0..=1.0).contains(&self.restitution)) {
            return Err(format!(
                "contact.restitution must be between 0 and 1, got {}",
                self.restitution
            ));
        }
        Ok(())
    }
}

/// Solver settings a scenario may tune.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverSettings {
    /// Physics step, s.
    pub dt: f64,
    /// Gravitational acceleration in the world frame [x, y], m/s².
    pub gravity: [f64; 2],
    /// The exact engine's substeps per step (efforts and loads are held over the whole step).
    pub substeps: usize,
    /// The engine and the rapier engine's settings (`[solver]`).
    pub solver: SolverOptions,
    /// How the rapier engine resolves contacts (`[contact]`).
    pub contact: ContactOptions,
    /// The rigid bodies beside the mechanism (`[[bodies]]`).
    pub bodies: Vec<BodySpec>,
    /// Pairs that touch by design (`[[allowed_contacts]]`): the rapier engine does not push
    /// them apart (a tool in its stock is a cut, which the machine's process model computes).
    pub allowed_contacts: Vec<AllowedContact>,
}

impl SolverSettings {
    /// The exact engine with `substeps` RK4 substeps and nothing beside the mechanism.
    pub fn exact(dt: f64, gravity: [f64; 2], substeps: usize) -> Self {
        Self {
            dt,
            gravity,
            substeps,
            solver: SolverOptions::default(),
            contact: ContactOptions::default(),
            bodies: Vec::new(),
            allowed_contacts: Vec::new(),
        }
    }
}
