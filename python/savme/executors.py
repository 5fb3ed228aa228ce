"""Executors: where a campaign's simulator runs execute, when not on local threads.

``savme.Campaign(protocol, problem, executor=savme.RayExecutor(address=...))`` keeps the kernel,
the store and the campaign loop in this process (the *driver*) and runs each HF and LF run on a
Ray cluster: runs of Python simulator callables, of the bundled driving simulator
(``run(sim=savme.sim.Driving())``) and of a campaign file's FMUs
(``savme.campaign.load(path).run(executor="ray")``: the FMUs go through Ray's object store and
are written once per node). The trials are told in ask order, so the same seed gives the same
trials as a local run under ``cost="work"`` (under wall-clock cost, the measured runtimes differ
as they do between two local runs).

By default each run is a Ray **task** on Ray's warm worker processes; when the executor uses the
whole cluster (no ``workers=``), up to two runs per CPU slot are handed to Ray at once, so that
a worker that finishes a run is given the next by Ray itself, without waiting for the driver.
``actors=N`` runs them on N Ray actors instead, each keeping one simulator instance for the
whole campaign and holding up to two runs (the one it runs and the next): for simulators that
are expensive to start; each campaign then starts N worker processes first.

Ray is an optional dependency: ``pip install ray`` (or ``"ray[default]"`` for the dashboard) on
the driver and on every node; ``import savme`` never imports it.

Semantics, per run:

- **timeout** (``timeout=`` seconds): a run still going after that long is stopped (its Ray
  worker process is killed: the task cancelled with ``force=True``, or the actor restarted) and
  fails with "timed out" — what follows is the protocol's ``on_error``: ``"abort"`` stops the
  campaign naming the trial, ``"skip"`` withdraws the trial (replaced by a new one). The clock
  starts when the run is handed to Ray (a task), or to an idle actor or, behind another run on
  the same actor, when the driver sees that one finish; so it measures the run, plus Ray's
  dispatch (milliseconds), on first use the start of a worker process (about a second), and,
  for a task handed over while every CPU is busy (the whole cluster: two runs per slot), the
  wait for a free one — at most the run before it: give a timeout of at least twice the
  longest run.
- **a lost worker** (the process running the run died — killed, out of memory, its node gone):
  the run is re-run once, on any worker; its trial is told once, with the re-run's result. A run
  whose worker is lost twice fails ("lost twice"), then ``on_error`` applies. A run that was
  only waiting on a lost actor is handed to another without counting.
- **an exception** raised by the simulator fails the run (``on_error``), with the exception's
  type and message, as a local run does; a native simulator's error is the one a local run
  stores.
- **Ctrl-C** (or SIGTERM) stops the campaign within seconds (a poll of 0.2 s; the runs in
  flight get 2 s to end, then are stopped), every told trial is stored, and the
  ``KeyboardInterrupt`` names the call that resumes it.

Any object with ``start``, ``submit``, ``poll`` and ``finish`` methods can be an executor (see
``savme._savme``'s ``executor`` module documentation for their contract); ``RayExecutor`` is the
one savme ships.
"""

from __future__ import annotations

import collections
import fcntl
import hashlib
import logging
import os
import pathlib
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Deque, Dict, List, Optional, Set, Tuple, Type

__all__ = ["RayExecutor", "native"]

log = logging.getLogger("savme.ray")

# How long `finish` lets the runs still in flight end on their own before force-cancelling them.
_FINISH_GRACE_S = 2.0
# Runs an actor holds at once: the one it runs and the next.
_ACTOR_DEPTH = 2
# Runs per CPU slot handed to Ray as tasks when the executor uses the whole cluster.
_TASK_DEPTH = 2

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


# Native simulators (a campaign file's FMUs, the bundled driving simulator) on a Ray worker.


def native(spec: str, files: Dict[str, str]) -> Tuple["_NativeRun", "_NativeRun"]:
    """The ``(hf, lf)`` callables of a native simulator for an executor (made by
    ``Campaign.run`` with ``executor=``): ``spec`` (JSON) says what to build, ``files`` the
    files it needs on this host, by role (an FMU campaign's ``hf`` and ``lf`` FMUs).

    ``RayExecutor`` ships the files through Ray's object store; each node writes them once into
    its cache (``$SAVME_RAY_CACHE``, else ``~/.cache/savme/fmus``, by SHA-256) and each Ray
    worker process builds the simulator once and keeps it. Another executor may call them as
    plain simulator callables, on this host's files."""
    shipment = _Native(spec, {role: str(path) for role, path in files.items()})
    return _NativeRun(shipment, "hf"), _NativeRun(shipment, "lf")


