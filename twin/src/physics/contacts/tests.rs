//! The detector against analytic contacts, its pair rules and its broad phase against checking
//! every pair.

use super::*;
use crate::mechanism::Outline;

/// A URDF of links hung from `ground` by revolute joints (so that no two of them are
/// adjacent), each with the collision geometry given, plus `extra` elements.
fn urdf(links: &[(&str, &str)], extra: &str) -> Mechanism {
    let mut text = String::from("<robot name=\"r\"><link name=\"ground\"/>");
    for (name, geometry) in links {
        text.push_str(&format!(
            "<link name=\"{name}\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" \
             ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial>{geometry}</link>\
             <joint name=\"{name}_joint\" type=\"continuous\"><parent link=\"ground\"/>\
             <child link=\"{name}\"/><axis xyz=\"0 0 1\"/></joint>"
        ));
    }
    text.push_str(extra);
    text.push_str("</robot>");
    crate::urdf::load_str(&text, "test.urdf").unwrap_or_else(|e| panic!("{e}"))
}

fn collision(origin: &str, geometry: &str) -> String {
    format!("<collision><origin xyz=\"{origin}\"/><geometry>{geometry}</geometry></collision>")
}

fn pose(x: f64, y: f64, angle: f64) -> Pose2 {
    Pose2::new(x, y, angle)
}

fn body(name: &str, outline: Outline, moves: bool) -> BodyShapes {
    BodyShapes {
        name: name.into(),
        shapes: vec![Shape {
            origin: Pose2::IDENTITY,
            outline,
            color: None,
        }],
        moves,
    }
}

#[test]
fn two_boxes_overlapping_by_a_known_depth() {
    let unit = collision("0 0 0", "<box size=\"1 1 1\"/>");
    let mechanism = urdf(&[("a", &unit), ("b", &unit)], "");
    let mut detector = ContactDetector::new(&mechanism, &[], &[]).unwrap();
    // b 0.9 m right of a and turned a quarter (a square turned 90° is the same square).
    let poses = [
        Pose2::IDENTITY,
        pose(0.0, 0.0, 0.0),
        pose(0.9, 0.2, FRAC_PI_2),
    ];
    let onsets = detector.update(0.5, &poses, &[]).to_vec();
    assert_eq!(onsets.len(), 1, "{onsets:?}");
    let hit = &onsets[0];
    assert_eq!((hit.a.as_str(), hit.b.as_str()), ("a", "b"));
    assert!((hit.depth - 0.1).abs() < 1e-12, "{hit:?}");
    // Midway between a's right face (x = 0.5) and b's left face (x = 0.4), where both overlap.
    assert!((hit.point[0] - 0.45).abs() < 1e-12, "{hit:?}");
    assert!((-0.3..=0.5).contains(&hit.point[1]), "{hit:?}");
    let (metrics, warning) = detector.findings();
    assert_eq!(metrics[0], ("collisions".into(), 1.0));
    assert_eq!(metrics[1], ("first_collision_time".into(), 0.5));
    assert!((metrics[2].1 - 0.1).abs() < 1e-12);
    let warning = warning.unwrap();
    assert!(
        warning.contains("`a` and `b` touched first, at t = 0.500 s"),
        "{warning}"
    );
}

#[test]
fn a_disc_against_a_wall() {
    let disc = collision("0.1 0 0", "<cylinder radius=\"0.1\" length=\"0.02\"/>");
    let mechanism = urdf(&[("arm", &disc)], "");
    let wall = body(
        "wall",
        Outline::Rectangle {
            width: 0.2,
            height: 2.0,
        },
        false,
    );
    let mut detector = ContactDetector::new(&mechanism, &[wall], &[]).unwrap();
    // The wall's face at x = 0.15 m; the disc's centre 0.1 m out along its link turned by 60°.
    let walls = [pose(0.25, 0.0, 0.0)];
    let frame = pose(0.12, -0.3, std::f64::consts::FRAC_PI_3);
    let centre = frame.apply(0.1, 0.0);
    let onsets = detector
        .update(0.0, &[Pose2::IDENTITY, frame], &walls)
        .to_vec();
    assert_eq!(onsets.len(), 1);
    let expected = centre[0] + 0.1 - 0.15;
    assert!(
        (onsets[0].depth - expected).abs() < 1e-9,
        "{onsets:?} vs {expected}"
    );
    assert!((onsets[0].point[1] - centre[1]).abs() < 1e-9, "{onsets:?}");
    assert!((onsets[0].point[0] - (0.15 + expected / 2.0)).abs() < 1e-9);
}

