-- Version 4 (issue 41): workers act through functions, not tables; the coordinator's lock is a
-- row a worker cannot write; results are checked by the server.
--
-- The worker functions are SECURITY DEFINER: they run as their owner (the owner of savme's
-- tables, the role that migrates the schema) with a pinned search_path, check once per call
-- that the calling session's role (session_user: set by the server at login, not by the
-- client) may work on the campaign, and touch only that campaign's rows. A worker role needs
-- EXECUTE on them (savme.grant_worker) and no right on any table.

-- Who claimed a run: the session's role, and the worker process's secret (a random token
-- only that process knows: another worker cannot finish, renew or hand back the run); when
-- its holder last showed it was alive (the claim or a lease renewal).
ALTER TABLE savme.runs
    ADD COLUMN claimed_by name,
    ADD COLUMN token      text,
    ADD COLUMN seen_at    timestamptz;

-- The coordinator's lock: one row per campaign naming the server session that holds it (its
-- backend pid and start time, its role as the server authenticated it). The lock is held
-- while that session lives; only a role that may write this table (a coordinator) takes it.
CREATE TABLE savme.coordinators (
    campaign_id   integer PRIMARY KEY REFERENCES savme.campaigns (id) ON DELETE CASCADE,
    pid           integer NOT NULL,
    backend_start timestamptz NOT NULL,
    usename       name NOT NULL,
    application   text,
    client        text,
    taken_at      timestamptz NOT NULL DEFAULT clock_timestamp()
);

-- (The functions are PL/pgSQL, not SQL: PL/pgSQL keeps its statements' plans for the
-- session, whereas a SQL function with a SET clause is planned again at every call. The
-- internal helpers the worker functions call — savme.may_work, check_worker, check_lease,
-- take_run, bad_result — have no SET clause and no SECURITY DEFINER: they run inside a worker
-- function, as its owner and with its pinned search_path, without the cost of switching
-- either again; called directly they run with the caller's rights, and a worker role may not
-- call those that touch a table.)

-- Whether the session of lock row (pid, backend start) is alive.
CREATE FUNCTION savme.session_alive(p_pid integer, p_start timestamptz) RETURNS boolean
  LANGUAGE plpgsql STABLE SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  RETURN EXISTS (SELECT 1 FROM pg_stat_activity a
                  WHERE a.pid = p_pid
                    AND (a.backend_start = p_start OR a.backend_start IS NULL));
END $$;

-- Takes campaign p_campaign's coordinator lock for this session (true), unless a live session
-- holds it (false). Runs with the caller's rights: a role that may not write
-- savme.coordinators (a worker) cannot take it.
CREATE FUNCTION savme.take_lock(p_campaign integer) RETURNS boolean
  LANGUAGE sql VOLATILE SET search_path = pg_catalog, pg_temp AS $$
    INSERT INTO savme.coordinators AS l (campaign_id, pid, backend_start, usename, application, client)
    SELECT p_campaign, a.pid, a.backend_start, session_user, a.application_name,
           coalesce(host(a.client_addr), 'local socket')
      FROM pg_stat_activity a WHERE a.pid = pg_backend_pid()
    ON CONFLICT (campaign_id) DO UPDATE
       SET pid = excluded.pid, backend_start = excluded.backend_start, usename = excluded.usename,
           application = excluded.application, client = excluded.client,
           taken_at = clock_timestamp()
     WHERE (l.pid = excluded.pid AND l.backend_start = excluded.backend_start)
        OR NOT savme.session_alive(l.pid, l.backend_start)
    RETURNING true $$;

-- Whether a live session holds campaign p_campaign's coordinator lock.
CREATE FUNCTION savme.locked(p_campaign integer) RETURNS boolean
  LANGUAGE plpgsql STABLE SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  RETURN EXISTS (SELECT 1 FROM savme.coordinators l
                  WHERE l.campaign_id = p_campaign AND savme.session_alive(l.pid, l.backend_start));
END $$;