# The simulators built in this process, by their spec and files' digests.
_BUILT: Dict[Tuple[str, Tuple[Tuple[str, str], ...]], Any] = {}


@dataclass
class _Shipped:
    digest: str
    name: str
    ref: Any


class _Native:
    """A native simulator's spec and files, shipped (once) by the executor that runs it."""

    def __init__(self, spec: str, files: Dict[str, str]) -> None:
        self.spec = spec
        self.files = files
        self.shipped: Optional[Dict[str, _Shipped]] = None

    def ship(self, ray: Any) -> None:
        """Puts each file's bytes into Ray's object store (a file used by both roles once)."""
        if self.shipped is not None:
            return
        by_digest: Dict[str, Any] = {}
        shipped = {}
        for role, path in self.files.items():
            data = pathlib.Path(path).read_bytes()
            digest = hashlib.sha256(data).hexdigest()
            if digest not in by_digest:
                by_digest[digest] = ray.put(data)
            shipped[role] = _Shipped(digest, os.path.basename(path), by_digest[digest])
        self.shipped = shipped

    def simulator(self) -> Any:
        """The simulator, built in this process once (on a node: from its cached files)."""
        shipped = self.shipped
        if shipped is None:
            key = (self.spec, tuple(sorted(self.files.items())))
        else:
            key = (self.spec, tuple(sorted((r, s.digest) for r, s in shipped.items())))
        sim = _BUILT.get(key)
        if sim is None:
            from ._savme import NativeSimulator

            if shipped is None:
                paths = dict(self.files)
            else:
                ray = _import_ray()
                paths = {role: str(_fetch(ray, s)) for role, s in shipped.items()}
            sim = _BUILT[key] = NativeSimulator(self.spec, paths)
        return sim


