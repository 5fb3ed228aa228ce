//! The worker's side of the work queue (`savme worker`): `jobs` threads, each with its own
//! connection and simulator, claim runs of one campaign (`FOR UPDATE SKIP LOCKED`), run them
//! and write their results — all through savme's server-side functions, which check that the
//! session's role may work on the campaign and that a result is valid, and let only this
//! process (its secret token) finish, renew or hand back the runs it claimed; one more thread
//! renews the leases of the runs in progress. A worker killed mid-run stops renewing: its lease
//! expires and another worker runs the run again. Idle threads (only they: every notification
//! wakes every listening session) wait on `LISTEN savme_tasks_<campaign>` (re-checking every
//! second); a watch thread looks at the coordinator every [`WATCH`] and says within 2 s when
//! its heartbeat stops; the worker exits once the coordinator marks the campaign finished.
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
//! # Ok::<(), savme_postgres::worker::WorkerError>(())
//! ```

use crate::{application_name, queue, shell_quote, worker_command, worker_url, Database, Session};
use savme_campaign::executor::simulate;
use savme_campaign::Stop;
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
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
    /// How long without a live coordinator (one whose heartbeat is fresh and that runs the
    /// campaign through the queue) before the worker stops.
    pub grace: Duration,
    /// The command that starts this worker again, as its messages print it (with the flags it
    /// was given, e.g. `--jobs`); `None`: [`worker_command`] (the database and campaign alone).
    pub restart: Option<String>,
}

impl Default for WorkerOptions {
    fn default() -> Self {
        WorkerOptions {
            jobs: 1,
            lease: Duration::from_secs(30),
            wait_for_campaign: Duration::from_secs(600),
            stop: Stop::new(),
            grace: Duration::from_secs(120),
            restart: None,
        }
    }
}

/// The simulator of a worker whose host cannot build the campaign's one: every run fails with
/// the reason (after a second's pause, so that the healthy workers take most runs while this
/// one is fixed or stopped).
///
/// ```
/// use savme_postgres::worker::Unavailable;
/// use savme_kernel::{Assignment, Role, Simulator};
/// let mut sim = Unavailable::new("cannot open /opt/fmus/car.fmu".into(), std::time::Duration::ZERO);
/// let e = sim.simulate_as(Role::High, "s", &Assignment::new(), &Assignment::new()).unwrap_err();
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
    fn simulate_as(
        &mut self,
        _role: Role,
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

/// Why a worker stopped before its campaign finished.
#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    /// The database failed (named, without its password).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// No live coordinator for the grace period.
    #[error("no live coordinator of campaign {campaign:?} for {seconds} s (the grace period, --grace); this worker stops. Resume the campaign with: {resume}\nthen start the workers again: {worker}")]
    CoordinatorGone {
        /// The campaign.
        campaign: String,
        /// The grace period, in seconds.
        seconds: u64,
        /// The command that resumes the campaign.
        resume: String,
        /// The command that starts a worker again.
        worker: String,
    },
}

/// The campaign's coordinator as the worker's watch thread last saw it.
#[derive(Default)]
struct Watch {
    /// The coordinator marked the campaign finished.
    finished: AtomicBool,
    /// No live coordinator for the grace period: stop claiming.
    gone: Mutex<Option<WorkerError>>,
}

impl Watch {
    fn stop(&self) -> bool {
        self.finished.load(Ordering::Relaxed) || lock(&self.gone).is_some()
    }
}

