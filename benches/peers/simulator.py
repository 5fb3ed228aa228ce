"""The bundled driving simulator as a child process (`examples/peers_sim.rs`, JSON lines)."""
from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Variable:
    """One φ variable: a real interval cut into `bins` linear bins (savme's arms)."""

    name: str
    lo: float
    hi: float
    bins: int


@dataclass(frozen=True)
class ScenarioSpace:
    """A scenario's name, number and φ variables, as the simulator declares them."""

    name: str
    number: int
    variables: tuple[Variable, ...]


@dataclass(frozen=True)
class Run:
    """One HF run's result; `rho` is the robustness given to VerifAI (min distance, −1 on a collision)."""

    scenario: str
    phi: dict[str, float]
    arms: tuple[int, ...]
    failure: bool
    min_distance: float
    work: int

    @property
    def rho(self) -> float:
        return -1.0 if self.failure else self.min_distance


class Simulator:
    """One `peers_sim` process; requests are answered in order."""

    def __init__(self, exe: Path, ideal: bool = False) -> None:
        cmd = [str(exe)] + (["--ideal"] if ideal else [])
        self._proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def _call(self, request: dict[str, Any]) -> dict[str, Any]:
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._proc.stdin.write(json.dumps(request) + "\n")
        self._proc.stdin.flush()
        line = self._proc.stdout.readline()
        if not line:
            raise RuntimeError("the simulator process exited")
        answer: dict[str, Any] = json.loads(line)
        if "error" in answer:
            raise RuntimeError(f"simulator: {answer['error']} (request {request})")
        return answer

    def space(self, scenario: str | int) -> ScenarioSpace:
        a = self._call({"op": "space", "scenario": scenario})
        variables = []
        for v in a["variables"]:
            if v.get("scale", "linear") != "linear" or "lo" not in v:
                raise ValueError(f"{a['scenario']}.{v['name']}: only linear real variables are handled")
            variables.append(Variable(v["name"], float(v["lo"]), float(v["hi"]), int(v["bins"])))
        return ScenarioSpace(a["scenario"], int(a["id"]), tuple(variables))

    def arms(self, scenario: str, phi: dict[str, float]) -> tuple[int, ...]:
        return tuple(self._call({"op": "arms", "scenario": scenario, "phi": phi})["arms"])

    def run(self, scenario: str, phi: dict[str, float]) -> Run:
        a = self._call({"scenario": scenario, "phi": phi})
        return Run(
            scenario=a["scenario"],
            phi=phi,
            arms=tuple(a["arms"]),
            failure=bool(a["failure"]),
            min_distance=float(a["min_distance_m"]),
            work=int(a["work"]),
        )

    def close(self) -> None:
        if self._proc.stdin:
            self._proc.stdin.close()
        self._proc.wait(timeout=30)

    def __enter__(self) -> "Simulator":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
