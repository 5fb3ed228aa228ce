#!/usr/bin/env python3
"""Rates at equal work from a run_highway_env.py output, for a row stopped for time (Bayesian
optimisation): each row's search runs in the order run, cut at the work the partial row had
spent (runs/ROW-seed-S.partial.json), as HF failures and distinct failing cells per 10⁶ wu of
that prefix, per seed and scenario. Standard library only; savme's search rows come from
runs/ in trial order (its trials.jsonl order), so a prefix is what it had found by then.

    python3 benches/peers/highway_prefix.py target/peers/full-highway/highway [ROW]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

BINS = 6  # run_highway_env.py's cells: 6 linear bins per φ variable


def prefix(runs: list, work: float) -> list:
    """The runs until their work reaches `work` (the run that reaches it counts)."""
    out, spent = [], 0
    for r in runs:
        if spent >= work:
            break
        out.append(r)
        spent += r[3]
    return out


def rates(runs: list, boxes: dict) -> tuple[float, float, float]:
    work = sum(r[3] for r in runs) or 1
    fails = [r for r in runs if r[2]]
    cells = {(r[0], tuple(min(int((r[1][k] - lo) / (hi - lo) * BINS), BINS - 1)
                          for k, (lo, hi) in boxes[r[0]].items())) for r in fails}
    return 1e6 * len(fails) / work, 1e6 * len(cells) / work, work / 1e6


def main() -> int:
    out = Path(sys.argv[1])
    stopped = sys.argv[2] if len(sys.argv) > 2 else "bayesopt"
    runs = {}
    for f in sorted((out / "runs").glob("*.json")):
        r = json.loads(f.read_text())
        runs[(r["row"] + (" (partial)" if f.name.endswith(".partial.json") else ""), r["seed"])] = r
    # φ boxes from the runs themselves would be biased: take highway-env's from the adapter
    from savme.integrations import highway_env as hw  # run with target/highway-peers-venv's python

    boxes = {sc: {n: (lo, hi) for n, lo, hi, _, _ in hw.SCENARIOS[sc].variables} for sc in hw.SCENARIOS}
    for (row, seed), partial in sorted(runs.items()):
        if row != f"{stopped} (partial)":
            continue
        work = sum(r[3] for r in partial["search"])
        print(f"seed {seed}: {stopped} stopped after {len(partial['search'])} search runs, "
              f"{work / 1e6:.1f} M wu of {partial['budgets'][0] / 1e6:.1f} M, {partial['cpu_s'] / 60:.0f} "
              f"min CPU (updated {partial['updated']}); each row's first {work / 1e6:.1f} M wu of its search:")
        print("| row | HF failures / 10⁶ wu | failing cells / 10⁶ wu | per scenario: HF failures / 10⁶ wu of its work |")
        print("|---|---:|---:|---|")
        for (other, s), r in sorted(runs.items()):
            if s != seed or other.endswith("(partial)") and other != row:
                continue
            cut = prefix(r["search"], work)
            f, c, _ = rates(cut, boxes)
            per = "; ".join(f"{sc} {rates([x for x in cut if x[0] == sc], boxes)[0]:.2f} "
                            f"({sum(x[3] for x in cut if x[0] == sc) / 1e6:.1f} M wu)"
                            for sc in sorted({x[0] for x in cut}))
            print(f"| {other} | {f:.2f} | {c:.2f} | {per} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
