//! Road layouts and static scenery (buildings, parked cars, poles, trees) in a parry3d bounding
//! volume hierarchy, so that sensors cast rays against them.
//!
//! Coordinates: x east, y north, z up, metres. Traffic drives on the right; lanes are 3.5 m wide.

use crate::path::Path;
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use parry3d::bounding_volume::Aabb;
use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::{Cuboid, Shape};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// Lane width, metres.
pub const LANE: f64 = 3.5;

/// The road layouts of the paper's pre-crash scenario figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layout {
    /// A four-way intersection, one lane each way, centred at the origin.
    Intersection,
    /// A straight two-lane one-way road heading east (dashed separation), lanes at y = −1.75
    /// (right) and y = +1.75 (left).
    OneWay,
    /// A straight two-lane two-way road (double yellow): eastbound at y = −1.75, westbound at
    /// y = +1.75.
    TwoWay,
    /// A two-way road with a parking lot on its south side (spots perpendicular to the road).
    ParkingLot,
    /// A two-lane one-way road heading east with an on-ramp curving in from the south-west and
    /// merging into the right lane between x = −20 and x = 20.
    OnRamp,
}

/// What a scenery object is (sensors render them differently).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ObjectKind {
    /// A building: a large box with windows.
    Building,
    /// A parked car.
    ParkedCar,
    /// A street-light or sign pole.
    Pole,
    /// A tree (trunk and crown as one square prism).
    Tree,
}

/// The shape of a scenery object. Every object is a box (poles and trees are square prisms:
/// boxes are what both sensors handle exactly and fastest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectShape {
    /// A box with these half-extents.
    Box(Vector3<f32>),
}

/// One static object.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    /// Its kind.
    pub kind: ObjectKind,
    /// Its shape.
    pub shape: ObjectShape,
    /// Its pose (centre of the shape).
    pub pose: Isometry3<f32>,
}

impl SceneObject {
    fn aabb(&self) -> Aabb {
        match self.shape {
            ObjectShape::Box(h) => Cuboid::new(h).compute_aabb(&self.pose),
        }
    }

    fn cast_normal(&self, ray: &Ray, max: f32) -> Option<parry3d::query::RayIntersection> {
        match self.shape {
            ObjectShape::Box(h) => {
                Cuboid::new(h).cast_ray_and_get_normal(&self.pose, ray, max, true)
            }
        }
    }

    fn cast(&self, ray: &Ray, max: f32) -> Option<f32> {
        match self.shape {
            ObjectShape::Box(h) => Cuboid::new(h).cast_ray(&self.pose, ray, max, true),
        }
    }
}

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub distance: f32,
    /// The scenery object hit, or None for the ground.
    pub object: Option<usize>,
}

/// A ray hit with its surface normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Distance along the (unit) ray direction.
    pub distance: f32,
    /// Outward unit normal at the hit.
    pub normal: Vector3<f32>,
    /// The scenery object hit, or None for the ground.
    pub object: Option<usize>,
}

/// A road layout with its lane paths and static scenery.
#[derive(Debug, Clone)]
pub struct World {
    layout: Layout,
    objects: Vec<SceneObject>,
    bvh: Bvh,
}

fn place(kind: ObjectKind, shape: ObjectShape, x: f64, y: f64, z: f64, yaw: f64) -> SceneObject {
    SceneObject {
        kind,
        shape,
        pose: Isometry3::from_parts(
            Translation3::new(x as f32, y as f32, z as f32),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw as f32),
        ),
    }
}

fn building(x: f64, y: f64, w: f64, d: f64, h: f64) -> SceneObject {
    let half = Vector3::new((w / 2.0) as f32, (d / 2.0) as f32, (h / 2.0) as f32);
    place(
        ObjectKind::Building,
        ObjectShape::Box(half),
        x,
        y,
        h / 2.0,
        0.0,
    )
}

fn pole(x: f64, y: f64) -> SceneObject {
    place(
        ObjectKind::Pole,
        ObjectShape::Box(Vector3::new(0.11, 0.11, 4.0)),
        x,
        y,
        4.0,
        0.0,
    )
}

fn tree(x: f64, y: f64) -> SceneObject {
    place(
        ObjectKind::Tree,
        ObjectShape::Box(Vector3::new(0.8, 0.8, 3.0)),
        x,
        y,
        3.0,
        0.0,
    )
}

fn parked_car(x: f64, y: f64, yaw: f64) -> SceneObject {
    let half = Vector3::new(2.4, 0.95, 0.75);
    place(
        ObjectKind::ParkedCar,
        ObjectShape::Box(half),
        x,
        y,
        0.75,
        yaw,
    )
}

