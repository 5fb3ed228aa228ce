//! Sedan-sized vehicles: a kinematic bicycle model and the oriented box used for collisions.

use nalgebra::{Isometry3, Point2, Translation3, UnitQuaternion, Vector2, Vector3};
use parry3d::shape::Cuboid;

/// Body length of every vehicle (a mid-size sedan), metres. Also the braking threshold of the
/// system under test ("one car length").
pub const LENGTH: f64 = 4.8;
/// Body width, metres.
pub const WIDTH: f64 = 1.9;
/// Body height, metres.
pub const HEIGHT: f64 = 1.5;
/// Distance between the axles, metres.
pub const WHEELBASE: f64 = 2.8;
/// Distance from the rear axle to the body centre, metres.
pub const REAR_TO_CENTER: f64 = WHEELBASE / 2.0;
/// Steering limit, radians.
pub const MAX_STEER: f64 = 0.6;

/// The planar state of a vehicle: rear-axle position, heading, speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleState {
    /// Rear-axle position, metres.
    pub position: Point2<f64>,
    /// Heading, radians counter-clockwise from +x.
    pub heading: f64,
    /// Speed, m/s (never negative: vehicles do not reverse).
    pub speed: f64,
}

impl VehicleState {
    /// Unit vector along the heading.
    pub fn direction(&self) -> Vector2<f64> {
        Vector2::new(self.heading.cos(), self.heading.sin())
    }

    /// Centre of the body.
    pub fn center(&self) -> Point2<f64> {
        self.position + self.direction() * REAR_TO_CENTER
    }

    /// Front-axle position (the point a Stanley controller steers).
    pub fn front_axle(&self) -> Point2<f64> {
        self.position + self.direction() * WHEELBASE
    }

    /// Velocity vector.
    pub fn velocity(&self) -> Vector2<f64> {
        self.direction() * self.speed
    }

    /// A state whose body centre is at `center` with the given heading and speed.
    pub fn from_center(center: Point2<f64>, heading: f64, speed: f64) -> Self {
        let dir = Vector2::new(heading.cos(), heading.sin());
        VehicleState {
            position: center - dir * REAR_TO_CENTER,
            heading,
            speed,
        }
    }

    /// Advances the kinematic bicycle model by `dt` with steering angle `steer` (clamped to
    /// ±[`MAX_STEER`]) and longitudinal acceleration `accel`. Exact for constant inputs over the
    /// step: the vehicle moves along a circular arc, and stops rather than reverses.
    pub fn step(&mut self, steer: f64, accel: f64, dt: f64) {
        let steer = steer.clamp(-MAX_STEER, MAX_STEER);
        // Time until the vehicle stops, if it is braking.
        let moving = if accel < 0.0 {
            (self.speed / -accel).min(dt)
        } else {
            dt
        };
        let distance = self.speed * moving + 0.5 * accel * moving * moving;
        let curvature = steer.tan() / WHEELBASE;
        let turn = distance * curvature;
        if turn.abs() < 1e-9 {
            self.position += self.direction() * distance;
        } else {
            let r = 1.0 / curvature;
            let h0 = self.heading;
            self.position +=
                Vector2::new((h0 + turn).sin() - h0.sin(), h0.cos() - (h0 + turn).cos()) * r;
            self.heading = crate::path::wrap_angle(h0 + turn);
        }
        self.speed = (self.speed + accel * moving).max(0.0);
    }

    /// The body as an oriented box pose for parry3d (centre at half height).
    pub fn pose(&self) -> Isometry3<f32> {
        let c = self.center();
        Isometry3::from_parts(
            Translation3::new(c.x as f32, c.y as f32, (HEIGHT / 2.0) as f32),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.heading as f32),
        )
    }
}

/// The body shape (half-extents).
pub fn body() -> Cuboid {
    Cuboid::new(Vector3::new(
        (LENGTH / 2.0) as f32,
        (WIDTH / 2.0) as f32,
        (HEIGHT / 2.0) as f32,
    ))
}

