//! Collision geometry and crash detection through the library's doors: URDF `<collision>`
//! shapes (boxes, cylinders standing or lying, spheres, STL and OBJ meshes), the `arm-crash`
//! scenario's report and stop, collision geometry leaving the dynamics alone, and every bad
//! contact input against its one-line error.

use framework::{EventKind, EventLevel};
use std::path::Path;
use twin::engine::{load_urdf_file, Outline, Shape};
use twin::{
    FailureKind, LoadedScenario, Observer, ObserverError, RunSummary, Scenario, StepView, Twin,
};

fn builtin_text(name: &str) -> &'static str {
    twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap()
        .1
}

/// A built-in scenario with `extra` TOML appended and `--set`-style assignments.
fn scenario(name: &str, extra: &str, sets: &[&str]) -> Result<LoadedScenario, String> {
    let text = format!("{}\n{extra}", builtin_text(name));
    let mut builder = Scenario::from_toml(&text, name, None).map_err(|e| e.to_string())?;
    for set in sets {
        builder = builder.assign(set).map_err(|e| e.to_string())?;
    }
    builder
        .build(&controllers::builtin())
        .map_err(|e| e.to_string())
}

/// Every crash seen by an observer: (time, a, b, depth) from the step views, and the events.
#[derive(Default)]
struct Crashes {
    seen: Vec<(f64, String, String, f64)>,
    events: Vec<(EventLevel, EventKind, String)>,
}

impl Observer for Crashes {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        for c in view.collisions {
            self.seen
                .push((view.time, c.a.clone(), c.b.clone(), c.depth));
        }
        for event in view.events {
            self.events
                .push((event.level, event.kind.clone(), event.text.clone()));
        }
        Ok(())
    }
}

fn run(loaded: LoadedScenario) -> (RunSummary, Crashes) {
    let mut crashes = Crashes::default();
    let summary = Twin::new(loaded)
        .and_then(|twin| twin.run_with(None, &mut [&mut crashes]))
        .unwrap_or_else(|e| panic!("{e}"));
    (summary, crashes)
}

#[test]
fn arm_crash_reports_the_hand_hitting_the_clamp_when_and_how_deep() {
    let (summary, crashes) = run(scenario("arm-crash", "", &["duration=6"]).unwrap());
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let (time, a, b, depth) = &crashes.seen[0];
    assert_eq!((a.as_str(), b.as_str()), ("hand", "clamp"));
    // During the approach, as the head swoops over the part (the guide's arm chapter, arm-crash).
    assert!((1.4..1.55).contains(time), "{time}");
    assert!(*depth > 1e-6 && *depth < 1e-3, "{depth}");
    assert!(crashes
        .seen
        .iter()
        .all(|(_, a, b, _)| a == "hand" && b == "clamp"));
    let kind = EventKind::Collision {
        a: "hand".into(),
        b: "clamp".into(),
    };
    let event = crashes.events.iter().find(|(_, k, _)| *k == kind).unwrap();
    assert_eq!(event.0, EventLevel::Warning);
    assert!(
        event.2.starts_with("collision: `hand` hits `clamp` at ("),
        "{}",
        event.2
    );
    assert!(event.2.ends_with("µm deep"), "{}", event.2);
    let metric = |name: &str| summary.metric(name).unwrap();
    assert_eq!(metric("collisions"), crashes.seen.len() as f64);
    assert_eq!(metric("first_collision_time"), *time);
    // The cut runs the head 5 mm into the clamp (the head reaches 30 mm, the clamp is 25 mm in).
    let deepest = metric("deepest_penetration");
    assert!((4e-3..6e-3).contains(&deepest), "{deepest}");
    let warning = summary
        .warnings
        .iter()
        .find(|w| w.starts_with("collision:"));
    assert!(
        warning.is_some_and(|w| w.contains("`hand` and `clamp` touched first")),
        "{:?}",
        summary.warnings
    );
}

