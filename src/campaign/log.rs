//! `trials.jsonl`: every told trial of a campaign as one JSON line, written (and flushed)
//! before the kernel learns from it. It is the campaign's journal: `--resume` replays it.

use super::CampaignError;
use savme_kernel::{Assignment, Credit, Outcome, Phase, SimResult};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

/// One simulator run of a trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunLine {
    /// The system under test failed.
    pub failure: bool,
    /// The cost the kernel was told (wall seconds or work units, per the protocol).
    pub runtime: f64,
    /// Measured wall-clock seconds.
    pub wall_seconds: f64,
    /// Work units, if the simulator counts them.
    pub work: Option<u64>,
}

impl RunLine {
    /// The line of a simulator result told with cost `runtime`.
    pub fn new(r: &SimResult, runtime: f64) -> Self {
        RunLine {
            failure: r.failure,
            runtime,
            wall_seconds: r.wall_seconds,
            work: r.work,
        }
    }

    /// The kernel's view of the run.
    pub fn run(&self) -> savme_kernel::Run {
        savme_kernel::Run::new(self.failure, self.runtime)
    }
}

/// One told trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrialLine {
    /// The stage label, e.g. `train@0.3` (see [`super::Stage::label`]).
    pub stage: String,
    /// Position of the trial within its stage, from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// The kernel phase.
    pub phase: Phase,
    /// The stage's budget (None for the baselines).
    pub budget: Option<f64>,
    /// Scenario name.
    pub scenario: String,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// Learned-fidelity settings θ_LF (None for HF-only trials).
    pub theta_lf: Option<Assignment>,
    /// The HF run.
    pub hf: RunLine,
    /// The LF run (None for HF-only trials).
    pub lf: Option<RunLine>,
    /// t_LF / t_HF.
    pub cost_ratio: Option<f64>,
    /// TP / TN / FP / FN.
    pub outcome: Option<Outcome>,
    /// What the kernel credited (Table II).
    pub credit: Credit,
}

impl TrialLine {
    /// The observation the kernel was told.
    pub fn observation(&self) -> savme_kernel::Observation {
        match &self.lf {
            Some(lf) => savme_kernel::Observation::Paired {
                hf: self.hf.run(),
                lf: lf.run(),
            },
            None => savme_kernel::Observation::HfOnly(self.hf.run()),
        }
    }
}

/// A trial whose simulation failed and that was withdrawn (`on_error = "skip"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailedLine {
    /// The stage label.
    pub stage: String,
    /// Position of the trial within its stage (failed ones included), from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// Scenario name.
    pub scenario: String,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// θ_LF (None for HF-only trials).
    pub theta_lf: Option<Assignment>,
    /// What failed.
    pub error: String,
}

/// A line of `trials.jsonl`: a told trial, or a withdrawn one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum LogLine {
    /// A told trial.
    Trial(TrialLine),
    /// A trial withdrawn after its simulation failed.
    Failed(FailedLine),
}

impl LogLine {
    /// The stage label.
    pub fn stage(&self) -> &str {
        match self {
            LogLine::Trial(t) => &t.stage,
            LogLine::Failed(f) => &f.stage,
        }
    }

    /// The told trial, if it is one.
    pub fn trial(&self) -> Option<&TrialLine> {
        match self {
            LogLine::Trial(t) => Some(t),
            LogLine::Failed(_) => None,
        }
    }
}

/// A trials file read back.
#[derive(Debug, Default)]
pub struct Log {
    /// The complete lines, in file order.
    pub lines: Vec<LogLine>,
    /// Bytes of the file that hold complete lines (a torn last line, from a killed process,
    /// lies beyond).
    pub valid_len: u64,
    /// A torn last line was found (and will be dropped on resume).
    pub torn_tail: bool,
}

/// Reads `path`. A last line without its newline is a torn write from a killed process and is
/// reported in [`Log::torn_tail`]; any other bad line is an error that names the file and line.
pub fn read(path: &Path) -> Result<Log, CampaignError> {
    let file = File::open(path).map_err(|e| CampaignError::io(path, e))?;
    let mut reader = BufReader::new(file);
    let mut log = Log::default();
    let mut buf = String::new();
    let mut number = 0usize;
    loop {
        buf.clear();
        let n = reader
            .read_line(&mut buf)
            .map_err(|e| CampaignError::io(path, e))?;
        if n == 0 {
            break;
        }
        number += 1;
        if !buf.ends_with('\n') {
            // The last line lacks its newline: a write cut short by a killed process. Resume
            // drops it (and runs that trial again).
            log.torn_tail = true;
            break;
        }
        match serde_json::from_str::<LogLine>(buf.trim_end()) {
            Ok(line) => {
                log.lines.push(line);
                log.valid_len += n as u64;
            }
            Err(e) => {
                return Err(CampaignError::Log {
                    path: path.to_path_buf(),
                    line: number,
                    message: e.to_string(),
                })
            }
        }
    }
    Ok(log)
}

/// Appends lines to a trials file, flushing each one.
#[derive(Debug)]
pub struct Writer {
    path: PathBuf,
    file: File,
}

impl Writer {
    /// Opens `path` for appending after cutting it to `valid_len` bytes (dropping a torn tail).
    pub fn append(path: &Path, valid_len: u64) -> Result<Self, CampaignError> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| CampaignError::io(path, e))?;
        file.set_len(valid_len)
            .map_err(|e| CampaignError::io(path, e))?;
        Ok(Writer {
            path: path.to_path_buf(),
            file,
        })
    }

    /// Writes one line and flushes it to the operating system.
    pub fn write(&mut self, line: &LogLine) -> Result<(), CampaignError> {
        let mut s = serde_json::to_string(line).map_err(|e| CampaignError::Log {
            path: self.path.clone(),
            line: 0,
            message: e.to_string(),
        })?;
        s.push('\n');
        self.file
            .write_all(s.as_bytes())
            .and_then(|()| self.file.flush())
            .map_err(|e| CampaignError::io(&self.path, e))
    }
}
