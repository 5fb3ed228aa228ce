//! An append-only JSON-lines trial log from which a kernel's exact state is rebuilt.
//!
//! Each line is one [`Event`]: the kernel's configuration first, then every phase switch, ask,
//! tell and cancel in the order they happened. [`replay`] rebuilds the kernel by re-running the
//! asks (checking that each reproduces the logged trial) and re-applying the tells, so a
//! resumed kernel makes exactly the asks the original would have made.
//!
//! [`Journaled`] wraps a kernel and writes ahead: an ask or tell is logged *before* it changes
//! the kernel, and a failed write changes nothing. Every event is one `write_all` of a complete
//! line followed by a flush, so a process killed at any moment leaves at most one incomplete
//! last line; [`replay`] reports such a line ([`TruncatedTail`]) and keeps every earlier record.
//!
//! The writer is any [`std::io::Write`]; the kernel crate itself never opens files.
//!
//! ```
//! use savme_kernel::{journal, Assignment, Kernel, Observation, Run, Space, Variable};
//! let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
//! let config = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
//!     .scenario("s", Space::new(vec![Variable::boolean("rain")])?, 1.0)
//!     .build()?
//!     .config()
//!     .clone();
//! let mut log = journal::Journaled::start(config, Vec::new())?;
//! let t = log.ask()?;
//! log.tell(t.id, Observation::Paired { hf: Run::new(true, 1.0), lf: Run::new(true, 0.1) })?;
//! let next = log.kernel().clone().ask();
//!
//! let bytes = log.into_writer();
//! let replayed = journal::replay(&bytes[..])?;
//! assert_eq!(replayed.records.len(), 1);
//! assert_eq!(replayed.kernel.clone().ask(), next);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::kernel::{ConfigError, Kernel, KernelConfig, Phase, TellError, Trial, TrialRecord};
use crate::outcome::Observation;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};

/// Version of the journal format written in the start event.
pub const FORMAT: u32 = 1;

/// One line of the journal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The kernel's configuration; always the first line.
    Start {
        /// Journal format version ([`FORMAT`]).
        format: u32,
        /// The configuration.
        config: Box<KernelConfig>,
    },
    /// A phase switch.
    Phase {
        /// The new phase.
        phase: Phase,
    },
    /// An ask.
    Ask {
        /// The trial handed out.
        trial: Trial,
    },
    /// A tell, with the whole record so that each line reads on its own.
    Tell {
        /// The told trial.
        #[serde(flatten)]
        record: Box<TrialRecord>,
    },
    /// A cancelled trial.
    Cancel {
        /// Its id.
        id: u64,
    },
}

