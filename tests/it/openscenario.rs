//! OpenSCENARIO parameter value distributions written by a third-party generator (PyPI
//! `scenariogeneration`, run here in the interop virtual environment `scripts/test` makes):
//! read into φ-spaces and nominals, then driving an FMU campaign (the `braking` example) and
//! its estimate — `savme run --config` and `savme estimate --config` — and a bad file refused
//! through the campaign file, naming both files, their lines, the key and the element.
use crate::common;

use common::{made_dir, savme};
use savme_kernel::estimation::Nominal;
use savme_kernel::Value;
use savme_openscenario::{Domain, ParameterDistribution, Variation};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The interop environment's python (`SAVME_INTEROP_PYTHON`, set by `scripts/test`, which
/// also sets `SAVME_REQUIRE_INTEROP=1`: then a missing one fails instead of skipping).
fn interop_python() -> Option<String> {
    let python = std::env::var("SAVME_INTEROP_PYTHON").ok();
    let required = std::env::var("SAVME_REQUIRE_INTEROP").is_ok_and(|v| v == "1");
    match python {
        Some(p) => Some(p),
        None if required => panic!("SAVME_REQUIRE_INTEROP=1 but SAVME_INTEROP_PYTHON is not set"),
        None => {
            eprintln!(
                "SKIPPED: the OpenSCENARIO generator tests need SAVME_INTEROP_PYTHON (a python \
                 with scenariogeneration; scripts/test makes one)"
            );
            None
        }
    }
}

/// Writes the variation files with scenariogeneration into `dir`.
const GENERATE: &str = r#"
import sys
from scenariogeneration import xosc

out = sys.argv[1]
# The dry road: speed normal around 16 m/s, the gap uniform, both with ranges.
st = xosc.Stochastic(200, 7)
st.add_distribution("speed0", xosc.NormalDistribution(16.0, 9.0, xosc.Range(8.0, 25.0)))
st.add_distribution("gap", xosc.UniformDistribution(xosc.Range(10.0, 60.0)))
xosc.ParameterValueDistribution("dry road variation", "savme test", "braking.xosc", st
    ).write_xml(f"{out}/dry_road.xosc")

# The wet road: a log-normal gap and a histogram of speeds, named as the scenario names them
# (the campaign binds them to the FMU's variables).
st = xosc.Stochastic(100)
h = xosc.Histogram()
h.add_bin(1.0, xosc.Range(8.0, 12.0))
h.add_bin(3.0, xosc.Range(12.0, 20.0))
st.add_distribution("InitialSpeed", h)
st.add_distribution("Gap", xosc.LogNormalDistribution(35.0, 100.0, xosc.Range(10.0, 80.0)))
xosc.ParameterValueDistribution("wet road variation", "savme test", "braking.xosc", st
    ).write_xml(f"{out}/wet_road.xosc")

# The icy road: a deterministic grid of speeds and a set of gaps.
de = xosc.Deterministic()
de.add_single_distribution("speed0", xosc.DistributionRange(1.0, xosc.Range(4.0, 15.0)))
gaps = xosc.DistributionSet()
for g in ("10", "25", "40", "70", "100"):
    gaps.add_value(g)
de.add_single_distribution("gap", gaps)
xosc.ParameterValueDistribution("icy road variation", "savme test", "braking.xosc", de
    ).write_xml(f"{out}/icy_road.xosc")

# Probability sets and a Poisson count (read only: the braking FMU has no such parameters).
st = xosc.Stochastic(10)
p = xosc.ProbabilityDistributionSet()
p.add_set("dry", 0.6)
p.add_set("wet", 0.3)
p.add_set("ice", 0.1)
st.add_distribution("Road", p)
st.add_distribution("Cars", xosc.PoissonDistribution(2.0, xosc.Range(0.0, 6.0)))
xosc.ParameterValueDistribution("sets", "savme test", "traffic.xosc", st
    ).write_xml(f"{out}/sets.xosc")

# A normal without a range: refused by savme (its φ-space is bounded).
st = xosc.Stochastic(10)
st.add_distribution("speed0", xosc.NormalDistribution(16.0, 9.0))
xosc.ParameterValueDistribution("unbounded", "savme test", "braking.xosc", st
    ).write_xml(f"{out}/unbounded.xosc")
"#;

/// The generated files' directory (generated once per test process), or None to skip.
fn generated() -> Option<&'static Path> {
    static DIR: OnceLock<Option<PathBuf>> = OnceLock::new();
    DIR.get_or_init(|| {
        let python = interop_python()?;
        let dir = made_dir("generated");
        let out = Command::new(&python)
            .args(["-c", GENERATE])
            .arg(&dir)
            .output()
            .unwrap_or_else(|e| panic!("{python}: {e}"));
        assert!(
            out.status.success(),
            "scenariogeneration failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        Some(dir)
    })
    .as_deref()
}

