//! Campaign helpers of the PostgreSQL tests (`tests/it/postgres.rs`, `tests/it/distributed.rs`):
//! process output, trial lines from a directory or the database
//! (without the measured wall-clock seconds, which differ run to run), `savme worker`
//! processes, and the set-up of a distributed toy campaign ([`Distributed`]).
#![allow(dead_code)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use super::postgres::Server;
use super::{temp_dir, trial_lines, without_wall, EXE};

/// stdout then stderr.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The lines of `dir/trials.jsonl` without their store version and wall-clock seconds.
pub fn file_trials(dir: &Path) -> Vec<Value> {
    without_wall(trial_lines(dir))
}

/// The trial lines of campaign `name`, in order.
pub fn db_trials(client: &mut postgres::Client, name: &str) -> Vec<Value> {
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

/// A `savme worker` process on campaign `name` (stderr kept for [`finish`]).
pub fn worker(url: &str, name: &str, extra: &[&str]) -> Child {
    Command::new(EXE)
        .args(["worker", "--storage", url, "--campaign", name])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits (up to 180 s) for `child` to exit successfully; its output.
pub fn finish(mut child: Child, what: &str) -> String {
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

/// A count (0 while the coordinator has not created the schema yet).
pub fn query_i64(client: &mut postgres::Client, sql: &str) -> i64 {
    client.query_one(sql, &[]).map_or(0, |r| r.get(0))
}

/// Polls `ok` every 20 ms; fails the test after `limit`.
pub fn wait_until(what: &str, limit: Duration, mut ok: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ok() {
        assert!(start.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A small toy protocol, work-unit cost (`tests/it/distributed.rs`).
pub const TOY: &[&str] = &[
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

/// `savme <args> --out <out>` run locally (a reference run): its trial lines.
pub fn local_trials(out: &Path, args: &[&str]) -> Vec<Value> {
    let o = Command::new(EXE)
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    file_trials(out)
}

/// `savme toy` locally into `out` (the reference), with `extra` flags.
pub fn toy_local(out: &Path, extra: &[&str]) -> Vec<Value> {
    local_trials(out, &[&["toy"], TOY, extra].concat())
}

/// The coordinator of a toy campaign in the database, its runs done by workers.
pub fn toy_coordinator(url: &str, name: &str, out: &Path, extra: &[&str]) -> Command {
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

/// A toy campaign to distribute, each run sleeping `sleep_ms`: a database on a PostgreSQL
/// server of its own, the reference run of the same protocol made locally (`expected`, its
/// trial lines, in `local`) and the coordinator's output directory.
pub struct Distributed {
    /// The server (dropped: stopped).
    pub server: Server,
    /// The database's URL.
    pub url: String,
    /// The local run's directory.
    pub local: PathBuf,
    /// Its trial lines, without the wall-clock seconds.
    pub expected: Vec<Value>,
    /// The coordinator's output directory.
    pub out: PathBuf,
    sleep: String,
}

impl Distributed {
    /// Starts the server (None where PostgreSQL cannot run: `Server::start` says so loudly)
    /// and runs the reference campaign; `name` names the server, database and directories.
    /// Its directories are the calling test file's ([`temp_dir`]).
    #[track_caller]
    pub fn set_up(name: &str, sleep_ms: u32) -> Option<Distributed> {
        let server = Server::start(name)?;
        let url = server.create_db(name);
        let local = temp_dir(&format!("{name}-local"));
        let sleep = sleep_ms.to_string();
        let expected = toy_local(&local, &["--sleep-ms", &sleep]);
        let out = temp_dir(&format!("{name}-out"));
        Some(Distributed {
            server,
            url,
            local,
            expected,
            out,
            sleep,
        })
    }

    /// The coordinator of campaign `campaign` (the same protocol, runs left to workers),
    /// started with its standard output discarded and standard error to `stderr`.
    pub fn coordinator(&self, campaign: &str, stderr: Stdio) -> Child {
        toy_coordinator(&self.url, campaign, &self.out, &["--sleep-ms", &self.sleep])
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .unwrap()
    }

    /// A client of the database.
    pub fn client(&self) -> postgres::Client {
        postgres::Client::connect(&self.url, postgres::NoTls).unwrap()
    }

    /// Removes both directories.
    pub fn clean(&self) {
        for d in [&self.local, &self.out] {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}
