"""Adapters that plug the savme kernel into other tools' loops.

`FalsificationSampler` fits the shape of a VerifAI-style falsification loop — a sampler with
`next_sample()` and `update(sample, result)`, where the result is a continuous robustness value
ρ of the specification (ρ below a threshold, 0 by default, means it was violated):

    sampler = savme.integrations.FalsificationSampler(kernel, threshold=0.0)
    for _ in range(1000):
        sample = sampler.next_sample()          # .scenario, .params (φ), .fidelity (θ), .role
        rho = run_simulation(sample.scenario, sample.params, sample.fidelity)
        sampler.update(sample, rho)             # runtime measured since next_sample()

Each savme trial needs two simulations of the same φ — at θ_HF and at the learned θ_LF (one
for a baseline trial) — so the sampler hands out one *sample* per simulation: the HF sample
of a trial, then its LF sample. Once both results are in, the trial is told to the kernel.
Several samples may be outstanding at once (a parallel loop), and results may arrive in any
order. It is written against that interface alone: VerifAI itself is not needed.
"""

import math
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple, Union

from ._savme import Kernel, Record, Trial

Result = Union[float, bool, Tuple[float, float], Dict[str, float]]


@dataclass(frozen=True)
class Sample:
    """One simulation to run: `scenario` with parameters `params` (φ) under the fidelity
    settings `fidelity` (θ_HF for role "hf", the learned θ_LF for role "lf")."""

    trial: Trial
    role: str
    fidelity: Dict[str, Any]
    key: Tuple[int, str] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "key", (self.trial.id, self.role))

    @property
    def scenario(self) -> str:
        return self.trial.scenario

    @property
    def params(self) -> Dict[str, Any]:
        return self.trial.phi


class FalsificationSampler:
    """A VerifAI-style sampler (`next_sample()` / `update(sample, result)`) driven by a kernel.

    threshold: a robustness value ρ < threshold is a failure (VerifAI's convention with the
    default 0: a negative ρ falsifies the specification); `failure_below=False` flips it
    (ρ > threshold fails, e.g. for a collision-energy metric).

    A result is ρ (a float), a failure flag (a bool), (ρ, runtime) or a dict with "rho" (or
    "failure") and optionally "runtime". Without a runtime, the wall-clock time from
    `next_sample()` to `update()` is the run's cost.
    """

    def __init__(self, kernel: Kernel, threshold: float = 0.0, failure_below: bool = True) -> None:
        if not isinstance(kernel, Kernel):
            raise TypeError(f"FalsificationSampler needs a savme.Kernel, got {type(kernel).__name__}")
        if not math.isfinite(threshold):
            raise ValueError(f"threshold must be a finite number, got {threshold!r}")
        self.kernel = kernel
        self.threshold = float(threshold)
        self.failure_below = failure_below
        self._queue: List[Sample] = []
        self._handed: Dict[Tuple[int, str], float] = {}
        self._runs: Dict[int, Dict[str, Tuple[Any, ...]]] = {}
        self.records: List[Record] = []
        """Every told trial's record, in tell order."""

    def next_sample(self) -> Sample:
        """The next simulation to run (asks the kernel for a new trial when needed). A trial
        withdrawn meanwhile (`cancel`, or `kernel.cancel`) hands out no more runs."""
        if self._queue:
            pending = {t.id for t in self.kernel.pending()}
            for gone in {s.trial.id for s in self._queue} - pending:
                self._forget(gone)
        if not self._queue:
            trial = self.kernel.ask()
            self._queue.append(Sample(trial, "hf", self.kernel.theta_hf))
            if trial.paired:
                self._queue.append(Sample(trial, "lf", trial.theta_lf))
            self._runs[trial.id] = {}
        sample = self._queue.pop(0)
        self._handed[sample.key] = time.perf_counter()
        return sample

    def is_failure(self, rho: float) -> bool:
        """Whether robustness `rho` violates the specification."""
        return rho < self.threshold if self.failure_below else rho > self.threshold

    def margin(self, rho: float) -> float:
        """ρ as savme's robustness: how far it is from the threshold on the passing side
        (negative: failed), so the kernel's elite search can learn from near-misses."""
        return rho - self.threshold if self.failure_below else self.threshold - rho

    def _run(self, sample: Sample, result: Result, elapsed: float) -> Tuple[Any, ...]:
        where = f"update(trial {sample.trial.id}, {sample.role})"
        runtime: Optional[float] = None
        value: Any = result
        if isinstance(result, tuple):
            if len(result) != 2:
                raise TypeError(f"{where}: a tuple result must be (rho, runtime), got {result!r}")
            value, runtime = result
        elif isinstance(result, dict):
            unknown = set(result) - {"rho", "failure", "runtime"}
            if unknown or ("rho" in result) == ("failure" in result):
                raise ValueError(
                    f"{where}: a dict result needs exactly one of 'rho' or 'failure' (and maybe "
                    f"'runtime'), got keys {sorted(result)}"
                )
            value = result.get("rho", result.get("failure"))
            runtime = result.get("runtime")
        margin: Optional[float] = None
        if isinstance(value, bool):
            failure = value
        elif isinstance(value, (int, float)):
            if math.isnan(value):
                raise ValueError(f"{where}: the robustness value is NaN")
            failure = self.is_failure(float(value))
            if math.isfinite(value):
                margin = self.margin(float(value))
        else:
            raise TypeError(f"{where}: expected a robustness value (float) or a failure flag, got {value!r}")
        if runtime is None:
            runtime = max(elapsed, 1e-9)
        if margin is None:
            return failure, float(runtime)
        return failure, float(runtime), margin

    def update(self, sample: Sample, result: Result) -> Optional[Record]:
        """Reports a sample's result. Returns the trial's record once all its runs are in
        (None before). Raises KeyError for a sample not handed out (or reported twice)."""
        if sample.key not in self._handed:
            raise KeyError(f"sample of trial {sample.trial.id} ({sample.role}) is not outstanding")
        elapsed = time.perf_counter() - self._handed[sample.key]
        run = self._run(sample, result, elapsed)
        runs = dict(self._runs[sample.trial.id], **{sample.role: run})
        record = None
        if "hf" in runs and (not sample.trial.paired or "lf" in runs):
            # A refused tell (TellError) leaves the sample outstanding and nothing changed.
            record = self.kernel.tell(sample.trial, hf=runs["hf"], lf=runs.get("lf"))
            self.records.append(record)
            del self._runs[sample.trial.id]
        else:
            self._runs[sample.trial.id] = runs
        del self._handed[sample.key]
        return record

    def cancel(self, sample: Union[Sample, Trial, int]) -> Trial:
        """Withdraws a sample's trial (its simulation crashed): the kernel never hears of it
        again, and none of its runs is handed out any more. Returns the trial."""
        if isinstance(sample, Sample):
            trial_id = sample.trial.id
        elif isinstance(sample, Trial):
            trial_id = sample.id
        else:
            trial_id = sample
        trial = self.kernel.cancel(trial_id)
        self._forget(trial.id)
        return trial

    def _forget(self, trial_id: int) -> None:
        """Drops every queued, handed-out and collected run of a withdrawn trial."""
        self._queue = [s for s in self._queue if s.trial.id != trial_id]
        self._handed = {k: v for k, v in self._handed.items() if k[0] != trial_id}
        self._runs.pop(trial_id, None)

    def failures(self) -> List[Trial]:
        """The trials whose high-fidelity run failed (the counterexamples found)."""
        return [r.trial for r in self.records if r.hf[0]]


__all__ = ["FalsificationSampler", "Sample"]
