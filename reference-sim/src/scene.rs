//! What the sensors see: the static world plus the moving vehicles, with surface materials.

use crate::vehicle::{self, VehicleState};
use crate::world::{ObjectKind, World};
use nalgebra::{Isometry3, Point3, Vector3};
use parry3d::query::{Ray, RayCast};

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// The ground: road or verge.
    Ground,
    /// A static object of the world (its index).
    Object(usize),
    /// A vehicle of the scene (its index in [`Scene::vehicles`]).
    Vehicle(usize),
}

/// A hit with its surface, normal and material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHit {
    /// Distance along the unit ray.
    pub distance: f32,
    /// Outward unit normal.
    pub normal: Vector3<f32>,
    /// What was hit.
    pub surface: Surface,
    /// The hit point is glass (a car window or a building window).
    pub glass: bool,
}

/// The world and the vehicles in it at one instant.
#[derive(Debug, Clone, Copy)]
pub struct Scene<'a> {
    /// Static world.
    pub world: &'a World,
    /// Moving vehicles (the intruder; the ego is not seen by its own sensors).
    pub vehicles: &'a [VehicleState],
}

impl Scene<'_> {
    /// The nearest hit within `max`, ignoring `skip`.
    pub fn cast(
        &self,
        origin: Point3<f32>,
        dir: Vector3<f32>,
        max: f32,
        skip: Option<Surface>,
    ) -> Option<SceneHit> {
        self.caster().cast(origin, dir, max, skip)
    }

    /// A [`Caster`] for many rays through this scene.
    pub fn caster(&self) -> Caster<'_> {
        Caster {
            scene: self,
            poses: self.vehicles.iter().map(VehicleState::pose).collect(),
        }
    }
    /// Windows: the upper part of a car body; a grid of windows on building facades.
    fn is_glass(&self, surface: Surface, p: Point3<f32>) -> bool {
        match surface {
            Surface::Vehicle(_) => p.z > 0.95,
            Surface::Object(i) => {
                self.world.objects()[i].kind == ObjectKind::Building
                    && (p.z % 3.5) > 1.0
                    && (p.z % 3.5) < 2.6
                    && ((p.x + p.y).rem_euclid(3.0)) < 1.8
            }
            Surface::Ground => false,
        }
    }

    /// Lidar reflectivity of a surface (0–1).
    pub fn reflectivity(&self, hit: &SceneHit) -> f32 {
        if hit.glass {
            return 0.1;
        }
        match hit.surface {
            Surface::Ground => 0.15,
            Surface::Vehicle(_) => 0.8,
            Surface::Object(i) => match self.world.objects()[i].kind {
                ObjectKind::Building => 0.4,
                ObjectKind::ParkedCar => 0.7,
                ObjectKind::Pole => 0.5,
                ObjectKind::Tree => 0.3,
            },
        }
    }
}

/// A sphere around a vehicle body: its half-diagonal (2.69 m) plus a margin (0.5 m) far above
/// the rounding of a ray cast in `f32` over hundreds of metres.
const BODY_REACH: f32 = 3.2;

/// True when the ray from `origin` along the unit `dir` provably misses, within `limit`, the body
/// at `pose`: it passes outside the sphere of radius [`BODY_REACH`] around the body's centre, or
/// the sphere lies behind the origin or beyond `limit`. Then parry's cast finds no hit either,
/// and need not run (most of a sweep's rays pass far from the intruder). Anything not finite,
/// or a direction not of unit length, is not provably a miss.
#[inline]
fn misses_body(pose: &Isometry3<f32>, origin: Point3<f32>, dir: Vector3<f32>, limit: f32) -> bool {
    const {
        let (l, w, h) = (
            vehicle::LENGTH / 2.0,
            vehicle::WIDTH / 2.0,
            vehicle::HEIGHT / 2.0,
        );
        let sphere = BODY_REACH as f64 - 0.5;
        assert!(sphere * sphere >= l * l + w * w + h * h);
    };
    if (dir.norm_squared() - 1.0).abs() > 1e-3 {
        return false;
    }
    let to_centre = pose.translation.vector - origin.coords;
    let along = to_centre.dot(&dir);
    let off_axis = to_centre.cross(&dir).norm_squared();
    along < -BODY_REACH || along - BODY_REACH > limit || off_axis > BODY_REACH * BODY_REACH
}

/// Casts rays through a [`Scene`] with the vehicles' poses computed once (a lidar sweep casts
/// over a thousand rays through the same scene).
#[derive(Debug, Clone)]
pub struct Caster<'a> {
    scene: &'a Scene<'a>,
    poses: Vec<Isometry3<f32>>,
}

