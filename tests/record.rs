//! Recordings read back with rerun's ChunkStore (only with `--features rerun`): the trial view
//! of `savme simulate --record`, a campaign's recordings (one per recorded trial, chosen by the
//! informative-first rule), their blueprints, Ctrl-C, and `--connect` to nowhere.
#![cfg(feature = "rerun")]
mod common;
#[path = "record/views.rs"]
mod views;

use common::{made_dir, EXE};
use rerun::external::re_sdk_types::blueprint::archetypes::ViewBlueprint;
use rerun::{ChunkStore, ChunkStoreConfig};
use savme::viewer::layout::names;
use savme::viewer::rerun;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// One store (a recording or a blueprint) of an .rrd file.
#[derive(Default, Debug)]
struct Store {
    app: String,
    blueprint: bool,
    /// Rows per entity path.
    rows: BTreeMap<String, usize>,
    /// Texts (logs, documents, labels) per entity path.
    texts: BTreeMap<String, Vec<String>>,
    /// Scalars per entity path, in row order.
    scalars: BTreeMap<String, Vec<f64>>,
    /// Largest time per timeline per entity path.
    times: BTreeMap<String, BTreeMap<String, i64>>,
    /// Blobs per entity path.
    blobs: BTreeMap<String, Vec<Vec<u8>>>,
    /// The recording's name, or the blueprint's view names.
    names: Vec<String>,
    /// Text log levels.
    levels: Vec<String>,
    /// Colours (series styles, boxes) per entity path, as RGBA.
    colours: BTreeMap<String, Vec<u32>>,
}

impl Store {
    fn has(&self, e: &str) -> bool {
        self.rows.contains_key(e)
    }

    fn text(&self, e: &str) -> String {
        self.texts.get(e).map(|t| t.join("\n")).unwrap_or_default()
    }

    fn timelines(&self) -> BTreeSet<String> {
        self.times
            .values()
            .flat_map(|t| t.keys().cloned())
            .collect()
    }
}

// Long because it reads every kind of component the tests look at, chunk by chunk.
fn load(path: &Path) -> Vec<Store> {
    use rerun::external::re_sdk_types::archetypes as a;
    let mut f = std::fs::File::open(path).unwrap();
    let stores = ChunkStore::from_rrd_reader(&ChunkStoreConfig::DEFAULT, &mut f)
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()));
    let text_ids = [
        a::TextLog::descriptor_text().component,
        a::TextDocument::descriptor_text().component,
        a::Boxes2D::descriptor_labels().component,
        a::Points2D::descriptor_labels().component,
        a::Points3D::descriptor_labels().component,
        a::Boxes3D::descriptor_labels().component,
        a::LineStrips3D::descriptor_labels().component,
        a::SeriesLines::descriptor_names().component,
    ];
    let name_ids = [
        ViewBlueprint::descriptor_display_name().component,
        a::RecordingInfo::descriptor_name().component,
    ];
    let mut out = Vec::new();
    for (id, store) in &stores {
        let mut s = Store {
            app: id.application_id().to_string(),
            blueprint: id.is_blueprint(),
            ..Store::default()
        };
        for chunk in store.iter_physical_chunks() {
            let entity = chunk.entity_path().to_string();
            *s.rows.entry(entity.clone()).or_insert(0) += chunk.num_rows();
            for t in text_ids {
                for x in chunk.iter_component::<rerun::components::Text>(t) {
                    let v = s.texts.entry(entity.clone()).or_default();
                    v.extend(x.iter().map(|x| x.as_str().to_string()));
                }
            }
            for t in name_ids {
                for x in chunk.iter_component::<rerun::components::Name>(t) {
                    s.names.extend(x.iter().map(|x| x.as_str().to_string()));
                }
            }
            for x in chunk.iter_component::<rerun::components::Scalar>(
                rerun::Scalars::descriptor_scalars().component,
            ) {
                let v = s.scalars.entry(entity.clone()).or_default();
                v.extend(x.iter().map(|x| x.0 .0));
            }
            for x in chunk.iter_component::<rerun::components::Blob>(
                a::EncodedImage::descriptor_blob().component,
            ) {
                let v = s.blobs.entry(entity.clone()).or_default();
                v.extend(x.iter().map(|b| b.0.to_vec()));
            }
            for c in [
                a::SeriesLines::descriptor_colors().component,
                a::SeriesPoints::descriptor_colors().component,
                a::Boxes2D::descriptor_colors().component,
            ] {
                for x in chunk.iter_component::<rerun::components::Color>(c) {
                    let v = s.colours.entry(entity.clone()).or_default();
                    v.extend(x.iter().map(|c| c.0 .0));
                }
            }
            for x in chunk.iter_component::<rerun::components::TextLogLevel>(
                a::TextLog::descriptor_level().component,
            ) {
                s.levels.extend(x.iter().map(|l| l.as_str().to_string()));
            }
            for (name, col) in chunk.timelines() {
                let max = col.times_raw().iter().copied().max().unwrap_or(0);
                let t = s.times.entry(entity.clone()).or_default();
                let m = t.entry(name.to_string()).or_insert(i64::MIN);
                *m = (*m).max(max);
            }
        }
        out.push(s);
    }
    out
}

/// The application whose blueprint the file activates last: the view a viewer opens on.
fn last_activated_app(path: &Path) -> String {
    use rerun::external::re_log_encoding::DecoderApp;
    use rerun::external::re_log_types::LogMsg;
    let f = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut last = None;
    for msg in DecoderApp::decode_eager(f).unwrap() {
        if let LogMsg::BlueprintActivationCommand(c) = msg.unwrap() {
            assert!(c.make_active && c.make_default);
            last = Some(c.blueprint_id.application_id().to_string());
        }
    }
    last.expect("no blueprint activated")
}

