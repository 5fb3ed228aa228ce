//! `savme serve`: the kernel behind a JSON-lines protocol on standard input and output, so that
//! a harness in any language (Python, MATLAB, C++, a shell script) can drive it.
//!
//! One request per line, one response per line, in order:
//!
//! | request | response |
//! |---|---|
//! | `{"op":"ask"}` or `{"op":"ask","n":4}` | `{"ok":true,"trials":[…]}` |
//! | `{"op":"tell","id":3,"observation":{"paired":{"hf":{"failure":true,"runtime":1.2},"lf":{"failure":true,"runtime":0.3}}}}` | `{"ok":true,"record":{…}}` |
//! | `{"op":"tell","id":4,"observation":{"hf_only":{"failure":false,"runtime":1.1}}}` | (baseline trials) |
//! | `{"op":"cancel","id":5}` | `{"ok":true,"trial":{…}}` |
//! | `{"op":"phase","phase":"evaluate"}` (train, evaluate, baseline, test) | `{"ok":true}` |
//! | `{"op":"estimate"}` or `{"op":"estimate","estimator":"mean"}` | `{"ok":true,"theta_lf":{…}}` |
//! | `{"op":"posterior"}` | `{"ok":true,"fidelity":{…},"scenarios":{…}}` |
//! | `{"op":"stats"}` | `{"ok":true,"stats":{…},"pending":[ids]}` |
//!
//! A bad request gets `{"ok":false,"error":"…"}` naming the input line, and changes nothing; the
//! server goes on. With a journal every change is logged before it is applied, and a restarted
//! server resumes from it.

use crate::campaign::store::journal::JournalSink;
use crate::campaign::store::StoreError;
use savme_kernel::journal::Journaled;
use savme_kernel::{Estimator, Kernel, Observation, Phase};
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::{BufRead, Write};

/// One request line.
#[derive(Debug, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
enum Request {
    Ask {
        #[serde(default = "one")]
        n: usize,
    },
    Tell {
        id: u64,
        observation: Observation,
    },
    Cancel {
        id: u64,
    },
    Phase {
        phase: Phase,
    },
    Estimate {
        #[serde(default)]
        estimator: Option<Estimator>,
    },
    Posterior,
    Stats,
}

fn one() -> usize {
    1
}

/// The most trials one ask request may hand out.
pub const MAX_BATCH: usize = 100_000;

/// A kernel, journaled or not, behind the protocol.
#[derive(Debug)]
pub enum Session {
    /// No journal: state lives in memory only.
    Plain(Kernel),
    /// Every change logged to the journal (a trial store) first.
    Journaled(Journaled<JournalSink>),
}

impl Session {
    fn kernel(&self) -> &Kernel {
        match self {
            Session::Plain(k) => k,
            Session::Journaled(j) => j.kernel(),
        }
    }

    /// Handles one request line; returns the response object.
    pub fn handle(&mut self, line: &str) -> Value {
        match serde_json::from_str::<Request>(line) {
            Err(e) => error(format!("not a request: {e}")),
            Ok(r) => self.apply(r).unwrap_or_else(error),
        }
    }

    fn apply(&mut self, request: Request) -> Result<Value, String> {
        let io = |e: StoreError| format!("journal: {e}");
        match request {
            Request::Ask { n } => {
                if n == 0 || n > MAX_BATCH {
                    return Err(format!("n must be between 1 and {MAX_BATCH}, got {n}"));
                }
                let mut trials = Vec::with_capacity(n);
                for _ in 0..n {
                    trials.push(match self {
                        Session::Plain(k) => k.ask(),
                        Session::Journaled(j) => j.ask().map_err(io)?,
                    });
                }
                Ok(json!({"ok": true, "trials": trials}))
            }
            Request::Tell { id, observation } => {
                let record = match self {
                    Session::Plain(k) => k.tell(id, observation).map_err(|e| e.to_string())?,
                    Session::Journaled(j) => j.tell(id, observation).map_err(|e| e.to_string())?,
                };
                Ok(json!({"ok": true, "record": record}))
            }
            Request::Cancel { id } => {
                let trial = match self {
                    Session::Plain(k) => k.cancel(id).map_err(|e| e.to_string())?,
                    Session::Journaled(j) => j.cancel(id).map_err(|e| e.to_string())?,
                };
                Ok(json!({"ok": true, "trial": trial}))
            }
            Request::Phase { phase } => {
                match self {
                    Session::Plain(k) => k.set_phase(phase),
                    Session::Journaled(j) => j.set_phase(phase).map_err(io)?,
                }
                Ok(json!({"ok": true}))
            }
            Request::Estimate { estimator } => {
                let k = self.kernel();
                let est = estimator.unwrap_or(k.config().estimator);
                Ok(json!({"ok": true, "theta_lf": k.fidelity_estimate(est)}))
            }
            Request::Posterior => {
                let k = self.kernel();
                let scenarios: serde_json::Map<String, Value> = k
                    .config()
                    .scenarios
                    .iter()
                    .map(|s| {
                        let p = k.scenario_posterior(&s.name);
                        (s.name.to_string(), json!(p))
                    })
                    .collect();
                Ok(json!({
                    "ok": true,
                    "fidelity": k.fidelity_posterior(),
                    "scenarios": scenarios,
                }))
            }
            Request::Stats => {
                let k = self.kernel();
                let pending: Vec<u64> = k.pending().map(|t| t.id).collect();
                Ok(json!({
                    "ok": true,
                    "stats": k.stats(),
                    "phase": k.phase(),
                    "pending": pending,
                }))
            }
        }
    }

