//! OpenSCENARIO files as the campaign reads them, by real `savme` processes (issue 40): a
//! signal during the reading of a large file ends it promptly with 130 or 143; an `.xosc`
//! edited after its campaign ran is refused by `estimate --config` and `run --resume` naming
//! the file, the parameter and both ranges; an unknown attribute of `<Range>` is refused
//! naming the file, the line and the attribute.
mod common;

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
