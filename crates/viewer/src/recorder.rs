//! The recording to the rerun viewer (cargo feature `rerun`): a campaign [`Observer`] that
//! writes one *campaign recording* (its own blueprint: found failures over runtime per stage,
//! fidelity success rate and cost ratio, the posterior grids — see `campaign`) and, for a
//! bounded choice of trials, one *trial recording* each, in the same file or viewer, named by
//! stage, trial, scenario and outcome (the trial view — see `trial`).
//!
//! Which trials get frames: every `every`-th told trial as it is told, and — when the campaign
//! ends — up to `failure_cap` of the informative ones: FN and FP of the learning and evaluation
//! stages first (alternately, in campaign order), then TP, and HF failures of the baselines
//! (which have no LF run) only while no other remains. Frames are re-runs of the same
//! deterministic runs with recording on.

use super::campaign::CampaignView;
use super::layout::{self, Layout};
use super::trial::{self, TrialRecording};
use rerun::RecordingStream;
use savme_campaign::log::{ScreenLine, TrialLine};
use savme_campaign::{CampaignError, Observer, Problem, Protocol, Stage};
use savme_kernel::{Assignment, Kernel, Outcome};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// The application id of campaign recordings (the viewer keeps one layout per application).
pub const CAMPAIGN_APP: &str = "savme-campaign";

/// Which run of a trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunSide {
    /// The high-fidelity run.
    Hf,
    /// The low-fidelity run.
    Lf,
}

impl RunSide {
    /// Its entity path root, `hf` or `lf`.
    pub fn path(self) -> &'static str {
        match self {
            RunSide::Hf => "hf",
            RunSide::Lf => "lf",
        }
    }

    /// `HF` or `LF`.
    pub fn label(self) -> &'static str {
        match self {
            RunSide::Hf => "HF",
            RunSide::Lf => "LF",
        }
    }
}

/// What happened in a recorded run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    /// The system under test failed.
    pub failure: bool,
    /// When it collided, seconds.
    pub collision_time: Option<f64>,
    /// Smallest distance between the bodies, metres.
    pub min_distance: f64,
    /// Simulation steps.
    pub steps: u64,
    /// Wall-clock seconds of this (recording) run.
    pub wall_seconds: f64,
    /// Work units, if counted.
    pub work: Option<u64>,
}

