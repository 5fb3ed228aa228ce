//! The remote [`Runner`]: the coordinator's side of the work queue in PostgreSQL. Runs are
//! rows of `savme.runs` (see [`queue`]); `savme worker` processes on any host claim and run
//! them; the coordinator waits for their results with `LISTEN`/`NOTIFY` (re-reading at least
//! once a second, so a notification lost in a reconnect costs a second, not the campaign).
//!
//! **One commit per wake-up.** The Remote shares the store's locked connection: the trial
//! lines told since it last waited and the runs asked for meanwhile are committed in one
//! transaction just before it waits again ([`crate::locked`]), so a campaign costs one durable
//! commit per batch of finished runs, not one per trial.
//!
//! **Heartbeat.** While it runs, a thread stamps `savme.campaigns.coordinator_seen_at` every
//! [`HEARTBEAT`]; a worker that sees no fresh stamp says so and, after its grace period,
//! exits naming the command that resumes the campaign (stored in `resume_command`).
//!
//! **Results it cannot use** (a row written by hand or before the server checked results: a
//! NULL or negative work count, a NULL failure, a wall time that is not finite) are queued
//! again with a message naming the run and its worker, and failed after
//! [`queue::MAX_ATTEMPTS`] claims — never the end of the campaign. **After a database crash**
//! it writes back the results it told whose rows lost them, and queues again the runs whose
//! holder did not come back ([`RECONCILE_AFTER`]).
//!
//! If no run finishes for [`Remote::worker_wait`], the coordinator says so on stderr — that no
//! worker ever started a run of this campaign (with the command to start one), or that the
//! workers stopped — and keeps waiting.

