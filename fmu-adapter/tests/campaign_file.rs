//! Campaign files on the test-kit FMU: a good one loads into its parts; a binding the FMU does
//! not have, or of the wrong type, is named with its line and key.
mod common;
use savme_fmu::campaign_file::{ConfigError, FmuCampaignFile};
use savme_fmu::{CostSource, Failure, StepSize};
use savme_kernel::{Assignment, Space, Value};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

fn temp_dir(name: &str) -> PathBuf {
    common::temp_dir("savme-fmu-campaign", name)
}

use common::testkit_library;

/// The test-kit FMU, packed once.
fn packed() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let out = temp_dir("packed").join("testkit.fmu");
        savme_fmi_export::pack(
            &savme_fmu_testkit::model_description(),
            "savme_fmu_testkit",
            &testkit_library(),
            &out,
        )
        .unwrap();
        out
    })
}

/// A directory with the test-kit FMU as `testkit.fmu` and `body` as `campaign.toml`.
fn campaign(name: &str, body: &str) -> PathBuf {
    let dir = temp_dir(name);
    std::fs::copy(packed(), dir.join("testkit.fmu")).unwrap();
    let path = dir.join("campaign.toml");
    std::fs::write(&path, body).unwrap();
    path
}

fn no_paper(_: u32) -> (Space, Assignment) {
    panic!("the paper's space was asked for")
}

const GOOD: &str = r#"
[fmu]
hf = "testkit.fmu"
stop_time = 1.0
step = { rate_of = "rate" }
cost = "steps"
isolate = true
timeout_s = 5.0
on_error = "skip"

[failure]
boolean = "failed"

[campaign]
seed = 3
budgets = [0.5]
cost = "work"
out = "results"

[fidelity]
[[fidelity.variable]]
name = "rate"
values = [1.0, 2.0]
hf = 2.0

[[scenario]]
name = "grow"
role = "train"
fixed = { threshold = 0.5, fault = 0 }
[[scenario.phi]]
name = "start"
fmu = "x0"
range = [0.0, 1.0]
bins = 4

[[scenario]]
name = "slow"
role = "test"
weight = 2.0
fixed = { threshold = 0.9 }
[[scenario.phi]]
name = "x0"
range = [0.0, 0.5]
"#;

#[test]
fn a_good_file_loads_into_its_parts() {
    let path = campaign("good", GOOD);
    let dir = path.parent().unwrap();
    let f = FmuCampaignFile::load(&path, &no_paper).unwrap();
    let fmu = dir.join("testkit.fmu");
    assert_eq!(f.common.path, path);
    assert_eq!((&f.init.hf, &f.init.lf), (&fmu, &fmu));
    assert_eq!(f.label, format!("fmu:{}|{}", fmu.display(), fmu.display()));
    assert!(f.isolate && f.skip_failed_runs);
    assert_eq!(f.timeout, Duration::from_secs(5));
    assert_eq!(f.common.scenarios.train, ["grow"]);
    assert_eq!(f.common.scenarios.test, ["slow"]);
    assert_eq!(
        f.common.scenarios.weights.into_iter().collect::<Vec<_>>(),
        [("slow".to_string(), 2.0)]
    );
    // Where each scenario is, for protocol errors found later (role, weight).
    let lines: Vec<_> = f
        .common
        .scenarios
        .lines
        .iter()
        .map(|s| (s.name.as_str(), s.index, s.table, s.role, s.weight))
        .collect();
    assert_eq!(
        lines,
        [("grow", 0, 26, 28, None), ("slow", 1, 36, 38, Some(39))]
    );
    assert_eq!(
        f.common.fidelity.theta_hf,
        Assignment::new().with("rate", 2.0)
    );
    assert_eq!(f.common.fidelity.space.variables()[0].arms(), 2);
    assert_eq!(f.common.scenarios.spaces["grow"].variables()[0].arms(), 4);
    assert_eq!(f.init.phi, f.common.scenarios.spaces);
    // The run specification the simulator is built from.
    let spec = &f.init.spec;
    assert_eq!(spec.step, StepSize::RateOf("rate".into()));
    assert_eq!(spec.cost, CostSource::Output("steps".into()));
    assert!(
        matches!(&spec.failure, Failure::Boolean { variable, robustness: None } if variable == "failed")
    );
    let grow = &spec.scenarios[0];
    assert_eq!(grow.phi[0].fmu_variable, "x0");
    let fixed: Vec<(&str, &Value)> = grow
        .fixed
        .iter()
        .map(|x| (x.fmu_variable.as_str(), &x.value))
        .collect();
    assert_eq!(
        fixed,
        [("fault", &Value::Int(0)), ("threshold", &Value::Real(0.5))]
    );
    // The [campaign] section as written, with its lines.
    let c = &f.common.campaign;
    assert_eq!(c.values["seed"], toml::Value::Integer(3));
    assert_eq!(c.values["cost"], toml::Value::String("work".into()));
    assert_eq!(c.values["budgets"], toml::Value::Array(vec![0.5.into()]));
    assert!(!c.values.contains_key("train_iterations"));
    assert_eq!(c.out, Some(dir.join("results")));
    assert_eq!(c.lines["seed"], 15);
    assert_eq!(c.lines["budgets"], 16);
    // The simulator builds from it.
    f.init.simulator().unwrap();
}

