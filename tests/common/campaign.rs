//! Campaign helpers of the PostgreSQL tests (`tests/postgres.rs`, `tests/distributed.rs`):
//! process output, trial lines from a directory or the database
//! (without the measured wall-clock seconds, which differ run to run), `savme worker`
//! processes.
#![allow(dead_code)]

use serde_json::Value;
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use super::{trial_lines, without_wall, EXE};

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