-- Whether the calling session's role may work on campaign p_campaign: a coordinator (a role
-- that may write trials) on any, any other role on the campaigns it (or a role it belongs
-- to) is listed for in savme.campaign_workers.
CREATE FUNCTION savme.may_work(p_campaign integer) RETURNS boolean
  LANGUAGE plpgsql STABLE AS $$
BEGIN
  RETURN has_table_privilege(session_user, 'savme.trials', 'INSERT')
      OR EXISTS (SELECT 1 FROM savme.campaign_workers w JOIN pg_roles r ON r.rolname = w.role
                  WHERE w.campaign_id = p_campaign AND pg_has_role(session_user, r.oid, 'MEMBER'));
END $$;

-- Raises unless the calling session's role may work on campaign p_campaign.
CREATE FUNCTION savme.check_worker(p_campaign integer) RETURNS void
  LANGUAGE plpgsql STABLE AS $$
BEGIN
  IF NOT savme.may_work(p_campaign) THEN
    RAISE EXCEPTION 'savme: role % may not work on campaign %', session_user, p_campaign
      USING ERRCODE = '42501',
            HINT = 'its coordinator lists the roles allowed on it: --worker-role ROLE';
  END IF;
END $$;

-- Raises unless p_lease (seconds) is a lease a worker may take: more than 0, at most an hour.
CREATE FUNCTION savme.check_lease(p_lease double precision, p_worker text) RETURNS void
  LANGUAGE plpgsql STABLE AS $$
BEGIN
  IF p_lease IS NULL OR NOT (p_lease > 0 AND p_lease <= 3600) THEN
    RAISE EXCEPTION 'savme: worker %: a lease of % s is refused (more than 0 and at most 3600 s)',
      p_worker, p_lease USING ERRCODE = '22023';
  END IF;
END $$;

-- The campaign p_name as a worker sees it (no row: none, or this role may not work on it).
CREATE FUNCTION savme.worker_campaign(p_name text)
  RETURNS TABLE (id integer, simulator text, "window" bigint, finished boolean)
  LANGUAGE sql STABLE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
    SELECT c.id, c.protocol->>'simulator', (c.protocol->>'window')::bigint, c.finished_at IS NOT NULL
      FROM savme.campaigns c WHERE c.name = p_name AND savme.may_work(c.id) $$;

-- The campaign's coordinator as its workers see it (no row: gone, or not allowed). Whether a
-- live session holds its lock is looked up (in pg_stat_activity) only when its heartbeat is
-- older than a second: a fresh heartbeat comes from a live coordinator, and every worker asks
-- four times a second.
CREATE FUNCTION savme.coordinator_state(p_campaign integer)
  RETURNS TABLE (finished boolean, remote boolean, seen_ago double precision, locked boolean,
                 resume_command text)
  LANGUAGE plpgsql STABLE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  RETURN QUERY
    SELECT c.finished_at IS NOT NULL, c.remote,
           extract(epoch FROM clock_timestamp() - c.coordinator_seen_at)::float8,
           CASE WHEN c.remote AND c.coordinator_seen_at > clock_timestamp() - interval '1 second'
                THEN true ELSE savme.locked(c.id) END,
           c.resume_command
      FROM savme.campaigns c WHERE c.id = p_campaign AND savme.may_work(c.id);
END $$;

-- Claims the oldest run of p_campaign that is queued or whose lease expired (never run
-- p_except), for worker p_worker of the process holding p_token, with a lease of p_lease s.
-- Internal: called by savme.claim and savme.finish_and_claim after their checks.
CREATE FUNCTION savme.take_run(p_campaign integer, p_worker text, p_token text,
                               p_lease double precision, p_except bigint)
  RETURNS TABLE (id bigint, stage text, trial_id bigint, role text, scenario text, phi text,
                 fidelity text, attempts integer)
  LANGUAGE plpgsql VOLATILE AS $$
