//! The recording to the rerun viewer (cargo feature `rerun`): a campaign [`Observer`] that
//! logs the learning on a `trial` timeline — found failures per stage, C_budget, the posterior
//! mean of every fidelity arm and of every scenario parameter's bins — and, for a bounded sample
//! of trials, their outcome and (when the simulator offers them through [`TrialFrames`]) the
//! HF and LF runs' frames side by side.
//!
//! Which trials are sampled is bounded: every `every`-th told trial, plus HF failures up to
//! `failure_cap` — a full default campaign stays well under 500 MB (docs/BENCHMARKS.md).

use crate::campaign::log::TrialLine;
use crate::campaign::{CampaignError, Observer, Stage};
use rerun::RecordingStream;
use savme_kernel::{Assignment, Kernel, Posterior};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

/// A simulator that can show a run in the viewer: it re-runs the run (deterministically, as
/// the campaign ran it) with recording on and logs its frames under the entity path `base`.
/// The bundled driving simulator implements it ([`super::DrivingFrames`]); a simulator without
/// frames (an FMU) gets the learning view and the outcomes only.
pub trait TrialFrames: Send {
    /// Logs the run; returns a one-line description of what happened, or None when this
    /// simulator has no frames for `scenario`.
    fn record_run(
        &mut self,
        rec: &RecordingStream,
        base: &str,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<Option<String>, RecordError>;
}

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
pub struct RecordError(pub(crate) String);

pub(crate) fn err(e: impl std::fmt::Display) -> RecordError {
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
    frames: Option<Box<dyn TrialFrames>>,
    theta_hf: Assignment,
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
        frames: Option<Box<dyn TrialFrames>>,
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
            frames,
            theta_hf,
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
        if self.opts.every > 0 && told.is_multiple_of(self.opts.every) {
            return true;
        }
        if hf_failure && self.failures_recorded < self.opts.failure_cap {
            self.failures_recorded += 1;
            return true;
        }
        false
    }

    /// Flushes and closes the recording.
    pub fn close(&self) -> Result<(), RecordError> {
        self.rec.flush_blocking().map_err(err)?;
        self.rec.disconnect();
        Ok(())
    }

    /// Records one trial: its runs' frames (if the simulator offers them) under
    /// `trials/<n>/hf` and `trials/<n>/lf`, and its outcome under `trials/<n>/outcome`.
    pub fn record_trial(&mut self, n: u64, line: &TrialLine) -> Result<(), RecordError> {
        self.rec.set_time_sequence("trial", n as i64);
        let base = format!("trials/{n}");
        let mut hf_run = None;
        if let Some(frames) = &mut self.frames {
            hf_run = frames.record_run(
                &self.rec,
                &format!("{base}/hf"),
                &line.scenario,
                &line.phi,
                &self.theta_hf,
            )?;
            if let Some(theta) = &line.theta_lf {
                frames.record_run(
                    &self.rec,
                    &format!("{base}/lf"),
                    &line.scenario,
                    &line.phi,
                    theta,
                )?;
            }
        }
        self.rec.set_time_sequence("trial", n as i64);
        let outcome = match line.outcome {
            Some(o) => format!("{o:?}"),
            None if line.hf.failure => "HF failure (HF only)".into(),
            None => "HF pass (HF only)".into(),
        };
        let detail = hf_run.map_or(String::new(), |d| format!("; HF run: {d}"));
        self.rec
            .log(
                format!("{base}/outcome"),
                &rerun::TextLog::new(format!(
                    "{} {} {} — {outcome}{detail}",
                    line.stage, line.scenario, line.phi
                )),
            )
            .map_err(err)?;
        self.recorded.insert(n);
        Ok(())
    }

    /// Records one run (`savme simulate --record …`) under `run/`.
    pub fn record_run(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<(), RecordError> {
        let frames = self
            .frames
            .as_mut()
            .ok_or_else(|| RecordError("this simulator has no frames to record".into()))?;
        let what = frames
            .record_run(&self.rec, "run", scenario, phi, theta)?
            .ok_or_else(|| RecordError(format!("unknown scenario `{scenario}`")))?;
        self.rec
            .log(
                "run/outcome",
                &rerun::TextLog::new(format!("{scenario}: {what}")),
            )
            .map_err(err)
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
    fn finish(&mut self) -> Result<(), CampaignError> {
        self.observer_finish()
    }

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
        if stage.phase().learns() && line.index.is_multiple_of(10) {
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

impl Recorder {
    fn observer_finish(&mut self) -> Result<(), CampaignError> {
        self.close()
            .map_err(|e| CampaignError::Recording(e.0.clone()))
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
