//! Crash detection, for either engine: every step, the collision shapes of the links (URDF
//! `<collision>`) and of the scenario's bodies (`[[bodies]]`) at their poses, and which pairs
//! that may not touch do.
//!
//! It only reads poses (the links' from [`super::MechanismState`], the bodies' beside them): it
//! changes nothing in the motion, so collision geometry leaves the exact engine's dynamics as
//! they are. A broad phase (sweep and prune on the shapes' bounding boxes along x) finds the
//! boxes that overlap; parry's contact query gives the depth and point of the shapes in them.
//! Each full check also leaves every pair a clearance (a lower bound on how far apart its shapes
//! are); until the owners have moved that far since (translation plus turn times reach, no
//! trigonometry), no pair can touch and the step costs a few comparisons.
//!
//! Allowed to touch: links joined by a tree joint or a loop joint (a pin overlaps its two links
//! by design), links welded by fixed joints (one rigid body), and the pairs the scenario lists
//! in `[[allowed_contacts]]`. Two things that never move (links welded to the root, static
//! bodies) are never checked while running, only a static body against the links at t = 0.

use super::shapes::{parry_shape, to_parry};
use crate::mechanism::{JointMotion, Mechanism, Pose2, Shape};
use parry2d_f64::bounding_volume::Aabb;
use parry2d_f64::math::Pose;
use parry2d_f64::query;
use parry2d_f64::shape::SharedShape;
use thiserror::Error;

/// Two shapes touch when they overlap deeper than this, m: far below any machine's setup
/// tolerance and far above the round-off of parry's queries, so that two faces laid exactly
/// against each other (a part on its fixture) are not a crash. A touching pair is released
/// only once it no longer overlaps at all, so a graze hovering about 1 µm is one contact.
pub const CONTACT_TOLERANCE: f64 = 1e-6;

/// A pair that started to touch at this step: a crash (its pair is not allowed).
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    /// The two links or bodies, links first, each in the order of the URDF and the scenario.
    pub a: String,
    /// The other of the two, the later in that order.
    pub b: String,
    /// How deep the shapes overlap, m.
    pub depth: f64,
    /// Where, world frame, m: midway between the two shapes' deepest points.
    pub point: [f64; 2],
}

impl Collision {
    /// The event's sentence: who, where and how deep (µm below 1 mm, else mm).
    pub fn describe(&self) -> String {
        format!(
            "collision: `{}` hits `{}` at ({:.1}, {:.1}) mm, {} deep",
            self.a,
            self.b,
            1e3 * self.point[0],
            1e3 * self.point[1],
            length(self.depth)
        )
    }
}

/// A length for people: µm below 1 mm, else mm.
pub fn length(metres: f64) -> String {
    if metres.abs() < 1e-3 {
        format!("{:.1} µm", 1e6 * metres)
    } else {
        format!("{:.3} mm", 1e3 * metres)
    }
}

/// A rigid body beside the mechanism, as the detector sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyShapes {
    pub name: String,
    /// Its shapes in its own frame.
    pub shapes: Vec<Shape>,
    /// Whether it can move (a free body); a static one stays where it is put.
    pub moves: bool,
}

/// What is wrong with the contact setup: names the scenario entry to change.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    #[error("allowed_contacts.{entry}: no link or body named `{name}` (known: {known})")]
    UnknownName {
        entry: usize,
        name: String,
        known: String,
    },
    #[error("allowed_contacts.{entry}: `{name}` cannot be allowed to touch itself")]
    SamePair { entry: usize, name: String },
    #[error("bodies.{index} `{name}`: a link of the URDF has that name; name the body otherwise")]
    NameTaken { index: usize, name: String },
    #[error("{owner}: parry cannot make shape {shape} (a polygon without area)")]
    Shape { owner: String, shape: usize },
    #[error(
        "bodies.{index} `{body}` overlaps link `{link}` at t = 0 by {}; move it or allow the pair",
        length(*depth)
    )]
    StartOverlap {
        index: usize,
        body: String,
        link: String,
        depth: f64,
    },
}

