//! Campaigns on `savme worker` processes through PostgreSQL, against the local thread pool.
//!
//! `cargo bench --bench distributed -- [repetitions]`
//!
//! Starts a throwaway PostgreSQL (as the tests do: `tests/common/postgres.rs`), then:
//! 1. **Throughput**: `savme toy --sleep-ms 20` (every run sleeps 20 ms: a slow simulator that
//!    uses no CPU), 200 trials (350 runs), window 16, work-unit cost — run by N = 1, 2, 4, 8
//!    worker processes (`savme worker --jobs 1` each, coordinator with `--remote`), and by the
//!    local pool with `--jobs N`. Wall time of the coordinator process, median of the
//!    repetitions.
//! 2. **Coordinator cost per trial**: `savme toy --null` (runs cost nothing), 1,000 trials,
//!    window 16, 2 workers: the coordinator process's CPU time (user + system, from
//!    `/proc/PID/stat`) per trial — ask + task insert + result read + tell + store — and the
//!    same for the local pool (kernel + JSON-lines store) for comparison.
#[path = "../tests/common/postgres.rs"]
mod pg;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_savme");

const SLEEPING: &[&str] = &[
    "--sleep-ms",
    "20",
    "--cost",
    "work",
    "--seed",
    "1",
    "--window",
    "16",
    "--iterations",
    "80",
    "--eval-iterations",
    "20",
    "--test-iterations",
    "20",
    "--baseline-iterations",
    "40",
    "--baseline-test-iterations",
    "20",
    "--quiet",
];
const SLEEPING_TRIALS: f64 = 200.0;

const NULL: &[&str] = &[
    "--null",
    "--cost",
    "work",
    "--seed",
    "1",
    "--window",
    "16",
    "--iterations",
    "400",
    "--eval-iterations",
    "100",
    "--test-iterations",
    "100",
    "--baseline-iterations",
    "200",
    "--baseline-test-iterations",
    "100",
    "--quiet",
];
const NULL_TRIALS: f64 = 1000.0;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn clock_ticks() -> f64 {
    Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8_lossy(&o.stdout).trim().parse().ok())
        .unwrap_or(100.0)
}

/// utime + stime of a running process, in clock ticks.
fn cpu_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = after.split(' ').collect();
    // Fields 14 and 15 of stat; `after` starts at field 3.
    Some(fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?)
}

/// Runs `cmd` to the end: (wall seconds, CPU seconds of the process as last sampled).
fn measure(mut cmd: Command) -> (f64, f64) {
    let start = Instant::now();
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("savme starts");
    let mut ticks = 0;
    loop {
        if let Some(t) = cpu_ticks(child.id()) {
            ticks = ticks.max(t);
        }
        if let Some(status) = child.try_wait().expect("wait") {
            let wall = start.elapsed().as_secs_f64();
            let err = child
                .wait_with_output()
                .map(|o| o.stderr)
                .unwrap_or_default();
            assert!(status.success(), "{}", String::from_utf8_lossy(&err));
            return (wall, ticks as f64 / clock_ticks());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn local(out: &Path, flags: &[&str], jobs: usize) -> Command {
    let _ = std::fs::remove_dir_all(out);
    let mut c = Command::new(EXE);
    c.args(["toy", "--out"])
        .arg(out)
        .args(flags)
        .args(["--jobs", &jobs.to_string()]);
    c
}

/// A remote campaign `name` with `workers` worker processes started first; returns the
/// coordinator's (wall, CPU) seconds.
fn remote(url: &str, name: &str, out: &Path, flags: &[&str], workers: usize) -> (f64, f64) {
    let _ = std::fs::remove_dir_all(out);
    let children: Vec<Child> = (0..workers)
        .map(|_| {
            Command::new(EXE)
                .args([
                    "worker",
                    "--storage",
                    url,
                    "--campaign",
                    name,
                    "--jobs",
                    "1",
                ])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("worker starts")
        })
        .collect();
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
    .args(flags);
    let r = measure(c);
    for mut w in children {
        let _ = w.wait();
    }
    r
}

fn main() {
    let reps: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(3);
    let Some(server) = pg::Server::start("bench") else {
        return;
    };
    let url = server.create_db("bench");
    let out: PathBuf =
        std::env::temp_dir().join(format!("savme-bench-dist-{}", std::process::id()));
    let counts = [1usize, 2, 4, 8];
    let mut local_s = vec![Vec::new(); counts.len()];
    let mut remote_s = vec![Vec::new(); counts.len()];
    for rep in 0..reps {
        for (k, &n) in counts.iter().enumerate() {
            local_s[k].push(measure(local(&out, SLEEPING, n)).0);
            let name = format!("sleep-{n}-{rep}");
            remote_s[k].push(remote(&url, &name, &out, SLEEPING, n).0);
        }
    }
    println!("sleeping 20 ms runs, {SLEEPING_TRIALS} trials, window 16, median of {reps}:");
    println!("| N | local pool --jobs N: s | trials/s | N worker processes: s | trials/s | vs 1 worker |");
    println!("|---|---|---|---|---|---|");
    let one = median(remote_s[0].clone());
    for (k, &n) in counts.iter().enumerate() {
        let (l, r) = (median(local_s[k].clone()), median(remote_s[k].clone()));
        println!(
            "| {n} | {l:.2} | {:.1} | {r:.2} | {:.1} | {:.2}× |",
            SLEEPING_TRIALS / l,
            SLEEPING_TRIALS / r,
            one / r
        );
    }

    let mut null_local = Vec::new();
    let mut null_remote = Vec::new();
    for rep in 0..reps {
        null_local.push(measure(local(&out, NULL, 1)));
        null_remote.push(remote(&url, &format!("null-{rep}"), &out, NULL, 2));
    }
    let per = |v: &[(f64, f64)], f: fn(&(f64, f64)) -> f64| {
        median(v.iter().map(f).collect()) / NULL_TRIALS * 1e3
    };
    println!("\nnull simulator, {NULL_TRIALS} trials, window 16, median of {reps} (ms per trial):");
    println!("| executor | coordinator CPU | wall |");
    println!("|---|---|---|");
    println!(
        "| local pool, --jobs 1 (JSON-lines store) | {:.3} | {:.3} |",
        per(&null_local, |x| x.1),
        per(&null_local, |x| x.0)
    );
    println!(
        "| --remote, 2 worker processes (PostgreSQL) | {:.3} | {:.3} |",
        per(&null_remote, |x| x.1),
        per(&null_remote, |x| x.0)
    );
    let _ = std::fs::remove_dir_all(&out);
}