fn read(name: &str) -> Option<ParameterDistribution> {
    let path = generated()?.join(name);
    Some(ParameterDistribution::read(&path).unwrap_or_else(|e| panic!("{e}")))
}

#[test]
fn files_written_by_scenariogeneration_read_into_their_spaces_and_nominals() {
    let Some(dry) = read("dry_road.xosc") else {
        return;
    };
    assert_eq!(dry.scenario_file.as_deref(), Some("braking.xosc"));
    assert_eq!(
        dry.variation,
        Variation::Stochastic {
            runs: Some(200),
            seed: Some(7.0)
        }
    );
    let n = dry.nominal();
    assert_eq!(
        n["speed0"],
        Nominal::Normal {
            mean: 16.0,
            sd: 3.0
        }
    );
    assert!(!n.contains_key("gap"));
    assert_eq!(
        dry.parameter("gap").unwrap().domain,
        Domain::Continuous { lo: 10.0, hi: 60.0 }
    );

    let wet = read("wet_road.xosc").expect("generated");
    let n = wet.nominal();
    assert_eq!(
        n["InitialSpeed"],
        Nominal::Histogram {
            edges: vec![8.0, 12.0, 20.0],
            weights: vec![1.0, 3.0]
        }
    );
    let Nominal::LogNormal { mu, sigma } = n["Gap"] else {
        panic!("{:?}", n["Gap"])
    };
    let mean = (mu + sigma * sigma / 2.0).exp();
    assert!((mean - 35.0).abs() < 1e-9, "{mean}");

    let icy = read("icy_road.xosc").expect("generated");
    assert_eq!(icy.variation, Variation::Deterministic);
    assert!(icy.nominal().is_empty());
    let Domain::Values(speeds) = &icy.parameter("speed0").unwrap().domain else {
        panic!()
    };
    assert_eq!(speeds.len(), 12);
    assert_eq!(
        icy.parameter("gap").unwrap().domain,
        Domain::Values([10, 25, 40, 70, 100].map(Value::Int).to_vec())
    );

    let sets = read("sets.xosc").expect("generated");
    let n = sets.nominal();
    assert_eq!(
        n["Road"],
        Nominal::Weights {
            weights: vec![0.6, 0.3, 0.1]
        }
    );
    assert_eq!(
        sets.parameter("Road").unwrap().domain,
        Domain::Values(vec!["dry".into(), "wet".into(), "ice".into()])
    );
    let Nominal::Weights { weights } = &n["Cars"] else {
        panic!()
    };
    assert_eq!(weights.len(), 7);

    let path = generated().unwrap().join("unbounded.xosc");
    let e = ParameterDistribution::read(&path).unwrap_err().to_string();
    let at = format!("{}, line 8, element `NormalDistribution`: ", path.display());
    assert!(e.starts_with(&at) && e.contains("without a <Range>"), "{e}");
}

