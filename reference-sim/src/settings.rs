//! The paper's 16 fidelity settings (Table II) as typed values.

use crate::fidelity;
use savme_kernel::{Assignment, Domain, SimError, Value, Variable};

/// The cheapest value of a Table II setting: switches disabled, low bloom, 2 Hz, one subsample,
/// no bounces, the shortest view distance, the largest clipping distances.
///
/// ```
/// let space = savme_sim::fidelity::space(10);
/// let rate = space.variable("simulation_rate_hz").unwrap();
/// assert_eq!(savme_sim::settings::cheapest_value(rate), savme_kernel::Value::Int(2));
/// ```
pub fn cheapest_value(v: &Variable) -> Value {
    match (&*v.name, &v.domain) {
        ("camera_bloom_level", _) => Value::from("low"),
        (_, Domain::Discrete { values }) if values.iter().all(|x| x.as_bool().is_some()) => {
            Value::Bool(true)
        }
        (_, Domain::Discrete { values }) => values[0].clone(),
        (name, Domain::Continuous { lo, hi, .. }) => {
            Value::Real(if name.contains("view_distance") {
                *lo
            } else {
                *hi
            })
        }
    }
}

/// Camera bloom glow size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BloomLevel {
    /// A wide glow pass (HF).
    High,
    /// A narrow one.
    Low,
}

/// All 16 settings, read from a θ assignment ([`fidelity::space`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Physics, control and sensor rate, Hz.
    pub rate_hz: f64,
    /// Bloom glow size.
    pub bloom_level: BloomLevel,
    /// No bloom pass.
    pub disable_bloom: bool,
    /// Flat albedo instead of shading.
    pub disable_lighting: bool,
    /// No shadows.
    pub disable_shadows: bool,
    /// Pinhole projection instead of the radially distorted lens.
    pub disable_lens_model: bool,
    /// One sample per pixel instead of several aperture samples.
    pub disable_depth_of_field: bool,
    /// No per-pixel noise.
    pub camera_disable_shot_noise: bool,
    /// Camera far plane, metres.
    pub view_distance: f64,
    /// Camera near plane, metres.
    pub camera_near_clip: f64,
    /// No lidar range noise.
    pub lidar_disable_shot_noise: bool,
    /// No spurious sunlight returns.
    pub disable_ambient: bool,
    /// Glass is opaque to the lidar.
    pub disable_translucency: bool,
    /// Rays per lidar beam, averaged.
    pub subsamples: u32,
    /// Multi-path reflections traced per beam.
    pub bounces: u32,
    /// Lidar minimum range, metres.
    pub lidar_near_clip: f64,
}

impl Settings {
    /// θ_HF.
    pub fn hf() -> Settings {
        Settings::from_assignment(&fidelity::theta_hf()).expect("θ_HF is valid")
    }

    /// Reads a complete, in-range assignment of the 16 settings.
    pub fn from_assignment(theta: &Assignment) -> Result<Settings, SimError> {
        fidelity::space(1)
            .arms_of(theta)
            .map_err(|e| SimError::BadValue {
                variable: "fidelity".into(),
                value: theta.to_string(),
                expected: e.to_string(),
            })?;
        // Validated above: every name is present with a value of the right kind.
        let num = |n: &str| theta.get_f64(n).unwrap_or(f64::NAN);
        let flag = |n: &str| theta.get_bool(n).unwrap_or(false);
        Ok(Settings {
            rate_hz: num("simulation_rate_hz"),
            bloom_level: match theta.get("camera_bloom_level").and_then(|v| v.as_label()) {
                Some("low") => BloomLevel::Low,
                _ => BloomLevel::High,
            },
            disable_bloom: flag("camera_disable_bloom"),
            disable_lighting: flag("camera_disable_lighting"),
            disable_shadows: flag("camera_disable_shadows"),
            disable_lens_model: flag("camera_disable_lens_model"),
            disable_depth_of_field: flag("camera_disable_depth_of_field"),
            camera_disable_shot_noise: flag("camera_disable_shot_noise"),
            view_distance: num("camera_view_distance_m"),
            camera_near_clip: num("camera_near_clipping_m"),
            lidar_disable_shot_noise: flag("lidar_disable_shot_noise"),
            disable_ambient: flag("lidar_disable_ambient_effects"),
            disable_translucency: flag("lidar_disable_translucency"),
            subsamples: num("lidar_subsample_count") as u32,
            bounces: num("lidar_raytracing_bounces") as u32,
            lidar_near_clip: num("lidar_near_clipping_m"),
        })
    }
}
