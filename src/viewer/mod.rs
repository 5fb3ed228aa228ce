//! Watching trials and campaigns in the rerun viewer.
//!
//! This module holds what every build has: what the user asked to record ([`RecordRequest`],
//! from `--record FILE.rrd`, `--spawn`, `--connect [URL]`, `--record-every N`,
//! `--record-failures N`) and [`start`], which turns it into a campaign observer — or, in a
//! build without the `rerun` feature, into a clear error instead of an unknown flag. What is
//! logged lives behind the feature: `recorder` (the learning view, outcomes, sampling, the
//! `TrialFrames` trait a simulator implements to offer frames) and `driving` (the bundled
//! simulator's frames).

#[cfg(feature = "rerun")]
mod driving;
#[cfg(feature = "rerun")]
mod recorder;

#[cfg(feature = "rerun")]
pub use driving::DrivingFrames;
#[cfg(feature = "rerun")]
pub use recorder::{entity_label, RecordError, RecordOptions, Recorder, Sink, TrialFrames};

use crate::campaign::{CampaignError, Observer};
use savme_kernel::Assignment;
use savme_sim::sim::DrivingSimulator;
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
    /// use savme::viewer::RecordRequest;
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

/// The simulator whose frames a recording shows.
#[derive(Debug, Clone)]
pub enum Frames {
    /// The bundled driving simulator (re-run with recording on).
    Driving(DrivingSimulator),
    /// None: the learning view and the outcomes only (e.g. FMUs).
    None,
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
    theta_hf: Assignment,
) -> Result<Option<Box<dyn Observer>>, CampaignError> {
    #[cfg(feature = "rerun")]
    {
        Ok(recorder(req, frames, theta_hf)?.map(|r| Box::new(r) as Box<dyn Observer>))
    }
    #[cfg(not(feature = "rerun"))]
    {
        let _ = (frames, theta_hf);
        req.check()?;
        Ok(None)
    }
}

#[cfg(feature = "rerun")]
fn recorder(
    req: &RecordRequest,
    frames: Frames,
    theta_hf: Assignment,
) -> Result<Option<Recorder>, CampaignError> {
    if !req.check()? {
        return Ok(None);
    }
    let sink = match (&req.file, req.spawn, &req.connect) {
        (Some(f), _, _) => Sink::File(f.clone()),
        (_, true, _) => Sink::Spawn,
        (_, _, Some(url)) if url.is_empty() => Sink::Connect(None),
        (_, _, Some(url)) => Sink::Connect(Some(url.clone())),
        _ => return Ok(None),
    };
    let opts = RecordOptions {
        sink,
        every: req.every,
        failure_cap: req.failures,
    };
    let frames: Option<Box<dyn TrialFrames>> = match frames {
        Frames::Driving(sim) => Some(Box::new(DrivingFrames::new(sim))),
        Frames::None => None,
    };
    Recorder::start(opts, frames, theta_hf)
        .map(Some)
        .map_err(|e| CampaignError::Recording(e.to_string()))
}

/// Records one run of the bundled simulator (`savme simulate --record …`).
pub fn record_run(
    req: &RecordRequest,
    scenario: &str,
    phi: &Assignment,
    theta: &Assignment,
) -> Result<(), CampaignError> {
    #[cfg(feature = "rerun")]
    {
        let frames = Frames::Driving(DrivingSimulator::default());
        if let Some(mut r) = recorder(req, frames, theta.clone())? {
            let rec = |e: RecordError| CampaignError::Recording(e.to_string());
            r.record_run(scenario, phi, theta).map_err(rec)?;
            r.close().map_err(rec)?;
        }
        Ok(())
    }
    #[cfg(not(feature = "rerun"))]
    {
        let _ = (scenario, phi, theta);
        req.check().map(|_| ())
    }
}
