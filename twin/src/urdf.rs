//! Planar URDF loader: URDF (plus the `<loop_joint>` extension) → [`Mechanism`].
//!
//! The standard elements are read by `urdf-rs`; `<loop_joint>` elements, which URDF has no place
//! for, are read from the same text:
//!
//! ```xml
//! <loop_joint name="slot" type="prismatic">   <!-- or "revolute" -->
//!   <link1 link="slotted_link" xyz="0.4 0 0" rpy="0 0 0"/>  <!-- joint frame in link1 -->
//!   <link2 link="block" xyz="0 0 0" rpy="0 0 0"/>           <!-- joint frame in link2 -->
//!   <axis xyz="1 0 0"/>                                      <!-- prismatic: in the joint frame -->
//!   </loop_joint>
//! ```
//!
//! The two frames must coincide (position, and for a prismatic joint also direction) in the pose
//! the URDF describes, where every tree joint is at zero: the loader checks it.
//!
//! A wheel rolling on the floor spins about an axis in the plane, which a planar world cannot
//! rotate about; `<wheel>` declares one on the link that carries its axle:
//!
//! ```xml
//! <wheel name="left_wheel" link="chassis" xyz="0 0.1 0" rpy="0 0 0" axis="0 1 0"
//!        radius="0.04" width="0.02" spin_inertia="1e-4" friction="0.8"
//!        driven="true" effort="0.9"/>
//! ```
//!
//! `xyz`/`rpy` place the wheel centre (seen from above, its contact point) in the link frame;
//! `axis` is the spin axis in that frame and must lie in the xy plane (default `0 1 0`: the wheel
//! rolls along +x for a positive spin); `radius`, `width` (m) and `spin_inertia` (kg·m², about the
//! axis) must be > 0; `friction` is the tyre–floor μ (> 0); a `driven="true"` wheel is an actuator
//! with the torque limit `effort` (N·m, > 0). The wheel's mass belongs to its link's `<inertial>`.
//! Its footprint is drawn as a visual of the link.
//!
//! A joint may carry a linear spring between its parent and child (part of the plant, such as a
//! flexible tool's bending stiffness), declared inside the `<joint>`:
//!
//! ```xml
//! <joint name="tool_x" type="prismatic"> … <spring stiffness="2.0e6" reference="0"/> </joint>
//! ```
//!
//! `stiffness` (N/m or N·m/rad, ≥ 0) and `reference` (the relaxed coordinate, m or rad, default
//! 0) are in the joint's own sense; the joint's `<dynamics damping>` is the damper beside it.
//!
//! `<visual>` and `<collision>` geometry becomes outlines on the plane ([`geometry`]): boxes,
//! cylinders and spheres, and meshes (STL, OBJ) as the convex hull of their vertices.

mod geometry;
mod published;

use crate::mechanism::{
    Inertial, Joint, JointMotion, JointSpring, Link, LoopJoint, Mechanism, Outline, Plane, Pose2,
    Shape, Wheel,
};
use std::collections::HashMap;
use std::path::Path;
use thiserror::Error;

/// How far from planar a value may be before it is an error (m or rad).
const PLANAR_TOLERANCE: f64 = 1e-9;
/// Deepest element nesting accepted (a URDF needs 5: robot, link, visual, geometry, box). Checked
/// before any parser runs, since urdf-rs recurses once per level.
const MAX_XML_DEPTH: usize = 32;
/// Largest gap allowed between a loop joint's two frames in the URDF's pose, m (or rad).
const LOOP_CLOSURE_TOLERANCE: f64 = 1e-6;

/// Every defect found while loading a URDF, naming the file, the element and the reason.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum UrdfError {
    /// The URDF file cannot be read.
    #[error("{file}: cannot read: {reason}")]
    Read {
        /// The file's path.
        file: String,
        /// What the file system said.
        reason: String,
    },
    /// The text is not well-formed XML, nests too deep, or is not a `<robot>` URDF.
    #[error("{file}: malformed URDF: {reason}")]
    Malformed {
        /// The file's path, or the name given to the text.
        file: String,
        /// What the parser said, with the line where it can.
        reason: String,
    },
    /// A well-formed URDF describes no valid planar mechanism.
    #[error("{file}: {element}: {reason}")]
    Invalid {
        /// The file's path, or the name given to the text.
        file: String,
        /// The element at fault, e.g. `link "crank"`.
        element: String,
        /// What is wrong with it.
        reason: String,
    },
}

