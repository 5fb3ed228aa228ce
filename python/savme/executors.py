"""Executors: where a campaign's simulator runs execute, when not on local threads.

``savme.Campaign(protocol, problem, executor=savme.RayExecutor(address=...))`` keeps the kernel,
the store and the campaign loop in this process (the *driver*) and runs each HF and LF run of a
Python simulator on a Ray cluster — as a Ray task, or on one of a pool of Ray actors that each
hold one simulator instance (``actors=N``: for simulators that are expensive to start). The
trials are told in ask order, so the same seed gives the same trials as a local run under
``cost="work"`` (under wall-clock cost, the measured runtimes differ as they do between two
local runs).

Ray is an optional dependency: ``pip install ray`` (or ``"ray[default]"`` for the dashboard) on
the driver and on every node; ``import savme`` never imports it.

Semantics, per run:

- **timeout** (``timeout=`` seconds): a run still going after that long is stopped (its Ray
  worker process is killed: the task cancelled with ``force=True``, or the actor restarted) and
  fails with "timed out" — what follows is the protocol's ``on_error``: ``"abort"`` stops the
  campaign naming the trial, ``"skip"`` withdraws the trial (replaced by a new one). The clock
  starts when the run is handed to Ray; at most one run per free worker slot is handed over,
  so it measures the run, plus Ray's dispatch (milliseconds) and, on first use, the start of a
  worker process (about a second).
- **a lost worker** (the process running the run died — killed, out of memory, its node gone):
  the run is re-run once, on any worker; its trial is told once, with the re-run's result. A run
  whose worker is lost twice fails ("lost twice"), then ``on_error`` applies.
- **an exception** raised by the simulator fails the run (``on_error``), with the exception's
  type and message, as a local run does.

Any object with ``start``, ``submit``, ``poll`` and ``finish`` methods can be an executor (see
``savme._savme``'s ``executor`` module documentation for their contract); ``RayExecutor`` is the
one savme ships.
"""

from __future__ import annotations

import collections
import logging
import os
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Deque, Dict, List, Optional, Tuple, Type

__all__ = ["RayExecutor"]

log = logging.getLogger("savme.ray")

# How long `finish` lets the runs still in flight end on their own before force-cancelling them.
_FINISH_GRACE_S = 2.0

Outcome = Tuple[Any, ...]
Polled = List[Tuple[int, str, Outcome]]


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as e:  # pragma: no cover - the message is the point
        raise ImportError(
            "savme.RayExecutor needs Ray: pip install ray (on the driver and on every node of "
            "the cluster, the same version)"
        ) from e
    return ray


def _call(sims: Tuple[Callable[..., Any], Callable[..., Any]], which: str, scenario: str,
          phi: Dict[str, Any], theta: Dict[str, Any]) -> Outcome:
    """One run, on a Ray worker: the callable's result and wall time, or what it raised."""
    f = sims[0] if which == "hf" else sims[1]
    start = time.perf_counter()
    try:
        out = f(scenario, phi, theta)
    except Exception as e:  # the simulator's own failure: the run fails, per on_error
        return ("raised", f"{type(e).__name__}: {e}")
    return ("ok", out, time.perf_counter() - start)


class _SimulatorActor:
    """One simulator instance kept across runs (``RayExecutor(actors=N)``)."""

    def __init__(self, hf: Callable[..., Any], lf: Callable[..., Any]) -> None:
        self.sims = (hf, lf)

    def run(self, which: str, scenario: str, phi: Dict[str, Any],
            theta: Dict[str, Any]) -> Outcome:
        return _call(self.sims, which, scenario, phi, theta)

    def pid(self) -> int:
        return os.getpid()


@dataclass
class _Run:
    trial: int
    which: str
    args: Tuple[str, Dict[str, Any], Dict[str, Any]]
    attempts: int = 0
    started: float = 0.0
    actor: Any = None


@dataclass
class _Stats:
    submitted: int = 0
    finished: int = 0
    reruns: int = 0
    timed_out: int = 0
    lost_twice: int = 0
    lost: List[str] = field(default_factory=list)


