//! Campaigns on `savme worker` processes through PostgreSQL with **durable commits**.
//!
//! `cargo bench --features postgres --bench distributed -- [repetitions] [--no-optuna]`
//!
//! Starts a throwaway PostgreSQL 15 with durable commits (`fsync=on`, `synchronous_commit=on`:
//! `tests/common/postgres.rs` `Server::start_durable`; the settings are printed), then for N =
//! 1, 4, 16, 64 worker threads (one `savme worker --jobs N` process; the coordinator `savme toy
//! --remote`, window 64 for every row):
//! 1. a **null** simulator (`--null`: runs cost nothing), 1,000 trials (1,750 runs): trials/s of
//!    the coordinator process's wall time (start to exit: schema, connections and outputs
//!    included), and its CPU per trial — once with the worker connecting as the tables' owner,
//!    once as the **least-privilege worker role** of `docs/DISTRIBUTED.md` (`CREATE ROLE …
//!    LOGIN`, `--worker-role`: the worker functions, no table);
//! 2. a **sleeping** simulator (`--sleep-ms 20`: every run sleeps 20 ms), 200 trials (350 runs),
//!    the worker as the least-privilege role.
//!
//! Each row also gives the CPU time per trial of the coordinator process, the worker process
//! and the whole database server (the postmaster, its reaped children and its live backends,
//! from `/proc`). `--no-optuna` skips the reference rows.
//!
//! Then the reference: Optuna with RDB storage on the same server (`benches/optuna_rdb.py`,
//! `n_jobs` = N threads, RandomSampler, a null and a 20 ms objective) when
//! `target/optuna-venv/bin/python` (or `SAVME_OPTUNA_PYTHON`) has optuna and psycopg2.
#[path = "../tests/common/postgres.rs"]
mod pg;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_savme");

/// The window of every row: trials in flight at once (2 runs each at most).
const WINDOW: &str = "64";

const SLEEPING: &[&str] = &[
    "--sleep-ms",
    "20",
    "--cost",
    "work",
    "--seed",
    "1",
    "--window",
    WINDOW,
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
    WINDOW,
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

/// The fields of `/proc/PID/stat` from the third on (after the command's parentheses).
fn stat_fields(pid: u32) -> Option<Vec<u64>> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    // Field 3 (the state) is a letter: read as 0.
    Some(after.split(' ').map(|f| f.parse().unwrap_or(0)).collect())
}

/// utime + stime of a running process, in clock ticks.
fn cpu_ticks(pid: u32) -> Option<u64> {
    let f = stat_fields(pid)?;
    // Fields 14 and 15 of stat; `f` starts at field 3.
    Some(f.get(11)? + f.get(12)?)
}

/// The CPU time of the whole database server so far, in clock ticks: the postmaster's own and
/// its reaped children's (cutime, cstime), and its live children's (the backends).
fn server_ticks(server: &pg::Server) -> u64 {
    let Some(postmaster) = server.postmaster_pid() else {
        return 0;
    };
    let own = stat_fields(postmaster).map_or(0, |f| f[11..15].iter().sum());
    let children: u64 = std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter_map(stat_fields)
        .filter(|f| f.get(1) == Some(&(postmaster as u64)))
        .map(|f| f[11] + f[12])
        .sum();
    own + children
}

