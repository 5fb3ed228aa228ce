//! The system under test, as in the paper: perception yields an obstacle position; the last two
//! positions give a first-order (constant-velocity) point-mass prediction of the closest
//! approach; the ego brakes while the predicted minimum distance is below one car length.

use crate::vehicle::{VehicleState, LENGTH};
use crate::world::World;
use nalgebra::{Point2, Point3, Vector2};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

/// What the ego knows about the world at one sensing instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensing<'a> {
    /// Simulation time, seconds.
    pub time: f64,
    /// The ego's true state (the localisation sensor is exact).
    pub ego: &'a VehicleState,
    /// The obstacle's true state (only an idealised perception may read it).
    pub obstacle: &'a VehicleState,
}

/// A perception stack: where is the obstacle, if it is seen at all.
pub trait Perception {
    /// The measured obstacle position (its centre), or None when it is not detected.
    fn perceive(&mut self, sensing: &Sensing) -> Option<Point2<f64>>;

    /// Work units spent so far (rays, pixels, …); 0 for an idealised perception.
    fn work(&self) -> u64 {
        0
    }
}

impl<P: Perception + ?Sized> Perception for &mut P {
    fn perceive(&mut self, sensing: &Sensing) -> Option<Point2<f64>> {
        (**self).perceive(sensing)
    }

    fn work(&self) -> u64 {
        (**self).work()
    }
}

/// Idealised perception: the true obstacle centre plus Gaussian noise, for obstacles inside a
/// forward camera's field of view and range and — when given the world — not hidden behind
/// static scenery (a building at a corner hides cross traffic until it is close).
#[derive(Debug, Clone)]
pub struct IdealPerception {
    noise: Option<Normal<f64>>,
    rng: Pcg64,
    world: Option<&'static World>,
    rays: u64,
    /// Half of the horizontal field of view, radians.
    pub half_fov: f64,
    /// Detection range, metres.
    pub range: f64,
}

impl IdealPerception {
    /// Perfect detections within ±50° and 120 m.
    pub fn new() -> Self {
        IdealPerception {
            noise: None,
            rng: Pcg64::seed_from_u64(0),
            world: None,
            rays: 0,
            half_fov: 50f64.to_radians(),
            range: 120.0,
        }
    }

    /// Hides obstacles that no line of sight reaches through `world`'s scenery.
    pub fn with_occlusion(mut self, world: &'static World) -> Self {
        self.world = Some(world);
        self
    }

    /// Adds zero-mean Gaussian position noise of `sd` metres per axis, drawn from a stream
    /// seeded with `seed` (runs stay deterministic).
    pub fn with_noise(mut self, sd: f64, seed: u64) -> Self {
        self.noise = Normal::new(0.0, sd).ok().filter(|_| sd > 0.0);
        self.rng = Pcg64::seed_from_u64(seed);
        self
    }
}

impl Default for IdealPerception {
    fn default() -> Self {
        Self::new()
    }
}

impl Perception for IdealPerception {
    fn work(&self) -> u64 {
        self.rays
    }

    fn perceive(&mut self, s: &Sensing) -> Option<Point2<f64>> {
        let eye = s.ego.center();
        let target = s.obstacle.center();
        let rel = target - eye;
        let bearing = crate::path::wrap_angle(rel.y.atan2(rel.x) - s.ego.heading);
        if rel.norm() > self.range || bearing.abs() > self.half_fov {
            return None;
        }
        if let Some(world) = self.world {
            // Visible when a line of sight reaches its centre or either end (camera 1.4 m up,
            // targets at mid-body height).
            let eye3 = Point3::new(eye.x as f32, eye.y as f32, 1.4);
            let dir = s.obstacle.direction() * (LENGTH / 2.0 - 0.2);
            let seen = [target, target + dir, target - dir].iter().any(|p| {
                self.rays += 1;
                world.line_of_sight(eye3, Point3::new(p.x as f32, p.y as f32, 0.75))
            });
            if !seen {
                return None;
            }
        }
        Some(match &self.noise {
            Some(n) => target + Vector2::new(n.sample(&mut self.rng), n.sample(&mut self.rng)),
            None => target,
        })
    }
}