#[test]
fn stop_on_collision_ends_the_run_at_the_first_crash_naming_both() {
    let loaded = scenario("arm-crash", "", &["health.stop_on_collision=true"]).unwrap();
    let (summary, crashes) = run(loaded);
    let failure = summary.failure.as_ref().expect("stopped");
    assert_eq!(failure.kind, FailureKind::Collision);
    assert_eq!(failure.signal, "collision hand/clamp");
    assert_eq!(summary.steps, failure.step);
    assert_eq!(failure.time, crashes.seen[0].0);
    let text = failure.to_string();
    assert!(text.starts_with("run stopped at step 1"), "{text}");
    assert!(
        text.contains("collision hand/clamp") && text.ends_with("µm deep"),
        "{text}"
    );
    // The crash is the run's last event, at error level, and no divergence is claimed.
    let (level, kind, _) = crashes.events.last().unwrap();
    assert_eq!(*level, EventLevel::Error);
    assert!(matches!(kind, EventKind::Collision { .. }), "{kind:?}");
    assert!(!crashes
        .events
        .iter()
        .any(|(_, kind, _)| *kind == EventKind::Divergence));
    assert_eq!(summary.metric("collisions"), Some(1.0));
}

#[test]
fn collision_geometry_leaves_the_exact_engines_motion_alone() {
    // arm-milling with the URDF's collision shapes and the same URDF without them: the same
    // series, bit for bit, and no crash in the program.
    let dir = tempfile::tempdir().unwrap();
    let urdf =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../urdf/arm.urdf")).unwrap();
    let mut bare = String::new();
    let mut rest = urdf.as_str();
    while let Some(start) = rest.find("<collision>") {
        bare.push_str(&rest[..start]);
        let end = rest[start..].find("</collision>").unwrap() + start;
        rest = &rest[end + "</collision>".len()..];
    }
    bare.push_str(rest);
    assert!(!bare.contains("<collision>") && urdf.contains("<collision>"));
    std::fs::write(dir.path().join("bare.urdf"), bare).unwrap();
    let text = builtin_text("arm-milling").replace("urdf/arm.urdf", "bare.urdf");
    let path = dir.path().join("bare.toml");
    std::fs::write(&path, text).unwrap();
    let bare = Scenario::from_file(&path)
        .unwrap()
        .duration(4.0)
        .build(&controllers::builtin())
        .unwrap();
    let shaped = scenario("arm-milling", "", &["duration=4"]).unwrap();
    let (with_shapes, _) = run(shaped);
    let (without, _) = run(bare);
    assert_eq!(with_shapes.series_digest, without.series_digest);
    assert_eq!(with_shapes.metric("collisions"), Some(0.0));
    assert_eq!(
        without.metric("collisions"),
        None,
        "nothing to check, nothing reported"
    );
}