impl Caster<'_> {
    /// The nearest hit within `max`, ignoring `skip` (as [`Scene::cast`]).
    pub fn cast(
        &self,
        origin: Point3<f32>,
        dir: Vector3<f32>,
        max: f32,
        skip: Option<Surface>,
    ) -> Option<SceneHit> {
        let scene = self.scene;
        let skip_object = match skip {
            Some(Surface::Object(i)) => Some(i),
            _ => None,
        };
        let mut best = scene
            .world
            .cast_ray_normal(origin, dir, max, skip_object)
            .map(|h| SceneHit {
                distance: h.distance,
                normal: h.normal,
                surface: h.object.map_or(Surface::Ground, Surface::Object),
                glass: false,
            });
        let body = vehicle::body();
        let ray = Ray::new(origin, dir);
        for (k, pose) in self.poses.iter().enumerate() {
            if skip == Some(Surface::Vehicle(k)) {
                continue;
            }
            let limit = best.map_or(max, |b| b.distance);
            if misses_body(pose, origin, dir, limit) {
                continue;
            }
            if let Some(h) = body.cast_ray_and_get_normal(pose, &ray, limit, true) {
                best = Some(SceneHit {
                    distance: h.time_of_impact,
                    normal: h.normal,
                    surface: Surface::Vehicle(k),
                    glass: false,
                });
            }
        }
        best.map(|mut h| {
            let p = origin + dir * h.distance;
            h.glass = scene.is_glass(h.surface, p);
            h
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Wherever [`misses_body`] skips parry's cast, parry finds no hit: rays from around the
    /// body (near, far, inside it, grazing it), in every direction, with short and long limits.
    #[test]
    fn a_ray_said_to_miss_the_body_misses_it() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(39);
        let body = vehicle::body();
        let (mut skipped, mut hits) = (0, 0);
        for _ in 0..200_000 {
            let state = VehicleState {
                position: nalgebra::Point2::new(
                    rng.random_range(-50.0..50.0),
                    rng.random_range(-50.0..50.0),
                ),
                heading: rng.random_range(-4.0..4.0),
                speed: 0.0,
            };
            let pose = state.pose();
            let centre = pose.translation.vector;
            let reach: f32 = [1.0, 3.0, 6.0, 120.0][rng.random_range(0..4usize)];
            let origin = Point3::new(
                centre.x + rng.random_range(-reach..reach),
                centre.y + rng.random_range(-reach..reach),
                rng.random_range(0.0..3.0),
            );
            // Aimed near the body (grazing its sphere) or anywhere.
            let target = centre
                + Vector3::new(
                    rng.random_range(-4.0..4.0),
                    rng.random_range(-4.0..4.0),
                    rng.random_range(-2.0..2.0),
                );
            let dir = if rng.random::<bool>() {
                (Point3::from(target) - origin).normalize()
            } else {
                Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize()
            };
            let limit: f32 = rng.random_range(0.1..150.0);
            let hit = body.cast_ray_and_get_normal(&pose, &Ray::new(origin, dir), limit, true);
            hits += usize::from(hit.is_some());
            if misses_body(&pose, origin, dir, limit) {
                skipped += 1;
                assert!(
                    hit.is_none(),
                    "{origin:?} {dir:?} {limit} {state:?}: {hit:?}"
                );
            }
        }
        // Both kinds of ray were drawn often.
        assert!(
            skipped > 50_000 && hits > 20_000,
            "{skipped} skipped, {hits} hits"
        );
    }

    #[test]
    fn a_direction_not_of_unit_length_or_not_finite_is_never_skipped() {
        let pose = VehicleState {
            position: nalgebra::Point2::new(0.0, 0.0),
            heading: 0.3,
            speed: 0.0,
        }
        .pose();
        let origin = Point3::new(0.0, 40.0, 1.0);
        for dir in [
            Vector3::new(0.0, 2.0, 0.0),
            Vector3::new(f32::NAN, 1.0, 0.0),
            Vector3::zeros(),
        ] {
            assert!(!misses_body(&pose, origin, dir, 100.0));
        }
        // Towards the body with a limit that is not a number: not skipped.
        assert!(!misses_body(&pose, origin, -Vector3::y(), f32::NAN));
        // A unit direction away from the body is skipped, as is one towards it that stops short.
        assert!(misses_body(&pose, origin, Vector3::y(), 100.0));
        assert!(misses_body(&pose, origin, -Vector3::y(), 30.0));
        assert!(!misses_body(&pose, origin, -Vector3::y(), 40.0));
    }
}
