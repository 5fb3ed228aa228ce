//! The driving simulator's fidelity settings: the SAVME paper's Table II (Schlichting et al.,
//! ITSC 2023) as a kernel [`Space`], with θ_HF.

use savme_kernel::{Assignment, Scale, Space, Variable};

/// The 16 fidelity settings of Table II, continuous ones cut into `bins` log-scaled bins.
///
/// # Panics
///
/// If `bins` is 0 (a continuous variable needs at least one bin): callers taking `bins` from
/// the user must check it first.
///
/// ```
/// let space = savme_sim::fidelity::space(10);
/// assert_eq!(space.len(), 16);
/// assert!(space.arms_of(&savme_sim::fidelity::theta_hf()).is_ok());
/// ```
pub fn space(bins: u32) -> Space {
    let b = Variable::boolean;
    let vars = vec![
        Variable::discrete("simulation_rate_hz", [2, 4, 6, 8, 10]),
        Variable::discrete("camera_bloom_level", ["high", "low"]),
        b("camera_disable_bloom"),
        b("camera_disable_lighting"),
        b("camera_disable_shadows"),
        b("camera_disable_lens_model"),
        b("camera_disable_depth_of_field"),
        b("camera_disable_shot_noise"),
        Variable::continuous("camera_view_distance_m", 10.0, 5000.0, bins, Scale::Log),
        Variable::continuous("camera_near_clipping_m", 0.2, 20.0, bins, Scale::Log),
        b("lidar_disable_shot_noise"),
        b("lidar_disable_ambient_effects"),
        b("lidar_disable_translucency"),
        Variable::discrete("lidar_subsample_count", [1, 2, 3, 4, 5]),
        Variable::discrete("lidar_raytracing_bounces", [0, 1, 2, 3, 4]),
        Variable::continuous("lidar_near_clipping_m", 0.2, 20.0, bins, Scale::Log),
    ];
    Space::new(vars).expect("Table II is a valid space")
}

/// The unit of a fidelity setting: `Hz` and `m` as the names end; flags, levels and counts
/// have none.
///
/// ```
/// assert_eq!(savme_sim::fidelity::unit("simulation_rate_hz"), Some("Hz"));
/// assert_eq!(savme_sim::fidelity::unit("lidar_near_clipping_m"), Some("m"));
/// assert_eq!(savme_sim::fidelity::unit("lidar_subsample_count"), None);
/// ```
pub fn unit(setting: &str) -> Option<&'static str> {
    if setting.ends_with("_hz") {
        Some("Hz")
    } else if setting.ends_with("_m") {
        Some("m")
    } else {
        None
    }
}

/// θ_HF: Table II's bold values.
pub fn theta_hf() -> Assignment {
    Assignment::new()
        .with("simulation_rate_hz", 10)
        .with("camera_bloom_level", "high")
        .with("camera_disable_bloom", false)
        .with("camera_disable_lighting", false)
        .with("camera_disable_shadows", false)
        .with("camera_disable_lens_model", false)
        .with("camera_disable_depth_of_field", false)
        .with("camera_disable_shot_noise", false)
        .with("camera_view_distance_m", 5000.0)
        .with("camera_near_clipping_m", 0.2)
        .with("lidar_disable_shot_noise", false)
        .with("lidar_disable_ambient_effects", false)
        .with("lidar_disable_translucency", false)
        .with("lidar_subsample_count", 5)
        .with("lidar_raytracing_bounces", 4)
        .with("lidar_near_clipping_m", 0.2)
}
