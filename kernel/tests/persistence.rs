//! Snapshots and the trial journal: exact state, edited or missing events, failed writes. (Torn
//! lines and corrupt bytes are the trial store's business: tests in the `savme` package.)
mod common;
use savme_kernel::journal::{
    self, Event, Journaled, JournaledTellError, ReplayError, ReplayFailed,
};
use savme_kernel::{Kernel, Observation, Phase, Run, TellError, Trial};

fn obs(t: &Trial, i: u64) -> Observation {
    let hf = Run::new(i.is_multiple_of(3), 1.0 + (i % 5) as f64);
    match t.phase {
        Phase::Baseline => Observation::HfOnly(hf),
        _ => Observation::Paired {
            hf,
            lf: Run::new(i.is_multiple_of(4), 0.1 + (i % 7) as f64 / 10.0),
        },
    }
}

/// Runs a mixed session on a journaled kernel: batches of asks told out of order, a cancel, phase
/// switches. Leaves a few trials pending.
fn session(log: &mut Journaled<Vec<Event>>) {
    for round in 0..6u64 {
        if round == 3 {
            log.set_phase(Phase::Baseline).unwrap();
        }
        if round == 4 {
            log.set_phase(Phase::Evaluate).unwrap();
        }
        if round == 5 {
            log.set_phase(Phase::Train).unwrap();
        }
        let batch: Vec<Trial> = (0..5).map(|_| log.ask().unwrap()).collect();
        for t in batch.iter().rev().skip(1) {
            log.tell(t.id, obs(t, t.id)).unwrap();
        }
        if round == 2 {
            log.cancel(batch[4].id).unwrap();
        }
    }
}

fn next_asks(mut k: Kernel, n: usize) -> Vec<Trial> {
    (0..n).map(|_| k.ask()).collect()
}

#[test]
fn snapshot_restore_gives_identical_future_asks() {
    let mut k = common::kernel();
    for i in 0..30 {
        let t = k.ask();
        if i % 4 != 0 {
            k.tell(t.id, obs(&t, i)).unwrap();
        }
    }
    let json = k.to_json();
    let restored = Kernel::from_json(&json).unwrap();
    assert_eq!(restored.to_json(), json);
    assert_eq!(restored.pending().count(), k.pending().count());
    assert_eq!(next_asks(restored, 20), next_asks(k, 20));
}

#[test]
fn corrupt_or_inconsistent_snapshots_are_refused() {
    let k = common::kernel();
    let json = k.to_json();
    assert!(matches!(
        Kernel::from_json(&json[..json.len() / 2]),
        Err(savme_kernel::RestoreError::Parse(_))
    ));
    let bad_budget = json.replacen("\"budget\":0.3", "\"budget\":7.0", 1);
    assert_ne!(bad_budget, json);
    let e = Kernel::from_json(&bad_budget).unwrap_err();
    assert!(e.to_string().contains("C_budget"), "{e}");
    let bad_arm = json.replacen("\"alpha\":1.0", "\"alpha\":-1.0", 1);
    let e = Kernel::from_json(&bad_arm).unwrap_err();
    assert!(e.to_string().contains("needs finite counts"), "{e}");
}

#[test]
fn journal_replay_rebuilds_the_exact_state() {
    let mut log = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut log);
    let live = log.kernel().clone();
    let r = journal::replay(log.into_sink()).unwrap();
    assert_eq!(r.kernel.to_json(), live.to_json());
    assert_eq!(r.records.len() as u64, live.stats().told);
    assert_eq!(next_asks(r.kernel, 10), next_asks(live, 10));
}

#[test]
fn a_resumed_journal_continues_as_if_never_interrupted() {
    let mut whole = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut whole);
    let mut first = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut first);
    let events = first.into_sink();
    let replay = journal::replay(events.clone()).unwrap();
    let mut resumed = Journaled::resume(replay.kernel, events);
    for _ in 0..5 {
        let a = whole.ask().unwrap();
        let b = resumed.ask().unwrap();
        assert_eq!(a, b);
        whole.tell(a.id, obs(&a, a.id)).unwrap();
        resumed.tell(b.id, obs(&b, b.id)).unwrap();
    }
    assert_eq!(resumed.into_sink(), whole.into_sink());
}