/// Works on campaign `name` until the coordinator marks it finished — or until no live
/// coordinator has been seen for `options.grace` ([`WorkerError::CoordinatorGone`]).
pub fn work<S>(
    db: &Database,
    name: &str,
    sim: &S,
    options: &WorkerOptions,
) -> Result<WorkerReport, WorkerError>
where
    S: Simulator + Clone + Send,
{
    let mut session = Session::connect(db, "worker")?;
    let found = wait_for_campaign(&mut session, name, options.wait_for_campaign)?;
    let campaign = found.id;
    if let Some(warning) = found
        .window
        .and_then(|w| window_warning(name, w, options.jobs))
    {
        eprintln!("{warning}");
    }
    let held = Mutex::new(HashSet::new());
    let stop = AtomicBool::new(false);
    let watch = Watch::default();
    let (runs, dropped) = (AtomicU64::new(0), AtomicU64::new(0));
    let lease = (options.lease).clamp(Duration::from_millis(300), queue::MAX_LEASE);
    let restart = options.restart.as_deref();
    // This process's secret: only the process that claimed a run may finish, renew or hand it
    // back.
    let token = &*token();
    std::thread::scope(|scope| -> Result<(), WorkerError> {
        let beat = scope.spawn(|| heartbeat(db, campaign, token, &held, &stop, lease));
        let watcher = scope.spawn(|| {
            watch_coordinator(
                session,
                campaign,
                name,
                options.grace,
                restart,
                &watch,
                &stop,
            )
        });
        let threads: Vec<_> = (0..options.jobs.max(1))
            .map(|k| {
                let mut sim = sim.clone();
                let (held, runs, dropped, watch) = (&held, &runs, &dropped, &watch);
                let stop = &options.stop;
                scope.spawn(move || {
                    work_thread(
                        db,
                        (campaign, token),
                        k,
                        &mut sim,
                        lease,
                        held,
                        (watch, stop),
                        [runs, dropped],
                    )
                })
            })
            .collect();
        let first_error = join_all(db, threads);
        stop.store(true, Ordering::Relaxed);
        let _ = beat.join();
        let _ = watcher.join();
        first_error?;
        match lock(&watch.gone).take() {
            Some(gone) if !watch.finished.load(Ordering::Relaxed) => Err(gone),
            _ => Ok(()),
        }
    })?;
    Ok(WorkerReport {
        runs: runs.into_inner(),
        dropped: dropped.into_inner(),
        stopped: options.stop.is_requested(),
    })
}

/// Waits for the worker threads; the first error (a panic is one, naming the database).
fn join_all(
    db: &Database,
    threads: Vec<std::thread::ScopedJoinHandle<'_, Result<(), StoreError>>>,
) -> Result<(), StoreError> {
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
    first_error
}

/// A random secret of 128 bits, as hex (the kernel's random source; the clock and the pid
/// hashed by a randomly keyed hasher where there is none).
fn token() -> String {
    use std::hash::{BuildHasher, Hasher};
    use std::io::Read;
    let mut bytes = [0u8; 16];
    let read = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut bytes));
    if read.is_err() {
        for half in bytes.chunks_mut(8) {
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write_u128(
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos()),
            );
            h.write_u32(std::process::id());
            half.copy_from_slice(&h.finish().to_le_bytes());
        }
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A stopping thread's claimed but unstarted run, queued again for another worker (without
/// waiting for its lease to expire).
fn hand_back(
    s: &mut Session,
    (campaign, token): (i32, &str),
    run: Option<queue::Claimed>,
    me: &str,
) -> Result<(), StoreError> {
    if let Some(run) = run {
        s.run(|c| queue::release(c, campaign, run.id, me, token))?;
    }
    Ok(())
}

/// Writes run `id`'s `result` and claims the next run (none if `next` is false) in one round
/// trip; whether the result was kept. A result the server refuses (not a valid one: e.g. a
/// work count where the campaign counts none) is written as the run's failure, with the
/// server's message, so that the coordinator applies the campaign's `on_error`.
#[allow(clippy::too_many_arguments)]
fn finish(
    s: &mut Session,
    (campaign, token): (i32, &str),
    id: i64,
    me: &str,
    result: &Result<SimResult, SimError>,
    lease: Duration,
    next: bool,
) -> Result<(bool, Option<queue::Claimed>), StoreError> {
    let mut tried = false;
    let mut refusal = None;
    let done = s.run(|c| {
        let retry = std::mem::replace(&mut tried, true);
        match queue::finish_and_claim(c, campaign, id, me, token, result, lease, next) {
            Ok((kept, next)) => {
                // After a reconnect the finish may have committed before the connection broke.
                let kept = kept || (retry && queue::finished_by(c, campaign, id, me, token)?);
                Ok(Some((kept, next)))
            }
            Err(e) => match queue::refused(&e) {
                Some(message) => {
                    refusal = Some(message);
                    Ok(None)
                }
                None => Err(e),
            },
        }
    })?;
    if let Some(done) = done {
        return Ok(done);
    }
    let message = refusal.unwrap_or_default();
    eprintln!(
        "savme worker: {}",
        message.strip_prefix("savme: ").unwrap_or(&message)
    );
    let failed = Err(SimError::Failed(message));
    s.run(|c| queue::finish_and_claim(c, campaign, id, me, token, &failed, lease, next))
}

