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


def per_seed_rate(row: dict, part: str, key: str, scenario: str | None = None) -> float:
    parts = row[part] if scenario is None else {scenario: row[part].get(scenario, {})}
    n = sum(s.get(key, 0) for s in parts.values())
    work = sum(s.get("work", 0) for s in parts.values())
    return n / work if work > 0 else math.nan


def mean(xs) -> float:
    v = [x for x in xs if not math.isnan(x)]
    return statistics.fmean(v) if v else math.nan


def family(rows: list[dict], savme: str) -> dict:
    methods = sorted({r["method"] for r in rows})
    peers = [m for m in methods if m.startswith("VerifAI")]
    by = {m: [r for r in rows if r["method"] == m] for m in methods}
    out = {}
    for part, key, name in METRICS:
        means = {m: mean(per_seed_rate(r, part, key) for r in by[m]) for m in methods}
        best = max(peers, key=lambda m: -1 if math.isnan(means[m]) else means[m])
        out[name] = (means[savme], best, means[best])
    scenarios = sorted({s for r in by[savme] for s in r["search"]})
    worst = (math.inf, "", "")
    for sc in scenarios:
        mine = mean(per_seed_rate(r, "search", "failures", sc) for r in by[savme])
        theirs = {p: mean(per_seed_rate(r, "search", "failures", sc) for r in by[p]) for p in peers}
        best = max(peers, key=lambda p: -1 if math.isnan(theirs[p]) else theirs[p])
        ratio = mine / theirs[best] if theirs[best] > 0 else math.inf
        if ratio < worst[0]:
            worst = (ratio, sc, best)
    out["worst scenario"] = worst
    return out


def ratio_text(mine: float, peer: str, theirs: float) -> str:
    r = mine / theirs if theirs > 0 else math.inf
    return f"{r:.2f}× ({peer.removeprefix('VerifAI ')})"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("families", nargs="+", metavar="NAME=DIR")
    ap.add_argument("--method", default="savme", help="savme's row (default: savme, its defaults)")
    args = ap.parse_args()
    header = ["family", *(m[2] for m in METRICS), "worst scenario, search"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    logs: dict[str, list[float]] = {m[2]: [] for m in METRICS}
    for item in args.families:
        name, _, d = item.partition("=")
        rows = json.loads((Path(d) / "outcomes.json").read_text())
        f = family(rows, args.method)
        cells = [name]
        for _, _, m in METRICS:
            mine, peer, theirs = f[m]
            cells.append(ratio_text(mine, peer, theirs))
            if theirs > 0 and mine > 0:
                logs[m].append(math.log(mine / theirs))
        r, sc, peer = f["worst scenario"]
        cells.append(f"{r:.2f}× ({sc}, {peer.removeprefix('VerifAI ')})")
        lines.append("| " + " | ".join(cells) + " |")
    geo = ["geometric mean"] + [
        f"{math.exp(statistics.fmean(v)):.2f}×" if v else "–" for v in logs.values()
    ] + ["–"]
    lines.append("| " + " | ".join(geo) + " |")
    print(f"savme (`{args.method}`) against the best VerifAI sampler per family and metric:\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
