#!/usr/bin/env python3
"""A VerifAI-style falsification loop on the savme kernel: the sampler hands out one
simulation at a time (the HF run of a trial, then its LF run), the "simulator" returns a
robustness value ρ (negative: the specification is violated), and the sampler learns both
where ρ goes negative and which cheap fidelity still gets the sign right.

    python3 examples/python/falsify.py
"""

import savme
from harness import FIDELITY, PHI, THETA_HF, simulate
from savme.integrations import FalsificationSampler


def robustness(scenario, params, fidelity):
    """Clearance left at standstill (m) — ρ < 0 is a collision — and the run's cost."""
    fails, runtime = simulate(scenario, params, fidelity)
    stop = params["speed"] ** 2 / 14.0 + params["speed"] / fidelity["rate_hz"]
    return params["gap"] - stop, runtime


def main():
    kernel = savme.Kernel(fidelity=FIDELITY, theta_hf=THETA_HF, scenarios={"dry_road": PHI},
                          budget=0.3, seed=4)
    sampler = FalsificationSampler(kernel, threshold=0.0)
    for _ in range(600):
        sample = sampler.next_sample()
        sampler.update(sample, robustness(sample.scenario, sample.params, sample.fidelity))
    found = sampler.failures()
    print(f"{len(sampler.records)} trials, {len(found)} counterexamples, e.g. {found[0].phi if found else None}")
    print("cheapest agreeing fidelity:", kernel.estimate())


if __name__ == "__main__":
    main()