#variable_conflict use_column
BEGIN
  RETURN QUERY
    UPDATE savme.runs u SET state = 'running', worker = p_worker, token = p_token,
           claimed_by = session_user, attempts = u.attempts + 1,
           lease_until = clock_timestamp() + make_interval(secs => p_lease),
           started_at = clock_timestamp(), seen_at = clock_timestamp()
     WHERE u.id = (SELECT r.id FROM savme.runs r
                    WHERE r.campaign_id = p_campaign AND r.id <> p_except
                      AND (r.state = 'queued' OR (r.state = 'running' AND r.lease_until < clock_timestamp()))
                    ORDER BY r.id LIMIT 1 FOR UPDATE SKIP LOCKED)
    RETURNING u.id, u.stage, u.trial_id, u.role, u.scenario, u.phi::text, u.fidelity::text, u.attempts;
END $$;

CREATE FUNCTION savme.claim(p_campaign integer, p_worker text, p_token text,
                            p_lease double precision)
  RETURNS TABLE (id bigint, stage text, trial_id bigint, role text, scenario text, phi text,
                 fidelity text, attempts integer)
  LANGUAGE plpgsql VOLATILE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  PERFORM savme.check_worker(p_campaign);
  PERFORM savme.check_lease(p_lease, p_worker);
  RETURN QUERY SELECT * FROM savme.take_run(p_campaign, p_worker, p_token, p_lease, -1);
END $$;

-- Why a result is refused (NULL: it is acceptable), for campaign p_campaign.
CREATE FUNCTION savme.bad_result(p_campaign integer, p_state text, p_failure boolean,
                                 p_wall double precision, p_work bigint, p_error text,
                                 p_robustness double precision) RETURNS text
  LANGUAGE plpgsql STABLE AS $$
BEGIN
  RETURN CASE
      WHEN p_state IS NULL OR p_state NOT IN ('done', 'failed')
        THEN format('state %L is neither done nor failed', p_state)
      WHEN p_state = 'failed' AND p_error IS NULL THEN 'a failed run must say why (error is NULL)'
      WHEN p_state = 'failed' THEN NULL
      WHEN p_failure IS NULL THEN 'failure is NULL (true or false: did the system fail?)'
      WHEN p_wall IS NULL OR NOT (p_wall >= 0 AND p_wall < 'Infinity'::float8)
        THEN format('wall_seconds = %s is not a finite number of seconds >= 0', coalesce(p_wall::text, 'NULL'))
      WHEN p_work < 0 THEN format('work = %s is negative', p_work)
      WHEN p_work IS NULL AND (SELECT c.protocol->>'cost' FROM savme.campaigns c WHERE c.id = p_campaign) = 'work'
        THEN 'work is NULL, but this campaign''s cost is work units'
      WHEN p_robustness IS NOT NULL AND NOT (p_robustness > '-Infinity'::float8 AND p_robustness < 'Infinity'::float8)
        THEN format('robustness = %s is not finite', p_robustness)
      WHEN p_error IS NOT NULL THEN 'a done run has no error'
    END;
END $$;

-- Writes the result of run p_id, which worker p_worker of the process holding p_token claimed,
-- and tells the coordinator (kept = false: the run is no longer this worker's — its lease
-- expired and another took it, or it is finished); then, if p_claim, claims the worker's next
-- run. A result that is not acceptable (savme.bad_result), or a run claimed by another
-- process under the same worker name, is refused with an error naming the run and the worker.
CREATE FUNCTION savme.finish_and_claim(p_campaign integer, p_id bigint, p_worker text,
                                       p_token text, p_state text, p_failure boolean,
                                       p_wall double precision, p_work bigint, p_error text,
                                       p_robustness double precision,
                                       p_lease double precision, p_claim boolean)
  RETURNS TABLE (kept boolean, id bigint, stage text, trial_id bigint, role text, scenario text,
                 phi text, fidelity text, attempts integer)
  LANGUAGE plpgsql VOLATILE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
#variable_conflict use_column
DECLARE
  r savme.runs%ROWTYPE;
  bad text;
  held boolean := false;
