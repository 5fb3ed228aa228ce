//! Watching trials and campaigns in the rerun viewer.
//!
//! This module holds what every build has: what the user asked to record ([`RecordRequest`],
//! from `--record FILE.rrd`, `--spawn`, `--connect [URL]`, `--record-every N`,
//! `--record-failures N`), [`start`], which turns it into a campaign observer, and
//! [`record_run`] for `savme simulate` — or, in a build without the `rerun` feature, a clear
//! error instead of an unknown flag. What is logged lives behind the feature:
//!
//! - `recorder`: the campaign observer — one campaign recording, plus one recording per trial
//!   that gets frames (which trials: see there), all in the same file or viewer;
//! - `campaign`: what the campaign recording shows (curves per stage, posterior grids);
//! - `trial`: one trial's recording (HF and LF side by side, the outcome document);
//! - `driving`: the bundled simulator's frames (`TrialFrames` is what a simulator implements
//!   to offer frames);
//! - `series_frames`: a campaign's frames as time series per trial (an FMU campaign's: the
//!   outputs its file lists under `[fmu] record`), from a simulator's [`Rerun`] (`series`, in
//!   every build);
//! - `layout`: the blueprints both recordings open with;
//! - `plan`: what the campaign layout needs before the first trial, and the grids' geometry;
//! - `palette`: the colours every view shares (one per stage kind, HF red, LF blue).

#[cfg(feature = "rerun")]
mod campaign;
#[cfg(feature = "rerun")]
mod driving;
#[cfg(feature = "rerun")]
mod error;
#[cfg(feature = "rerun")]
pub mod layout;
#[cfg(feature = "rerun")]
mod palette;
#[cfg(feature = "rerun")]
mod plan;
#[cfg(feature = "rerun")]
mod recorder;
mod series;
#[cfg(feature = "rerun")]
mod series_frames;
#[cfg(feature = "rerun")]
mod stream;
#[cfg(feature = "rerun")]
mod trial;

#[cfg(feature = "rerun")]
pub use driving::DrivingFrames;
#[cfg(feature = "rerun")]
pub use error::RecordError;
#[cfg(feature = "rerun")]
pub use layout::plot_path;
#[cfg(feature = "rerun")]
pub use palette::{kind_colour, stage_colours};
#[cfg(feature = "rerun")]
pub use plan::entity_label;
#[cfg(feature = "rerun")]
pub use recorder::{campaign_app, is_campaign_app, Recorder, CAMPAIGN_APP};
/// The rerun SDK this crate records with (to read recordings back with the same version).
#[cfg(feature = "rerun")]
pub use rerun;
#[cfg(feature = "rerun")]
pub use series_frames::{leading_sentinels, SeriesFrames, FMU_APP, FMU_HF_APP, SENTINEL};
#[cfg(feature = "rerun")]
pub use stream::{RecordOptions, RunSide, RunSummary, Sink, TrialFrames};
#[cfg(feature = "rerun")]
pub use trial::{HF_APP, PAIRED_APP};

use savme_campaign::{CampaignError, Observer, Problem, Protocol};
use savme_kernel::Assignment;
use savme_sim::sim::{DrivingSimulator, RunResult};
pub use series::{Rerun, Series, Signal};
use std::path::PathBuf;

/// What the user asked to record.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordRequest {
    /// `--record FILE.rrd`.
    pub file: Option<PathBuf>,
    /// `--spawn`.
    pub spawn: bool,
    /// `--connect [URL]` (Some("") for the default URL).
    pub connect: Option<String>,
    /// `--record-every N`.
    pub every: u64,
    /// `--record-failures N`.
    pub failures: u64,
}

impl RecordRequest {
    /// True when a recording was asked for.
    pub fn wanted(&self) -> bool {
        self.file.is_some() || self.spawn || self.connect.is_some()
    }