/// A store of application `app`; `CAMPAIGN_APP` stands for any campaign's own application.
fn of_app(s: &Store, app: &str) -> bool {
    s.app == app || (app == savme::viewer::CAMPAIGN_APP && savme::viewer::is_campaign_app(&s.app))
}

fn recordings<'a>(stores: &'a [Store], app: &str) -> Vec<&'a Store> {
    stores
        .iter()
        .filter(|s| !s.blueprint && of_app(s, app))
        .collect()
}

fn blueprint<'a>(stores: &'a [Store], app: &str) -> &'a Store {
    stores
        .iter()
        .find(|s| s.blueprint && of_app(s, app))
        .unwrap_or_else(|| panic!("no blueprint for {app}"))
}

/// A message of an .rrd file, in file (= stream) order.
#[derive(Debug, PartialEq)]
enum Msg {
    /// A recording's first message (`SetStoreInfo`): a viewer selects it.
    NewRecording(String),
    /// Data of a recording (not a blueprint): its recording id.
    Data(String),
    /// A blueprint activation, by application.
    Activate(String),
}

fn messages(path: &Path) -> Vec<Msg> {
    use rerun::external::re_log_encoding::DecoderApp;
    use rerun::external::re_log_types::LogMsg;
    let f = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut out = Vec::new();
    for msg in DecoderApp::decode_eager(f).unwrap() {
        let msg = msg.unwrap();
        let id = msg.store_id().clone();
        match msg {
            LogMsg::SetStoreInfo(_) if !id.is_blueprint() => {
                out.push(Msg::NewRecording(id.recording_id().to_string()));
            }
            LogMsg::ArrowMsg(..) if !id.is_blueprint() => {
                out.push(Msg::Data(id.recording_id().to_string()));
            }
            LogMsg::BlueprintActivationCommand(c) => {
                out.push(Msg::Activate(c.blueprint_id.application_id().to_string()));
            }
            _ => {}
        }
    }
    out
}

fn assert_views(bp: &Store, views: &[&str]) {
    for v in views {
        assert!(
            bp.names.iter().any(|n| n == v),
            "no view `{v}` in {:?}",
            bp.names
        );
    }
}

const PHI: &str = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";

fn phi() -> savme::kernel::Assignment {
    savme::kernel::Assignment::new()
        .with("ego_speed", 20.0)
        .with("lead_speed", 10.0)
        .with("gap", 8.0)
        .with("lead_decel", 9.0)
        .with("brake_time", 0.5)
}