/// Scenery along a straight east–west road from x0 to x1 whose edges are at y = ±edge:
/// poles and trees on the verges, buildings set back behind them.
fn street(objects: &mut Vec<SceneObject>, x0: f64, x1: f64, edge: f64, north: bool, south: bool) {
    let mut x = x0;
    let mut k = 0;
    while x < x1 {
        for (side, on) in [(1.0, north), (-1.0, south)] {
            if !on {
                continue;
            }
            if k % 2 == 0 {
                objects.push(pole(x, side * (edge + 1.0)));
            } else {
                objects.push(tree(x, side * (edge + 3.0)));
            }
            // Buildings 12–22 m deep, 10–18 m tall, set back 8 m from the road edge.
            let depth = 12.0 + 10.0 * ((k * 7 + 3) % 5) as f64 / 4.0;
            let height = 10.0 + 8.0 * ((k * 3 + 1) % 4) as f64 / 3.0;
            objects.push(building(
                x + 7.5,
                side * (edge + 8.0 + depth / 2.0),
                13.0,
                depth,
                height,
            ));
        }
        x += 15.0;
        k += 1;
    }
}

/// Rotates an object's pose by `angle` about the z axis through the origin.
fn rotated(mut o: SceneObject, angle: f64) -> SceneObject {
    let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle as f32);
    o.pose = Isometry3::from_parts(Translation3::identity(), r) * o.pose;
    o
}

impl World {
    /// Builds a layout with its scenery.
    pub fn new(layout: Layout) -> World {
        let mut objects = Vec::new();
        let edge = LANE; // two lanes: edges at ±3.5 m
        match layout {
            Layout::Intersection => {
                // Four arms, 200 m each, leaving the corner areas to buildings.
                for arm in 0..4 {
                    let mut one = Vec::new();
                    street(&mut one, edge + 6.0, 200.0, edge, true, true);
                    objects.extend(one.into_iter().map(|o| rotated(o, arm as f64 * FRAC_PI_2)));
                }
            }
            Layout::OneWay | Layout::TwoWay => {
                street(&mut objects, -250.0, 250.0, edge, true, true)
            }
            Layout::ParkingLot => {
                street(&mut objects, -250.0, 250.0, edge, true, false);
                street(&mut objects, -250.0, -40.0, edge, false, true);
                street(&mut objects, 60.0, 250.0, edge, false, true);
                // Perpendicular spots south of the road, 2.6 m wide, noses towards the road.
                for i in 0..36 {
                    let x = -38.0 + 2.6 * i as f64;
                    if i % 5 != 2 {
                        objects.push(parked_car(x, -(edge + 1.5 + 2.4), FRAC_PI_2));
                    }
                    if i % 4 != 1 {
                        objects.push(parked_car(x, -(edge + 1.5 + 6.0 + 2.4 + 2.4), FRAC_PI_2));
                    }
                }
            }
            Layout::OnRamp => {
                street(&mut objects, -250.0, 250.0, edge, true, false);
                street(&mut objects, 20.0, 250.0, edge, false, true);
                for i in 0..8 {
                    objects.push(tree(-120.0 + 12.0 * i as f64, -60.0));
                }
            }
        }
        let leaves: Vec<Aabb> = objects.iter().map(SceneObject::aabb).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::default(), &leaves);
        World {
            layout,
            objects,
            bvh,
        }
    }

    /// The world of a layout, built once per process and shared.
    pub fn shared(layout: Layout) -> &'static World {
        static WORLDS: [OnceLock<World>; 5] = [const { OnceLock::new() }; 5];
        let i = match layout {
            Layout::Intersection => 0,
            Layout::OneWay => 1,
            Layout::TwoWay => 2,
            Layout::ParkingLot => 3,
            Layout::OnRamp => 4,
        };
        WORLDS[i].get_or_init(|| World::new(layout))
    }

    /// Like [`World::cast_ray`], with the surface normal, ignoring the object `skip`.
    pub fn cast_ray_normal(
        &self,
        origin: Point3<f32>,
        dir: Vector3<f32>,
        max: f32,
        skip: Option<usize>,
    ) -> Option<SurfaceHit> {
        let ray = Ray::new(origin, dir);
        let ground = (dir.z < -1e-6)
            .then(|| -origin.z / dir.z)
            .filter(|&t| t >= 0.0 && t < max);
        let limit = ground.unwrap_or(max);
        let best = std::cell::Cell::new(None);
        let scenery = self.bvh.cast_ray(&ray, limit, |i, so_far| {
            if Some(i as usize) == skip {
                return None;
            }
            let hit = self.objects[i as usize].cast_normal(&ray, so_far)?;
            if hit.time_of_impact < so_far {
                best.set(Some((i as usize, hit.normal)));
            }
            Some(hit.time_of_impact)
        });
        match (scenery, best.get(), ground) {
            (Some((i, t)), Some((j, n)), _) if t < limit && i as usize == j => Some(SurfaceHit {
                distance: t,
                normal: n,
                object: Some(j),
            }),
            (_, _, Some(t)) => Some(SurfaceHit {
                distance: t,
                normal: Vector3::z(),
                object: None,
            }),
            _ => None,
        }
    }

    /// True when nothing static blocks the straight line from `from` to `to`.
    pub fn line_of_sight(&self, from: Point3<f32>, to: Point3<f32>) -> bool {
        let d = to - from;
        let len = d.norm();
        if len <= 0.0 {
            return true;
        }
        let ray = Ray::new(from, d / len);
        self.bvh
            .cast_ray(&ray, len, |i, best| {
                self.objects[i as usize].cast(&ray, best)
            })
            .is_none_or(|(_, t)| t >= len)
    }

    /// The layout.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The static objects.
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// The nearest hit of a ray (unit direction) against the scenery and the ground (z = 0)
    /// within `max` metres.
    pub fn cast_ray(&self, origin: Point3<f32>, dir: Vector3<f32>, max: f32) -> Option<Hit> {
        self.cast_ray_normal(origin, dir, max, None).map(|h| Hit {
            distance: h.distance,
            object: h.object,
        })
    }
}

