#!/usr/bin/env python3
"""A Python harness on the `savme` package: meta-training on two scenarios with a crash-safe
journal, evaluation of the learned fidelity, then meta-testing on a new scenario with the
learned fidelity posterior as its prior.

The "simulators" are a stand-in: a one-dimensional emergency brake whose low-fidelity version
reacts later at a coarse simulation rate and ignores sensor noise; replace `simulate` with
calls into your simulator.

    python3 examples/python/harness.py --journal train.journal   # kill it; run it again: it resumes
"""

import argparse
import os

import savme

FIDELITY = savme.Space([
    savme.Discrete("rate_hz", [5, 10, 20, 50, 100]),
    savme.Boolean("sensor_noise"),
    savme.Continuous("horizon_s", 3.0, 15.0, bins=4),
])
THETA_HF = {"rate_hz": 100, "sensor_noise": True, "horizon_s": 15.0}
PHI = savme.Space([savme.Continuous("speed", 5, 35, bins=6), savme.Continuous("gap", 10, 120, bins=6)])


def simulate(scenario, phi, theta):
    """(failure, runtime): stopping distance v²/2a plus the reaction distance of one control
    step beyond the gap fails; the cost grows with the rate and the horizon."""
    decel = 7.0 if scenario != "wet_road" else 5.0
    reaction = phi["speed"] / theta["rate_hz"] + (0.15 if theta["sensor_noise"] else 0.0)
    fails = phi["speed"] ** 2 / (2 * decel) + phi["speed"] * reaction > phi["gap"]
    return fails, theta["rate_hz"] * theta["horizon_s"] / 1500.0


def run(kernel, n):
    for _ in range(n):
        t = kernel.ask()
        hf = simulate(t.scenario, t.phi, kernel.theta_hf)
        lf = simulate(t.scenario, t.phi, t.theta_lf) if t.paired else None
        kernel.tell(t, hf=hf, lf=lf)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--journal", default="train.journal", help="the meta-training journal")
    ap.add_argument("--iterations", type=int, default=400,
                    help="trials told to the training kernel in all (a resumed journal's count)")
    a = ap.parse_args()
    scenarios = {"dry_road": PHI, "highway": PHI}
    if os.path.exists(a.journal):
        train = savme.Kernel.resume(a.journal)  # after a crash: exactly where it stopped
        for t in train.pending():  # trials asked but never told: run them now
            train.tell(t, hf=simulate(t.scenario, t.phi, train.theta_hf), lf=simulate(t.scenario, t.phi, t.theta_lf))
    else:
        train = savme.Kernel(fidelity=FIDELITY, theta_hf=THETA_HF, scenarios=scenarios,
                             budget=0.3, seed=1, journal=a.journal)
    with train:
        run(train, max(0, a.iterations - train.stats()["told"]))
        print("meta-training:", train.stats(), "θ_LF* =", train.estimate())
        trained = train.to_json()
    # Evaluation on a copy of the trained kernel (not journaled): the journal holds the
    # training trials only, so a rerun continues training and evaluates again from there.
    evaluation = savme.Kernel.from_json(trained)
    evaluation.set_phase("evaluate")
    records = []
    for _ in range(50):
        t = evaluation.ask()
        records.append(evaluation.tell(t, hf=simulate(t.scenario, t.phi, THETA_HF), lf=simulate(t.scenario, t.phi, t.theta_lf)))
    agree = sum(r.outcome in ("TP", "TN") for r in records) / len(records)
    cost = sum(r.cost_ratio for r in records) / len(records)
    print(f"evaluation: LF agrees with HF on {agree:.0%} of trials at {cost:.2f} × the HF cost")
    prior = evaluation.fidelity_posterior()  # evaluation learns nothing: the trained posterior

    test = savme.Kernel(fidelity=FIDELITY, theta_hf=THETA_HF, scenarios={"wet_road": PHI},
                        budget=0.3, seed=2, fidelity_prior=prior, prior_strength=1.0)
    test.set_phase("test")
    run(test, 100)
    print("meta-testing:", test.stats(), "θ_LF* =", test.estimate())


if __name__ == "__main__":
    main()
