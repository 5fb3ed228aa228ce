#!/usr/bin/env python3
"""The SAVME authors' Python code against the `savme` package: one sample + update per trial on
the paper's space (the space and synthetic outcome of `benches/python_ask_tell.py`), the two
timed in interleaved blocks of the same run, so that their ratio holds on a loaded machine.

The authors' code (https://github.com/sisl/SAVME, `SAVME/settings.py` and `SAVME/variable.py`)
is not part of this repository; give the path of a checkout. Its dependencies: torch and numpy.

    python3 -m venv /tmp/authors-venv
    /tmp/authors-venv/bin/pip install torch numpy target/wheels/savme-*.whl   # a release wheel
    /tmp/authors-venv/bin/python benches/authors_ask_tell.py --authors PATH/TO/SAVME

A trial of the authors' code is what `MetaEnv.train_one_step_hf_lf` does around the simulator,
without its printing and its pickling of the whole history (which grows with every step):
Thompson-sample the scenario's and the fidelity settings (`Settings.sample_from_prior`: one
`torch.distributions.Beta` draw per arm), classify the outcome, update both
(`Settings.update_prior`). A trial of the package: ask, read φ and θ_LF, tell (the paper's
method). Prints per-trial medians over the blocks (wall and CPU) and the ratio.
"""

import argparse
import os
import random
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from python_ask_tell import FIDELITY, PHI, THETA_HF, outcome  # noqa: E402  (the same space)

import savme  # noqa: E402

BUDGET = 0.3


def authors_config():
    """The paper's space in the authors' `Settings` format: discrete and Boolean settings as
    discrete values, log-scaled ones as continuous with their log bins, φ in 10 linear bins."""
    fidelity = {}
    for v in FIDELITY:
        if v.kind == "discrete":
            fidelity[v.name] = {"var_type": "discrete", "values": tuple(v.values)}
        else:
            lo, hi, bins, scale = v.range
            fidelity[v.name] = {"var_type": "continuous", "values": (lo, hi), "bins": bins,
                                "bin_edge_type": "log" if scale == "log" else "linear"}
    scenario = {n: {"var_type": "continuous", "values": (1.0, 30.0), "bins": 10,
                    "bin_edge_type": "linear"} for n in PHI}
    return scenario, fidelity


def authors_block(settings_cls):
    scenario_cfg, fidelity_cfg = authors_config()
    scenario = settings_cls(scenario_cfg)
    fidelity = settings_cls(fidelity_cfg)

    def block(n):
        for _ in range(n):
            phi = scenario.sample_from_prior()
            theta = fidelity.sample_from_prior()
            (hf, hf_cost), (lf, lf_cost) = outcome(phi, theta)
            cost = lf_cost / hf_cost
            # MetaEnv.train_one_step_hf_lf's classification: TP/TN within the budget is a
            # fidelity success; an HF failure (TP or FN) is a scenario success.
            fidelity.update_prior(int(hf == lf and cost <= BUDGET), theta)
            scenario.update_prior(int(hf), phi)
    return block


def package_block():
    space = savme.Space([savme.Continuous(n, 1.0, 30.0, bins=10) for n in PHI])
    k = savme.Kernel(fidelity=savme.Space(FIDELITY), theta_hf=THETA_HF,
                     scenarios={"lead_vehicle": space}, budget=BUDGET, seed=1, method="paper")

    def block(n):
        for _ in range(n):
            t = k.ask()
            hf, lf = outcome(t.phi, t.theta_lf)
            k.tell(t, hf=hf, lf=lf)
    return block


def timed(block, n):
    c0, t0 = time.process_time(), time.perf_counter()
    block(n)
    return (time.perf_counter() - t0) / n * 1e6, (time.process_time() - c0) / n * 1e6


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--authors", required=True, help="a checkout of the authors' SAVME code")
    ap.add_argument("--trials", type=int, default=200, help="trials per block (authors' code)")
    ap.add_argument("--package-trials", type=int, default=20000, help="trials per block (package)")
    ap.add_argument("--reps", type=int, default=7, help="blocks of each, interleaved")
    a = ap.parse_args()
    sys.path.insert(0, os.path.abspath(a.authors))
    import numpy as np
    import torch
    from SAVME.settings import Settings

    random.seed(1)
    np.random.seed(1)
    torch.manual_seed(1)
    theirs, ours = authors_block(Settings), package_block()
    theirs(a.trials)  # warm up
    ours(2000)
    rows = {"authors": [], "package": []}
    for _ in range(a.reps):
        rows["authors"].append(timed(theirs, a.trials))
        rows["package"].append(timed(ours, a.package_trials))
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in rows.items()}
    print(f"torch {torch.__version__}, numpy {np.__version__}, savme {savme.__version__}, "
          f"load average {os.getloadavg()[0]:.1f}")
    print("| per sample + update (median of the blocks) | wall | CPU |")
    print("|---|---|---|")
    print(f"| the authors' code (`Settings.sample_from_prior` + `update_prior`, torch) "
          f"| {med['authors'][0]:.1f} µs | {med['authors'][1]:.1f} µs |")
    print(f"| the `savme` package (ask + read φ, θ_LF + tell, paper's method) "
          f"| {med['package'][0]:.2f} µs | {med['package'][1]:.2f} µs |")
    print(f"| ratio authors ÷ package | {med['authors'][0] / med['package'][0]:.0f} × "
          f"| {med['authors'][1] / med['package'][1]:.0f} × |")


if __name__ == "__main__":
    main()
