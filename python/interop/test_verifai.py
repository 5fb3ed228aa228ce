"""savme.verifai.SavmeSampler against the installed VerifAI: a FeatureSampler its own
falsifier runs (server, socket client, monitor, error table), the φ-space of a FeatureSpace,
ρ as failure and robustness."""

import math
import socket
import threading

import pytest
from dotmap import DotMap
from verifai.client import Client
from verifai.falsifier import generic_falsifier
from verifai.features import Array, Box, Categorical, Constant, DiscreteBox, Feature, FeatureSpace, Struct
from verifai.samplers import FeatureSampler

import savme
from savme.verifai import ROLE, SavmeSampler, phi_space

FIDELITY = savme.Space([savme.Discrete("rate_hz", [2, 5, 10])])


def space():
    return FeatureSpace({"gap": Feature(Box((5, 50))), "lane": Feature(DiscreteBox((0, 2)))})


def sampler(**kw):
    return SavmeSampler(space(), fidelity=FIDELITY, theta_hf={"rate_hz": 10}, budget=0.3, seed=5, **kw)


def robustness(gap, rate_hz):
    """Clearance to the lead car minus a margin: ρ < 0 below a gap of 15 m; the 2 Hz simulator
    sees 5 m more clearance than there is."""
    rho = gap - 15.0
    return rho + 5.0 if rate_hz == 2 else rho


def test_a_feature_space_becomes_a_phi_space():
    fs = FeatureSpace({
        "pos": Feature(Box((0, 1), (-2, 2))),
        "lane": Feature(DiscreteBox((1, 3))),
        "weather": Feature(Categorical("dry", "rain")),
        "map": Feature(Constant("town01")),
    })
    phi, layout = phi_space(fs, bins=4)
    assert phi.names == ["lane", "pos[0]", "pos[1]", "weather"]
    assert phi["pos[1]"].range == (-2.0, 2.0, 4, "linear")
    assert phi["lane"].values == [1, 2, 3] and phi["weather"].values == ["dry", "rain"]
    assert ("map", "constant", []) in layout
    with pytest.raises(ValueError, match="feature `cars`: a feature list"):
        phi_space(FeatureSpace({"cars": Feature(Box((0, 1)), lengthDomain=DiscreteBox((1, 3)))}))
    with pytest.raises(ValueError, match="feature `car`: a Struct domain is not supported"):
        phi_space(FeatureSpace({"car": Feature(Struct({"x": Box((0, 1))}))}))
    with pytest.raises(ValueError, match="feature `grid`: a Array domain"):
        phi_space(FeatureSpace({"grid": Feature(Array(Box((0, 1)), (2,)))}))


def test_samples_are_points_of_the_space_in_hf_lf_pairs_with_their_fidelity():
    s = sampler()
    assert isinstance(s, FeatureSampler)
    assert [n for n, _ in s.space.namedFeatures] == ["gap", "lane", "rate_hz", ROLE]
    hf, hf_info = s.getSample()
    lf, lf_info = s.getSample()
    assert (hf.savme_run, lf.savme_run) == ("hf", "lf") and hf_info.trial == lf_info.trial
    assert hf.rate_hz == 10 and lf.rate_hz == hf_info.trial.theta_lf["rate_hz"]
    assert (hf.gap, hf.lane) == (lf.gap, lf.lane)
    assert hf.gap == (hf_info.trial.phi["gap"],) and hf.lane == (hf_info.trial.phi["lane"],)
    assert s.space.flatten(hf)  # VerifAI's own tables can flatten it
    assert s.update(lf, lf_info, -1.0) is None  # any order
    record = s.update(hf, hf_info, -2.0)
    assert record.outcome == "TP"
    told = record.to_dict()
    assert told["observation"]["paired"]["hf"]["robustness"] == -2.0
    assert told["observation"]["paired"]["lf"]["robustness"] == -1.0


def test_rho_at_or_below_the_threshold_fails_and_bad_rho_is_refused():
    s = sampler(threshold=1.0)
    hf, hf_info = s.getSample()
    lf, lf_info = s.getSample()
    with pytest.raises(TypeError, match="multi-objective"):
        s.update(hf, hf_info, (0.5, 2.0))
    with pytest.raises(ValueError, match="the robustness value is nan"):
        s.update(hf, hf_info, float("nan"))
    with pytest.raises(TypeError, match="a number"):
        s.update(hf, hf_info, None)
    s.update(hf, hf_info, 1.0)              # ρ = threshold: a counterexample, as VerifAI counts
    r = s.update(lf, lf_info, 1.5)
    assert r.hf[0] is True and r.lf[0] is False and r.outcome == "FN"
    with pytest.raises(KeyError, match="not outstanding"):
        s.update(lf, lf_info, 1.5)


def test_a_cancelled_trial_hands_out_no_more_runs():
    s = sampler()
    hf, info = s.getSample()
    s.cancel(info)
    nxt, nxt_info = s.getSample()
    assert nxt_info.trial.id != info.trial.id and nxt.savme_run == "hf"
    with pytest.raises(KeyError):
        s.update(hf, info, 1.0)


