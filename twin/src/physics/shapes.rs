//! The twin's outlines as parry shapes, and its poses as parry's: the one place that turns the
//! mechanism's geometry into what parry (and Rapier, which re-exports the same parry) computes
//! with. Both engines make their colliders here, so a shape collides alike in each.

use crate::mechanism::{Outline, Pose2, Shape};
use parry2d_f64::math::{Pose, Vector};
use parry2d_f64::shape::SharedShape;

/// A shape as parry's, with its pose in its link's (or body's) frame; `None` for an outline
/// parry cannot make (a polygon without area), which the URDF loader and the scenario's checks
/// refuse before any run.
pub(crate) fn parry_shape(shape: &Shape) -> Option<(SharedShape, Pose)> {
    let made = match &shape.outline {
        &Outline::Rectangle { width, height } => SharedShape::cuboid(width / 2.0, height / 2.0),
        &Outline::Circle { radius } => SharedShape::ball(radius),
        Outline::Polygon { points } => {
            SharedShape::convex_polyline(points.iter().map(|&[x, y]| Vector::new(x, y)).collect())?
        }
    };
    Some((made, to_parry(&shape.origin)))
}

/// A twin pose as parry's.
pub(crate) fn to_parry(pose: &Pose2) -> Pose {
    Pose::new(Vector::new(pose.x, pose.y), pose.angle)
}

/// A parry pose as the twin's (its angle in (−π, π]).
pub(crate) fn from_parry(pose: &Pose) -> Pose2 {
    Pose2::new(
        pose.translation.x,
        pose.translation.y,
        pose.rotation.angle(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(outline: Outline, origin: Pose2) -> Shape {
        Shape {
            origin,
            outline,
            color: None,
        }
    }

    #[test]
    fn outlines_become_parry_shapes_at_their_origin() {
        let origin = Pose2::new(0.1, -0.2, 0.3);
        let (rectangle, pose) = parry_shape(&shape(
            Outline::Rectangle {
                width: 0.4,
                height: 0.2,
            },
            origin,
        ))
        .unwrap();
        let cuboid = rectangle.as_cuboid().unwrap();
        assert_eq!([cuboid.half_extents.x, cuboid.half_extents.y], [0.2, 0.1]);
        let back = from_parry(&pose);
        assert!((back.x - 0.1).abs() < 1e-15 && (back.y + 0.2).abs() < 1e-15);
        assert!((back.angle - 0.3).abs() < 1e-15);
        let (disc, _) = parry_shape(&shape(Outline::Circle { radius: 0.05 }, origin)).unwrap();
        assert_eq!(disc.as_ball().unwrap().radius, 0.05);
        let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let (polygon, _) =
            parry_shape(&shape(Outline::Polygon { points: square }, origin)).unwrap();
        assert_eq!(polygon.as_convex_polygon().unwrap().points().len(), 4);
        let line = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        assert!(parry_shape(&shape(Outline::Polygon { points: line }, origin)).is_none());
    }

    #[test]
    fn poses_map_points_alike() {
        let twin = Pose2::new(0.4, 0.7, -2.5);
        let parry = to_parry(&twin);
        let [x, y] = twin.apply(0.3, -0.1);
        let p = parry * Vector::new(0.3, -0.1);
        assert!((p.x - x).abs() < 1e-15 && (p.y - y).abs() < 1e-15);
    }
}
