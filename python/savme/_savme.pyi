"""Type stubs for savme's Rust extension module (re-exported by the `savme` package)."""

from os import PathLike
from typing import (Any, Callable, Dict, Iterable, List, Literal, Mapping, Optional, Sequence, Tuple, Type,
                    TypedDict, TypeVar, Union, final, overload)

from .history import Trials

_Value = Union[bool, int, float, str]
"""A variable's value: a bool, int, float or str."""

_V = TypeVar("_V", bool, int, float, str)
"""The kind asked of a value by `Trial.phi_as` / `Trial.theta_as`."""

_Phase = Literal["train", "evaluate", "baseline", "test"]
_EstimatorName = Literal["map", "mean", "evidence"]
_RunResult = Tuple[bool, float]
_RunArg = Union[Tuple[bool, float], Tuple[bool, float, float]]
"""One simulation's result as (failure, runtime); runtimes finite and > 0, on a common scale."""

__version__: str
__all__ = [
    "__version__", "TellError", "JournalError", "CampaignError", "Variable", "Space", "Discrete",
    "Boolean", "Continuous", "Trial", "Record", "Posterior", "Kernel", "Estimation", "Protocol", "PROTOCOL_VALUES", "Problem",
    "Campaign", "CampaignResult", "load_campaign", "Driving", "NativeSimulator",
    "Simulator", "ParameterVariation",
    "read_openscenario",
]

class TellError(ValueError):
    """A tell or cancel the kernel refused: an unknown or already told trial, a paired
    observation for a baseline trial (or the reverse), a runtime that is not finite and > 0.
    The message names the trial; the kernel is unchanged."""

class JournalError(Exception):
    """A journal could not be opened, replayed or written: held by another process (the
    message names its pid), a bad line (named by file and line), another configuration, a
    full disk. The kernel is unchanged."""

class CampaignError(Exception):
    """A campaign could not run or finish: its directory, store or stored trials, or a
    simulation that failed (the message names the trial and the simulator's error). A
    campaign stopped this way resumes with resume=True."""

@final
class Variable:
    """One named variable of a Space; made by Discrete, Boolean or Continuous."""

    @property
    def name(self) -> str:
        """The variable's name, unique in its space."""
    @property
    def kind(self) -> Literal["discrete", "continuous"]:
        """Discrete (one arm per value) or continuous (one arm per bin)."""
    @property
    def arms(self) -> int:
        """How many arms the bandit chooses among."""
    @property
    def values(self) -> Optional[List[_Value]]:
        """A discrete variable's values, in arm order (None for a continuous one)."""
    @property
    def range(self) -> Optional[Tuple[float, float, int, Literal["linear", "log", "shifted-log"]]]:
        """A continuous variable's (lo, hi, bins, scale) (None for a discrete one)."""

def Discrete(name: str, values: Sequence[_Value]) -> Variable:
    """A discrete variable with one arm per value (bools, ints, floats or strings).

    Raises ValueError naming the variable for no values, a repeated value or NaN."""

def Boolean(name: str) -> Variable:
    """A boolean variable: arms False and True."""

def Continuous(
    name: str, lo: float, hi: float, bins: int = 10, scale: Literal["linear", "log", "shifted-log"] = "linear"
) -> Variable:
    """A continuous variable on [lo, hi] cut into `bins` arms of equal width ("linear") or
    equal ratio ("log", needs 0 < lo). Values are drawn uniformly (log-uniformly) in a bin.

    Raises ValueError naming the variable for lo >= hi, no bins or a negative number of them,
    a non-positive log range."""

@final
class Space:
    """An ordered, validated list of variables (a scenario's φ, or the fidelity θ)."""

    def __new__(cls, variables: Sequence[Variable]) -> Space:
        """Raises ValueError for no variables or a name used twice (naming it)."""
    @property
    def names(self) -> List[str]:
        """The variables' names, in order."""
    @property
    def variables(self) -> List[Variable]:
        """The variables, in order."""
    def to_json(self) -> str:
        """The space as JSON (the format of the kernel configuration's spaces)."""
    @staticmethod
    def from_json(text: str) -> Space:
        """A space from `to_json()` output; errors name the variable."""
    def __len__(self) -> int: ...
    def __getitem__(self, name: str, /) -> Variable:
        """The variable called `name` (KeyError listing the known names otherwise)."""

