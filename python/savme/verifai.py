"""savme inside VerifAI: a `FeatureSampler` that VerifAI's own falsifiers accept.

    from verifai.features import Box, DiscreteBox, Feature, FeatureSpace
    from verifai.falsifier import generic_falsifier
    import savme.verifai

    space = FeatureSpace({"gap": Feature(Box((5, 50))), "lane": Feature(DiscreteBox((0, 2)))})
    sampler = savme.verifai.SavmeSampler(
        space,
        fidelity=savme.Space([savme.Discrete("rate_hz", [2, 5, 10])]),
        theta_hf={"rate_hz": 10},
        budget=0.3, seed=1)
    falsifier = generic_falsifier(sampler=sampler, monitor=sampler.monitor(rho_of),
                                  falsifier_params=DotMap(n_iters=600))  # even: a trial is 2 samples
    falsifier.run_falsifier()          # your simulator client reads sample.rate_hz too
    sampler.flush(falsifier)           # the last ρ (VerifAI passes each with the next request)
    sampler.failures()                 # the HF counterexamples
    sampler.kernel.estimate()          # the cheapest fidelity that agrees with HF

The φ-space comes from the `FeatureSpace`: a `Box` feature becomes one continuous variable per
dimension (`gap`, or `gap[0]`, `gap[1]`, … for a box of several), a `DiscreteBox` one discrete
variable per dimension (its integers), a `Categorical` one discrete variable (its values); a
`Constant` stays constant. Feature lists, arrays and structs are refused (ValueError naming the
feature). The sampler's own space (`sampler.space`, what the falsifier and its error tables
see) is that space plus one feature per fidelity setting θ (a `Categorical` of its values, or a
1-dimensional `Box` for a continuous setting) and `savme_run` ("hf" or "lf"): every savme
trial is two samples, the HF run at θ_HF and the LF run at the learned θ_LF, of the same φ
(baseline trials: the HF run only). The simulator client sets its fidelity from the θ features.
VerifAI's error tables write a categorical feature as its index (`point.savme_run` 0 = "hf").

ρ is VerifAI's robustness value: ρ ≤ threshold (VerifAI's `fal_thres`, 0 by default) is a
failure (a counterexample, as VerifAI's falsifier counts them), and ρ − threshold is the run's
robustness in the kernel (`Run.robustness`). The cost of a run is the wall-clock time from the
sample to its ρ, or what the monitor from `sampler.monitor(fn)` reports (fn returning
(ρ, cost)): a deterministic work count makes the search reproducible. Needs the `verifai`
package (`pip install verifai`); `import savme` alone does not import it.
"""

import math
import time
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

from verifai.features import Box, Categorical, Constant, DiscreteBox, Feature, FeatureSpace
from verifai.monitor import specification_monitor
from verifai.samplers import FeatureSampler

from ._savme import Continuous, Discrete, Kernel, Record, Space, TellError, Trial, Variable

#: The feature that says which run of a trial a sample is.
ROLE = "savme_run"


@dataclass(frozen=True)
class SampleInfo:
    """What `getSample` hands VerifAI with a sample (VerifAI passes it back to `update`)."""

    trial: Trial
    role: str
    theta: Dict[str, Any]

    @property
    def key(self) -> Tuple[int, str]:
        return (self.trial.id, self.role)


def phi_space(space: FeatureSpace, bins: int = 10) -> Tuple[Space, List[Tuple[str, str, List[str]]]]:
    """The savme φ-space of a VerifAI `FeatureSpace`, and how each feature is laid out:
    (feature, kind, its variables' names) with kind "box", "discrete", "categorical" or
    "constant". ValueError names a feature savme cannot search."""
    variables: List[Variable] = []
    layout: List[Tuple[str, str, List[str]]] = []
    for name, feature in space.namedFeatures:
        if feature.lengthDomain is not None:
            raise ValueError(f"feature `{name}`: a feature list (lengthDomain) has no fixed φ-space")
        d = feature.domain
        names = [name] if getattr(d, "dimension", 1) == 1 else [f"{name}[{i}]" for i in range(d.dimension)]
        if isinstance(d, Box):
            variables += [Continuous(n, lo, hi, bins=bins) for n, (lo, hi) in zip(names, d.intervals)]
            layout.append((name, "box", names))
        elif isinstance(d, DiscreteBox):
            variables += [Discrete(n, list(range(lo, hi + 1))) for n, (lo, hi) in zip(names, d.intervals)]
            layout.append((name, "discrete", names))
        elif isinstance(d, Categorical):
            variables.append(Discrete(name, list(d.values)))
            layout.append((name, "categorical", [name]))
        elif isinstance(d, Constant):
            layout.append((name, "constant", []))
        else:
            raise ValueError(
                f"feature `{name}`: a {type(d).__name__} domain is not supported (give Box, "
                "DiscreteBox, Categorical or Constant features)"
            )
    if not variables:
        raise ValueError("the feature space has no Box, DiscreteBox or Categorical feature to search")
    return Space(variables), layout