class _NativeRun:
    """The ``hf`` or ``lf`` callable of a native simulator."""

    def __init__(self, shipment: _Native, which: str) -> None:
        self.shipment = shipment
        self.which = which

    def outcome(self, which: str, scenario: str, phi: Dict[str, Any],
                theta: Dict[str, Any]) -> Outcome:
        """One run as an executor reports it (the simulator's own wall time and errors)."""
        return tuple(self.shipment.simulator().run(which, scenario, phi, theta))

    def __call__(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        out = self.outcome(self.which, scenario, phi, theta)
        if out[0] != "ok":
            raise RuntimeError(out[1])
        return out[1]

    def __repr__(self) -> str:
        return f"<savme native simulator, {self.which} run>"


def cache_dir() -> pathlib.Path:
    """Where this host keeps the files shipped to it: ``$SAVME_RAY_CACHE``, else
    ``$XDG_CACHE_HOME/savme/fmus`` (``~/.cache/savme/fmus``). Created private (0700)."""
    root = os.environ.get("SAVME_RAY_CACHE")
    if root:
        path = pathlib.Path(root)
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(pathlib.Path.home() / ".cache")
        path = pathlib.Path(base) / "savme" / "fmus"
    path.mkdir(mode=0o700, parents=True, exist_ok=True)
    if path.is_symlink() or not path.is_dir():
        raise RuntimeError(f"{path}: savme's file cache must be a directory, not a link")
    return path


def _fetch(ray: Any, shipped: _Shipped) -> pathlib.Path:
    """The shipped file in this node's cache: written once per node (the first worker process
    to need it takes a lock, gets the bytes from the object store, checks their SHA-256, and
    renames a private directory into place); later ones find it there."""
    root = cache_dir()
    final = root / shipped.digest / shipped.name
    if final.is_file() and not final.is_symlink():
        return final
    flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW
    lock = os.open(root / f".{shipped.digest}.lock", flags, 0o600)
    try:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if final.is_file() and not final.is_symlink():
            return final
        data = ray.get(shipped.ref)
        if hashlib.sha256(data).hexdigest() != shipped.digest:
            raise RuntimeError(f"{shipped.name}: the bytes from Ray's object store do not have "
                               f"the SHA-256 the driver sent ({shipped.digest})")
        staging = pathlib.Path(tempfile.mkdtemp(prefix=".fetch-", dir=root))
        fd = os.open(staging / shipped.name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW,
                     0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.rename(staging, root / shipped.digest)
        fd = os.open(root / "fetched.log", os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NOFOLLOW,
                     0o600)
        with os.fdopen(fd, "a") as f:
            f.write(f"{shipped.digest} {shipped.name} {len(data)} bytes, pid {os.getpid()}\n")
        return final
    finally:
        os.close(lock)


# What runs on a Ray worker.


def _call(sims: Tuple[Callable[..., Any], Callable[..., Any]], which: str, scenario: str,
          phi: Dict[str, Any], theta: Dict[str, Any]) -> Outcome:
    """One run, on a Ray worker: the callable's result and wall time, or what it raised."""
    f = sims[0] if which == "hf" else sims[1]
    if isinstance(f, _NativeRun):
        try:
            return f.outcome(which, scenario, phi, theta)
        except Exception as e:  # the simulator could not be built here (files, library)
            return ("error", f"the `{which}` simulator on Ray worker pid {os.getpid()}: "
                             f"{type(e).__name__}: {e}")
    start = time.perf_counter()
    try:
        out = f(scenario, phi, theta)
    except Exception as e:  # the simulator's own failure: the run fails, per on_error
        return ("raised", f"{type(e).__name__}: {e}")
    return ("ok", out, time.perf_counter() - start)


class _SimulatorActor:
    """One simulator instance kept across runs (one per worker of ``RayExecutor``)."""

    def __init__(self, hf: Callable[..., Any], lf: Callable[..., Any]) -> None:
        self.sims = (hf, lf)

    def run(self, which: str, scenario: str, phi: Dict[str, Any],
            theta: Dict[str, Any]) -> Outcome:
        return _call(self.sims, which, scenario, phi, theta)

    def pid(self) -> int:
        return os.getpid()


# The driver's side.


@dataclass
class _Run:
    trial: int
    which: str
    args: Tuple[str, Dict[str, Any], Dict[str, Any]]
    attempts: int = 0
    # When it started (as the driver knows it); None while it waits behind another run.
    started: Optional[float] = None
    worker: Optional["_Worker"] = None


@dataclass
class _Worker:
    """An actor and the runs handed to it, in the order it runs them."""

    actor: Any
    refs: Deque[Any] = field(default_factory=collections.deque)
    # False while Ray restarts its process (it takes runs again once it answers a ping).
    alive: bool = True


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
    model) is then opened once per actor, not once per run — and up to two runs at a time.

    ``workers``: runs that execute at once with tasks (default: the cluster's CPUs //
    ``num_cpus`` when the campaign starts, with two runs per slot handed to Ray so that a worker
    never waits for the driver between runs; ``workers=N`` hands exactly N). ``num_cpus``: CPUs
    a run reserves. ``timeout``: seconds a run may take (None: no limit). ``init``: more keyword
    arguments of ``ray.init``.

    After a campaign, ``stats`` counts the runs submitted, finished, re-run after a lost
    worker, timed out and lost twice.
    """

    def __init__(self, address: Optional[str] = None, *, actors: Optional[int] = None,
                 workers: Optional[int] = None, num_cpus: float = 1,
                 timeout: Optional[float] = None, init: Optional[Dict[str, Any]] = None) -> None:
        for name, value in (("actors", actors), ("workers", workers)):
            if value is not None and (not isinstance(value, int) or isinstance(value, bool)
                                      or value < 1):
                raise ValueError(f"RayExecutor: {name} must be a positive integer, got {value!r}")
        if actors is not None and workers is not None and workers != actors:
            raise ValueError(f"RayExecutor: actors={actors} runs {actors} at once: "
                             f"workers={workers} contradicts it (give one of them)")
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
        self._pool: List[_Worker] = []
        # Workers whose actor process died or was stopped, by the ping they must answer.
        self._restarting: Dict[Any, _Worker] = {}
        self._task: Any = None
        self._sims: Any = None
        self._capacity = 0

    def __repr__(self) -> str:
        mode = f"actors={self.actors}" if self.actors else f"tasks, workers={self.workers}"
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
        for f in (hf, lf):
            if isinstance(f, _NativeRun):
                f.shipment.ship(ray)
        if self.actors:
            cls = ray.remote(num_cpus=self.num_cpus, max_restarts=-1,
                             max_task_retries=0)(_SimulatorActor)
            self._pool = [_Worker(cls.remote(hf, lf)) for _ in range(self.actors)]
        else:
            self._sims = ray.put((hf, lf))
            self._task = ray.remote(num_cpus=self.num_cpus, max_retries=0)(_call)
            # The whole cluster: Ray runs at most a run per slot, and the second run handed
            # per slot waits in Ray, which gives it to the first worker free (no round trip
            # to this driver). With workers=N, exactly N.
            self._capacity = self.workers or _TASK_DEPTH * self._cluster_slots()

    def submit(self, trial: int, which: str, scenario: str, phi: Dict[str, Any],
               theta: Dict[str, Any]) -> None:
        """Queues a run; it goes to Ray as soon as a worker can take it."""
        self.stats.submitted += 1
        self._queue.append(_Run(trial, which, (scenario, phi, theta)))
        self._dispatch()

    def poll(self, timeout: float) -> Polled:
        """The runs finished since the last poll, waiting up to ``timeout`` s for one."""
        self._dispatch()
        if not self._running:
            self._wait_idle(timeout)
            self._dispatch()
            return []
        wait = timeout
        if self.timeout is not None:
            starts = [r.started for r in self._running.values() if r.started is not None]
            if starts:
                wait = max(0.0, min(wait, min(starts) + self.timeout - time.monotonic()))
        refs = list(self._running)
        ready, _ = self._ray.wait(refs, num_returns=1, timeout=wait)
        if ready:
            ready, _ = self._ray.wait(refs, num_returns=len(refs), timeout=0)
        out: Polled = []
        self._collect(ready, out)
        self._stop_overdue(out)
        self._dispatch()
        self.stats.finished += len(out)
        return out

    def finish(self) -> None:
        """Cancels the runs still queued or running (a campaign that stopped early, Ctrl-C)
        and lets the actors go; Ray stays up if it was running before ``start``."""
        ray = self._ray
        if ray is None:
            return
        try:
            if self._task is not None and self._running:
                self._cancel_tasks()
            for worker in self._pool:
                ray.kill(worker.actor, no_restart=True)
        finally:
            self._reset()
            if self._started_ray:
                self._started_ray = False
                ray.shutdown()

    # Inside.

    def _cancel_tasks(self) -> None:
        # Only runs still going after a short grace are force-cancelled: Ray 2.60's core
        # worker aborts the whole driver process ("Tried to complete task that was not
        # pending", task_manager.cc) when a force-cancel races the task's own completion,
        # which an aborted campaign's just-finishing runs made happen about once in six
        # runs of test_ray.py on a loaded machine.
        ray = self._ray
        refs = list(self._running)
        _, still = ray.wait(refs, num_returns=len(refs), timeout=_FINISH_GRACE_S)
        for ref in still:
            try:
                ray.cancel(ref, force=True)
            except Exception as e:  # finished meanwhile, or its worker gone: nothing to stop
                log.debug("cancel: %s", e)

    def _cluster_slots(self) -> int:
        cpus = self._ray.cluster_resources().get("CPU", 0)
        slots = int(cpus // self.num_cpus)
        if slots < 1:
            raise RuntimeError(
                f"RayExecutor: the Ray cluster has {cpus} CPUs, fewer than one run's "
                f"num_cpus={self.num_cpus}; add nodes (ray start --address=...) or lower num_cpus")
        return slots

    def _wait_idle(self, timeout: float) -> None:
        """Nothing in flight: wait for a restarting actor to come back, or just wait."""
        if self._restarting and self._queue:
            self._ray.wait(list(self._restarting), num_returns=1, timeout=timeout)
        else:
            time.sleep(timeout)

    def _dispatch(self) -> None:
        self._check_restarting()
        if not self.actors:
            while self._queue and len(self._running) < self._capacity:
                run = self._queue.popleft()
                run.attempts += 1
                run.started = time.monotonic()
                self._running[self._task.remote(self._sims, run.which, *run.args)] = run
            return
        while self._queue:
            # The live worker with the fewest runs: an idle one first, so that a run waits
            # behind another only when every worker is busy.
            free = [w for w in self._pool if w.alive and len(w.refs) < _ACTOR_DEPTH]
            if not free:
                return
            worker = min(free, key=lambda w: len(w.refs))
            run = self._queue.popleft()
            run.attempts += 1
            run.worker = worker
            run.started = time.monotonic() if not worker.refs else None
            ref = worker.actor.run.remote(run.which, *run.args)
            worker.refs.append(ref)
            self._running[ref] = run

    def _drop(self, worker: _Worker, cause: Optional[BaseException], out: Polled) -> None:
        """An actor whose process was lost (``cause``) or stopped: Ray restarts it
        (max_restarts=-1) and it takes runs again once it answers a ping. Of the runs it held,
        the one it ran is lost (run again once, see ``_lost``), if ``cause``; the others only
        waited, and go back to the queue without counting."""
        worker.alive = False
        runs = [self._running.pop(ref) for ref in worker.refs if ref in self._running]
        worker.refs.clear()
        if cause is not None and runs:
            self._lost(runs.pop(0), cause, out)
        for run in reversed(runs):
            run.attempts -= 1
            run.worker = None
            run.started = None
            self._queue.appendleft(run)
        self._restarting[worker.actor.pid.remote()] = worker

    def _check_restarting(self) -> None:
        if not self._restarting:
            return
        refs = list(self._restarting)
        ready, _ = self._ray.wait(refs, num_returns=len(refs), timeout=0)
        for ref in ready:
            worker = self._restarting.pop(ref)
            try:
                self._ray.get(ref)
            except self._ray.exceptions.RayError as e:
                log.debug("a Ray actor is still restarting: %s", _first_line(e))
                self._restarting[worker.actor.pid.remote()] = worker  # ask again
            else:
                worker.alive = True

    def _collect(self, ready: List[Any], out: Polled) -> None:
        """Files the finished runs: each worker's in the order it ran them."""
        ray = self._ray
        lost = _lost_errors(ray)
        done: Set[Any] = set(ready)
        order = [ref for w in self._pool for ref in w.refs if ref in done]
        order += [ref for ref in ready if ref in self._running and self._running[ref].worker is None]
        for ref in order:
            run = self._running.get(ref)
            if run is None:  # handed back to the queue with its lost actor
                continue
            try:
                outcome = ray.get(ref)
            except lost as e:
                if run.worker is not None:
                    self._drop(run.worker, e, out)
                else:
                    del self._running[ref]
                    self._lost(run, e, out)
                continue
            except ray.exceptions.RayError as e:
                outcome = ("error", f"the `{run.which}` run failed on Ray: {type(e).__name__}: "
                                    f"{_first_line(e)}")
            del self._running[ref]
            worker = run.worker
            if worker is not None:
                worker.refs.remove(ref)
                if worker.refs:  # the run waiting behind it starts now
                    self._running[worker.refs[0]].started = time.monotonic()
            out.append((run.trial, run.which, outcome))

    def _lost(self, run: _Run, e: BaseException, out: Polled) -> None:
        """A run whose worker was lost: run again once, then failed."""
        run.worker = None
        run.started = None
        what = f"trial {run.trial} {run.which} run: {type(e).__name__}"
        self.stats.lost.append(what)
        if run.attempts < 2:
            self.stats.reruns += 1
            log.warning("savme: %s (its Ray worker was lost); running it again", what)
            self._queue.appendleft(run)
            return
        self.stats.lost_twice += 1
        out.append((run.trial, run.which, (
            "error", f"the Ray worker running the `{run.which}` run was lost twice "
                     f"(the last: {type(e).__name__}: {_first_line(e)})")))

    def _stop_overdue(self, out: Polled) -> None:
        if self.timeout is None:
            return
        now = time.monotonic()
        for ref, run in list(self._running.items()):
            if ref not in self._running or run.started is None or now - run.started < self.timeout:
                continue
            del self._running[ref]
            self.stats.timed_out += 1
            worker = run.worker
            if worker is not None:
                # A fresh instance replaces the stuck one (max_restarts=-1).
                worker.refs.remove(ref)
                self._ray.kill(worker.actor, no_restart=False)
                self._drop(worker, None, out)
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
