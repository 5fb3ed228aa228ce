//! The bundled driving simulator's frames for the viewer ([`DrivingFrames`]): the road's
//! scenery, both vehicles on a `sim_time` timeline with their trajectories and planned paths,
//! the camera image with the detector's box, the lidar cloud coloured by intensity, the
//! perceived obstacle, the planner's predicted closest approach and the actual one.

use super::recorder::{err, RecordError, TrialFrames};
use rerun::RecordingStream;
use savme_kernel::Assignment;
use savme_sim::perception::SensorFrame;
use savme_sim::scenario;
use savme_sim::sim::{DrivingSimulator, Frame, RunResult};
use savme_sim::vehicle::VehicleState;
use savme_sim::world::{ObjectShape, World};
use std::collections::BTreeSet;

/// Re-runs trials of the bundled simulator with recording on and logs their frames.
#[derive(Debug, Clone, Default)]
pub struct DrivingFrames {
    sim: DrivingSimulator,
    layouts_logged: BTreeSet<String>,
}

impl DrivingFrames {
    /// Frames of `sim` (the same deterministic runs as the campaign's).
    pub fn new(sim: DrivingSimulator) -> Self {
        DrivingFrames {
            sim,
            layouts_logged: BTreeSet::new(),
        }
    }

    fn log_scenery(
        &mut self,
        rec: &RecordingStream,
        info: &'static scenario::ScenarioInfo,
    ) -> Result<(), RecordError> {
        let key = format!("{:?}", info.layout).to_lowercase();
        if !self.layouts_logged.insert(key.clone()) {
            return Ok(());
        }
        let world = World::shared(info.layout);
        let (mut centres, mut halves, mut rotations) = (Vec::new(), Vec::new(), Vec::new());
        for o in world.objects() {
            let ObjectShape::Box(h) = o.shape;
            let t = o.pose.translation.vector;
            centres.push((t.x, t.y, t.z));
            halves.push((h.x, h.y, h.z));
            let q = o.pose.rotation;
            rotations.push(rerun::Quaternion::from_xyzw([q.i, q.j, q.k, q.w]));
        }
        rec.log_static(
            format!("world/{key}/scenery"),
            &rerun::Boxes3D::from_centers_and_half_sizes(centres, halves)
                .with_quaternions(rotations)
                .with_colors([rerun::Color::from_rgb(150, 150, 150)]),
        )
        .map_err(err)
    }
}

/// Logs a run of the bundled simulator under `base`: planned paths, vehicles over `sim_time`,
/// camera, detections, lidar, closest approach.
fn log_run(
    rec: &RecordingStream,
    base: &str,
    info: &'static scenario::ScenarioInfo,
    phi: &Assignment,
    r: &RunResult,
) -> Result<(), RecordError> {
    if let Ok(setup) = scenario::setup(info, phi) {
        log_planned_paths(rec, base, &setup)?;
    }
    let frames: &[Frame] = r.trajectory.as_deref().unwrap_or(&[]);
    log_frames(rec, base, frames)?;
    log_closest_approach(rec, base, frames, r.min_distance)?;
    for sf in r.sensor_frames.as_deref().unwrap_or(&[]) {
        rec.set_duration_secs("sim_time", sf.time);
        log_camera(rec, base, sf)?;
        log_lidar(rec, base, sf)?;
    }
    Ok(())
}

/// The ego's and the intruder's planned paths, sampled every metre, as static line strips.
fn log_planned_paths(
    rec: &RecordingStream,
    base: &str,
    setup: &scenario::Setup,
) -> Result<(), RecordError> {
    for (name, path) in [
        ("ego_path", &setup.ego_path),
        ("intruder_path", &setup.intruder_path),
    ] {
        let n = (path.length() / 1.0).ceil() as usize + 1;
        let pts: Vec<(f32, f32, f32)> = (0..n)
            .map(|k| {
                let p = path.point_at(k as f64 * path.length() / (n - 1).max(1) as f64);
                (p.x as f32, p.y as f32, 0.02)
            })
            .collect();
        rec.log_static(
            format!("{base}/{name}"),
            &rerun::LineStrips3D::new([pts]).with_colors([rerun::Color::from_rgb(90, 90, 200)]),
        )
        .map_err(err)?;
    }
    Ok(())
}

/// Every step on the `sim_time` timeline: both vehicles with their trajectories so far, the
/// planner's predicted closest approach (cleared when it has none) and the perceived obstacle.
fn log_frames(rec: &RecordingStream, base: &str, frames: &[Frame]) -> Result<(), RecordError> {
    let mut ego_track = Vec::new();
    let mut intruder_track = Vec::new();
    for f in frames {
        rec.set_duration_secs("sim_time", f.time);
        log_vehicle(
            rec,
            base,
            "ego",
            &f.ego,
            rerun::Color::from_rgb(220, 40, 40),
            &mut ego_track,
        )?;
        log_vehicle(
            rec,
            base,
            "intruder",
            &f.intruder,
            rerun::Color::from_rgb(230, 110, 20),
            &mut intruder_track,
        )?;
        log_predicted_closest_approach(rec, base, f)?;
        if let Some(m) = f.measured {
            rec.log(
                format!("{base}/measured"),
                &rerun::Points3D::new([(m.x as f32, m.y as f32, 1.0f32)])
                    .with_radii([0.4f32])
                    .with_colors([rerun::Color::from_rgb(40, 200, 40)]),
            )
            .map_err(err)?;
        }
    }
    Ok(())
}

