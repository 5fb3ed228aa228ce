//! OpenSCENARIO files as the campaign reads them, by real `savme` processes (issue 40): a
//! signal during the reading of a large file ends it promptly with 130 or 143; an `.xosc`
//! edited after its campaign ran is refused by `estimate --config` and `run --resume` naming
//! the file, the parameter and both ranges; an unknown attribute of `<Range>` is refused
//! naming the file, the line and the attribute.
use crate::common;

use common::{made_dir, EXE};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const HEAD: &str = "<?xml version=\"1.0\"?>\n<OpenSCENARIO>\n  <FileHeader revMajor=\"1\" revMinor=\"2\" author=\"a\" description=\"d\" date=\"2024-01-01T00:00:00\"/>\n  <ParameterValueDistribution>\n    <ScenarioFile filepath=\"braking.xosc\"/>\n";
const TAIL: &str = "  </ParameterValueDistribution>\n</OpenSCENARIO>\n";

/// A variation file of `n` uniform parameters (3 elements a parameter: 80,000 make 12.8 MB and
/// 240,000 elements, within the limits).
fn many_parameters(n: usize) -> String {
    let mut s = String::from(HEAD);
    s += "    <Stochastic numberOfTestRuns=\"10\">\n";
    for i in 0..n {
        s += &format!("      <StochasticDistribution parameterName=\"p{i}\"><UniformDistribution><Range lowerLimit=\"0\" upperLimit=\"1\"/></UniformDistribution></StochasticDistribution>\n");
    }
    s + "    </Stochastic>\n" + TAIL
}

/// A campaign file (no FMU needed: the reading is what is timed) whose `scenarios` train
/// scenarios each take their φ from `xosc`.
fn reading_campaign(dir: &Path, name: &str, xosc: &Path, scenarios: usize) -> PathBuf {
    let mut text = String::from(
        "[fmu]\nhf = \"braking.fmu\"\nstop_time = 8.0\n\n[failure]\nboolean = \"collision\"\n\n[fidelity]\n[[fidelity.variable]]\nname = \"step\"\ndrives = \"step_size\"\nvalues = [0.4, 0.1]\nhf = 0.1\n",
    );
    for k in 0..scenarios {
        text += &format!(
            "\n[[scenario]]\nname = \"s{k}\"\nrole = \"{}\"\nopenscenario = \"{}\"\n",
            if k == 0 { "test" } else { "train" },
            xosc.display()
        );
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// `savme estimate DIR --config FILE` started (its campaign file is read first); SIGINT ignored
/// in it when `ignore_int` (as in a shell's background job, where the issue was seen).
fn start_estimate(config: &Path, dir: &Path, ignore_int: bool) -> std::process::Child {
    let mut cmd = Command::new(EXE);
    cmd.arg("estimate")
        .arg(dir.join("no-campaign"))
        .arg("--config")
        .arg(config)
        .arg("--quiet")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if ignore_int {
        use std::os::unix::process::CommandExt;
        // SAFETY: only signal(2), async-signal-safe, between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                libc::signal(libc::SIGINT, libc::SIG_IGN);
                Ok(())
            });
        }
    }
    cmd.spawn().expect("savme starts")
}

