"""The HF simulator both sides of the benchmark share, as a child process speaking JSON lines.

Two back ends answer the same requests (`scenarios`, `space`, `arms`, a run with failure, ρ, work
units and savme's bins): the bundled driving simulator (`benches/peers/process/src/peers_sim.rs`) and the FMU a
campaign file names (`benches/peers/process/src/peers_fmu.rs`, read by savme's own campaign-file loading). A
[`Backend`] says which, and how savme runs its campaign on the same problem.
"""
from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence


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
    """One HF run's result; `rho` is the robustness given to VerifAI, < 0 exactly on a failure
    (the bundled simulator: min distance, −1 on a collision; an FMU campaign: see
    benches/peers/process/src/peers_fmu.rs)."""

    scenario: str
    phi: dict[str, float]
    arms: tuple[int, ...]
    failure: bool
    rho: float
    work: int


@dataclass(frozen=True)
class Sets:
    """A back end's scenario sets (as savme's campaign takes them), its label and how ρ is made."""

    train: tuple[str, ...]
    test: tuple[str, ...]
    label: str
    rho: str


def parse_run(scenario: str, phi: dict[str, float], a: dict[str, Any]) -> Run:
    """A run's answer as a `Run`, refusing a ρ that disagrees with the failure flag (VerifAI
    counts ρ < 0 as a counterexample: any other ρ would miscount)."""
    failure, rho = bool(a["failure"]), float(a["rho"])
    if failure != (rho < 0):
        raise ValueError(f"{scenario} {phi}: ρ = {rho} but failure = {failure} (ρ < 0 must be exactly a failure)")
    if a.get("work") is None:
        raise ValueError(f"{scenario} {phi}: the run counted no work units")
    return Run(a["scenario"], phi, tuple(a["arms"]), failure, rho, int(a["work"]))


@dataclass(frozen=True)
class Backend:
    """The problem both sides get: the HF simulator process the peers (and the bookkeeping)
    use, and the campaign savme runs on the same simulator — `savme reproduce` on the bundled
    simulator (`config` None), `savme run --config FILE` on a campaign file."""

    tag: str  # in output directories and results markers ("" for the bundled simulator)
    sim_command: tuple[str, ...]
    config: Path | None = None

    @staticmethod
    def driving(exe: Path, ideal: bool = False) -> "Backend":
        return Backend("", (str(exe), *(["--ideal"] if ideal else [])))

    @staticmethod
    def campaign(exe: Path, config: Path, rho_output: str | None) -> "Backend":
        cmd = [str(exe), str(config)] + (["--rho-output", rho_output] if rho_output else [])
        return Backend(campaign_tag(config), tuple(cmd), config)


def campaign_tag(config: Path) -> str:
    """`examples/fmu/braking/campaign.toml` → `braking` (a file named campaign.toml is known by
    its directory), `x/other.toml` → `other`."""
    return config.parent.name if config.stem == "campaign" and config.parent.name else config.stem


class SimulatorError(RuntimeError):
    """The simulator process refused a request or exited (its own message names the cause)."""


class Simulator:
    """One simulator process (a back end's `sim_command`); requests are answered in order."""

    def __init__(self, command: Sequence[str]) -> None:
        self._proc = subprocess.Popen(
            list(command), stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def _call(self, request: dict[str, Any]) -> dict[str, Any]:
        assert self._proc.stdin is not None and self._proc.stdout is not None
        try:
            self._proc.stdin.write(json.dumps(request) + "\n")
            self._proc.stdin.flush()
            line = self._proc.stdout.readline()
        except BrokenPipeError:
            line = ""
        if not line:
            raise SimulatorError(
                f"the simulator process exited (status {self._proc.wait()}; its message is above)"
            )
        answer: dict[str, Any] = json.loads(line)
        if "error" in answer:
            raise SimulatorError(f"simulator: {answer['error']} (request {request})")
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

    def sets(self) -> Sets:
        a = self._call({"op": "scenarios"})
        return Sets(tuple(a["train"]), tuple(a["test"]), str(a["label"]), str(a["rho"]))

    def run(self, scenario: str, phi: dict[str, float]) -> Run:
        return parse_run(scenario, phi, self._call({"scenario": scenario, "phi": phi}))

    def close(self) -> None:
        if self._proc.stdin:
            try:
                self._proc.stdin.close()
            except BrokenPipeError:  # it exited already (and said why on standard error)
                pass
        self._proc.wait(timeout=30)

    def __enter__(self) -> "Simulator":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
