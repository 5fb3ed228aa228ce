//! Recordings read back with rerun's ChunkStore (only with `--features rerun`).
#![cfg(feature = "rerun")]

use rerun::{ChunkStore, ChunkStoreConfig};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_savme");

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("savme-record-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Rows per entity path, and the texts of text logs, from an .rrd file.
struct Loaded {
    rows: BTreeMap<String, usize>,
    texts: Vec<String>,
    scalars: BTreeMap<String, Vec<f64>>,
}

fn load(path: &Path) -> Loaded {
    let mut f = std::fs::File::open(path).unwrap();
    let stores = ChunkStore::from_rrd_reader(&ChunkStoreConfig::DEFAULT, &mut f)
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()));
    let mut rows = BTreeMap::new();
    let mut texts = Vec::new();
    let mut scalars: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let text_id = rerun::TextLog::descriptor_text().component;
    let scalar_id = rerun::Scalars::descriptor_scalars().component;
    for store in stores.values() {
        for chunk in store.iter_physical_chunks() {
            let entity = chunk.entity_path().to_string();
            *rows.entry(entity.clone()).or_insert(0) += chunk.num_rows();
            for t in chunk.iter_component::<rerun::components::Text>(text_id) {
                texts.extend(t.iter().map(|x| x.as_str().to_string()));
            }
            for s in chunk.iter_component::<rerun::components::Scalar>(scalar_id) {
                scalars
                    .entry(entity.clone())
                    .or_default()
                    .extend(s.iter().map(|x| x.0 .0));
            }
        }
    }
    Loaded {
        rows,
        texts,
        scalars,
    }
}

#[test]
fn simulate_records_a_run_with_its_sensor_frames() {
    let dir = temp_dir("simulate");
    let rrd = dir.join("run.rrd");
    let phi = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    let o = Command::new(EXE)
        .args(["simulate", "--scenario", "7", "--phi", phi, "--record"])
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let l = load(&rrd);
    for e in [
        "/world/oneway/scenery",
        "/run/ego",
        "/run/intruder",
        "/run/ego_trajectory",
        "/run/camera",
        "/run/lidar",
        "/run/closest_approach",
        "/run/predicted_closest_approach",
        "/run/outcome",
    ] {
        assert!(l.rows.contains_key(e), "no {e} in {:?}", l.rows.keys());
    }
    // One ego box per simulated step (+ the collision instant), as the in-process run.
    let run = savme_sim::sim::DrivingSimulator::default()
        .run(
            "lead_vehicle_brakes",
            &savme::kernel::Assignment::new()
                .with("ego_speed", 20.0)
                .with("lead_speed", 10.0)
                .with("gap", 8.0)
                .with("lead_decel", 9.0)
                .with("brake_time", 0.5),
            &savme_sim::fidelity::theta_hf(),
            true,
        )
        .unwrap();
    assert_eq!(l.rows["/run/ego"], run.trajectory.as_ref().unwrap().len());
    assert_eq!(
        l.rows["/run/camera"],
        run.sensor_frames.as_ref().unwrap().len()
    );
    let t = run.collision_time.expect("this φ collides");
    assert!(
        l.texts
            .iter()
            .any(|x| x.contains(&format!("collision at {t:.2} s"))),
        "{:?}",
        l.texts
    );
}

// Long because it checks every entity of one recorded campaign, which is slow to produce.
#[test]
fn a_campaign_records_bounded_frames_and_its_learning() {
    let dir = temp_dir("campaign");
    let rrd = dir.join("campaign.rrd");
    let out = dir.join("out");
    let o = Command::new(EXE)
        .args([
            "reproduce",
            "--quiet",
            "--budgets",
            "0.3",
            "--iterations",
            "12",
            "--eval-iterations",
            "4",
            "--test-iterations",
            "6",
            "--baseline-iterations",
            "10",
            "--baseline-test-iterations",
            "6",
            "--cost",
            "work",
            "--record-every",
            "7",
            "--record-failures",
            "2",
            "--out",
        ])
        .arg(&out)
        .arg("--record")
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let l = load(&rrd);
    // The bounded-frames rule, recomputed from trials.jsonl: every 7th told trial, plus the
    // first two HF failures among the others.
    let trials: Vec<serde_json::Value> = std::fs::read_to_string(out.join("trials.jsonl"))
        .unwrap()
        .lines()
        .map(|x| serde_json::from_str(x).unwrap())
        .collect();
    let mut expected = BTreeSet::new();
    let mut failures = 0;
    for (n, t) in trials.iter().enumerate() {
        if n % 7 == 0 {
            expected.insert(n);
        } else if t["hf"]["failure"] == true && failures < 2 {
            failures += 1;
            expected.insert(n);
        }
    }
    let recorded: BTreeSet<usize> = l
        .rows
        .keys()
        .filter_map(|e| e.strip_prefix("/trials/"))
        .filter_map(|rest| rest.split('/').next()?.parse().ok())
        .collect();
    assert_eq!(recorded, expected);
    // Each recorded paired trial has both runs with camera and lidar.
    for n in &expected {
        let paired = !trials[*n]["lf"].is_null();
        for run in if paired { vec!["hf", "lf"] } else { vec!["hf"] } {
            for what in ["camera", "lidar", "ego"] {
                let e = format!("/trials/{n}/{run}/{what}");
                assert!(l.rows.contains_key(&e), "missing {e}");
            }
        }
    }
    // Learning: one found-failures point per trial of the stage, ending at its HF failures.
    let train: Vec<&serde_json::Value> = trials
        .iter()
        .filter(|t| t["stage"] == "train@0.3")
        .collect();
    let curve = l
        .scalars
        .get("/campaign/found_failures/train/0_3")
        .unwrap_or_else(|| panic!("no curve in {:?}", l.scalars.keys()));
    assert_eq!(curve.len(), train.len());
    let hf_failures = train.iter().filter(|t| t["hf"]["failure"] == true).count();
    assert_eq!(*curve.last().unwrap(), hf_failures as f64);
    assert!(
        l.rows
            .keys()
            .any(|e| e.starts_with("/campaign/fidelity/train/0_3/")),
        "{:?}",
        l.rows.keys()
    );
    assert!(l.rows.contains_key("/campaign/budget"));
}

#[test]
fn ctrl_c_still_closes_the_recording() {
    let dir = temp_dir("sigint");
    let rrd = dir.join("interrupted.rrd");
    let mut child = Command::new(EXE)
        .args([
            "reproduce",
            "--quiet",
            "--budgets",
            "0.3",
            "--iterations",
            "400",
            "--cost",
            "work",
            "--record-every",
            "3",
            "--out",
        ])
        .arg(dir.join("out"))
        .arg("--record")
        .arg(&rrd)
        .spawn()
        .unwrap();
    let log = dir.join("out").join("trials.jsonl");
    let start = Instant::now();
    while std::fs::read_to_string(&log).map_or(0, |s| s.lines().count()) < 8 {
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let status = child.wait().unwrap();
    assert!(!status.success(), "it should stop on Ctrl-C");
    let l = load(&rrd);
    assert!(
        l.rows.keys().any(|e| e.starts_with("/trials/0/hf/")),
        "{:?}",
        l.rows.keys()
    );
}
