//! The worker's side of the work queue (`savme worker`): `jobs` threads, each with its own
//! connection and simulator, claim runs of one campaign (`FOR UPDATE SKIP LOCKED`), run them
//! and write their results; one more thread renews the leases of the runs in progress. A
//! worker killed mid-run stops renewing: its lease expires and another worker runs the run
//! again. Idle threads wait on `LISTEN savme_tasks_<campaign>` (re-checking every second);
//! the worker exits once the coordinator marks the campaign finished.
//!
//! A worker whose host cannot build the campaign's simulator (its FMUs are missing there) still
//! works, on an [`Unavailable`] simulator: every run it claims fails with the reason, naming
//! the host, and the coordinator applies the campaign's `on_error` to it (stops the campaign,
//! or withdraws the trial).
//!
//! ```no_run
//! use savme_postgres::Database;
//! use savme_postgres::worker::{work, WorkerOptions};
//! use savme_campaign::toy::ToySimulator;
//! let db = Database::parse("postgresql://worker@db.example/safety")?;
//! let report = work(&db, "night-run-1", &ToySimulator, &WorkerOptions::default())?;
//! println!("{} runs", report.runs);
//! # Ok::<(), savme_store::StoreError>(())
//! ```

use crate::{application_name, find_campaign, queue, Database, Session};
use savme_campaign::executor::simulate;
use savme_campaign::Stop;
use savme_kernel::{Assignment, SimError, SimResult, Simulator};
use savme_store::StoreError;
use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How a worker runs.
#[derive(Debug, Clone)]
pub struct WorkerOptions {
    /// Runs at once (threads, each with its own simulator and connection).
    pub jobs: usize,
    /// How long a claimed run stays this worker's without a heartbeat; heartbeats come every
    /// third of it. A killed worker's runs are taken over after at most this long.
    pub lease: Duration,
    /// How long to wait for the campaign to appear in the database before giving up.
    pub wait_for_campaign: Duration,
    /// Asks the worker to stop between runs (SIGINT/SIGTERM in `savme worker`): each thread
    /// finishes and writes the run it is running, hands back a run it claimed but did not
    /// start (queued again for another worker), and [`work`] returns with
    /// [`WorkerReport::stopped`] set.
    pub stop: Stop,
}

impl Default for WorkerOptions {
    fn default() -> Self {
        WorkerOptions {
            jobs: 1,
            lease: Duration::from_secs(30),
            wait_for_campaign: Duration::from_secs(600),
            stop: Stop::new(),
        }
    }
}

/// The simulator of a worker whose host cannot build the campaign's one: every run fails with
/// the reason (after a second's pause, so that the healthy workers take most runs while this
/// one is fixed or stopped).
///
/// ```
/// use savme_postgres::worker::Unavailable;
/// use savme_kernel::{Assignment, Simulator};
/// let mut sim = Unavailable::new("cannot open /opt/fmus/car.fmu".into(), std::time::Duration::ZERO);
/// let e = sim.simulate("s", &Assignment::new(), &Assignment::new()).unwrap_err();
/// assert!(e.to_string().contains("cannot open /opt/fmus/car.fmu"));
/// ```
#[derive(Debug, Clone)]
pub struct Unavailable {
    reason: String,
    pause: Duration,
}

impl Unavailable {
    /// A simulator failing every run with `reason` (prefixed with this worker and its host)
    /// after `pause`.
    pub fn new(reason: String, pause: Duration) -> Unavailable {
        Unavailable {
            reason: format!(
                "{} cannot run this campaign's simulator: {reason}",
                application_name("worker")
            ),
            pause,
        }
    }
}

impl Simulator for Unavailable {
    fn simulate(
        &mut self,
        _scenario: &str,
        _phi: &Assignment,
        _fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        std::thread::sleep(self.pause);
        Err(SimError::Failed(self.reason.clone()))
    }
}

/// What a worker did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkerReport {
    /// Runs it finished and wrote.
    pub runs: u64,
    /// Runs it finished too late: its lease had expired and another worker had taken them.
    pub dropped: u64,
    /// It stopped because [`WorkerOptions::stop`] was requested (the campaign may go on).
    pub stopped: bool,
}