/// Loads a URDF file.
pub fn load_file(path: &Path) -> Result<Mechanism, UrdfError> {
    let file = path.display().to_string();
    let text = crate::files::read_text(path).map_err(|reason| UrdfError::Read {
        file: file.clone(),
        reason,
    })?;
    load_str(&text, &file)
}

/// Loads URDF text; `source` names it in errors. When `source` is the path of a file, the meshes
/// it names are read from that file's folder, otherwise from the working folder.
pub fn load_str(text: &str, source: &str) -> Result<Mechanism, UrdfError> {
    let malformed = |reason: String| UrdfError::Malformed {
        file: source.to_string(),
        reason,
    };
    check_depth(text).map_err(malformed)?;
    // Parse the raw XML first: its errors carry line numbers, urdf-rs's do not.
    let document = roxmltree::Document::parse(text).map_err(|e| malformed(e.to_string()))?;
    let root = document.root_element().tag_name().name();
    if root != "robot" {
        return Err(malformed(format!(
            "the root element is <{root}>; a URDF's is <robot>"
        )));
    }
    let mut robot = urdf_rs::read_from_string(text).map_err(|e| malformed(e.to_string()))?;
    let path = Path::new(source);
    let folder = path.is_file().then(|| path.parent()).flatten();
    let invalid = |(element, reason)| UrdfError::Invalid {
        file: source.to_string(),
        element,
        reason,
    };
    let mut notes = published::weld_to_world(&mut robot).map_err(invalid)?;
    let plane = published::plane_of(&robot);
    if !plane.is_identity() {
        published::lay(&mut robot, &plane);
    }
    notes.extend(published::axial_offsets(&mut robot));
    notes.extend(published::left_out(&document));
    let mut mechanism = Loader {
        file: source,
        folder,
        plane,
    }
    .build(&robot, &document)?;
    notes.extend(published::transmissions(&document, &mut mechanism).map_err(invalid)?);
    mechanism.plane = plane;
    mechanism.notes = notes;
    Ok(mechanism)
}

/// Fails on elements nested deeper than [`MAX_XML_DEPTH`], in one pass over the text that
/// stops at the first too-deep element (comments, CDATA, declarations and quoted attribute
/// values are skipped; anything else malformed is left to the XML parser).
fn check_depth(text: &str) -> Result<(), String> {
    let bytes = text.as_bytes();
    let (mut depth, mut i) = (0usize, 0usize);
    let skip_to = |from: usize, end: &[u8]| -> usize {
        bytes[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(bytes.len(), |p| from + p + end.len())
    };
    while let Some(offset) = bytes[i..].iter().position(|&b| b == b'<') {
        let start = i + offset;
        let rest = &bytes[start..];
        i = if rest.starts_with(b"<!--") {
            skip_to(start, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_to(start, b"]]>")
        } else if rest.starts_with(b"<!") || rest.starts_with(b"<?") {
            skip_to(start, b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            skip_to(start, b">")
        } else {
            let end = tag_end(bytes, start);
            if bytes.get(end.wrapping_sub(2)) != Some(&b'/') {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    let line = text[..start].matches('\n').count() + 1;
                    return Err(format!(
                        "line {line}: elements nested more than {MAX_XML_DEPTH} deep"
                    ));
                }
            }
            end
        };
    }
    Ok(())
}

/// The index just past the `>` closing the tag that starts at `start`, skipping quoted values.
fn tag_end(bytes: &[u8], start: usize) -> usize {
    let mut quote = None;
    for (k, &b) in bytes.iter().enumerate().skip(start + 1) {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if b == q => quote = None,
            (None, b'>') => return k + 1,
            _ => {}
        }
    }
    bytes.len()
}

struct Loader<'a> {
    file: &'a str,
    /// Where mesh paths are read from (the working folder when `None`).
    folder: Option<&'a Path>,
    /// The plane the URDF is laid onto: the frames `urdf-rs` read are laid already, those read
    /// here (loop joints, wheels) are laid as they are read.
    plane: Plane,
}

