//! Write-ahead logging of a kernel's decisions, and rebuilding its exact state from them.
//!
//! Each [`Event`] is one decision: the kernel's configuration first, then every phase switch,
//! ask, tell and cancel in the order they happened. [`Replayer`] rebuilds the kernel by
//! re-running the asks (checking that each reproduces the logged trial) and re-applying the
//! tells, so a resumed kernel makes exactly the asks the original would have made.
//!
//! [`Journaled`] wraps a kernel and writes ahead: an ask or tell is handed to its [`Sink`]
//! *before* it changes the kernel, and a failed write changes nothing.
//!
//! The kernel crate never touches files: where the events go (a JSON-lines file with a lock, a
//! database) is the sink's business — the `savme` package's trial stores are such sinks.
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
//! let events: Vec<journal::Event> = log.into_sink();
//! let replayed = journal::replay(events)?;
//! assert_eq!(replayed.records.len(), 1);
//! assert_eq!(replayed.kernel.clone().ask(), next);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::kernel::{ConfigError, Kernel, KernelConfig, Phase, TellError, Trial, TrialRecord};
use crate::outcome::Observation;
use serde::{Deserialize, Serialize};
use std::convert::Infallible;

/// Version of the journal format written in the start event.
pub const FORMAT: u32 = 1;

/// One logged decision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The kernel's configuration; always the first event.
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
    /// A tell, with the whole record so that each event reads on its own.
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

/// Why an event cannot be replayed. The caller knows where the event came from (a file and
/// line, a database row) and names it.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The journal is empty or does not begin with a start event.
    #[error("the journal must begin with the start event holding the kernel configuration")]
    MissingStart,
    /// A start event of an unknown format version, or a second start event.
    #[error("{0}")]
    BadStart(String),
    /// The configuration in the start event is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A logged tell or cancel the kernel refuses.
    #[error(transparent)]
    Tell(#[from] TellError),
    /// Replaying did not reproduce what was logged (a different kernel version or an edited
    /// journal).
    #[error("replay diverged: {0}")]
    Diverged(String),
}

/// A kernel rebuilt from a journal.
#[derive(Debug)]
pub struct Replay {
    /// The kernel, in the state after the last event.
    pub kernel: Kernel,
    /// Every told trial, in tell order.
    pub records: Vec<TrialRecord>,
}

/// Rebuilds a kernel one event at a time ([`Replayer::apply`]), so that the caller can name
/// the line or row of an event that fails.
#[derive(Debug, Default)]
pub struct Replayer {
    kernel: Option<Kernel>,
    records: Vec<TrialRecord>,
}

impl Replayer {
    /// A replayer that expects the start event first.
    pub fn new() -> Self {
        Replayer::default()
    }

    /// Applies the next event; on an error the replayer is unchanged.
    pub fn apply(&mut self, event: Event) -> Result<(), ReplayError> {
        match (&mut self.kernel, event) {
            (None, Event::Start { format, config }) => {
                if format != FORMAT {
                    return Err(ReplayError::BadStart(format!(
                        "format {format} is not supported (expected {FORMAT})"
                    )));
                }
                self.kernel = Some(Kernel::new(*config)?);
                Ok(())
            }
            (None, _) => Err(ReplayError::MissingStart),
            (Some(_), Event::Start { .. }) => {
                Err(ReplayError::BadStart("a second start event".into()))
            }
            (Some(k), event) => apply(k, event, &mut self.records),
        }
    }

    /// True once the start event was applied.
    pub fn started(&self) -> bool {
        self.kernel.is_some()
    }

    /// The rebuilt kernel and its told trials.
    pub fn finish(self) -> Result<Replay, ReplayError> {
        Ok(Replay {
            kernel: self.kernel.ok_or(ReplayError::MissingStart)?,
            records: self.records,
        })
    }
}

/// [`replay`] failed at an event.
#[derive(Debug, thiserror::Error)]
#[error("event {event}: {source}")]
pub struct ReplayFailed {
    /// The 1-based position of the event.
    pub event: u64,
    /// What is wrong with it.
    #[source]
    pub source: ReplayError,
}

/// Rebuilds a kernel from all of a journal's events.
pub fn replay(events: impl IntoIterator<Item = Event>) -> Result<Replay, ReplayFailed> {
    let mut r = Replayer::new();
    let mut n = 0u64;
    for event in events {
        n += 1;
        r.apply(event)
            .map_err(|source| ReplayFailed { event: n, source })?;
    }
    r.finish().map_err(|source| ReplayFailed {
        event: n.max(1),
        source,
    })
}

fn apply(k: &mut Kernel, event: Event, records: &mut Vec<TrialRecord>) -> Result<(), ReplayError> {
    match event {
        Event::Start { .. } => Err(ReplayError::BadStart("a second start event".into())),
        Event::Phase { phase } => {
            k.set_phase(phase);
            Ok(())
        }
        Event::Ask { trial } => {
            let (rng, drawn) = k.draw_next();
            if *drawn.trial() != trial {
                return Err(ReplayError::Diverged(format!(
                    "logged trial {} differs from the one the kernel draws",
                    trial.id
                )));
            }
            k.commit_drawn(rng, drawn);
            Ok(())
        }
        Event::Tell { record } => {
            let assessed = k.assess_tell(record.trial.id, record.observation)?;
            if assessed.record != *record {
                return Err(ReplayError::Diverged(format!(
                    "logged tell of trial {} differs from what the kernel computes",
                    record.trial.id
                )));
            }
            records.push(k.commit_assessed(assessed));
            Ok(())
        }
        Event::Cancel { id } => {
            k.cancel(id)?;
            Ok(())
        }
    }
}