use crate::locked::Locked;
use crate::{queue, worker_command, Database, PostgresStore, Session};
use savme_campaign::executor::{Done, RemoteRunner, Runner, Task};
use savme_campaign::CampaignError;
use savme_kernel::Role;
use std::collections::{HashMap, VecDeque};
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often the coordinator stamps its heartbeat (workers judge it stale after
/// [`crate::worker::STALE`]).
pub const HEARTBEAT: Duration = Duration::from_millis(400);

/// How long after the coordinator's queue connection came back (the server restarted) it
/// queues again the runs it waits for whose holder has not renewed its lease since (workers
/// renew every second at most; see [`queue::requeue_orphans`]).
pub const RECONCILE_AFTER: Duration = Duration::from_secs(5);

/// How a coordinator runs its campaign through the queue.
#[derive(Debug, Clone)]
pub struct RemoteOptions {
    /// How long without a finished run before the coordinator says so (and again after as
    /// long).
    pub worker_wait: Duration,
    /// The command that resumes this campaign (shown by workers whose coordinator is gone;
    /// no password).
    pub resume_command: String,
    /// Database roles allowed to work on this campaign (registered in
    /// `savme.campaign_workers` and granted the worker functions, `savme.grant_worker`; a
    /// worker role works only on the campaigns it is listed for).
    pub worker_roles: Vec<String>,
}

/// The coordinator's connection to the work queue of one campaign.
pub struct Remote {
    session: Session,
    locked: Arc<Mutex<Locked>>,
    campaign: i32,
    name: String,
    /// Row id → the run, for runs submitted and not yet returned.
    waiting: HashMap<i64, (u64, Role)>,
    /// Runs asked for since the last wait: queued together (one statement) before it.
    pending: Vec<Task>,
    ready: VecDeque<Done>,
    worker_wait: Duration,
    last_progress: Instant,
    heartbeat: Option<(Sender<()>, JoinHandle<()>)>,
    /// Results read since the last commit (written back after a crash: [`Locked::commit`]).
    told: Vec<queue::RowResult>,
    /// The queue connection's reconnects seen, and when to look for orphaned runs after the
    /// last one.
    reconnects: u64,
    reconcile_at: Option<Instant>,
}

impl Remote {
    /// Connects to the queue of `store`'s campaign, registers the worker roles, marks the
    /// campaign running through the queue, and starts the heartbeat. From now on the store's
    /// appends are committed with the queue updates.
    pub fn open(store: &PostgresStore, options: RemoteOptions) -> Result<Remote, CampaignError> {
        let db = store.database();
        let campaign = store.campaign_id();
        let mut session = Session::connect(db, "coordinator queue")?;
        session.listen(&queue::done_channel(campaign))?;
        for role in &options.worker_roles {
            let exists = session.run(|c| queue::add_worker_role(c, campaign, role))?;
            if !exists {
                return Err(CampaignError::Store(savme_store::StoreError::Database {
                    store: "--worker-role".into(),
                    message: format!("{role:?}: no such role in {}", db.location()),
                }));
            }
        }
        let resume = options.resume_command.clone();
        session.run(|c| queue::start_remote(c, campaign, &resume))?;
        let locked = store.shared();
        lock(&locked).defer();
        Ok(Remote {
            session,
            locked,
            campaign,
            name: store.name().into(),
            waiting: HashMap::new(),
            pending: Vec::new(),
            ready: VecDeque::new(),
            worker_wait: options.worker_wait,
            last_progress: Instant::now(),
            heartbeat: Some(beat(db.clone(), campaign)),
            told: Vec::new(),
            reconnects: 0,
            reconcile_at: None,
        })
    }

    /// How long without a finished run before the coordinator says so.
    pub fn worker_wait(&self) -> Duration {
        self.worker_wait
    }

    /// Commits the trials told since the last wait and queues the runs asked for meanwhile
    /// (one transaction, one notification).
    fn flush(&mut self) -> Result<(), CampaignError> {
        let tasks = std::mem::take(&mut self.pending);
        let mut locked = lock(&self.locked);
        // The results read are kept until a commit (of lines or runs) flushes the log past
        // their finishes: until then a crash may lose those.
        let flushes = !tasks.is_empty() || locked.has_pending();
        let ids = locked.commit(&tasks, &self.told)?;
        drop(locked);
        if flushes {
            self.told.clear();
        }
        for (id, task) in ids.into_iter().zip(&tasks) {
            if id < 0 {
                return Err(CampaignError::Store(savme_store::StoreError::Database {
                    store: self.session.database().location().into(),
                    message: format!(
                        "the queue did not take run {} of trial {} ({})",
                        task.which.key(),
                        task.trial,
                        task.stage
                    ),
                }));
            }
            self.waiting.insert(id, (task.trial, task.which));
        }
        Ok(())
    }

    /// Moves the finished runs among those waited for to `ready`; a row holding no usable
    /// result is queued again (or, after [`queue::MAX_ATTEMPTS`] claims, failed), saying so.
    fn collect(&mut self) -> Result<(), CampaignError> {
        let ids: Vec<i64> = self.waiting.keys().copied().collect();
        let (finished, unusable) = self.session.run(|c| queue::finished(c, &ids))?;
        for f in finished {
            if let Some((trial, which)) = self.waiting.remove(&f.id) {
                self.told.push(queue::RowResult::new(f.id, &f.result));
                self.ready.push_back(Done {
                    trial,
                    which,
                    result: f.result,
                });
            }
        }
        for u in unusable {
            self.refuse(u)?;
        }
        Ok(())
    }

    /// A finished row whose result cannot be used: queued again with a message naming the run
    /// and its worker — or, once it was claimed [`queue::MAX_ATTEMPTS`] times, failed with
    /// that message (the campaign's `on_error` applies, as to a simulator that keeps failing).
    fn refuse(&mut self, u: queue::Unusable) -> Result<(), CampaignError> {
        let Some(&(trial, which)) = self.waiting.get(&u.id) else {
            return Ok(());
        };
        let message = format!(
            "savme: campaign {:?}: refused the result of run {} ({} of trial {trial}) from worker {:?}: {}",
            self.name,
            u.id,
            which.key(),
            u.worker,
            u.reason
        );
        if u.attempts >= queue::MAX_ATTEMPTS {
            self.waiting.remove(&u.id);
            self.ready.push_back(Done {
                trial,
                which,
                result: Err(savme_kernel::SimError::Failed(format!(
                    "{message} (claimed {} times)",
                    u.attempts
                ))),
            });
            return Ok(());
        }
        eprintln!("{message}; the run is queued again");
        let campaign = self.campaign;
        self.session
            .run(|c| queue::requeue(c, campaign, &[u.id], &message))?;
        Ok(())
    }

    /// After the queue connection came back from a lost one (a database restart), and
    /// [`RECONCILE_AFTER`] more: queues again the runs waited for whose holder has not shown
    /// itself alive since the server started.
    fn reconcile(&mut self) -> Result<(), CampaignError> {
        let reconnects = self.session.reconnects();
        if reconnects != self.reconnects {
            self.reconnects = reconnects;
            self.reconcile_at = Some(Instant::now() + RECONCILE_AFTER);
        }
        if self.reconcile_at.is_none_or(|at| Instant::now() < at) {
            return Ok(());
        }
        self.reconcile_at = None;
        let ids: Vec<i64> = self.waiting.keys().copied().collect();
        let campaign = self.campaign;
        let n = self
            .session
            .run(|c| queue::requeue_orphans(c, campaign, &ids))?;
        if n > 0 {
            eprintln!(
                "savme: campaign {:?}: {n} run(s) held before the database restarted were not renewed since by any worker; they are queued again",
                self.name
            );
        }
        Ok(())
    }

    /// Says on stderr why nothing finishes.
    fn complain(&mut self) -> Result<(), CampaignError> {
        let campaign = self.campaign;
        let started = self.session.run(|c| queue::started(c, campaign))?;
        let command = worker_command(self.session.database(), &self.name);
        let secs = self.last_progress.elapsed().as_secs();
        if started == 0 {
            eprintln!(
                "savme: no worker has taken a run of campaign {:?} in {secs} s; {} runs are waiting. Start workers on any host with: {command}",
                self.name,
                self.waiting.len(),
            );
        } else {
            eprintln!(
                "savme: no run of campaign {:?} finished in {secs} s ({} waiting); are the workers still running? ({command})",
                self.name,
                self.waiting.len(),
            );
        }
        Ok(())
    }

    fn stop_heartbeat(&mut self) {
        if let Some((stop, thread)) = self.heartbeat.take() {
            drop(stop);
            let _ = thread.join();
        }
    }
}

fn lock(m: &Mutex<Locked>) -> std::sync::MutexGuard<'_, Locked> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Starts the heartbeat thread of campaign `campaign` (stopped by dropping the sender).
fn beat(db: Database, campaign: i32) -> (Sender<()>, JoinHandle<()>) {
    let (stop, stopped) = channel::<()>();
    let thread = std::thread::spawn(move || {
        let Ok(mut s) = Session::connect(&db, "coordinator heartbeat") else {
            return;
        };
        loop {
            // A missed beat is retried at the next one; workers allow several.
            let _ = s.run(|c| queue::coordinator_seen(c, campaign));
            if stopped.recv_timeout(HEARTBEAT) != Err(RecvTimeoutError::Timeout) {
                return;
            }
        }
    });
    (stop, thread)
}

impl Drop for Remote {
    fn drop(&mut self) {
        self.stop_heartbeat();
    }
}

impl Runner for Remote {
    fn submit(&mut self, task: Task) -> Result<(), CampaignError> {
        // Queued at the next wait: the runs a told trial makes room for go in together.
        self.pending.push(task);
        Ok(())
    }

    fn next_done(&mut self) -> Result<Done, CampaignError> {
        let mut complained_at = Instant::now();
        loop {
            if let Some(done) = self.ready.pop_front() {
                self.last_progress = Instant::now();
                return Ok(done);
            }
            self.flush()?;
            if self.waiting.is_empty() {
                return Err(CampaignError::WorkersGone);
            }
            self.collect()?;
            self.reconcile()?;
            if !self.ready.is_empty() {
                continue;
            }
            let since = self.last_progress.elapsed().min(complained_at.elapsed());
            if since >= self.worker_wait {
                self.complain()?;
                complained_at = Instant::now();
            }
            self.session.wait(Duration::from_secs(1))?;
        }
    }
}

impl RemoteRunner for Remote {
    /// Commits the last trials and marks the campaign finished: idle workers exit.
    fn finish(mut self: Box<Self>) -> Result<(), CampaignError> {
        self.flush()?;
        self.stop_heartbeat();
        let campaign = self.campaign;
        self.session
            .run(|c| queue::set_finished(c, campaign, true))?;
        Ok(())
    }
}
