//! Every URDF defect is a typed error naming the file, the element and the reason — never a panic.

use twin::engine::{load_urdf as load_str, load_urdf_file as load_file, UrdfError};

/// A valid two-link pendulum; each test breaks one thing.
const PENDULUM: &str = r#"<robot name="pendulum">
  <link name="ground"/>
  <link name="arm">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0.1"/></inertial>
    <visual><origin xyz="0.5 0 0"/><geometry><box size="1 0.05 0.05"/></geometry></visual>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="ground"/><child link="arm"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="5"/>
  </joint>
</robot>"#;

fn broken(from: &str, to: &str) -> UrdfError {
    let text = PENDULUM.replacen(from, to, 1);
    assert_ne!(text, PENDULUM, "the replacement must change the URDF");
    load_str(&text, "pendulum.urdf").expect_err("must be rejected")
}

fn assert_names(err: &UrdfError, parts: &[&str]) {
    let message = err.to_string();
    assert!(
        message.starts_with("pendulum.urdf"),
        "file not named: {message}"
    );
    for part in parts {
        assert!(message.contains(part), "`{part}` missing from: {message}");
    }
}

#[test]
fn the_valid_pendulum_loads() {
    let mechanism = load_str(PENDULUM, "pendulum.urdf").unwrap();
    assert_eq!(mechanism.links.len(), 2);
    let hinge = &mechanism.joints[0];
    assert_eq!(hinge.effort_limit, Some(10.0));
    assert_eq!(hinge.limits, Some([-1.0, 1.0]));
}

#[test]
fn malformed_xml() {
    let err = load_str("<robot name='x'><link name='a'>", "pendulum.urdf").unwrap_err();
    assert!(matches!(err, UrdfError::Malformed { .. }), "{err}");
    assert_names(&err, &["malformed"]);
}