/// The closest approach of two points moving at constant velocity within `horizon` seconds:
/// relative position `p`, relative velocity `w`. Returns the relative position then.
///
/// ```
/// use nalgebra::Vector2;
/// use savme_sim::sut::closest_approach;
/// // Head-on, 20 m apart, closing at 10 m/s with a 1 m lateral offset: 1 m after 2 s.
/// let d = closest_approach(Vector2::new(20.0, 1.0), Vector2::new(-10.0, 0.0), 5.0);
/// assert!((d - Vector2::new(0.0, 1.0)).norm() < 1e-12);
/// ```
pub fn closest_approach(p: Vector2<f64>, w: Vector2<f64>, horizon: f64) -> Vector2<f64> {
    let w2 = w.norm_squared();
    let t = if w2 > 0.0 {
        (-p.dot(&w) / w2).clamp(0.0, horizon)
    } else {
        0.0
    };
    p + w * t
}

/// The braking logic of the system under test.
///
/// The paper's rule: brake when the predicted minimum distance is below one car length. The
/// paper measures to the lidar centroid of the obstacle's visible surface; with object centres
/// the planner subtracts one body length (two half-lengths), so the buffer is one car length of
/// clearance between the bodies. Taken literally the rule also brakes for every car passing in
/// the adjacent or oncoming lane (3.5 m apart), so the predicted position must also lie in the
/// ego's corridor: less than `corridor` metres to the side of the ego's heading. Positions are
/// predicted every 0.1 s over the horizon with constant velocities.
#[derive(Debug, Clone, PartialEq)]
pub struct Planner {
    /// Prediction horizon, seconds.
    pub horizon: f64,
    /// Brake when the predicted clearance falls below this, metres.
    pub threshold: f64,
    /// Half-width of the ego's corridor, metres.
    pub corridor: f64,
    last: Option<(f64, Point2<f64>)>,
    prediction: Option<Prediction>,
}

/// The planner's last prediction: where, within its horizon, the obstacle comes closest to the
/// ego under constant velocities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// When (absolute simulation time), seconds.
    pub time: f64,
    /// The ego's predicted centre then.
    pub ego: Point2<f64>,
    /// The obstacle's predicted centre then.
    pub obstacle: Point2<f64>,
    /// Predicted clearance (centre distance − one body length), metres.
    pub clearance: f64,
}

impl Default for Planner {
    fn default() -> Self {
        Planner {
            horizon: 3.0,
            threshold: LENGTH,
            corridor: crate::vehicle::WIDTH + 0.5,
            last: None,
            prediction: None,
        }
    }
}

impl Planner {
    /// Takes a measurement (or a miss) at `time` and says whether to brake.
    pub fn decide(&mut self, time: f64, ego: &VehicleState, measured: Option<Point2<f64>>) -> bool {
        let Some(now) = measured else {
            self.last = None;
            self.prediction = None;
            return false;
        };
        let previous = self.last.replace((time, now));
        let Some((t0, before)) = previous else {
            // One measurement: no velocity yet; brake only if already too close.
            self.prediction = Some(self.closest(time, ego, now - ego.center(), Vector2::zeros()));
            return self.conflict(ego, now - ego.center(), Vector2::zeros());
        };
        let dt = time - t0;
        if dt <= 0.0 {
            return false;
        }
        let obstacle_velocity = (now - before) / dt;
        let p = now - ego.center();
        let w = obstacle_velocity - ego.velocity();
        self.prediction = Some(self.closest(time, ego, p, w));
        self.conflict(ego, p, w)
    }

    /// The last prediction (None without a detection).
    pub fn prediction(&self) -> Option<Prediction> {
        self.prediction
    }

    /// The closest approach within the horizon under constant velocities.
    fn closest(
        &self,
        time: f64,
        ego: &VehicleState,
        p: Vector2<f64>,
        w: Vector2<f64>,
    ) -> Prediction {
        let steps = (self.horizon / 0.1).round() as usize;
        let k = (0..=steps)
            .min_by(|&a, &b| {
                let d = |k: usize| (p + w * (k as f64 * 0.1)).norm();
                d(a).total_cmp(&d(b))
            })
            .unwrap_or(0);
        let t = k as f64 * 0.1;
        let ego_then = ego.center() + ego.velocity() * t;
        let rel = p + w * t;
        Prediction {
            time: time + t,
            ego: ego_then,
            obstacle: ego_then + rel,
            clearance: rel.norm() - LENGTH,
        }
    }

