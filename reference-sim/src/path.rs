//! Lane centre-lines: chains of straight lines and circular arcs, sampled into a dense
//! polyline with arc length, with the queries a path-following controller needs.

use nalgebra::{Point2, Vector2};

/// Spacing of the samples a path is turned into, in metres.
const STEP: f64 = 0.25;

/// A planar path: a polyline sampled every 0.25 m along straight lines and arcs.
///
/// ```
/// use savme_sim::path::Path;
/// use nalgebra::Point2;
/// // 10 m east, then a quarter turn left of radius 5 m.
/// let p = Path::start(Point2::new(0.0, 0.0), 0.0).line(10.0).arc(5.0, std::f64::consts::FRAC_PI_2);
/// assert!((p.length() - (10.0 + 5.0 * std::f64::consts::FRAC_PI_2)).abs() < 1e-9);
/// let end = p.point_at(p.length());
/// assert!((end - Point2::new(15.0, 5.0)).norm() < 1e-6);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    points: Vec<Point2<f64>>,
    /// Arc length at each point.
    s: Vec<f64>,
    /// Heading of the path at each point (radians, counter-clockwise from +x).
    heading: Vec<f64>,
}

/// Where a point lies relative to a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Arc length of the closest point.
    pub s: f64,
    /// Signed lateral offset: positive to the left of the path.
    pub lateral: f64,
    /// Heading of the path there.
    pub heading: f64,
    /// Index of the polyline segment (a hint for the next query).
    pub segment: usize,
}

impl Path {
    /// A path starting at `origin` with heading `heading` (radians) and no length yet.
    pub fn start(origin: Point2<f64>, heading: f64) -> Self {
        Path {
            points: vec![origin],
            s: vec![0.0],
            heading: vec![heading],
        }
    }

    fn end(&self) -> (Point2<f64>, f64, f64) {
        let i = self.points.len() - 1;
        (self.points[i], self.heading[i], self.s[i])
    }

    /// Extends the path straight ahead by `length` metres.
    pub fn line(mut self, length: f64) -> Self {
        let (p0, h, s0) = self.end();
        let dir = Vector2::new(h.cos(), h.sin());
        let n = (length / STEP).ceil().max(1.0) as usize;
        for k in 1..=n {
            let d = length * k as f64 / n as f64;
            self.points.push(p0 + dir * d);
            self.s.push(s0 + d);
            self.heading.push(h);
        }
        self
    }

    /// Extends the path along a circular arc of `radius` turning by `angle` radians
    /// (positive = left / counter-clockwise).
    pub fn arc(mut self, radius: f64, angle: f64) -> Self {
        let (p0, h0, s0) = self.end();
        let sign = angle.signum();
        // Centre of the turn: to the left for a left turn, to the right otherwise.
        let left = Vector2::new(-h0.sin(), h0.cos());
        let center = p0 + left * (radius * sign);
        let length = radius * angle.abs();
        let n = (length / STEP).ceil().max(1.0) as usize;
        for k in 1..=n {
            let t = k as f64 / n as f64;
            let h = h0 + angle * t;
            let radial = Vector2::new(h.sin(), -h.cos()) * (radius * sign);
            self.points.push(center + radial);
            self.s.push(s0 + length * t);
            self.heading.push(h);
        }
        self
    }

    /// Total length.
    pub fn length(&self) -> f64 {
        self.s[self.s.len() - 1]
    }

    fn locate(&self, s: f64) -> (usize, f64) {
        let s = s.clamp(0.0, self.length());
        let i = self
            .s
            .partition_point(|&x| x <= s)
            .clamp(1, self.s.len() - 1)
            - 1;
        let span = self.s[i + 1] - self.s[i];
        let t = if span > 0.0 {
            (s - self.s[i]) / span
        } else {
            0.0
        };
        (i, t)
    }

    /// The point at arc length `s` (clamped to the path; beyond the end it extends straight).
    pub fn point_at(&self, s: f64) -> Point2<f64> {
        if s > self.length() {
            let (p, h, len) = self.end();
            return p + Vector2::new(h.cos(), h.sin()) * (s - len);
        }
        let (i, t) = self.locate(s);
        self.points[i] + (self.points[i + 1] - self.points[i]) * t
    }