fn simulate(rrd: &Path, fidelity: &str) -> String {
    let o = Command::new(EXE)
        .args([
            "simulate",
            "--scenario",
            "7",
            "--phi",
            PHI,
            "--fidelity",
            fidelity,
            "--record",
        ])
        .arg(rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

// Long because it checks every part of the trial view against the in-process runs.
#[test]
fn simulate_records_hf_and_lf_side_by_side_with_the_trial_view() {
    let dir = made_dir("simulate");
    let rrd = dir.join("run.rrd");
    let stdout = simulate(&rrd, "simulation_rate_hz=4");
    let stores = load(&rrd);
    let recs = recordings(&stores, savme::viewer::PAIRED_APP);
    assert_eq!(recs.len(), 1, "one recording");
    let r = recs[0];
    assert_views(
        blueprint(&stores, savme::viewer::PAIRED_APP),
        &[
            names::HF_CAMERA,
            names::LF_CAMERA,
            names::HF_3D,
            names::LF_3D,
            names::DISTANCE,
            names::SPEED,
            names::BRAKING,
            names::OUTCOME,
            names::EVENTS,
        ],
    );
    let bp = blueprint(&stores, savme::viewer::PAIRED_APP);
    let eyes = bp
        .rows
        .keys()
        .filter(|e| e.ends_with("/EyeControls3D"))
        .count();
    assert_eq!(
        eyes,
        2,
        "each 3D view has its chase eye: {:?}",
        bp.rows.keys()
    );
    let sim = savme_sim::sim::DrivingSimulator::default();
    let hf_theta = savme_sim::fidelity::theta_hf();
    let mut lf_theta = hf_theta.clone();
    lf_theta.set("simulation_rate_hz", 4.0);
    for (run, theta) in [("hf", &hf_theta), ("lf", &lf_theta)] {
        let expect = sim.run("lead_vehicle_brakes", &phi(), theta, true).unwrap();
        let frames = expect.trajectory.as_ref().unwrap();
        let sensors = expect.sensor_frames.as_ref().unwrap();
        for e in [
            "ego/body",
            "ego/camera",
            "intruder/body",
            "lidar",
            "ego_path",
            "closest_approach",
            "ego/captions/closest_approach",
            "events",
        ] {
            assert!(
                r.has(&format!("/{run}/{e}")),
                "no /{run}/{e} in {:?}",
                r.rows.keys()
            );
        }
        // The ego as a transform per step; JPEG images per sensor frame.
        assert_eq!(r.rows[&format!("/{run}/ego")], frames.len());
        let images = &r.blobs[&format!("/{run}/ego/camera/image")];
        assert_eq!(images.len(), sensors.len());
        assert!(images.iter().all(|b| b.starts_with(&[0xFF, 0xD8])), "JPEG");
        // Time series: the distance between the bodies (the quantity the failure is judged
        // on) at every step and at the closest approach, speed and braking flag of every step.
        let closest = expect
            .closest
            .expect("a recorded run has its closest approach");
        let mut distance: Vec<(f64, f64)> = frames
            .iter()
            .map(|f| (f.time, savme_sim::vehicle::distance(&f.ego, &f.intruder)))
            .collect();
        match distance.iter().position(|(t, _)| *t >= closest.time) {
            Some(k) if distance[k].0 == closest.time => distance[k].1 = closest.distance,
            Some(k) => distance.insert(k, (closest.time, closest.distance)),
            None => distance.push((closest.time, closest.distance)),
        }
        let curve = &r.scalars[&format!("/plots/distance/{run}")];
        assert_eq!(*curve, distance.iter().map(|p| p.1).collect::<Vec<f64>>());
        assert_eq!(curve_min(curve), expect.min_distance, "{run}");
        let braking: Vec<f64> = frames
            .iter()
            .map(|f| f64::from(u8::from(f.braking)))
            .collect();
        assert_eq!(r.scalars[&format!("/plots/braking/{run}")], braking);
        assert!(braking.contains(&1.0), "the ego brakes in this scenario");
        let speed: Vec<f64> = frames.iter().map(|f| f.ego.speed).collect();
        assert_eq!(r.scalars[&format!("/plots/speed/{run}")], speed);
        // The collision, as a warning and a caption.
        let t = expect.collision_time.expect("this φ collides");
        let warning = format!("{}: collision at {t:.2} s", run.to_uppercase());
        assert!(
            r.text(&format!("/{run}/events")).contains(&warning),
            "{:?}",
            r.texts
        );
        assert_eq!(
            r.texts[&format!("/{run}/ego/captions/closest_approach")],
            [format!("collision at {t:.2} s")],
            "one caption"
        );
        // The detector's box carries its class label.
        if sensors.iter().any(|s| s.detection.is_some()) {
            assert!(r
                .text(&format!("/{run}/ego/camera/detection"))
                .contains("vehicle"));
        }
    }
    assert!(r.levels.iter().all(|l| l == "WARN") && r.levels.len() == 2);
    // The failure threshold (a collision: 0 m) over the whole HF run, and no unlabelled bodies
    // stacked with labels.
    let threshold = &r.scalars["/plots/distance/collision"];
    assert!(threshold.len() > 10 && threshold.iter().all(|x| *x == 0.0));
    assert!(!r.texts.contains_key("/hf/ego/body") && !r.texts.contains_key("/hf/intruder/body"));
    // The outcome document: TP (both collide), φ, the setting off θ_HF, the cost ratio.
    let md = r.text("/outcome");
    assert!(md.starts_with("## TP — lead_vehicle_brakes"), "{md}");
    assert!(
        md.contains("simulation_rate_hz=4") && md.contains("gap=8") && md.contains("cost ratio"),
        "{md}"
    );
    assert!(r.names.iter().any(|n| n == "simulate lead_vehicle_brakes"));
    // No stale campaign timeline; one sim_time.
    assert_eq!(
        r.timelines(),
        BTreeSet::from(["sim_time".to_string()]),
        "{:?}",
        r.timelines()
    );
    // The printed result is the LF run's (the fidelity asked for).
    let lf = sim
        .run("lead_vehicle_brakes", &phi(), &lf_theta, false)
        .unwrap();
    assert!(
        stdout.contains(&format!("{} work units", lf.work)),
        "{stdout}"
    );
}

fn curve_min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The number after `key` in `text` (e.g. "closest approach 1.60 m" → 1.60).
fn number_after(text: &str, key: &str) -> f64 {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("no `{key}` in {text}"))
        + key.len()..];
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

// The issue's FP: HF passes, LF (2 Hz) collides; the plotted distance must agree with both.
#[test]
fn the_distance_plot_agrees_with_the_verdict_of_each_run() {
    let dir = made_dir("simulate-fp");
    let rrd = dir.join("fp.rrd");
    let o = Command::new(EXE)
        .args([
            "simulate",
            "--scenario",
            "3",
            "--phi",
            "ego_speed=15,intruder_speed=8,time_offset=0",
            "--fidelity",
            "simulation_rate_hz=2",
            "--record",
        ])
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stores = load(&rrd);
    let r = recordings(&stores, savme::viewer::PAIRED_APP)[0];
    let md = r.text("/outcome");
    assert!(md.starts_with("## FP"), "{md}");
    // HF passes: the curve's minimum is the closest approach the run reports (events,
    // outcome), and above the failure threshold.
    let hf = curve_min(&r.scalars["/plots/distance/hf"]);
    let events = r.text("/hf/events");
    let reported = number_after(&events, "closest approach");
    assert_eq!(format!("{hf:.2}"), format!("{reported:.2}"), "{events}");
    assert_eq!(number_after(&md, "closest approach"), reported, "{md}");
    assert!(hf > 0.0, "HF passes");
    // LF collides: its curve reaches the threshold, 0 m, and not below.
    assert_eq!(curve_min(&r.scalars["/plots/distance/lf"]), 0.0);
    assert!(r.text("/lf/events").contains("LF: collision at"));
    let sim = savme_sim::sim::DrivingSimulator::default();
    let phi = savme::kernel::Assignment::new()
        .with("ego_speed", 15.0)
        .with("intruder_speed", 8.0)
        .with("time_offset", 0.0);
    let run = sim
        .run("3", &phi, &savme_sim::fidelity::theta_hf(), false)
        .unwrap();
    assert!(!run.failure);
    assert_eq!(hf, run.min_distance, "the campaign's own run agrees");
}

#[test]
fn simulate_at_hf_records_the_hf_run_alone() {
    let dir = made_dir("simulate-hf");
    let rrd = dir.join("run.rrd");
    simulate(&rrd, "hf");
    let stores = load(&rrd);
    let recs = recordings(&stores, savme::viewer::HF_APP);
    assert_eq!(recs.len(), 1);
    assert!(recs[0].has("/hf/ego/camera/image"));
    assert!(
        !recs[0].rows.keys().any(|e| e.starts_with("/lf")),
        "no LF run"
    );
    let bp = blueprint(&stores, savme::viewer::HF_APP);
    assert_views(bp, &[names::HF_CAMERA, names::HF_3D, names::OUTCOME]);
    assert!(!bp.names.iter().any(|n| n == names::LF_CAMERA));
    assert!(recs[0].text("/outcome").starts_with("## HF failure"));
}

#[test]
fn simulate_refuses_a_viewer_address_where_none_listens_before_running() {
    // A port nothing listens on: bind one, then free it.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let o = Command::new(EXE)
        .args([
            "simulate",
            "--scenario",
            "7",
            "--phi",
            PHI,
            "--connect",
            &url,
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(err.matches("recording:").count(), 1, "{err}");
    assert!(
        err.contains(&format!("--connect {url}: no rerun viewer is listening")),
        "{err}"
    );
    assert!(
        o.stdout.is_empty(),
        "nothing ran: {}",
        String::from_utf8_lossy(&o.stdout)
    );
}

/// A trial's outcome class for the choice of frames: FN, FP, TP, baseline HF failure.
fn class_of(t: &serde_json::Value) -> Option<usize> {
    match t["outcome"].as_str() {
        Some("FN") => Some(0),
        Some("FP") => Some(1),
        Some("TP") => Some(2),
        None if t["hf"]["failure"] == true => Some(3),
        _ => None,
    }
}

/// The trials that get frames, recomputed from trials.jsonl: every `every`-th, then up to
/// `cap` of the others spread over (stage, class): round r takes the r-th trial of each
/// (stage, class), ordered by the stage's rank among those with that class, then the class.
/// Screening trials count in the told index but get no frames.
fn expected_recorded(trials: &[serde_json::Value], every: usize, cap: usize) -> BTreeSet<usize> {
    let mut buckets: Vec<((String, usize), Vec<usize>)> = Vec::new();
    let mut out = BTreeSet::new();
    for (n, t) in trials.iter().enumerate() {
        if t.get("screen").is_some() {
            continue;
        }
        if n % every == 0 {
            out.insert(n);
            continue;
        }
        let Some(class) = class_of(t) else { continue };
        let key = (t["stage"].as_str().unwrap().to_string(), class);
        match buckets.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) if v.len() < cap => v.push(n),
            Some(_) => {}
            None => buckets.push((key, vec![n])),
        }
    }
    let mut ranked: Vec<((usize, usize), Vec<usize>)> = Vec::new();
    let mut seen = [0usize; 4];
    for ((_, class), v) in buckets {
        ranked.push(((seen[class], class), v));
        seen[class] += 1;
    }
    ranked.sort_by_key(|(k, _)| *k);
    let mut chosen = Vec::new();
    for r in 0..cap {
        for (_, v) in &ranked {
            chosen.extend(v.get(r).copied());
        }
    }
    out.extend(chosen.into_iter().take(cap));
    out
}

fn trial_name(t: &serde_json::Value) -> String {
    let outcome = match t["outcome"].as_str() {
        Some(o) => o.to_string(),
        None if t["hf"]["failure"] == true => "HF failure".into(),
        None => "HF pass".into(),
    };
    // The outcome first: the viewer's Sources panel cuts long names off at the right.
    format!(
        "{outcome} · {} #{} {}",
        t["stage"].as_str().unwrap(),
        t["index"],
        t["scenario"].as_str().unwrap()
    )
}

fn campaign(dir: &Path, every: &str, failures: &str) -> (PathBuf, Vec<serde_json::Value>) {
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
            "--screen-iterations",
            "6",
            "--cost",
            "work",
            "--record-every",
            every,
            "--record-failures",
            failures,
            "--out",
        ])
        .arg(&out)
        .arg("--record")
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let trials = std::fs::read_to_string(out.join("trials.jsonl"))
        .unwrap()
        .lines()
        .map(|x| serde_json::from_str::<serde_json::Value>(x).unwrap())
        .filter(|v| v.get("protocol").is_none()) // the store's first record
        .collect();
    (rrd, trials)
}

