//! FMU evaluations in a worker child process: an FMU that crashes (segfault, abort) or hangs
//! costs one trial — reported as that trial's error — not the campaign.
//!
//! The parent ([`IsolatedSimulator`]) starts the worker (the `savme` binary itself, as
//! `savme fmu-worker`) and talks JSON lines over its stdin/stdout: first a [`WorkerInit`], then
//! one [`WorkerRequest`] per run, each answered by one [`WorkerResponse`]. A run that does not
//! answer within the timeout gets its worker killed; a worker that dies is restarted for the
//! next run.

use crate::{FmuError, FmuFile, FmuSimulator, RunSpec, Trace};
use crossbeam_channel::{Receiver, RecvTimeoutError};
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator, Space};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Arc;
use std::time::Duration;

/// What a worker needs to build its simulator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkerInit {
    /// The HF FMU.
    pub hf: PathBuf,
    /// The LF FMU.
    pub lf: PathBuf,
    /// How runs execute.
    pub spec: RunSpec,
    /// The fidelity space (for type checks and label positions).
    pub fidelity: Option<Space>,
    /// The scenario spaces.
    pub phi: BTreeMap<String, Space>,
}

impl WorkerInit {
    /// Opens both FMUs (once when they are the same file).
    pub fn open(&self) -> Result<(Arc<FmuFile>, Arc<FmuFile>), FmuError> {
        self.open_telling(&mut |_| {})
    }

    /// [`WorkerInit::open`], calling `loading` with each FMU's path before its library is
    /// loaded (a worker tells its parent, so that a crash while loading names the FMU).
    fn open_telling(
        &self,
        loading: &mut dyn FnMut(&Path),
    ) -> Result<(Arc<FmuFile>, Arc<FmuFile>), FmuError> {
        loading(&self.hf);
        let hf = Arc::new(FmuFile::open(&self.hf)?);
        let lf = if self.lf == self.hf {
            hf.clone()
        } else {
            loading(&self.lf);
            Arc::new(FmuFile::open(&self.lf)?)
        };
        Ok((hf, lf))
    }

    /// Opens both FMUs and builds the in-process simulator.
    pub fn simulator(&self) -> Result<FmuSimulator, FmuError> {
        self.simulator_telling(&mut |_| {})
    }

    fn simulator_telling(&self, loading: &mut dyn FnMut(&Path)) -> Result<FmuSimulator, FmuError> {
        let (hf, lf) = self.open_telling(loading)?;
        FmuSimulator::new(hf, lf, self.spec.clone(), self.fidelity.as_ref(), &|name| {
            self.phi.get(name).cloned()
        })
    }
}

/// One run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkerRequest {
    /// HF or LF.
    pub role: Role,
    /// Scenario.
    pub scenario: String,
    /// φ.
    pub phi: Assignment,
    /// θ.
    pub fidelity: Assignment,
    /// Outputs to record at every communication point (none: no trace in the answer).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub record: Vec<String>,
}

/// The answer to a request (or to the init line: `Ready`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WorkerResponse {
    /// The worker is about to load this FMU's library (a crash before the next answer is a
    /// crash while loading it).
    Loading(String),
    /// The simulator is built.
    Ready,
    /// A run's result.
    Done {
        /// Failure.
        failure: bool,
        /// Wall-clock seconds measured in the worker.
        wall_seconds: f64,
        /// Work units.
        work: Option<u64>,
        /// The run's robustness (a threshold failure signal's smallest margin, or the smallest
        /// value of a Boolean signal's `robustness` output).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        robustness: Option<f64>,
        /// The recorded outputs, when the request asked for some.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        trace: Option<Trace>,
    },
    /// The run (or the set-up) failed.
    Error(String),
}

