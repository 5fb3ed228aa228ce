//! Campaigns whose runs are done by `savme worker` processes through a real PostgreSQL server
//! the test starts itself (`common/postgres.rs`): the same trials as a local run for any number
//! of workers, and each fault with real processes — a worker killed with `kill -9` mid-run, the
//! coordinator killed and resumed, the database restarted mid-campaign, workers that never
//! come.
mod common;

use common::postgres::Server;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_savme");

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("savme-dist-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A small toy protocol, work-unit cost.
const TOY: &[&str] = &[
    "--iterations",
    "6",
    "--eval-iterations",
    "2",
    "--test-iterations",
    "3",
    "--baseline-iterations",
    "4",
    "--baseline-test-iterations",
    "2",
    "--cost",
    "work",
    "--seed",
    "5",
    "--quiet",
];

/// `savme toy` locally into `out` (the reference), with `extra` flags.
fn toy_local(out: &Path, extra: &[&str]) -> Vec<Value> {
    let o = Command::new(EXE)
        .args(["toy", "--out"])
        .arg(out)
        .args(TOY)
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    file_trials(out)
}

/// The coordinator of a toy campaign in the database, its runs done by workers.
fn toy_coordinator(url: &str, name: &str, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(EXE);
    c.args([
        "toy",
        "--storage",
        url,
        "--campaign",
        name,
        "--remote",
        "--out",
    ])
    .arg(out)
    .args(TOY)
    .args(extra);
    c
}

fn worker(url: &str, name: &str, extra: &[&str]) -> Child {
    Command::new(EXE)
        .args(["worker", "--storage", url, "--campaign", name])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn file_trials(dir: &Path) -> Vec<Value> {
    without_wall(
        std::fs::read_to_string(dir.join("trials.jsonl"))
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect(),
    )
}

fn db_trials(client: &mut postgres::Client, name: &str) -> Vec<Value> {
    let rows = client
        .query(
            "SELECT t.body::text FROM savme.trials t JOIN savme.campaigns c ON c.id = t.campaign_id
              WHERE c.name = $1 ORDER BY t.line",
            &[&name],
        )
        .unwrap();
    without_wall(
        rows.iter()
            .map(|r| serde_json::from_str(r.get::<_, &str>(0)).unwrap())
            .collect(),
    )
}

fn without_wall(mut t: Vec<Value>) -> Vec<Value> {
    for v in &mut t {
        if let Some(o) = v.as_object_mut() {
            o.remove("v");
        }
        for run in ["hf", "lf"] {
            if let Some(r) = v[run].as_object_mut() {
                r.remove("wall_seconds");
            }
        }
    }
    t
}

/// A count (0 while the coordinator has not created the schema yet).
fn query_i64(client: &mut postgres::Client, sql: &str) -> i64 {
    client.query_one(sql, &[]).map_or(0, |r| r.get(0))
}

fn wait_until(what: &str, limit: Duration, mut ok: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ok() {
        assert!(start.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn finish(mut child: Child, what: &str) -> String {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let o = child.wait_with_output().unwrap();
            let t = text(&o);
            assert!(status.success(), "{what}: {t}");
            return t;
        }
        if start.elapsed() > Duration::from_secs(180) {
            let _ = child.kill();
            panic!("{what} did not finish");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn one_or_three_workers_give_the_trials_of_the_local_run() {
    let Some(server) = Server::start("workers") else {
        return;
    };
    let url = server.create_db("workers");
    // The bundled driving simulator (idealised perception), named by the campaign.
    let tiny = [
        "--budgets",
        "0.3",
        "--iterations",
        "10",
        "--eval-iterations",
        "4",
        "--test-iterations",
        "5",
        "--baseline-iterations",
        "8",
        "--baseline-test-iterations",
        "4",
        "--cost",
        "work",
        "--seed",
        "11",
        "--perception",
        "ideal",
        "--quiet",
    ];
    let local = temp_dir("workers-local");
    let o = Command::new(EXE)
        .args(["reproduce", "--out"])
        .arg(&local)
        .args(tiny)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let expected = file_trials(&local);
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    // The single worker runs under the least-privilege role of docs/DISTRIBUTED.md (the
    // schema must exist for the grants: the coordinator of a first campaign creates it).
    let role_sql = common::doc_sql("worker-role")
        .replace("change-me", "worker-pw")
        .replace("DATABASE safety", "DATABASE workers");
    for workers in [1, 3] {
        let name = format!("w{workers}");
        let out = temp_dir(&name);
        let worker_url = if workers == 1 {
            // savme creates its schema when a store is first opened.
            let db = savme::campaign::store::postgres::Database::parse(&url).unwrap();
            drop(savme::campaign::store::postgres::PostgresStore::open(&db, "setup").unwrap());
            let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
            c.batch_execute(&role_sql).unwrap();
            server.url_for("savme_worker", "worker-pw", "workers")
        } else {
            url.clone()
        };
        let children: Vec<Child> = (0..workers)
            .map(|_| worker(&worker_url, &name, &[]))
            .collect();
        let o = Command::new(EXE)
            .args([
                "reproduce",
                "--storage",
                &url,
                "--campaign",
                &name,
                "--remote",
                "--out",
            ])
            .arg(&out)
            .args(tiny)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
        for (k, c) in children.into_iter().enumerate() {
            let t = finish(c, &format!("worker {k}"));
            assert!(t.contains(&format!("campaign \"{name}\" finished")), "{t}");
        }
        assert_eq!(db_trials(&mut client, &name), expected, "{workers} workers");
        assert_eq!(
            std::fs::read_to_string(out.join("table.md")).unwrap(),
            std::fs::read_to_string(local.join("table.md")).unwrap()
        );
        // Every run ran once, and with three workers, more than one worker ran some.
        let id: i32 = client
            .query_one("SELECT id FROM savme.campaigns WHERE name = $1", &[&name])
            .unwrap()
            .get(0);
        let row = client
            .query_one(
                "SELECT count(*), max(attempts), count(DISTINCT worker), bool_and(state = 'done')
                   FROM savme.runs WHERE campaign_id = $1",
                &[&id],
            )
            .unwrap();
        let runs =
            expected.len() as i64 + expected.iter().filter(|t| !t["lf"].is_null()).count() as i64;
        assert_eq!(row.get::<_, i64>(0), runs);
        assert_eq!(row.get::<_, i32>(1), 1);
        assert!(row.get::<_, bool>(3));
        if workers == 3 {
            assert!(row.get::<_, i64>(2) > 1, "one worker did everything");
        }
        let _ = std::fs::remove_dir_all(out);
    }
    let _ = std::fs::remove_dir_all(local);
}

#[test]
fn a_worker_killed_mid_run_loses_its_lease_and_another_reruns_the_run_once() {
    let Some(server) = Server::start("killworker") else {
        return;
    };
    let url = server.create_db("killworker");
    let local = temp_dir("killworker-local");
    let expected = toy_local(&local, &["--sleep-ms", "150"]);
    let out = temp_dir("killworker-out");
    let coordinator = toy_coordinator(&url, "k", &out, &["--sleep-ms", "150"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut doomed = worker(&url, "k", &["--lease", "1"]);
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let held_by = format!(
        "SELECT count(*) FROM savme.runs WHERE state = 'running' AND worker LIKE 'savme worker pid {} %'",
        doomed.id()
    );
    // Let it finish a few runs, then kill it while it holds one.
    wait_until(
        "the first worker to finish runs",
        Duration::from_secs(60),
        || {
            query_i64(
                &mut client,
                "SELECT count(*) FROM savme.runs WHERE state = 'done'",
            ) >= 3
        },
    );
    wait_until(
        "the first worker to hold a run",
        Duration::from_secs(60),
        || query_i64(&mut client, &held_by) > 0,
    );
    doomed.kill().unwrap(); // SIGKILL
    doomed.wait().unwrap();
    let orphaned = query_i64(&mut client, &held_by);
    let rescuer = worker(&url, "k", &["--lease", "1"]);
    finish(coordinator, "the coordinator");
    finish(rescuer, "the second worker");
    assert_eq!(db_trials(&mut client, "k"), expected);
    // The killed worker's run was taken over after its lease expired: claimed twice, done
    // once (the trial was told once: the trials equal the local run's).
    if orphaned > 0 {
        let retried = query_i64(
            &mut client,
            "SELECT count(*) FROM savme.runs WHERE attempts = 2 AND state = 'done'",
        );
        assert_eq!(retried, orphaned);
    }
    assert!(
        orphaned > 0,
        "the worker was killed between runs (timing); rerun"
    );
    for d in [local, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_killed_coordinator_resumes_using_the_runs_workers_finished_meanwhile() {
    let Some(server) = Server::start("killcoord") else {
        return;
    };
    let url = server.create_db("killcoord");
    let local = temp_dir("killcoord-local");
    let expected = toy_local(&local, &["--sleep-ms", "60"]);
    let out = temp_dir("killcoord-out");
    let w = worker(&url, "c", &["--jobs", "2"]);
    let mut coordinator = toy_coordinator(&url, "c", &out, &["--sleep-ms", "60"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    wait_until("trials to be stored", Duration::from_secs(60), || {
        query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 6
    });
    coordinator.kill().unwrap(); // SIGKILL
    coordinator.wait().unwrap();
    // The workers finish what was queued; those results must be used, not run again.
    std::thread::sleep(Duration::from_millis(500));
    let done_before = query_i64(
        &mut client,
        "SELECT count(*) FROM savme.runs WHERE state = 'done'",
    );
    let stored = query_i64(&mut client, "SELECT count(*) FROM savme.trials");
    assert!(
        (stored as usize) < expected.len(),
        "finished before the kill"
    );
    let resumed = Command::new(EXE)
        .args([
            "toy",
            "--storage",
            &url,
            "--campaign",
            "c",
            "--remote",
            "--resume",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed));
    finish(w, "the worker");
    assert_eq!(db_trials(&mut client, "c"), expected);
    // No run was claimed twice (none repeated), and the runs done before the resume are in.
    assert_eq!(
        query_i64(&mut client, "SELECT max(attempts)::bigint FROM savme.runs"),
        1
    );
    assert!(
        query_i64(
            &mut client,
            "SELECT count(*) FROM savme.runs WHERE state = 'done'"
        ) > done_before
    );
    for d in [local, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_database_restart_mid_campaign_loses_nothing() {
    let Some(mut server) = Server::start("restart") else {
        return;
    };
    let url = server.create_db("restart");
    let local = temp_dir("restart-local");
    let expected = toy_local(&local, &["--sleep-ms", "40"]);
    let out = temp_dir("restart-out");
    let w = worker(&url, "r", &["--jobs", "2", "--lease", "2"]);
    let coordinator = toy_coordinator(&url, "r", &out, &["--sleep-ms", "40"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
        wait_until("trials to be stored", Duration::from_secs(60), || {
            query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 5
        });
    }
    server.stop();
    std::thread::sleep(Duration::from_millis(1500));
    server.restart();
    let said = finish(coordinator, "the coordinator");
    assert!(said.contains("connection lost"), "{said}");
    assert!(!said.contains(common::postgres::PASSWORD), "{said}");
    finish(w, "the worker");
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    assert_eq!(db_trials(&mut client, "r"), expected);
    for d in [local, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_coordinator_without_workers_says_so() {
    let Some(server) = Server::start("noworkers") else {
        return;
    };
    let url = server.create_db("noworkers");
    let out = temp_dir("noworkers");
    let mut coordinator = toy_coordinator(&url, "lonely", &out, &["--worker-wait", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(4));
    coordinator.kill().unwrap();
    let o = coordinator.wait_with_output().unwrap();
    let t = text(&o);
    assert!(
        t.contains("no worker has taken a run of campaign \"lonely\" in 1 s")
            && t.contains("savme worker --storage postgresql://savme@127.0.0.1:")
            && t.contains("--campaign \"lonely\""),
        "{t}"
    );
    assert!(!t.contains(common::postgres::PASSWORD), "{t}");
    let _ = std::fs::remove_dir_all(out);
}
