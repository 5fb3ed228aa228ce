//! Snapshots and the trial journal: exact state, crash tails, corrupt lines, failed writes.
mod common;
use savme_kernel::journal::{self, JournalError, Journaled, JournaledTellError};
use savme_kernel::{Kernel, Observation, Phase, Run, TellError, Trial};

fn obs(t: &Trial, i: u64) -> Observation {
    let hf = Run::new(i % 3 == 0, 1.0 + (i % 5) as f64);
    match t.phase {
        Phase::Baseline => Observation::HfOnly(hf),
        _ => Observation::Paired {
            hf,
            lf: Run::new(i % 4 == 0, 0.1 + (i % 7) as f64 / 10.0),
        },
    }
}

/// Runs a mixed session on a journaled kernel: batches of asks told out of order, a cancel, phase
/// switches. Leaves a few trials pending.
fn session(log: &mut Journaled<Vec<u8>>) {
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
    let bytes = log.into_writer();
    let r = journal::replay(&bytes[..]).unwrap();
    assert!(r.truncated.is_none());
    assert_eq!(r.valid_len, bytes.len() as u64);
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
    let bytes = first.into_writer();
    let replay = journal::replay(&bytes[..]).unwrap();
    let mut resumed = Journaled::resume(&replay, bytes);
    for _ in 0..5 {
        let a = whole.ask().unwrap();
        let b = resumed.ask().unwrap();
        assert_eq!(a, b);
        whole.tell(a.id, obs(&a, a.id)).unwrap();
        resumed.tell(b.id, obs(&b, b.id)).unwrap();
    }
    assert_eq!(resumed.into_writer(), whole.into_writer());
}

#[test]
fn a_truncated_last_line_is_reported_and_earlier_records_kept() {
    let mut log = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut log);
    let full = log.into_writer();
    let complete = journal::replay(&full[..]).unwrap();
    // Cut the file inside its last line, as a crash mid-write would.
    let last_start = full[..full.len() - 1]
        .iter()
        .rposition(|&b| b == b'\n')
        .unwrap()
        + 1;
    for cut in [last_start + 1, full.len() - 1] {
        let r = journal::replay(&full[..cut]).unwrap();
        let tail = r.truncated.clone().expect("tail reported");
        assert_eq!(tail.line, complete.lines);
        assert_eq!(tail.bytes, cut - last_start);
        assert_eq!(r.valid_len, last_start as u64);
        assert_eq!(r.lines, complete.lines - 1);
        // Everything before the torn line is there.
        let told_before = complete.records.len()
            - usize::from(full[last_start..].starts_with(b"{\"event\":\"tell\""));
        assert_eq!(r.records.len(), told_before);
    }
}

#[test]
fn a_corrupt_middle_line_is_an_error_naming_the_line() {
    let mut log = Journaled::start(common::kernel().config().clone(), Vec::new()).unwrap();
    session(&mut log);
    let text = String::from_utf8(log.into_writer()).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[4] = "{\"event\":\"ask\",\"trial\":{\"garbage";
    let broken = lines.join("\n") + "\n";
    match journal::replay(broken.as_bytes()) {
        Err(JournalError::Corrupt { line, .. }) => assert_eq!(line, 5),
        other => panic!("expected a corrupt-line error, got {other:?}"),
    }
    // An edited (well-formed) record is caught as divergence.
    let edited = text.replacen("\"failure\":true", "\"failure\":false", 1);
    assert!(matches!(
        journal::replay(edited.as_bytes()),
        Err(JournalError::Diverged { .. })
    ));
    // A tell of an unknown trial is refused with its line.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let tell = lines
        .iter()
        .position(|l| l.starts_with("{\"event\":\"tell\""))
        .unwrap();
    let dup = lines[tell].clone();
    lines.insert(tell + 1, dup);
    let doubled = lines.join("\n") + "\n";
    match journal::replay(doubled.as_bytes()) {
        Err(JournalError::Tell {
            line,
            source: TellError::AlreadyTold(_),
        }) => assert_eq!(line, tell as u64 + 2),
        other => panic!("expected an already-told error, got {other:?}"),
    }
    assert!(matches!(
        journal::replay(&b""[..]),
        Err(JournalError::MissingStart)
    ));
    let no_start = lines[1..].join("\n") + "\n";
    assert!(matches!(
        journal::replay(no_start.as_bytes()),
        Err(JournalError::MissingStart)
    ));
}

/// A writer that fails after `budget` successful writes.
struct Flaky {
    budget: usize,
    data: Vec<u8>,
}
impl std::io::Write for Flaky {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.budget == 0 {
            return Err(std::io::Error::other("disk full"));
        }
        self.budget -= 1;
        self.data.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
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
            data: Vec::new(),
        },
    )
    .unwrap();
    let t = log.ask().unwrap(); // second write
    let before = log.kernel().to_json();
    assert!(matches!(log.ask(), Err(JournalError::Io { line: 3, .. })));
    assert_eq!(log.kernel().to_json(), before);
    let r = log.tell(t.id, obs(&t, 1));
    assert!(matches!(r, Err(JournaledTellError::Journal(_))));
    assert_eq!(log.kernel().to_json(), before);
    assert!(matches!(
        log.cancel(t.id),
        Err(JournaledTellError::Journal(_))
    ));
    assert!(matches!(
        log.tell(77, obs(&t, 1)),
        Err(JournaledTellError::Tell(TellError::Unknown(77)))
    ));
    assert_eq!(log.kernel().to_json(), before);
}