/// Serves the worker protocol on `input`/`output` until `input` closes: what `savme fmu-worker`
/// runs.
pub fn serve(input: impl BufRead, mut output: impl Write) -> std::io::Result<()> {
    let mut lines = input.lines();
    let say = |r: &WorkerResponse, out: &mut dyn Write| -> std::io::Result<()> {
        let text = serde_json::to_string(r).unwrap_or_else(|e| {
            serde_json::to_string(&WorkerResponse::Error(e.to_string())).unwrap_or_default()
        });
        writeln!(out, "{text}")?;
        out.flush()
    };
    let Some(first) = lines.next() else {
        return Ok(());
    };
    let mut sim = match serde_json::from_str::<WorkerInit>(&first?) {
        Err(e) => {
            return say(
                &WorkerResponse::Error(format!("worker init: {e}")),
                &mut output,
            )
        }
        Ok(init) => {
            let mut told: std::io::Result<()> = Ok(());
            let built = init.simulator_telling(&mut |path| {
                if told.is_ok() {
                    let loading = WorkerResponse::Loading(path.display().to_string());
                    told = say(&loading, &mut output);
                }
            });
            told?;
            match built {
                Ok(s) => s,
                Err(e) => return say(&WorkerResponse::Error(e.to_string()), &mut output),
            }
        }
    };
    say(&WorkerResponse::Ready, &mut output)?;
    for line in lines {
        let line = line?;
        let response = match serde_json::from_str::<WorkerRequest>(&line) {
            Err(e) => WorkerResponse::Error(format!("worker request: {e}")),
            Ok(r) => {
                let role = r.role;
                let run = if r.record.is_empty() {
                    sim.run(role, &r.scenario, &r.phi, &r.fidelity)
                        .map(|res| (res, None))
                } else {
                    sim.run_traced(role, &r.scenario, &r.phi, &r.fidelity, &r.record)
                        .map(|(res, trace)| (res, Some(trace)))
                };
                match run {
                    Ok((res, trace)) => WorkerResponse::Done {
                        failure: res.failure,
                        wall_seconds: res.wall_seconds,
                        work: res.work,
                        robustness: res.robustness,
                        trace,
                    },
                    Err(e) => WorkerResponse::Error(e.to_string()),
                }
            }
        };
        say(&response, &mut output)?;
    }
    Ok(())
}

struct Worker {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<std::io::Result<String>>,
}

impl Worker {
    /// Kills the worker and removes the FMUs it unpacked (a killed or crashed process leaves
    /// them behind): how it ended.
    fn kill(mut self) -> String {
        let _ = self.child.kill();
        let status = match self.child.wait() {
            Ok(status) => describe(status),
            Err(e) => e.to_string(),
        };
        crate::file::remove_unpacked_of(self.child.id());
        status
    }
}

pub(crate) fn describe(status: std::process::ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            let name = match sig {
                6 => " (SIGABRT: the FMU aborted)",
                7 => " (SIGBUS: the FMU crashed)",
                9 => " (SIGKILL)",
                11 => " (SIGSEGV: the FMU crashed)",
                _ => "",
            };
            return format!("killed by signal {sig}{name}");
        }
    }
    status.to_string()
}

/// A simulator whose runs execute in a worker process: `command` (e.g. `["savme",
/// "fmu-worker"]`) started with `init`, each run allowed `timeout`.
pub struct IsolatedSimulator {
    command: Arc<Vec<String>>,
    init: Arc<String>,
    fmu: Arc<String>,
    timeout: Duration,
    worker: Option<Worker>,
}

impl Clone for IsolatedSimulator {
    fn clone(&self) -> Self {
        IsolatedSimulator {
            command: self.command.clone(),
            init: self.init.clone(),
            fmu: self.fmu.clone(),
            timeout: self.timeout,
            worker: None,
        }
    }
}

impl std::fmt::Debug for IsolatedSimulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IsolatedSimulator")
            .field("command", &self.command)
            .field("timeout", &self.timeout)
            .finish()
    }
}