#[test]
fn a_contact_starts_once_and_ends_only_when_apart() {
    let unit = collision("0 0 0", "<box size=\"1 1 1\"/>");
    let mechanism = urdf(&[("a", &unit), ("b", &unit)], "");
    let mut detector = ContactDetector::new(&mechanism, &[], &[]).unwrap();
    let mut at = |time: f64, gap: f64| {
        let poses = [Pose2::IDENTITY, Pose2::IDENTITY, pose(1.0 + gap, 0.0, 0.0)];
        detector.update(time, &poses, &[]).len()
    };
    // Apart, a graze under the tolerance, a touch, a graze, apart, a crash.
    let onsets: Vec<usize> = [
        (0.0, 1e-3),
        (1.0, -5e-7),
        (2.0, -1e-5),
        (3.0, -5e-7),
        (4.0, 1e-3),
    ]
    .into_iter()
    .chain([(5.0, -1e-3), (6.0, -2e-3)])
    .map(|(t, gap)| at(t, gap))
    .collect();
    assert_eq!(onsets, [0, 0, 1, 0, 0, 1, 0]);
    let (metrics, _) = detector.findings();
    assert_eq!(metrics[0].1, 2.0);
    assert_eq!(metrics[1].1, 2.0);
    assert!((metrics[2].1 - 2e-3).abs() < 1e-12, "{metrics:?}");
}

#[test]
fn adjacent_and_welded_links_and_allowed_pairs_are_not_crashes() {
    let unit = collision("0 0 0", "<box size=\"1 1 1\"/>");
    // a and b hang from the ground; c hangs from a, d is welded to c, e to the ground.
    let extra = format!(
        "<link name=\"c\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" \
         iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial>{unit}</link>\
         <joint name=\"c_joint\" type=\"continuous\"><parent link=\"a\"/><child link=\"c\"/>\
         <axis xyz=\"0 0 1\"/></joint>\
         <link name=\"d\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" \
         iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial>{unit}</link>\
         <joint name=\"d_joint\" type=\"fixed\"><parent link=\"c\"/><child link=\"d\"/></joint>\
         <link name=\"e\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" \
         ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial>{unit}</link>\
         <joint name=\"e_joint\" type=\"fixed\"><parent link=\"ground\"/><child link=\"e\"/></joint>\
         <loop_joint name=\"pin\" type=\"revolute\"><link1 link=\"a\" xyz=\"0 0 0\"/>\
         <link2 link=\"b\" xyz=\"0 0 0\"/></loop_joint>"
    );
    let mechanism = urdf(&[("a", &unit), ("b", &unit)], &extra);
    let names: Vec<&str> = mechanism.links.iter().map(|l| l.name.as_str()).collect();
    let everything_at_the_origin = vec![Pose2::IDENTITY; names.len()];
    let block = body("block", Outline::Circle { radius: 0.2 }, false);
    let mut detector = ContactDetector::new(&mechanism, std::slice::from_ref(&block), &[]).unwrap();
    let mut pairs: Vec<(String, String)> = detector
        .update(0.0, &everything_at_the_origin, &[Pose2::IDENTITY])
        .iter()
        .map(|c| (c.a.clone(), c.b.clone()))
        .collect();
    pairs.sort();
    // Left out: a–b (loop joint), a–c (joint), c–d (weld), a–d (a joint to d's welded group),
    // a–e and b–e (joints to the ground, e's group), e–block (neither moves). Links come in
    // tree order (ground, a, b, e, c, d), then the bodies.
    let expected: Vec<(String, String)> = [
        ("a", "block"),
        ("b", "block"),
        ("b", "c"),
        ("b", "d"),
        ("c", "block"),
        ("d", "block"),
        ("e", "c"),
        ("e", "d"),
    ]
    .iter()
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .collect();
    assert_eq!(pairs, expected, "links {names:?}");
    let allowed = [("b", "c"), ("block", "d")];
    let mut detector = ContactDetector::new(&mechanism, &[block], &allowed).unwrap();
    let onsets = detector.update(0.0, &everything_at_the_origin, &[Pose2::IDENTITY]);
    assert!(onsets
        .iter()
        .all(|c| (c.a.as_str(), c.b.as_str()) != ("b", "c")));
    assert!(onsets
        .iter()
        .all(|c| (c.a.as_str(), c.b.as_str()) != ("d", "block")));
    assert_eq!(onsets.len(), 6);
}

