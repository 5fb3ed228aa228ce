"""Simulators for the Ray executor's tests and benchmark. They run in Ray worker processes,
so they live in a module the workers can import (the test cluster puts this directory on their
PYTHONPATH, as a real cluster would have the simulator's package installed on every node).

`Toy` is test_campaign.py's toy: deterministic outcome and work units, so a campaign under
`cost="work"` gives the same trials wherever its runs execute. Its `sleep` makes a run take
time; `victim` names a directory in which the first run to arrive claims the victim's role
(O_EXCL) — with `after=K`, the first run after K calls — and then misbehaves as `mode` says:

- "hang_once": writes its pid and sleeps until killed (the test kills that Ray worker);
  any later run behaves;
- "die_twice": SIGKILLs its own process, and so does every later attempt at the same run
  (same role, scenario, φ, θ): lost twice;
- "hang_forever": the same run sleeps for ever, every attempt (the timeout stops it);
- "raise": the same run raises ValueError.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import time
from typing import Any, Dict, Optional


class Toy:
    def __init__(self, role: str, sleep: float = 0.0, victim: Optional[str] = None,
                 mode: str = "hang_once", after: int = 0) -> None:
        self.role = role
        self.after = after
        self.sleep = sleep
        self.victim = victim
        self.mode = mode

    def __call__(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        if self.victim is not None:
            self._misbehave(scenario, phi, theta)
        if self.sleep:
            time.sleep(self.sleep)
        late = 10.0 / theta["rate_hz"] * phi["speed"] * 0.05
        fails = phi["speed"] ** 2 / 14.0 + late > phi["gap"]
        return fails, int(theta["rate_hz"] * 10)

    def _misbehave(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> None:
        key = json.dumps([self.role, scenario, phi, theta], sort_keys=True)
        claim = pathlib.Path(self.victim, "claim")
        if self.after and not claim.exists():
            with open(pathlib.Path(self.victim, "calls"), "a") as f:
                f.write(".")
            if pathlib.Path(self.victim, "calls").stat().st_size <= self.after:
                return
        try:
            fd = os.open(claim, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            mine = claim.read_text() == key if claim.stat().st_size else False
        else:
            with os.fdopen(fd, "w") as f:
                f.write(key)
            mine = True
            if self.mode == "hang_once":
                pathlib.Path(self.victim, "pid.tmp").write_text(str(os.getpid()))
                os.replace(pathlib.Path(self.victim, "pid.tmp"), pathlib.Path(self.victim, "pid"))
                time.sleep(3600)
        if not mine or self.mode == "hang_once":
            return
        with open(pathlib.Path(self.victim, "attempts"), "a") as f:
            f.write(f"{os.getpid()}\n")
        if self.mode == "die_twice":
            os.kill(os.getpid(), signal.SIGKILL)
        if self.mode == "hang_forever":
            time.sleep(3600)
        if self.mode == "raise":
            raise ValueError(f"no road in {scenario}")


def sleeper(seconds: float):
    """A simulator that only sleeps (the benchmark's): (failure, work) from φ."""
    return Sleeper(seconds)


class Sleeper:
    def __init__(self, seconds: float) -> None:
        self.seconds = seconds

    def __call__(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        if self.seconds:
            time.sleep(self.seconds)
        return phi["speed"] ** 2 / 14.0 > phi["gap"], int(theta["rate_hz"] * 10)


class SlowsDown(Toy):
    """The toy, each run taking `fast` seconds until the file `switch` exists, then `slow`
    seconds (a campaign whose runs in flight take minutes, for the Ctrl-C test)."""

    def __init__(self, role: str, switch: str, fast: float = 0.01, slow: float = 120.0) -> None:
        super().__init__(role)
        self.switch, self.fast, self.slow = switch, fast, slow

    def __call__(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        time.sleep(self.slow if os.path.exists(self.switch) else self.fast)
        return super().__call__(scenario, phi, theta)


class TracedSleeper(Sleeper):
    """The benchmark's sleeper that also appends each run's start and end (time.time()) to
    `<trace>/<pid>`: where a worker's time goes (runs, and the gaps between them)."""

    def __init__(self, seconds: float, trace: str) -> None:
        super().__init__(seconds)
        self.trace = trace

    def __call__(self, scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        start = time.time()
        out = super().__call__(scenario, phi, theta)
        with open(os.path.join(self.trace, str(os.getpid())), "a") as f:
            f.write(f"{start} {time.time()}\n")
        return out
