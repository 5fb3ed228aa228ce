//! Recording to the rerun viewer (cargo feature `rerun`): trials of the bundled simulator — the
//! scene, both vehicles on a `sim_time` timeline with their trajectories, the camera image with
//! the detector's box, the lidar cloud coloured by intensity, the planner's predicted closest
//! approach, the actual closest approach and the outcome, HF and LF side by side — and the campaign's learning on a `trial` timeline: found
//! failures per stage, C_budget, and the posterior mean of every fidelity arm and of every
//! scenario parameter's bins.
//!
//! Which trials carry sensor frames is bounded: every `every`-th told trial, plus HF failures up
//! to `failure_cap` — a full default campaign stays well under 500 MB (docs/BENCHMARKS.md).

use crate::campaign::log::TrialLine;
use crate::campaign::{Observer, Stage};
use rerun::RecordingStream;
use savme_kernel::{Assignment, Kernel, Posterior};
use savme_sim::scenario;
use savme_sim::sim::{DrivingSimulator, Frame, RunResult};
use savme_sim::world::{ObjectShape, World};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

/// Where the recording goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Sink {
    /// An `.rrd` file.
    File(PathBuf),
    /// A viewer started for it (`rerun` on the PATH).
    Spawn,
    /// A running viewer (its gRPC URL, or the default `rerun+http://127.0.0.1:9876/proxy`).
    Connect(Option<String>),
}

/// What to record.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordOptions {
    /// Where to.
    pub sink: Sink,
    /// Sensor frames for every `every`-th told trial (counted over the whole campaign).
    pub every: u64,
    /// … plus the trials whose HF run failed, up to this many.
    pub failure_cap: u64,
}

impl RecordOptions {
    /// To `sink`, frames for every 200th trial and up to 10 failures.
    pub fn new(sink: Sink) -> Self {
        RecordOptions {
            sink,
            every: 200,
            failure_cap: 10,
        }
    }
}

/// Why recording failed.
#[derive(Debug, thiserror::Error)]
#[error("recording: {0}")]
pub struct RecordError(String);

fn err(e: impl std::fmt::Display) -> RecordError {
    RecordError(e.to_string())
}

/// A recording in progress. Close it with [`Recorder::finish`] (also done on drop, and by the
/// Ctrl-C handler installed by [`Recorder::start`]), so the file always gets its footer.
pub struct Recorder {
    rec: RecordingStream,
    opts: RecordOptions,
    told: u64,
    failures_recorded: u64,
    recorded: BTreeSet<u64>,
    found: BTreeMap<String, u64>,
    sim: DrivingSimulator,
    theta_hf: Assignment,
    layouts_logged: BTreeSet<String>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("opts", &self.opts)
            .field("told", &self.told)
            .finish()
    }
}

impl Recorder {
    /// Opens the sink. `sim` re-runs the trials that get sensor frames (the same deterministic
    /// runs as the campaign's, with recording on).
    pub fn start(
        opts: RecordOptions,
        sim: DrivingSimulator,
        theta_hf: Assignment,
    ) -> Result<Recorder, RecordError> {
        let builder = rerun::RecordingStreamBuilder::new("savme");
        let rec = match &opts.sink {
            Sink::File(path) => builder.save(path).map_err(err)?,
            Sink::Spawn => builder.spawn().map_err(err)?,
            Sink::Connect(None) => builder.connect_grpc().map_err(err)?,
            Sink::Connect(Some(url)) => builder.connect_grpc_opts(url.clone()).map_err(err)?,
        };
        // Ctrl-C: flush and close the sink (the file gets its footer), then exit like SIGINT.
        let on_interrupt = rec.clone();
        let _ = ctrlc::set_handler(move || {
            let _ = on_interrupt.flush_blocking();
            on_interrupt.disconnect();
            std::process::exit(130);
        });
        Ok(Recorder {
            rec,
            opts,
            told: 0,
            failures_recorded: 0,
            recorded: BTreeSet::new(),
            found: BTreeMap::new(),
            sim,
            theta_hf,
            layouts_logged: BTreeSet::new(),
        })
    }