/// Runs `cmd` to the end: (wall seconds, CPU seconds of the process as last sampled, CPU
/// seconds of process `also` as last sampled).
fn measure(mut cmd: Command, also: u32) -> (f64, f64, f64) {
    let start = Instant::now();
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("savme starts");
    let (mut ticks, mut other) = (0, 0);
    loop {
        if let Some(t) = cpu_ticks(child.id()) {
            ticks = ticks.max(t);
        }
        if let Some(t) = cpu_ticks(also) {
            other = other.max(t);
        }
        if let Some(status) = child.try_wait().expect("wait") {
            let wall = start.elapsed().as_secs_f64();
            let err = child
                .wait_with_output()
                .map(|o| o.stderr)
                .unwrap_or_default();
            assert!(status.success(), "{}", String::from_utf8_lossy(&err));
            let hz = clock_ticks();
            return (wall, ticks as f64 / hz, other as f64 / hz);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The seconds from campaign `name`'s first queued run to its last stored trial (the campaign
/// itself, without the process's start and the output files).
fn span(server: &pg::Server, name: &str) -> f64 {
    let mut c = server.client_of("bench");
    c.query_one(
        "SELECT extract(epoch FROM (SELECT max(t.stored_at) FROM savme.trials t WHERE t.campaign_id = c.id)
                                - (SELECT min(r.queued_at) FROM savme.runs r WHERE r.campaign_id = c.id))::float8
           FROM savme.campaigns c WHERE c.name = $1",
        &[&name],
    )
    .unwrap()
    .get(0)
}

/// The least-privilege worker role of the benchmark, and its password.
const ROLE: (&str, &str) = ("bench_worker", "bench-pw");

/// One campaign's measurements: wall seconds of the coordinator process, and CPU seconds of
/// the coordinator, the worker process and the database server.
#[derive(Clone, Copy)]
struct Measured {
    wall: f64,
    coordinator: f64,
    worker: f64,
    server: f64,
}

/// A remote campaign `name` with one worker process of `threads` threads started first (on
/// `worker_url`: the owner's, or the worker role's, which the coordinator then lets work on the
/// campaign).
fn remote(
    server: &pg::Server,
    (url, worker_url): (&str, &str),
    name: &str,
    (out, flags): (&Path, &[&str]),
    threads: usize,
) -> Measured {
    let _ = std::fs::remove_dir_all(out);
    let before = server_ticks(server);
    let mut worker = Command::new(EXE)
        .args(["worker", "--storage", worker_url, "--campaign", name])
        .args(["--jobs", &threads.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("worker starts");
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
    if worker_url != url {
        c.args(["--worker-role", ROLE.0]);
    }
    let (wall, coordinator, mut worker_cpu) = measure(c, worker.id());
    while worker.try_wait().ok().flatten().is_none() {
        if let Some(t) = cpu_ticks(worker.id()) {
            worker_cpu = worker_cpu.max(t as f64 / clock_ticks());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    Measured {
        wall,
        coordinator,
        worker: worker_cpu,
        server: (server_ticks(server) - before) as f64 / clock_ticks(),
    }
}

/// The Python with optuna and psycopg2, if any.
fn optuna_python() -> Option<PathBuf> {
    let python = std::env::var_os("SAVME_OPTUNA_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("target/optuna-venv/bin/python")
        });
    let ok = Command::new(&python)
        .args(["-c", "import optuna, psycopg2"])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("\n!!!!!!!!!! no Optuna reference: {} lacks optuna or psycopg2 (python3 -m venv target/optuna-venv && target/optuna-venv/bin/pip install optuna psycopg2-binary) !!!!!!!!!!\n", python.display());
        return None;
    }
    Some(python)
}

/// Optuna's trials/s on `url` (SQLAlchemy form) with `threads` threads.
fn optuna(python: &Path, url: &str, sim: &str, trials: usize, threads: usize) -> f64 {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/optuna_rdb.py");
    let o = Command::new(python)
        .arg(script)
        .args([url, sim, &trials.to_string(), &threads.to_string()])
        .output()
        .expect("python runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let mut words = text.split_whitespace();
    let seconds: f64 = words.next().and_then(|w| w.parse().ok()).expect("seconds");
    let done: f64 = words.next().and_then(|w| w.parse().ok()).expect("trials");
    done / seconds
}

fn settings(server: &pg::Server) -> String {
    let mut c = server.client();
    [
        "fsync",
        "synchronous_commit",
        "wal_sync_method",
        "full_page_writes",
    ]
    .iter()
    .map(|k| {
        let v: String = c.query_one(&format!("SHOW {k}"), &[]).unwrap().get(0);
        format!("{k}={v}")
    })
    .collect::<Vec<_>>()
    .join(", ")
}

fn main() {
    let reps: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(1);
    let Some(server) = pg::Server::start_durable("bench") else {
        return;
    };
    let url = server.create_db("bench");
    let mut admin = server.client_of("bench");
    admin
        .batch_execute(&format!(
            "CREATE ROLE {0} LOGIN PASSWORD '{1}'; GRANT CONNECT ON DATABASE bench TO {0}",
            ROLE.0, ROLE.1
        ))
        .expect("the worker role");
    let role_url = server.url_for(ROLE.0, ROLE.1, "bench");
    println!("server: {}", settings(&server));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average before: {}", load.trim());
    let out: PathBuf =
        std::env::temp_dir().join(format!("savme-bench-dist-{}", std::process::id()));
    let threads = [1usize, 4, 16, 64];
    println!("\nsavme, window {WINDOW}, median of {reps}; one `savme worker --jobs N` process");
    println!("(trials/s: of the coordinator process's wall time / of the campaign's span in the database, first run queued to last trial stored; the sleeping rows' worker is the least-privilege role)");
    println!("| N threads | null, worker role: trials/s (process / span) | null, owner: trials/s (process / span) | CPU ms per null trial (role): coordinator / worker / server | 20 ms sleep: trials/s (process / span) | vs 1 thread (span) | CPU ms per 20 ms trial: coordinator / worker / server |");
    println!("|---|---|---|---|---|---|---|");
    let mut one = 0.0;
    let per = |m: &[Measured], trials: f64| {
        let ms = |f: fn(&Measured) -> f64| median(m.iter().map(f).collect()) / trials * 1e3;
        format!(
            "{:.3} / {:.3} / {:.3}",
            ms(|m| m.coordinator),
            ms(|m| m.worker),
            ms(|m| m.server)
        )
    };
    for (k, &n) in threads.iter().enumerate() {
        let (mut null, mut null_span) = (Vec::new(), Vec::new());
        let (mut owner, mut owner_span) = (Vec::new(), Vec::new());
        let (mut sleep, mut sleep_span) = (Vec::new(), Vec::new());
        for rep in 0..reps {
            let name = format!("null-{n}-{rep}");
            null.push(remote(&server, (&url, &role_url), &name, (&out, NULL), n));
            null_span.push(span(&server, &name));
            let name = format!("owner-{n}-{rep}");
            owner.push(remote(&server, (&url, &url), &name, (&out, NULL), n).wall);
            owner_span.push(span(&server, &name));
            let name = format!("sleep-{n}-{rep}");
            sleep.push(remote(
                &server,
                (&url, &role_url),
                &name,
                (&out, SLEEPING),
                n,
            ));
            sleep_span.push(span(&server, &name));
        }
        let wall = median(null.iter().map(|x| x.wall).collect());
        let s = SLEEPING_TRIALS / median(sleep_span);
        if k == 0 {
            one = s;
        }
        println!(
            "| {n} | {:.0} / {:.0} | {:.0} / {:.0} | {} | {:.1} / {s:.1} | {:.2}× | {} |",
            NULL_TRIALS / wall,
            NULL_TRIALS / median(null_span),
            NULL_TRIALS / median(owner),
            NULL_TRIALS / median(owner_span),
            per(&null, NULL_TRIALS),
            SLEEPING_TRIALS / median(sleep.iter().map(|x| x.wall).collect()),
            s / one,
            per(&sleep, SLEEPING_TRIALS),
        );
    }
    let skip_optuna = std::env::args().any(|a| a == "--no-optuna");
    if let Some(python) = optuna_python().filter(|_| !skip_optuna) {
        // Its own database on the same server (Optuna's tables would otherwise land in the
        // schema named after the user, `savme`, beside savme's own `trials`).
        server.create_db("optuna");
        let sa = format!(
            "postgresql+psycopg2://{}:{}@127.0.0.1:{}/optuna",
            pg::USER,
            pg::PASSWORD,
            server.port()
        );
        println!(
            "\nOptuna RDBStorage, same server, RandomSampler, n_jobs = N threads, median of {reps}"
        );
        println!("| N threads | null: trials/s | 20 ms sleep: trials/s | vs 1 thread |");
        println!("|---|---|---|---|");
        let mut one = 0.0;
        for (k, &n) in threads.iter().enumerate() {
            let null = median(
                (0..reps)
                    .map(|_| optuna(&python, &sa, "null", 500, n))
                    .collect(),
            );
            let s = median(
                (0..reps)
                    .map(|_| optuna(&python, &sa, "sleep", 200, n))
                    .collect(),
            );
            if k == 0 {
                one = s;
            }
            println!("| {n} | {null:.0} | {s:.1} | {:.2}× |", s / one);
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("\nload average after: {}", load.trim());
    let _ = std::fs::remove_dir_all(&out);
}