fn error(name: &str, from: &str, to: &str) -> ConfigError {
    assert!(GOOD.contains(from), "{from}");
    let path = campaign(name, &GOOD.replacen(from, to, 1));
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(e.file, path.display().to_string());
    e
}

#[test]
fn fmu_bindings_are_named_with_their_line_and_key() {
    for (from, to, line, key, message) in [
        (
            "fmu = \"x0\"",
            "fmu = \"x00\"",
            32,
            "scenario[0].phi[0].fmu",
            "no variable `x00`",
        ),
        (
            "name = \"x0\"",
            "name = \"y0\"",
            42,
            "scenario[1].phi[0].name",
            "no variable `y0`",
        ),
        (
            "boolean = \"failed\"",
            "boolean = \"x\"",
            12,
            "failure.boolean",
            "variable `x` is Real, expected Boolean",
        ),
        (
            "fault = 0",
            "fault = true",
            29,
            "scenario[0].fixed.fault",
            "variable `fault` is Integer",
        ),
        (
            "cost = \"steps\"",
            "cost = \"stepz\"",
            6,
            "fmu.cost",
            "no variable `stepz`",
        ),
        (
            "hf = 2.0",
            "hf = 2.0\nfmu = \"rat\"",
            25,
            "fidelity.variable[0].fmu",
            "no variable `rat`",
        ),
    ] {
        let e = error("binding", from, to);
        assert_eq!((e.line, e.key.as_deref()), (Some(line), Some(key)), "{e}");
        assert!(e.message.contains(message), "{message}: {e}");
    }
}

/// Issue 42: `[failure] robustness` names an output of the FMUs, Real or Integer, checked like
/// every other binding and named at its line and key; a good one reaches the run
/// specification.
#[test]
fn a_robustness_output_is_checked_at_its_line_and_key() {
    let flag = "boolean = \"failed\"";
    for (to, message) in [
        ("robustness = \"y\"", "no variable `y`"),
        (
            "robustness = \"failed\"",
            "variable `failed` is Boolean, expected Real or Integer",
        ),
        (
            "robustness = \"x0\"",
            "variable `x0` cannot be used here: expected an output",
        ),
    ] {
        let e = error("robustness", flag, &format!("{flag}\n{to}"));
        let at = (e.line, e.key.as_deref());
        assert_eq!(at, (Some(13), Some("failure.robustness")), "{e}");
        assert!(e.message.contains(message), "{message}: {e}");
    }
    let path = campaign(
        "robustness-good",
        &GOOD.replacen(flag, &format!("{flag}\nrobustness = \"x\""), 1),
    );
    let f = FmuCampaignFile::load(&path, &no_paper).unwrap();
    let failure = &f.init.spec.failure;
    let expected = Failure::Boolean {
        variable: "failed".into(),
        robustness: Some("x".into()),
    };
    assert_eq!(failure, &expected);
    f.init.simulator().unwrap();
}