/// Where a [`Journaled`] kernel's events go. A sink must have made an event durable (as far
/// as it promises durability) when `record` returns `Ok`.
pub trait Sink {
    /// Why an event could not be recorded.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Records one event.
    fn record(&mut self, event: &Event) -> Result<(), Self::Error>;

    /// Records several events, all or none (a batch ask must not leave half its trials
    /// recorded). The default records them one by one and is all-or-none only for a sink that
    /// cannot fail midway; a sink that can must override it.
    fn record_all(&mut self, events: &[Event]) -> Result<(), Self::Error> {
        events.iter().try_for_each(|e| self.record(e))
    }
}

/// Events kept in memory (tests, or a harness that persists them itself).
impl Sink for Vec<Event> {
    type Error = Infallible;

    fn record(&mut self, event: &Event) -> Result<(), Infallible> {
        self.push(event.clone());
        Ok(())
    }
}

/// A kernel whose every ask, tell, cancel and phase switch is recorded, write-ahead, to a
/// [`Sink`].
#[derive(Debug)]
pub struct Journaled<S: Sink> {
    kernel: Kernel,
    sink: S,
}

/// Why a journaled tell or cancel failed: the kernel refused it, or the sink could not record
/// it. Either way nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum JournaledTellError<E: std::error::Error + 'static> {
    /// The kernel refused the call (nothing was recorded or changed).
    #[error(transparent)]
    Tell(#[from] TellError),
    /// Recording failed (nothing was changed).
    #[error(transparent)]
    Sink(E),
}

impl<S: Sink> Journaled<S> {
    /// Builds a kernel from `config` and records the start event.
    pub fn start(config: KernelConfig, mut sink: S) -> Result<Self, JournalStartError<S::Error>> {
        let kernel = Kernel::new(config)?;
        let event = Event::Start {
            format: FORMAT,
            config: Box::new(kernel.config().clone()),
        };
        sink.record(&event).map_err(JournalStartError::Sink)?;
        Ok(Journaled { kernel, sink })
    }

    /// Continues a replayed journal; `sink` must append to it.
    pub fn resume(kernel: Kernel, sink: S) -> Self {
        Journaled { kernel, sink }
    }

    /// The kernel (read-only: changes go through the journaled methods).
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// The sink.
    pub fn sink(&self) -> &S {
        &self.sink
    }

    /// Gives back the sink.
    pub fn into_sink(self) -> S {
        self.sink
    }

    /// Records and applies a phase switch.
    pub fn set_phase(&mut self, phase: Phase) -> Result<(), S::Error> {
        self.sink.record(&Event::Phase { phase })?;
        self.kernel.set_phase(phase);
        Ok(())
    }

    /// Draws, records and hands out the next trial ([`Kernel::ask`]).
    pub fn ask(&mut self) -> Result<Trial, S::Error> {
        let (rng, drawn) = self.kernel.draw_next();
        self.sink.record(&Event::Ask {
            trial: drawn.trial().clone(),
        })?;
        Ok(self.kernel.commit_drawn(rng, drawn))
    }

    /// Draws, records and hands out `n` trials, all or none: if recording fails, no trial was
    /// asked (the kernel is unchanged).
    pub fn ask_batch(&mut self, n: usize) -> Result<Vec<Trial>, S::Error> {
        let mut next = self.kernel.clone();
        let trials: Vec<Trial> = (0..n).map(|_| next.ask()).collect();
        let events: Vec<Event> = trials
            .iter()
            .map(|t| Event::Ask { trial: t.clone() })
            .collect();
        self.sink.record_all(&events)?;
        self.kernel = next;
        Ok(trials)
    }

    /// Checks, records and applies a tell ([`Kernel::tell`]).
    pub fn tell(
        &mut self,
        id: u64,
        observation: Observation,
    ) -> Result<TrialRecord, JournaledTellError<S::Error>> {
        let assessed = self.kernel.assess_tell(id, observation)?;
        self.sink
            .record(&Event::Tell {
                record: Box::new(assessed.record.clone()),
            })
            .map_err(JournaledTellError::Sink)?;
        Ok(self.kernel.commit_assessed(assessed))
    }

    /// Records and applies a cancel ([`Kernel::cancel`]).
    pub fn cancel(&mut self, id: u64) -> Result<Trial, JournaledTellError<S::Error>> {
        // Check first so that a refused cancel records nothing.
        self.kernel.check_pending(id)?;
        self.sink
            .record(&Event::Cancel { id })
            .map_err(JournaledTellError::Sink)?;
        Ok(self.kernel.cancel(id)?)
    }
}

/// Why a journal could not be started.
#[derive(Debug, thiserror::Error)]
pub enum JournalStartError<E: std::error::Error + 'static> {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The start event could not be recorded.
    #[error(transparent)]
    Sink(E),
}