/// Lane paths of the layouts, each long enough for the scenarios.
pub mod lanes {
    use super::*;

    /// Northbound lane through the intersection, from y = `from`.
    pub fn northbound(from: f64) -> Path {
        Path::start(Point2::new(LANE / 2.0, from), FRAC_PI_2).line(200.0 - from)
    }

    /// Southbound lane through the intersection, from y = `from` (positive).
    pub fn southbound(from: f64) -> Path {
        Path::start(Point2::new(-LANE / 2.0, from), -FRAC_PI_2).line(200.0 + from)
    }

    /// Westbound lane, from x = `from` (positive).
    pub fn westbound(from: f64) -> Path {
        Path::start(Point2::new(from, LANE / 2.0), PI).line(200.0 + from)
    }

    /// Eastbound lane (y = −1.75) from x = `from`.
    pub fn eastbound(from: f64) -> Path {
        Path::start(Point2::new(from, -LANE / 2.0), 0.0).line(250.0 - from)
    }

    /// Left lane of a one-way road heading east (y = +1.75), from x = `from`.
    pub fn eastbound_left(from: f64) -> Path {
        Path::start(Point2::new(from, LANE / 2.0), 0.0).line(250.0 - from)
    }

    /// Radius of a left turn in the intersection (from the centre of one lane to the centre of
    /// the crossing lane, starting at the intersection edge).
    pub const LEFT_TURN_RADIUS: f64 = 1.5 * LANE;

    /// From the northbound lane, a left turn into the westbound lane.
    pub fn north_then_west(from: f64) -> Path {
        Path::start(Point2::new(LANE / 2.0, from), FRAC_PI_2)
            .line(-LANE - from)
            .arc(LEFT_TURN_RADIUS, FRAC_PI_2)
            .line(150.0)
    }

    /// From the eastbound lane (coming from the west), a left turn into the northbound lane.
    pub fn east_then_north(from: f64) -> Path {
        Path::start(Point2::new(from, -LANE / 2.0), 0.0)
            .line(-LANE - from)
            .arc(LEFT_TURN_RADIUS, FRAC_PI_2)
            .line(150.0)
    }

    /// From the southbound lane (coming from the north), a left turn into the eastbound lane.
    pub fn south_then_east(from: f64) -> Path {
        Path::start(Point2::new(-LANE / 2.0, from), -FRAC_PI_2)
            .line(from - LANE)
            .arc(LEFT_TURN_RADIUS, FRAC_PI_2)
            .line(150.0)
    }

    /// A lane change to the left (one lane, +3.5 m in y) on a road heading east: straight
    /// until x = `at`, an S-curve of the given length, then straight.
    pub fn lane_change(from: f64, y: f64, at: f64, length: f64, left: bool) -> Path {
        // Two opposite arcs of equal radius shift the path by one lane over `length`.
        let sign = if left { 1.0 } else { -1.0 };
        let half = length / 2.0;
        let shift = LANE / 2.0;
        // Arc with chord geometry: radius r and angle a with r(1 − cos a) = shift and
        // r sin a = half.
        let a = 2.0 * (shift / half).atan();
        let r = half / a.sin();
        Path::start(Point2::new(from, y), 0.0)
            .line((at - from).max(0.1))
            .arc(r, sign * a)
            .arc(r, -sign * a)
            .line(250.0)
    }

