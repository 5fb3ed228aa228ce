//! The paper-faithful default is unchanged: the journal `savme serve` wrote before the search
//! models and robustness existed (`tests/fixtures/serve-toy.journal.jsonl` of the workspace)
//! replays — every ask reproduces its logged trial — and every event re-serialises to the same
//! JSON.
use savme_kernel::journal::{self, Event};

#[test]
fn the_pre_search_journal_replays_and_reserialises_unchanged() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/fixtures/serve-toy.journal.jsonl"
    );
    let text = std::fs::read_to_string(path).expect("the workspace fixture");
    let mut events = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let event: Event = serde_json::from_str(line).expect("an event");
        let again = serde_json::to_value(&event).expect("serialisable");
        let logged: serde_json::Value = serde_json::from_str(line).expect("JSON");
        assert_eq!(again, logged, "re-serialised differently: {line}");
        events.push(event);
    }
    assert!(events.len() >= 10);
    let replay = journal::replay(events).expect("the default kernel draws the logged trials");
    assert_eq!(replay.records.len(), 5);
    assert!(replay.kernel.config().search.is_independent_bins());
}