    /// The heading at arc length `s`.
    pub fn heading_at(&self, s: f64) -> f64 {
        if s >= self.length() {
            return self.end().1;
        }
        let (i, t) = self.locate(s);
        let (a, b) = (self.heading[i], self.heading[i + 1]);
        a + wrap_angle(b - a) * t
    }

    /// Projects `p` onto the path. `hint` (a segment index from an earlier projection) makes
    /// the search local; without one the whole path is searched. Beyond the end the path
    /// continues straight.
    pub fn project(&self, p: Point2<f64>, hint: Option<usize>) -> Projection {
        let last = self.points.len() - 2;
        let (lo, hi) = match hint {
            Some(h) => (h.saturating_sub(40), (h + 40).min(last)),
            None => (0, last),
        };
        let mut best = (f64::INFINITY, lo, 0.0);
        for i in lo..=hi {
            let a = self.points[i];
            let ab = self.points[i + 1] - a;
            let len2 = ab.norm_squared();
            let mut t = if len2 > 0.0 {
                (p - a).dot(&ab) / len2
            } else {
                0.0
            };
            // The first and last segments extend without bound (the path goes on straight).
            if i > 0 {
                t = t.max(0.0);
            }
            if i < last {
                t = t.min(1.0);
            }
            let d2 = (p - (a + ab * t)).norm_squared();
            if d2 < best.0 {
                best = (d2, i, t);
            }
        }
        let (_, i, t) = best;
        let a = self.points[i];
        let ab = self.points[i + 1] - a;
        let heading = ab.y.atan2(ab.x);
        let dir = Vector2::new(heading.cos(), heading.sin());
        let rel = p - a;
        Projection {
            s: self.s[i] + t * (self.s[i + 1] - self.s[i]),
            lateral: dir.x * rel.y - dir.y * rel.x,
            heading,
            segment: i,
        }
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut x = (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI;
    if x <= -std::f64::consts::PI {
        x += two_pi;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn projection_gives_arc_length_and_signed_offset() {
        let p = Path::start(Point2::new(0.0, 0.0), 0.0)
            .line(10.0)
            .arc(5.0, FRAC_PI_2);
        let q = p.project(Point2::new(4.0, 1.5), None);
        assert!((q.s - 4.0).abs() < 1e-9 && (q.lateral - 1.5).abs() < 1e-9);
        let r = p.project(Point2::new(4.0, -2.0), Some(q.segment));
        assert!(
            (r.lateral + 2.0).abs() < 1e-9,
            "right of the path is negative"
        );
        // On the arc: a point 1 m outside the circle (to the right of a left turn).
        let on = p.point_at(10.0 + 5.0 * FRAC_PI_2 / 2.0);
        let center = Point2::new(10.0, 5.0);
        let outside = center + (on - center) * (6.0 / 5.0);
        let a = p.project(outside, None);
        assert!((a.lateral + 1.0).abs() < 0.01, "{}", a.lateral);
        assert!((a.heading - FRAC_PI_2 / 2.0).abs() < 0.03);
        // Past the end the path continues straight (heading north; the last chord is 0.025 rad
        // off north, hence the tolerance).
        let past = p.project(Point2::new(15.0, 12.0), None);
        assert!((past.s - (p.length() + 7.0)).abs() < 0.01, "{}", past.s);
    }

    #[test]
    fn right_turns_and_angles_wrap() {
        let p = Path::start(Point2::new(0.0, 0.0), FRAC_PI_2).arc(3.0, -FRAC_PI_2);
        let end = p.point_at(p.length());
        assert!((end - Point2::new(3.0, 3.0)).norm() < 1e-9);
        assert!(p.heading_at(p.length()).abs() < 1e-12);
        assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap_angle(-FRAC_PI_2 * 5.0) + FRAC_PI_2).abs() < 1e-12);
    }
}
