//! The work queue in `savme.runs`: every statement the coordinator and the `savme worker`
//! processes run on it, in one place.
//!
//! - the coordinator **submits** a run (an upsert on `(campaign, stage, trial, role)`: on
//!   `--resume` the same trials are asked again and find their rows — finished ones are used,
//!   not repeated) and `NOTIFY`s `savme_tasks_<campaign>`;
//! - a worker **claims** the oldest run that is queued or whose lease has expired (`FOR UPDATE
//!   SKIP LOCKED`: two workers never get the same row), holding a lease it renews by
//!   **heartbeat**;
//! - it **finishes** the run only while it still holds it (a worker whose lease expired and was
//!   taken over writes nothing), and `NOTIFY`s `savme_done_<campaign>` in the same
//!   transaction;
//! - the coordinator reads the **finished** rows of the runs it waits for.

use crate::campaign::executor::{Task, Which};
use postgres::{Client, GenericClient};
use savme_kernel::{Assignment, SimError, SimResult};
use std::time::Duration;

/// The channel workers listen on for new runs of campaign `id`.
pub fn tasks_channel(campaign: i32) -> String {
    format!("savme_tasks_{campaign}")
}

/// The channel the coordinator listens on for finished runs of campaign `id`.
pub fn done_channel(campaign: i32) -> String {
    format!("savme_done_{campaign}")
}

/// Submits `task` and wakes the workers; returns its row id. A row that failed before is
/// queued again.
pub fn submit(client: &mut Client, campaign: i32, task: &Task) -> Result<i64, postgres::Error> {
    let phi = serde_json::to_string(&task.phi).unwrap_or_default();
    let fidelity = serde_json::to_string(&task.fidelity).unwrap_or_default();
    let trial = task.trial as i64;
    let stage: &str = &task.stage;
    let scenario: &str = &task.scenario;
    // One round trip: the upsert, and the notification that wakes idle workers.
    let row = client.query_one(
        "WITH run AS (
            INSERT INTO savme.runs (campaign_id, stage, trial_id, role, scenario, phi, fidelity)
            VALUES ($1, $2, $3, $4, $5, $6::text::json, $7::text::json)
            ON CONFLICT (campaign_id, stage, trial_id, role) DO UPDATE
               SET state = CASE WHEN runs.state = 'failed' THEN 'queued' ELSE runs.state END,
                   error = CASE WHEN runs.state = 'failed' THEN NULL ELSE runs.error END
            RETURNING id, state)
         SELECT id, CASE WHEN state = 'queued' THEN pg_notify($8, '') END IS NULL FROM run",
        &[
            &campaign,
            &stage,
            &trial,
            &task.which.key(),
            &scenario,
            &phi,
            &fidelity,
            &tasks_channel(campaign),
        ],
    )?;
    Ok(row.get(0))
}

/// Wakes the workers listening for runs of `campaign`.
pub fn wake_workers(client: &mut Client, campaign: i32) -> Result<(), postgres::Error> {
    client
        .execute("SELECT pg_notify($1, '')", &[&tasks_channel(campaign)])
        .map(|_| ())
}

/// A finished run as the coordinator reads it.
#[derive(Debug)]
pub struct Finished {
    /// Its row id.
    pub id: i64,
    /// The result, or the simulator's error.
    pub result: Result<SimResult, SimError>,
}

/// The finished runs among `ids`.
pub fn finished(client: &mut Client, ids: &[i64]) -> Result<Vec<Finished>, postgres::Error> {
    let rows = client.query(
        "SELECT id, state, failure, wall_seconds, work, error FROM savme.runs
          WHERE id = ANY($1) AND state IN ('done', 'failed')",
        &[&ids],
    )?;
    Ok(rows
        .iter()
        .map(|r| {
            let state: &str = r.get(1);
            let result = if state == "done" {
                let work: Option<i64> = r.get(4);
                Ok(SimResult::new(
                    r.get::<_, Option<bool>>(2).unwrap_or(false),
                    r.get::<_, Option<f64>>(3).unwrap_or(0.0),
                    work.map(|w| w as u64),
                ))
            } else {
                Err(SimError::Failed(
                    r.get::<_, Option<String>>(5).unwrap_or_default(),
                ))
            };
            Finished {
                id: r.get(0),
                result,
            }
        })
        .collect())
}

/// How many runs of `campaign` a worker has ever started (to tell a coordinator whose workers
/// never showed up).
pub fn started(client: &mut Client, campaign: i32) -> Result<i64, postgres::Error> {
    Ok(client
        .query_one(
            "SELECT count(*) FROM savme.runs WHERE campaign_id = $1 AND attempts > 0",
            &[&campaign],
        )?
        .get(0))
}

/// Marks the campaign running (`finished = false`) or finished, waking idle workers so that
/// they can exit.
pub fn set_finished(
    client: &mut Client,
    campaign: i32,
    finished: bool,
) -> Result<(), postgres::Error> {
    client.execute(
        "UPDATE savme.campaigns SET finished_at = CASE WHEN $2 THEN now() END WHERE id = $1",
        &[&campaign, &finished],
    )?;
    wake_workers(client, campaign)
}

