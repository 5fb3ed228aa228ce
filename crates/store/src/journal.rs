//! A served kernel's journal in a trial store: every [`Event`] of a
//! [`Journaled`] kernel is one store line, and a store is replayed into the kernel it held.
//! `savme serve --journal` uses it (and so can any other front end: the format is the same).

use super::{StoreError, TornTail, TrialStore};
use savme_kernel::journal::{Event, Journaled, Replayer, Sink};
use savme_kernel::{KernelConfig, Trial};

/// A trial store as the sink of a [`Journaled`] kernel.
pub struct JournalSink {
    store: Box<dyn TrialStore>,
}

impl std::fmt::Debug for JournalSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JournalSink")
            .field("store", &self.store.location())
            .finish()
    }
}

impl Sink for JournalSink {
    type Error = StoreError;

    fn record(&mut self, event: &Event) -> Result<(), StoreError> {
        self.record_all(std::slice::from_ref(event))
    }

    fn record_all(&mut self, events: &[Event]) -> Result<(), StoreError> {
        self.store.append_all(&crate::records(events))
    }
}

/// Why a journal could not be opened.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JournalError {
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A line is not an event, or the kernel cannot replay it.
    #[error("{store}, line {line}: {message}")]
    Line {
        /// The store.
        store: String,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A new journal needs a configuration.
    #[error("{store} is new: give --config (a kernel configuration) to start it")]
    NoConfig {
        /// The store.
        store: String,
    },
    /// The configuration given differs from the journal's.
    #[error("{store} was started with a different configuration than the one given")]
    OtherConfig {
        /// The store.
        store: String,
    },
    /// The configuration is invalid.
    #[error("{store}: {source}")]
    Config {
        /// The store.
        store: String,
        /// The kernel's complaint.
        source: savme_kernel::ConfigError,
    },
}

/// What opening a journal found.
#[derive(Debug)]
pub struct OpenedJournal {
    /// The kernel, logging to the store.
    pub kernel: Journaled<JournalSink>,
    /// Some when an existing journal was resumed: trials told and pending.
    pub resumed: Option<(u64, Vec<Trial>)>,
    /// An incomplete last line that was dropped.
    pub torn: Option<TornTail>,
    /// The records of the trials told so far, in tell order (empty for a new journal).
    pub records: Vec<savme_kernel::TrialRecord>,
}

/// Opens the journal in `store`: replays it if it holds events (`config`, if given, must be
/// the journal's), else starts it with `config`.
///
/// ```
/// use savme_store::{journal, JsonlStore};
/// let path = std::env::temp_dir().join(format!("savme-journal-doc-{}.jsonl", std::process::id()));
/// # let _ = std::fs::remove_file(&path);
/// use savme_kernel::{Assignment, Kernel, Scale, Space, Variable};
/// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [5, 10])])?;
/// let phi = Space::new(vec![Variable::continuous("gap", 5.0, 50.0, 4, Scale::Linear)])?;
/// let config = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
///     .scenario("s", phi, 1.0)
///     .seed(1)
///     .build()?
///     .config()
///     .clone();
/// let mut j = journal::open(Box::new(JsonlStore::open(&path)?), Some(config.clone()))?;
/// let t = j.kernel.ask()?;
/// drop(j);
/// let j = journal::open(Box::new(JsonlStore::open(&path)?), None)?;
/// assert_eq!(j.resumed.as_ref().map(|(_, pending)| pending.clone()), Some(vec![t]));
/// # drop(j); std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn open(
    mut store: Box<dyn TrialStore>,
    config: Option<KernelConfig>,
) -> Result<OpenedJournal, JournalError> {
    let location = store.location();
    let loaded = store.load()?;
    if loaded.lines.is_empty() {
        let config = config.ok_or(JournalError::NoConfig {
            store: location.clone(),
        })?;
        let kernel = Journaled::start(config, JournalSink { store }).map_err(|e| match e {
            savme_kernel::journal::JournalStartError::Config(source) => JournalError::Config {
                store: location.clone(),
                source,
            },
            savme_kernel::journal::JournalStartError::Sink(e) => JournalError::Store(e),
        })?;
        return Ok(OpenedJournal {
            kernel,
            resumed: None,
            torn: loaded.torn,
            records: Vec::new(),
        });
    }
    let mut replayer = Replayer::new();
    // An edited line is refused after the replay, so that a line that is no event, or an
    // event the kernel refuses, is named as such first.
    let edited = loaded.refuse_edits(&location);
    for l in loaded.lines {
        let bad = |message: String| JournalError::Line {
            store: location.clone(),
            line: l.line,
            message,
        };
        let event: Event = serde_json::from_value(l.value).map_err(|e| bad(e.to_string()))?;
        replayer.apply(event).map_err(|e| bad(e.to_string()))?;
    }
    let replay = replayer.finish().map_err(|e| JournalError::Line {
        store: location.clone(),
        line: 1,
        message: e.to_string(),
    })?;
    edited?;
    if config.is_some_and(|c| &c != replay.kernel.config()) {
        return Err(JournalError::OtherConfig { store: location });
    }
    let told = replay.kernel.stats().told;
    let pending = replay.kernel.pending().cloned().collect();
    Ok(OpenedJournal {
        kernel: Journaled::resume(replay.kernel, JournalSink { store }),
        resumed: Some((told, pending)),
        torn: loaded.torn,
        records: replay.records,
    })
}
