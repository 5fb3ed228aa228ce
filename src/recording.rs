//! The command line's recording flags (`--record FILE.rrd`, `--spawn`, `--connect [URL]`,
//! `--record-every N`, `--record-failures N`), with or without the `rerun` feature: without it,
//! asking for a recording is a clear error instead of an unknown flag.

use crate::campaign::{CampaignError, NoObserver, Observer};
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
}

fn asked_twice() -> CampaignError {
    CampaignError::Protocol {
        field: "--record / --spawn / --connect".into(),
        message: "give only one of them".into(),
    }
}

/// A recording in progress (or none).
pub enum Recording {
    /// Recording to rerun.
    #[cfg(feature = "rerun")]
    Rerun(Box<crate::record::Recorder>),
    /// Not recording.
    Off(NoObserver),
}

impl Recording {
    /// The campaign observer.
    pub fn observer(&mut self) -> &mut dyn Observer {
        match self {
            #[cfg(feature = "rerun")]
            Recording::Rerun(r) => r.as_mut(),
            Recording::Off(o) => o,
        }
    }

    /// Closes the recording (the file gets its footer).
    pub fn finish(self) -> Result<(), CampaignError> {
        match self {
            #[cfg(feature = "rerun")]
            Recording::Rerun(r) => r
                .finish()
                .map_err(|e| CampaignError::Recording(e.to_string())),
            Recording::Off(_) => Ok(()),
        }
    }
}

/// Starts the recording asked for, if any. `sim` re-runs the trials that get sensor frames.
pub fn start(
    req: &RecordRequest,
    sim: DrivingSimulator,
    theta_hf: Assignment,
) -> Result<Option<Recording>, CampaignError> {
    if !req.wanted() {
        return Ok(None);
    }
    let n = usize::from(req.file.is_some())
        + usize::from(req.spawn)
        + usize::from(req.connect.is_some());
    if n > 1 {
        return Err(asked_twice());
    }
    #[cfg(feature = "rerun")]
    {
        use crate::record::{RecordOptions, Recorder, Sink};
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
        let r = Recorder::start(opts, sim, theta_hf)
            .map_err(|e| CampaignError::Recording(e.to_string()))?;
        Ok(Some(Recording::Rerun(Box::new(r))))
    }
    #[cfg(not(feature = "rerun"))]
    {
        let _ = (sim, theta_hf);
        Err(CampaignError::Recording(
            "this savme was built without the `rerun` feature; rebuild with `cargo build --release --features rerun`".into(),
        ))
    }
}

/// Records one run (`savme simulate --record …`).
pub fn record_run(
    req: &RecordRequest,
    scenario: &str,
    phi: &Assignment,
    theta: &Assignment,
) -> Result<(), CampaignError> {
    match start(req, DrivingSimulator::default(), theta.clone())? {
        None => Ok(()),
        #[cfg(feature = "rerun")]
        Some(Recording::Rerun(mut r)) => {
            r.record_run(scenario, phi, theta)
                .map_err(|e| CampaignError::Recording(e.to_string()))?;
            r.finish()
                .map_err(|e| CampaignError::Recording(e.to_string()))
        }
        Some(other) => {
            let _ = (scenario, phi);
            other.finish()
        }
    }
}
