//! # savme-sim
//!
//! The bundled driving simulator of savme (work in progress): planar lane paths, sedan-sized
//! vehicles with a kinematic bicycle model, the ego's Stanley and PI controllers, and parry3d
//! box collisions. The road layouts, the ten pre-crash scenarios, the system under test and the
//! camera/lidar sensors build on these.
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
