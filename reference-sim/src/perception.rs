//! Camera + lidar perception, as in the paper: detect the vehicle in the camera image, keep the
//! lidar points that project into its box, and take their intensity-weighted centroid as the
//! obstacle position.
//!
//! The paper's detector is YOLOv5s, whose weights cannot be fetched here; this one is classical:
//! colour segmentation tuned to the intruder's paint, 4-connected components, a size filter, the
//! largest component's box. Lidar points are projected with the lens model the perception is
//! calibrated for — with the lens model disabled in the camera, boxes and points disagree off
//! the image centre.

use crate::camera::{self, CameraPose, Image, HEIGHT, WIDTH};
use crate::lidar::{self, LidarPoint};
use crate::scene::Scene;
use crate::settings::Settings;
use crate::sut::{Perception, Sensing};
use crate::world::World;
use nalgebra::{Point2, Point3, Vector2};
use rand::SeedableRng;
use rand_pcg::Pcg64;

/// A detection box in pixels: `[u0, v0, u1, v1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundingBox {
    /// Left column.
    pub u0: usize,
    /// Top row.
    pub v0: usize,
    /// One past the right column.
    pub u1: usize,
    /// One past the bottom row.
    pub v1: usize,
    /// Pixels in the component.
    pub pixels: usize,
}

/// Smallest component the detector accepts, pixels.
pub const MIN_PIXELS: usize = 4;
/// The surface centroid is moved this far along the line of sight to estimate the centre.
pub const CENTRE_OFFSET: f64 = 1.5;

/// Pixels that look like the intruder's paint.
pub fn paint_mask(img: &Image) -> Vec<bool> {
    img.pixels
        .iter()
        .map(|&[r, g, b]| r > 0.08 && r > 1.6 * g && g > 1.8 * b)
        .collect()
}

