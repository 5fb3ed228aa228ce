//! The PostgreSQL trial store against a real server the test starts itself (see
//! `common/postgres.rs`): campaigns in the database give the same trials as in a directory,
//! resume after `kill -9`, refuse a second coordinator (another process), keep the protocol
//! in the database, and never show the password.
use crate::common;

use common::campaign::{db_trials, file_trials, text};
use common::postgres::{Server, PASSWORD};
use common::{temp_dir, EXE, TINY_PROTOCOL};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The tiny protocol of the CLI tests, on the bundled simulator with idealised perception.
const IDEAL: &[&str] = &["--perception", "ideal"];
const TINY_TRIALS: usize = 14 + 16 + 6 + 8 + 2 * 8;

fn savme(args: &[&str]) -> Output {
    Command::new(EXE).args(args).output().unwrap()
}

/// `savme reproduce` TINY_PROTOCOL + IDEAL (plus `extra`) into campaign `name` of `url`, results in `out`.
fn reproduce_in_db(url: &str, name: &str, out: &Path, extra: &[&str]) -> Output {
    Command::new(EXE)
        .args(["reproduce", "--storage", url, "--campaign", name, "--out"])
        .arg(out)
        .args(TINY_PROTOCOL)
        .args(IDEAL)
        .args(extra)
        .output()
        .unwrap()
}

fn count(client: &mut postgres::Client, name: &str) -> i64 {
    client
        .query_one(
            "SELECT count(*) FROM savme.trials t JOIN savme.campaigns c ON c.id = t.campaign_id WHERE c.name = $1",
            &[&name],
        )
        .map(|r| r.get(0))
        .unwrap_or(0)
}