def test_a_run_of_a_trial_cancelled_on_the_kernel_is_refused_not_taken():
    """`sampler.kernel.cancel(t)` between a sample and its ρ: the ρ is refused naming the
    trial (it was taken silently, and the trial's HF result kept)."""
    s = sampler()
    hf, info = s.getSample()
    s.kernel.cancel(info.trial)
    with pytest.raises(savme.TellError, match=r"update\(trial 0, hf\): trial 0 was withdrawn on the kernel"):
        s.update(hf, info, 1.0)
    nxt, nxt_info = s.getSample()
    assert nxt_info.trial.id == 1 and nxt.savme_run == "hf"
    # The LF sample of a cancelled trial, handed out before the cancel, is refused too.
    hf, hf_info = s.getSample() if nxt_info.role == "lf" else (nxt, nxt_info)
    s.update(hf, hf_info, 1.0)
    lf, lf_info = s.getSample()
    assert lf_info.role == "lf"
    s.kernel.cancel(lf_info.trial)
    with pytest.raises(savme.TellError, match=r"trial 1 was withdrawn"):
        s.update(lf, lf_info, 1.0)
    assert s.kernel.stats() == {"asked": 2, "told": 0, "cancelled": 2}


def free_port():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Simulator(Client):
    """VerifAI's socket client: receives a sample, returns its simulation data."""

    def __init__(self, port):
        super().__init__(port, 4096)
        self.runs = []

    def simulate(self, sample):
        self.runs.append(sample)
        return {"rho": robustness(sample.gap[0], sample.rate_hz), "cost": sample.rate_hz / 10.0}


def serve(client, stop):
    while not stop.is_set():
        try:
            client.run_client()
        except RuntimeError:  # the server is gone
            return


def falsify(s, n_iters):
    """Runs VerifAI's falsifier on sampler `s` for `n_iters` samples against the socket
    client; returns the falsifier, the client and what `s.flush` returned."""
    port = free_port()
    falsifier = generic_falsifier(
        sampler=s,
        monitor=s.monitor(lambda data: (data["rho"], data["cost"])),
        falsifier_params=DotMap(n_iters=n_iters, save_error_table=True, save_safe_table=False),
        server_options=DotMap(port=port),
    )
    client = Simulator(port)
    stop = threading.Event()
    thread = threading.Thread(target=serve, args=(client, stop), daemon=True)
    thread.start()
    try:
        falsifier.run_falsifier()
        flushed = s.flush(falsifier)
    finally:
        stop.set()
        thread.join(timeout=10)
    return falsifier, client, flushed


def test_savme_runs_inside_verifai_s_falsifier():
    s = sampler()
    falsifier, client, flushed = falsify(s, 600)
    assert flushed is not None
    assert len(client.runs) == 600 and s.kernel.stats()["told"] == 300
    # The falsifier's error table holds the counterexamples, HF and LF runs alike (VerifAI
    # writes a categorical feature as its index: savme_run 0 is "hf").
    table = falsifier.error_table.table
    hf_rows = table[table[f"point.{ROLE}"] == 0]
    assert len(hf_rows) == len(s.failures()) > 0
    assert all(t.phi["gap"] <= 15.0 for t in s.failures())
    # The costs came from the monitor: 2 Hz costs 0.2 ≤ 0.3 of 10 Hz and agrees but between
    # 15 and 20 m; 5 Hz costs 0.5.
    assert all(math.isclose(r.cost_ratio, r.trial.theta_lf["rate_hz"] / 10.0) for r in s.records)
    assert s.kernel.estimate()["rate_hz"] == 2
    gap = s.kernel.scenario_posterior("verifai").means("gap")
    assert gap.index(max(gap)) <= 2, gap  # the failure region: the lowest bins


def test_an_odd_n_iters_leaves_a_half_run_trial_with_a_warning_naming_it():
    """Each savme trial is two samples: n_iters=7 runs three trials and the HF run of a
    fourth, which cannot be told — flush says so (it was left pending silently)."""
    s = sampler()
    with pytest.warns(RuntimeWarning, match=r"trial 3 has its hf run but not its lf run, so it is not told: "
                                            r"n_iters=7 is odd .*sampler.cancel\(3\)"):
        _, client, _ = falsify(s, 7)
    assert len(client.runs) == 7 and s.kernel.stats()["told"] == 3
    assert [t.id for t in s.kernel.pending()] == [3]
    # The next sample is its LF run; with it the trial is told.
    lf, info = s.getSample()
    assert (info.trial.id, info.role) == (3, "lf")
    assert s.update(lf, info, 2.0) is not None and s.kernel.stats()["told"] == 4


def test_the_falsify_example_runs():
    import pathlib
    import subprocess
    import sys

    example = pathlib.Path(__file__).parents[2] / "examples/python/falsify.py"
    out = subprocess.run([sys.executable, str(example), "--iterations", "200", "--port", str(free_port())],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "100 trials" in out.stdout and "cheapest agreeing fidelity" in out.stdout, out.stdout
    assert int(out.stdout.split(" counterexamples")[0].split()[-1]) > 0, out.stdout
