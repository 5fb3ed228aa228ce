//! A forward-looking lidar ray-cast through the scene with parry3d, with the paper's six lidar
//! fidelity settings: shot noise, ambient (sunlight) returns, translucency, subsample count,
//! ray-tracing bounces and near clipping.

use crate::scene::{Caster, Scene, SceneHit, Surface};
use crate::settings::Settings;
use nalgebra::{Point3, Vector3};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Normal};

/// Elevation of the 8 channels, degrees.
pub const ELEVATIONS_DEG: [f32; 8] = [-14.0, -10.0, -7.0, -5.0, -3.5, -2.0, -1.0, 0.0];
/// Half of the horizontal field of view, degrees.
pub const HALF_FOV_DEG: f32 = 30.0;
/// Azimuth step, degrees.
pub const AZIMUTH_STEP_DEG: f32 = 2.0;
/// Maximum range, metres.
pub const MAX_RANGE: f32 = 100.0;
/// Range noise (standard deviation) of one ray, metres.
pub const RANGE_NOISE: f32 = 0.03;
/// Probability that a beam also reports a spurious sunlight return.
pub const AMBIENT_RATE: f64 = 0.02;
/// Work units charged per ray cast: a ray through the scenery's BVH costs about as much as 90
/// camera pixel operations (measured: ~0.55 µs per ray, ~6 ns per pixel operation), so the
/// deterministic work counter tracks wall-clock cost across both sensors.
pub const RAY_WORK: u64 = 90;
/// Beam divergence: subsample rays spread over ± this, degrees.
pub const DIVERGENCE_DEG: f32 = 0.3;

/// Why a point was returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReturnKind {
    /// The first surface the beam met.
    Surface,
    /// Light that passed through glass and hit what is behind it.
    Transmitted,
    /// A multi-path ghost: light reflected off a surface onto another one, reported along the
    /// beam at the total path length.
    MultiPath,
    /// A spurious return caused by sunlight.
    Ambient,
}

/// One lidar return.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LidarPoint {
    /// Position in the world.
    pub position: Point3<f32>,
    /// Return intensity (0–1).
    pub intensity: f32,
    /// What produced it.
    pub kind: ReturnKind,
    /// The surface hit (for `Surface` and `Transmitted` returns).
    pub surface: Option<Surface>,
}

/// One sweep.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LidarScan {
    /// The returns.
    pub points: Vec<LidarPoint>,
    /// Rays cast.
    pub rays: u64,
    /// Random numbers drawn (noise, sunlight).
    pub draws: u64,
}

/// Offsets (in units of the divergence) of the subsample rays of a beam.
const SUBSAMPLE: [(f32, f32); 5] = [
    (0.0, 0.0),
    (0.5, 0.5),
    (-0.5, -0.5),
    (0.5, -0.5),
    (-0.5, 0.5),
];

fn reflect(d: Vector3<f32>, n: Vector3<f32>) -> Vector3<f32> {
    d - n * (2.0 * d.dot(&n))
}

/// Sweeps the lidar at `origin` looking along `heading` (radians).
pub fn scan<R: Rng + ?Sized>(
    scene: &Scene,
    origin: Point3<f32>,
    heading: f32,
    settings: &Settings,
    rng: &mut R,
) -> LidarScan {
    let subsamples = settings.subsamples.clamp(1, SUBSAMPLE.len() as u32) as usize;
    let div = DIVERGENCE_DEG.to_radians();
    let steps = (2.0 * HALF_FOV_DEG / AZIMUTH_STEP_DEG).round() as i32;
    let azimuths: Vec<f32> = (0..=steps)
        .map(|k| heading + (-HALF_FOV_DEG + k as f32 * AZIMUTH_STEP_DEG).to_radians())
        .collect();
    let elevations = ELEVATIONS_DEG.map(f32::to_radians);
    // The sines and cosines of every beam's and subsample ray's angles, computed once per
    // sweep (each azimuth serves 8 channels, each elevation 31 beams).
    let angles = |base: &[f32], offset: fn(&(f32, f32)) -> f32| -> Vec<Trig> {
        base.iter()
            .flat_map(|&b| {
                std::iter::once(Trig::of(b)).chain(
                    SUBSAMPLE[..subsamples]
                        .iter()
                        .map(move |o| Trig::of(b + offset(o) * div)),
                )
            })
            .collect()
    };
    let sweep = Sweep {
        caster: scene.caster(),
        scene,
        origin,
        settings,
        noise: Normal::new(0.0f32, RANGE_NOISE).expect("valid noise"),
        near: settings.lidar_near_clip as f32,
        subsamples,
        azimuths: angles(&azimuths, |o| o.0),
        elevations: angles(&elevations, |o| o.1),
    };
    let mut out = LidarScan::default();
    for el in 0..elevations.len() {
        for az in 0..azimuths.len() {
            sweep.beam(az, el, rng, &mut out);
        }
    }
    out
}

