//! Every committed figure is drawn by the current code (issue 30 item 2): `docs/figures.json`
//! records, per PNG under `docs/`, its generator (`scripts/figures SET`), when it was drawn,
//! the sha256 of the generator's inputs (the code that draws it) and of the PNG. This test
//! fails when a generator's inputs changed after its figures were drawn, when a PNG is not
//! the one recorded, and when a PNG under docs/ has no entry. A figure the manifest marks
//! `stale` (with the reason it could not be redrawn) is listed loudly instead.
use crate::common;

use common::manifest::{hex, inputs_hash, root};
use serde_json::Value;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Every PNG under docs/.
fn pngs(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            pngs(&p, out);
        } else if p.extension().is_some_and(|e| e == "png") {
            out.push(p);
        }
    }
}

#[test]
fn every_committed_figure_is_drawn_by_its_current_generator() {
    let text = std::fs::read_to_string(root().join("docs/figures.json")).unwrap();
    let m: Value = serde_json::from_str(&text).unwrap();
    let figures = m["figures"].as_object().expect("figures");
    let mut problems = Vec::new();
    let mut all = Vec::new();
    pngs(&root().join("docs"), &mut all);
    for p in &all {
        let rel = p
            .strip_prefix(root())
            .unwrap()
            .to_string_lossy()
            .into_owned();
        if !figures.contains_key(&rel) {
            problems.push(format!(
                "{rel}: not in docs/figures.json (add it to a generator and run scripts/figures)"
            ));
        }
    }
    for (name, g) in m["generators"].as_object().expect("generators") {
        let now = inputs_hash(g["inputs"].as_array().expect("inputs"));
        for fig in g["figures"].as_array().expect("figures") {
            let fig = fig.as_str().unwrap();
            let e = &figures[fig];
            assert_eq!(e["generator"], name.as_str(), "{fig}");
            let png = std::fs::read(root().join(fig)).unwrap_or_default();
            if e["png_sha256"] != hex(&Sha256::digest(&png)).as_str() {
                problems.push(format!(
                    "{fig}: the PNG is not the one recorded (drawn by hand? run scripts/figures {name})"
                ));
            }
            if let Some(why) = e["stale"].as_str() {
                assert!(!why.trim().is_empty(), "{fig}: stale without a reason");
                eprintln!(
                    "STALE FIGURE {fig} (drawn {}): {why}",
                    e["drawn"].as_str().unwrap_or("?")
                );
            } else if e["inputs_sha256"] != now.as_str() {
                problems.push(format!(
                    "{fig}: its generator ({}) changed after it was drawn on {}: run scripts/figures {name}",
                    g["inputs"],
                    e["drawn"].as_str().unwrap_or("?")
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