/// An FMU variable used twice is blamed on the binding the error is about: the FMU check looks
/// at the failure signal, the cost, the fidelity settings and each scenario in turn.
#[test]
fn a_binding_error_is_put_on_the_use_that_failed() {
    for (from, to, line, key, message) in [
        // The failure signal is fine as a Boolean; as the cost it is not.
        (
            "cost = \"steps\"",
            "cost = \"failed\"",
            6,
            "fmu.cost",
            "variable `failed` is Boolean, expected Real or Integer",
        ),
        // Inputs as the failure signal or the cost, outputs as inputs: refused by causality, at
        // the binding that reads (or sets) it.
        (
            "boolean = \"failed\"",
            "boolean = \"x0\"",
            12,
            "failure.boolean",
            "variable `x0` cannot be used here: expected an output",
        ),
        (
            "cost = \"steps\"",
            "cost = \"x0\"",
            6,
            "fmu.cost",
            "variable `x0` cannot be used here: expected an output",
        ),
        (
            "fmu = \"x0\"",
            "fmu = \"failed\"",
            32,
            "scenario[0].phi[0].fmu",
            "variable `failed` cannot be used here: expected a parameter, a structural parameter, an input, or a variable whose start value can be set (initial=\"exact\" or \"approx\")",
        ),
        // Two scenarios bind `x0`; the second as a Boolean.
        (
            "name = \"x0\"\nrange = [0.0, 0.5]",
            "name = \"x0\"\nvalues = [true, false]",
            42,
            "scenario[1].phi[0].name",
            "variable `x0` is Real, expected Boolean (for `x0`)",
        ),
    ] {
        let e = error("use", from, to);
        assert_eq!((e.line, e.key.as_deref()), (Some(line), Some(key)), "{e}");
        assert!(e.message.ends_with(message), "{message}: {e}");
    }
}

#[test]
fn a_missing_fmu_is_named_at_its_line() {
    let e = error("no-hf", "hf = \"testkit.fmu\"", "hf = \"nowhere.fmu\"");
    assert_eq!(
        (e.line, e.key.as_deref()),
        (Some(3), Some("fmu.hf / fmu.lf"))
    );
    assert!(e.message.contains("nowhere.fmu"), "{e}");
    let e = error(
        "no-lf",
        "hf = \"testkit.fmu\"",
        "hf = \"testkit.fmu\"\nlf = \"lf.fmu\"",
    );
    assert_eq!(
        (e.line, e.key.as_deref()),
        (Some(4), Some("fmu.hf / fmu.lf"))
    );
    assert!(e.message.contains("lf.fmu"), "{e}");
}

#[test]
fn run_settings_are_checked() {
    let e = error("step", "step = { rate_of = \"rate\" }", "step = -0.1");
    assert_eq!((e.line, e.key.as_deref()), (Some(5), Some("fmu.step")));
    assert_eq!(
        e.message,
        "step size -0.1 is not a positive number of seconds"
    );
    let e = error("stop", "stop_time = 1.0", "stop_time = 0.0");
    assert_eq!((e.line, e.key.as_deref()), (Some(4), Some("fmu.stop_time")));
    assert_eq!(e.message, "stop time 0 is not a positive number of seconds");
    for t in ["0.0", "-1.0", "nan", "inf", "1e300"] {
        let e = error("timeout", "timeout_s = 5.0", &format!("timeout_s = {t}"));
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(8), Some("fmu.timeout_s")),
            "{t}"
        );
        assert!(
            e.message
                .starts_with("must be a finite number of seconds > 0, got "),
            "{t}: {}",
            e.message
        );
    }
}

#[test]
fn absolute_paths_stay_absolute() {
    let path = campaign("absolute", GOOD);
    let fmu = path.parent().unwrap().join("testkit.fmu");
    let moved = temp_dir("absolute-elsewhere").join("campaign.toml");
    let body = GOOD.replacen(
        "hf = \"testkit.fmu\"",
        &format!("hf = {:?}", fmu.display().to_string()),
        1,
    );
    std::fs::write(&moved, body).unwrap();
    let f = FmuCampaignFile::load(&moved, &no_paper).unwrap();
    assert_eq!(f.init.hf, fmu);
    assert_eq!(
        f.common.campaign.out,
        Some(moved.parent().unwrap().join("results"))
    );
}

/// `drives = "step_size"` / `"tolerance"`: a fidelity variable that is the step size (or the
/// tolerance) itself, bound to no FMU variable; then no `[fmu] step`.
const STEP_FIDELITY: &str = r#"name = "h"
drives = "step_size"
values = [0.25, 0.125]
hf = 0.125"#;

fn with_step_fidelity(extra: &str) -> String {
    GOOD.replacen("step = { rate_of = \"rate\" }\n", "", 1)
        .replacen(
            "name = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
            &format!("{STEP_FIDELITY}{extra}"),
            1,
        )
}

