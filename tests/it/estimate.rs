//! `savme estimate` end to end on the bundled simulator (idealised perception, for speed):
//! the importance-sampling interval covers a brute-force Monte Carlo value computed here
//! independently (fixed seeds); the summary agrees with the trial lines; the result does not
//! depend on `--jobs` and survives kill -9 + `--resume`; bad input is refused, naming the key,
//! variable, stage or line. The long check (≥ 20,000 Monte Carlo runs, a rare nominal) is the
//! example `estimate_check`, recorded in docs/RESULTS.md.
use crate::common;

use common::{run, temp_dir, trial_lines, EXE};
use rand::{RngExt, SeedableRng};
use savme_kernel::{Assignment, Role, Simulator};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

const SCENARIO: &str = "lead_vehicle_brakes";

/// A finished campaign that trained only `lead_vehicle_brakes` (200 iterations at C = 0.3;
/// every other stage one trial), made once for all tests.
fn campaign() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = temp_dir("campaign");
        let out = dir.display().to_string();
        let (code, _, err) = run(&[
            "reproduce",
            "--out",
            &out,
            "--perception",
            "ideal",
            "--budgets",
            "0.3",
            "--train-scenarios",
            SCENARIO,
            "--iterations",
            "200",
            "--eval-iterations",
            "1",
            "--test-iterations",
            "1",
            "--baseline-iterations",
            "1",
            "--baseline-test-iterations",
            "1",
            "--cost",
            "work",
            "--seed",
            "5",
            "--quiet",
            "--jobs",
            "2",
        ]);
        assert_eq!(code, Some(0), "{err}");
        dir
    })
}

fn estimate(out: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let c = campaign().display().to_string();
    let o = out.display().to_string();
    let mut a = vec!["estimate", &c, "--out", &o];
    a.extend(extra);
    run(&a)
}

fn summary(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// Brute-force Monte Carlo of P(failure) under the uniform nominal, independent of the
/// estimation code: φ uniform per variable, the HF simulator with idealised perception.
fn monte_carlo(runs: u32, seed: u64) -> f64 {
    let space = &savme_sim::scenario::spaces()[SCENARIO];
    let theta = savme_sim::fidelity::theta_hf();
    let mut sim = savme_sim::sim::DrivingSimulator::ideal();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut failures = 0;
    for _ in 0..runs {
        let mut phi = Assignment::new();
        for v in space.variables() {
            let (lo, hi) = (v.bin(0).unwrap().0, v.bin(v.arms() - 1).unwrap().1);
            phi.set(&v.name, lo + (hi - lo) * rng.random::<f64>());
        }
        let r = sim.simulate_as(Role::High, SCENARIO, &phi, &theta).unwrap();
        failures += u32::from(r.failure);
    }
    f64::from(failures) / f64::from(runs)
}

#[test]
fn the_interval_covers_brute_force_monte_carlo_and_agrees_with_the_trial_lines() {
    let out = temp_dir("cover");
    let (code, stdout, err) = estimate(&out, &["--no-target", "--max-runs", "3000", "--jobs", "2"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        stdout.contains("| lead_vehicle_brakes | 1.000 | 3000 |"),
        "{stdout}"
    );
    let s = summary(&out);
    let total = &s["estimate"]["total"];
    let (lo, hi, mean) = (
        total["lo"].as_f64().unwrap(),
        total["hi"].as_f64().unwrap(),
        total["mean"].as_f64().unwrap(),
    );
    let mc = monte_carlo(6000, 11);
    assert!(
        lo <= mc && mc <= hi,
        "IS [{lo}, {hi}] does not cover MC {mc}"
    );
    assert!(
        hi - lo < 0.3 * mean,
        "interval too wide to mean anything: [{lo}, {hi}]"
    );
    assert_eq!(s["stopped"], "max_runs");
    assert_eq!(s["training_hf_runs"], 200);
    // The trial lines: weight = p / q ≤ 1/ε, p = the uniform density 1/volume, and the
    // summary's estimate is their weighted mean.
    let space = &savme_sim::scenario::spaces()[SCENARIO];
    let volume: f64 = space
        .variables()
        .iter()
        .map(|v| v.bin(v.arms() - 1).unwrap().1 - v.bin(0).unwrap().0)
        .product();
    let ls = trial_lines(&out);
    assert_eq!(ls.len(), 3000);
    let mut sum = 0.0;
    for l in &ls {
        let (q, p, w) = (
            l["q"].as_f64().unwrap(),
            l["p"].as_f64().unwrap(),
            l["weight"].as_f64().unwrap(),
        );
        assert!((w - p / q).abs() < 1e-9 * w && w <= 10.0 + 1e-9, "{l}");
        assert!((p * volume - 1.0).abs() < 1e-9, "{l}");
        if l["hf"]["failure"].as_bool().unwrap() {
            sum += w;
        }
    }
    assert!((sum / 3000.0 - mean).abs() < 1e-12);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("**total (weighted by p(s))**"), "{table}");
    assert!(
        table.contains("failure ESS: the same over its failures"),
        "{table}"
    );
}

/// `--refine-reuse 1`: the last pilot round's runs join the estimate with their own weights —
/// the estimate is the pooled mean Σ w·f / N over them and the runs after the pilot, as the
/// trial lines give it — and the summary counts every run once.
#[test]
fn a_reused_pilot_round_counts_in_the_estimate_with_its_own_weights() {
    let args = [
        "--max-runs",
        "1600",
        "--no-target",
        "--refine-rounds",
        "3",
        "--refine-runs",
        "400",
        "--refine-reuse",
        "1",
        "--nominal",
        "lead_vehicle_brakes.ego_speed=normal:12,2",
    ];
    // Killed once 900 lines are stored (inside the reused round) and resumed: the replayed
    // reused runs count again, as in one uninterrupted run.
    let (_, out) = one_job_and_killed("reuse", &args, 900);
    let ls = trial_lines(&out);
    assert_eq!(ls.len(), 1600);
    let term = |l: &Value| {
        let w = l["weight"].as_f64().unwrap();
        if l["hf"]["failure"].as_bool().unwrap() {
            w
        } else {
            0.0
        }
    };
    assert!(ls[800..1200].iter().all(|l| l["round"] == 2));
    let pooled = ls[800..].iter().map(term).sum::<f64>() / 800.0;
    let s = summary(&out);
    let mean = s["estimate"]["total"]["mean"].as_f64().unwrap();
    assert!(
        (mean - pooled).abs() <= 1e-12 * pooled.max(1e-300),
        "{mean} vs {pooled}"
    );
    assert!(mean > 0.0, "the pooled runs hold failures");
    assert_eq!(
        (&s["pilot_hf_runs"], &s["pilot_hf_runs_reused"]),
        (&Value::from(1200), &Value::from(400))
    );
    assert_eq!(s["estimate_hf_runs"], 800);
    assert_eq!(s["estimate"]["runs"], 800);
    let cost: f64 = ls[800..]
        .iter()
        .map(|l| l["hf"]["runtime"].as_f64().unwrap())
        .sum();
    assert!((s["estimate_hf_cost"].as_f64().unwrap() - cost).abs() < 1e-9 * cost);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("the last 1 (these 400 runs) are part of the estimate too"),
        "{table}"
    );
    let settings: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("estimate.json")).unwrap()).unwrap();
    assert_eq!(settings["refine_reuse"], 1);
}

