//! A forward camera, rasterised: the scenery and vehicles as flat-shaded polygons over an
//! analytic ground (road, markings, verge) and sky, with the paper's eight camera fidelity
//! settings: lighting, shadows (a shadow map), bloom and its level, lens distortion, depth of
//! field (aperture samples), shot noise, view distance (far plane) and near clipping.
//!
//! One file of ~700 lines (the post-processing is in `camera/post.rs`): the rasteriser, the
//! shadow map and the frame assembly share the camera's constants and reusable buffers, and
//! each stage is short; splitting them further would export those internals.

mod post;

use crate::scene::Scene;
use crate::settings::Settings;
use crate::world::{Layout, ObjectKind, ObjectShape, LANE};
use nalgebra::{Isometry3, Point3, Vector3};
use post::{bloom, depth_of_field, distort, shot_noise};
use rand::Rng;

/// Image width, pixels.
pub const WIDTH: usize = 128;
/// Image height, pixels.
pub const HEIGHT: usize = 96;
/// Focal length, pixels (90° horizontal field of view).
pub const FOCAL: f32 = 64.0;
/// Radial distortion coefficient of the lens (barrel).
pub const K1: f32 = -0.12;
/// Aperture samples with depth of field.
pub const DOF_SAMPLES: usize = 3;
/// Lens aperture radius, metres (large, so the effect shows at this resolution).
pub const APERTURE: f32 = 0.04;
/// Focus distance, metres.
pub const FOCUS: f32 = 20.0;
/// The acceptable circle of confusion, pixels: surfaces whose aperture parallax stays below it
/// are in focus (the photographic definition of the depth of field) and are sampled once.
pub const ACCEPTABLE_COC: f32 = 0.25;
/// Per-channel noise with shot noise, standard deviation.
pub const NOISE: f32 = 0.03;
/// Direction towards the sun (unit length).
pub fn sun() -> Vector3<f32> {
    // (-0.45, 0.35, 0.82) normalised.
    Vector3::new(-0.460_566, 0.358_218, 0.839_253)
}

/// Paint of the intruder (the detector is tuned to it).
pub const INTRUDER_PAINT: [f32; 3] = [0.9, 0.42, 0.08];

/// An RGB image, row-major, values in [0, 1] (bloom may exceed 1 before clamping).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Image {
    /// Pixels, `WIDTH * HEIGHT`, row-major from the top left.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    fn new(fill: [f32; 3]) -> Self {
        Image {
            pixels: vec![fill; WIDTH * HEIGHT],
        }
    }

    /// 8-bit RGB bytes (for PNG files).
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| p.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
            .collect()
    }
}

/// One frame and the work it took.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The image.
    pub image: Image,
    /// Pixel operations: fragments rasterised, pixels shaded, shadow-map texels, post-process
    /// taps, noise draws.
    pub work: u64,
}

/// Where the camera is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Optical centre.
    pub eye: Point3<f32>,
    /// Heading (yaw), radians.
    pub heading: f32,
}

impl CameraPose {
    /// World point → camera frame (x forward, y left, z up).
    pub fn to_camera(self, p: Point3<f32>) -> Vector3<f32> {
        self.rotation().to_camera(p - self.eye)
    }

    fn rotation(self) -> Yaw {
        let (s, c) = self.heading.sin_cos();
        Yaw { s, c }
    }
}

/// A rotation about z by the camera heading, with its sine and cosine computed once.
#[derive(Debug, Clone, Copy)]
struct Yaw {
    s: f32,
    c: f32,
}

impl Yaw {
    fn to_camera(self, d: Vector3<f32>) -> Vector3<f32> {
        Vector3::new(
            self.c * d.x + self.s * d.y,
            -self.s * d.x + self.c * d.y,
            d.z,
        )
    }

    fn to_world(self, v: Vector3<f32>) -> Vector3<f32> {
        Vector3::new(
            self.c * v.x - self.s * v.y,
            self.s * v.x + self.c * v.y,
            v.z,
        )
    }
}