#[test]
fn a_fidelity_variable_can_be_the_step_size_or_the_tolerance() {
    let body = with_step_fidelity(
        "\n[[fidelity.variable]]\nname = \"tol\"\ndrives = \"tolerance\"\nrange = [1e-6, 1e-3]\nscale = \"log\"\nhf = 1e-6",
    );
    let path = campaign("step-fidelity", &body);
    let f = FmuCampaignFile::load(&path, &no_paper).unwrap();
    assert_eq!(f.init.spec.step, StepSize::Of("h".into()));
    assert_eq!(
        f.init.spec.tolerance,
        Some(savme_fmu::Tolerance::Of("tol".into()))
    );
    assert!(f.init.spec.fidelity.is_empty(), "bound to no FMU variable");
    assert_eq!(
        f.common.fidelity.theta_hf,
        Assignment::new().with("h", 0.125).with("tol", 1e-6)
    );
    // It runs in steps of θ[h] (the test kit counts its steps) up to the failure at t = 0.5
    // (x = t reaches the threshold 0.5; stop_on_failure).
    let mut sim = f.init.simulator().unwrap();
    for (h, steps) in [(0.25, 2), (0.125, 4)] {
        let r = sim
            .run(
                savme_kernel::Role::Learned,
                "grow",
                &Assignment::new().with("start", 0.0),
                &Assignment::new().with("h", h).with("tol", 1e-4),
            )
            .unwrap();
        assert_eq!(r.work, Some(steps));
    }
}

#[test]
fn a_step_size_or_tolerance_variable_is_checked() {
    let cases: [(String, usize, &str, &str); 6] = [
        // `step` and a step-size variable: which one?
        (
            with_step_fidelity("").replacen("stop_time = 1.0\n", "stop_time = 1.0\nstep = 0.1\n", 1),
            5,
            "fmu.step",
            "the step size is the fidelity variable `h` (`fidelity.variable[0].drives`, line 23): remove `step`",
        ),
        // Neither.
        (
            GOOD.replacen("step = { rate_of = \"rate\" }\n", "", 1),
            2,
            "fmu.step",
            "no step size: give `step` (seconds, or { rate_of = \"…\" }) or a fidelity variable with drives = \"step_size\"",
        ),
        (
            with_step_fidelity("\nfmu = \"rate\""),
            25,
            "fidelity.variable[0].fmu",
            "a variable that drives the step size is bound to no FMU variable: remove `fmu`",
        ),
        (
            with_step_fidelity("").replacen("values = [0.25, 0.125]", "values = [0.125, 0.0]", 1),
            22,
            "fidelity.variable[0].drives",
            "`h` drives the step size: every value must be a positive number",
        ),
        (
            with_step_fidelity("\n[[fidelity.variable]]\nname = \"h2\"\ndrives = \"step_size\"\nvalues = [1.0]\nhf = 1.0"),
            27,
            "fidelity.variable[1].drives",
            "`h` already drives the step size (`fidelity.variable[0].drives`, line 22)",
        ),
        (
            with_step_fidelity("\n[[fidelity.variable]]\nname = \"tol\"\ndrives = \"tolerance\"\nvalues = [0.1]\nhf = 0.1")
                .replacen("stop_time = 1.0\n", "stop_time = 1.0\ntolerance = 1e-4\n", 1),
            5,
            "fmu.tolerance",
            "the tolerance is the fidelity variable `tol` (`fidelity.variable[1].drives`, line 28): remove `tolerance`",
        ),
    ];
    for (k, (body, line, key, message)) in cases.iter().enumerate() {
        let path = campaign(&format!("step-bad-{k}"), body);
        let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(*line), Some(*key)),
            "{k}: {e}"
        );
        assert_eq!(e.message, *message, "{k}");
    }
    // An unknown kind is a serde error at its line.
    let path = campaign(
        "step-bad-kind",
        &with_step_fidelity("").replacen("\"step_size\"", "\"steps\"", 1),
    );
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(e.line, Some(22), "{e}");
    assert!(
        e.message.contains("expected `step_size` or `tolerance`"),
        "{e}"
    );
}