/// The sine and cosine of an angle.
#[derive(Debug, Clone, Copy)]
struct Trig {
    sin: f32,
    cos: f32,
}

impl Trig {
    #[inline]
    fn of(angle: f32) -> Trig {
        Trig {
            sin: angle.sin(),
            cos: angle.cos(),
        }
    }
}

/// The unit vector at an azimuth and an elevation.
#[inline]
fn direction(azimuth: Trig, elevation: Trig) -> Vector3<f32> {
    Vector3::new(
        azimuth.cos * elevation.cos,
        azimuth.sin * elevation.cos,
        elevation.sin,
    )
}

/// What every beam of a sweep shares.
struct Sweep<'a> {
    scene: &'a Scene<'a>,
    caster: Caster<'a>,
    origin: Point3<f32>,
    settings: &'a Settings,
    noise: Normal<f32>,
    /// Near clipping, metres.
    near: f32,
    /// Subsample rays per beam.
    subsamples: usize,
    /// Per beam azimuth: its own [`Trig`], then those of its subsample rays' azimuths.
    azimuths: Vec<Trig>,
    /// Per channel: its elevation's [`Trig`], then those of its subsample rays' elevations.
    elevations: Vec<Trig>,
}

/// The subsample rays of a beam that hit: the first one's hit, and their mean range and
/// intensity.
struct BeamHit {
    first: SceneHit,
    range: f32,
    intensity: f32,
}