class RayExecutor:
    """Runs a campaign's HF and LF runs on a Ray cluster.

    ``address``: the cluster to join (``"auto"``, ``"HOST:6379"``, ``"ray://HOST:10001"``);
    None uses ``RAY_ADDRESS`` or, without it, starts a local single-node Ray. Ray already
    initialised by the caller (``ray.init(...)``) is used as it is.

    ``actors``: None runs each run as a Ray task (the callables shipped once through the object
    store); N keeps N Ray actors, each holding one copy of the simulator callables for the whole
    campaign — state a callable opens lazily (a connection to a simulator server, a loaded
    model) is then opened once per actor, not once per run.

    ``workers``: runs handed to Ray at once (default: the cluster's CPUs // ``num_cpus`` when
    the campaign starts; with actors, ``actors``). ``num_cpus``: CPUs a run reserves.
    ``timeout``: seconds a run may take (None: no limit). ``init``: more keyword arguments of
    ``ray.init``.

    After a campaign, ``stats`` counts the runs submitted, finished, re-run after a lost
    worker, timed out and lost twice.
    """

    def __init__(self, address: Optional[str] = None, *, actors: Optional[int] = None,
                 workers: Optional[int] = None, num_cpus: float = 1, timeout: Optional[float] = None,
                 init: Optional[Dict[str, Any]] = None) -> None:
        for name, value in (("actors", actors), ("workers", workers)):
            if value is not None and (not isinstance(value, int) or value < 1):
                raise ValueError(f"RayExecutor: {name} must be a positive integer, got {value!r}")
        if timeout is not None and not (timeout > 0):
            raise ValueError(f"RayExecutor: timeout must be positive seconds, got {timeout!r}")
        if not (num_cpus > 0):
            raise ValueError(f"RayExecutor: num_cpus must be positive, got {num_cpus!r}")
        self.address = address
        self.actors = actors
        self.workers = workers
        self.num_cpus = num_cpus
        self.timeout = timeout
        self.init = dict(init or {})
        self.stats = _Stats()
        self._ray: Any = None
        self._started_ray = False
        self._reset()

    def _reset(self) -> None:
        self._queue: Deque[_Run] = collections.deque()
        self._running: Dict[Any, _Run] = {}
        self._idle: Deque[Any] = collections.deque()
        # Actors whose process died or was stopped, back to idle once they answer a ping.
        self._restarting: Dict[Any, Any] = {}
        self._pool: List[Any] = []
        self._task: Any = None
        self._sims: Any = None
        self._capacity = 0

    def __repr__(self) -> str:
        mode = f"actors={self.actors}" if self.actors else "tasks"
        return f"RayExecutor(address={self.address!r}, {mode}, timeout={self.timeout})"

    # The executor contract (called by savme.Campaign.run).

    def start(self, hf: Callable[..., Any], lf: Callable[..., Any]) -> None:
        """Joins (or starts) Ray and gets the workers ready for a campaign on ``hf``/``lf``."""
        ray = self._ray = _import_ray()
        if not ray.is_initialized():
            kwargs: Dict[str, Any] = {"logging_level": logging.WARNING}
            kwargs.update(self.init)
            ray.init(address=self.address or os.environ.get("RAY_ADDRESS"), **kwargs)
            self._started_ray = True
        self._reset()
        self.stats = _Stats()
        if self.actors:
            cls = ray.remote(num_cpus=self.num_cpus, max_restarts=-1,
                             max_task_retries=0)(_SimulatorActor)
            self._pool = [cls.remote(hf, lf) for _ in range(self.actors)]
            self._idle.extend(self._pool)
            self._capacity = self.actors
        else:
            self._sims = ray.put((hf, lf))
            self._task = ray.remote(num_cpus=self.num_cpus, max_retries=0)(_call)
            self._capacity = self.workers or self._cluster_slots()

    def submit(self, trial: int, which: str, scenario: str, phi: Dict[str, Any],
               theta: Dict[str, Any]) -> None:
        """Queues a run; it goes to Ray as soon as a worker slot is free."""
        self.stats.submitted += 1
        self._queue.append(_Run(trial, which, (scenario, phi, theta)))
        self._dispatch()

    def poll(self, timeout: float) -> Polled:
        """The runs finished since the last poll, waiting up to ``timeout`` s for one."""
        self._dispatch()
        if not self._running:
            time.sleep(timeout)
            return []
        wait = timeout
        if self.timeout is not None:
            first = min(r.started for r in self._running.values())
            wait = max(0.0, min(wait, first + self.timeout - time.monotonic()))
        refs = list(self._running)
        ready, _ = self._ray.wait(refs, num_returns=1, timeout=wait)
        if ready:
            ready, _ = self._ray.wait(refs, num_returns=len(refs), timeout=0)
        out: Polled = []
        for ref in ready:
            run = self._running.pop(ref)
            self._collect(ref, run, out)
        self._stop_overdue(out)
        self._dispatch()
        self.stats.finished += len(out)
        return out

    def finish(self) -> None:
        """Cancels the runs still queued or running (a campaign that stopped early) and lets
        the actors go; Ray stays up if it was running before ``start``."""
        ray = self._ray
        if ray is None:
            return
        if self._task is not None and self._running:
            # Only runs still going after a short grace are force-cancelled: Ray 2.60's core
            # worker aborts the whole driver process ("Tried to complete task that was not
            # pending", task_manager.cc) when a force-cancel races the task's own completion,
            # which an aborted campaign's just-finishing runs made happen about once in six
            # runs of test_ray.py on a loaded machine.
            refs = list(self._running)
            _, still = ray.wait(refs, num_returns=len(refs), timeout=_FINISH_GRACE_S)
            for ref in still:
                try:
                    ray.cancel(ref, force=True)
                except Exception as e:  # finished meanwhile, or its worker gone: nothing to stop
                    log.debug("cancel: %s", e)
        for actor in self._pool:
            ray.kill(actor, no_restart=True)
        self._reset()
        if self._started_ray:
            ray.shutdown()
            self._started_ray = False

    # Inside.

    def _cluster_slots(self) -> int:
        cpus = self._ray.cluster_resources().get("CPU", 0)
        slots = int(cpus // self.num_cpus)
        if slots < 1:
            raise RuntimeError(
                f"RayExecutor: the Ray cluster has {cpus} CPUs, fewer than one run's "
                f"num_cpus={self.num_cpus}; add nodes (ray start --address=...) or lower num_cpus")
        return slots

    def _dispatch(self) -> None:
        self._check_restarting()
        while self._queue and len(self._running) < self._capacity:
            run = self._queue.popleft()
            run.attempts += 1
            run.started = time.monotonic()
            if self.actors:
                if not self._idle:
                    self._queue.appendleft(run)
                    run.attempts -= 1
                    return
                run.actor = self._idle.popleft()
                ref = run.actor.run.remote(run.which, *run.args)
            else:
                ref = self._task.remote(self._sims, run.which, *run.args)
            self._running[ref] = run

    def _restart(self, actor: Any) -> None:
        """An actor whose process was lost (or killed): Ray restarts it (max_restarts=-1);
        it takes runs again once it answers."""
        self._restarting[actor.pid.remote()] = actor

    def _check_restarting(self) -> None:
        if not self._restarting:
            return
        refs = list(self._restarting)
        ready, _ = self._ray.wait(refs, num_returns=len(refs), timeout=0)
        for ref in ready:
            actor = self._restarting.pop(ref)
            try:
                self._ray.get(ref)
            except self._ray.exceptions.RayError as e:
                log.debug("a Ray actor is still restarting: %s", _first_line(e))
                self._restart(actor)  # ask again
            else:
                self._idle.append(actor)

    def _release(self, run: _Run) -> None:
        if run.actor is not None:
            self._idle.append(run.actor)
            run.actor = None

    def _collect(self, ref: Any, run: _Run, out: Polled) -> None:
        ray = self._ray
        try:
            outcome = ray.get(ref)
        except _lost_errors(ray) as e:
            if run.actor is not None:
                self._restart(run.actor)
                run.actor = None
            what = f"trial {run.trial} {run.which} run: {type(e).__name__}"
            self.stats.lost.append(what)
            if run.attempts < 2:
                self.stats.reruns += 1
                log.warning("savme: %s (its Ray worker was lost); running it again", what)
                self._queue.appendleft(run)
                return
            self.stats.lost_twice += 1
            outcome = ("error", f"the Ray worker running the `{run.which}` run was lost twice "
                                f"(the last: {type(e).__name__}: {_first_line(e)})")
        except ray.exceptions.RayError as e:
            outcome = ("error", f"the `{run.which}` run failed on Ray: {type(e).__name__}: "
                                f"{_first_line(e)}")
        self._release(run)
        out.append((run.trial, run.which, outcome))

    def _stop_overdue(self, out: Polled) -> None:
        if self.timeout is None:
            return
        now = time.monotonic()
        for ref, run in list(self._running.items()):
            if now - run.started < self.timeout:
                continue
            del self._running[ref]
            self.stats.timed_out += 1
            if run.actor is not None:
                # A fresh instance replaces the stuck one (max_restarts=-1).
                self._ray.kill(run.actor, no_restart=False)
                self._restart(run.actor)
                run.actor = None
            else:
                self._ray.cancel(ref, force=True)
            out.append((run.trial, run.which, (
                "error", f"the `{run.which}` run timed out after {self.timeout:g} s on Ray "
                         f"(its worker was stopped)")))


def _lost_errors(ray: Any) -> Tuple[Type[BaseException], ...]:
    """Ray's errors for a run whose worker process or node went away."""
    names = ("WorkerCrashedError", "NodeDiedError", "LocalRayletDiedError", "ActorDiedError",
             "ActorUnavailableError", "ObjectLostError", "OwnerDiedError")
    return tuple(getattr(ray.exceptions, n) for n in names if hasattr(ray.exceptions, n))


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__
