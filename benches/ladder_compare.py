#!/usr/bin/env python3
"""A fidelity ladder against the two-level screening (docs/RESULTS.md, "A fidelity ladder").

    python3 benches/ladder_compare.py LADDER_OUT TWO_LEVEL_OUT

LADDER_OUT and TWO_LEVEL_OUT: two `savme reproduce --repeat N` directories of the same protocol,
the first with `--ladder`. Per seed: confirmed failures per unit cost of each screening stage (HF-confirmed failures /
every run's cost), the ladder's against the best two-level one; and per level of the ladder."""
import json, sys, pathlib, statistics as st
lad, two = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
rows = []
for seed_dir in sorted(lad.glob("seed-*")):
    s = seed_dir.name
    def screens(d):
        out = {}
        rep = json.loads((d / "summary.json").read_text())["report"]
        for b in rep["budgets"]:
            x = b.get("screening")
            if not x:
                continue
            c = x["counts"]
            found = c["confirmed"] + c.get("margin_found", 0) + c.get("direct_found", 0)
            cost = c["lf_runtime"] + c["hf_runtime"]
            out[b["budget"]] = (found, cost, found / cost, x["levels"], c)
        return out
    a, b = screens(seed_dir), screens(two / s)
    top = max(a)
    ladder = a[top]
    best = max(b.items(), key=lambda kv: kv[1][2])
    same_low = {k: (a[k][0], a[k][1]) == (b[k][0], b[k][1]) for k in a if k != top}
    rows.append((s, ladder, b, best, same_low))
    print(f"{s}: ladder {ladder[0]} in {ladder[1]:.3e} = {ladder[2]*1e9:.1f}/1e9 wu; " +
          "; ".join(f"two-level {k}: {v[0]} in {v[1]:.3e} = {v[2]*1e9:.1f}" for k, v in sorted(b.items())) +
          f"; ratio vs best ({best[0]}) {ladder[2]/best[1][2]:.3f}; low stage identical: {same_low}")
    for lv in ladder[3]:
        print(f"   level {lv['budget']}: runs {lv['runs']} flagged {lv['flagged']} confirmed {lv['confirmed']} skipped {lv['skipped']} cost {lv['runtime']:.3e} ({lv['runtime']/max(lv['runs'],1):.3e}/run)")
    c = ladder[4]
    print(f"   HF: cost {c['hf_runtime']:.3e}; trials {c['trials']} direct {c.get('direct',0)} audited {c['audited']} misses {c['audit_misses']}")
    for k, v in sorted(b.items()):
        lv = v[3][0]; c = v[4]
        print(f"   two-level {k}: LF runs {lv['runs']} flagged {lv['flagged']} confirmed {lv['confirmed']} skipped {lv['skipped']} LF cost {lv['runtime']:.3e} ({lv['runtime']/max(lv['runs'],1):.3e}/run); HF cost {c['hf_runtime']:.3e}; trials {c['trials']}")
ratios = [r[1][2] / r[3][1][2] for r in rows]
print("ratio ladder / best two-level per seed:", [f"{x:.3f}" for x in ratios],
      "mean", f"{st.mean(ratios):.3f}", "sd", f"{st.stdev(ratios):.3f}" if len(ratios) > 1 else "")
