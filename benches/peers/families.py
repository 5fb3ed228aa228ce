#!/usr/bin/env python3
"""The peer benchmark over simulator families: savme (its defaults) against the best VerifAI
sampler on each family, and the geometric mean of the ratios over the families.

    python3 benches/peers/families.py 'bundled 1–8=target/peers/w3-train' \
        'bundled 9–10=target/peers/w3-test' 'braking FMU, train=target/peers/w3-braking-train' …

Each DIR is an output directory of `benches/peers/run.py` (its `outcomes.json`). Per family and
metric — HF failures per unit of work in the search, distinct failing joint cells per unit of
work in the search, HF-confirmed failures per unit of work in the deployed search — the mean
over seeds of savme's row (`--method savme`, default `savme`) and of each peer, the best peer
and savme's ratio to it; then the worst per-scenario ratio of the search (savme's HF failures
per unit of work in a scenario against the best peer's in that scenario, each at its own work
in it). The geometric mean is over the families' ratios. Nothing is re-run: the rows are what
run.py measured.

`--split work` (default) compares with the peers that split their budget by equal work per
scenario (rows `VerifAI <peer>`), `--split trials` with those split by equal trials (rows
`VerifAI <peer>, by trials`, from `run.py --peer-split work,trials`).
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
from pathlib import Path

METRICS = (
    ("search", "failures", "HF failures / wu, search"),
    ("search", "cells", "failing cells / wu, search"),
    ("deployed", "failures", "confirmed failures / wu, deployed"),
)
BY_TRIALS = ", by trials"


def per_seed_rate(row: dict, part: str, key: str, scenario: str | None = None) -> float:
    parts = row[part] if scenario is None else {scenario: row[part].get(scenario, {})}
    n = sum(s.get(key, 0) for s in parts.values())
    work = sum(s.get("work", 0) for s in parts.values())
    return n / work if work > 0 else math.nan


def mean(xs) -> float:
    v = [x for x in xs if not math.isnan(x)]
    return statistics.fmean(v) if v else math.nan


def sd(xs) -> float:
    v = [x for x in xs if not math.isnan(x)]
    return statistics.stdev(v) if len(v) > 1 else math.nan


def is_peer(method: str, split: str) -> bool:
    """A VerifAI row of the view: split by equal work, or (`trials`) by equal trials."""
    return method.startswith("VerifAI") and method.endswith(BY_TRIALS) == (split == "trials")


def has_view(rows: list[dict], savme: str, split: str) -> bool:
    """Whether the outcomes hold the savme row and peers of the split (a family stopped for
    time may have run one split only)."""
    methods = {r["method"] for r in rows}
    return savme in methods and any(is_peer(m, split) for m in methods)


def missing_note(families: list[tuple[str, list[dict]]], savme: str, split: str) -> list[str]:
    missing = [name for name, rows in families if not has_view(rows, savme, split)]
    return ["", f"Not in this table (no `{savme}` row or no peers split by equal {split} in its "
            f"outcomes): {', '.join(missing)}."] if missing else []


def best_of(peers: list[str], means: dict[str, float]) -> str:
    return max(peers, key=lambda m: -1 if math.isnan(means[m]) else means[m])


def family(rows: list[dict], savme: str, split: str = "work") -> dict:
    """Per metric: savme's mean rate, the best peer of the view and its mean rate (and the sd
    over seeds of both, under `sd`); the worst scenario's search ratio."""
    methods = sorted({r["method"] for r in rows})
    peers = [m for m in methods if is_peer(m, split)]
    if savme not in methods or not peers:
        raise SystemExit(f"no `{savme}` row or no peers split by {split} in these outcomes")
    by = {m: [r for r in rows if r["method"] == m] for m in methods}
    out: dict = {"sd": {}, "peer seeds": {}}
    for part, key, name in METRICS:
        means = {m: mean(per_seed_rate(r, part, key) for r in by[m]) for m in methods}
        best = best_of(peers, means)
        out[name] = (means[savme], best, means[best])
        out["peer seeds"][name] = len(by[best])
        out["sd"][name] = tuple(sd(per_seed_rate(r, part, key) for r in by[m]) for m in (savme, best))
    scenarios = sorted({s for r in by[savme] for s in r["search"]})
    worst = (math.inf, "", "")
    for sc in scenarios:
        mine = mean(per_seed_rate(r, "search", "failures", sc) for r in by[savme])
        theirs = {p: mean(per_seed_rate(r, "search", "failures", sc) for r in by[p]) for p in peers}
        best = best_of(peers, theirs)
        ratio = mine / theirs[best] if theirs[best] > 0 else math.inf
        if ratio < worst[0]:
            worst = (ratio, sc, best)
    out["worst scenario"] = worst
    out["seeds"] = len(by[savme])
    return out


