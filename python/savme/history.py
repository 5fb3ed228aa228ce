"""The kernel's trial history (`Kernel.trials()`) and the `Kernel.optimize` loop, for users who
know Optuna (python/README.md maps its concepts to savme's)."""

from __future__ import annotations

import collections
import time
from typing import TYPE_CHECKING, Any, Deque, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Type, Union

if TYPE_CHECKING:  # pragma: no cover
    from ._savme import Kernel, Record, Trial


class Trials(List["Record"]):
    """The told trials, in tell order: a list of `savme.Record` with a table view."""

    def rows(self) -> List[Dict[str, Any]]:
        """One flat dict per trial: id, phase, scenario, phi.<name>…, theta_lf.<name>…,
        hf_failure, hf_runtime, lf_failure, lf_runtime (None for a baseline trial), outcome,
        cost_ratio."""
        rows = []
        for record in self:
            trial = record.trial
            row: Dict[str, Any] = {"id": trial.id, "phase": trial.phase, "scenario": trial.scenario}
            row.update({f"phi.{k}": v for k, v in trial.phi.items()})
            row.update({f"theta_lf.{k}": v for k, v in (trial.theta_lf or {}).items()})
            hf, lf = record.hf, record.lf
            row.update(hf_failure=hf[0], hf_runtime=hf[1],
                       lf_failure=lf[0] if lf else None, lf_runtime=lf[1] if lf else None,
                       outcome=record.outcome, cost_ratio=record.cost_ratio)
            rows.append(row)
        return rows

    def to_pandas(self) -> Any:
        """The trials as a pandas DataFrame (one row per trial, the columns of `rows()`).
        Raises ImportError saying so when pandas is not installed."""
        try:
            import pandas
        except ImportError as exc:
            raise ImportError("Trials.to_pandas() needs pandas (pip install pandas); "
                              "Trials.rows() gives the same table as dicts") from exc
        return pandas.DataFrame(self.rows())


_Run = Tuple[bool, float]


def _catch_classes(catch: Any) -> Tuple[Type[BaseException], ...]:
    """`catch=`: an exception class or an iterable of them, as Optuna takes it."""
    if catch is None:
        return ()
    classes = (catch,) if isinstance(catch, type) else catch
    try:
        classes = tuple(classes)
    except TypeError:
        raise TypeError(f"catch must be an exception class or a tuple of them, got {catch!r}") from None
    for c in classes:
        if not (isinstance(c, type) and issubclass(c, BaseException)):
            raise TypeError(f"catch must be an exception class or a tuple of them; {c!r} is not an exception class")
    return classes


def _callback_list(callbacks: Any) -> List[Callable[["Kernel", "Record"], Any]]:
    """`callbacks=`: a list (any iterable) of callables, as Optuna takes it; a bare callable is
    refused naming the argument (Optuna fails on it too, after the first trial)."""
    if callbacks is None:
        return []
    if callable(callbacks) and not isinstance(callbacks, (list, tuple)):
        raise TypeError(f"callbacks must be a list of callables (as in Optuna), got the callable {callbacks!r}: "
                        "give callbacks=[cb]")
    try:
        listed = list(callbacks)
    except TypeError:
        raise TypeError(f"callbacks must be a list of callables, got {callbacks!r}") from None
    for cb in listed:
        if not callable(cb):
            raise TypeError(f"callbacks must be a list of callables; {cb!r} is not callable")
    return listed


def optimize(kernel: "Kernel", objective: Callable[["Trial"], Tuple[_Run, Optional[_Run]]],
             n_trials: Optional[int] = None, timeout: Optional[float] = None,
             callbacks: Optional[Iterable[Callable[["Kernel", "Record"], Any]]] = None,
             catch: Union[Type[BaseException], Sequence[Type[BaseException]], None] = None) -> Trials:
    """`Kernel.optimize`: see its docstring."""
    if n_trials is not None and (isinstance(n_trials, bool) or not isinstance(n_trials, int) or n_trials < 0):
        raise ValueError(f"n_trials must be an int >= 0 or None (no limit), got {n_trials!r}")
    if timeout is not None and (isinstance(timeout, bool) or not (timeout > 0 and timeout != float("inf"))):
        raise ValueError(f"timeout must be a finite number of seconds > 0 (or None), got {timeout!r}")
    callbacks = _callback_list(callbacks)
    catch = _catch_classes(catch)
    # The records returned: as many as the kernel's history keeps (the last ones).
    told: Deque["Record"] = collections.deque(maxlen=kernel.history_limit)
    start = time.monotonic()
    count = 0
    while n_trials is None or count < n_trials:
        if timeout is not None and time.monotonic() - start >= timeout:
            break
        count += 1
        trial = kernel.ask()
        try:
            result = objective(trial)
        except BaseException as exc:
            kernel.cancel(trial)
            if catch and isinstance(exc, catch) and isinstance(exc, Exception):
                continue
            raise
        try:
            hf, lf = result
        except (TypeError, ValueError):
            kernel.cancel(trial)
            raise TypeError(f"objective(trial {trial.id}) must return (hf, lf): each a (failure, runtime) "
                            f"pair, lf None for a baseline trial; got {result!r}") from None
        record = kernel.tell(trial, hf, lf)
        told.append(record)
        for callback in callbacks:
            callback(kernel, record)
    return Trials(told)
