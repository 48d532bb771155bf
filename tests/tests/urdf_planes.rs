//! URDFs published for other tools, laid onto the twin's plane: a mechanism turning about y or x
//! is the same mechanism as its twin about z; a weld to an undeclared `world` makes the ground; a
//! joint's offset along the axis is left out with a note; `<transmission>`s make actuators; and
//! what cannot be laid flat is refused, naming the element.

use twin::engine::{load_urdf as load_str, UrdfError};

/// A two-link arm turning about `axis`, its links along `along` (a unit vector in the plane),
/// its second joint offset by `offset` along the axis, with `extra` inside the robot.
fn arm(axis: [f64; 3], along: [f64; 3], offset: f64, extra: &str) -> String {
    let at = |k: f64| {
        let p: Vec<String> = (0..3)
            .map(|i| format!("{:?}", k * along[i] + offset * axis[i]))
            .collect();
        p.join(" ")
    };
    let half = |k: f64| {
        let p: Vec<String> = (0..3).map(|i| format!("{:?}", k * along[i])).collect();
        p.join(" ")
    };
    let [ax, ay, az] = axis;
    // The inertia about the axis is 0.02 (upper) and 0.01 (lower); about the others, 0.5.
    let inertia = |moment: f64| {
        let d: Vec<f64> = axis
            .iter()
            .map(|a| if a.abs() > 0.5 { moment } else { 0.5 })
            .collect();
        format!(
            r#"<inertia ixx="{:?}" ixy="0" ixz="0" iyy="{:?}" iyz="0" izz="{:?}"/>"#,
            d[0], d[1], d[2]
        )
    };
    format!(
        r#"<robot name="arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="{h1}"/><mass value="2"/>{i1}</inertial></link>
  <link name="lower"><inertial><origin xyz="{h2}"/><mass value="1"/>{i2}</inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="upper"/>
    <axis xyz="{ax} {ay} {az}"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <origin xyz="{o2}"/><axis xyz="{ax} {ay} {az}"/>
    <limit lower="-2" upper="2" effort="30" velocity="5"/></joint>
  {extra}
</robot>"#,
        h1 = half(0.25),
        h2 = half(0.2),
        o2 = at(0.5),
        i1 = inertia(0.02),
        i2 = inertia(0.01),
    )
}

fn message(err: UrdfError) -> String {
    err.to_string()
}

#[test]
fn an_arm_about_y_is_the_arm_about_z_hanging_in_the_plane() {
    // About z, links along −y (hanging); about y, links along −z (hanging in a z-up world).
    let flat = load_str(
        &arm([0.0, 0.0, 1.0], [0.0, -1.0, 0.0], 0.0, ""),
        "flat.urdf",
    )
    .unwrap();
    let upright = load_str(&arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, ""), "up.urdf").unwrap();
    for (a, b) in flat.links.iter().zip(&upright.links) {
        let (a, b) = (a.inertial, b.inertial);
        assert_eq!(a.map(|i| i.mass), b.map(|i| i.mass));
        let (a, b) = (a.map(|i| i.izz), b.map(|i| i.izz));
        assert_eq!(a, b, "the moment about the axis");
    }
    for (a, b) in flat.links.iter().zip(&upright.links).skip(1) {
        let (a, b) = (a.inertial.unwrap(), b.inertial.unwrap());
        for k in 0..2 {
            assert!((a.centre_of_mass[k] - b.centre_of_mass[k]).abs() < 1e-15);
        }
    }
    for (a, b) in flat.joints.iter().zip(&upright.joints) {
        assert!((a.origin.x - b.origin.x).abs() < 1e-15 && (a.origin.y - b.origin.y).abs() < 1e-15);
    }
    // The URDF's +y axis points into the screen: the joints count about it, so their sign flips.
    assert!(upright.notes.is_empty(), "{:?}", upright.notes);
    assert_ne!(flat.joints[0].motion, upright.joints[0].motion);
}