impl IsolatedSimulator {
    /// A simulator running `init` in worker processes started with `command`.
    pub fn new(
        command: Vec<String>,
        init: &WorkerInit,
        timeout: Duration,
    ) -> Result<Self, FmuError> {
        if command.is_empty() {
            return Err(FmuError::Spec("no worker command".into()));
        }
        let text = serde_json::to_string(init).map_err(|e| FmuError::Spec(e.to_string()))?;
        Ok(IsolatedSimulator {
            command: Arc::new(command),
            init: Arc::new(text),
            fmu: Arc::new(if init.hf == init.lf {
                init.hf.display().to_string()
            } else {
                format!("{} / {}", init.hf.display(), init.lf.display())
            }),
            timeout,
            worker: None,
        })
    }

    fn start(&self) -> Result<Worker, SimError> {
        let mut command = Command::new(&self.command[0]);
        command
            .args(&self.command[1..])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        die_with_parent(&mut command);
        let mut child = command.spawn().map_err(|e| {
            SimError::Failed(format!(
                "cannot start the FMU worker {:?}: {e}",
                self.command
            ))
        })?;
        let (Some(mut stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(SimError::Failed("the FMU worker has no pipes".into()));
        };
        let (tx, rx) = crossbeam_channel::unbounded();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let stop = line.is_err();
                if tx.send(line).is_err() || stop {
                    break;
                }
            }
        });
        writeln!(stdin, "{}", self.init)
            .and_then(|()| stdin.flush())
            .map_err(|e| SimError::Failed(format!("FMU worker: {e}")))?;
        let w = Worker {
            child,
            stdin,
            lines: rx,
        };
        self.ready(w)
    }

    /// Waits for a started worker to load and check its FMUs. A worker that dies meanwhile is
    /// reported naming the FMU it was loading (a library that crashes while it loads), a worker
    /// that reports an error or does not answer is killed.
    fn ready(&self, mut w: Worker) -> Result<Worker, SimError> {
        let mut loading: Option<String> = None;
        loop {
            match self.answer(&mut w, Duration::from_secs(60).max(self.timeout)) {
                Ok(WorkerResponse::Loading(fmu)) => loading = Some(fmu),
                Ok(WorkerResponse::Ready) => return Ok(w),
                Ok(WorkerResponse::Error(e)) => {
                    w.kill();
                    return Err(SimError::Failed(e));
                }
                Ok(other) => {
                    w.kill();
                    return Err(SimError::Failed(format!(
                        "FMU worker: unexpected {other:?}"
                    )));
                }
                Err(e) => {
                    let status = w.kill();
                    return Err(match loading {
                        Some(fmu) => SimError::Failed(format!(
                            "{fmu}: the FMU worker died while loading this FMU ({status})"
                        )),
                        None => e,
                    });
                }
            }
        }
    }

    /// Starts this simulator's worker now (else it starts at the first run): the FMUs are
    /// loaded and checked in it, and a failure — also a crash while loading, naming the FMU —
    /// comes back here, before any run.
    pub fn start_now(&mut self) -> Result<(), SimError> {
        if self.worker.is_none() {
            self.worker = Some(self.start()?);
        }
        Ok(())
    }

    /// The next response, or an error after `timeout` (the worker is then dead or killed and
    /// must not be reused).
    fn answer(&self, w: &mut Worker, timeout: Duration) -> Result<WorkerResponse, SimError> {
        match w.lines.recv_timeout(timeout) {
            Ok(Ok(line)) => serde_json::from_str(&line)
                .map_err(|e| SimError::Failed(format!("FMU worker sent {line:?}: {e}"))),
            Ok(Err(e)) => Err(SimError::Failed(format!("FMU worker: {e}"))),
            Err(RecvTimeoutError::Timeout) => Err(SimError::Failed(format!(
                "{}: no answer within {timeout:?} — the run hung; its worker was killed",
                self.fmu,
            ))),
            Err(RecvTimeoutError::Disconnected) => Err(SimError::Failed(format!(
                "{}: the FMU worker died during the run",
                self.fmu
            ))),
        }
    }
}