/// A vehicle's body as a box under `base/name`, and its trajectory (`track`, extended by this
/// frame's centre) under `base/name_trajectory`.
fn log_vehicle(
    rec: &RecordingStream,
    base: &str,
    name: &str,
    v: &VehicleState,
    colour: rerun::Color,
    track: &mut Vec<(f32, f32, f32)>,
) -> Result<(), RecordError> {
    let body = savme_sim::vehicle::body().half_extents;
    let c = v.center();
    track.push((c.x as f32, c.y as f32, 0.1f32));
    let q = v.pose().rotation;
    rec.log(
        format!("{base}/{name}"),
        &rerun::Boxes3D::from_centers_and_half_sizes(
            [(c.x as f32, c.y as f32, body.z)],
            [(body.x, body.y, body.z)],
        )
        .with_quaternions([rerun::Quaternion::from_xyzw([q.i, q.j, q.k, q.w])])
        .with_colors([colour])
        .with_labels([name]),
    )
    .map_err(err)?;
    rec.log(
        format!("{base}/{name}_trajectory"),
        &rerun::LineStrips3D::new([track.clone()]).with_colors([colour]),
    )
    .map_err(err)
}

/// The planner's predicted closest approach at this frame, or a clear when it has none.
fn log_predicted_closest_approach(
    rec: &RecordingStream,
    base: &str,
    f: &Frame,
) -> Result<(), RecordError> {
    if let Some(pr) = f.predicted {
        rec.log(
            format!("{base}/predicted_closest_approach"),
            &rerun::LineStrips3D::new([[
                (pr.ego.x as f32, pr.ego.y as f32, 1.2f32),
                (pr.obstacle.x as f32, pr.obstacle.y as f32, 1.2),
            ]])
            .with_colors([rerun::Color::from_rgb(255, 0, 255)])
            .with_labels([format!(
                "predicted clearance {:.1} m in {:.1} s",
                pr.clearance,
                pr.time - f.time
            )]),
        )
        .map_err(err)
    } else {
        rec.log(
            format!("{base}/predicted_closest_approach"),
            &rerun::Clear::flat(),
        )
        .map_err(err)
    }
}

/// The closest approach: the two centres where the bodies came closest, at that frame's time.
fn log_closest_approach(
    rec: &RecordingStream,
    base: &str,
    frames: &[Frame],
    min_distance: f64,
) -> Result<(), RecordError> {
    if let Some(f) = frames.iter().min_by(|a, b| {
        let d = |f: &Frame| (f.ego.center() - f.intruder.center()).norm();
        d(a).total_cmp(&d(b))
    }) {
        rec.set_duration_secs("sim_time", f.time);
        let (a, b) = (f.ego.center(), f.intruder.center());
        rec.log(
            format!("{base}/closest_approach"),
            &rerun::LineStrips3D::new([[
                (a.x as f32, a.y as f32, 1.6f32),
                (b.x as f32, b.y as f32, 1.6),
            ]])
            .with_colors([rerun::Color::from_rgb(250, 220, 0)])
            .with_labels([format!("min body distance {min_distance:.2} m")]),
        )
        .map_err(err)?;
    }
    Ok(())
}

/// The camera image and the detector's box on it (cleared when it detected nothing).
fn log_camera(rec: &RecordingStream, base: &str, sf: &SensorFrame) -> Result<(), RecordError> {
    rec.log(
        format!("{base}/camera"),
        &rerun::Image::from_rgb24(
            sf.image.to_rgb8(),
            [
                savme_sim::camera::WIDTH as u32,
                savme_sim::camera::HEIGHT as u32,
            ],
        ),
    )
    .map_err(err)?;
    match &sf.detection {
        Some(bb) => rec
            .log(
                format!("{base}/camera/detection"),
                &rerun::Boxes2D::from_mins_and_sizes(
                    [(bb.u0 as f32, bb.v0 as f32)],
                    [((bb.u1 - bb.u0) as f32, (bb.v1 - bb.v0) as f32)],
                )
                .with_labels(["vehicle"]),
            )
            .map_err(err),
        None => rec
            .log(format!("{base}/camera/detection"), &rerun::Clear::flat())
            .map_err(err),
    }
}

/// The lidar cloud, coloured by intensity.
fn log_lidar(rec: &RecordingStream, base: &str, sf: &SensorFrame) -> Result<(), RecordError> {
    let pts: Vec<(f32, f32, f32)> = sf
        .cloud
        .iter()
        .map(|p| (p.position.x, p.position.y, p.position.z))
        .collect();
    let colours: Vec<rerun::Color> = sf
        .cloud
        .iter()
        .map(|p| {
            let i = (p.intensity.clamp(0.0, 1.0) * 255.0) as u8;
            rerun::Color::from_rgb(i, 255 - i, 255)
        })
        .collect();
    rec.log(
        format!("{base}/lidar"),
        &rerun::Points3D::new(pts)
            .with_colors(colours)
            .with_radii([0.06f32]),
    )
    .map_err(err)
}

impl TrialFrames for DrivingFrames {
    fn record_run(
        &mut self,
        rec: &RecordingStream,
        base: &str,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<Option<String>, RecordError> {
        let Some(info) = scenario::find(scenario) else {
            return Ok(None);
        };
        self.log_scenery(rec, info)?;
        let r = self.sim.run(info.name, phi, theta, true).map_err(err)?;
        log_run(rec, base, info, phi, &r)?;
        Ok(Some(match r.collision_time {
            Some(t) => format!("collision at {t:.2} s"),
            None => format!("no collision, min distance {:.2} m", r.min_distance),
        }))
    }
}
