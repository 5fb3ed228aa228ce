//! `savme` on a simulator nobody in this project wrote: the Modelica Association's Reference FMU
//! BouncingBall (`examples/fmu/bouncing_ball/reference-fmus`, vendored unchanged), built by the
//! example's `build.sh` with the system C compiler and run through the example campaign file —
//! the peer benchmark's fifth family (benches/peers/README.md).
use crate::common;

use common::{made_dir, savme, trial_lines};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The example's directory in the source tree.
fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fmu/bouncing_ball")
}

/// `dir` with BouncingBall.fmu built by the example's build.sh and the example campaign file.
fn built(name: &str) -> (PathBuf, PathBuf) {
    let dir = made_dir(name);
    let status = Command::new(example().join("build.sh"))
        .arg(&dir)
        .status()
        .expect("build.sh runs");
    assert!(status.success(), "build.sh failed");
    let config = dir.join("campaign.toml");
    std::fs::copy(example().join("campaign.toml"), &config).unwrap();
    (dir, config)
}

/// The closed-form verdict of a ball starting at height `h` with velocity `v` (up > 0) under
/// gravity `g` (< 0): it fails when it first hits the floor faster than 7 m/s within 3 s. `None`
/// near the threshold or the horizon, where the model's fixed-step Euler and the 0.01 s
/// communication step may decide either way.
fn expected(h: f64, v: f64, g: f64) -> Option<bool> {
    let speed = (v * v - 2.0 * g * h).sqrt();
    let time = (v + speed) / -g;
    if (speed - 7.0).abs() < 0.15 || (time - 3.0).abs() < 0.05 {
        return None;
    }
    Some(speed > 7.0 && time < 3.0)
}

fn gravity(scenario: &str) -> f64 {
    match scenario {
        "earth" => -9.81,
        "mars" => -3.71,
        "moon" => -1.62,
        other => panic!("unexpected scenario {other}"),
    }
}

fn failure(run: &Value) -> bool {
    run["failure"].as_bool().expect("a verdict")
}

/// The example campaign runs the whole protocol on the Reference FMU; every HF verdict away
/// from the boundary is the physics' (impact speed and time in closed form); every LF run
/// (a coarser communication step: `v` read less often on the same 1 ms Euler trajectory) that
/// fails is an HF failure too — the coarse step can only miss the fastest instant, never invent
/// one — and a failing run ends at its impact, cheaper than a pass.
#[test]
fn the_reference_fmu_campaign_judges_as_the_physics_and_lf_only_misses() {
    let (dir, config) = built("reference-fmu-ball");
    let out = dir.join("out");
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let trials = trial_lines(&out);
    let (mut checked, mut failures, mut lf_failures) = (0, 0, 0);
    for t in &trials {
        let scenario = t["scenario"].as_str().unwrap();
        let (h, v) = (
            t["phi"]["h"].as_f64().unwrap(),
            t["phi"]["v"].as_f64().unwrap(),
        );
        let hf = &t["hf"];
        if hf.is_object() {
            if let Some(want) = expected(h, v, gravity(scenario)) {
                assert_eq!(failure(hf), want, "trial {t}");
                checked += 1;
            }
            let work = hf["work"].as_u64().unwrap();
            if failure(hf) {
                failures += 1;
                assert!(work < 300, "a failing run ends at its impact: {t}");
            } else {
                assert_eq!(work, 300, "a pass runs 3 s in 0.01 s steps: {t}");
            }
            if t["lf"].is_object() && failure(&t["lf"]) {
                lf_failures += 1;
                assert!(failure(hf), "an LF failure that HF does not confirm: {t}");
            }
        }
    }
    assert!(checked > 300, "only {checked} HF verdicts checked");
    assert!(
        failures > 20 && lf_failures > 0,
        "{failures} HF failures, {lf_failures} LF"
    );
}