@final
class Trial:
    """A suggested trial: run `scenario` with `phi` on the high-fidelity simulator (the
    kernel's `theta_hf`) and, unless it is a baseline trial, with `theta_lf` on the
    learned-fidelity one; then `Kernel.tell` both runs."""

    @property
    def id(self) -> int:
        """Unique id, counting up from 0 in ask order."""
    @property
    def phase(self) -> _Phase:
        """The phase the trial was asked in (its tell is credited by it)."""
    @property
    def scenario(self) -> str:
        """The scenario's name."""
    @property
    def phi(self) -> Dict[str, _Value]:
        """Scenario parameters φ, in space order."""
    @property
    def theta_lf(self) -> Optional[Dict[str, _Value]]:
        """Learned-fidelity settings θ_LF in space order; None for a baseline trial."""
    @property
    def paired(self) -> bool:
        """True when the trial needs both runs (every phase but baseline)."""
    def to_dict(self) -> Dict[str, Any]:
        """The trial as a dict (the JSON of `savme serve`'s trials)."""
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> Trial:
        """A trial from `to_dict()` output; ValueError names the field that is wrong."""
    def phi_as(self, name: str, kind: Type[_V]) -> _V:
        """φ's variable `name` as `kind` (bool, int, float or str), typed for a type checker:
        `trial.phi_as("gap_m", float) < 15`. An int is given as a float; any other mismatch
        raises TypeError naming the variable, an unknown name KeyError."""
    def theta_as(self, name: str, kind: Type[_V]) -> _V:
        """θ_LF's setting `name` as `kind`, as `phi_as`; ValueError for a baseline trial."""
    @staticmethod
    def _from_json(text: str) -> Trial:
        """What unpickling calls: a trial from its JSON."""
    def __reduce__(self) -> Tuple[Callable[[str], Trial], Tuple[str]]:
        """Pickling (`multiprocessing` over trials, copy.deepcopy): the trial exactly."""

@final
class Record:
    """A told trial: what was observed, its class and what the bandits were credited."""

    @property
    def trial(self) -> Trial:
        """The trial as it was asked."""
    @property
    def id(self) -> int:
        """The trial's id."""
    @property
    def outcome(self) -> Optional[Literal["TP", "TN", "FP", "FN"]]:
        """HF failure vs LF failure (TP: both failed); None for a baseline trial."""
    @property
    def cost_ratio(self) -> Optional[float]:
        """t_LF / t_HF; None for a baseline trial."""
    @property
    def credit(self) -> Dict[str, Optional[bool]]:
        """{"fidelity": …, "scenario": …}: the success credited to each bandit (Table II of
        the paper), None when nothing was updated (evaluation and baseline trials)."""
    @property
    def hf(self) -> _RunResult:
        """The HF run as (failure, runtime)."""
    @property
    def lf(self) -> Optional[_RunResult]:
        """The LF run as (failure, runtime); None for a baseline trial."""
    @property
    def hf_robustness(self) -> Optional[float]:
        """The HF run's robustness, if it was told one."""
    @property
    def lf_robustness(self) -> Optional[float]:
        """The LF run's robustness, if it was told one."""
    def to_dict(self) -> Dict[str, Any]:
        """The record as a dict (the JSON of `savme serve`'s records and journal tells)."""
    @staticmethod
    def _from_json(text: str) -> Record:
        """What unpickling calls: a record from its JSON."""
    def __reduce__(self) -> Tuple[Callable[[str], Record], Tuple[str]]:
        """Pickling (`multiprocessing`, copy.deepcopy): the record exactly."""

class _ScenarioPrior(TypedDict):
    """One φ prior carried over to a scenario (meta-testing's p_ψ transfer): the shape of a
    configuration's `scenario_priors` items."""

    scenario: str
    posterior: Posterior

@final
class Posterior:
    """Beta beliefs over the arms of a space: p_ω(θ_LF), or a scenario's p_ψ(φ | s)."""

    @property
    def names(self) -> List[str]:
        """The variables' names, in space order."""
    @property
    def prior(self) -> Tuple[float, float]:
        """The base prior counts (successes, losses)."""
    def arms(self, name: str) -> List[Tuple[float, float]]:
        """(alpha, beta) of every arm of variable `name` (KeyError if there is none)."""
    def means(self, name: str) -> List[float]:
        """The posterior mean of every arm of variable `name`."""
    def to_json(self) -> str:
        """The posterior as JSON (to keep it for a meta-testing kernel)."""
    @staticmethod
    def from_json(text: str) -> Posterior:
        """A posterior from `to_json()` output."""
    def to_dict(self) -> Dict[str, Any]:
        """The posterior as plain data."""