/// The largest 4-connected component of `mask` with at least [`MIN_PIXELS`] pixels.
pub fn detect(mask: &[bool]) -> Option<BoundingBox> {
    let mut seen = vec![false; mask.len()];
    let mut best: Option<BoundingBox> = None;
    let mut stack = Vec::new();
    for start in 0..mask.len() {
        if !mask[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut bb = BoundingBox {
            u0: WIDTH,
            v0: HEIGHT,
            u1: 0,
            v1: 0,
            pixels: 0,
        };
        while let Some(i) = stack.pop() {
            let (u, v) = (i % WIDTH, i / WIDTH);
            bb.u0 = bb.u0.min(u);
            bb.v0 = bb.v0.min(v);
            bb.u1 = bb.u1.max(u + 1);
            bb.v1 = bb.v1.max(v + 1);
            bb.pixels += 1;
            let mut push = |j: usize| {
                if mask[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if u > 0 {
                push(i - 1);
            }
            if u + 1 < WIDTH {
                push(i + 1);
            }
            if v > 0 {
                push(i - WIDTH);
            }
            if v + 1 < HEIGHT {
                push(i + WIDTH);
            }
        }
        if bb.pixels >= MIN_PIXELS && best.is_none_or(|b| bb.pixels > b.pixels) {
            best = Some(bb);
        }
    }
    best
}

/// Depth of the cluster kept behind the nearest point in a box, metres.
pub const CLUSTER_DEPTH: f32 = 3.0;

/// Intensity-weighted centroid (x, y) of the lidar points that project into `bb`: non-ground
/// points, within [`CLUSTER_DEPTH`] of the nearest one (what lies behind the object in the same
/// box — buildings, light through its windows, multi-path ghosts — is not the object).
pub fn fuse(points: &[LidarPoint], pose: &CameraPose, bb: &BoundingBox) -> Option<Point2<f64>> {
    let inside: Vec<(&LidarPoint, f32)> = points
        .iter()
        .filter(|p| p.position.z >= 0.15)
        .filter_map(|p| {
            let c = pose.to_camera(p.position);
            let (u, v) = camera::project_lens(c)?;
            let hit = u >= bb.u0 as f32 - 0.5
                && u < bb.u1 as f32 + 0.5
                && v >= bb.v0 as f32 - 0.5
                && v < bb.v1 as f32 + 0.5;
            hit.then_some((p, c.norm()))
        })
        .collect();
    let nearest = inside.iter().map(|(_, d)| *d).fold(f32::INFINITY, f32::min);
    let (mut sx, mut sy, mut w) = (0.0f64, 0.0f64, 0.0f64);
    for (p, d) in inside {
        if d <= nearest + CLUSTER_DEPTH {
            let i = f64::from(p.intensity);
            sx += i * f64::from(p.position.x);
            sy += i * f64::from(p.position.y);
            w += i;
        }
    }
    (w > 0.0).then(|| Point2::new(sx / w, sy / w))
}

/// Everything the sensors produced at one step (kept only when recording).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFrame {
    /// Simulation time, s.
    pub time: f64,
    /// The camera image.
    pub image: Image,
    /// The lidar points.
    pub cloud: Vec<LidarPoint>,
    /// The detection, if any.
    pub detection: Option<BoundingBox>,
    /// The obstacle position reported to the planner.
    pub measured: Option<Point2<f64>>,
}

/// Camera + lidar perception with the 16 fidelity settings.
#[derive(Debug, Clone)]
pub struct SensorPerception {
    world: &'static World,
    settings: Settings,
    rng: Pcg64,
    work: u64,
    camera: camera::Camera,
    image: camera::Image,
    /// Frames kept when recording (see [`SensorPerception::recording`]).
    pub frames: Option<Vec<SensorFrame>>,
}

impl SensorPerception {
    /// Perception in `world` with `settings`; sensor noise seeded with `seed`.
    pub fn new(world: &'static World, settings: Settings, seed: u64) -> Self {
        SensorPerception {
            world,
            settings,
            rng: Pcg64::seed_from_u64(seed),
            work: 0,
            camera: camera::Camera::default(),
            image: camera::Image::default(),
            frames: None,
        }
    }

    /// Keeps every step's image, cloud and detection in [`SensorPerception::frames`].
    pub fn recording(mut self) -> Self {
        self.frames = Some(Vec::new());
        self
    }
}

impl Perception for SensorPerception {
    fn perceive(&mut self, s: &Sensing) -> Option<Point2<f64>> {
        let vehicles = [*s.obstacle];
        let scene = Scene {
            world: self.world,
            vehicles: &vehicles,
        };
        let forward = s.ego.direction();
        let at = |ahead: f64, z: f32| {
            let c = s.ego.center() + forward * ahead;
            Point3::new(c.x as f32, c.y as f32, z)
        };
        let pose = CameraPose {
            eye: at(1.2, 1.3),
            heading: s.ego.heading as f32,
        };
        let camera_work = self.camera.render_into(
            &scene,
            &pose,
            &self.settings,
            &mut self.rng,
            &mut self.image,
        );
        let sweep = lidar::scan(
            &scene,
            at(0.5, 1.9),
            s.ego.heading as f32,
            &self.settings,
            &mut self.rng,
        );
        let mask = paint_mask(&self.image);
        let detection = detect(&mask);
        let measured = detection
            .and_then(|bb| fuse(&sweep.points, &pose, &bb))
            .map(|c| {
                // The centroid lies on the visible surface; estimate the centre behind it.
                let eye = Point2::new(f64::from(pose.eye.x), f64::from(pose.eye.y));
                let ray: Vector2<f64> = c - eye;
                c + ray.normalize() * CENTRE_OFFSET
            });
        self.work += camera_work
            + sweep.rays * lidar::RAY_WORK
            + sweep.draws
            + (WIDTH * HEIGHT) as u64
            + sweep.points.len() as u64;
        if let Some(frames) = self.frames.as_mut() {
            frames.push(SensorFrame {
                time: s.time,
                image: self.image.clone(),
                cloud: sweep.points,
                detection,
                measured,
            });
        }
        measured
    }

    fn work(&self) -> u64 {
        self.work
    }
}