#[test]
fn edited_doubled_or_missing_events_are_refused_with_their_position() {
    let mut log = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut log);
    let events = log.into_sink();
    // An edited record is caught as divergence, at its position.
    let tell = events
        .iter()
        .position(|e| matches!(e, Event::Tell { .. }))
        .unwrap();
    let mut edited = events.clone();
    if let Event::Tell { record } = &mut edited[tell] {
        let flipped = match record.observation {
            Observation::Paired { hf, lf } => Observation::Paired {
                hf: Run::new(!hf.failure, hf.runtime),
                lf,
            },
            Observation::HfOnly(hf) => Observation::HfOnly(Run::new(!hf.failure, hf.runtime)),
        };
        record.observation = flipped;
    }
    match journal::replay(edited) {
        Err(ReplayFailed {
            event: at,
            source: ReplayError::Diverged(_),
        }) => assert_eq!(at, tell as u64 + 1),
        other => panic!("expected divergence, got {other:?}"),
    }
    // A tell repeated is refused.
    let mut doubled = events.clone();
    doubled.insert(tell + 1, events[tell].clone());
    match journal::replay(doubled) {
        Err(ReplayFailed {
            event: at,
            source: ReplayError::Tell(TellError::AlreadyTold(_)),
        }) => {
            assert_eq!(at, tell as u64 + 2)
        }
        other => panic!("expected an already-told error, got {other:?}"),
    }
    // An ask that the kernel would not draw is divergence.
    let ask = events
        .iter()
        .position(|e| matches!(e, Event::Ask { .. }))
        .unwrap();
    let mut skipped = events.clone();
    skipped.remove(ask);
    assert!(matches!(
        journal::replay(skipped),
        Err(ReplayFailed {
            source: ReplayError::Diverged(_),
            ..
        })
    ));
    assert!(matches!(
        journal::replay(Vec::new()),
        Err(ReplayFailed {
            event: 1,
            source: ReplayError::MissingStart
        })
    ));
    assert!(matches!(
        journal::replay(events[1..].to_vec()),
        Err(ReplayFailed {
            event: 1,
            source: ReplayError::MissingStart
        })
    ));
    let mut two_starts = events.clone();
    two_starts.insert(2, events[0].clone());
    assert!(matches!(
        journal::replay(two_starts),
        Err(ReplayFailed {
            event: 3,
            source: ReplayError::BadStart(_)
        })
    ));
}

/// A sink that fails after `budget` successful events.
struct Flaky {
    budget: usize,
    events: Vec<Event>,
}

#[derive(Debug, thiserror::Error)]
#[error("disk full")]
struct DiskFull;

impl journal::Sink for Flaky {
    type Error = DiskFull;
    fn record(&mut self, event: &Event) -> Result<(), DiskFull> {
        if self.budget == 0 {
            return Err(DiskFull);
        }
        self.budget -= 1;
        self.events.push(event.clone());
        Ok(())
    }
}

#[test]
fn a_failed_write_changes_nothing() {
    let config = common::kernel().config().clone();
    let mut log = Journaled::start(
        config,
        Flaky {
            budget: 2,
            events: Vec::new(),
        },
    )
    .unwrap();
    let t = log.ask().unwrap(); // second event
    let before = log.kernel().to_json();
    assert!(log.ask().is_err());
    assert_eq!(log.kernel().to_json(), before);
    let r = log.tell(t.id, obs(&t, 1));
    assert!(matches!(r, Err(JournaledTellError::Sink(DiskFull))));
    assert_eq!(log.kernel().to_json(), before);
    assert!(matches!(log.cancel(t.id), Err(JournaledTellError::Sink(_))));
    assert!(matches!(
        log.tell(77, obs(&t, 1)),
        Err(JournaledTellError::Tell(TellError::Unknown(77)))
    ));
    assert_eq!(log.kernel().to_json(), before);
    assert_eq!(log.sink().events.len(), 2);
}