/// The reference shot of `docs/camera_*.png`, the camera tests and the sensor benchmarks: the
/// ego 18 m before the intersection looking north, the oncoming intruder turning left in front.
/// Returns the world, the intruder and the camera pose.
pub fn reference_shot() -> (
    &'static crate::world::World,
    [crate::vehicle::VehicleState; 1],
    CameraPose,
) {
    let world = crate::world::World::shared(Layout::Intersection);
    let intruder = [crate::vehicle::VehicleState::from_center(
        nalgebra::Point2::new(-1.0, 6.0),
        -1.2,
        6.0,
    )];
    let pose = CameraPose {
        eye: Point3::new(1.75, -18.0, 1.3),
        heading: std::f32::consts::FRAC_PI_2,
    };
    (world, intruder, pose)
}

/// Pinhole projection of a camera-frame point to pixel coordinates (None behind the camera).
pub fn project_pinhole(p: Vector3<f32>) -> Option<(f32, f32)> {
    (p.x > 1e-3).then(|| {
        (
            WIDTH as f32 / 2.0 - FOCAL * p.y / p.x,
            HEIGHT as f32 / 2.0 - FOCAL * p.z / p.x,
        )
    })
}

/// Projection through the lens model (radially distorted), as the perception is calibrated.
pub fn project_lens(p: Vector3<f32>) -> Option<(f32, f32)> {
    let (u, v) = project_pinhole(p)?;
    let (x, y) = (
        (u - WIDTH as f32 / 2.0) / FOCAL,
        (v - HEIGHT as f32 / 2.0) / FOCAL,
    );
    let s = 1.0 + K1 * (x * x + y * y);
    Some((
        WIDTH as f32 / 2.0 + FOCAL * x * s,
        HEIGHT as f32 / 2.0 + FOCAL * y * s,
    ))
}

/// What covers a pixel: the index of a face, or one of these two markers.
type Cover = u32;
/// Nothing: the sky.
const SKY: Cover = u32::MAX;
/// The ground plane.
const GROUND: Cover = u32::MAX - 1;

#[derive(Debug, Default, Clone)]
struct Buffers {
    depth: Vec<f32>,
    cover: Vec<Cover>,
    /// The light of each face of the frame.
    lights: Vec<f32>,
    /// The shadow map's depths (kept between frames, as the other buffers).
    shadow_depth: Vec<f32>,
}

/// A polygon of an object with its albedo.
struct Face {
    corners: [Point3<f32>; 4],
    normal: Vector3<f32>,
    albedo: [f32; 3],
    /// Its object may be in the field of view (otherwise it only casts shadows).
    in_view: bool,
}

fn parked_paint(i: usize) -> [f32; 3] {
    const P: [[f32; 3]; 5] = [
        [0.15, 0.2, 0.55],
        [0.85, 0.85, 0.85],
        [0.08, 0.08, 0.1],
        [0.45, 0.05, 0.08],
        [0.35, 0.4, 0.42],
    ];
    P[i % P.len()]
}

fn kind_albedo(kind: ObjectKind, i: usize) -> [f32; 3] {
    match kind {
        ObjectKind::Building => {
            let t = (i % 4) as f32 * 0.04;
            [0.72 - t, 0.66 - t, 0.56 - t]
        }
        ObjectKind::ParkedCar => parked_paint(i),
        ObjectKind::Pole => [0.45, 0.45, 0.47],
        ObjectKind::Tree => [0.2, 0.42, 0.16],
    }
}

