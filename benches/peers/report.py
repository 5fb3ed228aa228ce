"""Tallies per method, seed and scenario, and the tables (mean ± sd over seeds)."""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field
from typing import Iterable

Cell = tuple[str, tuple[int, ...]]
PER = 1e9  # rates are per 10⁹ work units unless a table says otherwise (`unit`)
UNITS = {1e9: "10⁹", 1e6: "10⁶", 1e3: "10³", 1.0: "1"}


def unit(budgets: Iterable[float]) -> float:
    """The unit of the tables: the largest of 10⁹, 10⁶, 10³, 1 work units that the smallest
    budget reaches (the bundled simulator: 10⁹; an FMU whose runs take a few hundred steps: 10³),
    so that rates read as small numbers."""
    smallest = min((b for b in budgets if b > 0), default=PER)
    return next((u for u in sorted(UNITS, reverse=True) if smallest >= u), 1.0)


@dataclass
class Tally:
    """HF runs, HF failures, work units and failing cells of one part of one method's seed."""

    trials: int = 0
    failures: int = 0
    work: int = 0
    cells: set[Cell] = field(default_factory=set)

    def add(self, other: "Tally") -> None:
        self.trials += other.trials
        self.failures += other.failures
        self.work += other.work
        self.cells |= other.cells


@dataclass
class Outcome:
    """One method on one seed: per scenario, the search and the deployed search."""

    method: str
    seed: int
    search: dict[str, Tally]
    deployed: dict[str, Tally]
    overhead_ms: float | None = None

    def total(self, part: str) -> Tally:
        t = Tally()
        for s in getattr(self, part).values():
            t.add(s)
        return t


def rate(n: int, work: int, per: float = PER) -> float:
    return per * n / work if work > 0 else math.nan


def mean_sd(xs: Iterable[float]) -> tuple[float, float]:
    v = [x for x in xs if not math.isnan(x)]
    if not v:
        return math.nan, math.nan
    return statistics.fmean(v), (statistics.stdev(v) if len(v) > 1 else math.nan)


def fmt(m: tuple[float, float], digits: int = 1) -> str:
    mean, sd = m
    if math.isnan(mean):
        return "–"
    return f"{mean:.{digits}f}" if math.isnan(sd) else f"{mean:.{digits}f} ± {sd:.{digits}f}"


def by_method(outcomes: list[Outcome]) -> dict[str, list[Outcome]]:
    out: dict[str, list[Outcome]] = {}
    for o in outcomes:
        out.setdefault(o.method, []).append(o)
    return out


def metrics(runs: list[Outcome], per: float = PER) -> dict[str, tuple[float, float]]:
    """Per `per` wu (10⁹ by default), mean ± sd over seeds."""
    s = [o.total("search") for o in runs]
    d = [o.total("deployed") for o in runs]
    return {
        "search_failures": mean_sd(rate(t.failures, t.work, per) for t in s),
        "search_cells": mean_sd(rate(len(t.cells), t.work, per) for t in s),
        "deployed_failures": mean_sd(rate(t.failures, t.work, per) for t in d),
        "search_work": mean_sd(t.work / per for t in s),
        "search_trials": mean_sd(float(t.trials) for t in s),
        "search_raw_failures": mean_sd(float(t.failures) for t in s),
        "deployed_work": mean_sd(t.work / per for t in d),
        "overhead_ms": mean_sd(o.overhead_ms if o.overhead_ms is not None else math.nan for o in runs),
    }


def rate_digits(per: float) -> int:
    """Decimals of a rate: 1 per 10⁹ wu (the bundled simulator's tables, as always), 2 per 10⁶ or
    10³ wu (an FMU's counter: rates of a few per unit), 4 per work unit (a quick run's budget of
    a few hundred units)."""
    return 1 if per >= PER else 2 if per >= 1e3 else 4


def main_table(outcomes: list[Outcome], per: float = PER) -> str:
    u, d = UNITS[per], rate_digits(per)
    rows = [
        f"| method | HF failures / {u} wu, search | distinct failing cells / {u} wu, search "
        f"| confirmed failures / {u} wu, deployed | search: HF failures, trials, {u} wu "
        f"| deployed: {u} wu | sampler overhead, ms / trial |",
        "|---|---|---|---|---|---|---|",
    ]
    for method, runs in by_method(outcomes).items():
        m = metrics(runs, per)
        rows.append(
            f"| {method} | {fmt(m['search_failures'], d)} | {fmt(m['search_cells'], d)} "
            f"| {fmt(m['deployed_failures'], d)} | {fmt(m['search_raw_failures'], 0)}, "
            f"{fmt(m['search_trials'], 0)}, {fmt(m['search_work'], 2)} "
            f"| {fmt(m['deployed_work'], 2)} | {fmt(m['overhead_ms'], 2)} |"
        )
    return "\n".join(rows)


def scenario_rates(runs: list[Outcome], scenario: str, per: float = PER) -> tuple[float, float]:
    return mean_sd(
        rate(o.search[scenario].failures, o.search[scenario].work, per)
        if scenario in o.search
        else math.nan
        for o in runs
    )


def scenario_table(
    outcomes: list[Outcome], scenarios: list[str], savme_methods: list[str], per: float = PER
) -> str:
    """HF failures per `per` wu in the search, per scenario, and which peers beat each savme row."""
    methods = by_method(outcomes)
    head = "| scenario | " + " | ".join(methods) + " | peers ahead of " + ", ".join(savme_methods) + " |"
    rows = [head, "|---" * (len(methods) + 2) + "|"]
    for sc in scenarios:
        means = {m: scenario_rates(r, sc, per) for m, r in methods.items()}
        ahead = []
        for sm in savme_methods:
            base = means[sm][0]
            better = [
                f"{m} ({means[m][0] / base:.1f}×)" if base > 0 else m
                for m in methods
                if m not in savme_methods and means[m][0] > base
            ]
            ahead.append(f"{sm}: " + (", ".join(better) if better else "none"))
        cells = " | ".join(fmt(means[m], rate_digits(per)) for m in methods)
        rows.append(f"| {sc} | {cells} | {'; '.join(ahead)} |")
    return "\n".join(rows)


def peers_ahead(outcomes: list[Outcome], savme_methods: list[str], per: float = PER) -> list[str]:
    """Plain sentences: each metric where a peer's mean beats a savme row's."""
    methods = by_method(outcomes)
    names = {
        "search_failures": "HF failures per cost in the search",
        "search_cells": "distinct failing cells per cost",
        "deployed_failures": "confirmed failures per cost in deployment",
    }
    out = []
    ms = {m: metrics(r, per) for m, r in methods.items()}
    for sm in savme_methods:
        for key, label in names.items():
            base = ms[sm][key][0]
            for m in methods:
                if m in savme_methods or math.isnan(ms[m][key][0]) or math.isnan(base):
                    continue
                if ms[m][key][0] > base:
                    d = rate_digits(per)
                    out.append(
                        f"- {label}: {m} {ms[m][key][0]:.{d}f} > {sm} {base:.{d}f} "
                        f"({ms[m][key][0] / base:.2f}×)" if base > 0 else f"- {label}: {m} > {sm}"
                    )
    return out