/// Whether the coordinator marked the campaign finished.
pub fn is_finished(client: &mut Client, campaign: i32) -> Result<bool, postgres::Error> {
    Ok(client
        .query_one(
            "SELECT finished_at IS NOT NULL FROM savme.campaigns WHERE id = $1",
            &[&campaign],
        )?
        .get(0))
}

/// A run a worker claimed.
#[derive(Debug, Clone)]
pub struct Claimed {
    /// Its row id.
    pub id: i64,
    /// The task, or why its row cannot be read (then the run fails with that message).
    pub task: Result<Task, String>,
    /// How many times it was claimed (this claim included).
    pub attempts: i32,
}

/// Claims the oldest run of `campaign` that is queued or whose lease expired, for `worker`,
/// with a lease of `lease`.
pub fn claim(
    client: &mut Client,
    campaign: i32,
    worker: &str,
    lease: Duration,
) -> Result<Option<Claimed>, postgres::Error> {
    let row = client.query_opt(
        "UPDATE savme.runs SET state = 'running', worker = $2, attempts = attempts + 1,
                lease_until = clock_timestamp() + make_interval(secs => $3),
                started_at = clock_timestamp()
          WHERE id = (SELECT id FROM savme.runs
                       WHERE campaign_id = $1
                         AND (state = 'queued' OR (state = 'running' AND lease_until < clock_timestamp()))
                       ORDER BY id LIMIT 1 FOR UPDATE SKIP LOCKED)
          RETURNING id, stage, trial_id, role, scenario, phi::text, fidelity::text, attempts",
        &[&campaign, &worker, &lease.as_secs_f64()],
    )?;
    let Some(r) = row else { return Ok(None) };
    let id: i64 = r.get(0);
    let parse = |column: usize, what: &str| -> Result<Assignment, String> {
        serde_json::from_str(r.get::<_, &str>(column))
            .map_err(|e| format!("savme.runs row {id}: `{what}` is not an assignment: {e}"))
    };
    let task = (|| {
        let which = match r.get::<_, &str>(3) {
            "lf" => Which::Lf,
            _ => Which::Hf,
        };
        Ok(Task {
            stage: r.get::<_, &str>(1).into(),
            trial: r.get::<_, i64>(2) as u64,
            which,
            scenario: r.get::<_, &str>(4).into(),
            phi: parse(5, "phi")?,
            fidelity: parse(6, "fidelity")?,
        })
    })();
    Ok(Some(Claimed {
        id,
        task,
        attempts: r.get(7),
    }))
}

/// Renews the leases of the runs `ids` that a worker whose name starts with `worker` (a
/// process: its threads' names extend it) still holds.
pub fn heartbeat(
    client: &mut Client,
    ids: &[i64],
    worker: &str,
    lease: Duration,
) -> Result<u64, postgres::Error> {
    client.execute(
        "UPDATE savme.runs SET lease_until = clock_timestamp() + make_interval(secs => $3)
          WHERE id = ANY($1) AND starts_with(worker, $2) AND state = 'running'",
        &[&ids, &worker, &lease.as_secs_f64()],
    )
}

/// Writes the result of run `id` if `worker` still holds it (false: its lease expired and
/// another worker took it over — the result is dropped), and tells the coordinator.
pub fn finish(
    client: &mut Client,
    campaign: i32,
    id: i64,
    worker: &str,
    result: &Result<SimResult, SimError>,
) -> Result<bool, postgres::Error> {
    let (state, failure, wall, work, error) = match result {
        Ok(r) => (
            "done",
            Some(r.failure),
            Some(r.wall_seconds),
            r.work.map(|w| w as i64),
            None,
        ),
        // Read back as `SimError::Failed(error)`: its own message, not "simulation failed: …"
        // twice.
        Err(SimError::Failed(m)) => ("failed", None, None, None, Some(m.clone())),
        Err(e) => ("failed", None, None, None, Some(e.to_string())),
    };
    // One statement (atomic, one round trip): the result, and the coordinator's wake-up.
    let rows = client.query(
        "WITH run AS (
            UPDATE savme.runs SET state = $3, failure = $4, wall_seconds = $5, work = $6,
                   error = $7, finished_at = clock_timestamp(), lease_until = NULL
             WHERE id = $1 AND worker = $2 AND state = 'running'
            RETURNING id)
         SELECT pg_notify($8, id::text) FROM run",
        &[
            &id,
            &worker,
            &state,
            &failure,
            &wall,
            &work,
            &error,
            &done_channel(campaign),
        ],
    )?;
    Ok(rows.len() == 1)
}

/// Starts listening on `channel` on this connection.
pub fn listen(client: &mut impl GenericClient, channel: &str) -> Result<(), postgres::Error> {
    // Channel names are savme's own (`savme_tasks_<id>`): safe to quote as identifiers.
    client.batch_execute(&format!("LISTEN \"{channel}\""))
}
