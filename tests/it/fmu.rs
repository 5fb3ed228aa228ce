//! The bundled simulator as an FMU (`savme fmu pack`) against the in-process simulator, FMPy
//! against savme on the same FMU, and `savme run --config` with good and bad campaign files.
use crate::common;

use common::{fmpy_python, made_dir, savme, trial_lines};
use savme::kernel::{Assignment, Space};
use savme_fmu::instance::Instance;
use savme_fmu::FmuFile;
use savme_sim::scenario::{find, phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, OnceLock};

/// The bundled simulator packed once by `savme fmu pack`.
fn packed() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let out = made_dir("packed").join("savme-sim.fmu");
        let (ok, stdout, err) = savme(&["fmu", "pack", "--out", out.to_str().unwrap()]);
        assert!(ok, "{err}");
        assert!(stdout.contains("wrote"), "{stdout}");
        out
    })
}

/// The bundled simulator packed once by `savme fmu pack --fmi 3` (FMI 3.0).
fn packed3() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let out = made_dir("packed3").join("savme-sim3.fmu");
        let (ok, stdout, err) =
            savme(&["fmu", "pack", "--fmi", "3", "--out", out.to_str().unwrap()]);
        assert!(ok, "{err}");
        assert!(stdout.contains("(FMI 3.0"), "{stdout}");
        out
    })
}

/// A φ sample of `space` (the k-th point of a fixed low-discrepancy pattern).
fn sample(space: &Space, k: usize) -> Assignment {
    let mut a = Assignment::new();
    for (j, v) in space.variables().iter().enumerate() {
        if let savme::kernel::Domain::Continuous { lo, hi, .. } = v.domain {
            let u = ((k as f64 + 0.5) * (0.618_034 + 0.1 * j as f64)).fract();
            a.set(&v.name, lo + u * (hi - lo));
        }
    }
    a
}

/// Runs one scenario through the FMU (to its stop time) and reads collision, min distance,
/// work.
fn through_fmu(
    file: &Arc<FmuFile>,
    id: u8,
    phi: &Assignment,
    theta: &Assignment,
) -> (bool, f64, f64) {
    let mut i = Instance::new(file.clone(), "cross-check").unwrap();
    i.setup(0.0, Some(12.0), None).unwrap();
    let vr = |n: &str| file.variable(n).unwrap().vr;
    i.set_integer(vr("scenario"), i32::from(id)).unwrap();
    for (n, v) in phi.iter() {
        i.set_real(vr(n), v.as_f64().unwrap()).unwrap();
    }
    for (n, v) in theta.iter() {
        match v {
            savme::kernel::Value::Bool(b) => i.set_boolean(vr(n), *b).unwrap(),
            savme::kernel::Value::Int(k) => i.set_integer(vr(n), *k as i32).unwrap(),
            savme::kernel::Value::Label(l) => {
                i.set_integer(vr(n), i32::from(&**l == "low")).unwrap()
            }
            savme::kernel::Value::Real(x) => i.set_real(vr(n), *x).unwrap(),
        }
    }
    i.initialize().unwrap();
    let mut t = 0.0;
    while t < 12.0 - 1e-9 {
        i.step(t, 0.1).unwrap();
        t += 0.1;
        t = (t * 10.0).round() / 10.0;
    }
    (
        i.boolean(vr("collision")).unwrap(),
        i.real(vr("min_distance")).unwrap(),
        i.real(vr("work")).unwrap(),
    )
}

