"""A throwaway multi-node Ray cluster on this machine, for the Ray executor's tests and
benchmark (python/tests/test_ray.py, python/bench_ray.py).

`ray start --head` and one `ray start --address=…` per extra worker node, each as a child
process (`--block`) with every file under a fresh temporary directory, free ports, no dashboard
and a small object store. `stop()` ends them with SIGTERM (Ray drains and stops the node's
processes), then SIGKILLs whatever is left of the processes started under that directory (found
by the directory in their command line: ours only), and removes the directory. Nothing here
runs `ray stop`, which would stop every Ray on the machine.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from typing import List, Optional

RAY = str(pathlib.Path(sys.executable).parent / "ray")
OBJECT_STORE_BYTES = 80 * 1024 * 1024  # Ray's minimum is ~75 MiB
START_SECONDS = 180


def free_ports(n: int, taken: frozenset = frozenset()) -> List[int]:
    """`n` distinct free ports, none in `taken`. The sockets stay bound until all `n` are chosen:
    a port asked for one at a time can come back twice (Ray then refuses to start, naming two of
    its components on one port)."""
    sockets: List[socket.socket] = []
    try:
        ports: List[int] = []
        while len(ports) < n:
            s = socket.socket()
            sockets.append(s)
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
            if port not in taken:
                ports.append(port)
        return ports
    finally:
        for s in sockets:
            s.close()


class LocalRayCluster:
    """A head node with `head_cpus` CPUs and one worker node per entry of `worker_cpus`."""

    def __init__(self, head_cpus: int = 1, worker_cpus: Optional[List[int]] = None,
                 pythonpath: Optional[str] = None) -> None:
        self.head_cpus = head_cpus
        self.worker_cpus = [1] if worker_cpus is None else worker_cpus
        self.dir = pathlib.Path(tempfile.mkdtemp(prefix="savme-ray-", dir="/tmp"))
        self.nodes: List[subprocess.Popen] = []
        self.names: List[str] = []
        self.address = ""
        self.ports: set = set()
        self.env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
        self.env.pop("RAY_ADDRESS", None)
        if pythonpath:
            # Where the simulators' module is, as it would be installed on a real cluster's nodes.
            self.env["PYTHONPATH"] = os.pathsep.join(
                p for p in (pythonpath, os.environ.get("PYTHONPATH")) if p)

    def _node(self, name: str, args: List[str]) -> subprocess.Popen:
        log = open(self.dir / f"{name}.log", "wb")
        # Distinct from each other and from the ports this cluster's other nodes were given.
        chosen = free_ports(4, frozenset(self.ports))
        self.ports.update(chosen)
        ports = [flag for pair in zip(("--dashboard-agent-listen-port",
                                       "--dashboard-agent-grpc-port",
                                       "--runtime-env-agent-port", "--metrics-export-port"),
                                      map(str, chosen)) for flag in pair]
        cmd = [RAY, "start", "--block", f"--temp-dir={self.dir}",
               f"--object-store-memory={OBJECT_STORE_BYTES}", "--disable-usage-stats",
               "--include-log-monitor=false",
               *ports, *args]
        # Each node has a file cache of its own, as separate hosts would (savme.executors
        # writes the FMUs shipped to a node there).
        env = dict(self.env, SAVME_RAY_CACHE=str(self.cache(name)))
        p = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env,
                             start_new_session=True)
        self.nodes.append(p)
        self.names.append(name)
        return p

    def cache(self, name: str) -> pathlib.Path:
        """The file cache of node `name` ("head", "worker0", …)."""
        return self.dir / f"cache-{name}"

    def add_worker(self, cpus: int) -> str:
        """Starts one more worker node; its name once it is up."""
        name = f"worker{len(self.nodes) - 1}"
        p = self._node(name, [f"--address={self.address}", f"--num-cpus={cpus}"])
        self._wait_started(p, name, time.monotonic() + START_SECONDS)
        return name

    def node_pids(self, name: str) -> List[int]:
        """Node `name`'s processes: its `ray start` process, its raylet and every process under
        them (its Ray workers)."""
        root = self.nodes[self.names.index(name)].pid
        children: dict = {}
        for pid, ppid in _parents().items():
            children.setdefault(ppid, []).append(pid)
        tree, todo = [], [root]
        while todo:
            pid = todo.pop()
            tree.append(pid)
            todo.extend(children.get(pid, []))
        return tree

    def kill_node(self, name: str) -> List[int]:
        """SIGKILLs node `name` as a lost host goes: its `ray start` process, its raylet and
        every process under them (its Ray workers), at once. The pids killed."""
        tree = self.node_pids(name)
        for pid in tree:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        return tree

    def start(self) -> "LocalRayCluster":
        try:
            self._start()
        except BaseException:
            self.stop()
            raise
        return self

    def _start(self) -> None:
        (gcs,) = free_ports(1)
        self.ports.add(gcs)
        head = self._node("head", ["--head", "--port", str(gcs),
                                   f"--num-cpus={self.head_cpus}", "--include-dashboard=false"])
        marker = self.dir / "ray_current_cluster"
        deadline = time.monotonic() + START_SECONDS
        while not marker.exists() or not marker.read_text().strip():
            self._check(head, "head", deadline)
            time.sleep(0.2)
        self.address = marker.read_text().strip()
        for i, cpus in enumerate(self.worker_cpus):
            self._node(f"worker{i}", [f"--address={self.address}", f"--num-cpus={cpus}"])
        for p, name in zip(self.nodes, self.names):
            self._wait_started(p, name, deadline)

    def _wait_started(self, p: subprocess.Popen, name: str, deadline: float) -> None:
        # `ray start --block` prints "Ray runtime started." once its node is up.
        while b"Ray runtime started" not in (self.dir / f"{name}.log").read_bytes():
            self._check(p, name, deadline)
            time.sleep(0.2)

    def _check(self, p: subprocess.Popen, name: str, deadline: float) -> None:
        if p.poll() is not None:
            raise RuntimeError(f"the Ray {name} node exited ({p.returncode}): "
                               f"{self.log(name)[-3000:]}")
        if time.monotonic() > deadline:
            raise RuntimeError(f"the Ray {name} node did not start within {START_SECONDS} s: "
                               f"{self.log(name)[-3000:]}")

    def log(self, name: str) -> str:
        try:
            return (self.dir / f"{name}.log").read_text(errors="replace")
        except OSError:
            return ""

    def pids(self) -> List[int]:
        """The processes of this cluster: those started under its directory (its command line
        names it) and their descendants (Ray worker processes retitle themselves `ray::…`)."""
        procs = {}
        for entry in pathlib.Path("/proc").iterdir():
            if not entry.name.isdigit() or int(entry.name) == os.getpid():
                continue
            try:
                cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            procs[int(entry.name)] = (ppid, cmdline)
        ours = {pid for pid, (_, cmd) in procs.items() if str(self.dir) in cmd}
        grew = True
        while grew:
            more = {pid for pid, (ppid, _) in procs.items() if ppid in ours} - ours
            ours |= more
            grew = bool(more)
        return sorted(ours)

    def worker_pids(self) -> List[int]:
        """The Ray worker processes (children of this cluster's raylets) that are alive."""
        raylets = set()
        for pid in self.pids():
            try:
                if b"raylet/raylet" in pathlib.Path(f"/proc/{pid}/cmdline").read_bytes():
                    raylets.add(pid)
            except OSError:
                pass
        found = []
        for pid in self.pids():
            try:
                stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) in raylets:
                found.append(pid)
        return found

    def stop(self) -> None:
        for p in self.nodes:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + 45
        for p in self.nodes:
            try:
                p.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for _ in range(3):
            left = self.pids()
            if not left:
                break
            for pid in left:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            time.sleep(0.5)
        shutil.rmtree(self.dir, ignore_errors=True)

    def __enter__(self) -> "LocalRayCluster":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _parents() -> dict:
    """Every process's parent: {pid: ppid}."""
    out = {}
    for entry in pathlib.Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            out[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    return out