/// One shape of a link or body, where it is this step.
struct Collider {
    owner: usize,
    shape: SharedShape,
    /// In its owner's frame.
    local: Pose,
    world: Pose,
    aabb: Aabb,
}

/// A pair of links or bodies that may not touch.
#[derive(Debug, Clone, Copy)]
struct Pair {
    owners: [usize; 2],
    touching: bool,
    /// The update in which it last overlapped.
    seen: u64,
    /// Lower bound on the distance between its shapes at the last full check without an
    /// overlap, m; 0 while it overlaps (every step is then checked in full).
    clearance: f64,
}

/// The deepest overlap of a pair at the step being checked.
#[derive(Debug, Clone, Copy)]
struct Hit {
    pair: usize,
    depth: f64,
    point: [f64; 2],
}

/// The run's contacts so far.
#[derive(Debug, Clone, Copy, Default)]
struct Tally {
    onsets: usize,
    /// Time and pair of the first onset.
    first: Option<(f64, usize)>,
    /// Depth, time and pair of the deepest overlap of a touching pair.
    deepest: Option<(f64, f64, usize)>,
}

/// Finds the pairs that start to touch, step by step. Built once per run.
pub struct ContactDetector {
    /// Owners: the links (URDF order), then the bodies (scenario order).
    names: Vec<String>,
    links: usize,
    /// Per owner: whether it moves.
    moves: Vec<bool>,
    /// Per owner: how far from its origin a point of its shapes can lie that a turn moves (a
    /// disc turning about its centre does not move), m.
    reach: Vec<f64>,
    /// Per owner: its pose at the last full check.
    checked_at: Vec<Pose2>,
    /// Per owner: how far any point of it may have moved since the last full check, m.
    moved: Vec<f64>,
    colliders: Vec<Collider>,
    /// Colliders whose owner moves: their boxes are renewed every step.
    moving: Vec<usize>,
    /// The colliders by the lower x of their boxes (sweep and prune), kept sorted step to step.
    order: Vec<usize>,
    /// Per owner pair (row-major), its index in `pairs`, if it is checked.
    pair_of: Vec<Option<usize>>,
    /// Per owner pair (row-major): allowed to touch.
    allowed: Vec<bool>,
    pairs: Vec<Pair>,
    hits: Vec<Hit>,
    onsets: Vec<Collision>,
    updates: u64,
    tally: Tally,
}