#[test]
fn the_fmu_gives_the_in_process_outcomes() {
    let file = Arc::new(FmuFile::open(packed()).unwrap());
    let hf = savme_sim::fidelity::theta_hf();
    let cheap = hf
        .clone()
        .with("simulation_rate_hz", 4)
        .with("camera_bloom_level", "low")
        .with("camera_disable_shadows", true)
        .with("camera_view_distance_m", 120.0)
        .with("lidar_subsample_count", 2)
        .with("lidar_near_clipping_m", 3.0);
    let sim = DrivingSimulator::default();
    let mut collisions = 0;
    for info in SCENARIOS.iter().filter(|s| [1, 5, 7, 10].contains(&s.id)) {
        for k in 0..3 {
            let phi = sample(&phi_space(info), k + usize::from(info.id));
            for theta in [&hf, &cheap] {
                let local = sim.run(info.name, &phi, theta, false).unwrap();
                let (collision, min_distance, work) = through_fmu(&file, info.id, &phi, theta);
                assert_eq!(collision, local.failure, "{} {phi}", info.name);
                assert_eq!(
                    min_distance,
                    local.min_distance.min(1e6),
                    "{} {phi}",
                    info.name
                );
                assert_eq!(work, local.work as f64, "{} {phi}", info.name);
                collisions += usize::from(collision);
            }
        }
    }
    // The comparison covers both outcomes.
    assert!(
        collisions > 0 && collisions < 24,
        "{collisions} collisions of 24"
    );
    assert!(find("7").is_some());
}

/// FMPy simulates the packed simulator like savme's in-process simulator — the FMI 2.0 pack
/// and the FMI 3.0 one (`savme fmu pack --fmi 3`, issue 13 item 7).
#[test]
fn fmpy_simulates_the_fmu_like_savme() {
    let Some(python) = fmpy_python() else { return };
    for fmu in [packed(), packed3()] {
        fmpy_compare(&python, fmu);
    }
}

fn fmpy_compare(python: &str, fmu: &Path) {
    let info = find("7").unwrap();
    let sim = DrivingSimulator::default();
    let hf = savme_sim::fidelity::theta_hf();
    for k in 0..3 {
        let phi = sample(&phi_space(info), k);
        let local = sim.run(info.name, &phi, &hf, false).unwrap();
        let mut start = vec![("scenario".to_string(), "7".to_string())];
        for (n, v) in phi.iter() {
            start.push((n.to_string(), format!("{:?}", v.as_f64().unwrap())));
        }
        let starts: String = start.iter().map(|(n, v)| format!("'{n}': {v}, ")).collect();
        let script = format!(
            "import fmpy\n\
             r = fmpy.simulate_fmu(r'{}', start_values={{{starts}}}, stop_time=12.0, \
             output_interval=0.1, output=['collision', 'min_distance', 'work'])\n\
             print(bool(r['collision'][-1]), repr(float(r['min_distance'][-1])), repr(float(r['work'][-1])))\n",
            fmu.display()
        );
        let o = Command::new(python)
            .arg("-c")
            .arg(&script)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        let f: Vec<&str> = out.split_whitespace().collect();
        assert_eq!(f.len(), 3, "{out}");
        assert_eq!(
            f[0] == "True",
            local.failure,
            "{}: {phi}: {out}",
            fmu.display()
        );
        assert_eq!(
            f[1].parse::<f64>().unwrap(),
            local.min_distance.min(1e6),
            "{phi}"
        );
        assert_eq!(f[2].parse::<f64>().unwrap(), local.work as f64, "{phi}");
    }
}

fn campaign_file(dir: &Path, body: &str) -> PathBuf {
    let path = dir.join("campaign.toml");
    let fmu = packed().display().to_string();
    std::fs::write(&path, body.replace("FMU", &fmu)).unwrap();
    path
}

/// The tiny campaign file (`FMU` is replaced by the packed FMU's path).
const TINY: &str = include_str!("../fixtures/fmu-tiny-campaign.toml");

