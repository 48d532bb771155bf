//! The `<wheel>` extension of the URDF loader: the platform loads, and every wheel defect is a
//! typed error naming the file, the element and the reason.

use twin::engine::JointMotion;
use twin::engine::{load_urdf as load_str, load_urdf_file as load_file, UrdfError};

fn platform_text() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../urdf/platform.urdf");
    std::fs::read_to_string(path).expect("urdf/platform.urdf")
}

fn broken(from: &str, to: &str) -> UrdfError {
    let text = platform_text();
    let changed = text.replacen(from, to, 1);
    assert_ne!(changed, text, "the replacement must change the URDF");
    load_str(&changed, "platform.urdf").expect_err("must be rejected")
}

fn assert_names(err: &UrdfError, parts: &[&str]) {
    let message = err.to_string();
    assert!(
        message.starts_with("platform.urdf"),
        "file not named: {message}"
    );
    for part in parts {
        assert!(message.contains(part), "`{part}` missing from: {message}");
    }
}

#[test]
fn the_platform_loads_with_its_wheels() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../urdf/platform.urdf");
    let mechanism = load_file(std::path::Path::new(path)).unwrap();
    let names: Vec<&str> = mechanism.wheels.iter().map(|w| w.name.as_str()).collect();
    assert_eq!(names, ["left_wheel", "right_wheel", "caster_wheel"]);
    let left = &mechanism.wheels[0];
    assert_eq!(left.radius, 0.04);
    assert_eq!(left.effort_limit, Some(1.0));
    assert_eq!(left.heading(), [1.0, 0.0]);
    assert_eq!(mechanism.wheels[2].effort_limit, None);
    assert_eq!(
        mechanism.links[mechanism.wheels[2].link].name,
        "caster_fork"
    );
    // The planar base: x, y, yaw; the caster swivels about z.
    let motions: Vec<JointMotion> = mechanism.joints.iter().map(|j| j.motion).collect();
    assert_eq!(
        motions,
        [
            JointMotion::Prismatic { axis: [1.0, 0.0] },
            JointMotion::Prismatic { axis: [0.0, 1.0] },
            JointMotion::Revolute { sign: 1.0 },
            JointMotion::Revolute { sign: 1.0 },
        ]
    );
    // No joint is actuated: the wheels are the actuators.
    assert!(mechanism.actuated_joints().is_empty());
    // The carriages are bookkeeping: a millionth of the platform's mass.
    let total: f64 = mechanism
        .links
        .iter()
        .filter_map(|l| l.inertial.map(|i| i.mass))
        .sum();
    assert!((total - 2.92).abs() < 1e-5, "{total}");
}

#[test]
fn wheel_radius_must_be_positive() {
    assert_names(
        &broken(r#"radius="0.04""#, r#"radius="0""#),
        &["wheel \"left_wheel\"", "radius must be > 0, got 0"],
    );
    assert_names(
        &broken(r#"radius="0.04""#, r#"radius="-0.04""#),
        &["wheel \"left_wheel\"", "radius must be > 0"],
    );
    assert_names(
        &broken(r#"radius="0.04""#, r#"radius="big""#),
        &["wheel \"left_wheel\"", "not a number"],
    );
}

#[test]
fn wheel_axis_must_lie_in_the_plane() {
    assert_names(
        &broken(r#"axis="0 1 0""#, r#"axis="0 1 0.5""#),
        &["wheel \"left_wheel\" axis", "not planar", "z part"],
    );
    assert_names(
        &broken(r#"axis="0 1 0""#, r#"axis="0 0 1""#),
        &["wheel \"left_wheel\" axis", "not planar"],
    );
    assert_names(
        &broken(r#"axis="0 1 0""#, r#"axis="0 0 0""#),
        &["wheel \"left_wheel\"", "zero length"],
    );
}

#[test]
fn wheel_on_an_unknown_link() {
    assert_names(
        &broken(
            r#"<wheel name="left_wheel" link="chassis""#,
            r#"<wheel name="left_wheel" link="frame""#,
        ),
        &["wheel \"left_wheel\"", "unknown link \"frame\""],
    );
}

#[test]
fn other_wheel_defects() {
    assert_names(
        &broken(r#"driven="true" effort="1.0"/>"#, r#"driven="true"/>"#),
        &["wheel \"left_wheel\"", "missing effort"],
    );
    assert_names(
        &broken(r#"driven="true""#, r#"driven="yes""#),
        &["wheel \"left_wheel\"", "driven=\"yes\""],
    );
    assert_names(
        &broken(r#"name="right_wheel""#, r#"name="left_wheel""#),
        &["wheel \"left_wheel\"", "already used"],
    );
    assert_names(
        &broken(
            r#"rpy="0 0 0" axis="0 1 0""#,
            r#"rpy="0.2 0 0" axis="0 1 0""#,
        ),
        &["wheel \"left_wheel\"", "roll is 0.2"],
    );
    assert_names(
        &broken(r#"spin_inertia="1e-4""#, r#"spin_inertia="-1""#),
        &["wheel \"left_wheel\"", "spin_inertia must be > 0"],
    );
}

#[test]
fn an_in_plane_continuous_joint_is_not_a_wheel() {
    let err = broken(
        r#"<axis xyz="0 0 1"/>
  </joint>

  <link name="caster_fork">"#,
        r#"<axis xyz="0 1 0"/>
  </joint>

  <link name="caster_fork">"#,
    );
    assert_names(
        &err,
        &["joint \"floor_yaw\" <axis>", "must be ±z", "<wheel>"],
    );
}