BEGIN
  PERFORM savme.check_worker(p_campaign);
  PERFORM savme.check_lease(p_lease, p_worker);
  SELECT * INTO r FROM savme.runs WHERE savme.runs.id = p_id FOR UPDATE;
  IF NOT FOUND OR r.campaign_id <> p_campaign THEN
    RAISE EXCEPTION 'savme: refused a result from worker %: campaign % has no run %',
      p_worker, p_campaign, p_id USING ERRCODE = 'SV001';
  END IF;
  IF r.state = 'running' AND r.worker = p_worker THEN
    IF r.token IS DISTINCT FROM p_token OR r.claimed_by IS DISTINCT FROM session_user THEN
      RAISE EXCEPTION 'savme: refused the result of run % (stage %, trial %, %) from worker %: the run was claimed by another process (role %), not by this session (role %)',
        p_id, r.stage, r.trial_id, r.role, p_worker, r.claimed_by, session_user
        USING ERRCODE = 'SV001';
    END IF;
    bad := savme.bad_result(p_campaign, p_state, p_failure, p_wall, p_work, p_error, p_robustness);
    IF bad IS NOT NULL THEN
      RAISE EXCEPTION 'savme: refused the result of run % (stage %, trial %, %) from worker %: %',
        p_id, r.stage, r.trial_id, r.role, p_worker, bad USING ERRCODE = 'SV001';
    END IF;
    UPDATE savme.runs
       SET state = p_state,
           failure = CASE WHEN p_state = 'done' THEN p_failure END,
           wall_seconds = CASE WHEN p_state = 'done' THEN p_wall END,
           work = CASE WHEN p_state = 'done' THEN p_work END,
           robustness = CASE WHEN p_state = 'done' THEN p_robustness END,
           error = CASE WHEN p_state = 'failed' THEN p_error END,
           finished_at = clock_timestamp(), lease_until = NULL
     WHERE savme.runs.id = p_id;
    PERFORM pg_notify('savme_done_' || p_campaign, p_id::text);
    held := true;
  END IF;
  IF p_claim THEN
    RETURN QUERY SELECT held, t.* FROM (SELECT 1) AS one
      LEFT JOIN savme.take_run(p_campaign, p_worker, p_token, p_lease, p_id) AS t ON true;
  ELSE
    RETURN QUERY SELECT held, NULL::bigint, NULL::text, NULL::bigint, NULL::text, NULL::text,
                        NULL::text, NULL::text, NULL::integer;
  END IF;
END $$;

-- Renews the leases of the runs p_ids that the process holding p_token still holds (how
-- many).
CREATE FUNCTION savme.renew(p_campaign integer, p_ids bigint[], p_token text,
                            p_lease double precision) RETURNS integer
  LANGUAGE plpgsql VOLATILE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
DECLARE n integer;
BEGIN
  PERFORM savme.check_worker(p_campaign);
  PERFORM savme.check_lease(p_lease, 'heartbeat');
  UPDATE savme.runs SET lease_until = clock_timestamp() + make_interval(secs => p_lease),
                        seen_at = clock_timestamp()
   WHERE id = ANY (p_ids) AND campaign_id = p_campaign AND state = 'running'
     AND token = p_token AND claimed_by = session_user;
  GET DIAGNOSTICS n = ROW_COUNT;
  RETURN n;
END $$;

-- Queues run p_id again if worker p_worker of the process holding p_token still holds it (a
-- stopping worker hands back a run it claimed but did not start).
CREATE FUNCTION savme.release(p_campaign integer, p_id bigint, p_worker text, p_token text)
  RETURNS integer
  LANGUAGE plpgsql VOLATILE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
DECLARE n integer;
BEGIN
  PERFORM savme.check_worker(p_campaign);
  UPDATE savme.runs SET state = 'queued', lease_until = NULL, started_at = NULL,
                        attempts = greatest(attempts - 1, 0), token = NULL
   WHERE id = p_id AND campaign_id = p_campaign AND worker = p_worker AND state = 'running'
     AND token = p_token AND claimed_by = session_user;
  GET DIAGNOSTICS n = ROW_COUNT;
  RETURN n;