impl Sweep<'_> {
    /// One beam at azimuth `az`, elevation `el`: its surface return with what glass lets
    /// through and the multi-path ghosts of shiny surfaces, then a possible sunlight return.
    #[inline]
    fn beam<R: Rng + ?Sized>(&self, az: usize, el: usize, rng: &mut R, out: &mut LidarScan) {
        let stride = self.subsamples + 1;
        let (az, el) = (
            &self.azimuths[az * stride..(az + 1) * stride],
            &self.elevations[el * stride..(el + 1) * stride],
        );
        let beam = direction(az[0], el[0]);
        if let Some(hit) = self.subsample(az, el, rng, out) {
            let (h, range) = (hit.first, hit.range);
            if range >= self.near {
                out.points.push(LidarPoint {
                    position: self.origin + beam * range,
                    intensity: hit.intensity,
                    kind: ReturnKind::Surface,
                    surface: Some(h.surface),
                });
                let hit_point = self.origin + beam * h.distance;
                // Glass lets part of the light through to what is behind it.
                if h.glass && !self.settings.disable_translucency {
                    self.transmitted(beam, hit_point, &h, out);
                }
                // Shiny surfaces (paint, glass) reflect the beam onward: multi-path ghosts.
                let shiny = h.glass || matches!(h.surface, Surface::Vehicle(_));
                if shiny {
                    self.multi_path(beam, hit_point, &h, out);
                }
            }
        }
        if !self.settings.disable_ambient {
            self.ambient(beam, rng, out);
        }
    }

    /// Casts the beam's subsample rays (at the angles `az[1..]`, `el[1..]`) and averages the
    /// ranges (with shot noise) and intensities of those that hit; `None` when none hits.
    #[inline]
    fn subsample<R: Rng + ?Sized>(
        &self,
        az: &[Trig],
        el: &[Trig],
        rng: &mut R,
        out: &mut LidarScan,
    ) -> Option<BeamHit> {
        let (scene, settings) = (self.scene, self.settings);
        let (mut sum_d, mut sum_i, mut hits) = (0.0f32, 0.0f32, 0u32);
        let mut first: Option<SceneHit> = None;
        for (&a, &e) in az[1..].iter().zip(&el[1..]) {
            let dir = direction(a, e);
            out.rays += 1;
            if let Some(h) = self.caster.cast(self.origin, dir, MAX_RANGE, None) {
                let mut d = h.distance;
                if !settings.lidar_disable_shot_noise {
                    out.draws += 1;
                    d += self.noise.sample(rng);
                }
                let opaque_glass = h.glass && settings.disable_translucency;
                let refl = if opaque_glass {
                    0.3
                } else {
                    scene.reflectivity(&h)
                };
                sum_d += d;
                sum_i += refl * (-dir.dot(&h.normal)).abs().max(0.05);
                hits += 1;
                first.get_or_insert(h);
            }
        }
        first.map(|first| BeamHit {
            first,
            range: sum_d / hits as f32,
            intensity: sum_i / hits as f32,
        })
    }

    /// The return of what is behind the glass hit `h` at `hit_point`.
    #[inline]
    fn transmitted(
        &self,
        beam: Vector3<f32>,
        hit_point: Point3<f32>,
        h: &SceneHit,
        out: &mut LidarScan,
    ) {
        out.rays += 1;
        let from = hit_point + beam * 0.05;
        if let Some(t) = self.caster.cast(from, beam, MAX_RANGE, Some(h.surface)) {
            out.points.push(LidarPoint {
                position: from + beam * t.distance,
                intensity: 0.5 * self.scene.reflectivity(&t),
                kind: ReturnKind::Transmitted,
                surface: Some(t.surface),
            });
        }
    }

    /// The ghosts of the beam reflected off the shiny hit `h` at `hit_point`, up to
    /// `bounces` times while it keeps meeting shiny surfaces; each reported along the beam
    /// at the total path length.
    #[inline]
    fn multi_path(
        &self,
        beam: Vector3<f32>,
        hit_point: Point3<f32>,
        h: &SceneHit,
        out: &mut LidarScan,
    ) {
        let scene = self.scene;
        let (mut dir, mut at, mut normal) = (beam, hit_point, h.normal);
        let mut path = h.distance;
        let mut gain = 1.0f32;
        let mut last = h.surface;
        for _ in 0..self.settings.bounces {
            dir = reflect(dir, normal);
            out.rays += 1;
            let Some(b) = self
                .caster
                .cast(at + dir * 0.05, dir, MAX_RANGE, Some(last))
            else {
                break;
            };
            path += b.distance;
            gain *= 0.15;
            out.points.push(LidarPoint {
                position: self.origin + beam * path,
                intensity: gain * scene.reflectivity(&b),
                kind: ReturnKind::MultiPath,
                surface: None,
            });
            at += dir * (0.05 + b.distance);
            normal = b.normal;
            last = b.surface;
            if !(b.glass || matches!(b.surface, Surface::Vehicle(_))) {
                break;
            }
        }
    }

    /// A spurious sunlight return along the beam, with probability [`AMBIENT_RATE`].
    #[inline]
    fn ambient<R: Rng + ?Sized>(&self, beam: Vector3<f32>, rng: &mut R, out: &mut LidarScan) {
        out.draws += 1;
        if rng.random::<f64>() < AMBIENT_RATE {
            out.draws += 1;
            let range = rng.random_range(2.0f32..60.0);
            if range >= self.near {
                out.points.push(LidarPoint {
                    position: self.origin + beam * range,
                    intensity: 0.05,
                    kind: ReturnKind::Ambient,
                    surface: None,
                });
            }
        }
    }
}
