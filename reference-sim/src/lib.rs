//! # savme-sim
//!
//! The bundled driving simulator of savme: five road layouts with scenery, the paper's ten
//! pre-crash scenarios ([`scenario`]), sedan-sized vehicles with a kinematic bicycle model and
//! parry3d box collisions, a camera and a lidar ([`camera`], [`lidar`]) whose cost and output
//! follow the paper's 16 fidelity settings (Table II, [`fidelity`]), and an emergency-braking
//! system under test that perceives through them ([`perception`], [`sut`]). A run is a
//! failure when the ego collides.
//!
//! ```
//! use savme_kernel::Assignment;
//! use savme_sim::{fidelity, scenario, sim::DrivingSimulator};
//!
//! // Scenario 7: a lead vehicle 8 m ahead brakes hard half a second in.
//! let info = scenario::find("7").unwrap();
//! let phi = Assignment::new()
//!     .with("ego_speed", 20.0)
//!     .with("lead_speed", 10.0)
//!     .with("gap", 8.0)
//!     .with("lead_decel", 9.0)
//!     .with("brake_time", 0.5);
//! // Idealised perception is fast; `DrivingSimulator::default()` sees through camera + lidar.
//! let r = DrivingSimulator::ideal().run(info.name, &phi, &fidelity::theta_hf(), false)?;
//! assert!(r.failure && r.collision_time.is_some());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod camera;
pub mod control;
pub mod fidelity;
pub mod lidar;
pub mod path;
pub mod perception;
pub mod scenario;
pub mod scene;
pub mod settings;
pub mod sim;
pub mod sut;
pub mod vehicle;
pub mod world;

/// The search problem of the bundled simulator: the paper's fidelity space (Table II, `bins`
/// per continuous setting), θ_HF, and the ten scenarios' parameter spaces by name — what a
/// campaign searches (`savme_campaign::Problem::from(savme_sim::problem(10))`).
pub fn problem(
    bins: u32,
) -> (
    savme_kernel::Space,
    savme_kernel::Assignment,
    std::collections::BTreeMap<String, savme_kernel::Space>,
) {
    (
        fidelity::space(bins),
        fidelity::theta_hf(),
        scenario::spaces(),
    )
}
