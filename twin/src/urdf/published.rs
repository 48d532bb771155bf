//! What URDFs published for other tools bring, made planar before the loader reads them: a weld
//! to an undeclared `world` link, revolute axes along y or x (the mechanism's plane is found and
//! every frame laid onto the twin's, [`Plane`]), ros_control `<transmission>`s, and elements the
//! twin has no use for (`<frame>`, `<gazebo>`), left out with a note.

use crate::mechanism::{Mechanism, Plane};

/// A defect found here: the element at fault and why.
pub(super) type Defect = (String, String);

/// The link URDFs name as the fixed world without declaring it.
const WORLD: &str = "world";
/// The top-level elements the loader reads (the rest are left out with a note).
const READ: [&str; 6] = [
    "link",
    "joint",
    "loop_joint",
    "wheel",
    "transmission",
    "material",
];

/// A `fixed` joint from an undeclared `world` link makes its child the ground: the joint is
/// dropped and said so. A weld turned by an rpy is refused (it would turn gravity).
pub(super) fn weld_to_world(robot: &mut urdf_rs::Robot) -> Result<Vec<String>, Defect> {
    if robot.links.iter().any(|l| l.name == WORLD) {
        return Ok(Vec::new());
    }
    let Some(index) = robot.joints.iter().position(|j| j.parent.link == WORLD) else {
        return Ok(Vec::new());
    };
    let joint = &robot.joints[index];
    let element = format!("joint \"{}\"", joint.name);
    if joint.joint_type != urdf_rs::JointType::Fixed {
        return Err((
            element,
            "a joint from the undeclared link `world` must be fixed (declare a <link name=\"world\"/> to move against it)".into(),
        ));
    }
    if joint.origin.rpy.0.iter().any(|v| v.abs() > 1e-12) {
        return Err((
            element,
            "a weld to `world` turned by an rpy is not taken (it would turn gravity): put the turn in the scenario's gravity".into(),
        ));
    }
    let note = format!(
        "{element} welds link \"{}\" to `world`: that link is the ground",
        joint.child.link
    );
    robot.joints.remove(index);
    Ok(vec![note])
}

/// The plane the URDF's mechanism moves in: normal to the axis most of its revolute (and
/// continuous) joints turn about, z on a tie with z among them, else the first of the tied; the
/// xy plane when it has none. A joint about another axis is refused by the loader.
pub(super) fn plane_of(robot: &urdf_rs::Robot) -> Plane {
    let axes: Vec<[f64; 3]> = (robot.joints.iter())
        .filter(|j| {
            matches!(
                j.joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous
            )
        })
        .filter_map(|j| unit(j.axis.xyz.0))
        .collect();
    let parallel = |a: [f64; 3], b: [f64; 3]| (dot(a, b).abs() - 1.0).abs() < 1e-9;
    let count = |a: [f64; 3]| axes.iter().filter(|&&b| parallel(a, b)).count();
    let z = [0.0, 0.0, 1.0];
    let most = axes.iter().map(|&a| count(a)).max().unwrap_or(0);
    if most == 0 || count(z) == most {
        return Plane::IDENTITY;
    }
    let first = axes.iter().find(|&&a| count(a) == most);
    first.map_or(Plane::IDENTITY, |&a| Plane::normal_to(a))
}