#[test]
fn run_config_runs_the_protocol_on_fmus_in_process_and_isolated() {
    let dir = made_dir("run");
    // Scenario 10's φ must be its real one; check against `savme scenarios`.
    let ten: Vec<String> = phi_space(find("10").unwrap())
        .variables()
        .iter()
        .map(|v| v.name.to_string())
        .collect();
    assert_eq!(
        ten,
        ["ego_speed", "intruder_speed", "time_offset"],
        "update TINY"
    );
    for (name, isolate) in [("in-process", false), ("isolated", true)] {
        let body = TINY.replace(
            "cost = \"work\"\n\n[failure]",
            &format!("cost = \"work\"\nisolate = {isolate}\n\n[failure]"),
        );
        let config = campaign_file(&dir, &body);
        let out = dir.join(name);
        // The paper's method: the fixture below is its campaign.
        let (ok, stdout, err) = savme(&[
            "run",
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--method",
            "paper",
            "--quiet",
        ]);
        assert!(ok, "{name}: {err}");
        assert!(
            stdout.contains("| C_budget | TP-rate | mean LF cost | speedup |"),
            "{stdout}"
        );
        let trials = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
        // The protocol record, then the trials.
        assert!(trials.starts_with("{\"v\":1,\"protocol\":"), "{name}");
        assert_eq!(trials.lines().count(), 1 + 6 + 8 + 4 + 4 + 2 * 4, "{name}");
        for f in [
            "table.md",
            "fidelity.md",
            "summary.json",
            "breakeven.png",
            "meta_testing.png",
        ] {
            assert!(out.join(f).exists(), "{name}: {f}");
        }
    }
    // Both back-ends ran the same campaign (work-unit cost: bit for bit, but wall times).
    let strip = |path: PathBuf| -> Vec<serde_json::Value> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            // Not the protocol record a campaign's store begins with (the fixture predates it).
            .filter(|l| !l.starts_with("{\"v\":1,\"protocol\":"))
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                // The store's format version and checksum (absent from lines written before
                // they existed; the checksum covers the wall-clock seconds).
                if let Some(o) = v.as_object_mut() {
                    o.remove("v");
                    o.remove("c");
                }
                for r in ["hf", "lf"] {
                    if let Some(o) = v[r].as_object_mut() {
                        o.remove("wall_seconds");
                    }
                }
                v
            })
            .collect()
    };
    let trials = |d: &str| strip(dir.join(d).join("trials.jsonl"));
    assert_eq!(trials("in-process"), trials("isolated"));
    // The FMI 3.0 pack of the same simulator (`savme fmu pack --fmi 3`), isolated: the same
    // campaign, trial for trial (issue 13 item 7).
    let body = TINY
        .replace(
            "cost = \"work\"\n\n[failure]",
            "cost = \"work\"\nisolate = true\n\n[failure]",
        )
        .replace("FMU", &packed3().display().to_string());
    let config = dir.join("campaign3.toml");
    std::fs::write(&config, body).unwrap();
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        dir.join("fmi3").to_str().unwrap(),
        "--method",
        "paper",
        "--quiet",
    ]);
    assert!(ok, "FMI 3.0: {err}");
    assert_eq!(trials("fmi3"), trials("in-process"));
    // And the same as savme gave before the campaign core moved (tests/fixtures/README.md).
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/run-fmu-tiny-work.trials.jsonl");
    assert_eq!(trials("in-process"), strip(fixture));
}

/// Runs `savme run` on `body` (in `dir`) and checks that it is refused before a campaign
/// starts, with an error naming the file and each of `needles`.
fn assert_refused(dir: &Path, body: &str, needles: &[&str]) {
    let config = campaign_file(dir, body);
    let out = dir.join("out");
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        !out.join("trials.jsonl").exists(),
        "a campaign started: {body}"
    );
    assert!(!ok, "accepted: {body}");
    assert!(err.contains("campaign.toml"), "{err}");
    for n in needles {
        assert!(err.contains(n), "expected `{n}` in: {err}");
    }
}