// Long because it checks every part of one recorded campaign, which is slow to produce.
/// What a live viewer (rerun 0.36, `--connect`) needs to end on this campaign's view, read
/// from the message order (a file holds the stream as it was sent). It selects each new
/// recording once it has read the batch holding the recording's first message, and an
/// activation switches to its application's earliest recording. So: the campaign has an
/// application of its own; the campaign is activated again after each trial recorded as it
/// was told (every 17th here); and the trials recorded at the end are all opened before any
/// of them gets data, so that their frames lie between the last new recording and the final
/// activation (then they cannot share a batch).
fn opens_on_the_campaign_when_live(rrd: &Path, recorded: &BTreeSet<usize>) {
    let msgs = messages(rrd);
    let campaign = |m: &Msg| matches!(m, Msg::Activate(a) if savme::viewer::is_campaign_app(a));
    let activations = msgs.iter().filter(|m| campaign(m)).count();
    let told = recorded.iter().filter(|n| *n % 17 == 0).count();
    assert!(told >= 1, "a trial recorded as it was told");
    assert_eq!(
        activations,
        1 + told + 1,
        "at the start, after each told trial, at the end"
    );
    let last_new = msgs
        .iter()
        .rposition(|m| matches!(m, Msg::NewRecording(_)))
        .unwrap();
    let last_act = msgs.iter().rposition(campaign).unwrap();
    assert!(last_act > last_new);
    let Some(Msg::NewRecording(campaign_id)) = msgs.first() else {
        panic!("the campaign recording comes first: {:?}", msgs.first());
    };
    let filled: BTreeSet<&str> = msgs[last_new..last_act]
        .iter()
        .filter_map(|m| match m {
            Msg::Data(id) if id != campaign_id => Some(id.as_str()),
            _ => None,
        })
        .collect();
    let at_end = recorded.len() - told;
    assert!(at_end >= 2, "{at_end} trials recorded at the end");
    // Every trial recorded at the end gets its data after the last new recording.
    assert_eq!(filled.len(), at_end, "{filled:?}");
}