#[test]
fn unknown_parent_and_child() {
    assert_names(
        &broken(r#"<parent link="ground"/>"#, r#"<parent link="base"/>"#),
        &["joint \"hinge\"", "unknown parent link \"base\""],
    );
    assert_names(
        &broken(r#"<child link="arm"/>"#, r#"<child link="forearm"/>"#),
        &["joint \"hinge\"", "unknown child link \"forearm\""],
    );
}

#[test]
fn a_cycle_in_the_tree() {
    let err = broken(
        "</robot>",
        r#"<joint name="back" type="fixed"><parent link="arm"/><child link="ground"/></joint></robot>"#,
    );
    assert_names(&err, &["cycle"]);
}

#[test]
fn a_moving_link_without_inertial_or_with_bad_mass() {
    let text = PENDULUM.replace(
        r#"<inertial><origin xyz="0.5 0 0"/><mass value="1"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0.1"/></inertial>"#,
        "",
    );
    let err = load_str(&text, "pendulum.urdf").unwrap_err();
    assert_names(&err, &["link \"arm\"", "positive mass"]);
    assert_names(
        &broken(r#"<mass value="1"/>"#, r#"<mass value="-2"/>"#),
        &["link \"arm\"", "mass = -2"],
    );
    assert_names(
        &broken(r#"izz="0.1""#, r#"izz="0""#),
        &["link \"arm\"", "izz must be > 0"],
    );
}

#[test]
fn non_planar_geometry() {
    assert_names(
        &broken(
            r#"<visual><origin xyz="0.5 0 0"/>"#,
            r#"<visual><origin xyz="0.5 0 0.2"/>"#,
        ),
        &["link \"arm\" <visual>", "z offset is 0.2"],
    );
    assert_names(
        &broken(
            r#"<origin xyz="0 0 0" rpy="0 0 0"/><axis"#,
            r#"<origin xyz="0 0 0" rpy="0.3 0 0"/><axis"#,
        ),
        &["joint \"hinge\"", "roll is 0.3"],
    );

    assert_names(
        &broken(
            r#"<origin xyz="0.5 0 0"/><mass"#,
            r#"<origin xyz="0.5 0 0" rpy="0 0.1 0"/><mass"#,
        ),
        &["link \"arm\" <inertial>", "pitch is 0.1"],
    );
    let prismatic = PENDULUM
        .replace(r#"type="revolute""#, r#"type="prismatic""#)
        .replace(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="1 0 0.5"/>"#);
    let err = load_str(&prismatic, "pendulum.urdf").unwrap_err();
    assert_names(
        &err,
        &[
            "joint \"hinge\" <axis>",
            "prismatic axis must lie in the xy plane",
        ],
    );
}

#[test]
fn a_negative_revolute_axis_is_carried_as_a_sign() {
    let text = PENDULUM.replace(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="0 0 -1"/>"#);
    let mechanism = load_str(&text, "pendulum.urdf").unwrap();
    assert_eq!(
        mechanism.joints[0].motion,
        twin::engine::JointMotion::Revolute { sign: -1.0 }
    );
}

#[test]
fn unsupported_joint_type() {
    assert_names(
        &broken(r#"type="revolute""#, r#"type="floating""#),
        &["joint \"hinge\"", "unsupported joint type Floating"],
    );
}

#[test]
fn loop_joint_defects() {
    let closing = |body: &str| PENDULUM.replace("</robot>", &format!("{body}</robot>"));
    let missing = closing(
        r#"<loop_joint name="tie" type="revolute"><link1 link="arm" xyz="1 0 0"/><link2 link="rod" xyz="0 0 0"/></loop_joint>"#,
    );
    let err = load_str(&missing, "pendulum.urdf").unwrap_err();
    assert_names(
        &err,
        &["loop_joint \"tie\" <link2>", "unknown link \"rod\""],
    );

    let open = closing(
        r#"<loop_joint name="tie" type="revolute"><link1 link="arm" xyz="1 0 0"/><link2 link="ground" xyz="0 0.5 0"/></loop_joint>"#,
    );
    let err = load_str(&open, "pendulum.urdf").unwrap_err();
    assert_names(&err, &["loop_joint \"tie\"", "does not close"]);

    let bad_type = closing(
        r#"<loop_joint name="tie" type="ball"><link1 link="arm" xyz="1 0 0"/><link2 link="ground" xyz="1 0 0"/></loop_joint>"#,
    );
    assert_names(
        &load_str(&bad_type, "pendulum.urdf").unwrap_err(),
        &["loop_joint \"tie\"", "unsupported type \"ball\""],
    );

    let bad_numbers = closing(
        r#"<loop_joint name="tie" type="revolute"><link1 link="arm" xyz="1 zero 0"/><link2 link="ground" xyz="1 0 0"/></loop_joint>"#,
    );
    assert_names(
        &load_str(&bad_numbers, "pendulum.urdf").unwrap_err(),
        &["loop_joint \"tie\" <link1>", "not three finite numbers"],
    );
}

#[test]
fn a_missing_file_is_named() {
    let err = load_file(std::path::Path::new("/no/such/machine.urdf")).unwrap_err();
    assert!(matches!(err, UrdfError::Read { .. }));
    assert!(err.to_string().contains("/no/such/machine.urdf"), "{err}");
}

#[test]
fn garbage_never_panics() {
    let samples = [
        "", "<robot/>", "<robot name='r'><joint name='j' type='revolute'/></robot>",
        "<robot name='r'><link name='a'/><link name='a'/></robot>",
        "<robot name='r'><link name='a'/><link name='b'/></robot>",
        "\u{0}\u{1}binary", "<robot name='r'><link name='a'><visual><geometry><mesh filename='x.stl'/></geometry></visual></link></robot>",
    ];
    for sample in samples {
        // Any outcome but a panic is acceptable; defects must come back as errors.
        let _ = load_str(sample, "garbage.urdf");
    }
    assert!(load_str(
        "<robot name='r'><link name='a'/><link name='b'/></robot>",
        "g.urdf"
    )
    .unwrap_err()
    .to_string()
    .contains("more than one root link"));
}

#[test]
fn the_whitworth_urdf_matches_the_analytic_geometry() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../urdf/whitworth.urdf");
    let mechanism = load_file(std::path::Path::new(path)).unwrap();
    let geometry = models::whitworth::Geometry::default();
    let pose = geometry.pose(
        mechanism.joints[mechanism.joint_index("crank").unwrap()]
            .origin
            .angle,
    );
    let links = mechanism.zero_pose();
    let at = |name: &str| links[mechanism.link_index(name).unwrap()];
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(close(at("block").x, pose.crank_pin[0]) && close(at("block").y, pose.crank_pin[1]));
    assert!(
        close(at("coupler").x, pose.coupler_pin[0]) && close(at("coupler").y, pose.coupler_pin[1])
    );
    assert!(close(at("ram").x, pose.ram_pin[0]) && close(at("ram").y, pose.ram_pin[1]));
    assert!(close(at("slotted_link").angle, pose.slot_angle));
    assert_eq!(mechanism.loops.len(), 2);
}