    /// The underlying stream.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// Trials (by campaign-wide told index) that got sensor frames.
    pub fn recorded_trials(&self) -> &BTreeSet<u64> {
        &self.recorded
    }

    /// Whether the `told`-th trial gets frames: every `every`-th, and failures up to the cap.
    fn wants_frames(&mut self, told: u64, hf_failure: bool) -> bool {
        if self.opts.every > 0 && told % self.opts.every == 0 {
            return true;
        }
        if hf_failure && self.failures_recorded < self.opts.failure_cap {
            self.failures_recorded += 1;
            return true;
        }
        false
    }

    /// Flushes and closes the recording.
    pub fn finish(self) -> Result<(), RecordError> {
        self.rec.flush_blocking().map_err(err)?;
        self.rec.disconnect();
        Ok(())
    }

    fn log_scenery(&mut self, scenario_name: &str) -> Result<(), RecordError> {
        let Some(info) = scenario::find(scenario_name) else {
            return Ok(());
        };
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
        self.rec
            .log_static(
                format!("world/{key}/scenery"),
                &rerun::Boxes3D::from_centers_and_half_sizes(centres, halves)
                    .with_quaternions(rotations)
                    .with_colors([rerun::Color::from_rgb(150, 150, 150)]),
            )
            .map_err(err)
    }

    fn log_run(
        &self,
        base: &str,
        info: &'static scenario::ScenarioInfo,
        phi: &Assignment,
        r: &RunResult,
    ) -> Result<(), RecordError> {
        let rec = &self.rec;
        // The planned paths.
        if let Ok(setup) = scenario::setup(info, phi) {
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
                    &rerun::LineStrips3D::new([pts])
                        .with_colors([rerun::Color::from_rgb(90, 90, 200)]),
                )
                .map_err(err)?;
            }
        }
        let frames: &[Frame] = r.trajectory.as_deref().unwrap_or(&[]);
        let body = savme_sim::vehicle::body().half_extents;
        let mut ego_track = Vec::new();
        let mut intruder_track = Vec::new();
        for f in frames {
            rec.set_duration_secs("sim_time", f.time);
            for (name, v, colour, track) in [
                (
                    "ego",
                    &f.ego,
                    rerun::Color::from_rgb(220, 40, 40),
                    &mut ego_track,
                ),
                (
                    "intruder",
                    &f.intruder,
                    rerun::Color::from_rgb(230, 110, 20),
                    &mut intruder_track,
                ),
            ] {
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
                .map_err(err)?;
            }
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
                .map_err(err)?;
            } else {
                rec.log(
                    format!("{base}/predicted_closest_approach"),
                    &rerun::Clear::flat(),
                )
                .map_err(err)?;
            }
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
        // The closest approach: the two centres where the bodies came closest.
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
                .with_labels([format!("min body distance {:.2} m", r.min_distance)]),
            )
            .map_err(err)?;
        }
        for sf in r.sensor_frames.as_deref().unwrap_or(&[]) {
            rec.set_duration_secs("sim_time", sf.time);
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
                    .map_err(err)?,
                None => rec
                    .log(format!("{base}/camera/detection"), &rerun::Clear::flat())
                    .map_err(err)?,
            }
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
            .map_err(err)?;
        }
        Ok(())
    }

    /// Records one trial of the bundled simulator with its sensor frames (re-run with recording
    /// on): HF and LF under `trials/<n>/hf` and `trials/<n>/lf`.
    pub fn record_trial(&mut self, n: u64, line: &TrialLine) -> Result<(), RecordError> {
        let Some(info) = scenario::find(&line.scenario) else {
            return Ok(());
        };
        self.log_scenery(&line.scenario)?;
        self.rec.set_time_sequence("trial", n as i64);
        let base = format!("trials/{n}");
        let hf = self
            .sim
            .run(&line.scenario, &line.phi, &self.theta_hf, true)
            .map_err(err)?;
        self.log_run(&format!("{base}/hf"), info, &line.phi, &hf)?;
        if let Some(theta) = &line.theta_lf {
            let lf = self
                .sim
                .run(&line.scenario, &line.phi, theta, true)
                .map_err(err)?;
            self.log_run(&format!("{base}/lf"), info, &line.phi, &lf)?;
        }
        self.rec.set_time_sequence("trial", n as i64);
        let outcome = match (line.outcome, line.lf) {
            (Some(o), _) => format!("{o:?}"),
            (None, _) if line.hf.failure => "HF failure (HF only)".into(),
            _ => "HF pass (HF only)".into(),
        };
        self.rec
            .log(
                format!("{base}/outcome"),
                &rerun::TextLog::new(format!(
                    "{} {} — {outcome}; {}",
                    line.stage,
                    line.scenario,
                    hf.collision_time
                        .map_or("no collision".to_string(), |t| format!(
                            "HF collision at {t:.2} s"
                        ))
                )),
            )
            .map_err(err)?;
        self.recorded.insert(n);
        Ok(())
    }

    /// Records one run of the bundled simulator (`savme simulate --record`) under `run/`.
    pub fn record_run(
        &mut self,
        scenario_name: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<RunResult, RecordError> {
        let info = scenario::find(scenario_name)
            .ok_or_else(|| RecordError(format!("unknown scenario `{scenario_name}`")))?;
        self.log_scenery(info.name)?;
        let r = self.sim.run(info.name, phi, theta, true).map_err(err)?;
        self.log_run("run", info, phi, &r)?;
        self.rec
            .log(
                "run/outcome",
                &rerun::TextLog::new(match r.collision_time {
                    Some(t) => format!("{}: collision at {t:.2} s", info.name),
                    None => format!(
                        "{}: no collision, min distance {:.2} m",
                        info.name, r.min_distance
                    ),
                }),
            )
            .map_err(err)?;
        Ok(r)
    }

    fn posterior_bars(&self, prefix: &str, p: &Posterior) -> Result<(), RecordError> {
        for (name, arms) in p.names().iter().zip(p.arms()) {
            let means: Vec<f64> = arms.iter().map(|a| a.mean()).collect();
            self.rec
                .log(format!("{prefix}/{name}"), &rerun::BarChart::new(means))
                .map_err(err)?;
        }
        Ok(())
    }
}