impl Simulator for IsolatedSimulator {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        self.request(WorkerRequest {
            role,
            scenario: scenario.into(),
            phi: phi.clone(),
            fidelity: fidelity.clone(),
            record: Vec::new(),
        })
        .map(|(r, _)| r)
    }
}

impl IsolatedSimulator {
    /// A run in the worker that records the outputs `record` at every communication point
    /// (see [`FmuSimulator::run_traced`]).
    pub fn run_traced(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: &[String],
    ) -> Result<(SimResult, Trace), SimError> {
        let (r, trace) = self.request(WorkerRequest {
            role,
            scenario: scenario.into(),
            phi: phi.clone(),
            fidelity: fidelity.clone(),
            record: record.to_vec(),
        })?;
        let trace = trace.ok_or_else(|| {
            SimError::Failed(format!("{}: the FMU worker sent no trace", self.fmu))
        })?;
        Ok((r, trace))
    }

    /// Sends one run to the worker (started if need be) and waits for its answer.
    fn request(&mut self, request: WorkerRequest) -> Result<(SimResult, Option<Trace>), SimError> {
        let mut w = match self.worker.take() {
            Some(w) => w,
            None => self.start()?,
        };
        let line = serde_json::to_string(&request).map_err(|e| SimError::Failed(e.to_string()))?;
        if let Err(e) = writeln!(w.stdin, "{line}").and_then(|()| w.stdin.flush()) {
            let status = w.kill();
            return Err(SimError::Failed(format!(
                "{}: FMU worker gone ({e}; {status})",
                self.fmu
            )));
        }
        match self.answer(&mut w, self.timeout) {
            Ok(WorkerResponse::Done {
                failure,
                wall_seconds,
                work,
                robustness,
                trace,
            }) => {
                self.worker = Some(w);
                let result = SimResult::new(failure, wall_seconds, work);
                let result = match robustness {
                    Some(r) => result.with_robustness(r),
                    None => result,
                };
                Ok((result, trace))
            }
            Ok(WorkerResponse::Error(e)) => {
                self.worker = Some(w);
                Err(SimError::Failed(e))
            }
            Ok(other @ (WorkerResponse::Ready | WorkerResponse::Loading(_))) => {
                w.kill();
                Err(SimError::Failed(format!(
                    "FMU worker: unexpected {other:?}"
                )))
            }
            Err(SimError::Failed(msg)) => {
                let status = w.kill();
                Err(SimError::Failed(format!("{msg} ({status})")))
            }
            Err(e) => {
                w.kill();
                Err(e)
            }
        }
    }
}

impl Drop for IsolatedSimulator {
    fn drop(&mut self) {
        if let Some(w) = self.worker.take() {
            drop(w.stdin); // the worker exits when its input closes
            let mut child = w.child;
            if child.wait().is_ok() {
                // Whatever the ended worker left (it removes its own when it exits normally).
                crate::file::remove_unpacked_of(child.id());
            }
        }
    }
}

/// A worker must not outlive the process that started it: one hanging in an FMU never reads
/// the end of its input, so on Linux the kernel kills it (`PR_SET_PDEATHSIG`, SIGKILL) when
/// the starting thread's process dies — even by `kill -9`. (The signal follows the thread that
/// spawned the worker; the campaign's worker threads live as long as the campaign.) Elsewhere
/// the worker exits when its input closes.
fn die_with_parent(command: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: getpid is async-signal-safe.
        let parent = unsafe { libc::getpid() };
        // SAFETY: the closure runs in the forked child before exec and calls only
        // async-signal-safe functions (prctl, getppid, _exit).
        unsafe {
            command.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // The parent may have died before prctl took effect.
                if libc::getppid() != parent {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = command;
}