impl Loader<'_> {
    fn invalid(&self, element: String, reason: impl Into<String>) -> UrdfError {
        UrdfError::Invalid {
            file: self.file.to_string(),
            element,
            reason: reason.into(),
        }
    }

    fn build(
        &self,
        robot: &urdf_rs::Robot,
        document: &roxmltree::Document,
    ) -> Result<Mechanism, UrdfError> {
        let order = self.tree_order(robot)?;
        let position: HashMap<&str, usize> = order
            .iter()
            .enumerate()
            .map(|(i, &link)| (robot.links[link].name.as_str(), i))
            .collect();

        let mut links = Vec::with_capacity(order.len());
        for (i, &index) in order.iter().enumerate() {
            links.push(self.link(&robot.links[index], i == 0)?);
        }

        let mut joints = Vec::with_capacity(order.len() - 1);
        for &link in &order[1..] {
            let name = &robot.links[link].name;
            let joint = robot
                .joints
                .iter()
                .find(|j| &j.child.link == name)
                .expect("tree_order gives every non-root link a parent joint");
            joints.push(self.joint(joint, &position)?);
        }

        let mut mechanism = Mechanism {
            name: robot.name.clone(),
            source: self.file.to_string(),
            links,
            joints,
            loops: Vec::new(),
            wheels: Vec::new(),
            plane: Plane::IDENTITY,
            notes: Vec::new(),
        };
        self.springs(document, &mut mechanism)?;
        mechanism.loops = self.loop_joints(document, &mechanism)?;
        mechanism.wheels = self.wheels(document, &mechanism)?;
        for wheel in &mechanism.wheels {
            let [hx, hy] = wheel.heading();
            mechanism.links[wheel.link].visuals.push(Shape {
                origin: wheel.origin.compose(&Pose2::new(0.0, 0.0, hy.atan2(hx))),
                outline: Outline::Rectangle {
                    width: 2.0 * wheel.radius,
                    height: wheel.width,
                },
                color: Some([0.15, 0.15, 0.15, 1.0]),
            });
        }
        Ok(mechanism)
    }

    /// Link indices (into `robot.links`) root first, each parent before its children; checks that
    /// the joints form one tree.
    fn tree_order(&self, robot: &urdf_rs::Robot) -> Result<Vec<usize>, UrdfError> {
        if robot.links.is_empty() {
            return Err(self.invalid(format!("robot \"{}\"", robot.name), "has no links"));
        }
        let mut index = HashMap::new();
        for (i, link) in robot.links.iter().enumerate() {
            if index.insert(link.name.as_str(), i).is_some() {
                return Err(self.invalid(format!("link \"{}\"", link.name), "defined twice"));
            }
        }
        let mut parent_of = vec![None; robot.links.len()];
        let mut seen_joints = HashMap::new();
        for joint in &robot.joints {
            let element = format!("joint \"{}\"", joint.name);
            if seen_joints.insert(joint.name.as_str(), ()).is_some() {
                return Err(self.invalid(element, "defined twice"));
            }
            let parent = *index.get(joint.parent.link.as_str()).ok_or_else(|| {
                self.invalid(
                    element.clone(),
                    format!("unknown parent link \"{}\"", joint.parent.link),
                )
            })?;
            let child = *index.get(joint.child.link.as_str()).ok_or_else(|| {
                self.invalid(
                    element.clone(),
                    format!("unknown child link \"{}\"", joint.child.link),
                )
            })?;
            if parent == child {
                return Err(self.invalid(element, "parent and child are the same link"));
            }
            if parent_of[child].replace(parent).is_some() {
                return Err(self.invalid(
                    element,
                    format!(
                        "link \"{}\" already has a parent joint (a URDF is a tree: close loops with <loop_joint>)",
                        joint.child.link
                    ),
                ));
            }
        }
        let roots: Vec<usize> = (0..robot.links.len())
            .filter(|&i| parent_of[i].is_none())
            .collect();
        let root = match roots.as_slice() {
            [root] => *root,
            [] => {
                return Err(self.invalid(
                    format!("robot \"{}\"", robot.name),
                    "the joints form a cycle: no link is free of a parent",
                ))
            }
            many => {
                let names: Vec<&str> = many.iter().map(|&i| robot.links[i].name.as_str()).collect();
                return Err(self.invalid(
                    format!("robot \"{}\"", robot.name),
                    format!("more than one root link: {}", names.join(", ")),
                ));
            }
        };
        let mut order = vec![root];
        let mut next = 0;
        while next < order.len() {
            let parent = order[next];
            order.extend((0..robot.links.len()).filter(|&c| parent_of[c] == Some(parent)));
            next += 1;
        }
        if order.len() != robot.links.len() {
            let stray = (0..robot.links.len())
                .find(|i| !order.contains(i))
                .map(|i| robot.links[i].name.clone())
                .unwrap_or_default();
            return Err(self.invalid(
                format!("link \"{stray}\""),
                "is on a cycle of joints, not reachable from the root",
            ));
        }
        Ok(order)
    }

    fn link(&self, link: &urdf_rs::Link, is_root: bool) -> Result<Link, UrdfError> {
        let element = format!("link \"{}\"", link.name);
        let inertial = if is_root {
            None
        } else {
            let i = &link.inertial;
            let at = format!("{element} <inertial>");
            if !(i.mass.value.is_finite() && i.mass.value > 0.0) {
                return Err(self.invalid(
                    at,
                    format!(
                        "a moving link needs a positive mass (missing <inertial> or mass = {})",
                        i.mass.value
                    ),
                ));
            }
            if !(i.inertia.izz.is_finite() && i.inertia.izz > 0.0) {
                return Err(self.invalid(at, format!("izz must be > 0, got {}", i.inertia.izz)));
            }
            let origin = self.planar_pose(&i.origin, &at)?;
            Some(Inertial {
                mass: i.mass.value,
                centre_of_mass: [origin.x, origin.y],
                izz: i.inertia.izz,
            })
        };
        let visuals = link
            .visual
            .iter()
            .map(|v| {
                let color = v.material.as_ref().and_then(|m| m.color.as_ref()).map(|c| {
                    let [r, g, b, a] = c.rgba.0;
                    [r as f32, g as f32, b as f32, a as f32]
                });
                self.shape(
                    &v.origin,
                    &v.geometry,
                    color,
                    &format!("{element} <visual>"),
                )
            })
            .collect::<Result<_, _>>()?;
        let collisions = link
            .collision
            .iter()
            .map(|c| {
                self.shape(
                    &c.origin,
                    &c.geometry,
                    None,
                    &format!("{element} <collision>"),
                )
            })
            .collect::<Result<_, _>>()?;
        Ok(Link {
            name: link.name.clone(),
            inertial,
            visuals,
            collisions,
        })
    }

    /// A `<visual>` or `<collision>` geometry at its origin: the origin must be finite and in the
    /// plane (no z offset); its roll and pitch may stand the shape up (see [`geometry`]).
    fn shape(
        &self,
        origin: &urdf_rs::Pose,
        geometry: &urdf_rs::Geometry,
        color: Option<[f32; 4]>,
        element: &str,
    ) -> Result<Shape, UrdfError> {
        let [x, y, z] = self.finite_pose(origin, element)?;
        if z.abs() > PLANAR_TOLERANCE {
            return Err(self.invalid(
                element.to_string(),
                format!("not planar: z offset is {z} (must be 0)"),
            ));
        }
        let (outline, angle) =
            geometry::outline(geometry, origin.rpy.0, PLANAR_TOLERANCE, self.folder)
                .map_err(|reason| self.invalid(element.to_string(), reason))?;
        Ok(Shape {
            origin: Pose2::new(x, y, angle),
            outline,
            color,
        })
    }

    /// A pose's xyz, once every number of it is known to be finite.
    fn finite_pose(&self, pose: &urdf_rs::Pose, element: &str) -> Result<[f64; 3], UrdfError> {
        if pose.xyz.0.iter().chain(&pose.rpy.0).any(|v| !v.is_finite()) {
            let ([x, y, z], [roll, pitch, yaw]) = (pose.xyz.0, pose.rpy.0);
            return Err(self.invalid(
                element.to_string(),
                format!("origin xyz/rpy must be finite numbers, got xyz {x} {y} {z}, rpy {roll} {pitch} {yaw}"),
            ));
        }
        Ok(pose.xyz.0)
    }

    /// A URDF pose that must lie in the xy plane.
    fn planar_pose(&self, pose: &urdf_rs::Pose, element: &str) -> Result<Pose2, UrdfError> {
        let [x, y, z] = self.finite_pose(pose, element)?;
        let [roll, pitch, yaw] = pose.rpy.0;
        for (name, value) in [("z offset", z), ("roll", roll), ("pitch", pitch)] {
            if value.abs() > PLANAR_TOLERANCE {
                return Err(self.invalid(
                    element.to_string(),
                    format!("not planar: {name} is {value} (must be 0)"),
                ));
            }
        }
        Ok(Pose2::new(x, y, yaw))
    }

    fn joint(
        &self,
        joint: &urdf_rs::Joint,
        position: &HashMap<&str, usize>,
    ) -> Result<Joint, UrdfError> {
        let element = format!("joint \"{}\"", joint.name);
        let origin = self.planar_pose(&joint.origin, &format!("{element} <origin>"))?;
        let axis = self.unit_axis(joint.axis.xyz.0, &element)?;
        let limit = &joint.limit;
        let (motion, limits) = match &joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                let sign = self.z_axis_sign(axis, &element)?;
                let bounded = joint.joint_type == urdf_rs::JointType::Revolute;
                (JointMotion::Revolute { sign }, bounded.then_some([limit.lower, limit.upper]))
            }
            urdf_rs::JointType::Prismatic => {
                if axis[2].abs() > PLANAR_TOLERANCE {
                    return Err(self.invalid(
                        format!("{element} <axis>"),
                        format!("not planar: a prismatic axis must lie in the xy plane, its z part is {}", axis[2]),
                    ));
                }
                (
                    JointMotion::Prismatic {
                        axis: [axis[0], axis[1]],
                    },
                    Some([limit.lower, limit.upper]),
                )
            }
            urdf_rs::JointType::Fixed => (JointMotion::Fixed, None),
            other => {
                return Err(self.invalid(
                    element,
                    format!("unsupported joint type {other:?} (revolute, continuous, prismatic and fixed are)"),
                ))
            }
        };
        self.check_limit(limit, &element)?;
        // URDF 1.0 reads a missing or infinite range as lower = upper; treat that as unlimited.
        let limits = limits.filter(|[lower, upper]| lower < upper && lower.is_finite());
        // effort = 0 (URDF's default) declares an unactuated joint.
        let effort_limit = (motion.is_movable() && limit.effort > 0.0).then_some(limit.effort);
        let (damping, friction) = joint
            .dynamics
            .as_ref()
            .map_or((0.0, 0.0), |d| (d.damping, d.friction));
        for (name, value) in [("damping", damping), ("friction", friction)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(self.invalid(
                    format!("{element} <dynamics>"),
                    format!("{name} must be ≥ 0, got {value}"),
                ));
            }
        }
        Ok(Joint {
            name: joint.name.clone(),
            motion,
            parent: position[joint.parent.link.as_str()],
            child: position[joint.child.link.as_str()],
            origin,
            limits,
            effort_limit,
            velocity_limit: (limit.velocity > 0.0 && limit.velocity.is_finite())
                .then_some(limit.velocity),
            damping,
            friction,
            spring: None,
            reduction: 1.0,
        })
    }

    /// `<limit>`: no NaN anywhere, lower ≤ upper when both are finite, effort and velocity ≥ 0.
    fn check_limit(&self, limit: &urdf_rs::JointLimit, element: &str) -> Result<(), UrdfError> {
        let at = format!("{element} <limit>");
        let numbers = [
            ("lower", limit.lower),
            ("upper", limit.upper),
            ("effort", limit.effort),
            ("velocity", limit.velocity),
        ];
        if let Some((name, value)) = numbers.iter().find(|(_, v)| v.is_nan()) {
            return Err(self.invalid(at, format!("{name}=\"{value}\" is not a number")));
        }
        for (name, value) in &numbers[2..] {
            if !(value.is_finite() && *value >= 0.0) {
                return Err(self.invalid(
                    at,
                    format!("{name} must be ≥ 0 and finite (0: unactuated), got {value}"),
                ));
            }
        }
        if limit.lower > limit.upper {
            return Err(self.invalid(
                at,
                format!("lower ({}) is above upper ({})", limit.lower, limit.upper),
            ));
        }
        Ok(())
    }

    /// Reads each `<joint>`'s `<spring stiffness reference>` extension into its joint.
    fn springs(
        &self,
        document: &roxmltree::Document,
        mechanism: &mut Mechanism,
    ) -> Result<(), UrdfError> {
        for node in document
            .root_element()
            .children()
            .filter(|n| n.has_tag_name("joint"))
        {
            let Some(spring) = node.children().find(|n| n.has_tag_name("spring")) else {
                continue;
            };
            let name = node.attribute("name").unwrap_or("");
            let element = format!("joint \"{name}\" <spring>");
            let Some(j) = mechanism.joint_index(name) else {
                continue;
            };
            if !mechanism.joints[j].motion.is_movable() {
                return Err(self.invalid(element, "a fixed joint cannot have a spring"));
            }
            let number = |attribute: &str, default: Option<f64>| -> Result<f64, UrdfError> {
                match (spring.attribute(attribute), default) {
                    (None, Some(value)) => Ok(value),
                    (None, None) => {
                        Err(self.invalid(element.clone(), format!("needs {attribute}=\"…\"")))
                    }
                    (Some(text), _) => text
                        .trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                            self.invalid(
                                element.clone(),
                                format!("{attribute}=\"{text}\" is not a finite number"),
                            )
                        }),
                }
            };
            let stiffness = number("stiffness", None)?;
            if stiffness < 0.0 {
                return Err(
                    self.invalid(element, format!("stiffness must be ≥ 0, got {stiffness}"))
                );
            }
            let reference = number("reference", Some(0.0))?;
            mechanism.joints[j].spring = Some(JointSpring {
                stiffness,
                reference,
            });
        }
        Ok(())
    }

    fn unit_axis(&self, axis: [f64; 3], element: &str) -> Result<[f64; 3], UrdfError> {
        let norm = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(self.invalid(format!("{element} <axis>"), "axis has zero length"));
        }
        Ok([axis[0] / norm, axis[1] / norm, axis[2] / norm])
    }

    fn z_axis_sign(&self, axis: [f64; 3], element: &str) -> Result<f64, UrdfError> {
        if (axis[2].abs() - 1.0).abs() > PLANAR_TOLERANCE {
            let reason = if self.plane.is_identity() {
                format!(
                    "not planar: a revolute axis must be ±z as the others are, got ({}, {}, {}) (a wheel rolling on the floor is declared with <wheel>)",
                    axis[0], axis[1], axis[2]
                )
            } else {
                let [x, y, z] = self.plane.in_urdf(axis);
                let [nx, ny, nz] = self.plane.normal();
                format!(
                    "not planar: the revolute axes must be parallel (most turn about ({nx}, {ny}, {nz}), normal to the plane), got ({x}, {y}, {z})"
                )
            };
            return Err(self.invalid(format!("{element} <axis>"), reason));
        }
        Ok(axis[2].signum())
    }

    fn loop_joints(
        &self,
        document: &roxmltree::Document,
        mechanism: &Mechanism,
    ) -> Result<Vec<LoopJoint>, UrdfError> {
        let zero_pose = mechanism.zero_pose();
        let mut loops = Vec::new();
        for node in document
            .root_element()
            .children()
            .filter(|n| n.has_tag_name("loop_joint"))
        {
            let name = node.attribute("name").unwrap_or("").to_string();
            let element = format!("loop_joint \"{name}\"");
            if name.is_empty() {
                return Err(self.invalid(element, "needs a name"));
            }
            if loops.iter().any(|l: &LoopJoint| l.name == name)
                || mechanism.joint_index(&name).is_some()
            {
                return Err(self.invalid(element, "name already used by another joint"));
            }
            let (link1, frame1) = self.loop_end(&node, "link1", &element, mechanism)?;
            let (link2, frame2) = self.loop_end(&node, "link2", &element, mechanism)?;
            if link1 == link2 {
                return Err(self.invalid(element, "link1 and link2 are the same link"));
            }
            let motion = match node.attribute("type") {
                Some("revolute") | Some("continuous") => JointMotion::Revolute { sign: 1.0 },
                Some("prismatic") => {
                    let axis = node
                        .children()
                        .find(|n| n.has_tag_name("axis"))
                        .ok_or_else(|| {
                            self.invalid(element.clone(), "a prismatic loop joint needs <axis xyz>")
                        })?;
                    let xyz = self.triple(&axis, "xyz", &format!("{element} <axis>"))?;
                    let unit = self.plane.vector(self.unit_axis(xyz, &element)?);
                    if unit[2].abs() > PLANAR_TOLERANCE {
                        return Err(self.invalid(
                            format!("{element} <axis>"),
                            format!("not planar: z part is {}", unit[2]),
                        ));
                    }
                    JointMotion::Prismatic {
                        axis: [unit[0], unit[1]],
                    }
                }
                other => {
                    return Err(self.invalid(
                        element,
                        format!(
                            "unsupported type {:?} (revolute or prismatic)",
                            other.unwrap_or("<missing>")
                        ),
                    ))
                }
            };
            let loop_joint = LoopJoint {
                name,
                motion,
                link1,
                link2,
                frame1,
                frame2,
            };
            self.check_closure(&loop_joint, &zero_pose, &element)?;
            loops.push(loop_joint);
        }
        Ok(loops)
    }

    fn wheels(
        &self,
        document: &roxmltree::Document,
        mechanism: &Mechanism,
    ) -> Result<Vec<Wheel>, UrdfError> {
        let mut wheels: Vec<Wheel> = Vec::new();
        for node in document
            .root_element()
            .children()
            .filter(|n| n.has_tag_name("wheel"))
        {
            let name = node.attribute("name").unwrap_or("").to_string();
            let element = format!("wheel \"{name}\"");
            if name.is_empty() {
                return Err(self.invalid(element, "needs a name"));
            }
            if wheels.iter().any(|w| w.name == name)
                || mechanism.joint_index(&name).is_some()
                || mechanism.loops.iter().any(|l| l.name == name)
            {
                return Err(self.invalid(element, "name already used by another wheel or joint"));
            }
            let link_name = node.attribute("link").unwrap_or("");
            let link = mechanism.link_index(link_name).ok_or_else(|| {
                self.invalid(element.clone(), format!("unknown link \"{link_name}\""))
            })?;
            if link == 0 {
                return Err(self.invalid(element, "cannot sit on the fixed root link"));
            }
            let pose = self.laid_pose(
                self.triple(&node, "xyz", &element)?,
                self.triple(&node, "rpy", &element)?,
            );
            let origin = self.planar_pose(&pose, &element)?;
            let axis = match node.attribute("axis") {
                None => [0.0, 1.0, 0.0],
                Some(_) => self
                    .plane
                    .vector(self.unit_axis(self.triple(&node, "axis", &element)?, &element)?),
            };
            if axis[2].abs() > PLANAR_TOLERANCE {
                return Err(self.invalid(
                    format!("{element} axis"),
                    format!(
                        "not planar: a wheel spins about an axis in the xy plane, its z part is {}",
                        axis[2]
                    ),
                ));
            }
            let number = |attribute: &str, default: Option<f64>| {
                self.positive_number(&node, attribute, default, &element)
            };
            let radius = number("radius", None)?;
            let width = number("width", Some(0.5 * radius))?;
            let spin_inertia = number("spin_inertia", None)?;
            let friction = number("friction", None)?;
            let effort_limit = match node.attribute("driven") {
                None | Some("false") => None,
                Some("true") => Some(number("effort", None)?),
                Some(other) => {
                    return Err(self.invalid(
                        element,
                        format!("driven=\"{other}\" must be \"true\" or \"false\""),
                    ))
                }
            };
            wheels.push(Wheel {
                name,
                link,
                origin,
                axis: [axis[0], axis[1]],
                radius,
                width,
                spin_inertia,
                friction,
                effort_limit,
            });
        }
        Ok(wheels)
    }

    fn loop_end(
        &self,
        node: &roxmltree::Node,
        tag: &str,
        element: &str,
        mechanism: &Mechanism,
    ) -> Result<(usize, Pose2), UrdfError> {
        let at = format!("{element} <{tag}>");
        let end = node
            .children()
            .find(|n| n.has_tag_name(tag))
            .ok_or_else(|| self.invalid(element.to_string(), format!("missing <{tag} link=…>")))?;
        let link_name = end.attribute("link").unwrap_or("");
        let link = mechanism
            .link_index(link_name)
            .ok_or_else(|| self.invalid(at.clone(), format!("unknown link \"{link_name}\"")))?;
        let xyz = self.triple(&end, "xyz", &at)?;
        let rpy = self.triple(&end, "rpy", &at)?;
        let pose = self.laid_pose(xyz, rpy);
        Ok((link, self.planar_pose(&pose, &at)?))
    }

    /// A frame read from the text (not by `urdf-rs`), laid onto the plane.
    fn laid_pose(&self, xyz: [f64; 3], rpy: [f64; 3]) -> urdf_rs::Pose {
        let (xyz, rpy) = if self.plane.is_identity() {
            (xyz, rpy)
        } else {
            self.plane.frame(xyz, rpy)
        };
        urdf_rs::Pose {
            xyz: urdf_rs::Vec3(xyz),
            rpy: urdf_rs::Vec3(rpy),
        }
    }

    /// The attribute `name` of `node` (element `at`), a number > 0; `default` when absent, if
    /// any.
    fn positive_number(
        &self,
        node: &roxmltree::Node,
        name: &str,
        default: Option<f64>,
        at: &str,
    ) -> Result<f64, UrdfError> {
        let value = match (node.attribute(name), default) {
            (Some(text), _) => text.trim().parse::<f64>().map_err(|_| {
                self.invalid(at.to_string(), format!("{name}=\"{text}\" is not a number"))
            })?,
            (None, Some(value)) => value,
            (None, None) => return Err(self.invalid(at.to_string(), format!("missing {name}=…"))),
        };
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(self.invalid(at.to_string(), format!("{name} must be > 0, got {value}")))
        }
    }

    /// Three numbers from an attribute; a missing attribute reads as zeros, as in URDF.
    fn triple(&self, node: &roxmltree::Node, name: &str, at: &str) -> Result<[f64; 3], UrdfError> {
        let Some(text) = node.attribute(name) else {
            return Ok([0.0; 3]);
        };
        let values: Vec<f64> = text
            .split_whitespace()
            .map(|word| word.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or(()))
            .collect::<Result<_, _>>()
            .map_err(|_| {
                self.invalid(
                    at.to_string(),
                    format!("{name}=\"{text}\" is not three finite numbers"),
                )
            })?;
        <[f64; 3]>::try_from(values).map_err(|_| {
            self.invalid(
                at.to_string(),
                format!("{name}=\"{text}\" is not three finite numbers"),
            )
        })
    }

    fn check_closure(
        &self,
        joint: &LoopJoint,
        zero_pose: &[Pose2],
        element: &str,
    ) -> Result<(), UrdfError> {
        let world1 = zero_pose[joint.link1].compose(&joint.frame1);
        let world2 = zero_pose[joint.link2].compose(&joint.frame2);
        let gap = [world2.x - world1.x, world2.y - world1.y];
        let (off_axis, twist) = match joint.motion {
            JointMotion::Prismatic { axis } => {
                let [ax, ay] = world1.rotate(axis[0], axis[1]);
                let twist = (world2.angle - world1.angle).sin().abs();
                ((gap[1] * ax - gap[0] * ay).abs(), twist)
            }
            _ => (gap[0].hypot(gap[1]), 0.0),
        };
        if off_axis > LOOP_CLOSURE_TOLERANCE || twist > LOOP_CLOSURE_TOLERANCE {
            return Err(self.invalid(
                element.to_string(),
                format!(
                    "does not close in the URDF's pose: frames {off_axis:.3e} m apart, {twist:.3e} rad twisted (tolerance {LOOP_CLOSURE_TOLERANCE:e})"
                ),
            ));
        }
        Ok(())
    }
}