fn unit([x, y, z]: [f64; 3]) -> Option<[f64; 3]> {
    let norm = (x * x + y * y + z * z).sqrt();
    (norm.is_finite() && norm > 0.0).then(|| [x / norm, y / norm, z / norm])
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Every frame of `robot` re-expressed on `plane` (see [`Plane`]).
pub(super) fn lay(robot: &mut urdf_rs::Robot, plane: &Plane) {
    for joint in &mut robot.joints {
        turn(&mut joint.origin, |xyz, rpy| plane.frame(xyz, rpy));
        joint.axis.xyz.0 = plane.vector(joint.axis.xyz.0);
    }
    for link in &mut robot.links {
        let inertial = &mut link.inertial;
        let i = &inertial.inertia;
        let tensor = [
            [i.ixx, i.ixy, i.ixz],
            [i.ixy, i.iyy, i.iyz],
            [i.ixz, i.iyz, i.izz],
        ];
        let moment = plane.moment_about_normal(tensor, inertial.origin.rpy.0);
        inertial.inertia.izz = moment;
        turn(&mut inertial.origin, |xyz, rpy| plane.frame(xyz, rpy));
        for visual in &mut link.visual {
            turn(&mut visual.origin, |xyz, rpy| plane.shape_frame(xyz, rpy));
        }
        for collision in &mut link.collision {
            turn(&mut collision.origin, |xyz, rpy| {
                plane.shape_frame(xyz, rpy)
            });
        }
    }
}

/// A joint's offset along the plane's normal (z, once laid) moves nothing in the plane (a link
/// turns about a parallel axis, the same moment): it is dropped, with a note.
pub(super) fn axial_offsets(robot: &mut urdf_rs::Robot) -> Vec<String> {
    let mut notes = Vec::new();
    for joint in &mut robot.joints {
        let z = joint.origin.xyz.0[2];
        if z.abs() > 1e-9 {
            notes.push(format!(
                "joint \"{}\": its offset of {} m along the joints' axis is left out: it moves nothing in the plane",
                joint.name,
                z.abs()
            ));
        }
        if z.is_finite() {
            joint.origin.xyz.0[2] = 0.0;
        }
    }
    notes
}

/// Sets `pose` to `lay` of its own xyz and rpy.
fn turn(pose: &mut urdf_rs::Pose, lay: impl Fn([f64; 3], [f64; 3]) -> ([f64; 3], [f64; 3])) {
    let (xyz, rpy) = lay(pose.xyz.0, pose.rpy.0);
    pose.xyz.0 = xyz;
    pose.rpy.0 = rpy;
}

/// A note for each top-level element the twin leaves out (`<frame>`, `<gazebo>`, …).
pub(super) fn left_out(document: &roxmltree::Document) -> Vec<String> {
    let mut notes = Vec::new();
    for node in document
        .root_element()
        .children()
        .filter(|n| n.is_element())
    {
        let tag = node.tag_name().name();
        if READ.contains(&tag) {
            continue;
        }
        let name = node
            .attribute("name")
            .map_or(String::new(), |n| format!(" \"{n}\""));
        notes.push(format!(
            "<{tag}>{name} left out: the twin reads <link>, <joint>, <loop_joint>, <wheel> and <transmission>"
        ));
    }
    notes
}

/// Each ros_control `<transmission>` (a SimpleTransmission driving one joint by effort) makes its
/// joint an actuator with the transmission's mechanical reduction (joint effort = reduction ×
/// actuator effort). Its effort limit is the joint's `<limit effort>`, none when it gives 0.
pub(super) fn transmissions(
    document: &roxmltree::Document,
    mechanism: &mut Mechanism,
) -> Result<Vec<String>, Defect> {
    let mut notes = Vec::new();
    let nodes = document.root_element().children();
    for node in nodes.filter(|n| n.has_tag_name("transmission")) {
        let element = format!("transmission \"{}\"", node.attribute("name").unwrap_or(""));
        let kind = node
            .attribute("type")
            .or_else(|| text_of(&node, "type"))
            .unwrap_or("");
        if !kind.ends_with("SimpleTransmission") {
            return Err((
                element,
                format!("type \"{kind}\" is not taken (a SimpleTransmission, one joint, one actuator, is)"),
            ));
        }
        let joint_node = only_child(&node, "joint", &element)?;
        let joint_name = joint_node.attribute("name").unwrap_or("");
        let Some(j) = mechanism.joint_index(joint_name) else {
            return Err((
                element,
                format!("names no joint of the URDF: \"{joint_name}\""),
            ));
        };
        if !mechanism.joints[j].motion.is_movable() {
            return Err((element, format!("joint \"{joint_name}\" is fixed")));
        }
        check_interfaces(&node, &element)?;
        let reduction = reduction_of(&node, &element)?;
        let joint = &mut mechanism.joints[j];
        joint.reduction = reduction;
        if joint.effort_limit.is_none() {
            joint.effort_limit = Some(f64::INFINITY);
            notes.push(format!(
                "{element} drives joint \"{joint_name}\" with no effort limit (its <limit effort> is 0 or missing)"
            ));
        }
    }
    Ok(notes)
}

/// The one `<tag>` child of a transmission.
fn only_child<'a, 'input>(
    node: &roxmltree::Node<'a, 'input>,
    tag: &str,
    element: &str,
) -> Result<roxmltree::Node<'a, 'input>, Defect> {
    let mut found = node.children().filter(|n| n.has_tag_name(tag));
    match (found.next(), found.next()) {
        (Some(one), None) => Ok(one),
        (None, _) => Err((element.to_string(), format!("needs one <{tag} name=\"…\">"))),
        (Some(_), Some(_)) => Err((
            element.to_string(),
            format!("has more than one <{tag}> (the twin takes simple transmissions only)"),
        )),
    }
}

/// Every `<hardwareInterface>` must be an effort interface: the twin drives joints by effort.
fn check_interfaces(node: &roxmltree::Node, element: &str) -> Result<(), Defect> {
    for interface in node
        .descendants()
        .filter(|n| n.has_tag_name("hardwareInterface"))
    {
        let text = interface.text().unwrap_or("").trim();
        if !text.ends_with("EffortJointInterface") && !text.ends_with("EffortActuatorInterface") {
            return Err((
                format!("{element} <hardwareInterface>"),
                format!("\"{text}\" is not taken: the twin drives joints by effort (EffortJointInterface)"),
            ));
        }
    }
    Ok(())
}

/// The `<mechanicalReduction>`, in the transmission or its actuator; 1 when absent.
fn reduction_of(node: &roxmltree::Node, element: &str) -> Result<f64, Defect> {
    let Some(found) = node
        .descendants()
        .find(|n| n.has_tag_name("mechanicalReduction"))
    else {
        return Ok(1.0);
    };
    let text = found.text().unwrap_or("").trim();
    match text.parse::<f64>() {
        Ok(value) if value.is_finite() && value != 0.0 => Ok(value),
        _ => Err((
            format!("{element} <mechanicalReduction>"),
            format!("\"{text}\" must be a finite, non-zero number"),
        )),
    }
}

fn text_of<'a>(node: &roxmltree::Node<'a, '_>, tag: &str) -> Option<&'a str> {
    node.children()
        .find(|n| n.has_tag_name(tag))
        .and_then(|n| n.text())
        .map(str::trim)
}