#[test]
fn a_campaign_records_its_view_and_the_informative_trials_each_as_a_recording() {
    let dir = made_dir("campaign");
    let (rrd, trials) = campaign(&dir, "17", "4");
    let stores = load(&rrd);
    // Each recorded trial is its own recording, named by stage, trial, scenario and outcome.
    let expected = expected_recorded(&trials, 17, 4);
    let informative = trials
        .iter()
        .filter(|t| matches!(t["outcome"].as_str(), Some("FN" | "FP")))
        .count();
    assert!(
        informative >= 2,
        "the rule is exercised: {informative} FN/FP trials"
    );
    let mut names: Vec<String> = stores
        .iter()
        .filter(|s| !s.blueprint && !savme::viewer::is_campaign_app(&s.app))
        .flat_map(|s| s.names.clone())
        .collect();
    names.sort();
    let mut want: Vec<String> = expected.iter().map(|n| trial_name(&trials[*n])).collect();
    want.sort();
    assert_eq!(names, want);
    // The informative picks are spread: over every outcome class the campaign had (within
    // the cap of 4) and more than one stage.
    let picked: Vec<&serde_json::Value> = expected
        .iter()
        .filter(|n| *n % 17 != 0)
        .map(|n| &trials[*n])
        .collect();
    let had: BTreeSet<usize> = trials
        .iter()
        .enumerate()
        .filter(|(n, t)| n % 17 != 0 && t.get("screen").is_none())
        .filter_map(|(_, t)| class_of(t))
        .collect();
    let classes: BTreeSet<usize> = picked.iter().filter_map(|t| class_of(t)).collect();
    assert_eq!(classes, had.iter().copied().take(4).collect(), "classes");
    let stages: BTreeSet<&str> = picked
        .iter()
        .map(|t| t["stage"].as_str().unwrap())
        .collect();
    assert!(stages.len() >= 2, "one stage only: {stages:?}");
    // The file opens on the campaign view: its blueprint is the last one activated.
    assert!(savme::viewer::is_campaign_app(&last_activated_app(&rrd)));
    opens_on_the_campaign_when_live(&rrd, &expected);
    for s in stores
        .iter()
        .filter(|s| !s.blueprint && s.app == savme::viewer::PAIRED_APP)
    {
        for e in [
            "/hf/ego/camera/image",
            "/lf/ego/camera/image",
            "/lf/lidar",
            "/outcome",
            "/plots/distance/lf",
        ] {
            assert!(s.has(e), "{:?} has no {e}", s.names);
        }
        let md = s.text("/outcome");
        assert!(
            md.contains("ms wall") && md.contains("cost ratio t_LF / t_HF (work units)"),
            "{md}"
        );
        assert_eq!(s.timelines(), BTreeSet::from(["sim_time".to_string()]));
    }
    // The campaign recording: curves per stage on `trial` and `runtime`, no sim_time.
    let c = recordings(&stores, savme::viewer::CAMPAIGN_APP);
    assert_eq!(c.len(), 1);
    let c = c[0];
    assert_eq!(
        c.timelines(),
        BTreeSet::from(["runtime".to_string(), "trial".to_string()])
    );
    let train: Vec<&serde_json::Value> = trials
        .iter()
        .filter(|t| t["stage"] == "train@0.3")
        .collect();
    let curve = &c.scalars["/campaign/found_failures/train_0_3"];
    assert_eq!(curve.len(), train.len());
    let hf_failures = train.iter().filter(|t| t["hf"]["failure"] == true).count();
    assert_eq!(*curve.last().unwrap(), hf_failures as f64);
    let runtime: f64 = train
        .iter()
        .map(|t| {
            t["hf"]["wall_seconds"].as_f64().unwrap() + t["lf"]["wall_seconds"].as_f64().unwrap()
        })
        .sum();
    let logged = c.times["/campaign/found_failures/train_0_3"]["runtime"] as f64 * 1e-9;
    assert!((logged - runtime).abs() < 1e-6, "{logged} vs {runtime}");
    // The screening stage's HF failures (confirmations and audit misses) on the same plot.
    let screen: Vec<&serde_json::Value> = trials
        .iter()
        .filter(|t| t["stage"] == "screen@0.3")
        .collect();
    assert_eq!(screen.len(), 6);
    let found = screen.iter().filter(|t| t["hf"]["failure"] == true).count();
    let curve = &c.scalars["/campaign/found_failures/screen_0_3"];
    assert_eq!((curve.len(), *curve.last().unwrap()), (6, found as f64));
    for stage in [
        "baseline-train",
        "baseline-test",
        "test-learned_0_3",
        "test-uniform_0_3",
    ] {
        assert!(
            c.has(&format!("/campaign/found_failures/{stage}")),
            "{stage}"
        );
    }
    assert_eq!(
        c.scalars["/campaign/cost_ratio/train_0_3"].len(),
        train.len()
    );
    assert_eq!(
        c.scalars["/campaign/fidelity_success/train_0_3"].len(),
        train.len()
    );
    // The posterior grid: arm names and means, θ_HF and the MAP outlined; φ-bins per scenario.
    let cells = &c.texts["/posterior/train_0_3/fidelity/cells/labels"];
    assert!(
        cells.iter().any(|l| l == "high") && cells.iter().any(|l| l == "true"),
        "{cells:?}"
    );
    let means = &c.texts["/posterior/train_0_3/fidelity/cells/means"];
    assert!(
        means.len() >= cells.len()
            && means
                .iter()
                .all(|m| m.parse::<f64>().is_ok_and(|m| (0.0..=1.0).contains(&m))),
        "{means:?}"
    );
    assert!(
        c.texts
            .iter()
            .filter(|(e, _)| e.starts_with("/posterior") || e.starts_with("/campaign/key"))
            .flat_map(|(_, t)| t)
            .all(|t| !t.contains('\n')),
        "the viewer shows a label's first line only"
    );
    assert!(c
        .text("/posterior/train_0_3/fidelity/names")
        .contains("simulation_rate_hz"));
    assert!(
        c.has("/posterior/train_0_3/fidelity/theta_hf")
            && c.has("/posterior/train_0_3/fidelity/map")
    );
    assert!(c
        .rows
        .keys()
        .any(|e| e.starts_with("/posterior/train_0_3/scenarios/") && e.ends_with("/cells")));
    let summary = c.text("/campaign/summary");
    assert!(summary.contains(&format!("**{} trial recordings**", expected.len())));
    // Stages by their readable names, not their entity paths.
    assert!(
        summary.contains("| meta-training, budget 0.3 |") && !summary.contains("train_0_3"),
        "{summary}"
    );
    assert_views(
        blueprint(&stores, savme::viewer::CAMPAIGN_APP),
        &[
            names::KEY,
            names::FAILURES,
            names::SUCCESS,
            names::COST,
            names::CAMPAIGN,
            &names::theta("train@0.3"),
            &names::phi("test-learned@0.3", "on_ramp_merge"),
        ],
    );
    // One colour per stage, the same on every plot and in the key; distinct stages differ.
    let key_names = c.texts["/campaign/key/names"].clone();
    let key_colours = &c.colours["/campaign/key/names"];
    assert_eq!(key_names.len(), key_colours.len());
    let mut seen = BTreeSet::new();
    for (label, colour) in key_names.iter().zip(key_colours) {
        assert!(seen.insert(*colour), "{label} shares its colour");
        let e = savme::viewer::entity_label(label);
        for plot in ["found_failures", "fidelity_success", "cost_ratio"] {
            if let Some(c) = c.colours.get(&format!("/campaign/{plot}/{e}")) {
                assert_eq!(c, &vec![*colour], "{label} on {plot}");
            }
        }
        assert!(
            c.colours
                .contains_key(&format!("/campaign/found_failures/{e}")),
            "{e}"
        );
    }
    assert!(seen.len() >= 6, "{key_names:?}");
    // The cost plot's budget line, at the budget.
    let budget = &c.scalars["/campaign/cost_ratio/budget_0_3"];
    assert!(!budget.is_empty() && budget.iter().all(|b| *b == 0.3));
    // The grids' key: the colour scale and both outlines.
    let key = c.text("/posterior/train_0_3/fidelity/key/labels");
    assert!(
        key.contains("θ_HF") && key.contains("MAP") && key.contains("mean"),
        "{key}"
    );
}