#[test]
fn bad_campaign_files_name_the_file_line_and_key() {
    let dir = made_dir("bad-config");
    let check = |body: &str, needles: &[&str]| assert_refused(&dir, body, needles);
    // TOML-level: an unknown key, a wrong type.
    check(
        &TINY.replace("stop_time = 12.0", "stop_time = 12.0\nstop_tme = 3"),
        &["line 5", "unknown field `stop_tme`"],
    );
    check(
        &TINY.replace("stop_time = 12.0", "stop_time = \"long\""),
        &["line 4", "invalid type"],
    );
    // Sizes beyond the protocol's limits are refused before anything is allocated.
    check(
        &TINY.replace("train_iterations = 8", "train_iterations = 10000000000"),
        &[
            "campaign.train_iterations",
            "10000000000 is more than savme runs in one stage",
        ],
    );
    // An FMU variable that does not exist, named with its line and key.
    check(
        &TINY.replace(
            "name = \"time_offset\"",
            "name = \"time_offset\"\nfmu = \"time_ofset\"",
        ),
        &[
            "line 55",
            "scenario[1].phi[2].fmu",
            "no variable `time_ofset`",
        ],
    );
    // A fixed parameter of the wrong type: `scenario` is an Integer.
    check(
        &TINY.replace("fixed = { scenario = 7 }", "fixed = { scenario = true }"),
        &["scenario[0].fixed.scenario"],
    );
    // A failure signal that is no Boolean output.
    check(
        &TINY.replace("boolean = \"collision\"", "boolean = \"min_distance\""),
        &["line 9", "failure.boolean", "is Real, expected Boolean"],
    );
    check(
        &TINY.replace("boolean = \"collision\"", "threshold = \"min_distance\""),
        &["failure", "above` / `below"],
    );
    // Missing FMU; a role that is not train/test; a budget out of range.
    check(
        &TINY.replace("hf = \"FMU\"", "hf = \"nowhere.fmu\""),
        &["line 3", "nowhere.fmu"],
    );
    check(
        &TINY.replace("role = \"test\"", "role = \"tset\""),
        &["scenario[1].role", "`tset`"],
    );
    check(
        &TINY.replace("budgets = [0.3]", "budgets = [1.3]"),
        &["line 12", "campaign.budgets", "outside (0, 1]"],
    );
    // Zero bins for the paper's fidelity space (it cannot be built).
    check(
        &TINY.replace("budgets = [0.3]", "budgets = [0.3]\nfidelity_bins = 0"),
        &["line 13", "campaign.fidelity_bins", "must be at least 1"],
    );
    // Fidelity ladders: out of order, a level not trained, no screening to use it.
    let ladder = |budgets: &str, ladder: &str, screen: &str| {
        TINY.replace(
            "budgets = [0.3]",
            &format!("budgets = {budgets}\n{screen}ladder = {ladder}"),
        )
    };
    let screens = "screen_iterations = 4\n";
    check(
        &ladder("[0.1, 0.3]", "[0.3, 0.1]", screens),
        &["line 14", "campaign.ladder", "cheapest first"],
    );
    check(
        &ladder("[0.3]", "[0.1, 0.3]", screens),
        &[
            "line 14",
            "campaign.ladder",
            "0.1 is not one of budgets (0.3)",
        ],
    );
    check(
        &ladder("[0.1, 0.3]", "[0.1, 0.3]", ""),
        &["line 13", "campaign.ladder", "screen_iterations is 0"],
    );
    check(
        &ladder("[0.1, 0.3]", "\"0.1\"", screens),
        &["line 14", "campaign.ladder"],
    );
    check(
        &TINY.replace(
            "step = { rate_of = \"simulation_rate_hz\" }",
            "step = { rate_of = \"fps\" }",
        ),
        &["fmu.step.rate_of", "`fps`"],
    );
}