#[test]
fn bad_setups_name_the_entry() {
    let unit = collision("0 0 0", "<box size=\"1 1 1\"/>");
    let mechanism = urdf(&[("arm", &unit)], "");
    let clamp = body(
        "clamp",
        Outline::Rectangle {
            width: 0.2,
            height: 0.2,
        },
        false,
    );
    let error = |bodies: &[BodyShapes], allowed: &[(&str, &str)]| {
        ContactDetector::new(&mechanism, bodies, allowed)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    assert_eq!(
        error(std::slice::from_ref(&clamp), &[("arm", "vise")]),
        "allowed_contacts.0: no link or body named `vise` (known: ground, arm, clamp)"
    );
    assert_eq!(
        error(&[], &[("arm", "arm")]),
        "allowed_contacts.0: `arm` cannot be allowed to touch itself"
    );
    let named_as_a_link = body("arm", Outline::Circle { radius: 1.0 }, false);
    assert_eq!(
        error(&[named_as_a_link], &[]),
        "bodies.0 `arm`: a link of the URDF has that name; name the body otherwise"
    );
    let mut detector = ContactDetector::new(&mechanism, std::slice::from_ref(&clamp), &[]).unwrap();
    let links = [Pose2::IDENTITY, Pose2::IDENTITY];
    let start = detector.check_start(&links, &[pose(0.55, 0.0, 0.0)]);
    assert_eq!(
        start.unwrap_err().to_string(),
        "bodies.0 `clamp` overlaps link `arm` at t = 0 by 50.000 mm; move it or allow the pair"
    );
    assert!(detector.check_start(&links, &[pose(0.7, 0.0, 0.0)]).is_ok());
    let mut allowed = ContactDetector::new(&mechanism, &[clamp], &[("clamp", "arm")]).unwrap();
    assert!(allowed.check_start(&links, &[pose(0.55, 0.0, 0.0)]).is_ok());
}

/// A small deterministic generator (the tests need no more).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn the_broad_phase_finds_what_checking_every_pair_finds() {
    let box_ = collision("0.1 0 0", "<box size=\"0.3 0.05 0.1\"/>");
    let disc = collision("0 0.05 0", "<sphere radius=\"0.06\"/>");
    let shapes = format!("{box_}{disc}");
    let names = ["a", "b", "c", "d", "e", "f"];
    let links: Vec<(&str, &str)> = names.iter().map(|n| (*n, shapes.as_str())).collect();
    let mechanism = urdf(&links, "");
    let triangle = Outline::Polygon {
        points: vec![[0.0, 0.0], [0.2, 0.0], [0.0, 0.15]],
    };
    let bodies = [
        body("wedge", triangle, false),
        body("puck", Outline::Circle { radius: 0.05 }, true),
    ];
    let mut detector = ContactDetector::new(&mechanism, &bodies, &[]).unwrap();
    let mut random = Lcg(7);
    let mut found = 0;
    for step in 0..400 {
        let mut place = || {
            pose(
                random.next() - 0.5,
                random.next() - 0.5,
                7.0 * random.next(),
            )
        };
        let links: Vec<Pose2> = (0..mechanism.links.len()).map(|_| place()).collect();
        let bodies = [place(), place()];
        detector.update(step as f64, &links, &bodies);
        let mut broad: Vec<(usize, f64)> =
            detector.hits.iter().map(|h| (h.pair, h.depth)).collect();
        let mut every: Vec<(usize, f64)> = Vec::new();
        for (i, first) in detector.colliders.iter().enumerate() {
            for second in &detector.colliders[i + 1..] {
                let owners = detector.names.len();
                let Some(pair) = detector.pair_of[first.owner * owners + second.owner] else {
                    continue;
                };
                if let Some((depth, _)) = overlap(first, second) {
                    match every.iter_mut().find(|(p, _)| *p == pair) {
                        Some((_, d)) => *d = d.max(depth),
                        None => every.push((pair, depth)),
                    }
                }
            }
        }
        broad.sort_by_key(|h| h.0);
        every.sort_by_key(|h| h.0);
        // The same pairs, as deep (to round-off: the query may see them the other way round).
        let pairs = |hits: &[(usize, f64)]| hits.iter().map(|h| h.0).collect::<Vec<_>>();
        assert_eq!(pairs(&broad), pairs(&every), "step {step}");
        for (b, e) in broad.iter().zip(&every) {
            assert!(
                (b.1 - e.1).abs() < 1e-12,
                "step {step}: {broad:?} vs {every:?}"
            );
        }
        found += every.len();
    }
    assert!(found > 200, "too few contacts to tell: {found}");
}