impl ContactDetector {
    /// The detector of a mechanism's link shapes and the scenario's bodies, with the pairs of
    /// `allowed` (names of links or bodies, per `[[allowed_contacts]]` entry) allowed besides the
    /// adjacent links.
    pub fn new(
        mechanism: &Mechanism,
        bodies: &[BodyShapes],
        allowed: &[(&str, &str)],
    ) -> Result<Self, ContactError> {
        let links = mechanism.links.len();
        let mut names: Vec<String> = mechanism.links.iter().map(|l| l.name.clone()).collect();
        for (index, body) in bodies.iter().enumerate() {
            if names[..links].contains(&body.name) {
                let name = body.name.clone();
                return Err(ContactError::NameTaken { index, name });
            }
            names.push(body.name.clone());
        }
        let owners = names.len();
        let group = weld_groups(mechanism);
        // A link moves unless welded to the root (the first link).
        let moves: Vec<bool> = (0..owners)
            .map(|o| match o.checked_sub(links) {
                Some(body) => bodies[body].moves,
                None => group[o] != 0,
            })
            .collect();
        let allowed = allowed_pairs(mechanism, &group, &names, allowed)?;
        let shapes = mechanism
            .links
            .iter()
            .map(|l| &l.collisions)
            .chain(bodies.iter().map(|b| &b.shapes));
        let colliders = colliders(shapes, &names)?;
        let has_shapes: Vec<bool> = (0..owners)
            .map(|o| colliders.iter().any(|c| c.owner == o))
            .collect();
        // Checked: two owners with shapes, one of them moving, not allowed to touch.
        let checked = |a: usize, b: usize| {
            has_shapes[a] && has_shapes[b] && (moves[a] || moves[b]) && !allowed[a * owners + b]
        };
        let mut pairs = Vec::new();
        let mut pair_of = vec![None; owners * owners];
        for a in 0..owners {
            for b in (a + 1..owners).filter(|&b| checked(a, b)) {
                pair_of[a * owners + b] = Some(pairs.len());
                pair_of[b * owners + a] = Some(pairs.len());
                pairs.push(Pair {
                    owners: [a, b],
                    touching: false,
                    seen: 0,
                    clearance: 0.0,
                });
            }
        }
        let moving = (0..colliders.len())
            .filter(|&c| moves[colliders[c].owner])
            .collect();
        let mut reach = vec![0.0_f64; owners];
        for collider in &colliders {
            reach[collider.owner] = reach[collider.owner].max(turn_reach(collider));
        }
        Ok(Self {
            order: (0..colliders.len()).collect(),
            names,
            links,
            moves,
            reach,
            checked_at: vec![Pose2::IDENTITY; owners],
            moved: vec![0.0; owners],
            colliders,
            moving,
            pair_of,
            allowed,
            pairs,
            hits: Vec::new(),
            onsets: Vec::new(),
            updates: 0,
            tally: Tally::default(),
        })
    }

    /// Whether any pair is checked at all (a mechanism without collision shapes has none).
    pub fn is_active(&self) -> bool {
        !self.pairs.is_empty()
    }

