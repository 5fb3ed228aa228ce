//! `savme` on an FMU as vendors ship them: the `braking` example (`examples/fmu/braking`, C
//! against the FMI 2.0 C API), compiled here with the system C compiler and packed with its
//! resources — its example campaign (the step size as the only fidelity), `--fmu-log`, and
//! `savme fmu info` / `validate`.
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

const EXE: &str = env!("CARGO_BIN_EXE_savme");

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("savme-vendor-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn savme(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(EXE).args(args).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fmu/braking")
}

/// The braking example's shared library, compiled once from `braking.c` (`$CC`, else `cc`).
fn braking_library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let lib =
            temp_dir("braking-lib").join(format!("braking.{}", std::env::consts::DLL_EXTENSION));
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let status = Command::new(&cc)
            .args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"])
            .arg(&lib)
            .arg(example().join("braking.c"))
            .arg("-lm")
            .status()
            .unwrap_or_else(|e| panic!("the C compiler `{cc}` (set CC): {e}"));
        assert!(status.success(), "compiling braking.c failed");
        lib
    })
}

/// `braking.fmu` in `dir` with `xml` as its model description (and its resources).
fn pack(dir: &Path, xml: &str) -> PathBuf {
    let out = dir.join("braking.fmu");
    let friction = std::fs::read(example().join("resources/friction.txt")).unwrap();
    savme_fmi_export::pack_with(
        xml,
        "braking",
        braking_library(),
        &[("resources/friction.txt", &friction)],
        &out,
    )
    .unwrap();
    out
}

fn model_description() -> String {
    std::fs::read_to_string(example().join("modelDescription.xml")).unwrap()
}

/// `dir` with the packed FMU and the example campaign file.
fn example_dir(name: &str) -> (PathBuf, PathBuf) {
    let dir = temp_dir(name);
    pack(&dir, &model_description());
    let config = dir.join("campaign.toml");
    std::fs::copy(example().join("campaign.toml"), &config).unwrap();
    (dir, config)
}

/// Item 2: the example campaign, whose only fidelity is the communication step size, runs the
/// whole protocol; every trial's θ is a step size of the list.
#[test]
fn the_step_size_example_campaign_runs() {
    let (dir, config) = example_dir("example");
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
    assert!(stdout.contains("| step | 0.01 |"), "{stdout}");
    let trials = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
    assert_eq!(trials.lines().count(), 120 + 120 + 40 + 3 * 60);
    let mut steps = std::collections::BTreeSet::new();
    for line in trials.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        assert!(v.get("error").is_none(), "a withdrawn trial: {line}");
        // θ_LF of the LF runs (HF runs use θ_HF = 0.01).
        if let Some(h) = v["theta_lf"]["step"].as_f64() {
            assert!([0.4, 0.2, 0.1, 0.05, 0.02, 0.01].contains(&h), "{line}");
            steps.insert(h.to_bits());
        }
    }
    assert!(steps.len() > 1, "the LF runs explore the step sizes");
}

/// Item 4 on the command line: `--fmu-log` prints every message of the FMU, also the
/// informational ones it sends only with `loggingOn`.
#[test]
fn fmu_log_prints_the_fmus_messages() {
    let (dir, config) = example_dir("fmu-log");
    let small = [
        "--iterations",
        "2",
        "--eval-iterations",
        "1",
        "--test-iterations",
        "1",
        "--baseline-iterations",
        "1",
        "--baseline-test-iterations",
        "1",
    ];
    for flag in [true, false] {
        let out = dir.join(format!("out-{flag}"));
        let mut args = vec![
            "run",
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ];
        args.extend(small);
        if flag {
            args.push("--fmu-log");
        }
        let (ok, _, err) = savme(&args);
        assert!(ok, "{err}");
        assert_eq!(
            err.contains("[savme-hf] ok logAll: friction 0.80 for the dry road from /"),
            flag,
            "--fmu-log {flag}: {err}"
        );
    }
}