@final
class Kernel:
    """The SAVME ask/tell kernel: Thompson-sampling bandits that learn where the system under
    test fails (per scenario, over φ) and which cheap fidelity settings θ_LF agree with the
    high-fidelity simulator within C_budget.

    Deterministic: the same configuration and calls give the same trials as the Rust kernel
    (and `savme serve`). With `journal=`, every change is written ahead to a crash-safe,
    locked JSON-lines file in the format of `savme serve --journal`; `Kernel.resume(path)`
    (or `savme serve --journal path`) continues it exactly.

    Example::

        kernel = savme.Kernel(fidelity=fidelity, theta_hf={"rate_hz": 10},
                              scenarios={"lead_brakes": phi}, budget=0.3, seed=7)
        for _ in range(100):
            t = kernel.ask()
            kernel.tell(t, hf=run(t.phi, kernel.theta_hf), lf=run(t.phi, t.theta_lf))
        print(kernel.estimate())
    """

    def __new__(
        cls,
        *,
        fidelity: Space,
        theta_hf: Mapping[str, _Value],
        scenarios: Union[Mapping[str, Space], Sequence[Union[Tuple[str, Space], Tuple[str, Space, float]]]],
        budget: float = 0.3,
        seed: int = 0,
        estimator: Optional[_EstimatorName] = None,
        prior: Optional[Tuple[float, float]] = None,
        fidelity_prior: Optional[Posterior] = None,
        prior_strength: float = 1.0,
        journal: Optional[Union[str, PathLike[str]]] = None,
        search: Union[Literal["bins", "elite"], Mapping[str, float], None] = None,
        pair_fraction: float = 1.0,
        pair_settle: int = 30,
        deployment: Optional[Literal["frozen", "exploit", "learn", "adaptive"]] = None,
        allocation: Optional[Literal["weights", "cost-rate", "cost-rate-recent", "cost-rate-scout"]] = None,
        method: Literal["tuned", "paper"] = "tuned",
        history: Union[bool, int, None] = None,
        scenario_priors: Optional[Sequence[_ScenarioPrior]] = None,
    ) -> Kernel:
        """Builds a kernel in the "train" phase.

        fidelity: the fidelity space; theta_hf: the high-fidelity settings (every variable);
        scenarios: {name: φ-space} (equal weights) or [(name, φ-space, weight), …];
        budget: C_budget in (0, 1], the largest cost ratio t_LF / t_HF credited;
        estimator: how evaluation picks θ_LF* — "evidence" (the highest lower 10 % Beta
            quantile, false alarms charged as 1 / C_budget losses; the default with method
            "tuned", as `savme run` and `savme example-config`), "map" (the paper's; the
            default with method "paper") or "mean";
        prior: base Beta prior counts (successes, losses) of every arm, default (1, 1);
        fidelity_prior, prior_strength: meta-testing — start p_ω(θ_LF) from an earlier
        kernel's `fidelity_posterior()`, its evidence scaled by the strength (1 = as learned);
        scenario_priors: meta-testing's φ transfer — [{"scenario": name, "posterior":
        Posterior}, …] (a configuration's `scenario_priors`, `KernelBuilder::scenario_prior`):
        start that scenario's p_ψ(φ | s) from the posterior (e.g. an earlier kernel's
        `scenario_posterior(name)`, or `PhiTransfer`'s prior) instead of the base prior; each
        must name a scenario of the kernel once and fit its φ-space (ValueError otherwise);
        journal: a journal file, created or resumed (it must hold the same configuration);
        method: what search, deployment, allocation and estimator default to — "tuned" (the
        default: savme's search by cost — search "elite" with the ρ model, deployment
        "adaptive", allocation "cost-rate-recent", estimator "evidence") or "paper" (the paper's SAVME —
        "bins", "frozen", "weights", "map"); a value given below wins over the method's;
        search: how train and test draw φ — "bins" (the paper's independent bins), "elite" (a
        joint proposal around failures, candidates ranked per expected cost and, where runs
        report a robustness, by a Gaussian process of it; paired with the same fidelity
        bandit), or a dict of elite-mixture parameters (e.g. {"explore": 0.1}; the rest at
        defaults, switches included);
        pair_fraction, pair_settle: once the greedy arm of every fidelity variable holds
        pair_settle observations, only this share of the learning trials is paired (default 1:
        every trial, so a harness always gets theta_lf; a campaign's tuned method uses 0.25 and
        pair_settle 10); the others
        have no theta_lf (`trial.paired` is False) and are told with the HF run alone;
        deployment: what the "evaluate" phase (evaluation, LF screening) does with what the
        search learned — "frozen" (the paper's), "exploit" (the elite proposal draws for
        failures, not for new cells), "learn" (its results keep teaching the φ search) or
        "adaptive" (both);
        allocation: how each ask chooses its scenario — "weights" (drawn from p(s), the
        paper's), "cost-rate" (a bandit by HF failures per unit cost, every scenario kept
        above 0.6 × its share of p(s) in cost), "cost-rate-recent" (the same, each
        scenario's evidence forgotten with a half-life of 20 told trials; the tuned preset's)
        or "cost-rate-scout" (the same, and until its first HF failure a scenario keeps its
        whole share of p(s) in cost and its trials are unpaired; a tuned campaign's).

        history: what `trials()` keeps of the told records — None or True every one (~320 B
        per told trial on a space of one φ and one θ variable, ~770 B on the paper's 4 φ and
        16 θ: +320 MB / +770 MB after 10⁶ trials), an int N the last N, False (or 0) none (the
        kernel's memory then stays flat however many trials are told; a journal keeps them).

        Raises ValueError naming the variable, scenario or argument at fault (a negative or
        too large `seed`, `pair_settle`, `history`), JournalError for a journal that cannot
        be used."""
    @staticmethod
    def from_config(
        config: str,
        journal: Optional[Union[str, PathLike[str]]] = None,
        *,
        history: Union[bool, int, None] = None,
    ) -> Kernel:
        """A kernel from a configuration in JSON (what `savme serve --config` reads and
        `savme example-config` prints); `history` as for `Kernel(...)`."""
    @staticmethod
    def resume(journal: Union[str, PathLike[str]], *, history: Union[bool, int, None] = None) -> Kernel:
        """Reopens an existing journal, written by Python or `savme serve --journal`: the
        kernel continues exactly (its pending trials are in `pending()`; its told records
        are `trials()`, as many as `history` keeps). A torn last line (a crash mid-write) is
        dropped with a RuntimeWarning."""
    @staticmethod
    def from_json(snapshot: str, *, history: Union[bool, int, None] = None) -> Kernel:
        """A kernel restored from `to_json()` output (not journaled; `trials()` starts empty —
        a pickled kernel keeps its history)."""
    @staticmethod
    def _restore(snapshot: str, history: str, limit: Optional[int] = None) -> Kernel:
        """What unpickling calls: a kernel from its snapshot, history and history limit."""
    @property
    def history_limit(self) -> Optional[int]:
        """How many told records `trials()` keeps: None all of them, else the last N (0:
        none) — the kernel's `history=`."""
    def __reduce__(self) -> Tuple[Callable[[str, str, Optional[int]], Kernel], Tuple[str, str, Optional[int]]]:
        """Pickling (and copy.deepcopy) of an unjournaled kernel, with its history; a
        journaled kernel raises TypeError (its journal has one writer)."""
    def trials(self) -> Trials:
        """The told trials in tell order (each a Record with φ, θ_LF, both runs' failures and
        runtimes, the outcome); `.to_pandas()` gives a DataFrame when pandas is installed.
        Only the last N with `history=N`, none with `history=False`."""
    def optimize(
        self,
        objective: Callable[[Trial], Tuple[_RunResult, Optional[_RunResult]]],
        n_trials: Optional[int] = None,
        *,
        timeout: Optional[float] = None,
        callbacks: Optional[Iterable[Callable[[Kernel, Record], Any]]] = None,
        catch: Union[Type[Exception], Sequence[Type[Exception]], None] = None,
    ) -> Trials:
        """Asks, runs and tells `n_trials` trials (fewer once `timeout` seconds passed; None:
        no limit — with neither, until interrupted), as Optuna's `study.optimize`:
        `objective(trial)` returns `(hf, lf)`, each a (failure, runtime) pair, `lf` None for
        a baseline trial. An exception of a type in `catch` (an exception class or a tuple of
        them, as Optuna takes it) cancels the trial and goes on; any other cancels it and is
        raised. Each of `callbacks` (a list, as Optuna's: a bare callable is a TypeError
        naming `callbacks`) is called as `callback(kernel, record)` after each tell. Returns
        the records told (as many as the kernel's `history` keeps)."""
    def to_json(self) -> str:
        """The complete state (configuration, posteriors, pending trials, random stream)."""
    def config_json(self) -> str:
        """The configuration as JSON (the format `savme serve --config` reads)."""
    @overload
    def ask(self, n: None = None) -> Trial:
        """Suggests the next trial in the current phase."""
    @overload
    def ask(self, n: int) -> List[Trial]:
        """Suggests the next trial in the current phase, or a list of `n` (all or none). Any
        number may be pending at once; tell them in any order."""
    def tell(
        self,
        trial: Union[Trial, int],
        hf: Union[_RunResult, Tuple[bool, float, float]],
        lf: Optional[Union[_RunResult, Tuple[bool, float, float]]] = None,
        *,
        robustness: Optional[float] = None,
        lf_robustness: Optional[float] = None,
    ) -> Record:
        """Ingests a trial's runs, hf=(failure, runtime) and (except for baseline trials)
        lf=(failure, runtime); credits the bandits in the learning phases and returns the
        record. A run may carry its robustness (how close it came to failing; ≤ 0 failed) as
        a third element or as robustness= (HF) / lf_robustness= (LF); the elite search
        learns from it, the paper's bins ignore it. A refused tell (also a non-finite
        robustness) raises TellError naming the trial and changes nothing."""
    def cancel(self, trial: Union[Trial, int]) -> Trial:
        """Withdraws a pending trial (its simulation crashed); it is never told."""
    def set_phase(self, phase: _Phase) -> None:
        """Switches the phase of future asks: "train" (learn φ and θ), "evaluate" (θ = the
        estimate, nothing learned), "baseline" (uniform φ, HF only) or "test" (meta-testing).
        Pending trials keep their phase."""
    @property
    def phase(self) -> _Phase:
        """The phase new asks are drawn in."""
    def estimate(self, estimator: Optional[_EstimatorName] = None) -> Dict[str, _Value]:
        """θ_LF*: the greedy fidelity settings (default: the kernel's estimator), continuous
        settings at their bin's expected value."""
    def estimate_evidence(self, estimator: Optional[_EstimatorName] = None) -> Optional[List[Dict[str, Any]]]:
        """What stands behind θ_LF* (default: the kernel's estimator): per fidelity setting
        {"variable", "arm", "tried", "successes", "tp", "tn", "fp", "fn", "cost",
        "false_alarm_rate", "miss_rate"} over the learning trials; None unless the kernel's
        estimator is "evidence" (the only one that keeps these tallies)."""
    def estimation(
        self,
        *,
        epsilon: float = 0.1,
        seed: int = 0,
        nominal: Optional[Mapping[str, Mapping[str, Mapping[str, Any]]]] = None,
        tilt: Literal["posterior", "nominal-weighted"] = "posterior",
        refine: Optional[Tuple[int, int]] = None,
        refine_reuse: int = 0,
        joint_components: Optional[int] = None,
        pilot_fidelity: Literal["hf", "lf"] = "hf",
        control_calibration: Optional[int] = None,
        control_extra: Optional[int] = None,
    ) -> Estimation:
        """An importance-sampling estimation of P(failure) under the nominal distribution
        from the current φ posteriors (docs/ESTIMATION.md): `epsilon` is the nominal's share
        of the proposal; `nominal` maps scenario → variable → {"distribution": "normal",
        "mean": M, "sd": S} (or "uniform", or "weights" with "weights": [...]) for variables
        that are not uniform; `refine=(rounds, runs)` adds cross-entropy pilot rounds,
        `refine_reuse=k` counts the last k of them in the estimate too, and
        `joint_components=K` (with `refine`) makes the pilot fit a joint proposal — a mixture
        of at most K components over the whole of φ — instead of per-variable bins, and
        `pilot_fidelity="lf"` (with `refine`) marks the pilot's trials "fidelity": "lf": run
        them at the learned θ_LF* (the multi-fidelity estimator; the estimate's trials stay
        HF), and `control_calibration=N` adds LF runs as control variates for the HF
        estimate: N calibration pairs (trials marked "control": "calibration") choose α and
        `control_extra` (extra LF-only runs per pair; given: forced), or HF only when the LF
        does not pay — tell each run's `cost`. ValueError names ε, the refinement, the
        control variates, the scenario or the variable. The kernel is not changed."""
    def fidelity_posterior(self) -> Posterior:
        """p_ω(θ_LF); pass it as `fidelity_prior=` to a meta-testing kernel."""
    def scenario_posterior(self, name: str) -> Posterior:
        """p_ψ(φ | s) of scenario `name` (KeyError listing the known ones otherwise)."""
    def posterior(self) -> Dict[str, Any]:
        """{"fidelity": Posterior, "scenarios": {name: Posterior}}."""
    def pending(self) -> List[Trial]:
        """Trials asked and not yet told or cancelled, in id order."""
    def stats(self) -> Dict[str, int]:
        """{"asked": …, "told": …, "cancelled": …}."""
    @property
    def theta_hf(self) -> Dict[str, _Value]:
        """The high-fidelity settings, in space order."""
    @property
    def budget(self) -> float:
        """C_budget."""
    @property
    def fidelity(self) -> Space:
        """The fidelity space."""
    @property
    def scenarios(self) -> List[str]:
        """The scenarios' names, in order."""
    @property
    def journal(self) -> Optional[PathLike[str]]:
        """The journal's path, or None."""
    def close(self) -> None:
        """Releases the journal and its lock (also on leaving a `with` block); later calls
        raise ValueError."""
    def __enter__(self) -> Kernel: ...
    def __exit__(self, *exc: object) -> bool: ...

