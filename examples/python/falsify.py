#!/usr/bin/env python3
"""savme inside VerifAI's own falsifier: `savme.verifai.SavmeSampler` is the falsifier's
sampler, a VerifAI socket client runs the simulations, and a monitor turns each run into a
robustness value ρ (negative: the specification is violated) and its cost. Every savme trial
is two samples — the HF run at θ_HF and the LF run at the learned θ_LF — so the kernel learns
both where ρ goes negative and which cheap fidelity still gets the sign right.

    pip install verifai        # VerifAI 2.2; then, with the savme package installed:
    python3 examples/python/falsify.py
"""

import argparse
import threading

from dotmap import DotMap
from verifai.client import Client
from verifai.falsifier import generic_falsifier
from verifai.features import Box, Feature, FeatureSpace

from harness import FIDELITY, THETA_HF, simulate
import savme.verifai

SPACE = FeatureSpace({"speed": Feature(Box((5, 35))), "gap": Feature(Box((10, 120)))})


class Simulator(Client):
    """The simulator side: a sample (φ and θ features) in, the run's data out."""

    def simulate(self, sample):
        phi = {"speed": sample.speed[0], "gap": sample.gap[0]}
        theta = {name: getattr(sample, name) for name in FIDELITY.names}
        theta["horizon_s"] = theta["horizon_s"][0]  # a continuous setting is a 1-D Box
        _, runtime = simulate("dry_road", phi, theta)
        stop = phi["speed"] ** 2 / 14.0 + phi["speed"] / theta["rate_hz"]
        return {"clearance": phi["gap"] - stop, "runtime": runtime}


def serve(client, done):
    while not done.is_set():
        try:
            client.run_client()
        except RuntimeError:  # the falsifier closed its server
            return


def main(iterations=600, port=8888):
    sampler = savme.verifai.SavmeSampler(SPACE, fidelity=FIDELITY, theta_hf=THETA_HF,
                                         budget=0.3, seed=4, scenario="dry_road")
    falsifier = generic_falsifier(
        sampler=sampler,
        monitor=sampler.monitor(lambda run: (run["clearance"], run["runtime"])),
        falsifier_params=DotMap(n_iters=iterations, save_error_table=True, save_safe_table=False),
        server_options=DotMap(port=port),
    )
    done = threading.Event()
    client = threading.Thread(target=serve, args=(Simulator(port, 4096), done), daemon=True)
    client.start()
    try:
        falsifier.run_falsifier()
        sampler.flush(falsifier)  # the last ρ: VerifAI passes each with the next request
    finally:
        done.set()
        client.join(timeout=10)
    found = sampler.failures()
    print(f"{len(sampler.records)} trials, {len(found)} counterexamples, e.g. {found[0].phi if found else None}")
    print(f"VerifAI's error table: {len(falsifier.error_table.table)} rows (HF and LF runs)")
    print("cheapest agreeing fidelity:", sampler.kernel.estimate())
    return {"trials": len(sampler.records), "counterexamples": len(found)}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--iterations", type=int, default=600, help="VerifAI samples (two per trial)")
    ap.add_argument("--port", type=int, default=8888, help="the falsifier's server port")
    a = ap.parse_args()
    main(a.iterations, a.port)
