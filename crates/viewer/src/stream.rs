//! The recording stream and what the views share (cargo feature `rerun`): where a recording
//! goes ([`Sink`]) and how it opens and closes, which run of a trial a frame belongs to
//! ([`RunSide`], [`RunSummary`]), what a simulator implements to offer frames
//! ([`TrialFrames`]), and [`RecordError`]. The views (`campaign`, `trial`, `layout`, the
//! frames of `driving` and `fmu`) and the `recorder` build on it; it imports none of them.

pub(crate) use super::error::{err, RecordError};
use super::layout::Layout;
use rerun::external::re_log_types::BlueprintActivationCommand;
use rerun::RecordingStream;
use savme_kernel::Assignment;
use std::path::PathBuf;

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
/// ([`super::SeriesFrames`]: one plot per output); without frames a campaign gets its campaign
/// view only.
///
/// It is the seam through which any simulator shows its runs: implement it in the simulator's
/// own crate (nothing in this crate lists simulators) and hand it to a recording with
/// [`super::Frames::new`]. For example, a simulator whose run is a closing gap, shown as one
/// plot of the gap over time in its own layout:
///
/// ```
/// use savme_kernel::Assignment;
/// use savme_viewer::layout::Layout;
/// use savme_viewer::rerun::{self, blueprint, RecordingStream};
/// use savme_viewer::{Frames, RecordError, RunSide, RunSummary, TrialFrames};
///
/// struct GapFrames;
///
/// impl TrialFrames for GapFrames {
///     fn layout(&self, _paired: bool) -> (&'static str, Layout) {
///         let plot = blueprint::TimeSeriesView::new("Gap (m): HF and LF").with_origin("/gap");
///         ("gap-trial", Layout::new(blueprint::Blueprint::new(plot)))
///     }
///     fn record_scene(&mut self, _: &RecordingStream, _: &str) -> Result<bool, RecordError> {
///         Ok(true)
///     }
///     fn record_run(
///         &mut self,
///         rec: &RecordingStream,
///         run: RunSide,
///         _scenario: &str,
///         phi: &Assignment,
///         _theta: &Assignment,
///     ) -> Result<Option<RunSummary>, RecordError> {
///         let gap0 = phi.get_f64("gap").ok_or_else(|| RecordError::new("φ has no `gap`"))?;
///         let gaps: Vec<f64> = (0..=10).map(|k| gap0 - f64::from(k)).collect();
///         let times = (0..=10).map(|k| f64::from(k) * 0.1);
///         rec.send_columns(
///             format!("gap/{}", run.path()),
///             [rerun::TimeColumn::new_duration_secs("sim_time", times)],
///             rerun::Scalars::new(gaps.iter().copied())
///                 .columns_of_unit_batches()
///                 .map_err(|e| RecordError::new(e.to_string()))?,
///         )
///         .map_err(|e| RecordError::new(e.to_string()))?;
///         let min = gaps.iter().copied().fold(f64::INFINITY, f64::min);
///         Ok(Some(RunSummary {
///             failure: min <= 0.0,
///             collision_time: None,
///             min_distance: min,
///             steps: 10,
///             wall_seconds: 0.0,
///             work: Some(10),
///         }))
///     }
/// }
///
/// let frames = Frames::new(GapFrames); // for `savme_viewer::start`
/// assert!(!frames.is_none());
/// ```
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

/// Opens `sink` as a recording of application `app` named `name`, laid out by `layout`;
/// returns the stream and its blueprint's activation (see `super::layout::activate`).
pub fn open(
    sink: &Sink,
    app: &str,
    name: &str,
    layout: Layout,
) -> Result<(RecordingStream, BlueprintActivationCommand), RecordError> {
    let app = rerun::external::re_log_types::ApplicationId::try_new(app)
        .map_err(|e| RecordError(format!("application id `{app}`: {e}")))?;
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
    let activation = layout.send(&rec)?;
    // Ctrl-C: flush and close the sink (the file gets its footer), then exit like SIGINT.
    let on_interrupt = rec.clone();
    let _ = ctrlc::set_handler(move || {
        let _ = on_interrupt.flush_blocking();
        on_interrupt.disconnect();
        std::process::exit(130);
    });
    Ok((rec, activation))
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