/// A value outside the bounds the model description declares is named at its binding.
#[test]
fn declared_bounds_are_checked_at_the_binding() {
    // The test kit declares `fault` in [0, 4].
    let e = error("bounds-fixed", "fault = 0", "fault = 7");
    assert_eq!(
        (e.line, e.key.as_deref()),
        (Some(29), Some("scenario[0].fixed.fault"))
    );
    assert!(
        e.message.ends_with(
            "variable `fault` is declared in [0, 4] (min/max); the fixed value 7 lies outside"
        ),
        "{e}"
    );
    let e = error(
        "bounds-phi",
        "name = \"x0\"\nrange = [0.0, 0.5]",
        "name = \"x0\"\nrange = [0.0, 0.5]\n[[scenario.phi]]\nname = \"fault\"\nvalues = [0, 5]",
    );
    assert_eq!(
        (e.line, e.key.as_deref()),
        (Some(45), Some("scenario[1].phi[1].name"))
    );
    assert!(
        e.message
            .ends_with("is declared in [0, 4] (min/max); φ `fault` value 5 lies outside"),
        "{e}"
    );
}

/// Issue 40 item 7, in a campaign file: listed Int64 and UInt64 values are kept exactly (the
/// Int64 maximum, 2⁵³ + 1, a UInt64 above 2⁶³ − 1 written as a float); a UInt64 integer
/// literal above 2⁶³ − 1, which TOML cannot hold, is refused at its line saying what to write
/// instead; a value outside the C type is refused before any run, naming the binding.
#[test]
fn int64_and_uint64_values_of_a_campaign_file_are_exact_or_refused_at_load() {
    let dir = temp_dir("uint64");
    let fmu = dir.join("stairs3.fmu");
    savme_fmu_testkit::pack_stairs(&fmu, 3, |xml| {
        xml.replacen(
            "  </ModelVariables>",
            r#"<UInt64 name="seed" valueReference="12" causality="parameter" variability="fixed" initial="exact" start="0"/>
  </ModelVariables>"#,
            1,
        )
    })
    .unwrap();
    let body = |ticket: &str, seed: &str| {
        format!(
            r#"
[fmu]
hf = "stairs3.fmu"
stop_time = 1.0
step = 0.5

[failure]
boolean = "failed"

[campaign]
budgets = [0.5]

[fidelity]
[[fidelity.variable]]
name = "min_step"
values = [1e-9, 1e-8]
hf = 1e-9

[[scenario]]
name = "s"
role = "train"
[[scenario.phi]]
name = "ticket"
values = {ticket}
[[scenario.phi]]
name = "seed"
values = {seed}

[[scenario]]
name = "t"
role = "test"
[[scenario.phi]]
name = "x0"
range = [0.0, 1.0]
"#
        )
    };
    let path = dir.join("campaign.toml");
    std::fs::write(
        &path,
        body(
            "[9223372036854775807, 9007199254740993, 9007199254740992]",
            "[1.5e19, 9007199254740993]",
        ),
    )
    .unwrap();
    let f = FmuCampaignFile::load(&path, &no_paper).unwrap();
    let space = &f.common.scenarios.spaces["s"];
    let values = |name: &str| match &space.variable(name).unwrap().domain {
        savme_kernel::Domain::Discrete { values } => values.clone(),
        d => panic!("{d:?}"),
    };
    assert_eq!(
        values("ticket"),
        [
            Value::Int(i64::MAX),
            Value::Int(9_007_199_254_740_993),
            Value::Int(9_007_199_254_740_992)
        ]
    );
    assert_eq!(
        values("seed"),
        [Value::Real(1.5e19), Value::Int(9_007_199_254_740_993)]
    );
    f.init.simulator().unwrap();
    // An integer literal TOML cannot hold: refused at its line, saying what to write.
    std::fs::write(&path, body("[1]", "[18446744073709551615]")).unwrap();
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(e.line, Some(27), "{e}");
    assert!(
        e.message
            .contains("TOML integers are signed 64-bit (at most 9223372036854775807)")
            && e.message.contains("as a float (`1.5e19`)"),
        "{e}"
    );
    // Outside the C type (UInt64 from 0; 2⁶⁴ as a float): refused at load, naming the binding.
    for seed in ["[-1]", "[1.8446744073709552e19]"] {
        std::fs::write(&path, body("[1]", seed)).unwrap();
        let e = FmuCampaignFile::load(&path, &no_paper)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 26, key `scenario[0].phi[1].name`")
                && e.contains("variable `seed` is declared in [0, 18446744073709551615]"),
            "{seed}: {e}"
        );
    }
}