@final
class Estimation:
    """P(failure) under the nominal distribution by importance sampling from a fixed
    proposal (made by Kernel.estimation): ask a trial, run the HF simulator on its φ, tell
    the failure, read the estimate."""

    def ask(self) -> Optional[Dict[str, Any]]:
        """The next trial: {"id", "scenario", "scenario_index", "phi", "q", "p", "weight",
        "round"} ("round": the refinement round, None for a trial of the estimate), and
        "fidelity": "lf" on a multi-fidelity estimation's pilot trials (run them at θ_LF*;
        every other trial runs HF); None while a refinement round waits for the outcomes of
        the trials it asked."""
    def tell(
        self, id: int, failure: bool, *, robustness: Optional[float] = None, cost: Optional[float] = None
    ) -> None:
        """The outcome of trial `id` — HF, or LF for a trial marked "fidelity": "lf"
        (savme.TellError if it is not pending), with the run's robustness if any (a joint proposal's pilot aims at the near-misses)
        and its cost (finite, ≥ 0: the control variates' calibration compares LF and HF costs)."""
    def estimate(self) -> Dict[str, Any]:
        """{"total": {"mean", "std_error", "half_width", "lo", "hi"}, "runs", "failures",
        "scenarios": [...]} from the trials after the refinement."""
    @property
    def told(self) -> int:
        """Trials told, refinement and estimate together."""
    @property
    def round(self) -> Optional[int]:
        """The refinement round under way (None: none, or it is over)."""