    /// Whether a recording can be made as asked: `Ok(true)` when one was asked for and this
    /// build can make it, `Ok(false)` when none was asked for; an error for more than one sink
    /// or, in a build without the `rerun` feature, for any request (saying how to get it).
    /// Commands call it before they run anything.
    ///
    /// ```
    /// use savme_viewer::RecordRequest;
    /// assert!(matches!(RecordRequest::default().check(), Ok(false)));
    /// let twice = RecordRequest { spawn: true, connect: Some(String::new()), ..Default::default() };
    /// assert!(twice.check().is_err());
    /// ```
    pub fn check(&self) -> Result<bool, CampaignError> {
        if !self.wanted() {
            return Ok(false);
        }
        let n = usize::from(self.file.is_some())
            + usize::from(self.spawn)
            + usize::from(self.connect.is_some());
        if n > 1 {
            return Err(asked_twice());
        }
        if cfg!(feature = "rerun") {
            Ok(true)
        } else {
            Err(CampaignError::Recording(
                "this savme was built without the `rerun` feature; rebuild with `cargo build --release --features rerun`".into(),
            ))
        }
    }
}

/// What a recorded trial shows besides its outcome: the frames a simulator adapter offers for
/// the viewer. An open seam: a simulator offers frames by implementing `TrialFrames` (in its
/// own crate) and handing it over with `Frames::new` (feature `rerun`); the bundled driving simulator and FMU
/// campaigns use [`Frames::driving`] and [`Frames::series`]; [`Frames::none`] records the
/// campaign view and the outcomes only. In a build without the `rerun` feature every `Frames`
/// is empty (nothing is recorded there).
///
/// ```
/// use savme_viewer::Frames;
/// assert!(Frames::none().is_none());
/// let bundled = Frames::driving(savme_sim::sim::DrivingSimulator::default());
/// assert_eq!(bundled.is_none(), !cfg!(feature = "rerun"));
/// ```
pub struct Frames {
    #[cfg(feature = "rerun")]
    inner: Option<Box<dyn TrialFrames>>,
}

impl Frames {
    /// No frames: the learning view and the outcomes only.
    pub fn none() -> Self {
        Frames {
            #[cfg(feature = "rerun")]
            inner: None,
        }
    }

    /// The frames `frames` logs — any simulator's (see `TrialFrames` for an example).
    #[cfg(feature = "rerun")]
    pub fn new(frames: impl TrialFrames + 'static) -> Self {
        Frames {
            inner: Some(Box::new(frames)),
        }
    }

    /// The bundled driving simulator's trial view (`DrivingFrames`: cameras, 3D, plots),
    /// from re-runs of `sim` with recording on.
    pub fn driving(sim: DrivingSimulator) -> Self {
        #[cfg(feature = "rerun")]
        {
            Frames::new(DrivingFrames::new(sim))
        }
        #[cfg(not(feature = "rerun"))]
        {
            let _ = sim;
            Frames::none()
        }
    }

    /// Time-series frames (`SeriesFrames`): re-runs of `runner` (as the campaign runs its
    /// simulator; an FMU campaign's back end, in this process or in workers) recording the
    /// outputs `record` (`[fmu] record`); `signal` is the campaign's failure signal.
    pub fn series(runner: impl Rerun + 'static, record: Vec<String>, signal: Signal) -> Self {
        #[cfg(feature = "rerun")]
        {
            Frames::new(SeriesFrames::new(runner, record, signal))
        }
        #[cfg(not(feature = "rerun"))]
        {
            let _ = (runner, record, signal);
            Frames::none()
        }
    }

    /// True when there are no frames to record.
    pub fn is_none(&self) -> bool {
        #[cfg(feature = "rerun")]
        {
            self.inner.is_none()
        }
        #[cfg(not(feature = "rerun"))]
        {
            true
        }
    }
}

impl std::fmt::Debug for Frames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.is_none() {
            "Frames(none)"
        } else {
            "Frames(..)"
        })
    }
}

