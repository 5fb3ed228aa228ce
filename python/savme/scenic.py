"""The paired HF/LF search on a Scenic program: φ = the program's VerifAI parameters
(`VerifaiRange`, `VerifaiDiscreteRange`, `VerifaiOptions`) and its global parameters drawn
from a `Range`, `DiscreteRange` or `Options`; θ = the fidelity settings of your simulator.

    import savme, savme.scenic

    def simulate(scene, theta):              # one run of a scene at fidelity θ
        sim = scenic.simulators.newtonian.NewtonianSimulator()
        result = sim.simulate(scene, maxSteps=int(8 / theta["timestep"]), timestep=theta["timestep"])
        return min_distance(result.trajectory) - 2.0   # ρ: ≤ 0 is a failure

    search = savme.scenic.ScenicSearch(
        "crossing.scenic", simulate=simulate,
        fidelity=savme.Space([savme.Discrete("timestep", [0.05, 0.2, 0.5])]),
        theta_hf={"timestep": 0.05}, budget=0.3, seed=1)
    search.run(300)                          # meta-training trials
    search.kernel.estimate()                 # the cheapest timestep that agrees with HF
    search.failures()                        # φ of the HF failures

Each trial samples ONE scene for its φ (the program's other random values drawn by Scenic as
usual) and simulates it twice, at θ_HF and at the learned θ_LF, so the two runs differ in
fidelity only. VerifAI parameters are set through Scenic's external sampler; a global
parameter is set by compiling the program with it (`scenarioFromFile(params=…)`, about
0.2 s per trial). φ variables are named after their global parameter (`param gap =
VerifaiRange(…)` → `gap`), else `param0`, `param1`, … in the order Scenic lists its external
parameters (as VerifAI names them); `VerifaiOptions` and `Options` give the index of the
option. `simulate` returns ρ, or (ρ, cost); ρ ≤ threshold is a failure and ρ − threshold the
run's robustness; the cost is the wall-clock time of `simulate` unless it returns one.
"""

import math
import time
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import scenic
from scenic.core.distributions import DiscreteRange, Options, Range, RejectionException
from scenic.core.external_params import (
    ExternalSampler,
    VerifaiDiscreteRange,
    VerifaiOptions,
    VerifaiParameter,
    VerifaiRange,
)

from ._savme import Continuous, Discrete, Kernel, Record, Space, Trial, Variable

Simulate = Callable[[Any, Dict[str, Any]], Union[float, Tuple[float, float]]]


class _FixedSampler(ExternalSampler):  # type: ignore[misc]
    """Scenic's external sampler handing out the φ of the current trial."""

    def __init__(self, params: Tuple[Any, ...], global_params: Dict[str, Any]) -> None:
        super().__init__(params, global_params)
        self.params = params
        for index, p in enumerate(params):
            p.sampler = self
            p.index = index
        self.current: Tuple[Any, ...] = ()

    def nextSample(self, feedback: Any) -> Tuple[Any, ...]:
        return self.current

    def valueFor(self, param: Any) -> Any:
        # VerifaiRange / VerifaiDiscreteRange take a 1-dimensional box point.
        return (self.cachedSample[param.index],)


def _variable(name: str, dist: Any, bins: int) -> Optional[Variable]:
    """The φ variable of a Scenic (or VerifAI) distribution, None for a fixed value."""
    if isinstance(dist, VerifaiRange):
        (lo, hi), = dist.domain.intervals
        return Continuous(name, lo, hi, bins=bins)
    if isinstance(dist, VerifaiDiscreteRange):
        (lo, hi), = dist.domain.intervals
        return Discrete(name, list(range(lo, hi + 1)))
    if isinstance(dist, Range):
        return Continuous(name, float(dist.low), float(dist.high), bins=bins)
    if isinstance(dist, DiscreteRange):
        return Discrete(name, list(range(int(dist.low), int(dist.high) + 1)))
    if isinstance(dist, Options):
        return Discrete(name, list(range(len(dist.options))))
    return None