_SimulatorFn = Callable[
    [str, Dict[str, _Value], Dict[str, _Value]],
    Union[bool, Tuple[bool, int], Tuple[bool, Optional[int], float]],
]
"""A Python simulator: (scenario, phi, theta) -> failure, (failure, work_units), or
(failure, work_units or None, robustness) — robustness: how close the run came to failing
(≤ 0 failed), stored with the trial and learned from by the elite search."""

PROTOCOL_VALUES: List[Dict[str, Any]]
"""Every protocol value as declared once in savme: name (the keyword of Protocol, the
`[campaign]` key of a campaign file), flag (`savme run`'s), help, the stages it changes."""

@final
class Protocol:
    """What a campaign runs: the paper's protocol (or the quick preset) for the given
    meta-training and meta-testing scenarios, any protocol value overridden by its name (see
    PROTOCOL_VALUES); validated (ValueError names the value)."""

    def __new__(
        cls,
        train_scenarios: Sequence[str],
        test_scenarios: Sequence[str],
        *,
        preset: Literal["paper", "quick"] = "paper",
        simulator: str = "python",
        seed: Optional[int] = None,
        budgets: Optional[Sequence[float]] = None,
        train_iterations: Optional[int] = None,
        eval_iterations: Optional[int] = None,
        test_iterations: Optional[int] = None,
        baseline_train_iterations: Optional[int] = None,
        baseline_test_iterations: Optional[int] = None,
        cost: Optional[Literal["wall", "work"]] = None,
        fidelity_bins: Optional[int] = None,
        log_bins: Optional[Literal["savme", "paper"]] = None,
        prior_strength: Optional[float] = None,
        window: Optional[int] = None,
        prior_strengths: Optional[Sequence[float]] = None,
        screen_iterations: Optional[int] = None,
        audit_fraction: Optional[float] = None,
        search: Optional[Literal["bins", "elite"]] = None,
        elite: Optional[Mapping[str, float]] = None,
        pair_fraction: Optional[float] = None,
        pair_settle: Optional[int] = None,
        deployment: Optional[Literal["frozen", "exploit", "learn", "adaptive"]] = None,
        screen_lf: Optional[Literal["always", "where-it-pays"]] = None,
        method: Optional[Literal["tuned", "paper"]] = None,
        allocation: Optional[Literal["weights", "cost-rate", "cost-rate-recent", "cost-rate-scout"]] = None,
        coverage_floor: Optional[float] = None,
        search_budget: Optional[float] = None,
        deploy_budget: Optional[float] = None,
        theta_lf_choice: Optional[Literal["map", "evidence"]] = None,
        transfer: Optional[Literal["fixed", "auto"]] = None,
        ladder: Optional[Sequence[float]] = None,
        ladder_training: Optional[Literal["separate", "shared"]] = None,
        weights: Optional[Mapping[str, float]] = None,
        on_error: Optional[Literal["abort", "skip"]] = None,
    ) -> Protocol:
        """The paper's stages (preset "paper", or the shorter "quick") searched with savme's
        tuned method (method="paper": the paper's SAVME). cost="work" makes a campaign
        reproducible bit for bit (simulators must then return (failure, work_units)); "wall"
        (default) measures each call's wall-clock time. search_budget / deploy_budget: run each
        search / deployed stage until its runs have cost this much (in the cost's unit).
        window: trials in flight; on_error="skip" withdraws a trial whose simulation raised.
        ladder: a fidelity ladder, two or more of the budgets cheapest first (each level
        meta-trained with its own θ_LF); the screening stage at its top budget screens down it.
        ladder_training="shared": only the ladder's top level (one of the budgets) meta-trains;
        the levels below (not budgets) read their θ_LF* off its trials re-credited at their
        budgets.
        weights: p(s) per scenario (a scenario not listed weighs 1); a name that is not one of
        the protocol's scenarios is a KeyError naming it. A value that is NaN, infinite or an
        int beyond 64 bits, or a str for a list of scenarios, is refused naming the value."""
    def to_json(self) -> str:
        """The protocol as JSON (a campaign directory's protocol.json)."""
    def to_dict(self) -> Dict[str, Any]:
        """The protocol as a dict."""
    @staticmethod
    def load(out: Union[str, PathLike[str]]) -> Protocol:
        """The protocol saved in campaign directory `out`."""
    @property
    def total_trials(self) -> Optional[int]:
        """How many trials the campaign runs in all; None when a stage runs by a cost budget
        (search_budget, deploy_budget), whose number of trials is not known in advance."""

