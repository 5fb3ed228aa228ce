//! The JSON Schemas in `docs/schemas/` are what `savme::json::schemas()` generates from the
//! types (regenerate with `SAVME_BLESS_SCHEMAS=1 cargo test --test it schemas::`), and every JSON
//! document the command line prints validates against its schema — checked on real outputs
//! (boon, a JSON Schema 2020-12 validator).
use crate::common;

use common::{made_dir, savme, TINY_PROTOCOL};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn schema_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs/schemas")
        .join(format!("{name}.schema.json"))
}

#[test]
fn committed_schemas_are_the_generated_ones() {
    let bless = std::env::var_os("SAVME_BLESS_SCHEMAS").is_some();
    let mut stale = Vec::new();
    for (name, schema) in savme::json::schemas() {
        let text = serde_json::to_string_pretty(&schema).unwrap() + "\n";
        let path = schema_path(name);
        if bless {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &text).unwrap();
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            stale.push(path.display().to_string());
        }
    }
    assert!(
        stale.is_empty(),
        "these schemas differ from the types (regenerate with SAVME_BLESS_SCHEMAS=1 cargo test --test it schemas::): {stale:?}"
    );
}

/// Validates `doc` against the committed schema `name`; the message names the document.
fn check(name: &str, doc: &Value, what: &str) {
    let mut schemas = boon::Schemas::new();
    let mut compiler = boon::Compiler::new();
    let path = schema_path(name);
    let schema: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let url = format!("file://{}", path.display());
    compiler.add_resource(&url, schema).unwrap();
    let index = compiler.compile(&url, &mut schemas).unwrap();
    if let Err(e) = schemas.validate(doc, index) {
        panic!("{what} does not match {name}.schema.json: {e:#}\n{doc:#}");
    }
    assert_eq!(doc["format_version"], 1, "{what}: {doc}");
}

fn json_of(args: &[&str]) -> Value {
    let (ok, out, err) = savme(args);
    assert!(ok, "savme {args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("savme {args:?}: {e}: {out}"))
}

#[test]
fn scenarios_and_fidelity_documents_match_their_schemas() {
    let scenarios = json_of(&["scenarios", "--json"]);
    check("scenarios", &scenarios, "scenarios --json");
    assert_eq!(scenarios["scenarios"].as_array().map(Vec::len), Some(10));
    let fidelity = json_of(&["fidelity", "--json"]);
    check("fidelity", &fidelity, "fidelity --json");
    assert_eq!(fidelity["settings"].as_array().map(Vec::len), Some(16));
    // The schemas say what each holds: a scenario's role and a setting's kind are closed lists.
    for (name, doc) in [("scenarios", &scenarios), ("fidelity", &fidelity)] {
        let text = std::fs::read_to_string(schema_path(name)).unwrap();
        for word in ["continuous", "format_version"] {
            assert!(text.contains(word), "{name}.schema.json has no {word}");
        }
        assert!(doc.is_object());
    }
    let text = std::fs::read_to_string(schema_path("scenarios")).unwrap();
    assert!(text.contains("meta-testing"), "{text}");
}

#[test]
fn simulate_and_fmu_documents_match_their_schemas() {
    let phi = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    let base = ["simulate", "--scenario", "7", "--phi", phi, "--json"];
    let sensors = json_of(&base);
    check("simulate", &sensors, "simulate --json");
    assert_eq!(sensors["perception"], "sensors");
    assert_eq!(sensors["ignored_settings"], serde_json::json!([]));
    let ideal = json_of(&[&base[..], &["--perception", "ideal"]].concat());
    check("simulate", &ideal, "simulate --perception ideal --json");
    assert_eq!(ideal["ignored_settings"].as_array().unwrap().len(), 15);

    let dir = made_dir("fmu");
    let fmu = dir.join("sim.fmu");
    let (ok, _, err) = savme(&["fmu", "pack", "--fmi", "3", "--out", fmu.to_str().unwrap()]);
    assert!(ok, "{err}");
    let info = json_of(&["fmu", "info", "--json", fmu.to_str().unwrap()]);
    check("fmu-info", &info, "fmu info --json");
    assert_eq!(info["model"]["fmi_version"], "3.0", "{info}");
    let valid = json_of(&["fmu", "validate", "--json", fmu.to_str().unwrap()]);
    check("fmu-validate", &valid, "fmu validate --json (valid)");
    assert_eq!(valid["valid"], true);
    // A broken FMU: the report still prints (exit status 1) and matches.
    let broken = dir.join("broken.fmu");
    std::fs::write(&broken, "not a zip archive").unwrap();
    let (ok, out, _) = savme(&["fmu", "validate", "--json", broken.to_str().unwrap()]);
    assert!(!ok);
    let invalid: Value = serde_json::from_str(&out).unwrap();
    check("fmu-validate", &invalid, "fmu validate --json (broken)");
    assert_eq!(invalid["valid"], false);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn campaign_documents_match_their_schemas() {
    let dir = made_dir("campaign");
    let out = dir.join("ideal");
    let args = [
        &[
            "reproduce",
            "--perception",
            "ideal",
            "--out",
            out.to_str().unwrap(),
        ],
        TINY_PROTOCOL,
    ]
    .concat();
    let (ok, _, err) = savme(&args);
    assert!(ok, "{err}");
    let (ok, lines, err) = savme(&["failures", "--json", out.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(lines.lines().count() > 0, "no failures: {lines}");
    for line in lines.lines() {
        let v: Value = serde_json::from_str(line).unwrap();
        check("failures-line", &v, "a failures --json line");
        // An idealised-perception campaign's failures replay with that perception.
        let replay = v["replay"].as_str().expect("a replay command");
        assert!(replay.ends_with(" --perception ideal"), "{replay}");
    }

    let estimate = json_of(&[
        "estimate",
        out.to_str().unwrap(),
        "--max-runs",
        "200",
        "--no-target",
        "--json",
        "--quiet",
    ]);
    check("estimate-summary", &estimate, "estimate --json");
    let file = out.join("estimate-0.3").join("summary.json");
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    check("estimate-summary", &summary, "an estimate's summary.json");
    assert_eq!(summary, estimate);

    // The toy simulator's failures have no replay command, and say why.
    let toy = dir.join("toy");
    let (ok, _, err) = savme(&[
        "toy",
        "--quiet",
        "--jobs",
        "1",
        "--out",
        toy.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let (ok, lines, err) = savme(&["failures", "--json", toy.to_str().unwrap()]);
    assert!(ok, "{err}");
    let first: Value = serde_json::from_str(lines.lines().next().expect("a toy failure")).unwrap();
    check(
        "failures-line",
        &first,
        "a toy campaign's failures --json line",
    );
    assert!(first["replay"].is_null());
    let why = first["replay_unavailable"].as_str().unwrap_or_default();
    assert!(why.contains("savme-toy"), "{first}");
    let _ = std::fs::remove_dir_all(&dir);
}
