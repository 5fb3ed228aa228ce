//! The work queue in `savme.runs`: every statement the coordinator and the `savme worker`
//! processes run on it, in one place.
//!
//! - the coordinator **submits** the runs it asked for since it last waited, in one statement
//!   (an upsert on `(campaign, stage, trial, role)`: on
//!   `--resume` the same trials are asked again and find their rows — finished ones are used,
//!   not repeated) and `NOTIFY`s `savme_tasks_<campaign>`;
//! - a worker **claims** the oldest run that is queued or whose lease has expired (`FOR UPDATE
//!   SKIP LOCKED`: two workers never get the same row), holding a lease it renews by
//!   **heartbeat**;
//! - it **finishes** the run only while it still holds it (a worker whose lease expired and was
//!   taken over writes nothing), and `NOTIFY`s `savme_done_<campaign>` in the same
//!   transaction — and claims its next run in that same statement (one round trip per run);
//! - the coordinator reads the **finished** rows of the runs it waits for.

use super::Conn;
use postgres::{Client, GenericClient};
use savme_campaign::executor::Task;
use savme_kernel::Role;
use savme_kernel::{Assignment, SimError, SimResult};
use std::sync::OnceLock;
use std::time::Duration;

/// The channel workers listen on for new runs of campaign `id`.
pub fn tasks_channel(campaign: i32) -> String {
    format!("savme_tasks_{campaign}")
}

/// The channel the coordinator listens on for finished runs of campaign `id`.
pub fn done_channel(campaign: i32) -> String {
    format!("savme_done_{campaign}")
}

/// The upsert of a batch of runs (arrays of their fields), waking idle workers in the same
/// statement (identical notifications of one transaction are delivered once). A row that failed
/// before is queued again; a finished one is left as it is (on `--resume` its result is used).
pub(crate) const SUBMIT: &str = "WITH run AS (
    INSERT INTO savme.runs (campaign_id, stage, trial_id, role, scenario, phi, fidelity)
    SELECT $1, u.stage, u.trial, u.role, u.scenario, u.phi::json, u.fidelity::json
      FROM unnest($2::text[], $3::bigint[], $4::text[], $5::text[], $6::text[], $7::text[])
           AS u(stage, trial, role, scenario, phi, fidelity)
    ON CONFLICT (campaign_id, stage, trial_id, role) DO UPDATE
       SET state = CASE WHEN runs.state = 'failed' THEN 'queued' ELSE runs.state END,
           error = CASE WHEN runs.state = 'failed' THEN NULL ELSE runs.error END
    RETURNING id, stage, trial_id, role, state)
 SELECT id, stage, trial_id, role, CASE WHEN state = 'queued' THEN pg_notify($8, '') END IS NULL
   FROM run";

