//! The remote [`Runner`]: the coordinator's side of the work queue in PostgreSQL. Runs are
//! rows of `savme.runs` (see [`queue`]); `savme worker` processes on any host claim and run
//! them; the coordinator waits for their results with `LISTEN`/`NOTIFY` (re-reading at least
//! once a second, so a notification lost in a reconnect costs a second, not the campaign).
//!
//! If no run finishes for [`Remote::worker_wait`], the coordinator says so on stderr — that no
//! worker ever started a run of this campaign (with the command to start one), or that the
//! workers stopped — and keeps waiting.

use crate::{queue, Database, Session};
use savme_campaign::executor::{Done, RemoteRunner, Runner, Task, Which};
use savme_campaign::CampaignError;
use std::collections::{HashMap, VecDeque};
use std::time::{Duration, Instant};

/// The coordinator's connection to the work queue of one campaign.
pub struct Remote {
    session: Session,
    campaign: i32,
    name: String,
    /// Row id → the run, for runs submitted and not yet returned.
    waiting: HashMap<i64, (u64, Which)>,
    /// Runs asked for since the last wait: inserted together (one statement) before it.
    pending: Vec<Task>,
    ready: VecDeque<Done>,
    worker_wait: Duration,
    last_progress: Instant,
}

impl Remote {
    /// Connects to the queue of campaign `name` (id `campaign`, as the store opened it) and
    /// marks the campaign running.
    pub fn open(
        db: &Database,
        campaign: i32,
        name: &str,
        worker_wait: Duration,
    ) -> Result<Remote, CampaignError> {
        let mut session = Session::connect(db, "coordinator queue")?;
        session.listen(&queue::done_channel(campaign))?;
        session.run(|c| queue::set_finished(c, campaign, false))?;
        Ok(Remote {
            session,
            campaign,
            name: name.into(),
            waiting: HashMap::new(),
            pending: Vec::new(),
            ready: VecDeque::new(),
            worker_wait,
            last_progress: Instant::now(),
        })
    }

    /// How long without a finished run before the coordinator says so.
    pub fn worker_wait(&self) -> Duration {
        self.worker_wait
    }

    /// Inserts the pending runs into the queue (one statement, one notification).
    fn flush(&mut self) -> Result<(), CampaignError> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let campaign = self.campaign;
        let tasks = std::mem::take(&mut self.pending);
        let ids = self.session.run(|c| queue::submit(c, campaign, &tasks))?;
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

    /// Moves the finished runs among those waited for to `ready`.
    fn collect(&mut self) -> Result<(), CampaignError> {
        let ids: Vec<i64> = self.waiting.keys().copied().collect();
        let finished = self.session.run(|c| queue::finished(c, &ids))?;
        for f in finished {
            if let Some((trial, which)) = self.waiting.remove(&f.id) {
                self.ready.push_back(Done {
                    trial,
                    which,
                    result: f.result,
                });
            }
        }
        Ok(())
    }

    /// Says on stderr why nothing finishes.
    fn complain(&mut self) -> Result<(), CampaignError> {
        let campaign = self.campaign;
        let started = self.session.run(|c| queue::started(c, campaign))?;
        let db = self.session.database().location().to_string();
        let secs = self.last_progress.elapsed().as_secs();
        if started == 0 {
            eprintln!(
                "savme: no worker has taken a run of campaign {:?} in {secs} s; {} runs are waiting. Start workers on any host with: savme worker --storage {db} --campaign {:?}",
                self.name,
                self.waiting.len(),
                self.name
            );
        } else {
            eprintln!(
                "savme: no run of campaign {:?} finished in {secs} s ({} waiting); are the workers still running? (savme worker --storage {db} --campaign {:?})",
                self.name,
                self.waiting.len(),
                self.name
            );
        }
        Ok(())
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
    /// Marks the campaign finished: idle workers exit.
    fn finish(mut self: Box<Self>) -> Result<(), CampaignError> {
        let campaign = self.campaign;
        self.session
            .run(|c| queue::set_finished(c, campaign, true))?;
        Ok(())
    }
}
