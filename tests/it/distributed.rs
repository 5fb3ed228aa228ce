//! Campaigns whose runs are done by `savme worker` processes through a real PostgreSQL server
//! the test starts itself (`common/postgres.rs`): the same trials as a local run for any number
//! of workers, and each fault with real processes — a worker killed with `kill -9` mid-run, the
//! coordinator killed and resumed, the database restarted mid-campaign, workers that never
//! come.
use crate::common;

use common::campaign::{
    db_trials, finish, local_trials, query_i64, text, toy_coordinator, toy_local, wait_until,
    worker, Distributed, TOY,
};
use common::postgres::Server;
use common::{send, temp_dir, EXE};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

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
    let expected = local_trials(&local, &[&["reproduce"][..], &tiny[..]].concat());
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
            let db = savme::postgres::Database::parse(&url).unwrap();
            drop(savme::postgres::PostgresStore::open(&db, "setup").unwrap());
            let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
            c.batch_execute(&role_sql).unwrap();
            server.url_for("savme_worker", "worker-pw", "workers")
        } else {
            url.clone()
        };
        // One thread each: with up to 2 × window runs in flight, one worker cannot take them
        // all while the others wait (with a thread per core, a fast first worker sometimes did).
        let children: Vec<Child> = (0..workers)
            .map(|_| worker(&worker_url, &name, &["--jobs", "1"]))
            .collect();
        let o = Command::new(EXE)
            .args([
                "reproduce",
                "--storage",
                &url,
                "--campaign",
                &name,
                "--remote",
                "--worker-role",
                "savme_worker",
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
        // Every run ran once.
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
        // (How the runs are shared out between the workers depends on timing: on an idle
        // machine one worker sometimes claims them all, which is correct. The trials above
        // must be the same whatever the sharing.)
        assert!(row.get::<_, i64>(2) >= 1);
        let _ = std::fs::remove_dir_all(out);
    }
    let _ = std::fs::remove_dir_all(local);
}

#[test]
fn a_worker_killed_mid_run_loses_its_lease_and_another_reruns_the_run_once() {
    let Some(dist) = Distributed::set_up("killworker", 150) else {
        return;
    };
    let (url, expected) = (dist.url.clone(), dist.expected.clone());
    let coordinator = dist.coordinator("k", Stdio::piped());
    let mut doomed = worker(&url, "k", &["--lease", "1"]);
    let mut client = dist.client();
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
    dist.clean();
}

#[test]
fn a_killed_coordinator_resumes_using_the_runs_workers_finished_meanwhile() {
    let Some(dist) = Distributed::set_up("killcoord", 60) else {
        return;
    };
    let (url, expected, out) = (dist.url.clone(), dist.expected.clone(), dist.out.clone());
    let w = worker(&url, "c", &["--jobs", "2"]);
    let mut coordinator = dist.coordinator("c", Stdio::null());
    let mut client = dist.client();
    // Killed twice mid-campaign (the second time after a resume): each time the stored lines
    // are exactly the first lines of the local run — a batch is committed whole or not at all.
    for (round, at) in [(0, 4), (1, 9)] {
        if round > 0 {
            coordinator = Command::new(EXE)
                .args([
                    "toy",
                    "--storage",
                    &url,
                    "--campaign",
                    "c",
                    "--remote",
                    "--resume",
                ])
                .args(["--quiet", "--out"])
                .arg(&out)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
        }
        wait_until("trials to be stored", Duration::from_secs(60), || {
            query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= at
        });
        coordinator.kill().unwrap(); // SIGKILL
        coordinator.wait().unwrap();
        let stored = db_trials(&mut client, "c");
        assert!(stored.len() < expected.len(), "finished before the kill");
        assert_eq!(stored, expected[..stored.len()], "after kill {round}");
        assert_eq!(
            query_i64(&mut client, "SELECT max(line) FROM savme.trials"),
            stored.len() as i64
        );
    }
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
    dist.clean();
}

#[test]
fn a_database_restart_mid_campaign_loses_nothing() {
    let Some(mut dist) = Distributed::set_up("restart", 40) else {
        return;
    };
    let (url, expected) = (dist.url.clone(), dist.expected.clone());
    // Leases long enough to outlast the restart: no run changes hands, so none is dropped.
    let w = worker(&url, "r", &["--jobs", "2", "--lease", "30"]);
    let coordinator = dist.coordinator("r", Stdio::piped());
    {
        let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
        wait_until("trials to be stored", Duration::from_secs(60), || {
            query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 5
        });
    }
    dist.server.stop();
    std::thread::sleep(Duration::from_millis(1500));
    dist.server.restart();
    let said = finish(coordinator, "the coordinator");
    assert!(said.contains("connection lost"), "{said}");
    assert!(!said.contains(common::postgres::PASSWORD), "{said}");
    let t = finish(w, "the worker");
    // A finish that committed just before the connection broke is not counted as dropped.
    assert!(
        t.contains("(0 finished after their lease expired and were dropped)"),
        "{t}"
    );
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    assert_eq!(db_trials(&mut client, "r"), expected);
    dist.clean();
}