/// A campaign file declares a three-level ladder (HF, C = 0.5, C = 0.2): each level is
/// meta-trained at its budget, and the screening stage at the top screens down the ladder.
#[test]
fn a_campaign_file_declares_a_fidelity_ladder() {
    let dir = made_dir("ladder");
    let body = TINY.replace(
        "budgets = [0.3]",
        "budgets = [0.2, 0.5]\nladder = [0.2, 0.5]\nscreen_iterations = 6\naudit_fraction = 0.5",
    );
    let config = campaign_file(&dir, &body);
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
    let lines = trial_lines(&out);
    let top: Vec<&serde_json::Value> = lines
        .iter()
        .filter(|l| l["stage"] == "screen@0.5")
        .collect();
    assert_eq!(top.len(), 6);
    for l in &top {
        assert_eq!(l["ladder"][0]["budget"], 0.2, "{l}");
        assert!(
            l["ladder"][0]["lf"].is_object() || l["screen"] == "direct",
            "{l}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn outputs_to_record_that_the_fmu_lacks_are_refused_before_the_first_run() {
    let dir = made_dir("bad-record");
    let check = |record: &str, needles: &[&str]| {
        let body = TINY.replace(
            "cost = \"work\"\n\n[failure]",
            &format!("cost = \"work\"\nrecord = {record}\n\n[failure]"),
        );
        assert_refused(&dir, &body, needles)
    };
    // An output the FMU does not have: the file, the line, the key and the variable.
    check(
        "[\"min_distance\", \"clearence\"]",
        &["line 7", "key `fmu.record`", "no variable `clearence`"],
    );
    // A parameter is no output.
    check(
        "[\"ego_speed\"]",
        &["line 7", "fmu.record", "`ego_speed`", "expected an output"],
    );
    // Listed twice.
    check(
        "[\"steps\", \"steps\"]",
        &["line 7", "fmu.record", "`steps` is listed twice"],
    );
    // Not a list of names.
    check("\"steps\"", &["line 7", "invalid type"]);
}

#[test]
fn conflicting_bindings_and_scenario_errors_name_their_line() {
    let dir = made_dir("bad-bindings");
    let check = |body: &str, needles: &[&str]| assert_refused(&dir, body, needles);
    // The failure signal as the cost: the cost is blamed, not the failure signal.
    check(
        &TINY.replacen("cost = \"work\"", "cost = \"collision\"", 1),
        &["line 6", "key `fmu.cost`", "`collision` is Boolean"],
    );
    // One FMU variable set twice in a run: fixed and φ, φ and a paper fidelity setting.
    check(
        &TINY.replace(
            "fixed = { scenario = 7 }",
            "fixed = { scenario = 7, gap = 10.0 }",
        ),
        &[
            "line 34",
            "key `scenario[0].phi[2].name`",
            "FMU variable `gap` is already bound by `scenario[0].fixed.gap` (line 26)",
        ],
    );
    check(
        &TINY.replace(
            "name = \"time_offset\"",
            "name = \"time_offset\"\nfmu = \"simulation_rate_hz\"",
        ),
        &[
            "line 55",
            "key `scenario[1].phi[2].fmu`",
            "is already bound by `fidelity.paper` (line 21)",
        ],
    );
    // Protocol errors about scenarios name the scenario's line.
    check(
        &TINY.replace("role = \"test\"", "role = \"train\""),
        &[
            "line 25",
            "key `scenario[0].role`",
            "no scenario has role \"test\"",
        ],
    );
    check(
        &TINY.replace(
            "name = \"on_ramp_merge\"",
            "name = \"on_ramp_merge\"\nweight = -1.0",
        ),
        &[
            "line 45",
            "key `scenario[1].weight`",
            "-1 is not a positive weight",
        ],
    );
}

#[test]
fn run_refuses_an_output_directory_that_is_a_file() {
    let dir = made_dir("out-file");
    let config = campaign_file(&dir, TINY);
    let file = dir.join("afile");
    std::fs::write(&file, "mine").unwrap();
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        file.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains(&format!("{} is a file, not a directory", file.display())),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
}

/// The campaign file's `[estimate]` stage: `savme run` estimates P(failure) under the declared
/// nominal after the campaign, on the FMU's HF runs; `--resume` finds it done; bad values are
/// refused before the campaign starts, naming the line and key (or the variable).
#[test]
fn an_estimate_section_runs_after_the_campaign_and_bad_ones_are_refused() {
    let dir = made_dir("estimate");
    let section = "\n[estimate]\nmax_runs = 40\ntarget_width = 0.5\nepsilon = 0.2\n\
                   refine_rounds = 1\nrefine_runs = 10\n\
                   [estimate.nominal.lead_vehicle_brakes]\n\
                   ego_speed = { distribution = \"normal\", mean = 20.0, sd = 3.0 }\n";
    let config = campaign_file(&dir, &(TINY.to_string() + section));
    let out = dir.join("out");
    let run = |flag: &str| {
        savme(&[
            "run",
            "--config",
            config.to_str().unwrap(),
            flag,
            out.to_str().unwrap(),
            "--quiet",
        ])
    };
    let (ok, stdout, err) = run("--out");
    assert!(ok, "{err}");
    assert!(
        stdout.contains("# P(failure) under the nominal distribution"),
        "{stdout}"
    );
    let est = out.join("estimate-0.3");
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(est.join("trials.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines.len() > 10 && lines.len() <= 40);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["round"].as_u64(), (i < 10).then_some(0), "{l}");
    }
    for l in &lines {
        let (q, p, w) = (
            l["q"].as_f64().unwrap(),
            l["p"].as_f64().unwrap(),
            l["weight"].as_f64().unwrap(),
        );
        assert!((w - p / q).abs() <= 1e-9 * w && w <= 5.0 + 1e-9, "{l}");
    }
    let settings: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(est.join("estimate.json")).unwrap()).unwrap();
    assert_eq!(
        settings["nominal"]["lead_vehicle_brakes"]["ego_speed"]["mean"],
        20.0
    );
    let before = std::fs::read_to_string(est.join("summary.json")).unwrap();
    let (ok, _, err) = run("--resume");
    assert!(ok, "{err}");
    let after = std::fs::read_to_string(est.join("summary.json")).unwrap();
    let estimate =
        |t: &str| serde_json::from_str::<serde_json::Value>(t).unwrap()["estimate"].clone();
    assert_eq!(estimate(&before), estimate(&after));
    // A resume with another protocol (here the seed) is refused naming the field, and
    // changes nothing.
    let trials_before = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
    let reseeded = campaign_file(
        &made_dir("estimate-reseeded"),
        &(TINY.replacen("budgets = [0.3]", "seed = 2\nbudgets = [0.3]", 1) + section),
    );
    let (ok, _, err) = savme(&[
        "run",
        "--config",
        reseeded.to_str().unwrap(),
        "--resume",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains("differs from the protocol given to resume: `seed` is 1 there, 2 here"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("trials.jsonl")).unwrap(),
        trials_before
    );
    // `savme estimate --config FILE` takes the file's [estimate] section: the same settings
    // and trials as the stage; a flag given overrides its key only.
    let again = |dir: &str, extra: &[&str]| {
        let target = out.join(dir);
        let mut args = vec![
            "estimate",
            out.to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
            "--out",
            target.to_str().unwrap(),
        ];
        args.extend(extra);
        let (ok, _, err) = savme(&args);
        assert!(ok, "{err}");
        let text = |f: &str| std::fs::read_to_string(target.join(f)).unwrap();
        let json = serde_json::from_str::<serde_json::Value>(&text("estimate.json")).unwrap();
        (json, text("trials.jsonl"))
    };
    let strip = |t: &str| -> Vec<serde_json::Value> {
        t.lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                v["hf"]["wall_seconds"] = serde_json::Value::Null;
                // The store's checksum covers the wall seconds.
                if let Some(o) = v.as_object_mut() {
                    o.remove("c");
                }
                v
            })
            .collect()
    };
    let (same, same_lines) = again("by-file", &[]);
    assert_eq!(same, settings);
    let stage_lines = std::fs::read_to_string(est.join("trials.jsonl")).unwrap();
    assert_eq!(strip(&same_lines), strip(&stage_lines));
    let (over, _) = again("by-file-and-flag", &["--epsilon", "0.3"]);
    assert_eq!(
        (over["epsilon"].as_f64(), over["max_runs"].as_u64()),
        (Some(0.3), Some(40))
    );
    assert_eq!(over["refine_runs"], 10);

    // A campaign file whose φ-space is not the campaign's: refused before any run, naming the
    // file, the scenario, the variable and both ranges (the campaign's phi.json); a campaign
    // without phi.json (written before it existed) still names the trial line that does not
    // fit (it was "line 0").
    let other = campaign_file(
        &made_dir("estimate-other"),
        &TINY.replacen("range = [10.0, 25.0]", "range = [24.9, 25.0]", 1),
    );
    let stored = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
    let line = 1 + stored
        .lines()
        .position(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["stage"] == "train@0.3"
                && v["scenario"] == "lead_vehicle_brakes"
                && !v["credit"]["scenario"].is_null()
                && v["phi"]["ego_speed"].as_f64().unwrap() < 24.9
        })
        .unwrap();
    let estimate_other = || {
        savme(&[
            "estimate",
            out.to_str().unwrap(),
            "--config",
            other.to_str().unwrap(),
            "--out",
            out.join("other").to_str().unwrap(),
        ])
    };
    let (ok, _, err) = estimate_other();
    assert!(!ok);
    assert!(
        err.contains(&format!(
            "{}: φ variable `ego_speed` of scenario `lead_vehicle_brakes` is [24.9, 25]",
            other.display()
        )) && err.contains("the campaign ran with [10, 25]"),
        "{err}"
    );
    std::fs::remove_file(out.join("phi.json")).unwrap();
    let (ok, _, err) = estimate_other();
    assert!(!ok);
    assert!(
        err.contains(&format!("trials.jsonl, line {line}: train@0.3 trial "))
            && err.contains("φ outside the scenario"),
        "line {line}: {err}"
    );
    let bad = made_dir("estimate-bad");
    // TINY's lines, an empty line, `[estimate]`, then `epsilon`.
    let line = TINY.lines().count() + 3;
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nepsilon = 0.0\n"),
        &[&format!("line {line}"), "estimate.epsilon", "(0, 1]"],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nscenarios = []\n"),
        &[
            &format!("line {line}, key `estimate.scenarios`"),
            "the list is empty: name scenarios, or leave the key out",
        ],
    );
    // A budget the campaign does not train: refused before it runs (it ran, then failed).
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nbudget = 0.7\n"),
        &[
            &format!("line {line}, key `estimate.budget`"),
            "the campaign trained budgets 0.3, not 0.7",
        ],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\ntarget_width = -1.0\n"),
        &["estimate.target_width", "must be a finite number > 0"],
    );
    assert_refused(
        &bad,
        &(TINY.to_string()
            + "\n[estimate]\n[estimate.nominal.lead_vehicle_brakes]\nego_sped = { distribution = \"uniform\" }\n"),
        &["[estimate]", "unknown variable `ego_sped` of scenario `lead_vehicle_brakes`"],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nepsilon = 0.1\nepsilom = 0.2\n"),
        &["unknown field `epsilom`"],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nrefine_rounds = 2\n"),
        &[
            "estimate.refine_runs",
            "2 refinement rounds need `refine_runs` ≥ 1",
        ],
    );
    let reuse = "\n[estimate]\nrefine_rounds = 1\nrefine_runs = 10\nrefine_reuse = 2\n";
    let line = format!(
        "line {}, key `estimate.refine_reuse`",
        TINY.lines().count() + 5
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + reuse),
        &[
            &line,
            "2 pilot rounds to reuse in the estimate, but `refine_rounds` is 1",
        ],
    );
    let joint = "\n[estimate]\nproposal = \"joint\"\n";
    let line = format!("line {}, key `estimate.proposal`", TINY.lines().count() + 3);
    assert_refused(
        &bad,
        &(TINY.to_string() + joint),
        &[
            &line,
            "the joint proposal is fitted by the cross-entropy pilot rounds",
        ],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\njoint_components = 3\n"),
        &[
            "key `estimate.joint_components`",
            "3 components need `proposal` = \"joint\"",
        ],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\nproposal = \"diagonal\"\n"),
        &["unknown variant `diagonal`, expected `product` or `joint`"],
    );
    let lf = "\n[estimate]\npilot_fidelity = \"lf\"\n";
    let line = format!(
        "line {}, key `estimate.pilot_fidelity`",
        TINY.lines().count() + 3
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + lf),
        &[
            &line,
            "`lf` runs the cross-entropy pilot rounds at the campaign's learned θ_LF*",
        ],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\npilot_fidelity = \"mf\"\n"),
        &["unknown variant `mf`, expected `hf` or `lf`"],
    );
    let line = format!(
        "line {}, key `estimate.control_extra`",
        TINY.lines().count() + 3
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\ncontrol_extra = 2\n"),
        &[&line, "2 extra LF runs per pair need `control_calibration`"],
    );
    assert_refused(
        &bad,
        &(TINY.to_string() + "\n[estimate]\ncontrol_calibration = 1\n"),
        &[
            "key `estimate.control_calibration`",
            "must be 0 (off) or at least 2 pairs",
        ],
    );
}

