//! The CPU and wall times README.md quotes are measured, and current (issue 39 item 4):
//! `docs/numbers.json` records each phrase that holds one, the generator that measured it
//! (`scripts/numbers` for the campaign times), when, and the sha256 of the generator's inputs.
//! This test fails when a time figure in README.md lies in no recorded phrase (typed by hand),
//! when a recorded phrase is not in README.md or is not its template rendered with its values,
//! and when a generator's inputs changed after its numbers were measured (run
//! `scripts/numbers`). A number marked `stale` (with the reason) is listed loudly instead.
use crate::common;

use common::manifest::{inputs_hash, root};
use serde_json::Value;

/// `text` with every run of whitespace one space.
fn normalised(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Byte spans of every time figure in `text`: a number (digits with `.`, `,`, `–`, `~`)
/// followed by a time unit — µs, ms, CPU-seconds, CPU-s, min, or s of wall / s wall.
fn time_figures(text: &str) -> Vec<(usize, usize)> {
    const UNITS: [&str; 7] = [
        "µs",
        "ms",
        "CPU-seconds",
        "CPU-s",
        "min",
        "s of wall",
        "s wall",
    ];
    let mut spans = Vec::new();
    for unit in UNITS {
        for (at, _) in text.match_indices(unit) {
            let end = at + unit.len();
            // A whole word: not the start of a longer one ("minimum", "msg").
            if text[end..]
                .chars()
                .next()
                .is_some_and(char::is_alphanumeric)
            {
                continue;
            }
            let head = text[..at].trim_end();
            let number_start = head
                .char_indices()
                .rev()
                .take_while(|(_, c)| c.is_ascii_digit() || ".,–~".contains(*c))
                .last()
                .map(|(i, _)| i);
            match number_start {
                Some(start) if head[start..].chars().any(|c| c.is_ascii_digit()) => {
                    spans.push((start, end))
                }
                _ => {}
            }
        }
    }
    spans
}

/// `template` with each `{key}` replaced by its value (`date`: the measurement's date).
fn render(template: &str, values: &Value, date: &str) -> String {
    let mut out = template.to_string();
    for (k, v) in values.as_object().expect("values") {
        out = out.replace(&format!("{{{k}}}"), v.as_str().expect("a value as text"));
    }
    out.replace("{date}", date)
}

#[test]
fn every_time_figure_in_the_readme_is_measured_and_current() {
    let readme = normalised(&std::fs::read_to_string(root().join("README.md")).unwrap());
    let m: Value =
        serde_json::from_str(&std::fs::read_to_string(root().join("docs/numbers.json")).unwrap())
            .unwrap();
    let mut problems = Vec::new();
    let mut covered = Vec::new();
    for n in m["numbers"].as_array().expect("numbers") {
        let id = n["id"].as_str().expect("id");
        let phrase = normalised(n["phrase"].as_str().expect("phrase"));
        match readme.find(&phrase) {
            Some(at) => covered.push((at, at + phrase.len())),
            None => problems.push(format!("{id}: README.md does not hold {phrase:?}")),
        }
        let generator = n["generator"].as_str().expect("generator");
        let g = &m["generators"][generator];
        if let Some(why) = n["stale"].as_str() {
            assert!(!why.trim().is_empty(), "{id}: stale without a reason");
            eprintln!("STALE NUMBER {id} ({generator}): {why}");
            continue;
        }
        let date = n["measured"].as_str().unwrap_or("?");
        if normalised(&render(n["template"].as_str().unwrap(), &n["values"], date)) != phrase {
            problems.push(format!(
                "{id}: the phrase is not its template rendered with its values (edited by hand? run scripts/numbers --record)"
            ));
        }
        if n["inputs_sha256"] != inputs_hash(g["inputs"].as_array().expect("inputs")).as_str() {
            problems.push(format!(
                "{id}: what it measured ({}) changed after it was measured on {date}: run {}",
                g["inputs"], g["command"]
            ));
        }
    }
    for (start, end) in time_figures(&readme) {
        if !covered.iter().any(|&(a, b)| a <= start && end <= b) {
            problems.push(format!(
                "README.md: the time figure {:?} (in \"…{}…\") is in no phrase of docs/numbers.json: measure it with scripts/numbers or record it there",
                &readme[start..end],
                &readme[start.saturating_sub(60)..(end + 20).min(readme.len())]
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The scanner finds the figures the README writes, and only those.
#[test]
fn time_figures_are_found() {
    let text = "takes 2 min 20 s; 60 CPU-seconds and 49 s of wall time; about 2 µs, ~90 µs, \
                55–95 ms; the minimum of 3 msgs; every 10 s; min/max";
    let found: Vec<&str> = time_figures(text)
        .into_iter()
        .map(|(a, b)| &text[a..b])
        .collect();
    for want in [
        "2 min",
        "60 CPU-seconds",
        "49 s of wall",
        "2 µs",
        "~90 µs",
        "55–95 ms",
    ] {
        assert!(found.contains(&want), "{want} not in {found:?}");
    }
    assert_eq!(found.len(), 6, "{found:?}");
}