    /// Fails when a static body overlaps a link it may not touch at the start (link poses at
    /// t = 0, body poses as placed) deeper than [`CONTACT_TOLERANCE`].
    pub fn check_start(
        &mut self,
        link_poses: &[Pose2],
        body_poses: &[Pose2],
    ) -> Result<(), ContactError> {
        self.place(link_poses, body_poses, false);
        let owners = self.names.len();
        let links = self.links;
        let statics = self
            .colliders
            .iter()
            .filter(|c| c.owner >= links && !self.moves[c.owner]);
        for body in statics {
            let touchable = self
                .colliders
                .iter()
                .filter(|c| c.owner < links && !self.allowed[body.owner * owners + c.owner]);
            for link in touchable {
                match overlap(link, body) {
                    Some((depth, _)) if depth > CONTACT_TOLERANCE => {
                        return Err(ContactError::StartOverlap {
                            index: body.owner - links,
                            body: self.names[body.owner].clone(),
                            link: self.names[link.owner].clone(),
                            depth,
                        })
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Checks the step at `time` (link and body poses as its state has them): the pairs that
    /// start to touch.
    pub fn update(
        &mut self,
        time: f64,
        link_poses: &[Pose2],
        body_poses: &[Pose2],
    ) -> &[Collision] {
        self.onsets.clear();
        if self.pairs.is_empty() {
            return &self.onsets;
        }
        self.updates += 1;
        if self.updates > 1 && self.all_clear(link_poses, body_poses) {
            self.hits.clear();
            return &self.onsets;
        }
        // Things that never move are placed once, at the first update.
        self.place(link_poses, body_poses, self.updates > 1);
        self.sweep();
        // While a pair overlaps every step is checked in full: clearances can wait till none does.
        match self.hits.first() {
            Some(hit) => self.pairs[hit.pair].clearance = 0.0,
            None => self.measure_clearances(link_poses, body_poses),
        }
        for k in 0..self.hits.len() {
            let hit = self.hits[k];
            let pair = &mut self.pairs[hit.pair];
            pair.seen = self.updates;
            if !pair.touching && hit.depth > CONTACT_TOLERANCE {
                pair.touching = true;
                self.tally.onsets += 1;
                self.tally.first.get_or_insert((time, hit.pair));
                let [a, b] = pair.owners;
                self.onsets.push(Collision {
                    a: self.names[a].clone(),
                    b: self.names[b].clone(),
                    depth: hit.depth,
                    point: hit.point,
                });
            }
            let deeper = self.tally.deepest.is_none_or(|(d, _, _)| hit.depth > d);
            if pair.touching && deeper {
                self.tally.deepest = Some((hit.depth, time, hit.pair));
            }
        }
        let updates = self.updates;
        for pair in &mut self.pairs {
            pair.touching &= pair.seen == updates;
        }
        &self.onsets
    }

    /// Whether no pair can touch yet: each has moved less than its clearance since the last
    /// full check (a point of a shape moves at most its owner's translation plus its reach times
    /// the chord of the turn, 2·sin(Δθ/2) ≤ |Δθ|). A non-finite pose is never clear.
    fn all_clear(&mut self, link_poses: &[Pose2], body_poses: &[Pose2]) -> bool {
        for owner in 0..self.names.len() {
            if !self.moves[owner] {
                continue;
            }
            let Some(now) = owner_pose(self.links, owner, link_poses, body_poses) else {
                return false;
            };
            let then = &self.checked_at[owner];
            let turn = std::f64::consts::TAU.mul_add(
                -((now.angle - then.angle) / std::f64::consts::TAU).round(),
                now.angle - then.angle,
            );
            self.moved[owner] =
                (now.x - then.x).hypot(now.y - then.y) + self.reach[owner] * turn.abs();
        }
        let moved = &self.moved;
        self.pairs.iter().all(|pair| {
            let [a, b] = pair.owners;
            moved[a] + moved[b] < pair.clearance
        })
    }

    /// After a full check that found no overlap: every pair's clearance (the gap between the
    /// bounding boxes of its shapes, or where those overlap, the shapes' distance) and where the
    /// owners were.
    fn measure_clearances(&mut self, link_poses: &[Pose2], body_poses: &[Pose2]) {
        for owner in 0..self.names.len() {
            if let Some(pose) = owner_pose(self.links, owner, link_poses, body_poses) {
                self.checked_at[owner] = *pose;
            }
        }
        for pair in &mut self.pairs {
            let [a, b] = pair.owners;
            let mut clearance = f64::INFINITY;
            for first in self.colliders.iter().filter(|c| c.owner == a) {
                for second in self.colliders.iter().filter(|c| c.owner == b) {
                    clearance = clearance.min(distance(first, second));
                }
            }
            pair.clearance = clearance;
        }
    }

    /// The pairs that started to touch at the last update.
    pub fn onsets(&self) -> &[Collision] {
        &self.onsets
    }

    /// Puts the colliders (the moving ones, or all) at their owners' poses; an owner without a
    /// finite pose keeps its last one.
    fn place(&mut self, link_poses: &[Pose2], body_poses: &[Pose2], moving_only: bool) {
        let count = if moving_only {
            self.moving.len()
        } else {
            self.colliders.len()
        };
        for k in 0..count {
            let c = if moving_only { self.moving[k] } else { k };
            let collider = &mut self.colliders[c];
            let owner = collider.owner;
            let pose = if owner < self.links {
                link_poses.get(owner)
            } else {
                body_poses.get(owner - self.links)
            };
            let Some(pose) = pose.filter(|p| [p.x, p.y, p.angle].iter().all(|v| v.is_finite()))
            else {
                continue;
            };
            collider.world = to_parry(pose) * collider.local;
            collider.aabb = collider.shape.compute_aabb(&collider.world);
        }
    }

    /// Sweep and prune along x: the pairs of overlapping boxes whose owners are checked go to
    /// the narrow phase; `hits` gets each pair's deepest overlap.
    fn sweep(&mut self) {
        let colliders = &self.colliders;
        let min_x = |c: usize| colliders[c].aabb.mins.x;
        // Insertion sort: the order changes little from one step to the next.
        for i in 1..self.order.len() {
            let mut j = i;
            while j > 0 && min_x(self.order[j - 1]) > min_x(self.order[j]) {
                self.order.swap(j - 1, j);
                j -= 1;
            }
        }
        self.hits.clear();
        let owners = self.names.len();
        for (i, &a) in self.order.iter().enumerate() {
            let first = &colliders[a];
            for &b in &self.order[i + 1..] {
                let second = &colliders[b];
                if second.aabb.mins.x > first.aabb.maxs.x {
                    break;
                }
                let apart_in_y = second.aabb.mins.y > first.aabb.maxs.y
                    || first.aabb.mins.y > second.aabb.maxs.y;
                let Some(pair) = self.pair_of[first.owner * owners + second.owner] else {
                    continue;
                };
                if apart_in_y {
                    continue;
                }
                if let Some((depth, point)) = overlap(first, second) {
                    match self.hits.iter_mut().find(|h| h.pair == pair) {
                        Some(hit) if hit.depth >= depth => {}
                        Some(hit) => (hit.depth, hit.point) = (depth, point),
                        None => self.hits.push(Hit { pair, depth, point }),
                    }
                }
            }
        }
    }

    /// The run's figures (`collisions`: contact onsets; `first_collision_time`, s, NaN without
    /// one; `deepest_penetration`, m) and, after a crash, a warning naming the first pair.
    pub fn findings(&self) -> (Vec<(String, f64)>, Option<String>) {
        let tally = &self.tally;
        let metrics = vec![
            ("collisions".to_string(), tally.onsets as f64),
            (
                "first_collision_time".to_string(),
                tally.first.map_or(f64::NAN, |(time, _)| time),
            ),
            (
                "deepest_penetration".to_string(),
                tally.deepest.map_or(0.0, |(depth, _, _)| depth),
            ),
        ];
        let warning = tally.first.map(|(time, first)| {
            let pair = |p: usize| {
                let [a, b] = self.pairs[p].owners;
                format!("`{}` and `{}`", self.names[a], self.names[b])
            };
            let deepest = tally.deepest.map_or(String::new(), |(depth, at, p)| {
                format!(
                    ", the deepest {} ({}, t = {at:.3} s)",
                    length(depth),
                    pair(p)
                )
            });
            let onsets = match tally.onsets {
                1 => "1 contact".to_string(),
                n => format!("{n} contacts"),
            };
            format!(
                "collision: {} touched first, at t = {time:.3} s; {onsets} in all{deepest}",
                pair(first),
            )
        });
        (metrics, warning)
    }
}

/// The owners' shapes (per owner, in owner order) as parry's, where their owners' frames are.
fn colliders<'a>(
    shapes: impl Iterator<Item = &'a Vec<Shape>>,
    names: &[String],
) -> Result<Vec<Collider>, ContactError> {
    let mut colliders = Vec::new();
    for (owner, list) in shapes.enumerate() {
        for (k, shape) in list.iter().enumerate() {
            let (shape, local) = parry_shape(shape).ok_or_else(|| ContactError::Shape {
                owner: names[owner].clone(),
                shape: k,
            })?;
            colliders.push(Collider {
                aabb: shape.compute_aabb(&local),
                owner,
                shape,
                local,
                world: local,
            });
        }
    }
    Ok(colliders)
}

/// Per link, its welded group: the topmost link it reaches through fixed joints (0 for the
/// links welded to the root, which never move).
pub(super) fn weld_groups(mechanism: &Mechanism) -> Vec<usize> {
    let mut group: Vec<usize> = (0..mechanism.links.len()).collect();
    // Joints come in tree order: every parent is settled before its children.
    for joint in &mechanism.joints {
        if joint.motion == JointMotion::Fixed {
            group[joint.child] = group[joint.parent];
        }
    }
    group
}

/// Which owners may touch (row-major matrix): links of one welded group, links whose groups a
/// tree or loop joint joins, and the `[[allowed_contacts]]` entries.
pub(super) fn allowed_pairs(
    mechanism: &Mechanism,
    group: &[usize],
    names: &[String],
    entries: &[(&str, &str)],
) -> Result<Vec<bool>, ContactError> {
    let owners = names.len();
    let links = mechanism.links.len();
    let joined: Vec<[usize; 2]> = mechanism
        .joints
        .iter()
        .map(|j| [j.parent, j.child])
        .chain(mechanism.loops.iter().map(|l| [l.link1, l.link2]))
        .map(|[a, b]| [group[a], group[b]])
        .collect();
    let mut allowed = vec![false; owners * owners];
    for a in 0..links {
        for b in 0..links {
            let (ga, gb) = (group[a], group[b]);
            allowed[a * owners + b] =
                ga == gb || joined.iter().any(|&j| j == [ga, gb] || j == [gb, ga]);
        }
    }
    let find = |entry: usize, name: &str| {
        names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| ContactError::UnknownName {
                entry,
                name: name.to_string(),
                known: names.join(", "),
            })
    };
    for (entry, &(a, b)) in entries.iter().enumerate() {
        let (a, b) = (find(entry, a)?, find(entry, b)?);
        if a == b {
            let name = names[a].clone();
            return Err(ContactError::SamePair { entry, name });
        }
        allowed[a * owners + b] = true;
        allowed[b * owners + a] = true;
    }
    Ok(allowed)
}

/// An owner's pose this step, if finite: a link's or a body's.
fn owner_pose<'p>(
    links: usize,
    owner: usize,
    link_poses: &'p [Pose2],
    body_poses: &'p [Pose2],
) -> Option<&'p Pose2> {
    let pose = match owner.checked_sub(links) {
        None => link_poses.get(owner),
        Some(body) => body_poses.get(body),
    };
    pose.filter(|p| [p.x, p.y, p.angle].iter().all(|v| v.is_finite()))
}

/// How far from its owner's origin a point of the collider lies that a turn of the owner moves:
/// a disc moves as its centre; any other shape as its farthest point.
fn turn_reach(collider: &Collider) -> f64 {
    let centre = collider.local.translation.length();
    if collider.shape.as_ball().is_some() {
        return centre;
    }
    let sphere = collider.shape.compute_bounding_sphere(&collider.local);
    sphere.center.length() + sphere.radius
}

/// A lower bound on the distance between two colliders, m: the gap between their boxes, or
/// where those overlap, the shapes' distance (0 when they overlap or the query fails).
fn distance(first: &Collider, second: &Collider) -> f64 {
    let (a, b) = (&first.aabb, &second.aabb);
    let dx = (b.mins.x - a.maxs.x).max(a.mins.x - b.maxs.x).max(0.0);
    let dy = (b.mins.y - a.maxs.y).max(a.mins.y - b.maxs.y).max(0.0);
    if dx > 0.0 || dy > 0.0 {
        return dx.hypot(dy);
    }
    query::distance(
        &first.world,
        first.shape.as_ref(),
        &second.world,
        second.shape.as_ref(),
    )
    .map_or(0.0, |found| found.distance)
}

/// How deep two colliders overlap (m, > 0) and where, world frame; `None` when they do not.
fn overlap(first: &Collider, second: &Collider) -> Option<(f64, [f64; 2])> {
    let contact = query::contact(
        &first.world,
        first.shape.as_ref(),
        &second.world,
        second.shape.as_ref(),
        0.0,
    )
    .ok()
    .flatten()?;
    let middle = (contact.point1 + contact.point2) * 0.5;
    (contact.dist < 0.0).then_some((-contact.dist, [middle.x, middle.y]))
}

#[cfg(test)]
mod tests;