/// Works on campaign `name` until the coordinator marks it finished.
pub fn work<S>(
    db: &Database,
    name: &str,
    sim: &S,
    options: &WorkerOptions,
) -> Result<WorkerReport, StoreError>
where
    S: Simulator + Clone + Send,
{
    let mut session = Session::connect(db, "worker")?;
    let campaign = wait_for_campaign(&mut session, name, options.wait_for_campaign)?;
    let held = Mutex::new(HashSet::new());
    let stop = AtomicBool::new(false);
    let (runs, dropped) = (AtomicU64::new(0), AtomicU64::new(0));
    let lease = options.lease.max(Duration::from_millis(300));
    std::thread::scope(|scope| -> Result<(), StoreError> {
        let beat = scope.spawn(|| heartbeat(db, &held, &stop, lease));
        let threads: Vec<_> = (0..options.jobs.max(1))
            .map(|k| {
                let mut sim = sim.clone();
                let (held, runs, dropped) = (&held, &runs, &dropped);
                scope.spawn(move || -> Result<(), StoreError> {
                    let me = format!("{} #{k}", application_name("worker"));
                    let mut s = Session::connect(db, "worker")?;
                    s.listen(&queue::tasks_channel(campaign))?;
                    let mut claimed = None;
                    loop {
                        if options.stop.is_requested() {
                            return hand_back(&mut s, claimed.take(), &me);
                        }
                        if claimed.is_none() {
                            claimed = s.run(|c| queue::claim(c, campaign, &me, lease))?;
                        }
                        let Some(run) = claimed.take() else {
                            if s.run(|c| queue::is_finished(c, campaign))? {
                                return Ok(());
                            }
                            s.wait(Duration::from_secs(1))?;
                            continue;
                        };
                        if options.stop.is_requested() {
                            return hand_back(&mut s, Some(run), &me);
                        }
                        lock(held).insert(run.id);
                        let result = match &run.task {
                            Ok(t) => {
                                simulate(&mut sim, t.which.role(), &t.scenario, &t.phi, &t.fidelity)
                            }
                            Err(message) => Err(SimError::Failed(message.clone())),
                        };
                        // The result, and the next run, in one round trip.
                        let (kept, next) = s.run(|c| {
                            queue::finish_and_claim(c, campaign, run.id, &me, &result, lease)
                        })?;
                        let mut held = lock(held);
                        held.remove(&run.id);
                        if let Some(next) = &next {
                            held.insert(next.id);
                        }
                        drop(held);
                        claimed = next;
                        let counter = if kept { runs } else { dropped };
                        counter.fetch_add(1, Ordering::Relaxed);
                    }
                })
            })
            .collect();
        let mut first_error = Ok(());
        for t in threads {
            let r = t.join().unwrap_or_else(|_| {
                Err(StoreError::Database {
                    store: db.location().into(),
                    message: "a worker thread panicked".into(),
                })
            });
            if first_error.is_ok() {
                first_error = r;
            }
        }
        stop.store(true, Ordering::Relaxed);
        let _ = beat.join();
        first_error
    })?;
    Ok(WorkerReport {
        runs: runs.into_inner(),
        dropped: dropped.into_inner(),
        stopped: options.stop.is_requested(),
    })
}

/// A stopping thread's claimed but unstarted run, queued again for another worker (without
/// waiting for its lease to expire).
fn hand_back(s: &mut Session, run: Option<queue::Claimed>, me: &str) -> Result<(), StoreError> {
    if let Some(run) = run {
        s.run(|c| queue::release(c, run.id, me))?;
    }
    Ok(())
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The campaign's id, waiting (with a message) until a coordinator has created it.
fn wait_for_campaign(
    session: &mut Session,
    name: &str,
    patience: Duration,
) -> Result<i32, StoreError> {
    let start = Instant::now();
    let mut said = false;
    loop {
        let schema: bool = session.run(|c| {
            Ok(
                c.query_one("SELECT to_regclass('savme.campaigns') IS NOT NULL", &[])?
                    .get(0),
            )
        })?;
        if schema {
            if let Some(id) = session.run(|c| find_campaign(c, name))? {
                return Ok(id);
            }
        }
        if start.elapsed() >= patience {
            return Err(StoreError::Database {
                store: session.database().location().into(),
                message: format!(
                    "no campaign {name:?} appeared in {} s: start its coordinator (savme reproduce/run/toy --storage … --campaign {name:?} --remote)",
                    patience.as_secs()
                ),
            });
        }
        if !said {
            eprintln!(
                "savme worker: {}: waiting for campaign {name:?} to be started",
                session.database().location()
            );
            said = true;
        }
        // Often: workers usually start before their coordinator, and every moment waited
        // here is a moment of the campaign (a cheap indexed read).
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Renews the leases of the runs in `held` every third of `lease` until `stop`.
fn heartbeat(db: &Database, held: &Mutex<HashSet<i64>>, stop: &AtomicBool, lease: Duration) {
    let Ok(mut s) = Session::connect(db, "worker heartbeat") else {
        return;
    };
    let me_prefix = application_name("worker");
    let mut last = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
        if last.elapsed() < lease / 3 {
            continue;
        }
        last = Instant::now();
        let ids: Vec<i64> = lock(held).iter().copied().collect();
        if ids.is_empty() {
            continue;
        }
        // A failed heartbeat is retried at the next beat; the lease outlasts two misses.
        let _ = s.run(|c| queue::heartbeat(c, &ids, &me_prefix, lease));
    }
}
