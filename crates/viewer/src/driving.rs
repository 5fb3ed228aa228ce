//! The bundled driving simulator's frames for the viewer ([`DrivingFrames`]), laid out for the
//! trial view (`super::layout::trial`): under `/hf` or `/lf`, the ego and the intruder as
//! transforms over `sim_time` with their bodies below them, the camera as a pinhole on the ego
//! (JPEG image, detector box with its class label), the lidar cloud coloured by range, planned
//! paths and trajectories, the planner's prediction, the closest approach or collision (a line
//! between the bodies and a warning in `/{run}/events`), the texts of those two as captions in
//! the ego's frame under `/{run}/ego/captions` (drawn below the ego in the 3D view, never over
//! the other vehicle); and the time series `/plots/distance/{run}` —
//! the distance between the bodies, the quantity the failure (a collision: 0 m, drawn as
//! `/plots/distance/collision`) is judged on, at every step and at the run's closest approach
//! (the swept contact check's sample, which may fall between steps), so that its minimum is
//! the run's reported closest approach — `/plots/speed/{run}`, `/plots/braking/{run}`. With
//! idealised perception there is no camera: its view says so (`/{run}/ego/camera/note`).

use super::layout::{self, Layout};
use super::palette::{self, rgb};
use super::stream::{err, RecordError, RunSide, RunSummary, TrialFrames};
use rerun::RecordingStream;
use savme_kernel::Assignment;
use savme_sim::camera::{FOCAL, HEIGHT, WIDTH};
use savme_sim::perception::SensorFrame;
use savme_sim::scenario;
use savme_sim::sim::{Closest, DrivingSimulator, Frame, PerceptionMode, RunResult};
use savme_sim::vehicle::{self, VehicleState};
use savme_sim::world::{ObjectShape, World};

/// Where the camera sits on the ego (as `SensorPerception` mounts it): 1.2 m ahead of the
/// centre, 1.3 m up; the lidar 0.5 m ahead, 1.9 m up.
const CAMERA_MOUNT: [f32; 3] = [1.2, 0.0, 1.3];
const LIDAR_MOUNT: (f64, f32) = (0.5, 1.9);
/// Lidar ranges the colour map spans, metres.
const RANGE_COLOURS: (f32, f32) = (2.0, 60.0);
/// JPEG quality of the camera images.
const JPEG_QUALITY: u8 = 90;

/// Runs trials of the bundled simulator with recording on and logs their frames.
#[derive(Debug, Clone, Default)]
pub struct DrivingFrames {
    sim: DrivingSimulator,
    last: Option<RunResult>,
}

impl DrivingFrames {
    /// Frames of `sim` (the same deterministic runs as the campaign's).
    pub fn new(sim: DrivingSimulator) -> Self {
        DrivingFrames { sim, last: None }
    }

    /// The last run recorded (with its trajectory and sensor frames).
    pub fn take_last(&mut self) -> Option<RunResult> {
        self.last.take()
    }
}

/// A run's ego and intruder colours (named in the 3D views' titles; the ego's is the run's
/// colour on the plots).
fn colour(run: RunSide) -> [rerun::Color; 2] {
    match run {
        RunSide::Hf => [rgb(palette::HF), rerun::Color::from_rgb(240, 150, 30)],
        RunSide::Lf => [rgb(palette::LF), rerun::Color::from_rgb(170, 80, 220)],
    }
}