    /// The on-ramp: from the south-west, a right-hand curve (radius 120 m) that ends parallel
    /// to the road one lane south of the right lane, a parallel stretch, then a merge into the
    /// right lane (y = −1.75) between x = −20 and x = 20.
    pub fn on_ramp() -> Path {
        // Start heading 25° north of east and curve right to heading east.
        let angle = 25f64.to_radians();
        let r = 120.0;
        let end_curve = Point2::new(-60.0, -LANE / 2.0 - LANE);
        let start = Point2::new(
            end_curve.x - r * angle.sin(),
            end_curve.y - r * (1.0 - angle.cos()),
        );
        let approach = 60.0;
        let origin = start - nalgebra::Vector2::new(angle.cos(), angle.sin()) * approach;
        Path::start(origin, angle)
            .line(approach)
            .arc(r, -angle)
            .line(40.0)
            .arc(lc_radius(40.0), lc_angle(40.0))
            .arc(lc_radius(40.0), -lc_angle(40.0))
            .line(250.0)
    }

    fn lc_angle(length: f64) -> f64 {
        2.0 * ((LANE / 2.0) / (length / 2.0)).atan()
    }

    fn lc_radius(length: f64) -> f64 {
        (length / 2.0) / lc_angle(length).sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_layout_has_scenery_off_the_road() {
        for layout in [
            Layout::Intersection,
            Layout::OneWay,
            Layout::TwoWay,
            Layout::ParkingLot,
            Layout::OnRamp,
        ] {
            let w = World::new(layout);
            assert!(w.objects().len() > 50, "{layout:?}: {}", w.objects().len());
            for o in w.objects() {
                let p = o.pose.translation;
                let (x, y) = (f64::from(p.x).abs(), f64::from(p.y).abs());
                let on_road = match layout {
                    Layout::Intersection => x < LANE || y < LANE,
                    _ => y < LANE,
                };
                assert!(
                    !on_road,
                    "{layout:?}: {:?} at ({}, {}) is on the road",
                    o.kind, p.x, p.y
                );
            }
        }
    }

    #[test]
    fn rays_hit_the_ground_and_the_nearest_object() {
        let w = World::new(Layout::OneWay);
        // Straight down from 2 m: the ground at 2 m.
        let down = w
            .cast_ray(Point3::new(0.0, 0.0, 2.0), -Vector3::z(), 100.0)
            .unwrap();
        assert!((down.distance - 2.0).abs() < 1e-5 && down.object.is_none());
        // Sideways (north) at 1.5 m height from the road: the first pole/tree/building.
        let side = w
            .cast_ray(Point3::new(0.3, 0.0, 1.5), Vector3::y(), 200.0)
            .unwrap();
        assert!(side.object.is_some());
        let brute = w
            .objects()
            .iter()
            .filter_map(|o| o.cast(&Ray::new(Point3::new(0.3, 0.0, 1.5), Vector3::y()), 200.0))
            .fold(f32::INFINITY, f32::min);
        assert!(
            (side.distance - brute).abs() < 1e-4,
            "{} vs {brute}",
            side.distance
        );
        // Up into the sky: nothing.
        assert!(w
            .cast_ray(Point3::new(0.0, 0.0, 1.0), Vector3::z(), 100.0)
            .is_none());
    }

    #[test]
    fn turn_paths_join_the_crossing_lanes() {
        let p = lanes::north_then_west(-60.0);
        let q = p.project(Point2::new(-30.0, LANE / 2.0), None);
        assert!(q.lateral.abs() < 0.01, "{}", q.lateral);
        let e = lanes::east_then_north(-60.0);
        assert!(e.project(Point2::new(LANE / 2.0, 40.0), None).lateral.abs() < 0.01);
        let s = lanes::south_then_east(60.0);
        assert!(
            s.project(Point2::new(40.0, -LANE / 2.0), None)
                .lateral
                .abs()
                < 0.01
        );
        let lc = lanes::lane_change(-50.0, -LANE / 2.0, 0.0, 40.0, true);
        assert!(
            lc.project(Point2::new(80.0, LANE / 2.0), None)
                .lateral
                .abs()
                < 0.01
        );
        let ramp = lanes::on_ramp();
        assert!(
            ramp.project(Point2::new(100.0, -LANE / 2.0), None)
                .lateral
                .abs()
                < 0.01
        );
    }
}