/// A signal while `savme` reads a campaign file whose 12 scenarios each read a 12.8 MB
/// variation file: the reading stops within a fraction of its length, exit 128 + the signal.
#[test]
fn a_signal_during_a_long_load_ends_it_promptly_with_130_or_143() {
    let dir = made_dir("signal");
    let xosc = dir.join("many.xosc");
    std::fs::write(&xosc, many_parameters(80_000)).unwrap();
    // The time of one file's reading (the whole command, to its refusal of the campaign).
    let one = reading_campaign(&dir, "one.toml", &xosc, 1);
    let t = Instant::now();
    let o = start_estimate(&one, &dir, false)
        .wait_with_output()
        .unwrap();
    let once = t.elapsed();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // Twelve of them: about twelve times as long; the signal comes during the second.
    let twelve = reading_campaign(&dir, "twelve.toml", &xosc, 12);
    for (signal, name, code, ignore_int) in [
        (libc::SIGINT, "Ctrl-C", 130, true),
        (libc::SIGTERM, "SIGTERM", 143, false),
    ] {
        let child = start_estimate(&twelve, &dir, ignore_int);
        std::thread::sleep(once.max(Duration::from_millis(300)));
        let sent = Instant::now();
        // SAFETY: kill(2) on the child's pid.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let o = child.wait_with_output().unwrap();
        let took = sent.elapsed();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{name}: {err}");
        assert!(
            err.contains(&format!(
                "savme: {name}: stopping the reading of the campaign file"
            )) && err.contains(&format!(
                "error: interrupted ({name}) while reading the campaign file {}; nothing ran",
                twelve.display()
            )),
            "{name}: {err}"
        );
        // Promptly: well before the other ten files would have been read.
        assert!(
            took < once * 4,
            "{name}: the reading ended {took:?} after the signal (one file takes {once:?}, twelve about {:?})",
            once * 12
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The dry road's variation: the speed normal around 16 m/s within [`speed_lo`, 25], the gap
/// uniform, its range given `range_extra` (an attribute more, for the refusal).
fn dry_road(speed_lo: f64, range_extra: &str) -> String {
    format!(
        "{HEAD}    <Stochastic numberOfTestRuns=\"100\" randomSeed=\"7\">
      <StochasticDistribution parameterName=\"speed0\">
        <NormalDistribution expectedValue=\"16\" variance=\"9\">
          <Range lowerLimit=\"{speed_lo}\" upperLimit=\"25\"/>
        </NormalDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName=\"gap\">
        <UniformDistribution>
          <Range lowerLimit=\"10\" upperLimit=\"60\"{range_extra}/>
        </UniformDistribution>
      </StochasticDistribution>
    </Stochastic>
{TAIL}"
    )
}

/// The icy road's: a grid of speeds, a set of gaps.
const ICY_ROAD: &str = "    <Deterministic>
      <DeterministicSingleParameterDistribution parameterName=\"speed0\">
        <DistributionRange stepWidth=\"1\"><Range lowerLimit=\"4\" upperLimit=\"15\"/></DistributionRange>
      </DeterministicSingleParameterDistribution>
      <DeterministicSingleParameterDistribution parameterName=\"gap\">
        <DistributionSet><Element value=\"10\"/><Element value=\"40\"/><Element value=\"100\"/></DistributionSet>
      </DeterministicSingleParameterDistribution>
    </Deterministic>
";

/// A small braking campaign (the example FMU) whose scenarios take φ from `dir`'s
/// `dry_road.xosc` (train) and `icy_road.xosc` (test), with an `[estimate]` section.
fn braking_campaign(dir: &Path) -> PathBuf {
    let fmu = common::braking::pack(dir, &common::braking::model_description());
    std::fs::write(dir.join("dry_road.xosc"), dry_road(8.0, "")).unwrap();
    std::fs::write(dir.join("icy_road.xosc"), format!("{HEAD}{ICY_ROAD}{TAIL}")).unwrap();
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
train_iterations = 12
eval_iterations = 4
test_iterations = 8
baseline_train_iterations = 12
baseline_test_iterations = 8
cost = "work"

[estimate]
max_runs = 20
target_width = 0.01
epsilon = 0.3

[fidelity]
[[fidelity.variable]]
name = "step"
drives = "step_size"
values = [0.4, 0.1]
hf = 0.1

[[scenario]]
name = "dry_road"
role = "train"
fixed = {{ road = "dry" }}
openscenario = "dry_road.xosc"

[[scenario]]
name = "icy_road"
role = "test"
fixed = {{ road = "ice" }}
openscenario = "icy_road.xosc"
"#,
        fmu = fmu.display(),
    );
    let path = dir.join("campaign.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn savme(args: &[&Path]) -> (Option<i32>, String, String) {
    common::run(args)
}

/// φ's range edited (widened: every trial still inside it) in the `.xosc` after the campaign ran: `estimate --config` (which gave
/// another P(failure) and said nothing) and `run --resume` (which blamed the trial store) both
/// refuse, naming the file, the scenario, the parameter and both ranges.
#[test]
fn an_xosc_edited_after_its_campaign_is_refused_naming_the_file_the_parameter_and_both_ranges() {
    let dir = made_dir("edited");
    let config = braking_campaign(&dir);
    let out = dir.join("out");
    let (code, _, err) = savme(&[
        "run".as_ref(),
        "--config".as_ref(),
        &config,
        "--out".as_ref(),
        &out,
        "--quiet".as_ref(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let xosc = dir.join("dry_road.xosc");
    std::fs::write(&xosc, dry_road(6.0, "")).unwrap();
    let expected = format!(
        "{}: parameter `speed0` of scenario `dry_road` is [6, 25] in 10 linear bins now, but the campaign ran with [8, 25] in 10 linear bins",
        xosc.display()
    );
    let (code, _, err) = savme(&[
        "estimate".as_ref(),
        &out,
        "--config".as_ref(),
        &config,
        "--out".as_ref(),
        &dir.join("again"),
        "--quiet".as_ref(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains(&expected), "expected {expected}\ngot {err}");
    assert!(!dir.join("again").exists(), "nothing estimated");
    let (code, _, err) = savme(&[
        "run".as_ref(),
        "--config".as_ref(),
        &config,
        "--resume".as_ref(),
        &out,
        "--quiet".as_ref(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains(&expected), "expected {expected}\ngot {err}");
    // The file as it was: both accepted again.
    std::fs::write(&xosc, dry_road(8.0, "")).unwrap();
    let (code, _, err) = savme(&[
        "estimate".as_ref(),
        &out,
        "--config".as_ref(),
        &config,
        "--out".as_ref(),
        &dir.join("again"),
        "--quiet".as_ref(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let _ = std::fs::remove_dir_all(dir);
}

/// An attribute OpenSCENARIO's `<Range>` does not have (a `step`, a misspelt `uperLimit`) is
/// refused naming the campaign file, the `.xosc`, its line, the element and the attribute.
#[test]
fn an_unknown_attribute_of_range_is_refused_naming_file_line_and_attribute() {
    let dir = made_dir("range");
    let config = braking_campaign(&dir);
    let xosc = dir.join("dry_road.xosc");
    for (extra, attribute) in [(" step=\"5\"", "step"), (" uperLimit=\"70\"", "uperLimit")] {
        std::fs::write(&xosc, dry_road(8.0, extra)).unwrap();
        let (code, _, err) = savme(&[
            "run".as_ref(),
            "--config".as_ref(),
            &config,
            "--out".as_ref(),
            &dir.join("out"),
            "--quiet".as_ref(),
        ]);
        assert_eq!(code, Some(1), "{err}");
        let expected = format!(
            "{}, line 35, key `scenario[0].openscenario`: {}, line 14, element `Range`: unknown attribute `{attribute}`: a <Range> has `lowerLimit` and `upperLimit` only",
            config.display(),
            xosc.display()
        );
        assert!(err.contains(&expected), "expected {expected}\ngot {err}");
        assert!(!dir.join("out").exists(), "nothing ran");
    }
    let _ = std::fs::remove_dir_all(dir);
}