    /// Serves requests from `input` until it ends, writing one response line each to `output`.
    /// Blank lines are skipped. Only an I/O error on `input` or `output` ends it early.
    pub fn serve<R: BufRead, O: Write>(&mut self, input: R, mut output: O) -> std::io::Result<()> {
        for (i, line) in input.lines().enumerate() {
            let line = line?;
            if line.trim().is_empty() {
                continue;
            }
            let mut response = self.handle(&line);
            if let Some(msg) = response.get("error").and_then(Value::as_str) {
                response["error"] = Value::String(format!("request line {}: {msg}", i + 1));
            }
            serde_json::to_writer(&mut output, &response)?;
            output.write_all(b"\n")?;
            output.flush()?;
        }
        Ok(())
    }
}

fn error(message: String) -> Value {
    json!({"ok": false, "error": message})
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session() -> Session {
        Session::Plain(crate::toy::kernel_builder().seed(3).build().unwrap())
    }

    fn run(s: &mut Session, input: &str) -> Vec<Value> {
        let mut out = Vec::new();
        s.serve(input.as_bytes(), &mut out).unwrap();
        String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    #[test]
    fn a_session_asks_tells_and_reports() {
        let mut s = session();
        let r = run(&mut s, "{\"op\":\"ask\",\"n\":2}\n");
        let trials = r[0]["trials"].as_array().unwrap();
        assert_eq!(trials.len(), 2);
        let id = trials[1]["id"].as_u64().unwrap();
        let tell = format!(
            "{{\"op\":\"tell\",\"id\":{id},\"observation\":{{\"paired\":{{\"hf\":{{\"failure\":true,\"runtime\":2.0}},\"lf\":{{\"failure\":true,\"runtime\":0.4}}}}}}}}\n\
             {{\"op\":\"stats\"}}\n{{\"op\":\"phase\",\"phase\":\"evaluate\"}}\n{{\"op\":\"estimate\",\"estimator\":\"mean\"}}\n{{\"op\":\"posterior\"}}\n"
        );
        let r = run(&mut s, &tell);
        assert_eq!(r[0]["record"]["outcome"], "TP");
        assert_eq!(r[0]["record"]["credit"]["fidelity"], true); // agreed, 0.4 / 2.0 ≤ 0.3
        assert_eq!(r[1]["stats"]["told"], 1);
        assert_eq!(r[1]["pending"], json!([0]));
        assert_eq!(r[2]["ok"], true);
        assert!(r[3]["theta_lf"]["rate_hz"].is_number());
        assert!(r[4]["scenarios"]["braking_lead"].is_object());
    }

    #[test]
    fn bad_requests_are_answered_with_the_line_and_change_nothing() {
        let mut s = session();
        let before = s.kernel().to_json();
        let input = "not json\n\n{\"op\":\"fly\"}\n{\"op\":\"ask\",\"n\":0}\n\
                     {\"op\":\"tell\",\"id\":9,\"observation\":{\"hf_only\":{\"failure\":true,\"runtime\":1}}}\n\
                     {\"op\":\"cancel\",\"id\":1}\n{\"op\":\"ask\",\"bogus\":1}\n";
        let r = run(&mut s, input);
        assert_eq!(r.len(), 6);
        for (resp, line) in r.iter().zip([1, 3, 4, 5, 6, 7]) {
            assert_eq!(resp["ok"], false);
            let msg = resp["error"].as_str().unwrap();
            assert!(msg.starts_with(&format!("request line {line}:")), "{msg}");
        }
        assert!(r[4]["error"].as_str().unwrap().contains("never asked"));
        assert_eq!(s.kernel().to_json(), before);
    }
}