/// Why writing to or replaying a journal failed.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    /// Reading or writing failed.
    #[error("journal I/O at line {line}: {source}")]
    Io {
        /// The line being read or written (1-based).
        line: u64,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A complete line is not a journal event.
    #[error("journal line {line} is corrupt: {message}")]
    Corrupt {
        /// The line (1-based).
        line: u64,
        /// What the parser said.
        message: String,
    },
    /// The journal is empty or does not begin with a start event.
    #[error("journal line 1 must be the start event holding the kernel configuration")]
    MissingStart,
    /// A start event of an unknown format version, or a second start event.
    #[error("journal line {line}: {message}")]
    BadStart {
        /// The line (1-based).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// The configuration in the start event is invalid.
    #[error("journal line 1: {0}")]
    Config(#[from] ConfigError),
    /// A logged tell or cancel the kernel refuses.
    #[error("journal line {line}: {source}")]
    Tell {
        /// The line (1-based).
        line: u64,
        /// Why the kernel refused it.
        source: TellError,
    },
    /// Replaying did not reproduce what was logged (a different kernel version or an edited
    /// journal).
    #[error("journal line {line}: replay diverged: {message}")]
    Diverged {
        /// The line (1-based).
        line: u64,
        /// What differed.
        message: String,
    },
}

/// An incomplete last line, left by a process killed mid-write. It was not replayed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TruncatedTail {
    /// Its line number (1-based).
    pub line: u64,
    /// Its length in bytes.
    pub bytes: usize,
}

/// A kernel rebuilt from a journal.
#[derive(Debug)]
pub struct Replay {
    /// The kernel, in the state after the last complete line.
    pub kernel: Kernel,
    /// Every told trial, in tell order.
    pub records: Vec<TrialRecord>,
    /// The incomplete last line, if there was one.
    pub truncated: Option<TruncatedTail>,
    /// Bytes of complete lines: truncate the file to this length before appending to it.
    pub valid_len: u64,
    /// Number of complete lines read.
    pub lines: u64,
}

/// Rebuilds a kernel from a journal. Complete lines must all be valid events (the error names
/// the first bad line); an incomplete last line (no trailing newline) is reported in
/// [`Replay::truncated`] and ignored. Blank lines are skipped.
pub fn replay<R: BufRead>(mut reader: R) -> Result<Replay, JournalError> {
    let mut kernel: Option<Kernel> = None;
    let mut records = Vec::new();
    let mut buf = Vec::new();
    let mut line = 0u64;
    let mut valid_len = 0u64;
    let mut truncated = None;
    loop {
        buf.clear();
        let n = reader
            .read_until(b'\n', &mut buf)
            .map_err(|source| JournalError::Io {
                line: line + 1,
                source,
            })?;
        if n == 0 {
            break;
        }
        line += 1;
        if buf.last() != Some(&b'\n') {
            truncated = Some(TruncatedTail { line, bytes: n });
            break;
        }
        valid_len += n as u64;
        if buf.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let event: Event = serde_json::from_slice(&buf).map_err(|e| JournalError::Corrupt {
            line,
            message: e.to_string(),
        })?;
        match (&mut kernel, event) {
            (None, Event::Start { format, config }) => {
                if format != FORMAT {
                    return Err(JournalError::BadStart {
                        line,
                        message: format!("format {format} is not supported (expected {FORMAT})"),
                    });
                }
                kernel = Some(Kernel::new(*config)?);
            }
            (None, _) => return Err(JournalError::MissingStart),
            (Some(_), Event::Start { .. }) => {
                return Err(JournalError::BadStart {
                    line,
                    message: "a second start event".into(),
                })
            }
            (Some(k), event) => apply(k, event, line, &mut records)?,
        }
    }
    let kernel = kernel.ok_or(JournalError::MissingStart)?;
    let lines = line - u64::from(truncated.is_some());
    Ok(Replay {
        kernel,
        records,
        truncated,
        valid_len,
        lines,
    })
}

fn apply(
    k: &mut Kernel,
    event: Event,
    line: u64,
    records: &mut Vec<TrialRecord>,
) -> Result<(), JournalError> {
    let diverged = |message: String| JournalError::Diverged { line, message };
    match event {
        Event::Start { .. } => unreachable!("handled by the caller"),
        Event::Phase { phase } => k.set_phase(phase),
        Event::Ask { trial } => {
            let (rng, drawn) = k.draw_next();
            if *drawn.trial() != trial {
                return Err(diverged(format!(
                    "logged trial {} differs from the one the kernel draws",
                    trial.id
                )));
            }
            k.commit_drawn(rng, drawn);
        }
        Event::Tell { record } => {
            let assessed = k
                .assess_tell(record.trial.id, record.observation)
                .map_err(|source| JournalError::Tell { line, source })?;
            if assessed.record != *record {
                return Err(diverged(format!(
                    "logged tell of trial {} differs from what the kernel computes",
                    record.trial.id
                )));
            }
            records.push(k.commit_assessed(assessed));
        }
        Event::Cancel { id } => {
            k.cancel(id)
                .map_err(|source| JournalError::Tell { line, source })?;
        }
    }
    Ok(())
}

/// Writes one event as a single complete line and flushes it.
fn write_event<W: Write>(w: &mut W, event: &Event, line: u64) -> Result<(), JournalError> {
    let mut bytes = serde_json::to_vec(event).map_err(|e| JournalError::Io {
        line,
        source: e.into(),
    })?;
    bytes.push(b'\n');
    w.write_all(&bytes)
        .and_then(|()| w.flush())
        .map_err(|source| JournalError::Io { line, source })
}

/// A kernel whose every ask, tell, cancel and phase switch is logged, write-ahead, to `W`.
#[derive(Debug)]
pub struct Journaled<W: Write> {
    kernel: Kernel,
    writer: W,
    /// Lines written or replayed so far.
    lines: u64,
}

/// Why a journaled tell failed: the kernel refused it, or the log could not be written.
#[derive(Debug, thiserror::Error)]
pub enum JournaledTellError {
    /// The kernel refused the tell (nothing was written or changed).
    #[error(transparent)]
    Tell(#[from] TellError),
    /// Writing the log failed (nothing was changed).
    #[error(transparent)]
    Journal(#[from] JournalError),
}

impl<W: Write> Journaled<W> {
    /// Builds a kernel from `config` and writes the start event.
    pub fn start(config: KernelConfig, mut writer: W) -> Result<Self, JournalError> {
        let kernel = Kernel::new(config)?;
        let event = Event::Start {
            format: FORMAT,
            config: Box::new(kernel.config().clone()),
        };
        write_event(&mut writer, &event, 1)?;
        Ok(Journaled {
            kernel,
            writer,
            lines: 1,
        })
    }

    /// Continues a replayed journal; `writer` must append to it (after truncating the file to
    /// [`Replay::valid_len`] if the replay found an incomplete tail).
    pub fn resume(replay: &Replay, writer: W) -> Self {
        Journaled {
            kernel: replay.kernel.clone(),
            writer,
            lines: replay.lines,
        }
    }

    /// The kernel (read-only: changes go through the journaled methods).
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// Gives back the writer.
    pub fn into_writer(self) -> W {
        self.writer
    }

    /// Logs and applies a phase switch.
    pub fn set_phase(&mut self, phase: Phase) -> Result<(), JournalError> {
        self.write(&Event::Phase { phase })?;
        self.kernel.set_phase(phase);
        Ok(())
    }

    /// Draws, logs and hands out the next trial ([`Kernel::ask`]).
    pub fn ask(&mut self) -> Result<Trial, JournalError> {
        let (rng, drawn) = self.kernel.draw_next();
        self.write(&Event::Ask {
            trial: drawn.trial().clone(),
        })?;
        Ok(self.kernel.commit_drawn(rng, drawn))
    }

    /// Checks, logs and applies a tell ([`Kernel::tell`]).
    pub fn tell(
        &mut self,
        id: u64,
        observation: Observation,
    ) -> Result<TrialRecord, JournaledTellError> {
        let assessed = self.kernel.assess_tell(id, observation)?;
        self.write(&Event::Tell {
            record: Box::new(assessed.record.clone()),
        })?;
        Ok(self.kernel.commit_assessed(assessed))
    }

    /// Logs and applies a cancel ([`Kernel::cancel`]).
    pub fn cancel(&mut self, id: u64) -> Result<Trial, JournaledTellError> {
        // Check first so that a refused cancel writes nothing.
        self.kernel.check_pending(id)?;
        self.write(&Event::Cancel { id })?;
        Ok(self.kernel.cancel(id)?)
    }

    fn write(&mut self, event: &Event) -> Result<(), JournalError> {
        write_event(&mut self.writer, event, self.lines + 1)?;
        self.lines += 1;
        Ok(())
    }
}