def _fidelity_feature(var: Variable) -> Feature:
    if var.values is not None:
        return Feature(Categorical(*var.values))
    lo, hi, _, _ = var.range  # type: ignore[misc]
    return Feature(Box((lo, hi)))


class SavmeSampler(FeatureSampler):  # type: ignore[misc]
    """A VerifAI `FeatureSampler` whose samples the savme kernel chooses (see the module).

    space: the VerifAI `FeatureSpace` of the scenario parameters φ; fidelity, theta_hf: the
    simulator's fidelity settings θ and their high-fidelity values; budget, seed: the
    kernel's; bins: bins per continuous φ variable; threshold: ρ ≤ threshold is a failure;
    scenario: the scenario's name in the kernel. `kernel` is the savme kernel (switch its
    phase, read its estimate and posteriors there).
    """

    def __init__(
        self,
        space: FeatureSpace,
        *,
        fidelity: Space,
        theta_hf: Dict[str, Any],
        budget: float = 0.3,
        seed: int = 0,
        bins: int = 10,
        threshold: float = 0.0,
        scenario: str = "verifai",
    ) -> None:
        if not isinstance(space, FeatureSpace):
            raise TypeError(f"SavmeSampler needs a verifai FeatureSpace, got {type(space).__name__}")
        if not math.isfinite(threshold):
            raise ValueError(f"threshold must be a finite number, got {threshold!r}")
        phi, self._layout = phi_space(space, bins)
        self.phi_space = space
        self.scenario = scenario
        self.kernel = Kernel(fidelity=fidelity, theta_hf=dict(theta_hf), scenarios={scenario: phi},
                             budget=budget, seed=seed)
        features = dict(space.featureNamed)
        for var in fidelity.variables:
            if var.name in features or var.name == ROLE:
                raise ValueError(f"fidelity setting `{var.name}` has the name of a feature of the space")
            features[var.name] = _fidelity_feature(var)
        features[ROLE] = Feature(Categorical("hf", "lf"))
        super().__init__(FeatureSpace(features))
        self.fidelity_names = fidelity.names
        self.threshold = float(threshold)
        self._queue: List[SampleInfo] = []
        self._handed: Dict[Tuple[int, str], float] = {}
        self._runs: Dict[int, Dict[str, Tuple[bool, float, float]]] = {}
        self._reported_cost: Optional[float] = None
        self.records: List[Record] = []
        """Every told trial's record, in tell order."""

    # --- VerifAI's sampler API -------------------------------------------------------------

    def getSample(self) -> Tuple[Any, SampleInfo]:
        """The next sample (a point of `self.space`) and its info: the HF run of a new trial,
        or the LF run of the last one. A trial withdrawn meanwhile hands out no more runs."""
        if self._queue:
            pending = {t.id for t in self.kernel.pending()}
            for gone in {s.trial.id for s in self._queue} - pending:
                self._forget(gone)
        if not self._queue:
            trial = self.kernel.ask()
            self._queue.append(SampleInfo(trial, "hf", self.kernel.theta_hf))
            if trial.paired:
                self._queue.append(SampleInfo(trial, "lf", trial.theta_lf))
            self._runs[trial.id] = {}
        info = self._queue.pop(0)
        self._handed[info.key] = time.perf_counter()
        return self.point(info), info

    def update(self, sample: Any, info: SampleInfo, rho: Any) -> Optional[Record]:
        """Takes ρ of a sample; tells the kernel once both runs of its trial are in and
        returns the record (None before). KeyError for a sample not outstanding; TellError
        for a sample whose trial was withdrawn meanwhile (`sampler.kernel.cancel(trial)`)."""
        if info.key not in self._handed:
            raise KeyError(f"sample of trial {info.trial.id} ({info.role}) is not outstanding")
        where = f"update(trial {info.trial.id}, {info.role})"
        if all(t.id != info.trial.id for t in self.kernel.pending()):
            self._forget(info.trial.id)
            raise TellError(f"{where}: trial {info.trial.id} was withdrawn on the kernel "
                            "(kernel.cancel): its runs are not taken any more")
        if isinstance(rho, (tuple, list)) or hasattr(rho, "__len__"):
            raise TypeError(f"{where}: savme needs one robustness value ρ, got {rho!r} (multi-objective monitors are not supported)")
        try:
            value = float(rho)
        except (TypeError, ValueError):
            value = None
        if value is None or isinstance(rho, bool):
            raise TypeError(f"{where}: expected a robustness value ρ (a number), got {rho!r}")
        if not math.isfinite(value):
            raise ValueError(f"{where}: the robustness value is {value}")
        elapsed = time.perf_counter() - self._handed[info.key]
        cost = self._reported_cost if self._reported_cost is not None else max(elapsed, 1e-9)
        self._reported_cost = None
        run = (value <= self.threshold, cost, value - self.threshold)
        runs = dict(self._runs[info.trial.id], **{info.role: run})
        record = None
        if "hf" in runs and (not info.trial.paired or "lf" in runs):
            record = self.kernel.tell(info.trial, hf=runs["hf"], lf=runs.get("lf"))
            self.records.append(record)
            del self._runs[info.trial.id]
        else:
            self._runs[info.trial.id] = runs
        del self._handed[info.key]
        return record

    def flush(self, falsifier: Any) -> Optional[Record]:
        """Tells the falsifier's last ρ. VerifAI hands a sampler each ρ with the request for
        the next sample, so after `run_falsifier()` the last sample's ρ is still with the
        falsifier's server: call this once it returns (a no-op if there is none).

        A trial run only half (its HF run without its LF run: an odd `n_iters`, since each
        savme trial is two samples) is not told: a RuntimeWarning names it. It stays pending —
        the next sample is its other run — or withdraw it with `sampler.cancel(trial)`."""
        info = getattr(self, "last_info", None)
        rho = getattr(getattr(falsifier, "server", None), "lastValue", None)
        record = None
        if self.last_sample is not None and info is not None and rho is not None and info.key in self._handed:
            record = self.update(self.last_sample, info, rho)
            self.last_sample = None
        self._warn_half_run(getattr(falsifier, "n_iters", None))
        return record

    def _warn_half_run(self, n_iters: Optional[int]) -> None:
        """Warns of each trial with a run in and its other run not (so not told)."""
        for trial_id, runs in self._runs.items():
            if not runs:
                continue
            missing = "lf" if "hf" in runs else "hf"
            why = f"n_iters={n_iters} is odd and " if isinstance(n_iters, int) and n_iters % 2 else ""
            warnings.warn(
                f"trial {trial_id} has its {'/'.join(runs)} run but not its {missing} run, so it is not told: "
                f"{why}every savme trial is two samples (HF and LF). The next sample is its {missing} run "
                f"(run the falsifier on), or withdraw it with sampler.cancel({trial_id})",
                RuntimeWarning, stacklevel=3)

    # --- savme's side ----------------------------------------------------------------------

    def point(self, info: SampleInfo) -> Any:
        """The sample of `info` as a point of `self.space`."""
        phi = info.trial.phi
        values: Dict[str, Any] = {}
        for name, kind, names in self._layout:
            if kind == "box":
                values[name] = tuple(float(phi[n]) for n in names)
            elif kind == "discrete":
                values[name] = tuple(int(phi[n]) for n in names)
            elif kind == "categorical":
                values[name] = phi[name]
            else:
                values[name] = self.phi_space.featureNamed[name].domain.value
        for name in self.fidelity_names:
            v = info.theta[name]
            values[name] = v if isinstance(self.space.featureNamed[name].domain, Categorical) else (float(v),)
        values[ROLE] = info.role
        return self.space.makePoint(**values)

    def monitor(self, fn: Callable[[Any], Union[float, Tuple[float, float]]]) -> specification_monitor:
        """A VerifAI monitor from `fn(simulation data)` → ρ, or (ρ, cost): the cost (e.g. the
        simulator's work count) becomes the run's cost instead of the wall-clock time."""
        sampler = self

        class _Monitor(specification_monitor):  # type: ignore[misc]
            def __init__(self) -> None:
                super().__init__(fn)

            def evaluate(self, traj: Any) -> Any:
                out = fn(traj)
                if isinstance(out, tuple):
                    if len(out) != 2 or not float(out[1]) > 0:
                        raise ValueError(f"the monitor returned {out!r}: expected ρ or (ρ, cost > 0)")
                    sampler._reported_cost = float(out[1])
                    return out[0]
                return out

        return _Monitor()

    def cancel(self, info: Union[SampleInfo, Trial, int]) -> Trial:
        """Withdraws a sample's trial (its simulation crashed): the kernel never hears of it,
        and none of its runs is handed out any more."""
        trial_id = info.trial.id if isinstance(info, SampleInfo) else info.id if isinstance(info, Trial) else info
        trial = self.kernel.cancel(trial_id)
        self._forget(trial.id)
        return trial

    def _forget(self, trial_id: int) -> None:
        self._queue = [s for s in self._queue if s.trial.id != trial_id]
        self._handed = {k: v for k, v in self._handed.items() if k[0] != trial_id}
        self._runs.pop(trial_id, None)

    def failures(self) -> List[Trial]:
        """The trials whose high-fidelity run failed (the counterexamples found)."""
        return [r.trial for r in self.records if r.hf[0]]


__all__ = ["ROLE", "SampleInfo", "SavmeSampler", "phi_space"]