/// Writes `files` (path, bytes) under a fresh folder; returns it.
fn folder(files: &[(&str, Vec<u8>)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (path, bytes) in files {
        let path = dir.path().join(path);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    dir
}

/// A binary STL of the unit cube (12 triangles, corners 0 and 1).
fn cube_stl() -> Vec<u8> {
    let corner = |i: u8| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32];
    let faces: [[u8; 3]; 12] = [
        [0, 1, 3],
        [0, 3, 2],
        [4, 6, 7],
        [4, 7, 5],
        [0, 4, 5],
        [0, 5, 1],
        [2, 3, 7],
        [2, 7, 6],
        [0, 2, 6],
        [0, 6, 4],
        [1, 5, 7],
        [1, 7, 3],
    ];
    let mut bytes = vec![0u8; 80];
    bytes.extend_from_slice(&(faces.len() as u32).to_le_bytes());
    for face in faces {
        bytes.extend_from_slice(&[0u8; 12]);
        for v in face {
            for c in corner(v) {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
        bytes.extend_from_slice(&[0, 0]);
    }
    bytes
}

/// A one-link robot whose link carries `collisions`.
fn robot(collisions: &str) -> String {
    format!(
        r#"<robot name="probe">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    {collisions}
  </link>
  <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/></joint>
</robot>"#
    )
}

fn collision(origin: &str, geometry: &str) -> String {
    format!("<collision><origin {origin}/><geometry>{geometry}</geometry></collision>")
}

fn area(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|i| points[i][0] * points[(i + 1) % n][1] - points[(i + 1) % n][0] * points[i][1])
        .sum::<f64>()
        / 2.0
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn urdf_collisions_become_outlines_on_their_links() {
    let tet = "# a tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n";
    let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 5\nvertex 0.1 0 5\n\
                 vertex 0 0.1 5\nendloop\nendfacet\nendsolid t\n";
    let dir = folder(&[
        ("robot/meshes/cube.stl", cube_stl()),
        ("robot/meshes/tet.OBJ", tet.as_bytes().to_vec()),
        ("elsewhere/thin.stl", ascii.as_bytes().to_vec()),
    ]);
    let absolute = dir.path().join("elsewhere/thin.stl");
    let collisions = [
        collision(
            r#"xyz="0.1 0 0" rpy="0 0 0.5""#,
            r#"<box size="0.2 0.1 0.05"/>"#,
        ),
        collision(
            r#"xyz="0 0 0""#,
            r#"<cylinder radius="0.05" length="0.3"/>"#,
        ),
        // Lying down: its axis along -y (a roll), along +x (a pitch, written to 4 decimals).
        collision(
            r#"xyz="0 0 0" rpy="1.5707963267948966 0 0""#,
            r#"<cylinder radius="0.05" length="0.3"/>"#,
        ),
        collision(
            r#"xyz="0 0 0" rpy="0 1.5708 0""#,
            r#"<cylinder radius="0.05" length="0.3"/>"#,
        ),
        collision(
            r#"xyz="0 0.2 0" rpy="0.3 0.2 0""#,
            r#"<sphere radius="0.02"/>"#,
        ),
        // The cube scaled to 0.1 × 0.2 × 0.3 and rolled a quarter turn: (x, y, z) → (x, −z, y).
        collision(
            r#"xyz="0.5 0 0" rpy="1.5707963267948966 0 0""#,
            r#"<mesh filename="../meshes/cube.stl" scale="0.1 0.2 0.3"/>"#,
        ),
        collision(
            r#"xyz="0 0 0""#,
            r#"<mesh filename="package://robot/meshes/tet.OBJ"/>"#,
        ),
        collision(
            r#"xyz="0 0 0""#,
            &format!(r#"<mesh filename="file://{}"/>"#, absolute.display()),
        ),
    ];
    std::fs::create_dir_all(dir.path().join("robot/urdf")).unwrap();
    let path = dir.path().join("robot/urdf/probe.urdf");
    std::fs::write(&path, robot(&collisions.concat())).unwrap();
    let mechanism = load_urdf_file(&path).unwrap_or_else(|e| panic!("{e}"));
    let shapes: &[Shape] = &mechanism.links[1].collisions;
    assert_eq!(shapes.len(), 8);
    let rectangle = |shape: &Shape| match shape.outline {
        Outline::Rectangle { width, height } => (width, height, shape.origin.angle),
        ref other => panic!("not a rectangle: {other:?}"),
    };
    assert_eq!(rectangle(&shapes[0]), (0.2, 0.1, 0.5));
    assert_eq!(shapes[1].outline, Outline::Circle { radius: 0.05 });
    let (w, h, angle) = rectangle(&shapes[2]);
    assert!(close(w, 0.3) && close(h, 0.1) && close(angle, -std::f64::consts::FRAC_PI_2));
    let (w, h, angle) = rectangle(&shapes[3]);
    assert!(
        close(w, 0.3) && close(h, 0.1) && angle.abs() < 1e-4,
        "{angle}"
    );
    assert_eq!(shapes[4].outline, Outline::Circle { radius: 0.02 });
    assert_eq!([shapes[4].origin.x, shapes[4].origin.y], [0.0, 0.2]);
    let polygon = |shape: &Shape| match &shape.outline {
        Outline::Polygon { points } => points.clone(),
        other => panic!("not a polygon: {other:?}"),
    };
    let cube = polygon(&shapes[5]);
    assert_eq!(cube.len(), 4, "{cube:?}");
    assert!(close(area(&cube), 0.1 * 0.3), "{cube:?}");
    for [x, y] in &cube {
        assert!(close(*x, 0.0) || close(*x, 0.1), "{cube:?}");
        assert!(close(*y, 0.0) || close(*y, -0.3), "{cube:?}");
    }
    assert_eq!(shapes[5].origin.x, 0.5);
    let tetrahedron = polygon(&shapes[6]);
    assert_eq!(tetrahedron.len(), 3);
    assert!(close(area(&tetrahedron), 0.5));
    assert!(close(area(&polygon(&shapes[7])), 0.005));
}

/// Files written beside a URDF: (name, contents).
type Files<'a> = Vec<(&'a str, Vec<u8>)>;

/// Loads `robot(collisions)` written beside `files`; the error's text.
fn urdf_error(collisions: &str, files: &[(&str, Vec<u8>)]) -> (String, String) {
    let dir = folder(files);
    let path = dir.path().join("bad.urdf");
    std::fs::write(&path, robot(collisions)).unwrap();
    let err = load_urdf_file(&path).expect_err(collisions).to_string();
    (err, path.display().to_string())
}

#[test]
fn bad_collision_geometry_is_one_line_naming_the_file_and_element() {
    let at = r#"xyz="0 0 0""#;
    let line = |points: &str| format!("solid l\n{points}endsolid l\n");
    let collinear = line("vertex 0 0 0\nvertex 1 1 0\nvertex 2 2 0\n");
    let cases: Vec<(String, Files, &str)> = vec![
        (
            collision(
                r#"xyz="0 0 0" rpy="0.3 0 0""#,
                r#"<cylinder radius="0.1" length="1"/>"#,
            ),
            vec![],
            "neither along z nor in the plane",
        ),
        (
            collision(r#"xyz="0 0 0" rpy="0 0.4 0""#, r#"<box size="1 1 1"/>"#),
            vec![],
            "the box is tilted out of the plane",
        ),
        (
            collision(at, r#"<mesh filename="meshes/none.stl"/>"#),
            vec![],
            "mesh \"meshes/none.stl\": ",
        ),
        (
            collision(at, r#"<mesh filename="part.dae"/>"#),
            vec![("part.dae", b"<COLLADA/>".to_vec())],
            "unsupported mesh format `.dae` (STL and OBJ are read)",
        ),
        (
            collision(at, r#"<mesh filename="line.stl"/>"#),
            vec![("line.stl", collinear.into_bytes())],
            "no area",
        ),
        (
            collision(at, r#"<mesh filename="package://nowhere/x.stl"/>"#),
            vec![],
            "package `nowhere` with `x.stl` not found",
        ),
        (
            collision(at, r#"<mesh filename="m.obj" scale="0 1 1"/>"#),
            vec![],
            "scale must be three finite non-zero numbers",
        ),
        (
            collision(at, r#"<box size="0 0.1 0.1"/>"#),
            vec![],
            "box size x must be > 0, got 0",
        ),
        (
            collision(at, r#"<cylinder radius="-0.1" length="1"/>"#),
            vec![],
            "radius must be > 0, got -0.1",
        ),
        (
            collision(at, r#"<cylinder radius="0.1" length="NaN"/>"#),
            vec![],
            "length must be > 0, got NaN",
        ),
        (
            collision(at, r#"<sphere radius="0"/>"#),
            vec![],
            "radius must be > 0, got 0",
        ),
        (
            collision(at, r#"<capsule radius="0.1" length="1"/>"#),
            vec![],
            "unsupported geometry capsule",
        ),
    ];
    for (collision, files, expected) in cases {
        let (err, path) = urdf_error(&collision, &files);
        assert!(!err.contains('\n'), "{err}");
        assert!(err.starts_with(&path), "{err}");
        assert!(err.contains("link \"arm\" <collision>"), "{err}");
        assert!(err.contains(expected), "`{expected}` missing from: {err}");
    }
    let (err, _) = urdf_error(&collision(at, r#"<mesh filename="meshes/none.stl"/>"#), &[]);
    assert!(
        err.contains(&format!("meshes{}none.stl", std::path::MAIN_SEPARATOR)),
        "{err}"
    );
}

/// `Twin::new` then the run, for a scenario that should fail: the error's text.
fn refused(loaded: Result<LoadedScenario, String>) -> String {
    let loaded = match loaded {
        Ok(loaded) => loaded,
        Err(error) => return error,
    };
    match Twin::new(loaded).and_then(|twin| twin.run(None)) {
        Ok(summary) => panic!("ran: {:?}", summary.failure),
        Err(error) => error.to_string(),
    }
}

#[test]
fn bad_bodies_and_pairs_are_refused_naming_the_entry() {
    let body =
        |shape: &str| format!("[[bodies]]\nname = \"clamp\"\npose = [0.4, -0.3, 0]\n{shape}");
    let cases = [
        (body("[[bodies.shapes]]\nsize = [0.0, 0.1]\n"), "bodies.0 (`clamp`): shapes.0: size must be > 0"),
        (body("[[bodies.shapes]]\nradius = -0.01\n"), "bodies.0 (`clamp`): shapes.0: radius must be > 0"),
        (
            body("[[bodies.shapes]]\nsize = [nan, 0.1]\n"),
            "`bodies.0.shapes.0.size.0` = NaN: must be a finite number",
        ),
        (
            body("[[bodies.shapes]]\ncapsule = 0.1\n"),
            "`bodies.0.shapes.0.capsule`: unknown field `capsule`",
        ),
        (body("[[bodies.shapes]]\norigin = [0, 0, 0]\n"), "give exactly one of size"),
        (
            body("[[bodies.shapes]]\npoints = [[0, 0], [1, 1], [2, 2]]\n"),
            "the polygon has no area",
        ),
        (
            body("[[bodies.shapes]]\npoints = [[0, 0], [0.1, 0], [0.02, 0.02], [0, 0.1]]\n"),
            "points.2 [0.02, 0.02] is not a corner of a convex polygon",
        ),
        (body(""), "`bodies.0`: missing field `shapes`"),
        (body("shapes = []\n"), "bodies.0 (`clamp`): give it at least one shape"),
        (
            body("kind = \"free\"\nmass = 1.0\n[[bodies.shapes]]\nradius = 0.01\n"),
            "bodies.0 `clamp`: free bodies need `[solver] engine = \"rapier\"`",
        ),
        (
            "[[bodies]]\nname = \"hand\"\n[[bodies.shapes]]\nradius = 0.01\n".to_string(),
            "bodies.0 `hand`: a link of the URDF has that name",
        ),
        (
            "[[allowed_contacts]]\na = \"hand\"\nb = \"vise\"\n".to_string(),
            "allowed_contacts.0: no link or body named `vise` (known: base, upper_arm, forearm, \
             hand, cutter)",
        ),
        (
            // Across the stretched arm's forearm (0.38 to 0.78 m along x) at t = 0.
            "[[bodies]]\nname = \"post\"\npose = [0.6, 0.0, 0.0]\n[[bodies.shapes]]\n\
             size = [0.02, 0.2]\n"
                .to_string(),
            "bodies.0 `post` overlaps link `forearm` at t = 0 by 135.000 mm; move it or allow the pair",
        ),
    ];
    for (extra, expected) in cases {
        let error = refused(scenario("arm-milling", &extra, &[]));
        assert!(!error.contains('\n'), "{error}");
        assert!(
            error.contains(expected),
            "`{expected}` missing from: {error}"
        );
    }
    // Allowed, the same post is no error.
    let allowed = "[[bodies]]\nname = \"post\"\npose = [0.6, 0.0, 0.0]\n[[bodies.shapes]]\n\
                   size = [0.02, 0.2]\n[[allowed_contacts]]\na = \"forearm\"\nb = \"post\"\n";
    let loaded = scenario("arm-milling", allowed, &["duration=0.01"]).unwrap();
    let (summary, _) = run(loaded);
    assert!(summary.failure.is_none());
}

#[test]
fn the_recording_draws_the_bodies_and_the_crashes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("crash.rrd");
    let loaded = scenario(
        "arm-crash",
        "",
        &["duration=2", "health.stop_on_collision=true"],
    );
    let summary = Twin::new(loaded.unwrap())
        .and_then(|twin| twin.run(Some(&out)))
        .unwrap();
    assert!(summary.failure.is_some());
    let contents = twin::recordings::inspect(Path::new(&out)).unwrap();
    for entity in [
        "/mechanism/bodies/clamp",
        "/mechanism/bodies/part",
        "/mechanism/collisions",
    ] {
        assert!(
            contents.entities.contains(entity),
            "{:?}",
            contents.entities
        );
    }
    assert!(
        contents
            .events
            .iter()
            .any(|e| e.contains("collision: `hand` hits `clamp`")),
        "{:?}",
        contents.events
    );
}