fn asked_twice() -> CampaignError {
    CampaignError::Protocol {
        field: "--record / --spawn / --connect".into(),
        message: "give only one of them".into(),
    }
}

/// Starts the recording asked for, if any, as a campaign observer (it closes the recording
/// when the campaign finishes).
pub fn start(
    req: &RecordRequest,
    frames: Frames,
    protocol: &Protocol,
    problem: &Problem,
) -> Result<Option<Box<dyn Observer>>, CampaignError> {
    #[cfg(feature = "rerun")]
    {
        Ok(recorder(req, frames, protocol, problem)?.map(|r| Box::new(r) as Box<dyn Observer>))
    }
    #[cfg(not(feature = "rerun"))]
    {
        let _ = (frames, protocol, problem);
        req.check()?;
        Ok(None)
    }
}

#[cfg(feature = "rerun")]
fn sink(req: &RecordRequest) -> Option<Sink> {
    match (&req.file, req.spawn, &req.connect) {
        (Some(f), _, _) => Some(Sink::File(f.clone())),
        (_, true, _) => Some(Sink::Spawn),
        (_, _, Some(url)) if url.is_empty() => Some(Sink::Connect(None)),
        (_, _, Some(url)) => Some(Sink::Connect(Some(url.clone()))),
        _ => None,
    }
}

#[cfg(feature = "rerun")]
fn recorder(
    req: &RecordRequest,
    frames: Frames,
    protocol: &Protocol,
    problem: &Problem,
) -> Result<Option<Recorder>, CampaignError> {
    if !req.check()? {
        return Ok(None);
    }
    let Some(sink) = sink(req) else {
        return Ok(None);
    };
    let opts = RecordOptions {
        sink,
        every: req.every,
        failure_cap: req.failures,
    };
    Recorder::start(opts, frames.inner, protocol, problem.clone())
        .map(Some)
        .map_err(|e| CampaignError::Recording(e.to_string()))
}

/// Runs one simulation of the bundled simulator once, with recording on, into the recording
/// asked for (`savme simulate --record …`): the run at `theta` and, when `theta` is not θ_HF,
/// the HF run beside it (the trial view, HF | LF). Returns the run at `theta`.
pub fn record_run(
    req: &RecordRequest,
    scenario: &str,
    phi: &Assignment,
    theta: &Assignment,
) -> Result<RunResult, CampaignError> {
    #[cfg(feature = "rerun")]
    {
        let rec = |e: RecordError| CampaignError::Recording(e.to_string());
        req.check()?;
        let sink = sink(req).ok_or_else(|| CampaignError::Recording("no sink".into()))?;
        let theta_hf = savme_sim::fidelity::theta_hf();
        let paired = *theta != theta_hf;
        let (stream, _) = stream::open(
            &sink,
            trial::app(paired),
            &format!("simulate {scenario}"),
            layout::trial(paired),
        )
        .map_err(rec)?;
        let t = trial::TrialRecording::on(stream);
        let mut frames = DrivingFrames::default();
        let (hf, lf) = t
            .record(
                &mut frames,
                scenario,
                phi,
                &theta_hf,
                paired.then_some(theta),
            )
            .map_err(rec)?
            .ok_or_else(|| CampaignError::Recording(format!("unknown scenario `{scenario}`")))?;
        let result = frames
            .take_last()
            .ok_or_else(|| CampaignError::Recording("no run".into()))?;
        t.outcome(&trial::run_markdown(
            scenario,
            phi,
            &hf,
            lf.as_ref().map(|l| (l, theta, &theta_hf)),
        ))
        .map_err(rec)?;
        stream::close(t.stream(), &sink).map_err(rec)?;
        Ok(result)
    }
    #[cfg(not(feature = "rerun"))]
    {
        let _ = (scenario, phi, theta);
        req.check()?;
        Err(CampaignError::Recording(
            "no recording was asked for".into(),
        ))
    }
}