// Idealised perception has no camera: the camera view says so instead of staying black, and
// the trial still has its 3D scene and plots.
#[test]
fn an_ideal_perception_trial_says_it_has_no_camera() {
    let dir = made_dir("ideal");
    let rrd = dir.join("ideal.rrd");
    let o = Command::new(EXE)
        .args([
            "reproduce",
            "--quiet",
            "--perception",
            "ideal",
            "--budgets",
            "0.3",
            "--iterations",
            "3",
            "--eval-iterations",
            "1",
            "--test-iterations",
            "1",
            "--baseline-iterations",
            "1",
            "--baseline-test-iterations",
            "1",
            "--screen-iterations",
            "0",
            "--cost",
            "work",
            "--record-every",
            "2",
            "--record-failures",
            "0",
            "--out",
        ])
        .arg(dir.join("out"))
        .arg("--record")
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stores = load(&rrd);
    let trials: Vec<&Store> = stores
        .iter()
        .filter(|s| !s.blueprint && !savme::viewer::is_campaign_app(&s.app))
        .collect();
    assert!(!trials.is_empty());
    for s in trials {
        let note = s.text("/hf/ego/camera/note");
        assert!(note.contains("no camera in this perception mode"), "{note}");
        assert!(!s.has("/hf/ego/camera/image"), "no camera images");
        assert!(s.has("/hf/ego") && s.has("/plots/distance/hf"));
    }
}

#[test]
fn ctrl_c_still_closes_the_recording() {
    let dir = made_dir("sigint");
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
    let stores = load(&rrd);
    assert!(
        stores
            .iter()
            .any(|s| s.has("/hf/ego/camera/image") && s.names.iter().any(|n| n.contains("#0 "))),
        "trial 0's recording was kept"
    );
}

/// An FMU campaign (the bundled simulator packed by `savme fmu pack`, run in FMU workers) whose
/// file lists outputs under `[fmu] record`.
const FMU_CAMPAIGN: &str = r#"
[fmu]
hf = "FMU"
stop_time = 12.0
step = { rate_of = "simulation_rate_hz" }
cost = "work"
isolate = true
record = ["min_distance", "steps", "collision"]

[failure]
boolean = "collision"

[campaign]
budgets = [0.3]
train_iterations = 8
eval_iterations = 4
test_iterations = 4
baseline_train_iterations = 6
baseline_test_iterations = 4
cost = "work"

[fidelity]
paper = true

[[scenario]]
name = "lead_vehicle_brakes"
role = "train"
fixed = { scenario = 7 }
[[scenario.phi]]
name = "ego_speed"
range = [10.0, 25.0]
[[scenario.phi]]
name = "lead_speed"
range = [5.0, 20.0]
[[scenario.phi]]
name = "gap"
range = [8.0, 28.0]
[[scenario.phi]]
name = "lead_decel"
range = [4.0, 9.0]
[[scenario.phi]]
name = "brake_time"
range = [0.5, 4.0]

[[scenario]]
name = "on_ramp_merge"
role = "test"
fixed = { scenario = 10 }
[[scenario.phi]]
name = "ego_speed"
range = [12.0, 22.0]
[[scenario.phi]]
name = "intruder_speed"
range = [12.0, 26.0]
[[scenario.phi]]
name = "time_offset"
range = [-3.0, 3.0]
"#;

/// The points of one run's recorded output: its series, and its last `sim_time` in seconds.
fn run_series<'a>(s: &'a Store, output: &str, run: &str) -> (&'a [f64], f64) {
    let e = format!("/plots/{output}/{run}");
    let v = s
        .scalars
        .get(&e)
        .unwrap_or_else(|| panic!("{:?} has no {e}", s.names));
    (v, s.times[&e]["sim_time"] as f64 * 1e-9)
}