/// A braking campaign whose scenarios come from the generated files (the test scenario from
/// `icy`), with an `[estimate]` section.
fn campaign(dir: &Path, files: &Path, icy: &str) -> PathBuf {
    let fmu = common::braking::pack(dir, &common::braking::model_description());
    let text = format!(
        r#"[fmu]
hf = "{fmu}"
stop_time = 8.0
cost = "steps"

[failure]
boolean = "collision"

[campaign]
seed = 3
budgets = [0.3]
train_iterations = 40
eval_iterations = 10
test_iterations = 20
baseline_train_iterations = 40
baseline_test_iterations = 20
cost = "work"

[estimate]
max_runs = 60
target_width = 0.01
epsilon = 0.3

[fidelity]
[[fidelity.variable]]
name = "step"
drives = "step_size"
values = [0.4, 0.1, 0.02]
hf = 0.02

[[scenario]]
name = "dry_road"
role = "train"
fixed = {{ road = "dry" }}
openscenario = "{files}/dry_road.xosc"

[[scenario]]
name = "wet_road"
role = "train"
fixed = {{ road = "wet" }}
openscenario = "{files}/wet_road.xosc"
bind = {{ InitialSpeed = "speed0", Gap = "gap" }}

[[scenario]]
name = "icy_road"
role = "test"
fixed = {{ road = "ice" }}
openscenario = "{files}/{icy}"
"#,
        fmu = fmu.display(),
        files = files.display(),
    );
    let path = dir.join("campaign.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn json_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn generated_files_drive_a_campaign_and_its_estimate() {
    let Some(files) = generated() else {
        return;
    };
    let dir = made_dir("campaign");
    let config = campaign(&dir, files, "icy_road.xosc");
    let out = dir.join("out");
    let (ok, stdout, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    assert!(
        stdout.contains("# P(failure) under the nominal distribution"),
        "{stdout}"
    );
    // Every φ lies in what its file declares: the icy road's speeds on the 1 m/s grid, its
    // gaps from the set; the wet road's speeds inside the histogram.
    let trials = json_lines(&out.join("trials.jsonl"));
    let phi = |t: &serde_json::Value, v: &str| t["phi"][v].as_f64().unwrap();
    let mut icy = 0;
    for t in trials.iter().filter(|t| t["phi"].is_object()) {
        match t["scenario"].as_str().unwrap() {
            "icy_road" => {
                icy += 1;
                let s = phi(t, "speed0");
                assert!((4.0..=15.0).contains(&s) && s.fract() == 0.0, "{t}");
                assert!(
                    [10.0, 25.0, 40.0, 70.0, 100.0].contains(&phi(t, "gap")),
                    "{t}"
                );
            }
            "wet_road" => assert!((8.0..=20.0).contains(&phi(t, "InitialSpeed")), "{t}"),
            "dry_road" => assert!((10.0..=60.0).contains(&phi(t, "gap")), "{t}"),
            other => panic!("scenario {other}"),
        }
    }
    assert!(icy > 0);
    // The estimate weighs by the files' distributions.
    let est = out.join("estimate-0.3");
    let settings: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(est.join("estimate.json")).unwrap()).unwrap();
    assert_eq!(
        settings["nominal"]["dry_road"]["speed0"],
        serde_json::json!({"distribution": "normal", "mean": 16.0, "sd": 3.0})
    );
    assert_eq!(
        settings["nominal"]["wet_road"]["Gap"]["distribution"],
        "lognormal"
    );
    assert_eq!(
        settings["nominal"]["wet_road"]["InitialSpeed"]["distribution"],
        "histogram"
    );
    let lines = json_lines(&est.join("trials.jsonl"));
    assert_eq!(lines.len(), 60);
    for l in &lines {
        // p is the nominal density of φ: the truncated normal × uniform on the dry road.
        if l["scenario"] == "dry_road" {
            let s = phi(l, "speed0");
            let normal = statrs::distribution::Normal::new(16.0, 3.0).unwrap();
            use statrs::distribution::{Continuous, ContinuousCDF};
            let mass = normal.cdf(25.0) - normal.cdf(8.0);
            let p = normal.pdf(s) / mass / 50.0;
            let logged = l["p"].as_f64().unwrap();
            assert!(
                (logged - p).abs() <= 1e-9 * p,
                "{l}: p = {logged}, expected {p}"
            );
        }
    }
    // `savme estimate --config` on the finished campaign takes the same nominals.
    let again = dir.join("again");
    let (ok, _, err) = savme(&[
        "estimate",
        out.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--max-runs",
        "60",
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let again_settings: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(again.join("estimate.json")).unwrap())
            .unwrap();
    assert_eq!(again_settings["nominal"], settings["nominal"]);
    // The same trials (the wall-clock seconds and the checksum over them aside).
    let again_lines = common::without_wall(json_lines(&again.join("trials.jsonl")));
    assert!(again_lines == common::without_wall(lines));
}

#[test]
fn a_bad_file_is_refused_through_the_campaign_naming_both_files() {
    let Some(files) = generated() else {
        return;
    };
    let dir = made_dir("bad");
    let config = campaign(&dir, files, "unbounded.xosc");
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    let xosc = files.join("unbounded.xosc");
    let expected = format!(
        "{}, line 48, key `scenario[2].openscenario`: {}, line 8, element `NormalDistribution`: a normal distribution without a <Range>",
        config.display(),
        xosc.display()
    );
    assert!(err.contains(&expected), "expected {expected}\ngot {err}");
    assert!(!dir.join("out").exists(), "nothing ran");
    // A `bind` naming no parameter of the file.
    let text = std::fs::read_to_string(&config)
        .unwrap()
        .replace("unbounded.xosc", "icy_road.xosc")
        .replace("InitialSpeed = \"speed0\"", "Initial_Speed = \"speed0\"");
    std::fs::write(&config, text).unwrap();
    let (ok, _, err) = savme(&["run", "--config", config.to_str().unwrap(), "--quiet"]);
    assert!(!ok);
    let expected = format!(
        "{}, line 42, key `scenario[1].bind.Initial_Speed`: `Initial_Speed` is no parameter of {} (its parameters: InitialSpeed, Gap)",
        config.display(),
        files.join("wet_road.xosc").display()
    );
    assert!(err.contains(&expected), "expected {expected}\ngot {err}");
}