/// The faces of a box (its four sides and its top; the bottom is never seen).
fn faces(shape: ObjectShape, pose: &Isometry3<f32>, albedo: [f32; 3], out: &mut Vec<Face>) {
    let ObjectShape::Box(h) = shape;
    let ring = [(h.x, h.y), (-h.x, h.y), (-h.x, -h.y), (h.x, -h.y)];
    let hh = h.z;
    let at = |x: f32, y: f32, z: f32| pose * Point3::new(x, y, z);
    let n = ring.len();
    for k in 0..n {
        let (a, b) = (ring[k], ring[(k + 1) % n]);
        let corners = [
            at(a.0, a.1, -hh),
            at(b.0, b.1, -hh),
            at(b.0, b.1, hh),
            at(a.0, a.1, hh),
        ];
        let mid = Vector3::new((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0, 0.0);
        let normal = pose.rotation * mid.normalize();
        out.push(Face {
            corners,
            normal,
            albedo,
            in_view: true,
        });
    }
    let top = ring.map(|(x, y)| at(x, y, hh));
    out.push(Face {
        corners: top,
        normal: pose.rotation * Vector3::z(),
        albedo,
        in_view: true,
    });
}

/// Road surface colour at a ground point.
fn ground_colour(layout: Layout, x: f32, y: f32) -> [f32; 3] {
    const ASPHALT: [f32; 3] = [0.28, 0.28, 0.3];
    const VERGE: [f32; 3] = [0.32, 0.45, 0.22];
    const WHITE: [f32; 3] = [0.9, 0.9, 0.88];
    const YELLOW: [f32; 3] = [0.9, 0.75, 0.15];
    let lane = LANE as f32;
    let dashed = |s: f32| s.rem_euclid(9.0) < 3.0;
    let (ax, ay) = (x.abs(), y.abs());
    match layout {
        Layout::Intersection => {
            let on_ns = ax < lane;
            let on_ew = ay < lane;
            if !(on_ns || on_ew) {
                return VERGE;
            }
            let in_box = on_ns && on_ew;
            if !in_box && ((on_ns && ax < 0.1 && dashed(y)) || (on_ew && ay < 0.1 && dashed(x))) {
                return YELLOW;
            }
            ASPHALT
        }
        _ => {
            let ramp = layout == Layout::OnRamp && (-lane * 2.0..-lane).contains(&y) && x < 20.0;
            if ay >= lane && !ramp {
                return VERGE;
            }
            if (ay - (lane - 0.15)).abs() < 0.1 && !ramp {
                return WHITE;
            }
            match layout {
                Layout::OneWay | Layout::OnRamp if ay < 0.08 && dashed(x) => WHITE,
                Layout::TwoWay | Layout::ParkingLot if (ay - 0.12).abs() < 0.06 => YELLOW,
                _ => ASPHALT,
            }
        }
    }
}

fn pixel_dir(u: f32, v: f32) -> Vector3<f32> {
    Vector3::new(
        1.0,
        (WIDTH as f32 / 2.0 - u) / FOCAL,
        (HEIGHT as f32 / 2.0 - v) / FOCAL,
    )
}

/// Rasterises the scene from `pose` into the depth and cover buffers `b`.
fn rasterise(
    b: &mut Buffers,
    faces: &[Face],
    pose: &CameraPose,
    near: f32,
    far: f32,
    work: &mut u64,
) {
    b.depth.clear();
    b.depth.resize(WIDTH * HEIGHT, f32::INFINITY);
    b.cover.clear();
    b.cover.resize(WIDTH * HEIGHT, SKY);
    // The ground plane: a pixel row below the horizon sees the ground at one forward depth.
    let eye_h = pose.eye.z;
    for v in 0..HEIGHT {
        let dz = pixel_dir(0.5, v as f32 + 0.5).z;
        if dz < -1e-4 {
            let t = eye_h / -dz; // along x (forward) units
            if t >= near && t <= far {
                let row = v * WIDTH..(v + 1) * WIDTH;
                b.depth[row.clone()].fill(t);
                b.cover[row].fill(GROUND);
            }
        }
    }
    *work += (WIDTH * HEIGHT) as u64;
    let yaw = pose.rotation();
    for (index, f) in faces.iter().enumerate() {
        if !f.in_view {
            continue;
        }
        // Back-face culling.
        let n_cam = yaw.to_camera(f.normal);
        let cam = f.corners.map(|p| yaw.to_camera(p - pose.eye));
        if n_cam.dot(&-cam[0]) <= 0.0 {
            continue;
        }
        if cam.iter().all(|c| c.x < near) || cam.iter().all(|c| c.x > far) {
            continue;
        }
        // Clip the polygon against the near plane (a quad gains at most one corner).
        let mut poly = [Vector3::zeros(); 5];
        let mut len = 0;
        for k in 0..cam.len() {
            let (a, c) = (cam[k], cam[(k + 1) % cam.len()]);
            if a.x >= near {
                poly[len] = a;
                len += 1;
            }
            if (a.x >= near) != (c.x >= near) {
                let t = (near - a.x) / (c.x - a.x);
                poly[len] = a + (c - a) * t;
                len += 1;
            }
        }
        if len < 3 {
            continue;
        }
        let proj = poly.map(|p| {
            let x = p.x;
            (
                WIDTH as f32 / 2.0 - FOCAL * p.y / x,
                HEIGHT as f32 / 2.0 - FOCAL * p.z / x,
                1.0 / x,
            )
        });
        let proj = &proj[..len];
        for k in 1..proj.len() - 1 {
            tri(b, proj[0], proj[k], proj[k + 1], far, index as Cover, work);
        }
    }
}

fn tri(
    b: &mut Buffers,
    p0: (f32, f32, f32),
    p1: (f32, f32, f32),
    p2: (f32, f32, f32),
    far: f32,
    cover: Cover,
    work: &mut u64,
) {
    let area = (p1.0 - p0.0) * (p2.1 - p0.1) - (p2.0 - p0.0) * (p1.1 - p0.1);
    if area.abs() < 1e-6 {
        return;
    }
    let min_u = p0.0.min(p1.0).min(p2.0).floor().max(0.0) as usize;
    let max_u = (p0.0.max(p1.0).max(p2.0).ceil() as isize).clamp(0, WIDTH as isize) as usize;
    let min_v = p0.1.min(p1.1).min(p2.1).floor().max(0.0) as usize;
    let max_v = (p0.1.max(p1.1).max(p2.1).ceil() as isize).clamp(0, HEIGHT as isize) as usize;
    if min_u >= max_u || min_v >= max_v {
        return;
    }
    let inv = 1.0 / area;
    // Barycentric weights are affine in (x, y): w = a·x + b·y + c; step them along a row.
    let edge = |p: (f32, f32, f32), q: (f32, f32, f32)| {
        (
            (p.1 - q.1) * inv,
            (q.0 - p.0) * inv,
            (p.0 * q.1 - q.0 * p.1) * inv,
        )
    };
    let (a0, b0, c0) = edge(p1, p2);
    let (a1, b1, c1) = edge(p2, p0);
    let (a2, b2, c2) = (-(a0 + a1), -(b0 + b1), 1.0 - c0 - c1);
    for v in min_v..max_v {
        let y = v as f32 + 0.5;
        // The span of this row where all three weights can be non-negative (each weight is
        // affine in x), widened by a pixel against rounding; the exact test below decides.
        let (mut lo, mut hi) = (min_u as f32 + 0.5, max_u as f32 - 0.5);
        for (a, k) in [(a0, b0 * y + c0), (a1, b1 * y + c1), (a2, b2 * y + c2)] {
            if a > 1e-12 {
                lo = lo.max(-k / a);
            } else if a < -1e-12 {
                hi = hi.min(-k / a);
            } else if k < -1e-6 {
                hi = lo - 1.0;
            }
        }
        if hi < lo {
            continue;
        }
        let start = ((lo - 1.5).floor().max(min_u as f32) as usize).max(min_u);
        let end = ((hi + 1.5).ceil().max(0.0) as usize).min(max_u);
        let row = v * WIDTH;
        let (depths, covers) = (
            &mut b.depth[row..row + WIDTH],
            &mut b.cover[row..row + WIDTH],
        );
        let fragment = |u: usize| {
            let x = u as f32 + 0.5;
            let w0 = a0 * x + b0 * y + c0;
            let w1 = a1 * x + b1 * y + c1;
            let w2 = 1.0 - w0 - w1;
            let inside = w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0;
            (inside, 1.0 / (w0 * p0.2 + w1 * p1.2 + w2 * p2.2))
        };
        // LANES pixels at a time without branches (the depth computed for every lane, kept
        // where the pixel is covered and nearer), which the compiler vectorises; the rest of
        // the span one by one.
        const LANES: usize = 4;
        let lanes_end = start + (end - start) / LANES * LANES;
        for u in (start..lanes_end).step_by(LANES) {
            let f: [(bool, f32); LANES] = std::array::from_fn(|k| fragment(u + k));
            let (d, c) = (&mut depths[u..u + LANES], &mut covers[u..u + LANES]);
            for k in 0..LANES {
                let (inside, depth) = f[k];
                *work += u64::from(inside);
                let nearer = inside && depth < d[k] && depth <= far;
                d[k] = if nearer { depth } else { d[k] };
                c[k] = if nearer { cover } else { c[k] };
            }
        }
        for u in lanes_end..end {
            let (inside, depth) = fragment(u);
            if inside {
                *work += 1;
                if depth < depths[u] && depth <= far {
                    depths[u] = depth;
                    covers[u] = cover;
                }
            }
        }
    }
}

/// A shadow map: depth along the sun direction over a square around the camera.
struct ShadowMap {
    size: usize,
    half: f32,
    centre: Point3<f32>,
    u: Vector3<f32>,
    v: Vector3<f32>,
    /// Texels per metre.
    scale: f32,
    depth: Vec<f32>,
}

impl ShadowMap {
    const SIZE: usize = 128;

    /// Builds the map from the faces of each object (one footprint per object: the rectangle,
    /// in sun-aligned coordinates, around all its corners, at its highest point towards the sun).
    /// `depth` is a buffer to reuse (a previous map's).
    fn build(
        objects: &[std::ops::Range<usize>],
        faces: &[Face],
        centre: Point3<f32>,
        mut depth: Vec<f32>,
        work: &mut u64,
    ) -> Self {
        let s = sun();
        let u = s.cross(&Vector3::z()).normalize();
        let v = s.cross(&u).normalize();
        let size = Self::SIZE;
        let half = 50.0;
        depth.clear();
        depth.resize(size * size, f32::NEG_INFINITY);
        let scale = size as f32 / (2.0 * half);
        for range in objects {
            // Height along the sun of every corner; rasterise the object's footprint.
            let (mut lo_u, mut hi_u) = (f32::MAX, f32::MIN);
            let (mut lo_v, mut hi_v) = (f32::MAX, f32::MIN);
            let mut h = f32::MIN;
            for &p in faces[range.clone()].iter().flat_map(|f| f.corners.iter()) {
                let d = p - centre;
                let (x, y) = ((d.dot(&u) + half) * scale, (d.dot(&v) + half) * scale);
                (lo_u, hi_u) = (lo_u.min(x), hi_u.max(x));
                (lo_v, hi_v) = (lo_v.min(y), hi_v.max(y));
                h = h.max(d.dot(&s));
            }
            if hi_u < 0.0 || hi_v < 0.0 || lo_u >= size as f32 || lo_v >= size as f32 {
                continue;
            }
            let span = |lo: f32, hi: f32| {
                let start = lo.max(0.0) as usize;
                start..(hi.ceil().min(size as f32) as usize).max(start)
            };
            let (columns, rows) = (span(lo_u, hi_u), span(lo_v, hi_v));
            *work += (rows.len() * columns.len()) as u64;
            for y in rows {
                let row = &mut depth[y * size..(y + 1) * size];
                for d in &mut row[columns.clone()] {
                    *d = d.max(h);
                }
            }
        }
        ShadowMap {
            size,
            half,
            centre,
            u,
            v,
            scale,
            depth,
        }
    }

    /// Whether something stands between each point of a row (`points`: the x, y and z of
    /// each) and the sun, into `out`: first every point's texel and height along the sun
    /// (vectorised), then the lookups. Points off the map are lit.
    #[inline]
    fn shadowed_row(
        &self,
        points: &[[f32; WIDTH]; 3],
        sun: &Vector3<f32>,
        out: &mut [bool; WIDTH],
    ) {
        let size = self.size as f32;
        let mut texel = [0u32; WIDTH];
        let mut height = [0.0f32; WIDTH];
        let mut on_map = [false; WIDTH];
        for k in 0..WIDTH {
            let d = Point3::new(points[0][k], points[1][k], points[2][k]) - self.centre;
            let x = (d.dot(&self.u) + self.half) * self.scale;
            let y = (d.dot(&self.v) + self.half) * self.scale;
            let inside = (x >= 0.0) & (y >= 0.0) & (x < size) & (y < size);
            // In the map the truncations are exact texel indices; off it, texel 0 is read and
            // ignored.
            let (column, row) = if inside { (x as u32, y as u32) } else { (0, 0) };
            texel[k] = row * self.size as u32 + column;
            height[k] = d.dot(sun) + 0.3;
            on_map[k] = inside;
        }
        for k in 0..WIDTH {
            out[k] = on_map[k] & (self.depth[texel[k] as usize] > height[k]);
        }
    }
}

/// The world points of a row of pixels: `eye + (dx, dy, dz) · depth` per pixel, with each
/// column's `(dx, dy)` from `columns`, the row's `dz` and the pixel's depth (x, y, z into
/// `points`).
#[inline]
fn row_points(
    eye: Point3<f32>,
    columns: &[(f32, f32); WIDTH],
    dz: f32,
    depths: &[f32; WIDTH],
    points: &mut [[f32; WIDTH]; 3],
) {
    for k in 0..WIDTH {
        let p = eye + Vector3::new(columns[k].0, columns[k].1, dz) * depths[k];
        points[0][k] = p.x;
        points[1][k] = p.y;
        points[2][k] = p.z;
    }
}

/// Renders one frame (with fresh buffers; [`Camera`] reuses them across frames).
pub fn render<R: Rng + ?Sized>(
    scene: &Scene,
    pose: &CameraPose,
    settings: &Settings,
    rng: &mut R,
) -> Frame {
    let mut image = Image::new([0.0; 3]);
    let work = Camera::default().render_into(scene, pose, settings, rng, &mut image);
    Frame { image, work }
}

/// A camera with reusable buffers: after the first frame, rendering allocates nothing large.
#[derive(Debug, Default, Clone)]
pub struct Camera {
    /// Boxed: a camera sits in [`crate::sim::Perceiver`] next to much smaller perceptions.
    buffers: Box<Buffers>,
    spare: Vec<[f32; 3]>,
    glow: [Vec<[f32; 3]>; 2],
}

impl Camera {
    /// Renders one frame into `image` and returns the work it took (pixel operations:
    /// fragments rasterised, pixels shaded, shadow-map texels, post-process taps, noise draws).
    ///
    /// ```
    /// use rand::SeedableRng;
    /// use savme_sim::camera::{reference_shot, Camera, Image};
    /// use savme_sim::scene::Scene;
    /// use savme_sim::settings::Settings;
    ///
    /// let (world, intruder, pose) = reference_shot();
    /// let scene = Scene { world, vehicles: &intruder };
    /// let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    /// let (mut camera, mut image) = (Camera::default(), Image::default());
    /// let work = camera.render_into(&scene, &pose, &Settings::hf(), &mut rng, &mut image);
    /// assert!(work > 0);
    /// assert_eq!(image.pixels.len(), savme_sim::camera::WIDTH * savme_sim::camera::HEIGHT);
    /// ```
    pub fn render_into<R: Rng + ?Sized>(
        &mut self,
        scene: &Scene,
        pose: &CameraPose,
        settings: &Settings,
        rng: &mut R,
        image: &mut Image,
    ) -> u64 {
        let mut work = 0u64;
        let far = settings.view_distance as f32;
        let near = settings.camera_near_clip as f32;
        let (list, objects) = visible_faces(scene, pose, settings, far);
        work += list.len() as u64;
        let shadows = (!settings.disable_shadows).then(|| {
            let buffer = std::mem::take(&mut self.buffers.shadow_depth);
            ShadowMap::build(&objects, &list, pose.eye, buffer, &mut work)
        });
        let b = &mut *self.buffers;
        rasterise(b, &list, pose, near, far, &mut work);
        image.pixels.resize(WIDTH * HEIGHT, [0.0; 3]);
        let yaw = pose.rotation();
        let sun = sun();
        let layout = scene.world.layout();
        // The light of each face and of the ground (a pixel's light depends only on its normal
        // and, below, on its shadow), computed once per frame.
        let light_of = |normal: Vector3<f32>| 0.35 + 0.75 * normal.dot(&sun).max(0.0);
        b.lights.clear();
        b.lights.extend(list.iter().map(|f| light_of(f.normal)));
        let ground_light = light_of(Vector3::z());
        let lit = !settings.disable_lighting;
        // A pixel's viewing direction in the world: x and y depend on its column only, z (which
        // the yaw leaves) on its row only.
        let columns: [(f32, f32); WIDTH] = std::array::from_fn(|u| {
            let d = yaw.to_world(pixel_dir(u as f32 + 0.5, 0.5));
            (d.x, d.y)
        });
        // Per row: every pixel's world point (the same arithmetic as one pixel at a time, over
        // arrays the compiler vectorises), then which of them lie in shadow, then the colours.
        let mut points = [[0.0f32; WIDTH]; 3];
        let mut shadowed = [false; WIDTH];
        for v in 0..HEIGHT {
            // Sky colour of this row.
            let t = (HEIGHT - v) as f32 / HEIGHT as f32;
            let sky = [0.55 + 0.2 * t, 0.7 + 0.15 * t, 0.92];
            let dz = pixel_dir(0.5, v as f32 + 0.5).z;
            let row = v * WIDTH..(v + 1) * WIDTH;
            let depths: &[f32; WIDTH] = b.depth[row.clone()].try_into().expect("a row");
            row_points(pose.eye, &columns, dz, depths, &mut points);
            if let Some(map) = &shadows {
                map.shadowed_row(&points, &sun, &mut shadowed);
            }
            for (u, (pixel, &cover)) in image.pixels[row.clone()]
                .iter_mut()
                .zip(&b.cover[row])
                .enumerate()
            {
                work += 1;
                if cover == SKY {
                    *pixel = sky;
                    continue;
                }
                let (albedo, face_light) = match cover {
                    GROUND => (
                        ground_colour(layout, points[0][u], points[1][u]),
                        ground_light,
                    ),
                    face => (list[face as usize].albedo, b.lights[face as usize]),
                };
                let mut light = if lit {
                    work += 1;
                    face_light
                } else {
                    1.0
                };
                if shadows.is_some() {
                    work += 1;
                    if shadowed[u] {
                        light *= 0.45;
                    }
                }
                *pixel = albedo.map(|a| a * light);
            }
        }
        if let Some(map) = shadows {
            b.shadow_depth = map.depth;
        }
        self.post_process(image, settings, rng, &mut work);
        work
    }

    /// The post-processing chain on the shaded image, each stage unless its setting disables
    /// it: depth of field, lens distortion, bloom, shot noise; then the clamp to [0, 1].
    fn post_process<R: Rng + ?Sized>(
        &mut self,
        image: &mut Image,
        settings: &Settings,
        rng: &mut R,
        work: &mut u64,
    ) {
        if !settings.disable_depth_of_field {
            depth_of_field(&image.pixels, &self.buffers.depth, &mut self.spare, work);
            std::mem::swap(&mut image.pixels, &mut self.spare);
        }
        if !settings.disable_lens_model {
            distort(&image.pixels, &mut self.spare, work);
            std::mem::swap(&mut image.pixels, &mut self.spare);
        }
        if !settings.disable_bloom {
            bloom(image, settings.bloom_level, &mut self.glow, work);
        }
        if !settings.camera_disable_shot_noise {
            shot_noise(&mut image.pixels, rng, &mut self.spare, work);
        }
        for p in &mut image.pixels {
            for c in p.iter_mut() {
                *c = c.clamp(0.0, 1.0);
            }
        }
    }
}

/// The faces to rasterise: those of every world object within the view distance (plus a
/// margin for big buildings), and of the vehicles; with the range of faces of each object that
/// may cast a shadow.
fn visible_faces(
    scene: &Scene,
    pose: &CameraPose,
    settings: &Settings,
    far: f32,
) -> (Vec<Face>, Vec<std::ops::Range<usize>>) {
    let mut list = Vec::new();
    let mut objects = Vec::new();
    for (i, o) in scene.world.objects().iter().enumerate() {
        // Cull by bounding sphere: what may be seen, and what may cast a shadow into view
        // (a shadow reaches 0.7 × the object's height away from it, for this sun).
        let ObjectShape::Box(h) = o.shape;
        let r = h.norm();
        let c = pose.to_camera(Point3::from(o.pose.translation.vector));
        let top = o.pose.translation.vector.z + h.z;
        let shadow_r = r + 0.7 * top.max(0.0);
        let within = |r: f32| {
            c.x > -r
                && c.x - r < far
                && c.norm() - r < far
                && (c.y.abs() - c.x) * std::f32::consts::FRAC_1_SQRT_2 < r
        };
        let (seen, shades) = (within(r), within(shadow_r));
        if seen || (shades && !settings.disable_shadows) {
            let first = list.len();
            faces(o.shape, &o.pose, kind_albedo(o.kind, i), &mut list);
            for f in &mut list[first..] {
                f.in_view = seen;
            }
            objects.push(first..list.len());
        }
    }
    for v in scene.vehicles {
        let h = crate::vehicle::body().half_extents;
        let first = list.len();
        faces(ObjectShape::Box(h), &v.pose(), INTRUDER_PAINT, &mut list);
        objects.push(first..list.len());
    }
    (list, objects)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// The per-pixel shadow test [`ShadowMap::shadowed_row`] replaced (commit 9e50294).
    fn shadowed(map: &ShadowMap, p: Point3<f32>, sun: &Vector3<f32>) -> bool {
        let d = p - map.centre;
        let x = (d.dot(&map.u) + map.half) * map.scale;
        let y = (d.dot(&map.v) + map.half) * map.scale;
        let size = map.size as f32;
        if !(x >= 0.0 && y >= 0.0 && x < size && y < size) {
            return false;
        }
        let i = y as usize * map.size + x as usize;
        map.depth.get(i).is_some_and(|&h| h > d.dot(sun) + 0.3)
    }

    /// Rows of points on and above the ground around the reference shot, off the map, and
    /// not finite (a sky pixel's): the same answers as one point at a time.
    #[test]
    fn a_row_of_shadow_tests_answers_as_one_point_at_a_time() {
        let (world, intruder, pose) = reference_shot();
        let scene = Scene {
            world,
            vehicles: &intruder,
        };
        let (list, objects) = visible_faces(&scene, &pose, &Settings::hf(), 1000.0);
        let map = ShadowMap::build(&objects, &list, pose.eye, Vec::new(), &mut 0);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(39);
        let sun = sun();
        let (mut row, mut shaded) = ([[0.0f32; WIDTH]; 3], 0);
        for _ in 0..400 {
            let reach = [5.0f32, 30.0, 80.0][rng.random_range(0..3usize)];
            let [xs, ys, zs] = &mut row;
            for ((x, y), z) in xs.iter_mut().zip(ys.iter_mut()).zip(zs.iter_mut()) {
                *x = pose.eye.x + rng.random_range(-reach..reach);
                *y = pose.eye.y + rng.random_range(-reach..reach);
                *z = [0.0, rng.random_range(0.0..8.0)][rng.random_range(0..2usize)];
            }
            row[0][rng.random_range(0..WIDTH)] = f32::INFINITY;
            row[1][rng.random_range(0..WIDTH)] = f32::NAN;
            let mut out = [false; WIDTH];
            map.shadowed_row(&row, &sun, &mut out);
            for k in 0..WIDTH {
                let p = Point3::new(row[0][k], row[1][k], row[2][k]);
                assert_eq!(out[k], shadowed(&map, p, &sun), "{p:?}");
                shaded += usize::from(out[k]);
            }
        }
        assert!(shaded > 1000, "{shaded} points in shadow");
    }
}
