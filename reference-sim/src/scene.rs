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