/// Submits `tasks` (each a distinct run) in one statement (`statement`: [`SUBMIT`] prepared on
/// the connection) and wakes the workers; returns each task's row id, in the order of `tasks`.
pub(crate) fn submit(
    c: &mut impl GenericClient,
    statement: &postgres::Statement,
    campaign: i32,
    tasks: &[Task],
) -> Result<Vec<i64>, postgres::Error> {
    if tasks.is_empty() {
        return Ok(Vec::new());
    }
    let json = |a: &Assignment| serde_json::to_string(a).unwrap_or_default();
    let stages: Vec<&str> = tasks.iter().map(|t| &*t.stage).collect();
    let trials: Vec<i64> = tasks.iter().map(|t| t.trial as i64).collect();
    let roles: Vec<&str> = tasks.iter().map(|t| t.which.key()).collect();
    let scenarios: Vec<&str> = tasks.iter().map(|t| &*t.scenario).collect();
    let phis: Vec<String> = tasks.iter().map(|t| json(&t.phi)).collect();
    let fidelities: Vec<String> = tasks.iter().map(|t| json(&t.fidelity)).collect();
    let rows = c.query(
        statement,
        &[
            &campaign,
            &stages,
            &trials,
            &roles,
            &scenarios,
            &phis,
            &fidelities,
            &tasks_channel(campaign),
        ],
    )?;
    // The rows come back in no promised order: match them to the tasks by their key.
    let ids: std::collections::HashMap<(String, i64, String), i64> = rows
        .iter()
        .map(|r| ((r.get(1), r.get(2), r.get(3)), r.get(0)))
        .collect();
    Ok(tasks
        .iter()
        .map(|t| {
            let key = (
                t.stage.to_string(),
                t.trial as i64,
                t.which.key().to_string(),
            );
            ids.get(&key).copied().unwrap_or(-1)
        })
        .collect())
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
pub fn finished(c: &mut Conn<'_>, ids: &[i64]) -> Result<Vec<Finished>, postgres::Error> {
    let statement = c.prepared(
        "SELECT id, state, failure, wall_seconds, work, error, robustness FROM savme.runs
          WHERE id = ANY($1) AND state IN ('done', 'failed')",
    )?;
    let rows = c.query(&statement, &[&ids])?;
    Ok(rows
        .iter()
        .map(|r| {
            let state: &str = r.get(1);
            let result = if state == "done" {
                let work: Option<i64> = r.get(4);
                let result = SimResult::new(
                    r.get::<_, Option<bool>>(2).unwrap_or(false),
                    r.get::<_, Option<f64>>(3).unwrap_or(0.0),
                    work.map(|w| w as u64),
                );
                Ok(match r.get::<_, Option<f64>>(6) {
                    Some(rho) => result.with_robustness(rho),
                    None => result,
                })
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
pub fn is_finished(c: &mut Conn<'_>, campaign: i32) -> Result<bool, postgres::Error> {
    let statement =
        c.prepared("SELECT finished_at IS NOT NULL FROM savme.campaigns WHERE id = $1")?;
    Ok(c.query_one(&statement, &[&campaign])?.get(0))
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

/// The claim of the oldest run of campaign `$1` that is queued or whose lease expired, for
/// worker `$2` with a lease of `$3` seconds (`exclude`: a further condition on the row).
fn claim_sql(exclude: &str) -> String {
    format!(
        "UPDATE savme.runs SET state = 'running', worker = $2, attempts = attempts + 1,
                lease_until = clock_timestamp() + make_interval(secs => $3),
                started_at = clock_timestamp()
          WHERE id = (SELECT id FROM savme.runs
                       WHERE campaign_id = $1 {exclude}
                         AND (state = 'queued' OR (state = 'running' AND lease_until < clock_timestamp()))
                       ORDER BY id LIMIT 1 FOR UPDATE SKIP LOCKED)
          RETURNING id, stage, trial_id, role, scenario, phi::text, fidelity::text, attempts"
    )
}

/// Claims the oldest run of `campaign` that is queued or whose lease expired, for `worker`,
/// with a lease of `lease`.
pub fn claim(
    c: &mut Conn<'_>,
    campaign: i32,
    worker: &str,
    lease: Duration,
) -> Result<Option<Claimed>, postgres::Error> {
    static SQL: OnceLock<String> = OnceLock::new();
    let statement = c.prepared(SQL.get_or_init(|| claim_sql("")))?;
    let row = c.query_opt(&statement, &[&campaign, &worker, &lease.as_secs_f64()])?;
    Ok(row.and_then(|r| claimed(&r, 0)))
}

/// The run claimed in columns `at..at + 8` of `r` (none if its id is NULL).
fn claimed(r: &postgres::Row, at: usize) -> Option<Claimed> {
    let id: i64 = r.get::<_, Option<i64>>(at)?;
    let parse = |column: usize, what: &str| -> Result<Assignment, String> {
        serde_json::from_str(r.get::<_, &str>(at + column))
            .map_err(|e| format!("savme.runs row {id}: `{what}` is not an assignment: {e}"))
    };
    let task = (|| {
        let key = r.get::<_, &str>(at + 3);
        let which = Role::from_key(key).ok_or_else(|| {
            format!("savme.runs row {id}: role {key:?} is neither \"hf\" nor \"lf\"")
        })?;
        Ok(Task {
            stage: r.get::<_, &str>(at + 1).into(),
            trial: r.get::<_, i64>(at + 2) as u64,
            which,
            scenario: r.get::<_, &str>(at + 4).into(),
            phi: parse(5, "phi")?,
            fidelity: parse(6, "fidelity")?,
        })
    })();
    Some(Claimed {
        id,
        task,
        attempts: r.get(at + 7),
    })
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
/// another worker took it over — the result is dropped), tells the coordinator, and claims the
/// worker's next run (as [`claim`], lease `lease`) — one statement, one round trip per run.
pub fn finish_and_claim(
    c: &mut Conn<'_>,
    campaign: i32,
    id: i64,
    worker: &str,
    result: &Result<SimResult, SimError>,
    lease: Duration,
) -> Result<(bool, Option<Claimed>), postgres::Error> {
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
    let robustness = result.as_ref().ok().and_then(|r| r.robustness);
    // The finished row is still `running` in the statement's snapshot (and excluded), so the
    // claim takes another. `note` runs only because the final SELECT reads it.
    static SQL: OnceLock<String> = OnceLock::new();
    let sql = SQL.get_or_init(|| {
        format!(
            "WITH fin AS (
                UPDATE savme.runs SET state = $5, failure = $6, wall_seconds = $7, work = $8,
                       error = $9, robustness = $11, finished_at = clock_timestamp(),
                       lease_until = NULL
                 WHERE id = $4 AND worker = $2 AND state = 'running'
                RETURNING id),
             note AS (SELECT pg_notify($10, id::text) FROM fin),
             next AS ({})
             SELECT (SELECT count(*) FROM note), next.* FROM (SELECT 1) AS one LEFT JOIN next ON true",
            claim_sql("AND id <> $4")
        )
    });
    let statement = c.prepared(sql)?;
    let row = c.query_one(
        &statement,
        &[
            &campaign,
            &worker,
            &lease.as_secs_f64(),
            &id,
            &state,
            &failure,
            &wall,
            &work,
            &error,
            &done_channel(campaign),
            &robustness,
        ],
    )?;
    Ok((row.get::<_, i64>(0) == 1, claimed(&row, 1)))
}

/// Queues run `id` again if `worker` still holds it (a stopping worker hands back a run it
/// claimed but did not start; the claim does not count as an attempt).
pub fn release(c: &mut Conn<'_>, id: i64, worker: &str) -> Result<u64, postgres::Error> {
    let statement = c.prepared(
        "UPDATE savme.runs SET state = 'queued', lease_until = NULL, started_at = NULL,
                attempts = greatest(attempts - 1, 0)
          WHERE id = $1 AND worker = $2 AND state = 'running'",
    )?;
    c.execute(&statement, &[&id, &worker])
}

/// Starts listening on `channel` on this connection.
pub fn listen(client: &mut impl GenericClient, channel: &str) -> Result<(), postgres::Error> {
    // Channel names are savme's own (`savme_tasks_<id>`): safe to quote as identifiers.
    client.batch_execute(&format!("LISTEN \"{channel}\""))
}

/// Lets database role `role` work on `campaign` (false: there is no such role).
pub fn add_worker_role(
    client: &mut Client,
    campaign: i32,
    role: &str,
) -> Result<bool, postgres::Error> {
    let exists: bool = client
        .query_one(
            "SELECT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = $1)",
            &[&role],
        )?
        .get(0);
    if exists {
        client.execute(
            "INSERT INTO savme.campaign_workers (campaign_id, role) VALUES ($1, $2::text::name)
             ON CONFLICT DO NOTHING",
            &[&campaign, &role],
        )?;
    }
    Ok(exists)
}

/// Marks `campaign` as run through the queue by a live coordinator (not finished, seen now,
/// resumed by `resume`) and wakes its workers.
pub fn start_remote(
    client: &mut Client,
    campaign: i32,
    resume: &str,
) -> Result<(), postgres::Error> {
    client.execute(
        "UPDATE savme.campaigns SET finished_at = NULL, remote = true,
                coordinator_seen_at = clock_timestamp(), resume_command = $2
          WHERE id = $1",
        &[&campaign, &resume],
    )?;
    wake_workers(client, campaign)
}

/// Marks `campaign` as held by a coordinator that runs its trials itself (no `--remote`).
pub fn start_local(client: &mut Client, campaign: i32) -> Result<(), postgres::Error> {
    client
        .execute(
            "UPDATE savme.campaigns SET remote = false, coordinator_seen_at = NULL WHERE id = $1",
            &[&campaign],
        )
        .map(|_| ())
}

/// The coordinator's heartbeat (not waited for on disk: a lost stamp is harmless).
pub fn coordinator_seen(client: &mut Client, campaign: i32) -> Result<(), postgres::Error> {
    client.batch_execute("SET synchronous_commit = off")?;
    client
        .execute(
            "UPDATE savme.campaigns SET coordinator_seen_at = clock_timestamp() WHERE id = $1",
            &[&campaign],
        )
        .map(|_| ())
}

/// What a worker knows of its campaign's coordinator.
#[derive(Debug, Clone, PartialEq)]
pub struct Coordinator {
    /// The campaign is finished.
    pub finished: bool,
    /// A coordinator runs it through the queue (`--remote`).
    pub remote: bool,
    /// Seconds since the coordinator's last heartbeat (None: never).
    pub seen_ago: Option<f64>,
    /// A session holds the campaign's coordinator lock.
    pub locked: bool,
    /// The command that resumes it, as its coordinator stored it.
    pub resume_command: Option<String>,
}

/// The state of `campaign`'s coordinator (None: the campaign's row is gone, or this role may no
/// longer see it).
pub fn coordinator(
    c: &mut Conn<'_>,
    campaign: i32,
) -> Result<Option<Coordinator>, postgres::Error> {
    let statement = c.prepared(
        "SELECT finished_at IS NOT NULL, remote,
                extract(epoch FROM clock_timestamp() - coordinator_seen_at)::float8,
                EXISTS (SELECT 1 FROM pg_locks l WHERE l.locktype = 'advisory' AND l.granted
                          AND l.objsubid = 2 AND l.classid = 29558::oid AND l.objid = id::oid),
                resume_command
           FROM savme.campaigns WHERE id = $1",
    )?;
    let row = c.query_opt(&statement, &[&campaign])?;
    Ok(row.map(|r| Coordinator {
        finished: r.get(0),
        remote: r.get(1),
        seen_ago: r.get(2),
        locked: r.get(3),
        resume_command: r.get(4),
    }))
}

/// Whether run `id` is finished and was last held by `worker` (its result is the one stored:
/// after a reconnect, the finish that seemed lost had committed).
pub fn finished_by(c: &mut Conn<'_>, id: i64, worker: &str) -> Result<bool, postgres::Error> {
    let row = c.query_opt(
        "SELECT state IN ('done', 'failed') AND worker = $2 FROM savme.runs WHERE id = $1",
        &[&id, &worker],
    )?;
    Ok(row.is_some_and(|r| r.get(0)))
}

/// The window of `campaign`'s stored protocol (trials in flight at once), if saved.
pub fn window(client: &mut Client, campaign: i32) -> Result<Option<i64>, postgres::Error> {
    Ok(client
        .query_opt(
            "SELECT (protocol->>'window')::bigint FROM savme.campaigns WHERE id = $1",
            &[&campaign],
        )?
        .and_then(|r| r.get(0)))
}