@final
class Problem:
    """What a campaign searches: the fidelity space with θ_HF, and each scenario's φ-space."""

    def __new__(
        cls, *, fidelity: Space, theta_hf: Mapping[str, _Value], scenarios: Mapping[str, Space]
    ) -> Problem: ...
    @staticmethod
    def driving(bins: int = 10) -> Problem:
        """The bundled driving simulator's problem (Table I, θ_HF, the ten scenarios)."""
    @property
    def scenarios(self) -> List[str]:
        """The scenarios' names."""

@final
class CampaignResult:
    """A finished campaign."""

    @property
    def out(self) -> PathLike[str]:
        """The campaign directory."""
    @property
    def report(self) -> Dict[str, Any]:
        """The report: baselines, per budget training/evaluation/meta-testing figures."""
    @property
    def table_md(self) -> str:
        """Table III as Markdown (table.md)."""
    @property
    def files(self) -> Dict[str, PathLike[str]]:
        """protocol, trials, table, fidelity, summary, breakeven, meta_testing."""
    @property
    def replayed(self) -> int:
        """Trials replayed from trials.jsonl (a resumed campaign)."""
    @property
    def ran(self) -> int:
        """Trials run by this call."""
    @property
    def elapsed_seconds(self) -> float:
        """Wall-clock seconds this call took."""
    @property
    def runs(self) -> List[CampaignResult]:
        """Each seed's result in seed order (with repeat; else this one)."""
    @property
    def estimate(self) -> Optional[Dict[str, Any]]:
        """The [estimate] stage's summary (a campaign file with one), else None."""