def short(peer: str) -> str:
    return peer.removeprefix("VerifAI ").removesuffix(BY_TRIALS)


def seeds_note(n: int, seeds: int) -> str:
    """`, 1 seed` when the peer's mean is over fewer seeds than savme's (a row that did not run
    on every seed, e.g. Bayesian optimisation stopped for time)."""
    return "" if n >= seeds else f", {n} seed{'s' if n > 1 else ''}"


def ratio_text(mine: float, peer: str, theirs: float, note: str = "") -> str:
    r = mine / theirs if theirs > 0 else math.inf
    return f"{r:.2f}× ({short(peer)}{note})"


def load(item: str) -> tuple[str, list[dict]]:
    name, _, d = item.partition("=")
    return name, json.loads((Path(d) / "outcomes.json").read_text())


def ratio_table(families: list[tuple[str, list[dict]]], savme: str, split: str) -> str:
    """savme's ratio to the best peer per family and metric, the worst scenario, the geometric
    mean over the families."""
    header = ["family", *(m[2] for m in METRICS), "worst scenario, search"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    logs: dict[str, list[float]] = {m[2]: [] for m in METRICS}
    for name, rows in families:
        if not has_view(rows, savme, split):
            continue
        f = family(rows, savme, split)
        cells = [name]
        for _, _, m in METRICS:
            mine, peer, theirs = f[m]
            cells.append(ratio_text(mine, peer, theirs, seeds_note(f["peer seeds"][m], f["seeds"])))
            if theirs > 0 and mine > 0:
                logs[m].append(math.log(mine / theirs))
        r, sc, peer = f["worst scenario"]
        cells.append(f"{r:.2f}× ({sc}, {short(peer)})")
        lines.append("| " + " | ".join(cells) + " |")
    geo = ["geometric mean"] + [
        f"{math.exp(statistics.fmean(v)):.2f}×" if v else "–" for v in logs.values()
    ] + ["–"]
    lines.append("| " + " | ".join(geo) + " |")
    return "\n".join(lines + missing_note(families, savme, split))


def rate(x: float, s: float, per: float) -> str:
    digits = 1 if per >= 1e9 else 2
    if math.isnan(x):
        return "–"
    return f"{x * per:.{digits}f}" + ("" if math.isnan(s) else f" ± {s * per:.{digits}f}")


def rates_table(families: list[tuple[str, list[dict]]], savme: str, split: str,
                units: dict[str, float]) -> str:
    """The rates behind the ratios (mean ± sd over seeds, per each family's unit)."""
    names = {1e9: "10⁹", 1e6: "10⁶", 1e3: "10³", 1.0: "1"}
    lines = ["| family (per … wu) | seeds | savme: search / cells / deployed | best peer, search "
             "| best peer, cells | best peer, deployed |", "|---|---|---|---|---|---|"]
    for name, rows in families:
        if not has_view(rows, savme, split):
            continue
        f, per = family(rows, savme, split), units.get(name, 1e9)
        mine = " / ".join(rate(f[m][0], f["sd"][m][0], per) for _, _, m in METRICS)
        theirs = [f"{short(f[m][1])} {rate(f[m][2], f['sd'][m][1], per)}"
                  + (f" ({f['peer seeds'][m]} of the seeds)" if f["peer seeds"][m] < f["seeds"] else "")
                  for _, _, m in METRICS]
        lines.append(f"| {name} ({names[per]}) | {f['seeds']} | {mine} | " + " | ".join(theirs) + " |")
    return "\n".join(lines + missing_note(families, savme, split))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("families", nargs="+", metavar="NAME=DIR")
    ap.add_argument("--method", default="savme", help="savme's row (default: savme, its defaults)")
    ap.add_argument("--split", choices=("work", "trials"), default="work",
                    help="the peers compared with: split by equal work (default) or by equal trials")
    args = ap.parse_args()
    fams = [load(item) for item in args.families]
    print(f"savme (`{args.method}`) against the best VerifAI sampler (split by equal {args.split}) "
          "per family and metric:\n")
    print(ratio_table(fams, args.method, args.split))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