/// True when two vehicle bodies overlap (a collision).
pub fn collide(a: &VehicleState, b: &VehicleState) -> bool {
    let shape = body();
    parry3d::query::intersection_test(&a.pose(), &shape, &b.pose(), &shape).unwrap_or(false)
}

/// Distance between two vehicle bodies (0 when they overlap).
pub fn distance(a: &VehicleState, b: &VehicleState) -> f64 {
    let shape = body();
    f64::from(parry3d::query::distance(&a.pose(), &shape, &b.pose(), &shape).unwrap_or(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn straight_and_circular_motion_are_exact() {
        let mut v = VehicleState::from_center(Point2::new(0.0, 0.0), 0.0, 10.0);
        v.step(0.0, 0.0, 0.5);
        assert!((v.center() - Point2::new(5.0, 0.0)).norm() < 1e-12);
        // Constant steering: a circle of radius L / tan(δ); a quarter circle returns the heading
        // to +90° and the rear axle to (r, r) from where it started.
        let steer: f64 = 0.3;
        let r = WHEELBASE / steer.tan();
        let mut c = VehicleState {
            position: Point2::origin(),
            heading: 0.0,
            speed: 5.0,
        };
        let t_quarter = r * FRAC_PI_2 / 5.0;
        for _ in 0..100 {
            c.step(steer, 0.0, t_quarter / 100.0);
        }
        assert!((c.heading - FRAC_PI_2).abs() < 1e-9);
        assert!((c.position - Point2::new(r, r)).norm() < 1e-9);
    }

    #[test]
    fn braking_stops_without_reversing() {
        let mut v = VehicleState::from_center(Point2::origin(), 0.0, 10.0);
        v.step(0.0, -8.0, 5.0);
        assert_eq!(v.speed, 0.0);
        // Stopping distance v² / 2a = 6.25 m.
        assert!((v.center().x - 6.25).abs() < 1e-12);
    }

    #[test]
    fn box_overlaps_agree_with_hand_computed_cases() {
        let at = |x: f64, y: f64, h: f64| VehicleState::from_center(Point2::new(x, y), h, 0.0);
        let a = at(0.0, 0.0, 0.0);
        // Nose to tail along x: touching at a centre distance of one length.
        assert!(collide(&a, &at(4.7, 0.0, 0.0)));
        assert!(!collide(&a, &at(4.9, 0.0, 0.0)));
        assert!((distance(&a, &at(5.8, 0.0, 0.0)) - 1.0).abs() < 1e-5);
        // Side by side: one width apart.
        assert!(collide(&a, &at(0.0, 1.8, 0.0)));
        assert!(!collide(&a, &at(0.0, 2.0, 0.0)));
        // Crossing at 90°: B's half-width (0.95) + A's half-length (2.4) = 3.35 along x.
        assert!(collide(&a, &at(3.3, 0.0, FRAC_PI_2)));
        assert!(!collide(&a, &at(3.4, 0.0, FRAC_PI_2)));
        // Rotated 45°: B centred at (4.0, 2.5) holds A's corner (2.4, 0.95) — in B's frame the
        // corner sits at (−2.23, 0.04), inside B's half-extents (2.4, 0.95).
        assert!(collide(&a, &at(4.0, 2.5, FRAC_PI_2 / 2.0)));
        // Moved to (4.0, 3.5): the corner is at (−2.93, −0.67) in B's frame, beyond B's rear
        // face, which is the nearest feature: distance (1.6 + 2.55)/√2 − 2.4.
        let b = at(4.0, 3.5, FRAC_PI_2 / 2.0);
        assert!(!collide(&a, &b));
        let d = distance(&a, &b);
        assert!(
            (d - ((1.6f64 + 2.55) / 2f64.sqrt() - 2.4)).abs() < 1e-4,
            "{d}"
        );
    }
}