@final
class Campaign:
    """A campaign run by savme's Rust campaign loop, with `savme run`'s outputs and resume.

    Python simulators are called from worker threads, each call holding the GIL; see the
    savme.campaign module for CPU-bound Python simulators."""

    def __new__(
        cls,
        protocol: Optional[Protocol],
        problem: Problem,
        *,
        out: Optional[Union[str, PathLike[str]]] = None,
        resume: bool = False,
        jobs: Optional[int] = None,
        progress: bool = False,
        storage: Optional[str] = None,
        campaign: Optional[str] = None,
        repeat: Optional[int] = None,
        executor: Optional[Union[Literal["local", "ray"], Any]] = None,
    ) -> Campaign:
        """repeat=N runs the protocol with seeds seed … seed+N−1, each in out/seed-<s>/, and
        writes the results over the seeds into `out` (as `savme run --repeat`).
        out: the campaign directory (default "savme-results"); resume=True continues the campaign in `out` (protocol=None takes its
        protocol.json); jobs: worker threads (default: one per core); progress: one line per
        finished stage on stderr; storage="postgresql://USER@HOST/DB" with campaign=NAME keeps
        the protocol and trials in that database instead (`savme run --storage`; the password
        from the URL, PGPASSWORD or ~/.pgpass is never shown), tables and figures still go
        to `out`. A malformed URL raises ValueError; a database that cannot be reached, or a
        campaign another process holds, CampaignError. executor="ray" or
        savme.RayExecutor(address=..., actors=..., timeout=...) runs each HF and LF run on a
        Ray cluster — of Python simulator callables, the bundled simulator (sim=) or a
        campaign file's FMUs (the kernel and store stay here; the same trials as a local run
        under cost="work"); not with jobs= or repeat=."""
    def run(
        self,
        simulate: Optional[_SimulatorFn] = None,
        *,
        hf: Optional[_SimulatorFn] = None,
        lf: Optional[_SimulatorFn] = None,
        sim: Optional[Union[Driving, Simulator]] = None,
        executor: Any = None,
    ) -> CampaignResult:
        """Runs (or resumes) the campaign: one `simulate` callable for both runs, or `hf=`
        and `lf=` callables, or a bundled simulator `sim=`; a campaign from
        `savme.campaign.load` runs its file's simulator (`run()`; a simulator given is a
        TypeError). `executor=` ("ray", savme.RayExecutor(...)) runs this call's runs there,
        whatever the simulator (Python callables, `sim=`, a campaign file's FMUs). Raises CampaignError (a failed simulation names the trial and the
        exception, a bad result the part and its value), ValueError for a bad protocol.
        Ctrl-C stops the campaign between trials (the runs in flight finish) and raises
        KeyboardInterrupt saying where it stopped and the call that resumes it; SIGTERM
        does the same and raises SystemExit(143) (said on stderr) — unless the program has a
        SIGTERM handler of its own. The told trials are stored, so resume=True continues. A
        KeyboardInterrupt or SystemExit the simulator itself raises stops the campaign too
        and is raised as it was."""
    @property
    def protocol(self) -> Protocol:
        """The protocol."""
    @property
    def out(self) -> PathLike[str]:
        """The output directory."""
    @property
    def repeat(self) -> Optional[int]:
        """The number of seeds (None: one campaign)."""