use std::f64::consts::FRAC_PI_2;

#[test]
fn skipping_steps_by_clearance_misses_no_contact_of_a_smooth_motion() {
    // Links swinging and sliding past each other and a wall in small steps, so that most steps
    // are skipped by clearance: each step's contacts must be those of checking every pair.
    let box_ = collision("0.15 0 0", "<box size=\"0.3 0.04 0.1\"/>");
    let disc = collision("0 0 0", "<cylinder radius=\"0.03\" length=\"0.1\"/>");
    let mechanism = urdf(&[("a", &box_), ("b", &box_), ("c", &disc)], "");
    let wall = Outline::Rectangle {
        width: 0.05,
        height: 1.0,
    };
    let bodies = [body("wall", wall, false)];
    let mut detector = ContactDetector::new(&mechanism, &bodies, &[]).unwrap();
    let mut every = ContactDetector::new(&mechanism, &bodies, &[]).unwrap();
    let (mut onsets, mut measured) = (0, 0);
    for step in 0..20_000 {
        let t = step as f64 * 1e-3;
        let links = [
            Pose2::IDENTITY,
            pose(-0.2, 0.1 * t.sin(), 1.3 * t),
            pose(0.2, -0.05, -0.7 * t + 1.0),
            pose(0.35 * (0.9 * t).cos(), 0.2 * (0.4 * t).sin(), 60.0 * t),
        ];
        let wall = [pose(0.45, 0.0, 0.0)];
        let skipped = detector.update(t, &links, &wall).to_vec();
        // A fresh clearance every step: the reference checks every pair each time.
        every.pairs.iter_mut().for_each(|p| p.clearance = 0.0);
        let checked = every.update(t, &links, &wall).to_vec();
        assert_eq!(skipped, checked, "step {step}");
        onsets += checked.len();
        measured += usize::from(detector.checked_at[1] == links[1]);
    }
    assert_eq!(detector.findings(), every.findings());
    println!("{onsets} onsets, clearances measured at {measured} of 20,000 steps");
    assert!(onsets >= 5, "too few contacts to tell: {onsets}");
    assert!(
        measured < 10_000,
        "clearance skipped too little: {measured}"
    );
}