#[test]
fn jobs_do_not_change_the_trials_and_a_killed_estimate_resumes_identically() {
    let (one, killed) = one_job_and_killed("plain", &["--max-runs", "1500", "--no-target"], 200);
    assert!(trial_lines(&one).iter().all(|l| l.get("round").is_none()));
    assert_eq!(summary(&killed)["pilot_hf_runs"], 0);
}

/// A refined estimate: 1,800 runs, no target, 3 cross-entropy rounds of 400 runs, a normal
/// nominal on the ego speed (the kill tests' arguments).
const REFINED: [&str; 9] = [
    "--max-runs",
    "1800",
    "--no-target",
    "--refine-rounds",
    "3",
    "--refine-runs",
    "400",
    "--nominal",
    "lead_vehicle_brakes.ego_speed=normal:12,2",
];

/// With cross-entropy refinement (3 rounds of 400 runs, killed inside the first), the pilot
/// waits for each round: `--jobs 1` and a killed-and-resumed `--jobs 2` give the same lines,
/// pilot lines carry their round, and the estimate counts only the runs after the pilot.
#[test]
fn a_refined_estimate_is_the_same_for_any_jobs_and_after_a_kill() {
    let (one, killed) = one_job_and_killed("refined", &REFINED, 200);
    let ls = trial_lines(&one);
    for (i, l) in ls.iter().enumerate() {
        let round = (i < 1200).then_some(i as u64 / 400);
        assert_eq!(l["round"].as_u64(), round, "line {}", i + 1);
    }
    let s = summary(&killed);
    assert_eq!(s["pilot_hf_runs"], 1200);
    assert_eq!(s["estimate_hf_runs"], 600);
    assert_eq!(s["estimate"]["runs"], 600);
    let failures = ls[..1200]
        .iter()
        .filter(|l| l["hf"]["failure"].as_bool().unwrap())
        .count();
    assert_eq!(s["pilot_failures"], failures as u64);
    let table = std::fs::read_to_string(killed.join("table.md")).unwrap();
    assert!(
        table.contains("3 rounds of 400 HF runs (1200 runs made"),
        "{table}"
    );
    // The refit moved the proposal off the posterior's: its first ego-speed bins (where the
    // nominal's failures are) weigh more than the posterior gives them.
    let plain = temp_dir("refined-plain");
    let (code, _, err) = estimate(&plain, &[&REFINED[..3], &REFINED[7..]].concat());
    assert_eq!(code, Some(0), "{err}");
    let ego = |s: &Value| -> Vec<f64> {
        s["proposal"]["lead_vehicle_brakes"]["ego_speed"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let (refined, posterior) = (ego(&s), ego(&summary(&plain)));
    assert!(
        refined[2..5].iter().sum::<f64>() > 2.0 * posterior[2..5].iter().sum::<f64>(),
        "{refined:?} vs {posterior:?}"
    );
    // Progress on standard error: a line when it starts (then about every 10 s); none with
    // --quiet.
    let talk = temp_dir("refined-progress");
    let small = [
        "--refine-rounds",
        "3",
        "--refine-runs",
        "10",
        "--max-runs",
        "40",
    ];
    let (code, _, err) = estimate(&talk, &small);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.starts_with("estimate: 0 of at most 40 HF runs; cross-entropy pilot round 1 of 3; "),
        "{err}"
    );
    let quiet = temp_dir("refined-quiet");
    let (code, _, err) = estimate(&quiet, &[&small[..], &["--quiet"]].concat());
    assert_eq!((code, err.as_str()), (Some(0), ""));
    // An edited round is refused on resume, naming the line and the field.
    edit_line(&killed.join("trials.jsonl"), 2, |l| {
        l["round"] = Value::from(1);
    });
    refused(
        &killed,
        &["--resume"],
        1,
        "trials.jsonl, line 3: `round` is 1 but the estimate asks 0",
    );
}

/// A joint proposal (3 pilot rounds of 400 runs, the declared rare nominal): `--jobs 1` and a
/// killed-and-resumed `--jobs 2` give the same lines; after the pilot the draws are the
/// fitted mixture's, not the product proposal's; the settings and the table say so; a
/// resume that changes `proposal` is refused naming it.
#[test]
fn a_joint_estimate_is_the_same_for_any_jobs_and_after_a_kill() {
    let args = [
        "--max-runs",
        "1800",
        "--no-target",
        "--refine-rounds",
        "3",
        "--refine-runs",
        "400",
        "--nominal",
        "lead_vehicle_brakes.ego_speed=normal:12,2",
        "--proposal",
        "joint",
        "--joint-components",
        "4",
    ];
    let (one, killed) = one_job_and_killed("joint", &args, 200);
    let s = summary(&killed);
    assert_eq!(s["settings"]["proposal"], "joint");
    assert_eq!(s["settings"]["joint_components"], 4);
    assert_eq!(
        (s["pilot_hf_runs"].as_u64(), s["estimate"]["runs"].as_u64()),
        (Some(1200), Some(600))
    );
    // The first round is the product proposal's (the same draws as without --proposal); the
    // estimate's draws are not.
    let product = temp_dir("joint-product");
    let (code, _, err) = estimate(&product, &args[..9]);
    assert_eq!(code, Some(0), "{err}");
    let (j, p) = (trial_lines(&one), trial_lines(&product));
    let phi = |l: &Value| l["phi"].to_string();
    assert!((0..400).all(|i| phi(&j[i]) == phi(&p[i])));
    assert!((1200..1800).all(|i| phi(&j[i]) != phi(&p[i])));
    let table = std::fs::read_to_string(killed.join("table.md")).unwrap();
    assert!(
        table.contains("Joint proposal: after each round a mixture of at most 4 components"),
        "{table}"
    );
    refused(
        &killed,
        &["--resume", "--proposal", "product"],
        2,
        "the estimate was started with `proposal` = \"joint\", and this resume gives \"product\"",
    );
}

/// The multi-fidelity estimate (`--pilot-fidelity lf`, 3 pilot rounds of 400 runs, the
/// declared rare nominal): the pilot runs LF at the campaign's learned θ_LF* (its evaluation
/// stage's), the estimate HF only; `--jobs 1` and a `--jobs 2` run killed (SIGKILL) inside
/// the first round and resumed give the same lines; the summary charges the LF runs at their
/// cost (`hf_equivalent_runs`); a resume that changes `pilot_fidelity`, or a line whose run
/// is at the other fidelity, is refused naming it.
#[test]
fn a_low_fidelity_pilot_runs_at_the_learned_fidelity_and_resumes_identically_after_a_kill() {
    let args = [&REFINED[..], &["--pilot-fidelity", "lf"]].concat();
    let (one, killed) = one_job_and_killed("lf-pilot", &args, 200);
    let ls = trial_lines(&one);
    for (i, l) in ls.iter().enumerate() {
        let pilot = i < 1200;
        assert_eq!(
            l["round"].as_u64(),
            pilot.then_some(i as u64 / 400),
            "line {}",
            i + 1
        );
        assert_eq!(
            (l.get("lf").is_some(), l.get("hf").is_some()),
            (pilot, !pilot),
            "line {}",
            i + 1
        );
    }
    // θ_LF* is the campaign's: what its evaluation stage ran.
    let eval = trial_lines(campaign())
        .into_iter()
        .find(|l| l["stage"] == "evaluate@0.3")
        .expect("the campaign's evaluation");
    let s = summary(&killed);
    assert_eq!(s["theta_lf"], eval["theta_lf"]);
    assert_eq!(s["settings"]["pilot_fidelity"], "lf");
    assert_eq!(
        (
            &s["pilot_lf_runs"],
            &s["pilot_hf_runs"],
            &s["estimate"]["runs"]
        ),
        (&Value::from(1200), &Value::from(0), &Value::from(600))
    );
    let cost = |run: &str| -> f64 { ls.iter().filter_map(|l| l[run]["runtime"].as_f64()).sum() };
    let (lf, hf) = (cost("lf"), cost("hf"));
    assert!((s["pilot_lf_cost"].as_f64().unwrap() - lf).abs() < 1e-9 * lf);
    assert!(
        lf / 1200.0 < hf / 600.0,
        "the LF runs are the cheaper ones: {lf} vs {hf}"
    );
    let equivalent = 600.0 + lf / (hf / 600.0);
    assert!((s["hf_equivalent_runs"].as_f64().unwrap() - equivalent).abs() < 1e-9 * equivalent);
    let failures = ls[..1200]
        .iter()
        .filter(|l| l["lf"]["failure"].as_bool().unwrap())
        .count();
    assert_eq!(s["pilot_failures"], failures as u64);
    let table = std::fs::read_to_string(killed.join("table.md")).unwrap();
    assert!(
        table.contains("Multi-fidelity: the cross-entropy refinement ran 3 rounds of 400 LF runs"),
        "{table}"
    );
    refused(
        &killed,
        &["--resume", "--pilot-fidelity", "hf"],
        2,
        "the estimate was started with `pilot_fidelity` = \"lf\", and this resume gives \"hf\"",
    );
    // A pilot line turned into an HF run is refused on resume, naming the line.
    edit_line(&killed.join("trials.jsonl"), 2, |l| {
        let lf_run = l["lf"].clone();
        l.as_object_mut().unwrap().remove("lf");
        l["hf"] = lf_run;
    });
    refused(
        &killed,
        &["--resume"],
        1,
        "trials.jsonl, line 3: `hf/lf` is an HF run but the estimate asks an LF run",
    );
    // A campaign cut after its training, before its evaluation stage: no θ_LF* to run the
    // pilot at (the protocol record, baseline-train and the 200 trials of train@0.3 kept).
    let dir = temp_dir("no-eval");
    std::fs::create_dir_all(&dir).unwrap();
    let c = campaign();
    std::fs::copy(c.join("protocol.json"), dir.join("protocol.json")).unwrap();
    let text = std::fs::read_to_string(c.join("trials.jsonl")).unwrap();
    let kept: Vec<&str> = text.lines().take(202).collect();
    assert!(!kept.iter().any(|l| l.contains("evaluate@0.3")));
    std::fs::write(dir.join("trials.jsonl"), kept.join("\n") + "\n").unwrap();
    let d = dir.display().to_string();
    let (code, _, err) = run(&[
        "estimate",
        &d,
        "--refine-rounds",
        "2",
        "--refine-runs",
        "10",
        "--pilot-fidelity",
        "lf",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("runs the pilot at the learned θ_LF* of budget 0.3, which the campaign's stage `evaluate@0.3` has not run yet"),
        "{err}"
    );
}

/// LF runs as control variates (`--control-calibration 200 --control-extra 2`, the declared
/// rare nominal, no pilot): 200 calibration pairs (HF then LF at the same φ), then blocks of
/// an estimate pair and its 2 extra LF runs; `--jobs 1` and a `--jobs 2` run killed (SIGKILL)
/// inside the estimate and resumed give the same lines; the summary's estimate is the
/// control-variate estimate ā_n + α·(b̄_m − b̄_n) of the lines with the stored α, and its
/// costs agree with the lines; a resume that changes `control_calibration`, and a line
/// whose `control` was edited, are refused naming them.
#[test]
fn control_variates_pair_hf_and_lf_runs_and_resume_identically_after_a_kill() {
    let args = [
        "--max-runs",
        "1400",
        "--no-target",
        "--control-calibration",
        "200",
        "--control-extra",
        "2",
        "--nominal",
        "lead_vehicle_brakes.ego_speed=normal:12,2",
    ];
    let (one, killed) = one_job_and_killed("control", &args, 700);
    let ls = trial_lines(&one);
    assert_eq!(ls.len(), 1400);
    let part = |l: &Value| l["control"].as_str().unwrap_or("none").to_string();
    for (i, l) in ls.iter().enumerate() {
        let (want, lf) = match i {
            i if i < 400 => ("calibration", i % 2 == 1),
            i => match (i - 400) % 4 {
                0 => ("paired", false),
                1 => ("paired", true),
                _ => ("extra", true),
            },
        };
        assert_eq!(
            (part(l).as_str(), l.get("lf").is_some()),
            (want, lf),
            "line {}",
            i + 1
        );
        if want != "extra" && lf {
            assert_eq!(l["phi"], ls[i - 1]["phi"], "line {}: a pair's φ", i + 1);
        }
    }
    let s = summary(&killed);
    let plan = &s["control_plans"][SCENARIO];
    assert_eq!(
        (plan["extra"].as_u64(), plan["use_lf"].as_bool()),
        (Some(2), Some(true))
    );
    assert_eq!(
        (
            &s["calibration_hf_runs"],
            &s["control_lf_runs"],
            &s["estimate"]["runs"]
        ),
        (&Value::from(200), &Value::from(950), &Value::from(250))
    );
    // The control-variate estimate, recomputed from the lines with the stored α.
    let y = |l: &Value, run: &str| {
        let f = l[run]["failure"].as_bool().unwrap();
        if f {
            l["weight"].as_f64().unwrap()
        } else {
            0.0
        }
    };
    let est = &ls[400..];
    let a: Vec<f64> = est
        .iter()
        .filter(|l| l.get("hf").is_some())
        .map(|l| y(l, "hf"))
        .collect();
    let b_pairs: Vec<f64> = est
        .iter()
        .filter(|l| part(l) == "paired" && l.get("lf").is_some())
        .map(|l| y(l, "lf"))
        .collect();
    let b_all: Vec<f64> = est
        .iter()
        .filter(|l| l.get("lf").is_some())
        .map(|l| y(l, "lf"))
        .collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let alpha = plan["alpha"].as_f64().unwrap();
    let want = mean(&a) + alpha * (mean(&b_all) - mean(&b_pairs));
    let got = s["estimate"]["total"]["mean"].as_f64().unwrap();
    assert!(
        (got - want).abs() <= 1e-12 * want.abs().max(1e-300),
        "{got} vs {want}"
    );
    let cost = |run: &str| -> f64 { ls.iter().filter_map(|l| l[run]["runtime"].as_f64()).sum() };
    let (lf, hf) = (cost("lf"), cost("hf"));
    assert!((s["control_lf_cost"].as_f64().unwrap() - lf).abs() < 1e-9 * lf);
    let equivalent = 450.0 + lf / (hf / 450.0);
    assert!((s["hf_equivalent_runs"].as_f64().unwrap() - equivalent).abs() < 1e-9 * equivalent);
    refused(
        &killed,
        &["--resume", "--control-calibration", "300"],
        2,
        "the estimate was started with `control_calibration` = 200, and this resume gives 300",
    );
    // An extra LF line turned into a paired one is refused on resume, naming the line.
    edit_line(&killed.join("trials.jsonl"), 402, |l| {
        l["control"] = Value::from("paired");
    });
    refused(
        &killed,
        &["--resume"],
        1,
        "trials.jsonl, line 403: `control` is \"paired\" but the estimate asks \"extra\" here",
    );
}

/// With the calibration choosing (no `--control-extra`): the plan is stored with its
/// measured ρ and cost ratio, and the runs after the calibration follow it — blocks of a
/// pair and its extra LF runs when it uses the LF, plain HF runs (the importance-sampling
/// estimate) when it does not.
#[test]
fn the_calibration_chooses_whether_the_lf_pays_and_the_runs_follow_its_plan() {
    let out = temp_dir("control-chosen");
    let (code, _, err) = estimate(
        &out,
        &[
            "--max-runs",
            "1000",
            "--no-target",
            "--control-calibration",
            "300",
            "--nominal",
            "lead_vehicle_brakes.ego_speed=normal:12,2",
        ],
    );
    assert_eq!(code, Some(0), "{err}");
    let s = summary(&out);
    let plan = &s["control_plans"][SCENARIO];
    let ratio = plan["cost_ratio"].as_f64().unwrap();
    assert!(
        ratio > 0.0 && ratio < 1.0,
        "the LF is the cheaper run: {ratio}"
    );
    assert!(plan["rho"].as_f64().unwrap().abs() <= 1.0);
    let ls = trial_lines(&out);
    let after = &ls[600..];
    if plan["use_lf"].as_bool().unwrap() {
        let k = plan["extra"].as_u64().unwrap() as usize;
        assert!(after
            .iter()
            .step_by(k + 2)
            .all(|l| l["control"] == "paired" && l.get("hf").is_some()));
    } else {
        assert_eq!(plan["alpha"], 0.0);
        assert!(after
            .iter()
            .all(|l| l.get("control").is_none() && l.get("hf").is_some()));
        assert_eq!(s["estimate"]["runs"], 400);
    }
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("Control variates:"), "{table}");
}

/// Runs the estimate with `args` once with `--jobs 1`, and once with `--jobs 2` killed
/// (SIGKILL) after ≥ 200 stored lines and resumed; asserts the two agree line by line.
fn one_job_and_killed(name: &str, args: &[&str], kill_at: usize) -> (PathBuf, PathBuf) {
    let one = temp_dir(&format!("{name}-jobs1"));
    let (code, _, err) = estimate(&one, &[args, &["--jobs", "1"]].concat());
    assert_eq!(code, Some(0), "{err}");
    let killed = temp_dir(&format!("{name}-killed"));
    let c = campaign().display().to_string();
    let o = killed.display().to_string();
    let mut child = Command::new(EXE)
        .args(["estimate", &c, "--out", &o, "--jobs", "2"])
        .args(args)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let trials = killed.join("trials.jsonl");
    let t0 = std::time::Instant::now();
    while std::fs::read_to_string(&trials).map_or(0, |t| t.lines().count()) < kill_at {
        assert!(t0.elapsed().as_secs() < 120, "the estimate did not start");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let before = trial_lines(&killed).len();
    assert!(
        before < trial_lines(&one).len(),
        "killed too late: {before}"
    );
    let (code, _, err) = estimate(&killed, &["--resume", "--jobs", "2"]);
    assert_eq!(code, Some(0), "{err}");
    let strip = |v: Vec<Value>| -> Vec<Value> {
        v.into_iter()
            .map(|mut l| {
                // Measured wall time differs between runs (and the store's checksum, which
                // covers it); everything else must be equal.
                for run in ["hf", "lf"] {
                    if l.get(run).is_some() {
                        l[run]["wall_seconds"] = Value::Null;
                    }
                }
                if let Some(o) = l.as_object_mut() {
                    o.remove("c");
                }
                l
            })
            .collect()
    };
    assert_eq!(strip(trial_lines(&killed)), strip(trial_lines(&one)));
    assert_eq!(summary(&killed)["estimate"], summary(&one)["estimate"]);
    assert_eq!(summary(&killed)["replayed"], before as u64);
    (one, killed)
}

#[test]
fn a_target_width_stops_the_estimate_once_reached() {
    let out = temp_dir("target");
    let (code, _, err) = estimate(&out, &["--target-width", "0.15", "--max-runs", "5000"]);
    assert_eq!(code, Some(0), "{err}");
    let s = summary(&out);
    assert_eq!(s["stopped"], "target_width");
    let total = &s["estimate"]["total"];
    let rel = total["half_width"].as_f64().unwrap() / total["mean"].as_f64().unwrap();
    assert!(rel <= 0.15, "{rel}");
    // It stopped at the first run after which the rule held: one run fewer was not enough.
    let ls = trial_lines(&out);
    let n = ls.len();
    assert!(n < 5000);
    let y: Vec<f64> = ls
        .iter()
        .map(|l| {
            if l["hf"]["failure"].as_bool().unwrap() {
                l["weight"].as_f64().unwrap()
            } else {
                0.0
            }
        })
        .collect();
    let rel_at = |k: usize| {
        let m = y[..k].iter().sum::<f64>() / k as f64;
        let v = y[..k].iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k as f64 - 1.0);
        1.959_963_984_540_054 * (v / k as f64).sqrt() / m
    };
    assert!((rel_at(n) - rel).abs() < 1e-9 && rel_at(n - 1) > 0.15);
}

#[test]
fn bad_input_is_refused_naming_the_key_variable_stage_or_line() {
    let out = temp_dir("bad");
    let o = out.display().to_string();
    let cases: &[(&[&str], &str)] = &[
        (&["--epsilon", "0"], "`epsilon`: must lie in (0, 1]"),
        (&["--epsilon", "1.5"], "`epsilon`: must lie in (0, 1]"),
        (
            &["--target-width", "0"],
            "`target_width`: must be a finite number > 0",
        ),
        (
            &["--target-width", "-0.1"],
            "`target_width`: must be a finite number > 0",
        ),
        (&["--max-runs", "0"], "`max_runs`: must lie in 1..="),
        (
            &["--budget", "0.5"],
            "the campaign trained budgets 0.3, not 0.5",
        ),
        (
            &["--scenario", "nowhere"],
            "scenario `nowhere` was not learned",
        ),
        (
            &["--nominal", "lead_vehicle_brakes.ego_sped=normal:12,2"],
            "unknown variable `ego_sped` of scenario `lead_vehicle_brakes`",
        ),
        (
            &["--nominal", "nowhere.ego_speed=normal:12,2"],
            "nominal declared for unknown scenario `nowhere`",
        ),
        (
            &["--nominal", "lead_vehicle_brakes.ego_speed=normal:12,0"],
            "nominal of variable `ego_speed` of scenario `lead_vehicle_brakes`: a normal needs",
        ),
        (
            &["--nominal", "ego_speed=normal:12,2"],
            "expected SCENARIO.VARIABLE before `=`",
        ),
        (
            &["--nominal", "lead_vehicle_brakes.ego_speed=normal:12"],
            "normal takes two numbers",
        ),
        (
            &["--nominal", "lead_vehicle_brakes.ego_speed=gamma:1"],
            "the distribution is uniform",
        ),
        (
            &[
                "--nominal",
                "lead_vehicle_brakes.ego_speed=normal:12,2",
                "--nominal",
                "lead_vehicle_brakes.ego_speed=normal:20,2",
            ],
            "--nominal `lead_vehicle_brakes.ego_speed=normal:20,2`: `lead_vehicle_brakes.ego_speed` is declared by an earlier --nominal",
        ),
        (
            &["--refine-runs", "100"],
            "`refine_runs`: 100 runs per round but no `refine_rounds`",
        ),
        (
            &["--refine-rounds", "2"],
            "`refine_runs`: 2 refinement rounds need `refine_runs` ≥ 1",
        ),
        (
            &["--refine-rounds", "2", "--refine-runs", "5000"],
            "2 rounds of 5000 runs leave none of `max_runs` = 10000",
        ),
        (
            &[
                "--refine-rounds",
                "2",
                "--refine-runs",
                "5",
                "--refine-reuse",
                "3",
            ],
            "`refine_reuse`: 3 pilot rounds to reuse in the estimate, but `refine_rounds` is 2",
        ),
        (
            &["--proposal", "joint"],
            "`proposal`: the joint proposal is fitted by the cross-entropy pilot rounds: give `refine_rounds` and `refine_runs` too",
        ),
        (
            &["--joint-components", "3"],
            "`joint_components`: 3 components need `proposal` = \"joint\"",
        ),
        (
            &[
                "--proposal",
                "joint",
                "--refine-rounds",
                "2",
                "--refine-runs",
                "5",
                "--joint-components",
                "65",
            ],
            "`joint_components`: must lie in 1..=64, got 65",
        ),
        (
            &["--pilot-fidelity", "lf"],
            "`pilot_fidelity`: `lf` runs the cross-entropy pilot rounds at the campaign's learned θ_LF*: give `refine_rounds` and `refine_runs` too",
        ),
        (
            &[
                "--pilot-fidelity",
                "lf",
                "--refine-rounds",
                "2",
                "--refine-runs",
                "5",
                "--refine-reuse",
                "1",
            ],
            "`refine_reuse`: 1 pilot rounds to reuse, but the pilot runs at LF",
        ),
        (
            &["--pilot-fidelity", "mf"],
            "invalid value 'mf' for '--pilot-fidelity",
        ),
        (
            &["--control-calibration", "1"],
            "`control_calibration`: must be 0 (off) or at least 2 pairs",
        ),
        (
            &["--control-extra", "3"],
            "`control_extra`: 3 extra LF runs per pair need `control_calibration`",
        ),
        (
            &["--control-calibration", "10", "--control-extra", "65"],
            "`control_extra`: must lie in 0..=64 extra LF runs per pair, got 65",
        ),
        (
            &[
                "--control-calibration",
                "10",
                "--refine-rounds",
                "2",
                "--refine-runs",
                "5",
                "--refine-reuse",
                "1",
            ],
            "`refine_reuse`: 1 pilot rounds to reuse, but with control variates",
        ),
        (
            &["--control-calibration", "50", "--max-runs", "50"],
            "`control_calibration`: 50 calibration pairs (2 runs each) leave no runs of `max_runs` = 50",
        ),
    ];
    for (args, message) in cases {
        let (code, _, err) = estimate(&out, args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err}");
        assert!(!out.join("trials.jsonl").exists(), "{args:?} ran trials");
    }
    // --resume without an estimate; then a finished one without --resume.
    let (code, _, err) = estimate(&out, &["--resume"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("no estimate to resume"), "{err}");
    let (code, _, err) = estimate(&out, &["--max-runs", "30", "--no-target"]);
    assert_eq!(code, Some(0), "{err}");
    refused(
        &out,
        &["--max-runs", "30"],
        1,
        "already holds an estimate; continue it with --resume",
    );
    // An edited stored trial is refused on resume, naming the line and the field.
    edit_line(&out.join("trials.jsonl"), 4, |l| {
        l["weight"] = Value::from(l["weight"].as_f64().unwrap() * 2.0);
    });
    let (code, _, err) = estimate(&out, &["--resume"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("trials.jsonl, line 5: `weight` is"), "{err}");
    let _ = o;
}

#[test]
fn estimating_before_training_is_refused_naming_the_stage() {
    // The campaign cut inside its training stage (as if it were stopped there).
    let dir = temp_dir("untrained");
    std::fs::create_dir_all(&dir).unwrap();
    let c = campaign();
    std::fs::copy(c.join("protocol.json"), dir.join("protocol.json")).unwrap();
    let text = std::fs::read_to_string(c.join("trials.jsonl")).unwrap();
    // The protocol record, baseline-train and 50 of train@0.3.
    let cut: Vec<&str> = text.lines().take(52).collect();
    std::fs::write(dir.join("trials.jsonl"), cut.join("\n") + "\n").unwrap();
    let d = dir.display().to_string();
    let (code, _, err) = run(&["estimate", &d]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("stage `train@0.3` has 50 of its 200 trials; finish the campaign"),
        "{err}"
    );
    assert!(!dir.join("estimate-0.3").join("trials.jsonl").exists());
    // No campaign at all.
    let empty = temp_dir("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let (code, _, err) = run(&["estimate", &empty.display().to_string()]);
    assert_eq!(code, Some(1));
    assert!(err.contains("no protocol.json"), "{err}");
}

#[test]
fn the_nominal_weighted_tilt_is_stored_with_the_settings() {
    let out = temp_dir("tilt");
    let (code, _, err) = estimate(
        &out,
        &[
            "--tilt",
            "nominal-weighted",
            "--nominal",
            "lead_vehicle_brakes.ego_speed=normal:12,2",
            "--max-runs",
            "50",
            "--no-target",
        ],
    );
    assert_eq!(code, Some(0), "{err}");
    let settings: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("estimate.json")).unwrap()).unwrap();
    assert_eq!(settings["tilt"], "nominal-weighted");
    // The slow ego speeds the nominal favours get more of the proposal than under `posterior`.
    let bins = |s: &Value| -> f64 {
        s["proposal"]["lead_vehicle_brakes"]["ego_speed"]
            .as_array()
            .unwrap()[..3]
            .iter()
            .map(|v| v.as_f64().unwrap())
            .sum()
    };
    let plain = temp_dir("tilt-plain");
    let (code, _, err) = estimate(
        &plain,
        &[
            "--nominal",
            "lead_vehicle_brakes.ego_speed=normal:12,2",
            "--max-runs",
            "50",
            "--no-target",
        ],
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(bins(&summary(&out)) > 2.0 * bins(&summary(&plain)));
    let (code, _, err) = estimate(&temp_dir("tilt-bad"), &["--tilt", "sideways"]);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("invalid value 'sideways' for '--tilt"),
        "{err}"
    );
}

#[test]
fn a_resume_refuses_a_changed_setting_naming_both_values_and_applies_a_stopping_rule() {
    let out = temp_dir("resume-changed");
    let o = out.display().to_string();
    let (code, _, err) = estimate(&out, &["--no-target", "--max-runs", "20", "--jobs", "1"]);
    assert_eq!(code, Some(0), "{err}");
    let first = trial_lines(&out);
    assert_eq!(first.len(), 20);
    // A setting that changes the runs drawn: refused, naming it and both values; nothing ran.
    for (flags, named) in [
        (
            vec!["--epsilon", "0.5"],
            "`epsilon` = 0.1, and this resume gives 0.5",
        ),
        (
            vec!["--seed", "9"],
            "`seed` = null, and this resume gives 9",
        ),
        (
            vec!["--tilt", "nominal-weighted"],
            "`tilt` = \"posterior\", and this resume gives \"nominal-weighted\"",
        ),
    ] {
        let mut args = vec!["--resume", "--quiet"];
        args.extend(flags.iter().copied());
        let (code, _, err) = estimate(&out, &args);
        assert_eq!(code, Some(2), "{flags:?}: {err}");
        assert!(
            err.contains(named) && err.contains("estimate.json"),
            "{flags:?}: {err}"
        );
        assert_eq!(trial_lines(&out), first, "{flags:?}: nothing ran");
    }
    // The same value as stored, or none given: accepted (a resume of a finished estimate).
    let (code, _, err) = estimate(&out, &["--resume", "--quiet", "--epsilon", "0.1"]);
    assert_eq!(code, Some(0), "{err}");
    // A stopping rule: applied, said, stored; the first 20 runs are those of before.
    let (code, _, err) = estimate(&out, &["--resume", "--quiet", "--max-runs", "30"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("max_runs: 20 → 30"), "{err}");
    let more = trial_lines(&out);
    assert_eq!((more.len(), &more[..20]), (30, &first[..]));
    assert_eq!(summary(&out)["settings"]["max_runs"], 30);
    assert_eq!(summary(&out)["changed_on_resume"][0], "max_runs: 20 → 30");
    // Fewer runs than are stored: refused naming both counts.
    let (code, _, err) = run(&[
        "estimate",
        &campaign().display().to_string(),
        "--out",
        &o,
        "--resume",
        "--max-runs",
        "25",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("holds 30 runs") && err.contains("got 25"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Runs `savme estimate` on `dir` with `args` and checks that it stops with exit status `code`
/// and an error containing `message`.
fn refused(dir: &Path, args: &[&str], code: i32, message: &str) {
    let (got, _, err) = estimate(dir, args);
    assert_eq!(got, Some(code), "{err}");
    assert!(err.contains(message), "{err}");
}

/// Rewrites line `index` (0-based) of the JSON-lines file `path` through `edit`, as a user
/// editing a stored trial would.
fn edit_line(path: &Path, index: usize, edit: impl FnOnce(&mut Value)) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut ls: Vec<String> = text.lines().map(String::from).collect();
    let mut l: Value = serde_json::from_str(&ls[index]).unwrap();
    edit(&mut l);
    ls[index] = l.to_string();
    std::fs::write(path, ls.join("\n") + "\n").unwrap();
}