/// A simulator that can show a run in the viewer: it runs it (deterministically, as the
/// campaign ran it) with recording on and logs its frames under `/hf` or `/lf` of the trial
/// recording `rec`. The bundled driving simulator implements it ([`super::DrivingFrames`]: the
/// trial view), and an FMU campaign's simulator when its file lists outputs to record
/// ([`super::FmuFrames`]: one plot per output); without frames a campaign gets its campaign
/// view only.
pub trait TrialFrames: Send {
    /// The application id and layout of its trial recordings (`paired`: with an LF run).
    fn layout(&self, paired: bool) -> (&'static str, Layout);

    /// Logs the static scene of `scenario` (false when this simulator has no frames for it).
    fn record_scene(&mut self, rec: &RecordingStream, scenario: &str) -> Result<bool, RecordError>;

    /// Runs and logs one run; None when this simulator has no frames for `scenario`.
    fn record_run(
        &mut self,
        rec: &RecordingStream,
        run: RunSide,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<Option<RunSummary>, RecordError>;
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
    /// Frames for every `every`-th told trial (counted over the whole campaign; 0: none).
    pub every: u64,
    /// … plus up to this many informative trials (FN/FP first, then TP, then baseline failures).
    pub failure_cap: u64,
}

impl RecordOptions {
    /// To `sink`, frames for every 200th trial and up to 10 informative ones.
    pub fn new(sink: Sink) -> Self {
        RecordOptions {
            sink,
            every: 200,
            failure_cap: 10,
        }
    }
}

/// Why recording failed (the message says what; callers add no prefix of their own).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RecordError(pub(crate) String);

pub(crate) fn err(e: impl std::fmt::Display) -> RecordError {
    RecordError(e.to_string())
}

/// The default `--connect` address.
const DEFAULT_URL: &str = "rerun+http://127.0.0.1:9876/proxy";

/// Checks that a viewer listens at `url` before anything is logged (the SDK would otherwise
/// block on a full queue, or drop the data, with no viewer there).
fn probe(url: &str) -> Result<(), RecordError> {
    use std::str::FromStr as _;
    let bad = |e: &dyn std::fmt::Display| RecordError(format!("--connect {url}: {e}"));
    let uri = rerun::external::re_uri::ProxyUri::from_str(url).map_err(|e| bad(&e))?;
    let host = uri.origin.format_host();
    let host = host.trim_start_matches('[').trim_end_matches(']');
    let addrs: Vec<std::net::SocketAddr> =
        std::net::ToSocketAddrs::to_socket_addrs(&(host, uri.origin.port))
            .map_err(|e| bad(&e))?
            .collect();
    let timeout = std::time::Duration::from_secs(3);
    let mut last = None;
    for a in &addrs {
        match std::net::TcpStream::connect_timeout(a, timeout) {
            Ok(_) => return Ok(()),
            Err(e) => last = Some(e),
        }
    }
    Err(RecordError(format!(
        "--connect {url}: no rerun viewer is listening at {host}:{} ({}); start one with `rerun`, or give its address",
        uri.origin.port,
        last.map_or_else(|| "no address".to_string(), |e| e.to_string())
    )))
}

/// Opens `sink` as a recording of application `app` named `name`, laid out by `layout`.
pub fn open(
    sink: &Sink,
    app: &'static str,
    name: &str,
    layout: Layout,
) -> Result<RecordingStream, RecordError> {
    let builder = rerun::RecordingStreamBuilder::new(app).recording_name(name);
    let rec = match sink {
        Sink::File(path) => builder
            .save(path)
            .map_err(|e| RecordError(format!("{}: {e}", path.display())))?,
        Sink::Spawn => builder.spawn().map_err(err)?,
        Sink::Connect(url) => {
            let url = url.as_deref().unwrap_or(DEFAULT_URL);
            probe(url)?;
            builder
                .connect_grpc_opts(url.to_string())
                .map_err(|e| RecordError(format!("--connect {url}: {e}")))?
        }
    };
    quiet_clocks(&rec);
    layout.send(&rec)?;
    // Ctrl-C: flush and close the sink (the file gets its footer), then exit like SIGINT.
    let on_interrupt = rec.clone();
    let _ = ctrlc::set_handler(move || {
        let _ = on_interrupt.flush_blocking();
        on_interrupt.disconnect();
        std::process::exit(130);
    });
    Ok(rec)
}

/// Our timelines only: no wall-clock `log_time` or `log_tick` on the data.
pub(crate) fn quiet_clocks(rec: &RecordingStream) {
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
}

/// Flushes and closes a recording; a sink that could not deliver (within a minute, for a
/// viewer) is an error naming it.
pub fn close(rec: &RecordingStream, sink: &Sink) -> Result<(), RecordError> {
    let flushed = rec.flush_with_timeout(std::time::Duration::from_secs(60));
    rec.disconnect();
    flushed.map_err(|e| match sink {
        Sink::File(p) => RecordError(format!("{}: {e}", p.display())),
        Sink::Spawn => RecordError(format!("the spawned viewer: {e}")),
        Sink::Connect(url) => RecordError(format!(
            "--connect {}: {e}",
            url.as_deref().unwrap_or(DEFAULT_URL)
        )),
    })
}

/// How informative a trial's frames are: lower goes first.
fn priority(line: &TrialLine) -> Option<u8> {
    match line.outcome {
        Some(Outcome::FN) | Some(Outcome::FP) => Some(0),
        Some(Outcome::TP) => Some(1),
        None if line.hf.failure => Some(2),
        _ => None,
    }
}

/// The informative trials kept for frames, bounded per class.
#[derive(Debug, Default)]
struct Candidates {
    fn_: Vec<(u64, TrialLine)>,
    fp: Vec<(u64, TrialLine)>,
    tp: Vec<(u64, TrialLine)>,
    baseline: Vec<(u64, TrialLine)>,
}

impl Candidates {
    fn offer(&mut self, n: u64, line: &TrialLine, cap: usize) {
        let list = match (priority(line), line.outcome) {
            (Some(0), Some(Outcome::FN)) => &mut self.fn_,
            (Some(0), _) => &mut self.fp,
            (Some(1), _) => &mut self.tp,
            (Some(2), _) => &mut self.baseline,
            _ => return,
        };
        if list.len() < cap {
            list.push((n, line.clone()));
        }
    }

    /// Up to `cap` trials not in `done`: FN and FP alternately, then TP, then baselines.
    fn choose(self, cap: usize, done: &BTreeSet<u64>) -> Vec<(u64, TrialLine)> {
        let fresh = |v: Vec<(u64, TrialLine)>| -> Vec<(u64, TrialLine)> {
            v.into_iter().filter(|(n, _)| !done.contains(n)).collect()
        };
        let (mut fns, mut fps) = (fresh(self.fn_).into_iter(), fresh(self.fp).into_iter());
        let mut out = Vec::new();
        loop {
            let (a, b) = (fns.next(), fps.next());
            if a.is_none() && b.is_none() {
                break;
            }
            out.extend(a);
            out.extend(b);
        }
        out.extend(fresh(self.tp));
        out.extend(fresh(self.baseline));
        out.truncate(cap);
        out
    }
}

/// A campaign's recording in progress. Close it with [`Observer::finish`] (also done on drop,
/// and by the Ctrl-C handler), so the file always gets its footer.
pub struct Recorder {
    rec: RecordingStream,
    opts: RecordOptions,
    told: u64,
    recorded: BTreeSet<u64>,
    names: Vec<String>,
    candidates: Candidates,
    frames: Option<Box<dyn TrialFrames>>,
    problem: Problem,
    view: CampaignView,
    finished: bool,
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
    /// Opens the sink with the campaign view. `frames` re-runs the trials that get frames.
    pub fn start(
        opts: RecordOptions,
        frames: Option<Box<dyn TrialFrames>>,
        protocol: &Protocol,
        problem: Problem,
    ) -> Result<Recorder, RecordError> {
        let rec = open(
            &opts.sink,
            CAMPAIGN_APP,
            &format!("campaign (seed {})", protocol.seed),
            layout::campaign(&CampaignView::learning_labels(protocol)),
        )?;
        Ok(Recorder {
            rec,
            opts,
            told: 0,
            recorded: BTreeSet::new(),
            names: Vec::new(),
            candidates: Candidates::default(),
            frames,
            view: CampaignView::new(&problem),
            problem,
            finished: false,
        })
    }

    /// The campaign recording's stream.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// Trials (by campaign-wide told index) that got frames.
    pub fn recorded_trials(&self) -> &BTreeSet<u64> {
        &self.recorded
    }

    /// Records one trial as its own recording (in the same sink), named by stage, trial,
    /// scenario and outcome.
    pub fn record_trial(&mut self, n: u64, line: &TrialLine) -> Result<(), RecordError> {
        let Some(frames) = self.frames.as_mut() else {
            return Ok(());
        };
        let name = trial::name(line);
        let t =
            TrialRecording::forwarded(&self.rec, &name, frames.layout(line.theta_lf.is_some()))?;
        let runs = t.record(
            frames.as_mut(),
            &line.scenario,
            &line.phi,
            &self.problem.theta_hf,
            line.theta_lf.as_ref(),
        )?;
        if runs.is_some() {
            t.outcome(&trial::campaign_markdown(line, &self.problem.theta_hf))?;
            self.recorded.insert(n);
            self.names.push(name);
        }
        t.close()
    }

    fn observer_finish(&mut self) -> Result<(), CampaignError> {
        if self.finished {
            return Ok(());
        }
        self.finished = true;
        let chosen = std::mem::take(&mut self.candidates)
            .choose(self.opts.failure_cap as usize, &self.recorded);
        for (n, line) in chosen {
            if let Err(e) = self.record_trial(n, &line) {
                eprintln!(
                    "savme: recording trial {} of {}: {e}",
                    line.index, line.stage
                );
            }
        }
        let summary = self.view.summary_markdown(&self.names, &self.opts);
        let _ = self.rec.log_static(
            "campaign/summary",
            &rerun::TextDocument::from_markdown(summary),
        );
        close(&self.rec, &self.opts.sink).map_err(|e| CampaignError::Recording(e.0))
    }
}

impl Observer for Recorder {
    fn finish(&mut self) -> Result<(), CampaignError> {
        self.observer_finish()
    }

    fn screened(&mut self, stage: &Stage, line: &ScreenLine, _: &Kernel) {
        // On the campaign's curves only: a screening trial is not a paired trial to replay.
        let n = self.told;
        self.told += 1;
        if let Err(e) = self.view.screened(&self.rec, n, stage, line) {
            eprintln!("savme: recording: {e}");
        }
    }

    fn trial(&mut self, stage: &Stage, line: &TrialLine, kernel: &Kernel) {
        let n = self.told;
        self.told += 1;
        if let Err(e) = self.view.trial(&self.rec, n, stage, line, kernel) {
            eprintln!("savme: recording: {e}");
        }
        if self.opts.every > 0 && n.is_multiple_of(self.opts.every) {
            if let Err(e) = self.record_trial(n, line) {
                eprintln!(
                    "savme: recording trial {} of {}: {e}",
                    line.index, line.stage
                );
            }
        } else {
            self.candidates
                .offer(n, line, self.opts.failure_cap as usize);
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