/// One worker thread: claims, runs and finishes runs until the watch says stop, or until
/// `stop` is requested (then it hands back a run it claimed but did not start), counting
/// `[runs, dropped]`.
#[allow(clippy::too_many_arguments)]
fn work_thread<S: Simulator>(
    db: &Database,
    (campaign, token): (i32, &str),
    k: usize,
    sim: &mut S,
    lease: Duration,
    held: &Mutex<HashSet<i64>>,
    (watch, stop): (&Watch, &Stop),
    [runs, dropped]: [&AtomicU64; 2],
) -> Result<(), StoreError> {
    let me = format!("{} #{k}", application_name("worker"));
    let mut s = Session::connect(db, "worker")?;
    // A result lost in a server crash only costs running its run again (its row stays
    // `running` and its lease expires), or is written back by the coordinator if it had read
    // it; the coordinator's own commits, which store the trials, are durable and flush every
    // result they were made from.
    s.set("SET synchronous_commit = off")?;
    let mut claimed = None;
    let ours = (campaign, token);
    // Listening only while idle: the server wakes every session listening in the database at
    // each notification (each finished run notifies the coordinator), so a busy thread that
    // listened would cost the server a wake-up per run of every other thread.
    let channel = queue::tasks_channel(campaign);
    let mut listening = false;
    loop {
        if stop.is_requested() {
            return hand_back(&mut s, ours, claimed.take(), &me);
        }
        if claimed.is_none() {
            if watch.stop() {
                return Ok(());
            }
            claimed = s.run(|c| queue::claim(c, campaign, &me, token, lease))?;
        }
        let Some(run) = claimed.take() else {
            if !listening {
                // Then claim again: a run queued before the LISTEN sent no wake-up to us.
                s.listen(&channel)?;
                listening = true;
            } else {
                s.wait(Duration::from_secs(1))?;
            }
            continue;
        };
        if listening {
            s.unlisten(&channel)?;
            listening = false;
        }
        if stop.is_requested() {
            return hand_back(&mut s, ours, Some(run), &me);
        }
        lock(held).insert(run.id);
        let result = match &run.task {
            Ok(t) => simulate(sim, t.which, &t.scenario, &t.phi, &t.fidelity),
            Err(message) => Err(SimError::Failed(message.clone())),
        };
        // The result, and the next run, in one round trip (none once told to stop).
        let (kept, next) = finish(&mut s, ours, run.id, &me, &result, lease, true)?;
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
}

/// Watches the campaign's coordinator every [`WATCH`] until `stop`: marks the campaign
/// finished, says on stderr when no live coordinator runs it through the queue (at once when one
/// runs it without `--remote`), and gives up after `grace` without one (naming `restart`, the
/// command that starts this worker again, if given).
fn watch_coordinator(
    mut s: Session,
    campaign: i32,
    name: &str,
    grace: Duration,
    restart: Option<&str>,
    watch: &Watch,
    stop: &AtomicBool,
) {
    let mut lost: Option<Instant> = None;
    let mut said = None;
    // Until a live coordinator was seen, one that is starting is given [`SETTLE`]; once one
    // was, its absence is said at once.
    let mut seen_live = false;
    while !stop.load(Ordering::Relaxed) {
        let state = match s.run(|c| queue::coordinator(c, campaign)) {
            Ok(Some(state)) => state,
            Ok(None) => queue::Coordinator {
                finished: true,
                ..gone_state()
            },
            // The sessions reconnect by themselves; try again shortly.
            Err(_) => gone_state(),
        };
        if state.finished {
            watch.finished.store(true, Ordering::Relaxed);
            return;
        }
        if live(&state) {
            if said.take().is_some() {
                eprintln!("savme worker: campaign {name:?}: its coordinator is back");
            }
            lost = None;
            seen_live = true;
        } else {
            let since = *lost.get_or_insert_with(Instant::now);
            let left = grace.saturating_sub(since.elapsed()).as_secs();
            let why = absence(&state, name, left);
            let settled = seen_live || since.elapsed() >= SETTLE;
            if said.as_ref() != Some(&why) && settled {
                eprintln!("{why}");
                said = Some(why);
            }
            if since.elapsed() >= grace {
                let resume = state.resume_command.clone().unwrap_or_else(|| format!(
                    "its coordinator's command (savme reproduce, run or toy) with --storage {} --campaign {} --remote --resume",
                    shell_quote(&worker_url(s.database())),
                    shell_quote(name)
                ));
                *lock(&watch.gone) = Some(WorkerError::CoordinatorGone {
                    campaign: name.into(),
                    seconds: grace.as_secs(),
                    resume,
                    worker: restart
                        .map_or_else(|| worker_command(s.database(), name), str::to_string),
                });
                return;
            }
        }
        std::thread::sleep(WATCH);
    }
}

/// Whether `state` is a live coordinator running the campaign through the queue: it holds the
/// campaign's lock (its server session is alive) and its heartbeat is fresh.
fn live(state: &queue::Coordinator) -> bool {
    state.remote && state.locked && state.seen_ago.is_some_and(|a| a < STALE.as_secs_f64())
}

/// A warning when `jobs` threads are more than campaign `name`'s window keeps busy: at most
/// two runs (HF and LF) per trial in flight, so 2 × window runs for all its workers together.
///
/// ```
/// use savme_postgres::worker::window_warning;
/// assert!(window_warning("n", 4, 8).is_none());
/// assert!(window_warning("n", 4, 9).unwrap().contains("--window 9"));
/// ```
pub fn window_warning(name: &str, window: i64, jobs: usize) -> Option<String> {
    (jobs as i64 > 2 * window).then(|| format!(
        "savme worker: WARNING: campaign {name:?} has a window of {window} trials, so at most {} runs are in flight for all its workers together; {} of this worker's {jobs} threads will always be idle. A new campaign keeps N worker threads busy with --window N (docs/DISTRIBUTED.md, \"The window\"): e.g. --window {jobs}",
        2 * window,
        jobs as i64 - 2 * window
    ))
}

/// How long a coordinator's heartbeat stays fresh (it stamps one every
/// [`crate::HEARTBEAT`]): a worker says within this and [`WATCH`] that the heartbeat stopped.
pub const STALE: Duration = Duration::from_millis(1500);
/// How often a worker looks at its coordinator.
pub const WATCH: Duration = Duration::from_millis(250);
/// How long a worker lets a coordinator that is starting settle before it says anything (only
/// before it has seen a live one).
const SETTLE: Duration = Duration::from_secs(2);
/// How often a worker renews the leases of its runs at most (a third of the lease if shorter):
/// also how soon after a database restart it shows the server that it is alive.
const RENEW: Duration = Duration::from_secs(1);

fn gone_state() -> queue::Coordinator {
    queue::Coordinator {
        finished: false,
        remote: false,
        seen_ago: None,
        locked: false,
        resume_command: None,
    }
}

/// Why the campaign has no live coordinator, as the worker says it.
fn absence(state: &queue::Coordinator, name: &str, left: u64) -> String {
    let then =
        format!("this worker waits {left} s more for a coordinator with --remote, then stops");
    if state.locked && !state.remote {
        format!(
            "savme worker: campaign {name:?} is held by a coordinator started without --remote: it runs its trials on its own threads, and this worker has nothing to do. Restart the coordinator with --remote to use workers; {then}"
        )
    } else if state.locked {
        let ago = state
            .seen_ago
            .map_or("ever".into(), |a| format!("{a:.0} s"));
        format!(
            "savme worker: campaign {name:?}: no heartbeat from its coordinator for {ago} (it is stuck or has lost the database); {then}"
        )
    } else {
        format!("savme worker: campaign {name:?} has no coordinator running (it stopped, was killed, or has not been resumed yet); {then}")
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The campaign as this worker may see it, waiting (with a message) until a coordinator has
/// created it (and migrated the schema to this savme's version) and lets this role work on it.
fn wait_for_campaign(
    session: &mut Session,
    name: &str,
    patience: Duration,
) -> Result<queue::WorkerCampaign, StoreError> {
    let start = Instant::now();
    let mut said = false;
    loop {
        if let Some(found) = session.run(|c| queue::worker_campaign(c, name))? {
            return Ok(found);
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
                "savme worker: {}: waiting for campaign {name:?} to be started (or, if it runs, for this role to be allowed to work on it: its coordinator's --worker-role)",
                session.database().location()
            );
            said = true;
        }
        // Often: workers usually start before their coordinator, and every moment waited
        // here is a moment of the campaign (a cheap indexed read).
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Renews the leases of the runs in `held` every third of `lease` (every [`RENEW`] at most)
/// until `stop`.
fn heartbeat(
    db: &Database,
    campaign: i32,
    token: &str,
    held: &Mutex<HashSet<i64>>,
    stop: &AtomicBool,
    lease: Duration,
) {
    let Ok(mut s) = Session::connect(db, "worker heartbeat") else {
        return;
    };
    let every = (lease / 3).min(RENEW);
    let mut last = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
        if last.elapsed() < every {
            continue;
        }
        last = Instant::now();
        let ids: Vec<i64> = lock(held).iter().copied().collect();
        if ids.is_empty() {
            continue;
        }
        // A failed heartbeat is retried at the next beat; the lease outlasts two misses.
        let _ = s.run(|c| queue::heartbeat(c, campaign, &ids, token, lease));
    }
}
