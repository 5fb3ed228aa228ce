#!/usr/bin/env python3
"""The Python package's per-call regression guard (issue 39 item 6): ask + read φ and θ_LF +
tell through the `savme` package on the paper's space with the paper's method, after 1,000
told (the space and outcome of `benches/python_ask_tell.py`), timed as a ratio to a fixed pure-Python reference loop measured in interleaved batches of
the same run (the fastest batch of each kept; a shared, noisy machine moves both), compared with the ratio recorded in
`benches/python_guard.json`. Exits 1 when the ratio is more than 10 % above its record.

    SAVME_PY_VENV=target/bench-venv python/develop.sh --release   # the package, release build
    target/bench-venv/bin/python benches/python_guard.py            # check
    target/bench-venv/bin/python benches/python_guard.py --record   # rewrite the record
"""

import json
import math
import os
import random
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from python_ask_tell import FIDELITY, PHI, THETA_HF, outcome  # noqa: E402  (the same space)

import savme  # noqa: E402

TOLERANCE = 1.10
# Many short interleaved batches (~3 ms), the fastest of each side kept: on a shared machine
# the least disturbed batch is the one that measures the code.
BATCHES = 201
TRIALS = 500
UNITS = 500
RECORD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "python_guard.json")
NAME = "package_ask_read_tell"
KEYS = [f"k{i}" for i in range(20)]


def reference_unit(rng):
    """A fixed unit of harness-like Python work: 20 draws into a dict, `exp`, look-ups."""
    d = {k: rng.random() for k in KEYS}
    return sum(math.exp(-d[k] * d[k]) for k in ("k1", "k5", "k9", "k13")) + len(d)


def kernel():
    """The paper's method (its cost per call does not grow with the history; the tuned
    method's elite search does, up to full archives), warmed with 1,000 told trials as the
    kernel's own guard is."""
    phi = savme.Space([savme.Continuous(n, 1.0, 30.0, bins=10) for n in PHI])
    k = savme.Kernel(fidelity=savme.Space(FIDELITY), theta_hf=THETA_HF,
                     scenarios={"lead_vehicle": phi}, budget=0.3, seed=1, method="paper")
    for _ in range(1_000):
        t = k.ask()
        hf, lf = outcome(t.phi, t.theta_lf)
        k.tell(t, hf=hf, lf=lf)
    return k


def measure():
    """Seconds per trial of the package and per reference unit: the fastest of interleaved
    batches."""
    k = kernel()
    rng = random.Random(7)
    per_trial, per_unit = [], []
    for _ in range(BATCHES):
        t0 = time.perf_counter()
        for _ in range(UNITS):
            reference_unit(rng)
        per_unit.append((time.perf_counter() - t0) / UNITS)
        t0 = time.perf_counter()
        for _ in range(TRIALS):
            t = k.ask()
            hf, lf = outcome(t.phi, t.theta_lf)
            k.tell(t, hf=hf, lf=lf)
        per_trial.append((time.perf_counter() - t0) / TRIALS)
    return min(per_trial), min(per_unit)


def main():
    trial, unit = measure()
    ratio = trial / unit
    print(f"{NAME}: {trial * 1e6:.2f} µs per ask+read+tell, reference {unit * 1e6:.2f} µs: "
          f"ratio {ratio:.3f}")
    if "--record" in sys.argv:
        with open(RECORD, "w", encoding="utf-8") as f:
            json.dump({NAME: ratio}, f, indent=2)
            f.write("\n")
        print(f"recorded in {RECORD}")
        return 0
    try:
        with open(RECORD, encoding="utf-8") as f:
            was = json.load(f)[NAME]
    except (OSError, KeyError) as e:
        print(f"{RECORD}: {e}; run with --record first", file=sys.stderr)
        return 2
    regressed = ratio > was * TOLERANCE
    print(f"{NAME}: ratio {ratio:.3f} against {was:.3f} recorded: "
          f"{'REGRESSION' if regressed else 'ok'}")
    return 1 if regressed else 0


if __name__ == "__main__":
    sys.exit(main())
