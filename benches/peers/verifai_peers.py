"""VerifAI's samplers on the benchmark's simulator process (the bundled simulator or a campaign
file's FMU): one sampler per scenario over a `FeatureSpace` with one `Box` feature per φ
variable, HF runs only, robustness ρ as the process gives it (< 0 exactly on a failure, so
VerifAI's default threshold 0 counts exactly the failures; the bundled simulator: the run's
minimum distance, −1 on a collision).

Used without Scenic and without VerifAI's server/falsifier (those add a socket round trip and
a monitor, nothing a sampler sees): `getSample()` → simulate → `update(sample, info, ρ)`.
"""
from __future__ import annotations

import math
import random
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from simulator import Run, ScenarioSpace, Simulator

# The peers and how each is made (VerifAI's own defaults unless said otherwise).
PEERS: tuple[str, ...] = (
    "random",
    "halton",
    "cross-entropy",
    "bandit",
    "annealing",
    "bayesopt",
)


def _sa_params() -> Any:
    """Simulated annealing has no defaults in VerifAI 2.2 (`default_sampler_params('sa')` is
    empty): temperature in metres of clearance, the proposal's width shrinks 0.9× a step,
    restarted epochs of 50 steps."""
    from dotmap import DotMap

    return DotMap(T=1.0, decay_rate=0.9, iterations=50, num_epoch=10**9, reset_temp=0.01)


def make_sampler(method: str, space: ScenarioSpace) -> Any:
    """A VerifAI `FeatureSampler` over the scenario's φ box."""
    from verifai.features import Box, Feature, FeatureSpace
    from verifai.samplers import FeatureSampler

    features = FeatureSpace({v.name: Feature(Box((v.lo, v.hi))) for v in space.variables})
    makers: dict[str, Callable[[], Any]] = {
        "random": lambda: FeatureSampler.randomSamplerFor(features),
        "halton": lambda: FeatureSampler.haltonSamplerFor(features),
        "cross-entropy": lambda: FeatureSampler.crossEntropySamplerFor(features),
        "bandit": lambda: FeatureSampler.multiArmedBanditSamplerFor(features),
        "annealing": lambda: FeatureSampler.simulatedAnnealingSamplerFor(features, _sa_params()),
        "bayesopt": lambda: FeatureSampler.bayesianOptimizationSamplerFor(features),
    }
    if method not in makers:
        raise ValueError(f"unknown peer `{method}` (known: {', '.join(makers)})")
    return makers[method]()


def annealing_started(sampler: Any) -> None:
    """VerifAI 2.2's annealing sampler never leaves its start-up state through the public API:
    `is_first_sample` only turns false on `update(…, rho=None)` before any sample (an assertion
    refuses it after one), and while it is true every sample is a fresh uniform point. After the
    first ρ the benchmark turns it false on the annealing part, so it anneals as designed."""
    from verifai.samplers.simulated_annealing import SimulatedAnnealingSampler

    for sub in getattr(sampler.domainSampler, "samplers", [sampler.domainSampler]):
        if isinstance(sub, SimulatedAnnealingSampler):
            sub.is_first_sample = False


def bayesopt_available() -> bool:
    try:
        import GPyOpt  # noqa: F401
    except Exception:
        return False
    return True


def phi_of(sample: Any, space: ScenarioSpace) -> dict[str, float]:
    """A VerifAI point as φ, clipped to the box (a sampler's float rounding must not leave it)."""
    return {
        v.name: min(v.hi, max(v.lo, float(getattr(sample, v.name)[0]))) for v in space.variables
    }


@dataclass
class PeerRun:
    """What one peer did on one seed: every HF run of the search and of the deployed part."""

    method: str
    seed: int
    search: list[Run] = field(default_factory=list)
    deployed: list[Run] = field(default_factory=list)
    sampler_seconds: float = 0.0
    sampler_calls: int = 0
    restarts: int = 0


# How a peer splits its budget over the scenarios: equal work (the default), or equal trials.
SPLITS = ("work", "trials")


class _Scenarios:
    """One sampler per scenario: `split = "work"` runs next the scenario that has cost least so
    far (an equal share of the work per scenario: what a VerifAI user with one sampler per
    scenario and a budget split evenly gets); `"trials"` visits them in turn (equal trials)."""

    def __init__(self, method: str, spaces: list[ScenarioSpace], split: str = "work") -> None:
        if split not in SPLITS:
            raise ValueError(f"split {split!r}: give one of {', '.join(SPLITS)}")
        self.method = method
        self.spaces = spaces
        self.samplers = [make_sampler(method, s) for s in spaces]
        self.split = split
        self.work = [0.0] * len(spaces)  # per scenario, in the current part (search, deployed)
        self.turn = 0
        self.restarts = 0

    def next(self) -> tuple[int, Any, Any]:
        from verifai.samplers.domain_sampler import TerminationException

        if self.split == "work":
            k = min(range(len(self.spaces)), key=lambda i: (self.work[i], i))
        else:
            k = self.turn % len(self.spaces)
        self.turn += 1
        try:
            sample, info = self.samplers[k].getSample()
        except TerminationException:  # a finished annealing schedule: start it again
            self.samplers[k] = make_sampler(self.method, self.spaces[k])
            self.restarts += 1
            sample, info = self.samplers[k].getSample()
        return k, sample, info


def _spend(
    state: _Scenarios, sim: Simulator, budget: float, out: list[Run], peer: PeerRun
) -> None:
    """Samples, runs on HF and feeds ρ back until `budget` work units are spent (the run that
    crosses the budget counts)."""
    spent = 0
    state.work = [0.0] * len(state.spaces)
    while spent < budget:
        t0 = time.perf_counter()
        k, sample, info = state.next()
        peer.sampler_seconds += time.perf_counter() - t0
        space = state.spaces[k]
        run = sim.run(space.name, phi_of(sample, space))
        t0 = time.perf_counter()
        state.samplers[k].update(sample, info, run.rho)
        if state.method == "annealing":
            annealing_started(state.samplers[k])
        peer.sampler_seconds += time.perf_counter() - t0
        peer.sampler_calls += 1
        out.append(run)
        spent += run.work
        state.work[k] += run.work


def run_peer(
    method: str,
    seed: int,
    spaces: list[ScenarioSpace],
    search_budget: float,
    deployed_budget: float,
    sim_command: Sequence[str],
    split: str = "work",
) -> PeerRun:
    """One peer, one seed: the search, then the deployed part (the same samplers go on
    sampling on HF), each until its work-unit budget is spent."""
    random.seed(seed)
    np.random.seed(seed)
    peer = PeerRun(method, seed)
    with Simulator(sim_command) as sim:
        state = _Scenarios(method, spaces, split)
        _spend(state, sim, search_budget, peer.search, peer)
        if deployed_budget > 0:
            _spend(state, sim, deployed_budget, peer.deployed, peer)
    peer.restarts = state.restarts
    return peer


def overhead_ms(peer: PeerRun) -> float:
    return 1e3 * peer.sampler_seconds / peer.sampler_calls if peer.sampler_calls else math.nan
