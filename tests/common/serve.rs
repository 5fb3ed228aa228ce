//! `savme serve` driven as a harness in another language drives it (`tests/it/serve.rs`): a child
//! process speaking JSON lines, its configuration, and trials asked and told.

use super::EXE;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// `savme example-config` written to `dir/kernel.json`.
pub fn write_config(dir: &Path) -> PathBuf {
    let out = Command::new(EXE).arg("example-config").output().unwrap();
    assert!(out.status.success());
    let path = dir.join("kernel.json");
    std::fs::write(&path, out.stdout).unwrap();
    path
}

/// A running `savme serve`.
pub struct Server {
    /// The process.
    pub child: Child,
    /// Its standard input (dropped: end of requests).
    pub stdin: ChildStdin,
    /// Its standard output, read a line per answer.
    pub stdout: BufReader<ChildStdout>,
}

impl Server {
    /// `savme serve ARGS`, its standard error discarded.
    pub fn start(args: &[&str]) -> Server {
        Server::start_with(args, Stdio::null())
    }

    /// `savme serve ARGS`, its standard error to `stderr`.
    pub fn start_with(args: &[&str], stderr: Stdio) -> Server {
        let mut child = Command::new(EXE)
            .arg("serve")
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        Server {
            child,
            stdin,
            stdout,
        }
    }

    /// Sends `request`; its answer.
    pub fn call(&mut self, request: Value) -> Value {
        writeln!(self.stdin, "{request}").unwrap();
        self.stdin.flush().unwrap();
        let mut line = String::new();
        self.stdout.read_line(&mut line).unwrap();
        serde_json::from_str(&line).unwrap()
    }
}

/// A paired observation of `trial` (fails above an ego speed of 28 m/s for HF, 27 for LF).
pub fn observation(trial: &Value) -> Value {
    let speed = trial["phi"]["ego_speed"].as_f64().unwrap();
    let hf = json!({"failure": speed > 28.0, "runtime": 1.0});
    let lf = json!({"failure": speed > 27.0, "runtime": 0.25});
    json!({"paired": {"hf": hf, "lf": lf}})
}

/// Asks and tells `n` trials; returns the trials.
pub fn drive(s: &mut Server, n: usize) -> Vec<Value> {
    (0..n)
        .map(|_| {
            let t = s.call(json!({"op": "ask"}))["trials"][0].clone();
            let r = s.call(json!({"op": "tell", "id": t["id"], "observation": observation(&t)}));
            assert_eq!(r["ok"], true, "{r}");
            t
        })
        .collect()
}

impl Server {
    /// The reference: a server with `config` journaling into `journal`, `n` trials asked and
    /// told without a stop, then its input closed (it must exit successfully); the trials.
    pub fn uninterrupted(config: &str, journal: &Path, n: usize) -> Vec<Value> {
        let j = journal.to_str().unwrap();
        let mut whole = Server::start(&["--config", config, "--journal", j]);
        let reference = drive(&mut whole, n);
        drop(whole.stdin);
        assert!(whole.child.wait().unwrap().success());
        reference
    }
}