#[test]
fn an_arm_about_x_lays_y_and_z_on_the_plane() {
    let flat = load_str(
        &arm([0.0, 0.0, 1.0], [0.0, -1.0, 0.0], 0.0, ""),
        "flat.urdf",
    )
    .unwrap();
    let turned = load_str(&arm([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.0, ""), "x.urdf").unwrap();
    let (a, b) = (flat.joints[1].origin, turned.joints[1].origin);
    assert!(
        (a.x - b.x).abs() < 1e-15 && (a.y - b.y).abs() < 1e-15,
        "{a:?} {b:?}"
    );
}

#[test]
fn an_offset_along_the_axis_is_left_out_with_a_note() {
    let offset = load_str(&arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.1, ""), "o.urdf").unwrap();
    let plain = load_str(&arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, ""), "p.urdf").unwrap();
    assert_eq!(offset.joints, plain.joints);
    assert_eq!(offset.notes.len(), 1, "{:?}", offset.notes);
    assert!(
        offset.notes[0].contains("joint \"elbow\""),
        "{:?}",
        offset.notes
    );
}

#[test]
fn a_weld_to_world_makes_the_ground_and_a_frame_is_left_out() {
    let extra = r#"<joint name="weld" type="fixed"><parent link="world"/><child link="base"/></joint>
  <frame name="hand" link="lower" xyz="0 0 -0.4" rpy="0 0 0"/>"#;
    let mechanism = load_str(
        &arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, extra),
        "w.urdf",
    )
    .unwrap();
    assert_eq!(mechanism.links[0].name, "base");
    let notes = mechanism.notes.join("\n");
    assert!(
        notes.contains("joint \"weld\" welds link \"base\""),
        "{notes}"
    );
    assert!(notes.contains("<frame> \"hand\" left out"), "{notes}");
}

#[test]
fn a_transmission_makes_an_actuator_with_its_reduction() {
    let extra = r#"<transmission name="shoulder_drive">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
    <actuator name="shoulder_motor"><mechanicalReduction>50</mechanicalReduction></actuator>
  </transmission>"#;
    let mechanism = load_str(
        &arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, extra),
        "t.urdf",
    )
    .unwrap();
    let shoulder = &mechanism.joints[0];
    assert_eq!(shoulder.reduction, 50.0);
    assert_eq!(shoulder.effort_limit, Some(f64::INFINITY));
    assert_eq!(mechanism.actuated_joints(), [0, 1]);
}

#[test]
fn what_cannot_be_laid_flat_is_refused_by_name() {
    let skew = arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, "").replacen(
        r#"<origin xyz="0.0 0.0 -0.5"/><axis xyz="0 1 0"/>"#,
        r#"<origin xyz="0.0 0.0 -0.5"/><axis xyz="1 0 0"/>"#,
        1,
    );
    let err = message(load_str(&skew, "skew.urdf").unwrap_err());
    assert!(
        err.starts_with("skew.urdf: joint \"elbow\" <axis>"),
        "{err}"
    );
    assert!(err.contains("must be parallel"), "{err}");
    let position = r#"<transmission name="t"><type>transmission_interface/SimpleTransmission</type>
    <joint name="elbow"><hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface></joint>
    <actuator name="m"/></transmission>"#;
    let err = message(
        load_str(
            &arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, position),
            "p.urdf",
        )
        .unwrap_err(),
    );
    assert!(
        err.contains("transmission \"t\" <hardwareInterface>"),
        "{err}"
    );
    assert!(err.contains("by effort"), "{err}");
    let moving_world = r#"<joint name="w" type="revolute"><parent link="world"/><child link="base"/>
    <axis xyz="0 1 0"/></joint>"#;
    let err = message(
        load_str(
            &arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, moving_world),
            "m.urdf",
        )
        .unwrap_err(),
    );
    assert!(
        err.contains("joint \"w\"") && err.contains("must be fixed"),
        "{err}"
    );
    let bad_reduction = r#"<transmission name="t"><type>SimpleTransmission</type>
    <joint name="elbow"/><actuator name="m"><mechanicalReduction>0</mechanicalReduction></actuator></transmission>"#;
    let err = message(
        load_str(
            &arm([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], 0.0, bad_reduction),
            "r.urdf",
        )
        .unwrap_err(),
    );
    assert!(
        err.contains("<mechanicalReduction>") && err.contains("non-zero"),
        "{err}"
    );
}
