#!/usr/bin/env python3
"""A fidelity ladder against the two-level screening (docs/RESULTS.md, "A fidelity ladder").

    python3 benches/ladder_compare.py LADDER_OUT TWO_LEVEL_OUT

LADDER_OUT and TWO_LEVEL_OUT: two `savme reproduce --repeat N` directories of the same protocol
(the ladder's may meta-train its top budget only: `--ladder-training shared`),
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

# With meta-training charged too: each screening stage's found failures over the cost of the
# stages it needs — its budget's train@ and evaluate@ and itself; a ladder with separate
# meta-training also each lower level's train@ and evaluate@ (with ladder_training = shared
# those stages do not exist, so they cost nothing).
def stage_costs(d):
    costs = {}
    for line in (d / "trials.jsonl").read_text().splitlines():
        t = json.loads(line)
        st_ = t.get("stage")
        if st_ is None:
            continue
        c = sum((t.get(k) or {}).get("runtime", 0.0) for k in ("hf", "lf"))
        c += sum((r.get("lf") or {}).get("runtime", 0.0) for r in t.get("ladder") or [])
        costs[st_] = costs.get(st_, 0.0) + c
    return costs


def need(costs, b, levels=()):
    total = 0.0
    for x in (b, *levels):
        for kind in ("train", "evaluate"):
            total += costs.get(f"{kind}@{x:g}", 0.0)
    return total + costs.get(f"screen@{b:g}", 0.0)


charged = []
for s, ladder, b, best, _ in rows:
    ca, cb = stage_costs(lad / s), stage_costs(two / s)
    top = max(k for k in [lv["budget"] for lv in ladder[3]])
    lower = [lv["budget"] for lv in ladder[3][:-1]]
    lad_rate = ladder[0] / need(ca, top, lower)
    two_rates = {k: v[0] / need(cb, k) for k, v in b.items()}
    k_best = max(two_rates, key=two_rates.get)
    charged.append(lad_rate / two_rates[k_best])
    print(f"{s}, meta-training and evaluation charged: ladder {lad_rate*1e9:.1f}/1e9 wu "
          f"(train+evaluate {sum(v for k, v in ca.items() if k.startswith(('train@', 'evaluate@'))):.3e}); " +
          "; ".join(f"two-level {k}: {r*1e9:.1f}" for k, r in sorted(two_rates.items())) +
          f"; ratio vs best ({k_best}) {charged[-1]:.3f}")
print("ratio with meta-training charged, per seed:", [f"{x:.3f}" for x in charged],
      "mean", f"{st.mean(charged):.3f}", "sd", f"{st.stdev(charged):.3f}" if len(charged) > 1 else "")