#[test]
fn a_campaign_in_the_database_equals_the_directory_campaign_and_is_queryable() {
    let Some(server) = Server::start("same") else {
        return;
    };
    let url = server.create_db("same");
    let (dir, out) = (temp_dir("same-dir"), temp_dir("same-out"));
    let o = Command::new(EXE)
        .args(["reproduce", "--out"])
        .arg(&dir)
        .args(TINY_PROTOCOL)
        .args(IDEAL)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let o = reproduce_in_db(&url, "tiny", &out, &["--jobs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    assert_eq!(db_trials(&mut client, "tiny"), file_trials(&dir));
    // The results are the same; the protocol is in the database, not in the directory.
    let read = |d: &Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    assert_eq!(read(&dir, "table.md"), read(&out, "table.md"));
    assert!(!out.join("protocol.json").exists());
    assert!(!out.join("trials.jsonl").exists());
    let protocol: String = client
        .query_one(
            "SELECT protocol::text FROM savme.campaigns WHERE name = 'tiny'",
            &[],
        )
        .unwrap()
        .get(0);
    let protocol: Value = serde_json::from_str(&protocol).unwrap();
    let file: Value = serde_json::from_str(&read(&dir, "protocol.json")).unwrap();
    assert_eq!(protocol, file);
    // Every field of a trial line is a column.
    let row = client
        .query_one(
            "SELECT stage, idx, trial_id, phase, budget, scenario, phi->>'ego_speed', theta_lf IS NOT NULL,
                    hf_failure, hf_runtime, hf_work, lf_runtime, cost_ratio, outcome, credit_fidelity, v
               FROM savme.trials WHERE stage = 'train@0.3' AND idx = 0",
            &[],
        )
        .unwrap();
    let first = file_trials(&dir)
        .into_iter()
        .find(|t| t["stage"] == "train@0.3")
        .unwrap();
    assert_eq!(row.get::<_, String>(0), "train@0.3");
    assert_eq!(row.get::<_, i64>(1), 0);
    assert_eq!(row.get::<_, i64>(2), first["id"].as_i64().unwrap());
    assert_eq!(row.get::<_, String>(3), "train");
    assert_eq!(row.get::<_, f64>(4), 0.3);
    assert_eq!(row.get::<_, String>(5), first["scenario"].as_str().unwrap());
    assert!(row.get::<_, Option<String>>(6).is_some());
    assert!(row.get::<_, bool>(7));
    assert_eq!(
        row.get::<_, bool>(8),
        first["hf"]["failure"].as_bool().unwrap()
    );
    assert_eq!(
        row.get::<_, f64>(9),
        first["hf"]["runtime"].as_f64().unwrap()
    );
    assert_eq!(row.get::<_, i64>(10), first["hf"]["work"].as_i64().unwrap());
    assert_eq!(
        row.get::<_, f64>(11),
        first["lf"]["runtime"].as_f64().unwrap()
    );
    assert_eq!(row.get::<_, f64>(12), first["cost_ratio"].as_f64().unwrap());
    assert_eq!(row.get::<_, String>(13), first["outcome"].as_str().unwrap());
    assert_eq!(
        row.get::<_, Option<bool>>(14),
        first["credit"]["fidelity"].as_bool()
    );
    assert_eq!(row.get::<_, i32>(15), 1);
    // The schema version is recorded.
    let v: i32 = client
        .query_one("SELECT max(version) FROM savme.schema_version", &[])
        .unwrap()
        .get(0);
    assert_eq!(v, savme::postgres::schema::VERSION);

    // The three queries of docs/DISTRIBUTED.md give what the trial lines say.
    let trials = file_trials(&dir);
    let sql = |marker: &str| common::doc_sql(marker).replace("'night-1'", "'tiny'");
    let per_scenario = client
        .query(&sql("query: failures-per-scenario"), &[])
        .unwrap();
    let mut total = 0;
    for row in &per_scenario {
        let scenario: String = row.get(0);
        let of = |t: &&Value| t["scenario"] == scenario.as_str();
        assert_eq!(
            row.get::<_, i64>(1),
            trials.iter().filter(of).count() as i64
        );
        let failures = trials
            .iter()
            .filter(of)
            .filter(|t| t["hf"]["failure"] == true)
            .count();
        assert_eq!(row.get::<_, i64>(2), failures as i64);
        total += row.get::<_, i64>(1);
    }
    assert_eq!(total, TINY_TRIALS as i64);
    let theta = client.query(&sql("query: learned-theta"), &[]).unwrap();
    assert_eq!(theta.len(), 1, "one θ* for the one budget");
    assert_eq!(theta[0].get::<_, f64>(0), 0.3);
    assert_eq!(theta[0].get::<_, i64>(2), 6);
    let curve = client
        .query(&sql("query: failures-over-runtime"), &[])
        .unwrap();
    assert_eq!(curve.len(), TINY_TRIALS);
    let last = curve
        .iter()
        .filter(|r| r.get::<_, String>(0) == "train@0.3")
        .last()
        .unwrap();
    let train: Vec<&Value> = trials
        .iter()
        .filter(|t| t["stage"] == "train@0.3")
        .collect();
    let cost: f64 = train
        .iter()
        .map(|t| t["hf"]["runtime"].as_f64().unwrap() + t["lf"]["runtime"].as_f64().unwrap_or(0.0))
        .sum();
    assert_eq!(last.get::<_, f64>(2), cost);
    let found = train.iter().filter(|t| t["hf"]["failure"] == true).count();
    assert_eq!(last.get::<_, i64>(3), found as i64);

    // Starting it again is refused; resuming it runs nothing and writes the same results.
    let again = reproduce_in_db(&url, "tiny", &out, &[]);
    assert!(!again.status.success());
    assert!(
        text(&again).contains("already holds a campaign; resume it with --resume"),
        "{}",
        text(&again)
    );
    let o = savme(&[
        "reproduce",
        "--storage",
        &url,
        "--campaign",
        "tiny",
        "--resume",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains(&format!(
            "({TINY_TRIALS} replayed from the trial store, 0 run)"
        )),
        "{}",
        text(&o)
    );
    assert_eq!(read(&dir, "table.md"), read(&out, "table.md"));
    // Resuming a campaign that does not exist says so.
    let o = savme(&[
        "reproduce",
        "--storage",
        &url,
        "--campaign",
        "nope",
        "--resume",
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no campaign to resume"), "{}", text(&o));
    // `savme failures` lists the same failures from the database as from the directory, and
    // reads without the coordinator's lock (held here by this test's session).
    let id: i32 = client
        .query_one("SELECT id FROM savme.campaigns WHERE name = 'tiny'", &[])
        .unwrap()
        .get(0);
    // (The coordinator's lock: the campaign's row of savme.coordinators, naming this session.)
    let took: bool = client
        .query_one("SELECT savme.take_lock($1)", &[&id])
        .unwrap()
        .get(0);
    assert!(took);
    let list = |args: &[&str]| {
        let o = savme(args);
        assert!(o.status.success(), "{args:?}: {}", text(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let from_db = list(&[
        "failures",
        "--storage",
        &url,
        "--campaign",
        "tiny",
        "--json",
    ]);
    let from_dir = list(&["failures", dir.to_str().unwrap(), "--json"]);
    assert_eq!(from_db, from_dir);
    let hf_failures = file_trials(&dir)
        .iter()
        .filter(|t| t["hf"]["failure"] == true)
        .count();
    assert!(hf_failures > 0, "the tiny campaign found no failure");
    assert_eq!(from_db.lines().count(), hf_failures);
    let o = savme(&["failures", "--storage", &url, "--campaign", "never"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("campaign \"never\": no such campaign in this database"),
        "{}",
        text(&o)
    );
    let table = list(&["failures", "--storage", &url, "--campaign", "tiny"]);
    for shown in [&table, &from_db, &text(&o)] {
        assert!(
            !shown.contains(PASSWORD),
            "the password was printed: {shown}"
        );
    }
    // `savme estimate` reads a database's campaign through the same seam as a directory's
    // (also without the lock): the same runs, the same estimate. It needs --out (the
    // campaign has no directory of its own).
    let o = savme(&["estimate", "--storage", &url, "--campaign", "tiny"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains(
            "has no directory of its own: give the estimate an output directory (--out DIR)"
        ),
        "{}",
        text(&o)
    );
    let (est_db, est_dir) = (temp_dir("estimate-db"), temp_dir("estimate-dir"));
    let estimate = ["--max-runs", "12", "--no-target", "--quiet", "--jobs", "2"];
    let (from_db, from_dir) = (
        [
            &[
                "estimate",
                "--storage",
                &url,
                "--campaign",
                "tiny",
                "--out",
                est_db.to_str().unwrap(),
            ][..],
            &estimate,
        ]
        .concat(),
        [
            &[
                "estimate",
                dir.to_str().unwrap(),
                "--out",
                est_dir.to_str().unwrap(),
            ][..],
            &estimate,
        ]
        .concat(),
    );
    let (a, b) = (list(&from_db), list(&from_dir));
    assert!(!a.contains(PASSWORD), "the password was printed: {a}");
    assert!(!b.is_empty());
    assert_eq!(file_trials(&est_db).len(), 12);
    assert_eq!(file_trials(&est_db), file_trials(&est_dir));
    let summary = |d: &std::path::Path| -> Value {
        serde_json::from_str::<Value>(&read(d, "summary.json")).unwrap()["estimate"].clone()
    };
    assert_eq!(summary(&est_db), summary(&est_dir));
    // A database savme never used: no such campaign, and listing creates nothing there.
    let empty = server.create_db("empty");
    let o = savme(&["failures", "--storage", &empty, "--campaign", "tiny"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("no such campaign in this database"),
        "{}",
        text(&o)
    );
    let mut e = postgres::Client::connect(&empty, postgres::NoTls).unwrap();
    let untouched: bool = e
        .query_one("SELECT to_regclass('savme.campaigns') IS NULL", &[])
        .unwrap()
        .get(0);
    assert!(untouched, "savme failures created savme's schema");
    // (The refused resume above left campaign `nope` a row without a protocol.)
    let o = savme(&["failures", "--storage", &url, "--campaign", "nope"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("campaign \"nope\": no protocol stored yet"),
        "{}",
        text(&o)
    );
    for d in [dir, out, est_db, est_dir] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_killed_coordinator_resumes_from_the_database_and_a_second_one_is_refused() {
    let Some(server) = Server::start("resume") else {
        return;
    };
    let url = server.create_db("resume");
    let (full, out) = (temp_dir("resume-full"), temp_dir("resume-out"));
    // The toy simulator sleeping 20 ms a run: slow enough to kill the coordinator midway and
    // to try a second one while it runs (120 trials, one run at a time: over 3 s).
    let longer: Vec<String> = [
        "--sleep-ms",
        "20",
        "--iterations",
        "50",
        "--eval-iterations",
        "10",
        "--test-iterations",
        "15",
        "--baseline-iterations",
        "20",
        "--baseline-test-iterations",
        "10",
        "--cost",
        "work",
        "--seed",
        "7",
        "--quiet",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let o = Command::new(EXE)
        .args(["toy", "--out"])
        .arg(&full)
        .args(&longer)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let expected = file_trials(&full);

    let mut first = Command::new(EXE)
        .args(["toy", "--storage", &url, "--campaign", "c", "--out"])
        .arg(&out)
        .args(&longer)
        .args(["--jobs", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let start = Instant::now();
    while count(&mut client, "c") < 20 {
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        assert!(first.try_wait().unwrap().is_none(), "finished too soon");
        std::thread::sleep(Duration::from_millis(5));
    }
    // A second coordinator (a resume, and a new campaign of the same name) is refused at once,
    // naming the first one's process, and changes nothing.
    let before = count(&mut client, "c");
    for resume in [true, false] {
        let mut args = vec!["toy", "--storage", &url, "--campaign", "c"];
        if resume {
            args.extend(["--resume", "--quiet"]);
        } else {
            args.extend(longer.iter().map(String::as_str));
        }
        let o = savme(&args);
        let t = text(&o);
        assert!(
            !o.status.success(),
            "first exited: {:?}; {t}",
            first.try_wait()
        );
        assert!(
            t.contains("is in use by another savme coordinator")
                && t.contains(&format!("savme coordinator pid {}", first.id())),
            "{t}"
        );
    }
    assert!(count(&mut client, "c") >= before);
    first.kill().unwrap(); // SIGKILL
    first.wait().unwrap();
    let stored = count(&mut client, "c") as usize;
    assert!(stored < expected.len(), "finished before the kill");
    // The server drops the dead session's lock: the campaign resumes and completes — from the
    // database alone (its protocol is the store's), into a new output directory.
    let _ = std::fs::remove_dir_all(&out);
    let o = savme(&[
        "toy",
        "--storage",
        &url,
        "--campaign",
        "c",
        "--resume",
        "--quiet",
        "--jobs",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains(&format!("({stored} replayed from the trial store")),
        "{}",
        text(&o)
    );
    assert_eq!(db_trials(&mut client, "c"), expected);
    for d in [full, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn the_password_never_appears_in_output_errors_or_stored_data() {
    let Some(server) = Server::start("secret") else {
        return;
    };
    let url = server.create_db("secret");
    assert!(url.contains(PASSWORD));
    let out = temp_dir("secret-out");
    let o = reproduce_in_db(&url, "s", &out, &["--jobs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let mut everything = text(&o);
    // A refused second coordinator, a wrong password, and a host that does not exist.
    let mut locked = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let id: i32 = locked
        .query_one("SELECT id FROM savme.campaigns WHERE name = 's'", &[])
        .unwrap()
        .get(0);
    let took: bool = locked
        .query_one("SELECT savme.take_lock($1)", &[&id])
        .unwrap()
        .get(0);
    assert!(took);
    let o = savme(&[
        "reproduce",
        "--storage",
        &url,
        "--campaign",
        "s",
        "--resume",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("a session not started by savme"),
        "{}",
        text(&o)
    );
    everything += &text(&o);
    let wrong = url.replace(PASSWORD, &format!("{PASSWORD}-wrong"));
    let o = savme(&[
        "reproduce",
        "--storage",
        &wrong,
        "--campaign",
        "s",
        "--resume",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("password authentication failed"),
        "{}",
        text(&o)
    );
    everything += &text(&o);
    let bad_host =
        format!("postgresql://savme:{PASSWORD}@no-such-host.invalid:5432/x?connect_timeout=2");
    let o = Command::new(EXE)
        .args(["reproduce", "--storage", &bad_host, "--campaign", "s"])
        .env("SAVME_RECONNECT_SECONDS", "1")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        text(&o).contains("postgresql://savme@no-such-host.invalid:5432/x"),
        "{}",
        text(&o)
    );
    everything += &text(&o);
    // The URL read from a file (--storage-file) works the same and is not shown either.
    let file = out.join("storage-url");
    std::fs::write(&file, format!("# the campaign database\n{url}\n")).unwrap();
    let o = savme(&[
        "reproduce",
        "--storage-file",
        file.to_str().unwrap(),
        "--campaign",
        "s",
        "--resume",
    ]);
    assert!(!o.status.success());
    everything += &text(&o);
    drop(locked);
    let o = savme(&[
        "reproduce",
        "--storage-file",
        file.to_str().unwrap(),
        "--campaign",
        "s",
        "--resume",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    everything += &text(&o);
    assert!(!everything.contains(PASSWORD), "{everything}");
    assert!(
        everything.contains("postgresql://savme@127.0.0.1:"),
        "{everything}"
    );
    // Nothing the campaign wrote holds it: the database's tables, nor the output files.
    let mut client = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let dump: String = client
        .query_one(
            "SELECT (SELECT string_agg(body::text, '') FROM savme.trials)
                 || (SELECT string_agg(protocol::text, '') FROM savme.campaigns)",
            &[],
        )
        .unwrap()
        .get(0);
    assert!(!dump.is_empty() && !dump.contains(PASSWORD));
    for f in std::fs::read_dir(&out).unwrap().flatten() {
        if f.path() == file {
            continue;
        }
        let bytes = std::fs::read(f.path()).unwrap();
        let needle = PASSWORD.as_bytes();
        assert!(
            !bytes.windows(needle.len()).any(|w| w == needle),
            "{}",
            f.path().display()
        );
    }
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn storage_flags_are_checked() {
    for (args, message) in [
        (
            vec!["reproduce", "--campaign", "x"],
            "--campaign names a campaign in a database",
        ),
        (
            vec!["reproduce", "--storage", "postgresql://u@h/d"],
            "--storage needs --campaign NAME",
        ),
        (
            vec![
                "reproduce",
                "--storage",
                "postgresql://u:pw@h:notaport/d",
                "--campaign",
                "x",
            ],
            "not a PostgreSQL connection URL",
        ),
        (
            vec!["reproduce", "--resume"],
            "--resume needs the campaign's directory",
        ),
        (
            vec![
                "reproduce",
                "--storage-file",
                "/nonexistent/savme-url",
                "--campaign",
                "x",
            ],
            "/nonexistent/savme-url",
        ),
        (
            vec![
                "reproduce",
                "--storage",
                "postgresql://u@h/d",
                "--campaign",
                "",
            ],
            "is not a campaign name",
        ),
    ] {
        let o = savme(&args);
        assert!(!o.status.success(), "{args:?}");
        assert!(text(&o).contains(message), "{args:?}: {}", text(&o));
        assert!(!text(&o).contains("pw@"), "{}", text(&o));
    }
    // Misused flags are usage errors (exit status 2, like clap's own).
    let url = "postgresql://u@h/d";
    for (args, message) in [
        (
            vec!["toy", "--remote"],
            "--remote runs trials through a database's work queue",
        ),
        (vec!["worker"], "savme worker needs --storage URL"),
        (
            vec!["toy", "--resume"],
            "--resume needs the campaign's directory",
        ),
        (
            vec!["worker", "--storage", url, "--campaign", "x", "--jobs", "0"],
            "'0' for '--jobs <JOBS>': must be at least 1",
        ),
        (
            vec![
                "worker",
                "--storage",
                url,
                "--campaign",
                "x",
                "--lease",
                "0",
            ],
            "--lease: 0 is not a positive number of seconds",
        ),
        // A lease has an upper bound (issue 41): the server refuses a longer one too.
        (
            vec![
                "worker",
                "--storage",
                url,
                "--campaign",
                "x",
                "--lease",
                "3601",
            ],
            "--lease: 3601 s is longer than a worker may hold a run (3600 s",
        ),
        // Refused values (issue 28): a worker checks a campaign name by the coordinator's
        // rule, with its message, at once; an unknown URL option; verify-full without a root
        // certificate.
        (
            vec!["worker", "--storage", url, "--campaign", ""],
            "\"\" is not a campaign name (1 to 200 characters, no control characters)",
        ),
        (
            vec!["toy", "--storage", url, "--campaign", ""],
            "\"\" is not a campaign name (1 to 200 characters, no control characters)",
        ),
        (
            vec![
                "worker",
                "--storage",
                "postgresql://u@h/d?bogus=1",
                "--campaign",
                "x",
            ],
            "not a PostgreSQL connection URL",
        ),
        (
            vec![
                "worker",
                "--storage",
                "postgresql://u@h/d?sslmode=verify-full",
                "--campaign",
                "x",
            ],
            "sslmode=verify-full needs the root certificate",
        ),
    ] {
        let start = std::time::Instant::now();
        let o = Command::new(EXE)
            .args(&args)
            .env("HOME", "/nonexistent")
            .env_remove("PGSSLROOTCERT")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(message), "{args:?}: {}", text(&o));
        assert!(
            start.elapsed() < std::time::Duration::from_secs(10),
            "{args:?}"
        );
    }
}

#[test]
fn a_world_readable_pgpass_is_ignored_with_a_warning_as_libpq_does() {
    use std::os::unix::fs::PermissionsExt;
    let Some(server) = Server::start("pgpass") else {
        return;
    };
    let dir = temp_dir("pgpass");
    std::fs::create_dir_all(&dir).unwrap();
    let pgpass = dir.join("pgpass");
    std::fs::write(&pgpass, format!("127.0.0.1:*:*:savme:{PASSWORD}\n")).unwrap();
    let url = format!("postgresql://savme@127.0.0.1:{}/postgres", server.port());
    let failures = |mode: u32| {
        std::fs::set_permissions(&pgpass, std::fs::Permissions::from_mode(mode)).unwrap();
        Command::new(EXE)
            .args(["failures", "--storage", &url, "--campaign", "none"])
            .env("PGPASSFILE", &pgpass)
            .env_remove("PGPASSWORD")
            .env("SAVME_RECONNECT_SECONDS", "0")
            .output()
            .unwrap()
    };
    // Private: the password is used (the campaign does not exist, but savme got in).
    let o = failures(0o600);
    assert!(
        text(&o).contains("no such campaign in this database"),
        "{}",
        text(&o)
    );
    assert!(!text(&o).contains("WARNING"), "{}", text(&o));
    // Readable by others: ignored, with libpq's warning, so the login fails.
    let o = failures(0o644);
    let t = text(&o);
    assert!(
        t.contains("WARNING: password file")
            && t.contains("has group or world access (mode 644)")
            && t.contains("chmod 600"),
        "{t}"
    );
    assert!(!t.contains("no such campaign"), "{t}");
    assert!(!t.contains(PASSWORD), "{t}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn savme_serve_journals_into_the_database_and_resumes_after_kill() {
    use std::io::{BufRead, BufReader, Write};
    let Some(server) = Server::start("serve") else {
        return;
    };
    let url = server.create_db("serve");
    let dir = temp_dir("serve");
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("kernel.json");
    std::fs::write(&config, savme(&["example-config"]).stdout).unwrap();
    let start = |extra: &[&str]| {
        let mut child = Command::new(EXE)
            .args(["serve", "--storage", &url, "--campaign", "served"])
            .args(extra)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        (child, stdin, stdout)
    };
    let call = |io: &mut (
        std::process::ChildStdin,
        BufReader<std::process::ChildStdout>,
    ),
                request: Value| {
        writeln!(io.0, "{request}").unwrap();
        io.0.flush().unwrap();
        let mut line = String::new();
        io.1.read_line(&mut line).unwrap();
        serde_json::from_str::<Value>(&line).unwrap()
    };
    let (mut first, stdin, stdout) = start(&["--config", config.to_str().unwrap()]);
    let mut io = (stdin, stdout);
    for _ in 0..5 {
        let t = call(&mut io, serde_json::json!({"op": "ask"}))["trials"][0].clone();
        let run = |failure: bool, runtime: f64| serde_json::json!({"failure": failure, "runtime": runtime});
        let obs = serde_json::json!({"paired": {"hf": run(true, 1.0), "lf": run(false, 0.25)}});
        let r = call(
            &mut io,
            serde_json::json!({"op": "tell", "id": t["id"], "observation": obs}),
        );
        assert_eq!(r["ok"], true, "{r}");
    }
    let pending = call(&mut io, serde_json::json!({"op": "ask"}))["trials"][0]["id"].clone();
    let stats = call(&mut io, serde_json::json!({"op": "stats"}));
    assert_eq!(stats["stats"]["told"], 5, "{stats}");
    assert_eq!(stats["pending"], serde_json::json!([pending]));
    first.kill().unwrap();
    first.wait().unwrap();
    let (second, stdin, stdout) = start(&[]);
    let mut io = (stdin, stdout);
    let again = call(&mut io, serde_json::json!({"op": "stats"}));
    assert_eq!(again, stats);
    drop(io);
    let out = second.wait_with_output().unwrap();
    assert!(out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("resumed postgresql://savme@127.0.0.1:"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// Runs `openssl` with `args` in `dir`.
fn openssl(dir: &Path, args: &[&str]) {
    let o = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "openssl {args:?}: {}", text(&o));
}

/// A test CA (`ca.crt`), a server certificate it signs for `localhost` only (`server.crt`,
/// `server.key`) and an unrelated CA (`other-ca.crt`), made in `dir` with the openssl CLI;
/// `None` (after a loud message) without openssl, unless `SAVME_REQUIRE_POSTGRES=1`.
fn certificates(dir: &Path) -> Option<()> {
    if Command::new("openssl").arg("version").output().is_err() {
        let message = "no openssl command to make the test certificates";
        if std::env::var("SAVME_REQUIRE_POSTGRES").as_deref() == Ok("1") {
            panic!("{message}, and SAVME_REQUIRE_POSTGRES=1");
        }
        eprintln!("\n!!!!!!!!!! SKIPPED the TLS test: {message} (Debian: apt-get install openssl) !!!!!!!!!!\n");
        return None;
    }
    std::fs::create_dir_all(dir).unwrap();
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:prime256v1",
        "-nodes",
    ];
    for ca in ["ca", "other-ca"] {
        let (key, crt, subj) = (
            format!("{ca}.key"),
            format!("{ca}.crt"),
            format!("/CN=savme test {ca}"),
        );
        let mut args = vec!["req", "-x509", "-days", "3", "-subj", &subj];
        args.extend(ec);
        args.extend(["-keyout", &key, "-out", &crt]);
        openssl(dir, &args);
    }
    let mut args = vec!["req", "-new", "-subj", "/CN=localhost"];
    args.extend(ec);
    args.extend(["-keyout", "server.key", "-out", "server.csr"]);
    openssl(dir, &args);
    std::fs::write(
        dir.join("server.ext"),
        "subjectAltName=DNS:localhost\nbasicConstraints=CA:FALSE\nextendedKeyUsage=serverAuth\n",
    )
    .unwrap();
    openssl(
        dir,
        &[
            "x509",
            "-req",
            "-in",
            "server.csr",
            "-CA",
            "ca.crt",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-days",
            "3",
            "-extfile",
            "server.ext",
            "-out",
            "server.crt",
        ],
    );
    Some(())
}

#[test]
fn sslmode_is_honoured_and_the_server_certificate_checked() {
    let certs = temp_dir("tls-certs");
    if certificates(&certs).is_none() {
        return;
    }
    let Some(server) =
        Server::start_tls("tls", &certs.join("server.crt"), &certs.join("server.key"))
    else {
        return;
    };
    let url = server.create_db("tls");
    let root = |ca: &str| certs.join(format!("{ca}.crt")).display().to_string();
    let at_localhost = url.replace("@127.0.0.1:", "@localhost:");
    let with = |base: &str, query: &str| format!("{base}?{query}");
    // This server takes TCP connections over TLS only: without TLS it refuses.
    let connect = |u: &str| {
        let db = savme::postgres::Database::parse(u).map_err(|e| e.to_string())?;
        let mut c = db
            .connect_for("tls test", Duration::from_secs(5))
            .map_err(|e| e.to_string())?;
        let ssl: bool = c
            .query_one(
                "SELECT ssl FROM pg_stat_ssl WHERE pid = pg_backend_pid()",
                &[],
            )
            .map_err(|e| e.to_string())?
            .get(0);
        Ok::<bool, String>(ssl)
    };
    let e = connect(&with(&url, "sslmode=disable")).unwrap_err();
    assert!(e.contains("no encryption"), "{e}");
    // prefer (the default) and require encrypt without checking the certificate; verify-ca
    // checks it is signed by the CA; verify-full also that it names the host (localhost).
    for ok in [
        url.clone(),
        with(&url, "sslmode=require"),
        with(
            &url,
            &format!("sslmode=verify-ca&sslrootcert={}", root("ca")),
        ),
        with(
            &at_localhost,
            &format!("sslmode=verify-full&sslrootcert={}", root("ca")),
        ),
    ] {
        assert_eq!(connect(&ok), Ok(true), "{ok}");
    }
    // A campaign over TLS: the coordinator with sslmode=require, its worker with verify-full.
    let out = temp_dir("tls-out");
    let w = common::campaign::worker(
        &with(
            &at_localhost,
            &format!("sslmode=verify-full&sslrootcert={}", root("ca")),
        ),
        "t",
        &[],
    );
    let o = reproduce_in_db(&with(&url, "sslmode=require"), "t", &out, &["--remote"]);
    assert!(o.status.success(), "{}", text(&o));
    let said = common::campaign::finish(w, "the TLS worker");
    let mut everything = text(&o) + &said;
    let mut client = server.client_of("tls");
    assert_eq!(db_trials(&mut client, "t").len(), TINY_TRIALS);
    // A certificate that does not verify is a clear error at once (not retried), naming the
    // mode and the root certificates — and never the password.
    let refused = |u: &str, needles: &[&str]| {
        let start = Instant::now();
        let o = Command::new(EXE)
            .args(["worker", "--storage", u, "--campaign", "t", "--wait", "1"])
            .output()
            .unwrap();
        assert!(!o.status.success());
        assert!(start.elapsed() < Duration::from_secs(20), "retried");
        let t = text(&o);
        for n in needles {
            assert!(t.contains(n), "{n:?} not in {t}");
        }
        t
    };
    everything += &refused(
        &with(
            &at_localhost,
            &format!("sslmode=verify-full&sslrootcert={}", root("other-ca")),
        ),
        &[
            "invalid peer certificate",
            "UnknownIssuer",
            "sslmode=verify-full",
            &root("other-ca"),
        ],
    );
    everything += &refused(
        &with(
            &url,
            &format!("sslmode=verify-full&sslrootcert={}", root("ca")),
        ),
        &[
            "invalid peer certificate",
            "not valid for name",
            "sslmode=verify-full",
        ],
    );
    let home = temp_dir("tls-home");
    std::fs::create_dir_all(&home).unwrap();
    let o = Command::new(EXE)
        .args([
            "worker",
            "--storage",
            &with(&url, "sslmode=verify-ca"),
            "--campaign",
            "t",
        ])
        .env("HOME", &home)
        .env_remove("PGSSLROOTCERT")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        text(&o).contains("sslmode=verify-ca needs the root certificate"),
        "{}",
        text(&o)
    );
    everything += &text(&o);
    assert!(!everything.contains(PASSWORD), "{everything}");
    for d in [certs, out, home] {
        let _ = std::fs::remove_dir_all(d);
    }
}