#[test]
fn a_coordinator_without_workers_says_so_with_a_command_that_pastes() {
    let Some(server) = Server::start("noworkers") else {
        return;
    };
    let url = server.create_db("noworkers");
    let out = temp_dir("noworkers");
    // A name a shell would split, and a URL option with `&`: the command must be quoted.
    let name = "lonely & night";
    let url = format!("{url}?sslmode=disable&connect_timeout=10");
    let mut coordinator = toy_coordinator(&url, name, &out, &["--worker-wait", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = std::io::BufReader::new(coordinator.stderr.take().unwrap());
    let mut said = String::new();
    let command = loop {
        let mut line = String::new();
        assert!(
            std::io::BufRead::read_line(&mut err, &mut line).unwrap() > 0,
            "the coordinator ended: {said}"
        );
        said.push_str(&line);
        if let Some((_, c)) = line.split_once("Start workers on any host with: ") {
            break c.trim().to_string();
        }
    };
    assert!(
        said.contains("no worker has taken a run of campaign \"lonely & night\" in 1 s"),
        "{said}"
    );
    assert!(
        command.starts_with("savme worker --storage 'postgresql://savme@127.0.0.1:")
            && command.ends_with("/noworkers?sslmode=disable' --campaign 'lonely & night'"),
        "{command}"
    );
    assert!(!said.contains(common::postgres::PASSWORD), "{said}");
    // Pasted into a shell (the password from the environment), it runs the campaign.
    // (With more threads than the campaign's window keeps busy: it says so.)
    let pasted = format!("{} --jobs 9", command.replacen("savme", EXE, 1));
    let w = Command::new("sh")
        .args(["-c", &pasted])
        .env("PGPASSWORD", common::postgres::PASSWORD)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    finish(coordinator, "the coordinator");
    let t = finish(w, "the pasted worker");
    assert!(t.contains("finished"), "{t}");
    assert!(
        t.contains("has a window of 4 trials, so at most 8 runs are in flight")
            && t.contains("1 of this worker's 9 threads will always be idle"),
        "{t}"
    );
    let _ = std::fs::remove_dir_all(out);
}

/// `savme fmu pack`'s FMU in `dir`, and the tiny FMU campaign file on it (`fmu_lines` added to
/// its `[fmu]` section).
fn fmu_campaign(dir: &Path, fmu_lines: &str) -> (PathBuf, PathBuf) {
    std::fs::create_dir_all(dir).unwrap();
    let fmu = dir.join("savme-sim.fmu");
    if !fmu.exists() {
        let o = Command::new(EXE)
            .args(["fmu", "pack", "--out"])
            .arg(&fmu)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
    }
    let body = include_str!("../fixtures/fmu-tiny-campaign.toml").replace(
        "hf = \"FMU\"",
        &format!("hf = {:?}\n{fmu_lines}", fmu.display().to_string()),
    );
    let config = dir.join(format!("campaign{}.toml", fmu_lines.len()));
    std::fs::write(&config, body).unwrap();
    (fmu, config)
}

/// `savme run --config CONFIG` as the coordinator of campaign `name`, its runs done by
/// workers.
fn fmu_coordinator(url: &str, name: &str, config: &Path, out: &Path) -> Child {
    Command::new(EXE)
        .args([
            "run",
            "--storage",
            url,
            "--campaign",
            name,
            "--remote",
            "--quiet",
        ])
        .arg("--config")
        .arg(config)
        .arg("--out")
        .arg(out)
        // The summary is printed at the end (a few kB: the pipe does not fill while it runs).
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn fmu_campaign_workers_give_the_trials_of_the_local_run() {
    let Some(server) = Server::start("fmu") else {
        return;
    };
    let url = server.create_db("fmu");
    let dir = temp_dir("fmu");
    let (_, config) = fmu_campaign(&dir, "");
    let cfg = config.to_str().unwrap();
    let local = dir.join("local");
    let expected = local_trials(&local, &["run", "--quiet", "--config", cfg]);
    let workers = [
        worker(&url, "f", &["--config", cfg]),
        worker(&url, "f", &["--config", cfg, "--jobs", "2"]),
    ];
    let out = dir.join("remote");
    finish(fmu_coordinator(&url, "f", &config, &out), "the coordinator");
    for (k, w) in workers.into_iter().enumerate() {
        finish(w, &format!("worker {k}"));
    }
    let mut client = server.client_of("fmu");
    assert_eq!(db_trials(&mut client, "f"), expected);
    assert_eq!(
        std::fs::read_to_string(out.join("table.md")).unwrap(),
        std::fs::read_to_string(local.join("table.md")).unwrap()
    );
    let ran = query_i64(
        &mut client,
        "SELECT count(*) FROM savme.runs WHERE state = 'done' AND attempts = 1",
    );
    let runs = expected.len() + expected.iter().filter(|t| !t["lf"].is_null()).count();
    assert_eq!(ran, runs as i64, "every run ran once, on a worker");
    let _ = std::fs::remove_dir_all(dir);
}

/// Waits until the coordinator of campaign `name` has queued runs (so it has loaded its FMUs).
fn wait_for_campaign(client: &mut postgres::Client, name: &str) {
    let sql = format!(
        "SELECT count(*) FROM savme.runs r JOIN savme.campaigns c ON c.id = r.campaign_id
          WHERE c.name = '{name}'"
    );
    wait_until("the campaign's first runs", Duration::from_secs(60), || {
        query_i64(client, &sql) > 0
    });
}

#[test]
fn a_worker_without_the_fmu_fails_its_runs_and_the_campaigns_on_error_applies() {
    let Some(server) = Server::start("nofmu") else {
        return;
    };
    let url = server.create_db("nofmu");
    let mut client = server.client_of("nofmu");
    let dir = temp_dir("nofmu");
    let (fmu, abort) = fmu_campaign(&dir, "");
    let (_, skip) = fmu_campaign(&dir, "on_error = \"skip\"");
    let away = dir.join("elsewhere.fmu");
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
    let names_the_fmu_and_host = |t: &str| {
        t.contains(&fmu.display().to_string())
            && t.contains(&format!("on {}", host.trim()))
            && t.contains("cannot run this campaign's simulator")
    };

    // on_error = "abort" (the default): the coordinator stops with the worker's error, naming
    // the trial, the FMU and the worker's host. The worker's host lacks the FMU: it is moved
    // away once the coordinator (on the same machine here) has loaded it.
    let coordinator = fmu_coordinator(&url, "a", &abort, &dir.join("a"));
    wait_for_campaign(&mut client, "a");
    std::fs::rename(&fmu, &away).unwrap();
    let mut broken = worker(&url, "a", &["--config", abort.to_str().unwrap()]);
    let o = coordinator.wait_with_output().unwrap();
    let said = text(&o);
    broken.kill().unwrap();
    let worker_said = text(&broken.wait_with_output().unwrap());
    assert!(!o.status.success(), "{said}");
    assert!(
        names_the_fmu_and_host(&said),
        "{said}\nworker: {worker_said}"
    );
    assert!(said.contains("trial"), "{said}");
    assert!(
        worker_said.contains("WARNING: this host cannot run campaign \"a\"'s simulator"),
        "{worker_said}"
    );
    std::fs::rename(&away, &fmu).unwrap();

    // on_error = "skip": the trials whose runs failed on that worker are withdrawn (stored with
    // the error) and replaced; once that worker is gone, a healthy one finishes the campaign.
    let coordinator = fmu_coordinator(&url, "s", &skip, &dir.join("s"));
    wait_for_campaign(&mut client, "s");
    std::fs::rename(&fmu, &away).unwrap();
    let mut broken = worker(
        &url,
        "s",
        &["--config", skip.to_str().unwrap(), "--lease", "1"],
    );
    wait_until("a withdrawn trial", Duration::from_secs(60), || {
        query_i64(
            &mut client,
            "SELECT count(*) FROM savme.trials WHERE error IS NOT NULL",
        ) > 0
    });
    broken.kill().unwrap(); // SIGKILL
    broken.wait().unwrap();
    std::fs::rename(&away, &fmu).unwrap();
    let healthy = worker(&url, "s", &["--config", skip.to_str().unwrap()]);
    let said = finish(coordinator, "the coordinator");
    finish(healthy, "the healthy worker");
    let lines = db_trials(&mut client, "s");
    let (failed, told): (Vec<&Value>, Vec<&Value>) =
        lines.iter().partition(|l| l.get("error").is_some());
    assert!(!failed.is_empty());
    // The printed summary says so too, not only summary.json.
    assert!(
        said.contains(&format!(
            "{} trials withdrawn because a simulation failed",
            failed.len()
        )),
        "{said}"
    );
    for f in &failed {
        assert!(names_the_fmu_and_host(f["error"].as_str().unwrap()), "{f}");
    }
    assert_eq!(
        told.len(),
        6 + 8 + 4 + 4 + 2 * 4,
        "every stage told its trials"
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// Waits (up to `limit`) for `child` to exit; its status code and output.
fn exit_of(mut child: Child, limit: Duration) -> (Option<i32>, String) {
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!("still running after {limit:?}: {}", text(&o));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = child.wait_with_output().unwrap();
    (o.status.code(), text(&o))
}

#[test]
fn a_worker_says_at_once_when_its_campaign_runs_without_remote_and_stops_after_its_grace() {
    let Some(server) = Server::start("noremote") else {
        return;
    };
    let url = server.create_db("noremote");
    let out = temp_dir("noremote");
    // The coordinator runs its trials itself (no --remote), slowly enough to outlast the
    // worker's grace.
    let mut coordinator = Command::new(EXE)
        .args(["toy", "--storage", &url, "--campaign", "local", "--out"])
        .arg(&out)
        .args(TOY)
        .args(["--sleep-ms", "400", "--jobs", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    wait_until("the campaign to start", Duration::from_secs(60), || {
        client
            .query_opt("SELECT 1 FROM savme.campaigns WHERE name = 'local'", &[])
            .is_ok_and(|r| r.is_some())
    });
    let start = std::time::Instant::now();
    let mut w = worker(&url, "local", &["--grace", "6"]);
    let mut err = std::io::BufReader::new(w.stderr.take().unwrap());
    let mut line = String::new();
    std::io::BufRead::read_line(&mut err, &mut line).unwrap();
    let first = start.elapsed();
    assert!(
        line.contains("is held by a coordinator started without --remote")
            && line.contains("waits"),
        "{line}"
    );
    assert!(first < Duration::from_secs(8), "said after {first:?}");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let status = w.wait().unwrap();
    let stopped = start.elapsed();
    assert_eq!(status.code(), Some(1), "{rest}");
    assert!(
        rest.contains("no live coordinator of campaign \"local\" for 6 s")
            && rest.contains("Resume the campaign with:")
            && rest.contains("savme worker --storage"),
        "{rest}"
    );
    assert!(
        stopped < Duration::from_secs(30),
        "stopped after {stopped:?}"
    );
    let _ = coordinator.kill();
    let _ = coordinator.wait();
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_worker_whose_coordinator_was_killed_stops_after_its_grace_naming_the_resume_command() {
    let Some(dist) = Distributed::set_up("graceful", 100) else {
        return;
    };
    let (url, expected) = (dist.url.clone(), dist.expected.clone());
    let w = worker(&url, "g", &["--grace", "5", "--jobs", "2"]);
    let mut coordinator = dist.coordinator("g", Stdio::null());
    let mut client = dist.client();
    wait_until("trials to be stored", Duration::from_secs(60), || {
        query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 3
    });
    coordinator.kill().unwrap(); // SIGKILL
    coordinator.wait().unwrap();
    let killed = std::time::Instant::now();
    let (code, said) = exit_of(w, Duration::from_secs(60));
    assert_eq!(code, Some(1), "{said}");
    assert!(
        killed.elapsed() < Duration::from_secs(30),
        "{:?}",
        killed.elapsed()
    );
    assert!(said.contains("has no coordinator running"), "{said}");
    let resume = said
        .lines()
        .find_map(|l| {
            l.split_once("Resume the campaign with: ")
                .map(|(_, c)| c.to_string())
        })
        .unwrap_or_else(|| panic!("no resume command: {said}"));
    assert!(
        resume.starts_with("savme toy --storage postgresql://savme@127.0.0.1:")
            && resume.contains(" --campaign g --remote --out ")
            && resume.ends_with(" --resume")
            && !resume.contains(common::postgres::PASSWORD),
        "{resume}"
    );
    // This worker's own command to start again keeps its --jobs.
    assert!(
        said.contains(
            "then start the workers again: savme worker --storage postgresql://savme@127.0.0.1:"
        ) && said.contains(" --campaign g --jobs 2"),
        "{said}"
    );
    // The command, pasted, resumes the campaign (the password from the environment).
    let w = worker(&url, "g", &[]);
    let resumed = Command::new("sh")
        .args(["-c", &resume.replacen("savme", EXE, 1)])
        .env("PGPASSWORD", common::postgres::PASSWORD)
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed));
    finish(w, "the second worker");
    assert_eq!(db_trials(&mut client, "g"), expected);
    dist.clean();
}

/// savme's schema in database `database` at `url`, and the documented worker role created twice,
/// as `worker_a` and `worker_b` (password `pw`); the owner's connection.
fn with_worker_roles(url: &str, database: &str) -> postgres::Client {
    let mut admin = postgres::Client::connect(url, postgres::NoTls).unwrap();
    let db = savme::postgres::Database::parse(url).unwrap();
    drop(savme::postgres::PostgresStore::open(&db, "setup").unwrap());
    for role in ["worker_a", "worker_b"] {
        let sql = common::doc_sql("worker-role")
            .replace("savme_worker", role)
            .replace("change-me", "pw")
            .replace("DATABASE safety", &format!("DATABASE {database}"));
        admin.batch_execute(&sql).unwrap();
    }
    admin
}

#[test]
fn a_worker_role_sees_and_changes_only_the_campaigns_it_is_allowed_on() {
    let Some(server) = Server::start("rls") else {
        return;
    };
    let url = server.create_db("rls");
    let local = temp_dir("rls-local");
    let expected = toy_local(&local, &["--sleep-ms", "30"]);
    let mut admin = with_worker_roles(&url, "rls");
    // Campaign B: its coordinator allows worker_b only; no worker yet, so its runs wait.
    let out_b = temp_dir("rls-b");
    let coordinator_b = toy_coordinator(&url, "b", &out_b, &["--sleep-ms", "30"])
        .args(["--worker-role", "worker_b"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until("b's runs to be queued", Duration::from_secs(60), || {
        query_i64(&mut admin, "SELECT count(*) FROM savme.runs r JOIN savme.campaigns c ON c.id = r.campaign_id WHERE c.name = 'b'") > 0
    });
    // Campaign A, worked on by worker_a, finishes as locally.
    let out_a = temp_dir("rls-a");
    let url_a = server.url_for("worker_a", "pw", "rls");
    let wa = worker(&url_a, "a", &[]);
    let o = toy_coordinator(&url, "a", &out_a, &["--sleep-ms", "30"])
        .args(["--worker-role", "worker_a"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    finish(wa, "worker_a");
    assert_eq!(db_trials(&mut admin, "a"), expected);
    // worker_a neither reads nor changes campaign B: it has no right on any table (it acts
    // through savme's functions, which show it campaign A only), and a forged result is
    // refused.
    let mut a = postgres::Client::connect(&url_a, postgres::NoTls).unwrap();
    let sees = |a: &mut postgres::Client, name: &str| {
        a.query("SELECT id FROM savme.worker_campaign($1)", &[&name])
            .unwrap()
            .len()
    };
    assert_eq!(sees(&mut a, "b"), 0);
    assert_eq!(sees(&mut a, "a"), 1);
    let b_id: i32 = admin
        .query_one("SELECT id FROM savme.campaigns WHERE name = 'b'", &[])
        .unwrap()
        .get(0);
    for sql in [
        "SELECT count(*) FROM savme.campaigns WHERE id = $1",
        "SELECT count(*) FROM savme.runs WHERE campaign_id = $1",
        "UPDATE savme.runs SET state = 'done', failure = true, wall_seconds = 1, work = 1
          WHERE campaign_id = $1",
    ] {
        let e = a.execute(sql, &[&b_id]).unwrap_err();
        assert_eq!(e.code().map(|c| c.code()), Some("42501"), "{sql}: {e}");
    }
    assert!(a.query("SELECT * FROM savme.trials", &[]).is_err());
    // A worker of role worker_a on campaign B waits for a campaign it cannot see.
    let stray = worker(&url_a, "b", &["--wait", "2"]);
    let (code, said) = exit_of(stray, Duration::from_secs(60));
    assert_eq!(code, Some(1), "{said}");
    assert!(said.contains("--worker-role"), "{said}");
    // worker_b finishes B: no forged result got in.
    let wb = worker(&server.url_for("worker_b", "pw", "rls"), "b", &[]);
    finish(coordinator_b, "b's coordinator");
    finish(wb, "worker_b");
    assert_eq!(db_trials(&mut admin, "b"), expected);
    for d in [local, out_a, out_b] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_coordinator_whose_database_stays_down_says_it_gave_up_and_how_to_resume() {
    let Some(mut server) = Server::start("down") else {
        return;
    };
    let url = server.create_db("down");
    let out = temp_dir("down");
    let w = worker(&url, "d", &[]);
    let coordinator = toy_coordinator(&url, "d", &out, &["--sleep-ms", "100"])
        .env("SAVME_RECONNECT_SECONDS", "3")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
        wait_until("trials to be stored", Duration::from_secs(60), || {
            query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 2
        });
    }
    server.stop();
    let (code, said) = exit_of(coordinator, Duration::from_secs(60));
    assert_eq!(code, Some(1), "{said}");
    let last = said
        .trim_end()
        .lines()
        .rev()
        .take(2)
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        last.contains("gave up reconnecting after")
            && last.contains("every trial it told is in the database")
            && last.contains("--resume"),
        "{said}"
    );
    assert!(!said.contains(common::postgres::PASSWORD), "{said}");
    let mut w = w;
    let _ = w.kill();
    let _ = w.wait();
    let _ = std::fs::remove_dir_all(out);
}

#[cfg(unix)]
#[test]
fn sigint_and_sigterm_stop_a_worker_between_runs_and_nothing_is_lost() {
    let Some(dist) = Distributed::set_up("sigworker", 100) else {
        return;
    };
    let (url, expected) = (dist.url.clone(), dist.expected.clone());
    let coordinator = dist.coordinator("s", Stdio::piped());
    let mut client = dist.client();
    let done = "SELECT count(*) FROM savme.runs WHERE state = 'done'";
    // A worker waiting for a campaign that does not exist yet stops too.
    let waiting = worker(&url, "not-yet", &["--wait", "60"]);
    std::thread::sleep(Duration::from_millis(800));
    send(&waiting, "TERM");
    let o = waiting.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(143), "{}", text(&o));
    assert!(
        text(&o).contains("while waiting for campaign"),
        "{}",
        text(&o)
    );
    for (k, (signal, status)) in [("INT", 130), ("TERM", 143)].into_iter().enumerate() {
        let w = worker(&url, "s", &["--jobs", "2", "--lease", "30"]);
        let before = query_i64(&mut client, done);
        wait_until("the worker to finish runs", Duration::from_secs(60), || {
            query_i64(&mut client, done) >= before + 2
        });
        send(&w, signal);
        let o = w.wait_with_output().unwrap();
        let said = text(&o);
        assert_eq!(o.status.code(), Some(status), "{signal}: {said}");
        assert!(
            said.contains("stopped between runs") || said.contains("between runs"),
            "{said}"
        );
        // The whole command: the flags it was given that change how it works (`--jobs`).
        assert!(
            said.contains("start it again with: savme worker --storage")
                && said.contains(" --campaign s --jobs 2"),
            "{signal}: {said}"
        );
        // Nothing it held is left running: its runs were finished or queued again (a lease of
        // 30 s would otherwise hold them).
        let held = query_i64(
            &mut client,
            "SELECT count(*) FROM savme.runs WHERE state = 'running'",
        );
        assert_eq!(
            held, 0,
            "{signal}: run {k}: a stopped worker still holds runs"
        );
    }
    let last = worker(&url, "s", &["--jobs", "2"]);
    finish(coordinator, "the coordinator");
    finish(last, "the last worker");
    assert_eq!(
        db_trials(&mut client, "s"),
        expected,
        "no run lost or repeated"
    );
    dist.clean();
}

#[cfg(unix)]
#[test]
fn a_run_in_a_database_stopped_by_a_signal_prints_the_whole_command_that_resumes_it() {
    use std::io::BufRead;
    let Some(server) = Server::start("runhint") else {
        return;
    };
    let url = server.create_db("runhint");
    let dir = temp_dir("runhint");
    let (_, config) = fmu_campaign(&dir, "");
    let out = dir.join("out");
    // A protocol flag a resumed run must repeat, and --out (its [estimate] stage's directory).
    let mut child = Command::new(EXE)
        .args([
            "run",
            "--storage",
            &url,
            "--campaign",
            "h",
            "--method",
            "paper",
        ])
        .args(["--jobs", "1", "--config"])
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Stopped once its first stage has started (a progress line on stderr).
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut said = String::new();
    while !said.contains(" started: ") {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "{said}");
        said += &line;
    }
    send(&child, "INT");
    std::io::Read::read_to_string(&mut err, &mut said).unwrap();
    assert_eq!(child.wait().unwrap().code(), Some(130), "{said}");
    let hint = said
        .lines()
        .find_map(|l| l.split_once("continue with ").map(|(_, c)| c.to_string()))
        .unwrap_or_else(|| panic!("no resume command: {said}"));
    assert!(
        hint.starts_with("savme run --storage postgresql://savme@127.0.0.1:")
            && hint.contains(" --campaign h --method paper --jobs 1 --config ")
            && hint.contains(" --out ")
            && hint.ends_with(" --resume")
            && !hint.contains(common::postgres::PASSWORD),
        "{hint}"
    );
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let count = "SELECT count(*) FROM savme.trials";
    assert!(
        query_i64(&mut client, count) < 30,
        "finished before the signal"
    );
    // The command, pasted, resumes the campaign to its end (the password from the environment).
    let resumed = Command::new("sh")
        .args(["-c", &hint.replacen("savme", EXE, 1)])
        .env("PGPASSWORD", common::postgres::PASSWORD)
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed));
    assert_eq!(query_i64(&mut client, count), 30);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The SQLSTATE and message of a statement the server refused (panics if it ran).
fn refusal<T: std::fmt::Debug>(r: Result<T, postgres::Error>, what: &str) -> (String, String) {
    let e = r.expect_err(what);
    let db = e
        .as_db_error()
        .unwrap_or_else(|| panic!("{what}: not a server error: {e}"));
    (db.code().code().to_string(), db.message().to_string())
}

/// Each attack of issue 41, played with a raw client connection as a worker role allowed on
/// campaign A only (`application_name` claiming to be a coordinator): the coordinator lock of
/// another campaign, that campaign's rows, a forged or corrupt result, a result under another
/// worker's name, an endless lease. Every one is refused, and both campaigns end with the local
/// run's trials.
#[test]
fn every_attack_of_a_worker_role_is_refused_and_no_campaign_stops() {
    let Some(server) = Server::start("attack") else {
        return;
    };
    let url = server.create_db("attack");
    let local = temp_dir("attack-local");
    let expected = toy_local(&local, &["--sleep-ms", "200"]);
    let mut admin = with_worker_roles(&url, "attack");
    for role in ["worker_a", "worker_b"] {
        // As when it was allowed on an earlier campaign: the worker functions, no table.
        admin
            .execute("SELECT savme.grant_worker($1::text::name)", &[&role])
            .unwrap();
    }
    // Campaign B, allowed to worker_b, queues its runs; its coordinator is then killed.
    let out_b = temp_dir("attack-b");
    let mut coordinator_b = toy_coordinator(&url, "b", &out_b, &["--sleep-ms", "200"])
        .args(["--worker-role", "worker_b"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let runs_of = |name: &str| {
        format!("SELECT count(*) FROM savme.runs r JOIN savme.campaigns c ON c.id = r.campaign_id WHERE c.name = '{name}'")
    };
    wait_until("b's runs to be queued", Duration::from_secs(60), || {
        query_i64(&mut admin, &runs_of("b")) > 0
    });
    coordinator_b.kill().unwrap();
    coordinator_b.wait().unwrap();
    let b_id: i32 = admin
        .query_one("SELECT id FROM savme.campaigns WHERE name = 'b'", &[])
        .unwrap()
        .get(0);
    let url_a = server.url_for("worker_a", "pw", "attack");
    let mut config: postgres::Config = url_a.parse().unwrap();
    config.application_name("savme coordinator pid 4242 on trusted-host");
    let mut a = config.connect(postgres::NoTls).unwrap();

    // 1. B's coordinator lock, and the next campaign's: an advisory lock is no lock any more,
    // and the lock row cannot be written.
    for id in [b_id, b_id + 1] {
        let r = a.query_one("SELECT pg_try_advisory_lock(29558, $1)", &[&id]);
        assert!(r.unwrap().get::<_, bool>(0));
    }
    let (code, _) = refusal(
        a.query_one("SELECT savme.take_lock($1)", &[&b_id]),
        "take_lock",
    );
    assert_eq!(code, "42501");
    for sql in [
        "INSERT INTO savme.coordinators VALUES (2, pg_backend_pid(), now(), 'worker_a', 'x', 'y')",
        "UPDATE savme.coordinators SET pid = pg_backend_pid()",
        "DELETE FROM savme.coordinators",
    ] {
        assert_eq!(refusal(a.execute(sql, &[]), sql).0, "42501", "{sql}");
    }
    // B's rows, through the tables or the functions: nothing.
    for sql in [
        "SELECT count(*) FROM savme.runs",
        "SELECT count(*) FROM savme.campaigns",
        "SELECT count(*) FROM savme.trials",
        "SELECT count(*) FROM savme.campaign_workers",
        "UPDATE savme.runs SET lease_until = 'infinity'",
        "UPDATE savme.runs SET state = 'done', failure = true, wall_seconds = 1, work = NULL",
        "INSERT INTO savme.campaign_workers VALUES (2, 'worker_a')",
    ] {
        assert_eq!(refusal(a.execute(sql, &[]), sql).0, "42501", "{sql}");
    }
    let none =
        |a: &mut postgres::Client, sql: &str, id: i32| a.query(sql, &[&id]).unwrap().is_empty();
    assert!(none(
        &mut a,
        "SELECT * FROM savme.coordinator_state($1)",
        b_id
    ));
    let seen = a.query("SELECT * FROM savme.worker_campaign('b')", &[]);
    assert!(seen.unwrap().is_empty());
    let (code, message) = refusal(
        a.query("SELECT * FROM savme.claim($1, 'me', 'tok', 30)", &[&b_id]),
        "claim of b",
    );
    assert_eq!(code, "42501");
    assert!(
        message.contains(&format!("role worker_a may not work on campaign {b_id}")),
        "{message}"
    );

    // Campaign A (its id is the one whose advisory lock the attacker holds) starts anyway.
    let out_a = temp_dir("attack-a");
    let coordinator_a = toy_coordinator(&url, "a", &out_a, &["--sleep-ms", "200"])
        .args(["--worker-role", "worker_a"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let honest = worker(&url_a, "a", &[]);
    let held = "SELECT r.id, r.worker, c.id FROM savme.runs r JOIN savme.campaigns c ON c.id = r.campaign_id
                 WHERE c.name = 'a' AND r.state = 'running' ORDER BY r.id LIMIT 1";
    wait_until(
        "the honest worker to hold a run",
        Duration::from_secs(60),
        || admin.query_opt(held, &[]).unwrap().is_some(),
    );
    let row = admin.query_one(held, &[]).unwrap();
    let (run, victim, a_id): (i64, String, i32) = (row.get(0), row.get(1), row.get(2));
    assert_eq!(a_id, b_id + 1);

    // 3. A result under the honest worker's name, its lease renewed forever, its run handed
    // back: refused or no effect.
    let finish_sql = "SELECT * FROM savme.finish_and_claim($1, $2, $3, $4, $5, $6, $7, $8, NULL, NULL, $9, false)";
    let forged = a.query(
        finish_sql,
        &[
            &a_id,
            &run,
            &victim,
            &"guess",
            &"done",
            &Some(true),
            &Some(0.1f64),
            &Some(1i64),
            &30.0f64,
        ],
    );
    let (code, message) = refusal(forged, "a result under another worker's name");
    assert_eq!(code, "SV001");
    assert!(
        message.contains(&format!("run {run} "))
            && message.contains(&victim)
            && message.contains("claimed by another process"),
        "{message}"
    );
    let renew = "SELECT savme.renew($1, ARRAY[$2::bigint], 'guess', $3)";
    for lease in [f64::INFINITY, 1e9, f64::NAN, -1.0] {
        let (code, message) = refusal(a.query_one(renew, &[&a_id, &run, &lease]), "renew");
        assert_eq!(code, "22023", "{lease}: {message}");
    }
    let renewed: i32 = a.query_one(renew, &[&a_id, &run, &30.0f64]).unwrap().get(0);
    assert_eq!(renewed, 0);
    let released: i32 = a
        .query_one(
            "SELECT savme.release($1, $2, $3, 'guess')",
            &[&a_id, &run, &victim],
        )
        .unwrap()
        .get(0);
    assert_eq!(released, 0);
    let claim = "SELECT * FROM savme.claim($1, 'attacker', 'tok', $2)";
    for lease in [f64::INFINITY, 1e9] {
        let (code, message) = refusal(a.query(claim, &[&a_id, &lease]), "an endless lease");
        assert_eq!(code, "22023", "{message}");
        assert!(message.contains("at most 3600 s"), "{message}");
    }

    // 2. A corrupt result on a run the attacker claimed itself (a lease of 1 s: the honest
    // worker runs it once it expires): refused, naming the run and the worker.
    let mine: i64 = loop {
        if let Some(r) = a.query(claim, &[&a_id, &1.0f64]).unwrap().first() {
            break r.get(0);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    type Corrupt<'a> = (&'a str, Option<bool>, Option<f64>, Option<i64>, &'a str);
    let corrupt: [Corrupt; 5] = [
        ("done", Some(false), Some(0.1), None, "work is NULL"),
        (
            "done",
            Some(false),
            Some(0.1),
            Some(-5),
            "work = -5 is negative",
        ),
        (
            "done",
            Some(false),
            Some(f64::NAN),
            Some(1),
            "wall_seconds = NaN",
        ),
        ("done", None, Some(0.1), Some(1), "failure is NULL"),
        (
            "won",
            Some(true),
            Some(0.1),
            Some(1),
            "neither done nor failed",
        ),
    ];
    for (state, failure, wall, work, why) in corrupt {
        let r = a.query(
            finish_sql,
            &[
                &a_id,
                &mine,
                &"attacker",
                &"tok",
                &state,
                &failure,
                &wall,
                &work,
                &30.0f64,
            ],
        );
        let (code, message) = refusal(r, why);
        assert_eq!(code, "SV001", "{message}");
        assert!(
            message.contains(&format!("refused the result of run {mine} "))
                && message.contains("from worker attacker")
                && message.contains(why),
            "{message}"
        );
    }
    drop(a);

    // Neither campaign stopped: A ends with the local run's trials, and B resumes (the
    // attacker's advisory locks are gone with its session, but they never mattered).
    let o = coordinator_a.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    finish(honest, "worker_a");
    assert_eq!(db_trials(&mut admin, "a"), expected);
    let mut a = config.connect(postgres::NoTls).unwrap();
    assert!(a
        .query_one("SELECT pg_try_advisory_lock(29558, $1)", &[&b_id])
        .unwrap()
        .get::<_, bool>(0));
    let wb = worker(&server.url_for("worker_b", "pw", "attack"), "b", &[]);
    let o = Command::new(EXE)
        .args([
            "toy",
            "--storage",
            &url,
            "--campaign",
            "b",
            "--remote",
            "--resume",
        ])
        .args(["--quiet", "--out"])
        .arg(&out_b)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    finish(wb, "worker_b");
    assert_eq!(db_trials(&mut admin, "b"), expected);
    drop(a);
    for d in [local, out_a, out_b] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// A finished row the coordinator cannot use — written by hand, or before the server checked
/// results (a NULL or a negative work count in a work-unit campaign) — is queued again with a
/// message naming the run and the worker, and the campaign ends as the local run does (it used
/// to stop the campaign for good, or wrap the work count to 1.8e19).
#[test]
fn a_corrupt_result_row_is_queued_again_and_the_campaign_goes_on() {
    let Some(dist) = Distributed::set_up("corrupt", 20) else {
        return;
    };
    let (url, expected) = (dist.url.clone(), dist.expected.clone());
    let coordinator = dist.coordinator("x", Stdio::piped());
    let mut client = dist.client();
    let queued = "SELECT count(*) FROM savme.runs WHERE state = 'queued'";
    wait_until("runs to be queued", Duration::from_secs(60), || {
        query_i64(&mut client, queued) >= 2
    });
    let ids: Vec<i64> = client
        .query("SELECT id FROM savme.runs ORDER BY id LIMIT 2", &[])
        .unwrap()
        .iter()
        .map(|r| r.get(0))
        .collect();
    // As a table owner can still write them (the server's checks are in the workers' functions).
    for (id, work) in ids.iter().zip([None, Some(-5i64)]) {
        client
            .execute(
                "UPDATE savme.runs SET state = 'done', failure = false, wall_seconds = 0.1,
                        work = $2, worker = 'forger', finished_at = now() WHERE id = $1",
                &[id, &work],
            )
            .unwrap();
    }
    client.execute("NOTIFY savme_done_1", &[]).unwrap();
    let w = worker(&url, "x", &[]);
    let said = finish(coordinator, "the coordinator");
    finish(w, "the worker");
    for (id, why) in ids.iter().zip(["work is NULL", "work = -5 is negative"]) {
        assert!(
            said.contains(&format!("refused the result of run {id} "))
                && said.contains("from worker \"forger\"")
                && said.contains(why)
                && said.contains("queued again"),
            "{said}"
        );
    }
    assert_eq!(db_trials(&mut client, "x"), expected);
    dist.clean();
}

/// Standard error of `child`, line by line as it comes, with the time each line came.
fn timed_lines(child: &mut Child) -> std::sync::mpsc::Receiver<(std::time::Instant, String)> {
    let err = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufRead::lines(std::io::BufReader::new(err)).map_while(Result::ok) {
            if tx.send((std::time::Instant::now(), line)).is_err() {
                return;
            }
        }
    });
    rx
}

/// The first line of `lines` containing `needle` (within 30 s), and when it came.
fn first_line_with(
    lines: &std::sync::mpsc::Receiver<(std::time::Instant, String)>,
    needle: &str,
) -> (std::time::Instant, String) {
    loop {
        let (at, line) = lines
            .recv_timeout(Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("no line with {needle:?} in 30 s"));
        if line.contains(needle) {
            return (at, line);
        }
    }
}

/// A worker says within 2 s that its coordinator's heartbeat stopped (the coordinator stopped
/// with SIGSTOP: it still holds its lock), that it is back, and that it is gone (SIGKILL).
#[cfg(unix)]
#[test]
fn a_worker_says_within_2_s_that_its_coordinators_heartbeat_stopped() {
    let Some(dist) = Distributed::set_up("heartbeat", 100) else {
        return;
    };
    let mut w = worker(&dist.url, "h", &["--grace", "60"]);
    let lines = timed_lines(&mut w);
    let coordinator = dist.coordinator("h", Stdio::null());
    let mut client = dist.client();
    wait_until("trials to be stored", Duration::from_secs(60), || {
        query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= 2
    });
    send(&coordinator, "STOP");
    let stopped = std::time::Instant::now();
    let (at, line) = first_line_with(&lines, "no heartbeat from its coordinator");
    let said_after = at - stopped;
    eprintln!("stopped coordinator: said after {said_after:?}: {line}");
    assert!(said_after < Duration::from_millis(2500), "{said_after:?}");
    send(&coordinator, "CONT");
    first_line_with(&lines, "its coordinator is back");
    let mut coordinator = coordinator;
    coordinator.kill().unwrap(); // SIGKILL
    let killed = std::time::Instant::now();
    coordinator.wait().unwrap();
    let (at, line) = first_line_with(&lines, "has no coordinator running");
    let said_after = at - killed;
    eprintln!("killed coordinator: said after {said_after:?}: {line}");
    assert!(said_after < Duration::from_millis(2500), "{said_after:?}");
    let _ = w.kill();
    let _ = w.wait();
    dist.clean();
}

/// An immediate restart of the database (as a crash: what its write-ahead log had not written
/// is lost — workers commit without waiting for the disk) mid-campaign, three times: the
/// campaign ends with the local run's trials and no run is left `running` or `queued` — a run
/// whose finish was lost although the coordinator had read and told it is written back, and a
/// run whose holder did not come back is queued again.
#[test]
fn runs_orphaned_by_an_immediate_database_restart_are_reconciled() {
    let Some(mut server) = Server::start("crash") else {
        return;
    };
    let url = server.create_db("crash");
    let protocol = [
        "--iterations",
        "60",
        "--eval-iterations",
        "10",
        "--test-iterations",
        "30",
        "--baseline-iterations",
        "20",
        "--baseline-test-iterations",
        "10",
        "--cost",
        "work",
        "--seed",
        "5",
        "--quiet",
        "--sleep-ms",
        "20",
    ];
    let local = temp_dir("crash-local");
    let expected = local_trials(&local, &[&["toy"][..], &protocol[..]].concat());
    let out = temp_dir("crash-out");
    let w = worker(&url, "z", &["--jobs", "4", "--lease", "30"]);
    let coordinator = Command::new(EXE)
        .args([
            "toy",
            "--storage",
            &url,
            "--campaign",
            "z",
            "--remote",
            "--out",
        ])
        .arg(&out)
        .args(protocol)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    for at in [20, 60, 100] {
        {
            let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
            wait_until("trials to be stored", Duration::from_secs(120), || {
                query_i64(&mut client, "SELECT count(*) FROM savme.trials") >= at
            });
        }
        server.crash_and_restart();
    }
    let said = finish(coordinator, "the coordinator");
    finish(w, "the worker");
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    assert_eq!(db_trials(&mut client, "z"), expected);
    let open: Vec<String> = client
        .query(
            "SELECT format('run %s (%s, trial %s, %s): %s, %s attempts, seen %s, server started %s',
                           id, stage, trial_id, role, state, attempts, seen_at, pg_postmaster_start_time())
               FROM savme.runs WHERE state <> 'done' ORDER BY id",
            &[],
        )
        .unwrap()
        .iter()
        .map(|r| r.get(0))
        .collect();
    assert!(open.is_empty(), "runs left open: {open:#?}\n{said}");
    eprintln!("{said}");
    for d in [local, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// A database of schema version 3 (before the worker functions), with a worker role set up as
/// the former instructions said (`SELECT`/`UPDATE` on the tables, row-level security) and
/// listed for a campaign: a worker of this savme waits until a coordinator migrates it; the
/// role then works through the functions, has lost its table rights, and the campaign ends as
/// the local run does.
#[test]
fn a_schema_version_3_database_is_migrated_and_its_worker_role_keeps_working() {
    let Some(dist) = Distributed::set_up("migrate", 20) else {
        return;
    };
    let expected = dist.expected.clone();
    let mut admin = dist.client();
    savme::postgres::schema::migrate_to(&mut admin, 3).unwrap();
    admin
        .batch_execute(
            "CREATE ROLE old_worker LOGIN PASSWORD 'pw';
             GRANT CONNECT ON DATABASE migrate TO old_worker;
             GRANT USAGE ON SCHEMA savme TO old_worker;
             GRANT SELECT ON savme.campaigns, savme.campaign_workers TO old_worker;
             GRANT SELECT, UPDATE (state, worker, attempts, lease_until, started_at, failure,
                                   wall_seconds, work, error, finished_at, robustness)
                ON savme.runs TO old_worker;
             INSERT INTO savme.campaigns (name) VALUES ('m');
             INSERT INTO savme.campaign_workers VALUES (1, 'old_worker');",
        )
        .unwrap();
    let version = "SELECT max(version)::bigint FROM savme.schema_version";
    assert_eq!(query_i64(&mut admin, version), 3);
    let w = worker(
        &dist.server.url_for("old_worker", "pw", "migrate"),
        "m",
        &[],
    );
    std::thread::sleep(Duration::from_millis(500));
    let coordinator = dist.coordinator("m", Stdio::piped());
    finish(coordinator, "the coordinator");
    let said = finish(w, "the worker");
    assert!(said.contains("waiting for campaign \"m\""), "{said}");
    assert_eq!(db_trials(&mut admin, "m"), expected);
    assert_eq!(query_i64(&mut admin, version), 4);
    let rights = admin
        .query_one(
            "SELECT has_table_privilege('old_worker', 'savme.runs', 'SELECT'),
                    has_any_column_privilege('old_worker', 'savme.runs', 'UPDATE'),
                    has_table_privilege('old_worker', 'savme.campaigns', 'SELECT'),
                    has_function_privilege('old_worker', 'savme.claim(integer, text, text, double precision)', 'EXECUTE')",
            &[],
        )
        .unwrap();
    let rights: [bool; 4] = [rights.get(0), rights.get(1), rights.get(2), rights.get(3)];
    assert_eq!(rights, [false, false, false, true]);
    let ran = query_i64(
        &mut admin,
        "SELECT count(*) FROM savme.runs WHERE claimed_by = 'old_worker' AND state = 'done'",
    );
    let runs = expected.len() + expected.iter().filter(|t| !t["lf"].is_null()).count();
    assert_eq!(ran, runs as i64);
    dist.clean();
}