// Long because it checks each recorded run's series against the trial that the campaign ran.
#[test]
fn an_fmu_campaign_records_the_listed_outputs_of_hf_and_lf_per_trial() {
    let dir = made_dir("fmu");
    let fmu = dir.join("savme-sim.fmu");
    let o = Command::new(EXE)
        .args(["fmu", "pack", "--out"])
        .arg(&fmu)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let config = dir.join("campaign.toml");
    std::fs::write(
        &config,
        FMU_CAMPAIGN.replace("FMU", &fmu.display().to_string()),
    )
    .unwrap();
    let (rrd, out) = (dir.join("fmu.rrd"), dir.join("out"));
    let o = Command::new(EXE)
        .args([
            "run",
            "--quiet",
            "--record-every",
            "7",
            "--record-failures",
            "3",
        ])
        .arg("--config")
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .arg("--record")
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let trials: Vec<serde_json::Value> = std::fs::read_to_string(out.join("trials.jsonl"))
        .unwrap()
        .lines()
        .map(|x| serde_json::from_str::<serde_json::Value>(x).unwrap())
        .filter(|v| v.get("protocol").is_none()) // the store's first record
        .collect();
    let stores = load(&rrd);
    // The trials chosen by the usual rule, each its own recording with the FMU trial view.
    let expected = expected_recorded(&trials, 7, 3);
    // Paired trials under one application, HF-only ones under another: each layout's plot
    // titles name only the runs its trials have.
    let (paired_app, hf_app) = (savme::viewer::FMU_APP, savme::viewer::FMU_HF_APP);
    let mut recs = recordings(&stores, paired_app);
    let hf_recs = recordings(&stores, hf_app);
    for s in &hf_recs {
        assert!(
            !s.has("/plots/steps/lf"),
            "an HF-only recording has an LF run"
        );
    }
    let hf_only = expected
        .iter()
        .filter(|n| trials[**n]["theta_lf"].is_null())
        .count();
    assert_eq!(
        hf_recs.len(),
        hf_only,
        "one {hf_app} recording per HF-only trial"
    );
    recs.extend(hf_recs.iter().copied());
    let mut names: Vec<String> = recs.iter().flat_map(|s| s.names.clone()).collect();
    names.sort();
    let mut want: Vec<String> = expected.iter().map(|n| trial_name(&trials[*n])).collect();
    want.sort();
    assert_eq!(names, want);
    let outputs = ["min_distance", "steps", "collision"];
    for (app, paired) in [(paired_app, true), (hf_app, false)] {
        if app == hf_app && hf_recs.is_empty() {
            continue;
        }
        let mut views: Vec<String> = outputs
            .iter()
            .map(|o| savme::viewer::layout::output_view_name(o, paired))
            .collect();
        views.extend([names::OUTCOME.to_string(), names::EVENTS.to_string()]);
        let views: Vec<&str> = views.iter().map(String::as_str).collect();
        assert_views(blueprint(&stores, app), &views);
    }
    let theta_hf = savme_sim::fidelity::theta_hf();
    let rate_hf = theta_hf.get_f64("simulation_rate_hz").unwrap();
    let (mut paired, mut failing) = (0, 0);
    for n in &expected {
        let t = &trials[*n];
        let s = *recs
            .iter()
            .find(|s| s.names == [trial_name(t)])
            .unwrap_or_else(|| panic!("no recording of trial {n}"));
        assert_eq!(s.timelines(), BTreeSet::from(["sim_time".to_string()]));
        let mut runs = vec![("hf", rate_hf)];
        if let Some(lf) = t["theta_lf"].as_object() {
            paired += 1;
            runs.push(("lf", lf["simulation_rate_hz"].as_f64().unwrap()));
        } else {
            assert!(!s.has("/plots/steps/lf"), "an HF-only trial has no LF run");
        }
        for (run, rate) in runs {
            let failed = t[run]["failure"] == true;
            failing += usize::from(failed);
            let (collision, end) = run_series(s, "collision", run);
            // One point per communication point, 0 to the end of the run (12 s, or the
            // first failure: the runs stop on failure).
            let points = (end * rate).round() as usize + 1;
            for o in outputs {
                let v = run_series(s, o, run).0;
                // min_distance starts at its placeholder 1e6: left out of the plot (and said).
                let skip = usize::from(o == "min_distance");
                assert_eq!(v.len(), points - skip, "{run} {o} of trial {n}");
                assert!(
                    v.iter().all(|x| x.abs() < savme::viewer::SENTINEL),
                    "{o}: {v:?}"
                );
            }
            assert!(
                s.text(&format!("/{run}/events"))
                    .contains("`min_distance` starts at placeholder 1e6: plotted from"),
                "{}",
                s.text(&format!("/{run}/events"))
            );
            if failed {
                assert!(end < 12.0, "{run} of trial {n} stops at its failure");
            } else {
                assert!((end - 12.0).abs() < 1e-6, "{run} of trial {n} runs to 12 s");
            }
            // The failure signal as recorded agrees with the campaign's outcome.
            assert_eq!(
                *collision.last().unwrap(),
                f64::from(u8::from(failed)),
                "{n}"
            );
            assert!(collision[..points - 1].iter().all(|c| *c == 0.0));
            // The simulator's own step count: 0 after initialisation, then counting (up to
            // the scenario's own end, which may come before the stop time).
            let steps = run_series(s, "steps", run).0;
            assert_eq!(steps[0], 0.0);
            assert!(steps[1] >= 1.0, "{steps:?}");
            assert!(steps.windows(2).all(|w| w[1] >= w[0]), "steps: {steps:?}");
        }
        let events = s.text("/hf/events");
        assert!(events.contains("HF: "), "{events}");
        assert!(s
            .text("/outcome")
            .contains(&format!("trial #{}", t["index"])));
    }
    assert!(
        paired >= 2 && failing >= 1,
        "{paired} paired, {failing} failing runs"
    );
}

