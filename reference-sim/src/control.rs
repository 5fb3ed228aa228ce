//! The ego's controllers: Stanley lateral path tracking and a PI speed controller.

use crate::path::{wrap_angle, Path};
use crate::vehicle::{VehicleState, MAX_STEER, WHEELBASE};

/// Stanley lateral controller (Hoffmann et al., 2007): steer = heading error +
/// atan(k · cross-track error / (softening + speed)), measured at the front axle.
///
/// At low control rates a steering angle held for a whole step can turn the car further than
/// the correction asked for (at 2 Hz and 15 m/s a step covers 2.7 wheelbases), which makes the
/// plain law oscillate and diverge. The angle is therefore capped so that one step turns the
/// heading by at most the requested correction; at 10 Hz and urban speeds the cap is inactive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stanley {
    /// Cross-track gain, 1/s.
    pub gain: f64,
    /// Softening speed, m/s (keeps the law finite at standstill).
    pub softening: f64,
    /// Path segment of the last projection (speeds up the next one).
    hint: Option<usize>,
}

impl Default for Stanley {
    fn default() -> Self {
        Stanley {
            gain: 2.5,
            softening: 1.0,
            hint: None,
        }
    }
}

impl Stanley {
    /// The steering angle that brings `state` onto `path`, to be held for `dt` seconds.
    pub fn steer(&mut self, state: &VehicleState, path: &Path, dt: f64) -> f64 {
        let p = path.project(state.front_axle(), self.hint);
        self.hint = Some(p.segment);
        let heading_error = wrap_angle(p.heading - state.heading);
        // `lateral` is positive when the axle is left of the path: steer right (negative).
        let cross = (-self.gain * p.lateral).atan2(self.softening + state.speed);
        let wanted = heading_error + cross;
        // Heading change over the step with angle δ: speed · dt · tan δ / wheelbase.
        let travel = state.speed * dt;
        let cap = if travel > 0.0 {
            (wanted.abs() * WHEELBASE / travel).atan()
        } else {
            f64::INFINITY
        };
        (wanted.signum() * wanted.abs().min(cap)).clamp(-MAX_STEER, MAX_STEER)
    }
}

/// PI speed controller with anti-windup: acceleration = kp · error + ki · ∫error, clamped to
/// comfortable limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedPi {
    /// Proportional gain, 1/s.
    pub kp: f64,
    /// Integral gain, 1/s².
    pub ki: f64,
    /// Largest acceleration, m/s².
    pub max_accel: f64,
    /// Largest deceleration (positive), m/s².
    pub max_decel: f64,
    integral: f64,
}

impl Default for SpeedPi {
    fn default() -> Self {
        SpeedPi {
            kp: 0.8,
            ki: 0.1,
            max_accel: 2.5,
            max_decel: 3.0,
            integral: 0.0,
        }
    }
}

impl SpeedPi {
    /// The acceleration that holds `target` speed, given the current `speed`, over a step `dt`.
    pub fn accel(&mut self, target: f64, speed: f64, dt: f64) -> f64 {
        let error = target - speed;
        let raw = self.kp * error + self.ki * (self.integral + error * dt);
        let a = raw.clamp(-self.max_decel, self.max_accel);
        // Integrate only while not saturated (anti-windup).
        if a == raw {
            self.integral += error * dt;
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point2;
    use std::f64::consts::FRAC_PI_2;

    /// Drives `path` at `speed` from a start 1 m off it; returns (largest cross-track error
    /// after `settle` metres, final speed error).
    fn track(path: &Path, speed: f64, rate: f64, settle: f64) -> (f64, f64) {
        let start = path.point_at(0.0) + nalgebra::Vector2::new(0.0, -1.0);
        let mut car = VehicleState::from_center(start, 0.0, speed * 0.5);
        let (mut stanley, mut pi) = (Stanley::default(), SpeedPi::default());
        let dt = 1.0 / rate;
        let mut worst: f64 = 0.0;
        while path.project(car.center(), None).s < path.length() - 5.0 {
            let steer = stanley.steer(&car, path, dt);
            let a = pi.accel(speed, car.speed, dt);
            car.step(steer, a, dt);
            let p = path.project(car.front_axle(), None);
            if p.s > settle {
                worst = worst.max(p.lateral.abs());
            }
        }
        (worst, (car.speed - speed).abs())
    }

    #[test]
    fn stanley_and_pi_track_a_straight_road() {
        let road = Path::start(Point2::new(0.0, 0.0), 0.0).line(300.0);
        for rate in [2.0, 4.0, 10.0] {
            let (lat, v) = track(&road, 15.0, rate, 60.0);
            assert!(lat < 0.1, "{rate} Hz: cross-track {lat:.3} m");
            assert!(v < 0.2, "{rate} Hz: speed error {v:.3} m/s");
        }
    }

    #[test]
    fn stanley_tracks_a_curve_within_half_a_metre() {
        // A quarter turn of radius 30 m (a ramp) and a left turn of radius 5.25 m (an
        // intersection), then straight.
        let ramp = Path::start(Point2::new(0.0, 0.0), 0.0)
            .line(40.0)
            .arc(30.0, FRAC_PI_2)
            .line(60.0);
        let (lat, _) = track(&ramp, 12.0, 10.0, 20.0);
        assert!(lat < 0.5, "ramp: cross-track {lat:.3} m");
        let (lat, _) = track(&ramp, 12.0, 2.0, 20.0);
        assert!(lat < 1.5, "ramp at 2 Hz: cross-track {lat:.3} m");
        let turn = Path::start(Point2::new(0.0, 0.0), 0.0)
            .line(30.0)
            .arc(5.25, FRAC_PI_2)
            .line(40.0);
        let (lat, _) = track(&turn, 6.0, 10.0, 20.0);
        assert!(lat < 0.5, "intersection turn: cross-track {lat:.3} m");
    }
}