END $$;

-- Whether run p_id is finished and was last held by worker p_worker of the process holding
-- p_token (after a reconnect: the finish that seemed lost had committed).
CREATE FUNCTION savme.finished_by(p_campaign integer, p_id bigint, p_worker text, p_token text)
  RETURNS boolean
  LANGUAGE plpgsql STABLE SECURITY DEFINER SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  PERFORM savme.check_worker(p_campaign);
  RETURN coalesce((SELECT state IN ('done', 'failed') AND worker = p_worker AND token = p_token
                     FROM savme.runs WHERE id = p_id AND campaign_id = p_campaign), false);
END $$;

-- What a worker role may call: the functions above that check the caller, nothing else.
REVOKE ALL ON FUNCTION savme.may_work(integer), savme.check_worker(integer),
    savme.bad_result(integer, text, boolean, double precision, bigint, text, double precision),
    savme.worker_campaign(text), savme.coordinator_state(integer),
    savme.take_run(integer, text, text, double precision, bigint),
    savme.claim(integer, text, text, double precision),
    savme.finish_and_claim(integer, bigint, text, text, text, boolean, double precision, bigint,
                           text, double precision, double precision, boolean),
    savme.renew(integer, bigint[], text, double precision),
    savme.release(integer, bigint, text, text),
    savme.finished_by(integer, bigint, text, text) FROM PUBLIC;

-- Lets role p_role work through the functions (usage of the schema, EXECUTE on the worker
-- functions) and takes away any right it had on savme's tables (a worker of savme 0.1 read
-- and updated them directly under row-level security). Run by the schema's owner.
CREATE FUNCTION savme.grant_worker(p_role name) RETURNS void
  LANGUAGE plpgsql VOLATILE SET search_path = pg_catalog, pg_temp AS $$
BEGIN
  EXECUTE format('GRANT USAGE ON SCHEMA savme TO %I', p_role);
  EXECUTE format('GRANT EXECUTE ON FUNCTION savme.worker_campaign(text),
      savme.coordinator_state(integer), savme.claim(integer, text, text, double precision),
      savme.finish_and_claim(integer, bigint, text, text, text, boolean, double precision,
                             bigint, text, double precision, double precision, boolean),
      savme.renew(integer, bigint[], text, double precision),
      savme.release(integer, bigint, text, text),
      savme.finished_by(integer, bigint, text, text) TO %I', p_role);
  IF NOT has_table_privilege(p_role, 'savme.trials', 'INSERT') THEN
    EXECUTE format('REVOKE ALL ON savme.runs, savme.campaigns, savme.campaign_workers, savme.coordinators FROM %I', p_role);
  END IF;
END $$;
REVOKE ALL ON FUNCTION savme.grant_worker(name) FROM PUBLIC;

-- The worker roles of existing campaigns move to the functions.
DO $$
DECLARE w record;
BEGIN
  FOR w IN SELECT DISTINCT c.role FROM savme.campaign_workers c JOIN pg_roles r ON r.rolname = c.role
            WHERE NOT has_table_privilege(r.oid, 'savme.trials', 'INSERT') LOOP
    PERFORM savme.grant_worker(w.role);
  END LOOP;
END $$;

-- The functions run as the owner of savme's tables (not as whoever migrated, e.g. a
-- superuser).
DO $$
DECLARE owner name := (SELECT tableowner FROM pg_tables WHERE schemaname = 'savme' AND tablename = 'runs');
        f record;
BEGIN
  FOR f IN SELECT p.oid::regprocedure AS sig FROM pg_proc p JOIN pg_namespace n ON n.oid = p.pronamespace
            WHERE n.nspname = 'savme' AND p.prosecdef LOOP
    EXECUTE format('ALTER FUNCTION %s OWNER TO %I', f.sig, owner);
  END LOOP;
END $$;