/// A simulator's frames from outside the viewer crate (issue 24's open seam): the toy
/// simulator re-run as the campaign ran it, its work per run as a plot in its own layout.
struct ToyFrames;

impl savme::viewer::TrialFrames for ToyFrames {
    fn layout(&self, _paired: bool) -> (&'static str, savme::viewer::layout::Layout) {
        let plot =
            rerun::blueprint::TimeSeriesView::new("Toy work units: HF and LF").with_origin("/work");
        (
            "toy-trial",
            savme::viewer::layout::Layout::new(rerun::blueprint::Blueprint::new(plot)),
        )
    }

    fn record_scene(
        &mut self,
        _: &rerun::RecordingStream,
        scenario: &str,
    ) -> Result<bool, savme::viewer::RecordError> {
        Ok(savme::toy::SCENARIOS.contains(&scenario))
    }

    fn record_run(
        &mut self,
        rec: &rerun::RecordingStream,
        run: savme::viewer::RunSide,
        scenario: &str,
        phi: &savme::kernel::Assignment,
        theta: &savme::kernel::Assignment,
    ) -> Result<Option<savme::viewer::RunSummary>, savme::viewer::RecordError> {
        use savme::kernel::{Role, Simulator};
        let role = match run {
            savme::viewer::RunSide::Hf => Role::High,
            savme::viewer::RunSide::Lf => Role::Learned,
        };
        let bad = |e: &dyn std::fmt::Display| savme::viewer::RecordError::new(e.to_string());
        let r = savme::toy::ToySimulator
            .simulate_as(role, scenario, phi, theta)
            .map_err(|e| bad(&e))?;
        let work = r.work.unwrap_or(0);
        rec.set_duration_secs("sim_time", 0.0);
        rec.log(
            format!("work/{}", run.path()),
            &rerun::Scalars::single(work as f64),
        )
        .map_err(|e| bad(&e))?;
        Ok(Some(savme::viewer::RunSummary {
            failure: r.failure,
            collision_time: None,
            min_distance: f64::NAN,
            steps: 1,
            wall_seconds: r.wall_seconds,
            work: r.work,
        }))
    }
}

#[test]
fn a_simulator_outside_the_viewer_crate_offers_its_own_frames() {
    use savme::campaign::config::{toy, Overrides, TOY};
    let dir = made_dir("record-seam");
    let rrd = dir.join("toy.rrd");
    let (protocol, problem) = toy(TOY, &Overrides::default()).expect("the toy protocol");
    let req = savme::viewer::RecordRequest {
        file: Some(rrd.clone()),
        every: 0,
        failures: 3,
        ..Default::default()
    };
    let frames = savme::viewer::Frames::new(ToyFrames);
    let observer = savme::viewer::start(&req, frames, &protocol, &problem)
        .expect("recording starts")
        .expect("a recording was asked for");
    savme::campaign::Campaign::new(protocol, problem)
        .out(dir.join("out"))
        .jobs(2)
        .boxed_observer(observer)
        .run(&savme::toy::ToySimulator)
        .expect("the toy campaign runs");
    let stores = load(&rrd);
    let trials = recordings(&stores, "toy-trial");
    assert_eq!(trials.len(), 3, "3 informative trials get frames");
    let mut paired = 0;
    for t in &trials {
        // Each run re-run and logged by the toy's frames, beside the recorder's outcome.
        let outcome = t.text("/outcome");
        let has_lf = outcome.contains("**LF**");
        paired += usize::from(has_lf);
        assert!(t.has("/work/hf"), "{:?}", t.rows);
        assert_eq!(t.has("/work/lf"), has_lf, "{outcome}\n{:?}", t.rows);
        let work = t.scalars["/work/hf"][0];
        assert!(work > 0.0, "HF work {work}");
    }
    assert!(paired > 0, "no paired trial among the recorded ones");
    assert_views(
        blueprint(&stores, "toy-trial"),
        &["Toy work units: HF and LF"],
    );
    assert!(savme::viewer::is_campaign_app(&last_activated_app(&rrd)));
    std::fs::remove_dir_all(&dir).ok();
}

/// The README's key to the stage colours names each stage kind's colour as the viewer draws it
/// (issue 40 item 15: it said "baseline white" while meta-training's baseline is pink).
#[test]
fn the_readme_names_every_stage_colour_as_drawn() {
    use savme::campaign::StageKind;
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .unwrap()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    // Reference colours of the names the README uses; the palette's colour must be nearest
    // to the name the README gives it.
    let names: [(&str, [f64; 3]); 7] = [
        ("orange", [255.0, 140.0, 0.0]),
        ("blue", [40.0, 120.0, 255.0]),
        ("white", [240.0, 240.0, 240.0]),
        ("green", [30.0, 200.0, 80.0]),
        ("pink", [240.0, 110.0, 180.0]),
        ("purple", [170.0, 90.0, 240.0]),
        ("yellow", [240.0, 220.0, 30.0]),
    ];
    let said = [
        ("learned prior orange", StageKind::TestLearned),
        ("uniform prior blue", StageKind::TestUniform),
        ("its baseline white", StageKind::BaselineTest),
        ("meta-training green", StageKind::Train),
        ("its baseline pink", StageKind::BaselineTrain),
        ("evaluation purple", StageKind::Evaluate),
        ("LF screening yellow", StageKind::Screen),
    ];
    for (phrase, kind) in said {
        assert!(readme.contains(phrase), "README.md does not say {phrase:?}");
        let colour = savme::viewer::kind_colour(kind).map(f64::from);
        let distance = |c: &[f64; 3]| (0..3).map(|i| (c[i] - colour[i]).powi(2)).sum::<f64>();
        let nearest = names
            .iter()
            .min_by(|a, b| distance(&a.1).total_cmp(&distance(&b.1)))
            .unwrap()
            .0;
        assert!(
            phrase.ends_with(nearest),
            "{kind:?} is drawn {colour:?}, nearest to {nearest}, but README.md says {phrase:?}"
        );
    }
}