/// The layout's scenery, static under `/world/scenery`, with the world's up axis.
fn log_scenery(
    rec: &RecordingStream,
    info: &'static scenario::ScenarioInfo,
) -> Result<(), RecordError> {
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
    rec.log_static("/", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
        .map_err(err)?;
    rec.log_static(
        "world/scenery",
        &rerun::Boxes3D::from_centers_and_half_sizes(centres, halves)
            .with_quaternions(rotations)
            .with_colors([rerun::Color::from_rgb(150, 150, 150)]),
    )
    .map_err(err)
}

/// The static parts of a run: bodies, the camera's pinhole (or, with idealised perception, a
/// note that there is no camera), the series' names and colours, the planned paths.
fn log_static_parts(
    rec: &RecordingStream,
    run: RunSide,
    info: &'static scenario::ScenarioInfo,
    phi: &Assignment,
    camera: bool,
) -> Result<(), RecordError> {
    let base = run.path();
    let [ego_colour, intruder_colour] = colour(run);
    let h = savme_sim::vehicle::body().half_extents;
    // Unlabelled: the view's title names the colours (labels at the bodies' centres stack on
    // each other as the vehicles close in).
    for (name, c) in [("ego", ego_colour), ("intruder", intruder_colour)] {
        rec.log_static(
            format!("{base}/{name}/body"),
            &rerun::Boxes3D::from_centers_and_half_sizes([(0.0, 0.0, h.z)], [(h.x, h.y, h.z)])
                .with_colors([c])
                .with_fill_mode(rerun::FillMode::Solid),
        )
        .map_err(err)?;
    }
    log_camera(rec, base, camera)?;
    for plot in ["distance", "speed", "braking"] {
        let mut style = rerun::SeriesLines::new()
            .with_names([run.label()])
            .with_colors([ego_colour]);
        if plot == "braking" {
            // A flag: held between steps, never averaged.
            style = style
                .with_interpolation_mode(rerun::components::InterpolationMode::StepAfter)
                .with_aggregation_policy(rerun::components::AggregationPolicy::Off);
        }
        rec.log_static(format!("plots/{plot}/{base}"), &style)
            .map_err(err)?;
    }
    if run == RunSide::Hf {
        rec.log_static(
            "plots/distance/collision",
            &rerun::SeriesLines::new()
                .with_names(["collision (the failure): 0 m"])
                .with_colors([rgb(palette::REFERENCE)]),
        )
        .map_err(err)?;
    }
    if let Ok(setup) = scenario::setup(info, phi) {
        for (name, path) in [
            ("ego_path", &setup.ego_path),
            ("intruder_path", &setup.intruder_path),
        ] {
            let n = path.length().ceil() as usize + 1;
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
    }
    Ok(())
}

/// The camera on the ego: its mount and pinhole, or — with idealised perception, which has no
/// camera — a note in the camera's view saying so.
fn log_camera(rec: &RecordingStream, base: &str, camera: bool) -> Result<(), RecordError> {
    if !camera {
        return rec
            .log_static(
                format!("{base}/ego/camera/note"),
                &rerun::Boxes2D::from_mins_and_sizes([(0.0, 0.0)], [(WIDTH as f32, 0.01)])
                    .with_colors([rgb(palette::REFERENCE)])
                    .with_labels([
                        "no camera in this perception mode (idealised perception: ground truth + noise)",
                    ])
                    .with_show_labels(true),
            )
            .map_err(err);
    }
    rec.log_static(
        format!("{base}/ego/camera"),
        &rerun::Transform3D::from_translation(CAMERA_MOUNT),
    )
    .map_err(err)?;
    rec.log_static(
        format!("{base}/ego/camera"),
        &rerun::Pinhole::from_focal_length_and_resolution(
            [FOCAL, FOCAL],
            [WIDTH as f32, HEIGHT as f32],
        )
        .with_camera_xyz(rerun::components::ViewCoordinates::FLU)
        .with_image_plane_distance(2.0),
    )
    .map_err(err)
}

/// A vehicle's pose as the transform of its entity.
fn pose(v: &VehicleState) -> rerun::Transform3D {
    let c = v.center();
    let half = (v.heading / 2.0) as f32;
    rerun::Transform3D::from_translation_rotation(
        [c.x as f32, c.y as f32, 0.0],
        rerun::Quaternion::from_xyzw([0.0, 0.0, half.sin(), half.cos()]),
    )
}

/// The distance between the bodies (what the failure is judged on: a collision is 0 m) at
/// every step, and at the closest approach where it falls between steps: (time, metres), in
/// time order.
pub fn body_distance(frames: &[Frame], closest: Option<&Closest>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = frames
        .iter()
        .map(|f| (f.time, vehicle::distance(&f.ego, &f.intruder)))
        .collect();
    if let Some(c) = closest {
        let k = out.partition_point(|(t, _)| *t < c.time);
        match out.get_mut(k) {
            Some(p) if p.0 == c.time => p.1 = c.distance,
            _ => out.insert(k, (c.time, c.distance)),
        }
    }
    out
}

/// Every step on `sim_time`: poses, the time series, the planner's prediction, the perceived
/// obstacle.
fn log_frames(
    rec: &RecordingStream,
    run: RunSide,
    frames: &[Frame],
    closest: Option<&Closest>,
) -> Result<(), RecordError> {
    let base = run.path();
    for (t, d) in body_distance(frames, closest) {
        rec.set_duration_secs("sim_time", t);
        rec.log(format!("plots/distance/{base}"), &rerun::Scalars::single(d))
            .map_err(err)?;
        if run == RunSide::Hf {
            rec.log("plots/distance/collision", &rerun::Scalars::single(0.0))
                .map_err(err)?;
        }
    }
    for f in frames {
        rec.set_duration_secs("sim_time", f.time);
        rec.log(format!("{base}/ego"), &pose(&f.ego)).map_err(err)?;
        rec.log(format!("{base}/intruder"), &pose(&f.intruder))
            .map_err(err)?;
        rec.log(
            format!("plots/speed/{base}"),
            &rerun::Scalars::single(f.ego.speed),
        )
        .map_err(err)?;
        rec.log(
            format!("plots/braking/{base}"),
            &rerun::Scalars::single(f64::from(u8::from(f.braking))),
        )
        .map_err(err)?;
        log_prediction(rec, base, f)?;
        match f.measured {
            Some(m) => rec.log(
                format!("{base}/measured"),
                &rerun::Points3D::new([(m.x as f32, m.y as f32, 1.0f32)])
                    .with_radii([0.4f32])
                    .with_colors([rerun::Color::from_rgb(40, 200, 40)]),
            ),
            None => rec.log(format!("{base}/measured"), &rerun::Clear::flat()),
        }
        .map_err(err)?;
    }
    let track = |pick: fn(&Frame) -> &VehicleState| -> Vec<(f32, f32, f32)> {
        frames
            .iter()
            .map(|f| {
                let c = pick(f).center();
                (c.x as f32, c.y as f32, 0.1)
            })
            .collect()
    };
    let [ego_colour, intruder_colour] = colour(run);
    for (name, pts, c) in [
        ("ego_trajectory", track(|f| &f.ego), ego_colour),
        (
            "intruder_trajectory",
            track(|f| &f.intruder),
            intruder_colour,
        ),
    ] {
        rec.log_static(
            format!("{base}/{name}"),
            &rerun::LineStrips3D::new([pts]).with_colors([c]),
        )
        .map_err(err)?;
    }
    Ok(())
}

/// The planner's predicted closest approach at this frame, or a clear when it has none.
fn log_prediction(rec: &RecordingStream, base: &str, f: &Frame) -> Result<(), RecordError> {
    let path = format!("{base}/predicted_closest_approach");
    match f.predicted {
        Some(pr) => rec
            .log(
                path,
                &rerun::LineStrips3D::new([[
                    (pr.ego.x as f32, pr.ego.y as f32, 1.2f32),
                    (pr.obstacle.x as f32, pr.obstacle.y as f32, 1.2),
                ]])
                .with_colors([prediction_colour()]),
            )
            .and_then(|()| {
                caption(
                    rec,
                    base,
                    "prediction",
                    PREDICTION_CAPTION,
                    prediction_colour(),
                    format!(
                        "predicted clearance {:.1} m in {:.1} s",
                        pr.clearance,
                        pr.time - f.time
                    ),
                )
            }),
        None => rec
            .log(path, &rerun::Clear::flat())
            .and_then(|()| rec.log(caption_path(base, "prediction"), &rerun::Clear::flat())),
    }
    .map_err(err)
}

/// Where a caption hangs in the ego's frame (x forward, z up): on the road behind the ego, so
/// that from the 3D view's chase eye (behind and above the ego, see `super::layout`) its text
/// shows below the ego and never over the other vehicle or the gap between them, wherever
/// that vehicle is. The viewer draws a label below its anchor.
pub const CLOSEST_CAPTION: [f32; 3] = [-4.0, 0.0, 0.0];
/// The planner's prediction's caption, below the closest approach's.
pub const PREDICTION_CAPTION: [f32; 3] = [-7.5, 0.0, 0.0];
/// The planner's prediction's colour.
fn prediction_colour() -> rerun::Color {
    rerun::Color::from_rgb(255, 0, 255)
}

/// The entity of a run's caption `name`, in the ego's frame.
fn caption_path(base: &str, name: &str) -> String {
    format!("{base}/ego/captions/{name}")
}

/// A caption: `text` in `colour`, hanging from an invisible point at `at` in the ego's frame.
fn caption(
    rec: &RecordingStream,
    base: &str,
    name: &str,
    at: [f32; 3],
    colour: rerun::Color,
    text: String,
) -> rerun::RecordingStreamResult<()> {
    rec.log(
        caption_path(base, name),
        &rerun::Points3D::new([at])
            .with_radii([0.0f32])
            .with_colors([colour])
            .with_labels([text])
            .with_show_labels(true),
    )
}

/// The collision, or else the closest approach: a line in 3D between the bodies where they
/// were nearest, a caption under the ego (see [`CLOSEST_CAPTION`]) and a warning in the
/// events.
fn log_closest_approach(
    rec: &RecordingStream,
    run: RunSide,
    r: &RunResult,
) -> Result<(), RecordError> {
    let base = run.path();
    let Some(c) = r.closest.as_ref() else {
        return Ok(());
    };
    let (text, label, marker) = match r.collision_time {
        Some(t) => (
            format!("{}: collision at {t:.2} s", run.label()),
            format!("collision at {t:.2} s"),
            rerun::Color::from_rgb(255, 30, 30),
        ),
        None => (
            format!(
                "{}: passes, closest approach {:.2} m at {:.2} s",
                run.label(),
                r.min_distance,
                c.time
            ),
            format!("closest {:.2} m", r.min_distance),
            rerun::Color::from_rgb(250, 220, 0),
        ),
    };
    rec.set_duration_secs("sim_time", c.time);
    let (a, b) = (c.ego.center(), c.intruder.center());
    rec.log(
        format!("{base}/closest_approach"),
        &rerun::LineStrips3D::new([[
            (a.x as f32, a.y as f32, 1.6f32),
            (b.x as f32, b.y as f32, 1.6),
        ]])
        .with_colors([marker])
        .with_radii([0.12f32]),
    )
    .map_err(err)?;
    caption(
        rec,
        base,
        "closest_approach",
        CLOSEST_CAPTION,
        marker,
        label,
    )
    .map_err(err)?;
    rec.log(
        format!("{base}/events"),
        &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::WARN),
    )
    .map_err(err)
}

/// The ego state at `time` (the frame at or just before it).
fn ego_at(frames: &[Frame], time: f64) -> Option<&VehicleState> {
    let k = frames.partition_point(|f| f.time <= time + 1e-9);
    frames.get(k.checked_sub(1)?).map(|f| &f.ego)
}

/// A colour map from near (red) over yellow and green to far (blue).
fn range_colour(range: f32) -> rerun::Color {
    let (lo, hi) = RANGE_COLOURS;
    let t = ((range - lo) / (hi - lo)).clamp(0.0, 1.0);
    // Piecewise-linear through red, yellow, green, cyan, blue.
    let stops = [
        [230.0, 40.0, 40.0],
        [240.0, 220.0, 40.0],
        [60.0, 200.0, 60.0],
        [40.0, 200.0, 220.0],
        [50.0, 70.0, 230.0],
    ];
    let x = t * (stops.len() - 1) as f32;
    let k = (x.floor() as usize).min(stops.len() - 2);
    let u = x - k as f32;
    let c = |i: usize| (stops[k][i] * (1.0 - u) + stops[k + 1][i] * u) as u8;
    rerun::Color::from_rgb(c(0), c(1), c(2))
}

/// The camera image (JPEG), the detector's box with its class label (cleared when it detected
/// nothing), and the lidar cloud coloured by range.
fn log_sensors(
    rec: &RecordingStream,
    run: RunSide,
    sf: &SensorFrame,
    ego: Option<&VehicleState>,
) -> Result<(), RecordError> {
    let base = run.path();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, JPEG_QUALITY)
        .encode(
            &sf.image.to_rgb8(),
            WIDTH as u32,
            HEIGHT as u32,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(err)?;
    rec.log(
        format!("{base}/ego/camera/image"),
        &rerun::EncodedImage::from_file_contents(jpeg).with_media_type(rerun::MediaType::JPEG),
    )
    .map_err(err)?;
    let detection = format!("{base}/ego/camera/detection");
    match &sf.detection {
        Some(bb) => rec.log(
            detection,
            &rerun::Boxes2D::from_mins_and_sizes(
                [(bb.u0 as f32, bb.v0 as f32)],
                [((bb.u1 - bb.u0) as f32, (bb.v1 - bb.v0) as f32)],
            )
            .with_labels(["vehicle"])
            .with_colors([rerun::Color::from_rgb(0, 255, 120)]),
        ),
        None => rec.log(detection, &rerun::Clear::flat()),
    }
    .map_err(err)?;
    let origin = ego.map(|e| {
        let c = e.center() + e.direction() * LIDAR_MOUNT.0;
        (c.x as f32, c.y as f32, LIDAR_MOUNT.1)
    });
    let pts: Vec<(f32, f32, f32)> = sf
        .cloud
        .iter()
        .map(|p| (p.position.x, p.position.y, p.position.z))
        .collect();
    let colours: Vec<rerun::Color> = sf
        .cloud
        .iter()
        .map(|p| {
            range_colour(origin.map_or(RANGE_COLOURS.1, |(x, y, z)| {
                let d = [p.position.x - x, p.position.y - y, p.position.z - z];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            }))
        })
        .collect();
    rec.log(
        format!("{base}/lidar"),
        &rerun::Points3D::new(pts)
            .with_colors(colours)
            .with_radii([0.08f32]),
    )
    .map_err(err)
}

impl TrialFrames for DrivingFrames {
    fn layout(&self, paired: bool) -> (&'static str, Layout) {
        (super::trial::app(paired), layout::trial(paired))
    }

    fn record_scene(&mut self, rec: &RecordingStream, scenario: &str) -> Result<bool, RecordError> {
        match scenario::find(scenario) {
            Some(info) => log_scenery(rec, info).map(|()| true),
            None => Ok(false),
        }
    }

    fn record_run(
        &mut self,
        rec: &RecordingStream,
        run: RunSide,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<Option<RunSummary>, RecordError> {
        let Some(info) = scenario::find(scenario) else {
            return Ok(None);
        };
        let r = self.sim.run(info.name, phi, theta, true).map_err(err)?;
        let camera = self.sim.perception == PerceptionMode::Sensors;
        log_static_parts(rec, run, info, phi, camera)?;
        let frames: &[Frame] = r.trajectory.as_deref().unwrap_or(&[]);
        log_frames(rec, run, frames, r.closest.as_ref())?;
        for sf in r.sensor_frames.as_deref().unwrap_or(&[]) {
            rec.set_duration_secs("sim_time", sf.time);
            log_sensors(rec, run, sf, ego_at(frames, sf.time))?;
        }
        log_closest_approach(rec, run, &r)?;
        let summary = RunSummary {
            failure: r.failure,
            collision_time: r.collision_time,
            min_distance: r.min_distance,
            steps: r.steps,
            wall_seconds: r.wall_seconds,
            work: Some(r.work),
        };
        self.last = Some(r);
        Ok(Some(summary))
    }
}