def load_campaign(
    path: Union[str, PathLike[str]],
    *,
    out: Optional[Union[str, PathLike[str]]] = None,
    resume: bool = False,
    jobs: Optional[int] = None,
    progress: bool = False,
    storage: Optional[str] = None,
    campaign: Optional[str] = None,
    executor: Any = None,
) -> Campaign:
    """A campaign file (TOML, as `savme run --config` reads) as a campaign with its FMUs
    bound (`savme.campaign.load`): its protocol, `repeat` and `[estimate]` stage are those
    `savme run --config` runs; storage, campaign and executor as for Campaign (executor=
    runs the FMUs where the executor runs its runs: "ray" ships them to a Ray cluster). Run it with `run()`: it
    refuses a Python simulator (its protocol and outputs name the file's simulator) — for
    one, make a `Campaign` with a `Protocol` and `Problem` of its own."""

@final
class Driving:
    """The bundled driving simulator: the paper's ten scenarios, camera + lidar perception
    with Table I's 16 fidelity settings, the paper's system under test."""

    def __new__(cls, perception: Literal["sensors", "ideal"] = "sensors") -> Driving: ...
    def simulate(
        self, scenario: str, phi: Mapping[str, _Value], theta: Optional[Mapping[str, _Value]] = None
    ) -> Dict[str, Any]:
        """One run (θ_HF by default): {"failure", "wall_seconds", "work", "min_distance",
        "collision_time"}. The GIL is released while it runs."""
    @staticmethod
    def scenarios() -> List[Dict[str, Any]]:
        """The ten scenarios: id, name, description, training (1–8) or not."""
    @staticmethod
    def phi_space(scenario: str) -> Space:
        """A scenario's φ-space (by name or number)."""
    @staticmethod
    def fidelity_space(bins: int = 10) -> Space:
        """Table I: the 16 fidelity settings, continuous ones in `bins` log bins."""
    @staticmethod
    def theta_hf() -> Dict[str, _Value]:
        """θ_HF of Table I."""

@final
class NativeSimulator:
    """A campaign file's FMUs or the bundled simulator built on the node that runs them
    (savme.executors makes one per Ray worker process)."""

    def __new__(cls, spec: str, files: Mapping[str, Union[str, PathLike[str]]]) -> NativeSimulator: ...
    def run(
        self, which: str, scenario: str, phi: Mapping[str, _Value], theta: Mapping[str, _Value]
    ) -> Tuple[Any, ...]:
        """One run: ("ok", value, wall_seconds) or ("error", message)."""

@final
class Simulator:
    """The HF and LF FMUs of a campaign file, their bindings checked (savme.fmu.Simulator)."""

    def __new__(cls, path: Union[str, PathLike[str]]) -> Simulator: ...
    def simulate(
        self,
        scenario: str,
        phi: Mapping[str, _Value],
        theta: Optional[Mapping[str, _Value]] = None,
        role: Literal["hf", "lf"] = "hf",
    ) -> Dict[str, Any]:
        """One run on the HF (or LF) FMU: {"failure", "wall_seconds", "work"}, and "robustness"
        when the file's [failure] gives one (a threshold's margin, a `robustness` output)."""
    @property
    def scenarios(self) -> List[str]:
        """The scenarios' names."""
    def phi_space(self, scenario: str) -> Space:
        """A scenario's φ-space (KeyError if there is none)."""
    @property
    def fidelity(self) -> Space:
        """The fidelity space."""
    @property
    def theta_hf(self) -> Dict[str, _Value]:
        """θ_HF."""

@final
class ParameterVariation:
    """An OpenSCENARIO `ParameterValueDistribution` file, read and checked
    (`savme.openscenario.read`)."""

    @property
    def path(self) -> PathLike[str]:
        """The file."""
    @property
    def scenario_file(self) -> Optional[str]:
        """`ScenarioFile filepath`: the scenario whose parameters vary, as written."""
    @property
    def variation(self) -> Literal["deterministic", "stochastic"]:
        """Which kind of variation the file declares."""
    @property
    def number_of_test_runs(self) -> Optional[int]:
        """`numberOfTestRuns` of a stochastic variation (None if not given)."""
    @property
    def names(self) -> List[str]:
        """The varied parameters' names, in file order."""
    def space(self, bins: int = 10) -> Space:
        """The φ-space: one variable per parameter, continuous ones in `bins` linear bins."""
    @property
    def nominal(self) -> Dict[str, Dict[str, Any]]:
        """The nominal of every parameter that is not uniform, as
        `Kernel.estimation(nominal={scenario: this})` takes it."""
    @property
    def declared_at(self) -> Dict[str, Dict[str, Any]]:
        """Where each parameter's distribution is: {name: {"element": ..., "line": ...}}."""

def read_openscenario(path: Union[str, PathLike[str]]) -> ParameterVariation:
    """Reads a `ParameterValueDistribution` file; ValueError naming the file, line and
    element of what is wrong."""