#[test]
fn an_estimate_with_another_campaigns_file_names_what_differs() {
    let dir = made_dir("other-file");
    let config = campaign_file(&dir, TINY);
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
    let other_dir = dir.join("other");
    std::fs::create_dir_all(&other_dir).unwrap();
    let other = campaign_file(
        &other_dir,
        &TINY
            .replace(
                "name = \"lead_vehicle_brakes\"",
                "name = \"stopped_obstacle\"",
            )
            .replace("fixed = { scenario = 7 }", "fixed = { scenario = 1 }"),
    );
    let (code, _, err) = common::run(&[
        "estimate",
        out.to_str().unwrap(),
        "--config",
        other.to_str().unwrap(),
        "--max-runs",
        "5",
        "--no-target",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("this campaign file describes another campaign than")
            && err.contains("train_scenarios [\"lead_vehicle_brakes\"] there, [\"stopped_obstacle\"] in the file")
            && !err.contains("was not learned"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `savme ARGS` run in directory `cwd`: exit status, standard output and standard error.
fn savme_in(cwd: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let o = Command::new(common::EXE)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Issue 40 item 3: a campaign's identity does not depend on how the campaign file's path is
/// spelled: run with `--config ./campaign.toml` beside its FMU (`hf = "sim.fmu"`), it resumes
/// and estimates from another directory with `--config ../campaign.toml` (refused before:
/// "simulator fmu:../sim.fmu|../sim.fmu there, fmu:./sim.fmu|./sim.fmu in the file"). Another
/// FMU of the same name is still another campaign.
#[test]
fn a_campaign_resumes_and_estimates_from_any_directory() {
    let dir = made_dir("spelling");
    std::fs::copy(packed(), dir.join("sim.fmu")).unwrap();
    std::fs::write(dir.join("campaign.toml"), TINY.replace("FMU", "sim.fmu")).unwrap();
    let (code, _, err) = savme_in(
        &dir,
        &[
            "run",
            "--config",
            "./campaign.toml",
            "--out",
            "out",
            "--quiet",
        ],
    );
    assert_eq!(code, Some(0), "{err}");
    let sub = dir.join("sub");
    std::fs::create_dir_all(&sub).unwrap();
    let (code, _, err) = savme_in(
        &sub,
        &[
            "run",
            "--config",
            "../campaign.toml",
            "--resume",
            "../out",
            "--quiet",
        ],
    );
    assert_eq!(code, Some(0), "resume from another directory: {err}");
    let (code, _, err) = savme_in(
        &sub,
        &[
            "estimate",
            "../out",
            "--config",
            "../campaign.toml",
            "--max-runs",
            "5",
            "--no-target",
        ],
    );
    assert_eq!(code, Some(0), "estimate from another directory: {err}");
    let parent = dir.parent().unwrap();
    let spelled = format!(
        "{}/./campaign.toml",
        dir.file_name().unwrap().to_str().unwrap()
    );
    let out = format!("{}/out", dir.file_name().unwrap().to_str().unwrap());
    let (code, _, err) = savme_in(
        parent,
        &["run", "--config", &spelled, "--resume", &out, "--quiet"],
    );
    assert_eq!(code, Some(0), "resume from the parent directory: {err}");
    // Another file named sim.fmu, beside another copy of the campaign file: another campaign.
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::copy(packed(), other.join("sim.fmu")).unwrap();
    std::fs::copy(dir.join("campaign.toml"), other.join("campaign.toml")).unwrap();
    let (code, _, err) = savme_in(
        &other,
        &[
            "estimate",
            "../out",
            "--config",
            "campaign.toml",
            "--max-runs",
            "5",
            "--no-target",
        ],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("describes another campaign"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