/// A stage label as entity-path parts: `train@0.3` → `train/0_3` (rerun escapes `@` and `.`).
pub fn entity_label(label: &str) -> String {
    label.replace('@', "/").replace('.', "_")
}

impl Observer for Recorder {
    fn stage(&mut self, stage: &Stage) {
        self.rec.set_time_sequence("trial", self.told as i64);
        if let Some(b) = stage.budget {
            let _ = self.rec.log("campaign/budget", &rerun::Scalars::single(b));
        }
    }

    fn trial(&mut self, stage: &Stage, line: &TrialLine, kernel: &Kernel) {
        let n = self.told;
        self.told += 1;
        self.rec.set_time_sequence("trial", n as i64);
        let label = entity_label(&stage.label());
        let found = self.found.entry(label.clone()).or_default();
        *found += u64::from(line.hf.failure);
        let found = *found;
        let _ = self.rec.log(
            format!("campaign/found_failures/{label}"),
            &rerun::Scalars::single(found as f64),
        );
        if let Some(b) = stage.budget {
            let _ = self.rec.log("campaign/budget", &rerun::Scalars::single(b));
        }
        // Posteriors every 10 trials of a learning stage (and the first), to keep the file small.
        if stage.phase().learns() && line.index % 10 == 0 {
            let _ = self.posterior_bars(
                &format!("campaign/fidelity/{label}"),
                kernel.fidelity_posterior(),
            );
            if let Some(p) = kernel.scenario_posterior(&line.scenario) {
                let _ = self
                    .posterior_bars(&format!("campaign/scenarios/{label}/{}", line.scenario), p);
            }
        }
        if self.wants_frames(n, line.hf.failure) {
            if let Err(e) = self.record_trial(n, line) {
                eprintln!("savme: {e}");
            }
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