    /// Whether the obstacle, at relative position `p` moving at relative velocity `w`, comes
    /// within the threshold inside the ego's corridor during the horizon.
    fn conflict(&self, ego: &VehicleState, p: Vector2<f64>, w: Vector2<f64>) -> bool {
        let d = ego.direction();
        let steps = (self.horizon / 0.1).round() as usize;
        (0..=steps).any(|k| {
            let rel = p + w * (k as f64 * 0.1);
            let lateral = (d.x * rel.y - d.y * rel.x).abs();
            rel.norm() - LENGTH < self.threshold && lateral < self.corridor
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_prediction_is_the_closest_approach_within_the_horizon() {
        let ego = VehicleState::from_center(Point2::new(0.0, 0.0), 0.0, 10.0);
        let mut p = Planner::default();
        assert!(p.prediction().is_none());
        p.decide(0.0, &ego, Some(Point2::new(30.0, 0.0)));
        p.decide(0.1, &ego, Some(Point2::new(30.0, 0.0)));
        // A stopped car 30 m ahead of an ego at 10 m/s: closest at the horizon's end (3 s),
        // the ego then at 30 m, on top of it.
        let pr = p.prediction().unwrap();
        assert!((pr.time - 3.1).abs() < 1e-9, "{pr:?}");
        assert!((pr.ego.x - 30.0).abs() < 1e-9 && (pr.obstacle.x - 30.0).abs() < 1e-9);
        assert!((pr.clearance + LENGTH).abs() < 1e-9);
        p.decide(0.2, &ego, None);
        assert!(p.prediction().is_none(), "no detection, no prediction");
    }

    #[test]
    fn brakes_for_a_stopped_car_ahead_and_not_for_one_pulling_away() {
        let ego = VehicleState::from_center(Point2::new(0.0, 0.0), 0.0, 15.0);
        let mut p = Planner::default();
        assert!(!p.decide(0.0, &ego, Some(Point2::new(50.0, 0.0))));
        // Stopped 50 m ahead, ego at 15 m/s: contact predicted within 3 s.
        assert!(p.decide(0.1, &ego, Some(Point2::new(50.0, 0.0))));
        let mut far = Planner::default();
        far.decide(0.0, &ego, Some(Point2::new(60.0, 0.0)));
        assert!(
            !far.decide(0.1, &ego, Some(Point2::new(60.0, 0.0))),
            "55 m to go in 3 s: not yet"
        );
        let mut q = Planner::default();
        q.decide(0.0, &ego, Some(Point2::new(20.0, 0.0)));
        // Moving away at 20 m/s (faster than the ego).
        assert!(!q.decide(0.1, &ego, Some(Point2::new(22.0, 0.0))));
        // Lost track: no braking, and the next measurement starts afresh.
        assert!(!q.decide(0.2, &ego, None));
        // An oncoming car in the next lane (3.5 m to the left) passes: no braking.
        let mut r = Planner::default();
        r.decide(0.0, &ego, Some(Point2::new(40.0, 3.5)));
        assert!(!r.decide(0.1, &ego, Some(Point2::new(38.5, 3.5))));
        // The same car drifting into the ego's lane: brake.
        let mut s = Planner::default();
        s.decide(0.0, &ego, Some(Point2::new(40.0, 3.5)));
        assert!(s.decide(0.1, &ego, Some(Point2::new(38.5, 3.3))));
        assert_eq!(
            closest_approach(Vector2::new(5.0, 0.0), Vector2::zeros(), 3.0).x,
            5.0
        );
    }

    #[test]
    fn perception_sees_only_ahead_within_range() {
        let ego = VehicleState::from_center(Point2::new(0.0, 0.0), 0.0, 10.0);
        let mut cam = IdealPerception::new();
        let at = |x: f64, y: f64| VehicleState::from_center(Point2::new(x, y), 0.0, 0.0);
        let see = |cam: &mut IdealPerception, o: &VehicleState| {
            cam.perceive(&Sensing {
                time: 0.0,
                ego: &ego,
                obstacle: o,
            })
        };
        assert_eq!(see(&mut cam, &at(30.0, 3.5)), Some(Point2::new(30.0, 3.5)));
        assert_eq!(see(&mut cam, &at(-10.0, 0.0)), None, "behind");
        assert_eq!(
            see(&mut cam, &at(1.0, 3.5)),
            None,
            "beside, outside the field of view"
        );
        assert_eq!(see(&mut cam, &at(200.0, 0.0)), None, "out of range");
        let mut noisy = IdealPerception::new().with_noise(0.5, 9);
        let m = see(&mut noisy, &at(30.0, 0.0)).unwrap();
        assert!(m != Point2::new(30.0, 0.0) && (m - Point2::new(30.0, 0.0)).norm() < 3.0);
        let mut again = IdealPerception::new().with_noise(0.5, 9);
        assert_eq!(
            see(&mut again, &at(30.0, 0.0)),
            Some(m),
            "seeded noise is repeatable"
        );
    }
}