class ScenicSearch:
    """savme's paired search on the Scenic program at `path` (see the module).

    fidelity, theta_hf: θ and its high-fidelity values; simulate(scene, theta): one run;
    budget, seed: the kernel's; bins: bins per continuous φ variable; threshold: ρ ≤
    threshold fails; params, model: passed to `scenic.scenarioFromFile`; max_iterations:
    Scenic's rejection sampling per scene. ValueError for a program without parameters to
    search, or with a VerifAI parameter of another kind.
    """

    def __init__(
        self,
        path: str,
        *,
        fidelity: Space,
        theta_hf: Dict[str, Any],
        simulate: Simulate,
        budget: float = 0.3,
        seed: int = 0,
        bins: int = 10,
        threshold: float = 0.0,
        scenario: str = "scenic",
        params: Optional[Dict[str, Any]] = None,
        model: Optional[str] = None,
        max_iterations: int = 100,
    ) -> None:
        if not math.isfinite(threshold):
            raise ValueError(f"threshold must be a finite number, got {threshold!r}")
        self.path = str(path)
        self.simulate = simulate
        self.threshold = float(threshold)
        self.max_iterations = max_iterations
        self._params = dict(params or {})
        self._model = model
        compiled = self._compile({})
        variables: List[Variable] = []
        # The global parameters (a VerifAI parameter assigned to one is named after it).
        named: Dict[int, str] = {}
        self._globals: List[str] = []
        for name, value in compiled.params.items():
            if name in self._params:
                continue
            if isinstance(value, VerifaiParameter):
                named[id(value)] = name
            elif isinstance(value, VerifaiOptions):
                named[id(value.index)] = name  # its selector is the external parameter
            elif (var := _variable(name, value, bins)) is not None:
                variables.append(var)
                self._globals.append(name)
        self._external: List[str] = []
        for index, p in enumerate(compiled.externalParams):
            name = named.get(id(p), f"param{index}")
            var = _variable(name, p, bins)
            if var is None:
                raise ValueError(
                    f"{self.path}: external parameter `{name}` is a {type(p).__name__}: savme "
                    "searches VerifaiRange, VerifaiDiscreteRange and VerifaiOptions"
                )
            variables.append(var)
            self._external.append(name)
        if not variables:
            raise ValueError(
                f"{self.path}: no parameter to search (give VerifaiRange/VerifaiDiscreteRange/"
                "VerifaiOptions values, or global parameters drawn from a Range, DiscreteRange or Options)"
            )
        self.phi_space = Space(variables)
        self.scenario = scenario
        self.kernel = Kernel(fidelity=fidelity, theta_hf=dict(theta_hf),
                             scenarios={scenario: self.phi_space}, budget=budget, seed=seed)
        self._compiled = compiled
        self.records: List[Record] = []
        """Every told trial's record, in tell order."""
        self.rejected: List[Trial] = []
        """Trials withdrawn because Scenic found no scene for their φ."""

    def _compile(self, overrides: Dict[str, Any]) -> Any:
        params = dict(self._params, **overrides)
        return scenic.scenarioFromFile(self.path, params=params, model=self._model)

    def scene(self, phi: Dict[str, Any]) -> Any:
        """A scene of the program with parameters `phi` (RejectionException if Scenic finds
        none within max_iterations)."""
        compiled = self._compiled
        if self._globals:
            compiled = self._compile({name: self._global_value(name, phi[name]) for name in self._globals})
        if compiled.externalParams:
            sampler = _FixedSampler(compiled.externalParams, compiled.params)
            sampler.current = tuple(phi[name] for name in self._external)
            compiled.externalSampler = sampler
        scene, _ = compiled.generate(maxIterations=self.max_iterations)
        return scene

    def _global_value(self, name: str, value: Any) -> Any:
        dist = self._compiled.params[name]
        return dist.options[value] if isinstance(dist, Options) else value

    def _run(self, scene: Any, theta: Dict[str, Any]) -> Tuple[bool, float, float]:
        start = time.perf_counter()
        out = self.simulate(scene, theta)
        elapsed = time.perf_counter() - start
        rho, cost = out if isinstance(out, tuple) else (out, max(elapsed, 1e-9))
        rho = float(rho)
        if not math.isfinite(rho):
            raise ValueError(f"simulate returned ρ = {rho} for θ = {theta}")
        return (rho <= self.threshold, float(cost), rho - self.threshold)

    def step(self) -> Optional[Record]:
        """One trial: ask, sample its scene, run it at θ_HF (and θ_LF), tell. None if Scenic
        found no scene for the trial's φ (the trial is withdrawn, in `rejected`). If
        `simulate` raises, the trial is withdrawn and the error raised."""
        trial = self.kernel.ask()
        try:
            scene = self.scene(trial.phi)
        except RejectionException:
            self.rejected.append(self.kernel.cancel(trial))
            return None
        try:
            hf = self._run(scene, self.kernel.theta_hf)
            lf = self._run(scene, trial.theta_lf) if trial.paired else None
        except BaseException:
            # A run that raised (or was interrupted) is never told: withdraw the trial so the
            # kernel asks on as if it had not been asked.
            self.kernel.cancel(trial)
            raise
        record = self.kernel.tell(trial, hf=hf, lf=lf)
        self.records.append(record)
        return record

    def run(self, trials: int, phase: Optional[str] = None) -> List[Record]:
        """`trials` trials (in `phase` if given: "train", "evaluate", "baseline", "test");
        returns their records."""
        if phase is not None:
            self.kernel.set_phase(phase)
        out = []
        for _ in range(trials):
            record = self.step()
            if record is not None:
                out.append(record)
        return out

    def failures(self) -> List[Trial]:
        """The trials whose high-fidelity run failed."""
        return [r.trial for r in self.records if r.hf[0]]


__all__ = ["ScenicSearch"]
