"""savme.integrations.FalsificationSampler in a VerifAI-style loop, without VerifAI."""

import pytest

import savme
from savme.integrations import FalsificationSampler


def kernel(**kw):
    fidelity = savme.Space([savme.Discrete("rate_hz", [2, 5, 10]), savme.Boolean("shadows")])
    phi = savme.Space([savme.Continuous("gap_m", 5, 50, bins=9)])
    return savme.Kernel(fidelity=fidelity, theta_hf={"rate_hz": 10, "shadows": True},
                        scenarios={"lead_brakes": phi}, budget=0.3, seed=5, **kw)


def robustness(scenario, params, fidelity):
    """Clearance to the lead car minus a margin: negative (falsified) below a gap of 15 m; the
    2 Hz simulator sees 5 m more clearance than there is."""
    rho = params["gap_m"] - 15.0
    return rho + 5.0 if fidelity["rate_hz"] == 2 else rho


def falsify(sampler, n, runtime=True):
    """VerifAI's falsifier loop shape: sample, simulate, update."""
    for _ in range(n):
        s = sampler.next_sample()
        rho = robustness(s.scenario, s.params, s.fidelity)
        cost = s.fidelity["rate_hz"] / 10.0
        sampler.update(s, (rho, cost) if runtime else rho)


def test_samples_come_in_hf_lf_pairs_and_each_pair_is_one_told_trial():
    k = kernel()
    sampler = FalsificationSampler(k)
    hf = sampler.next_sample()
    lf = sampler.next_sample()
    assert (hf.role, lf.role) == ("hf", "lf") and hf.trial == lf.trial
    assert hf.fidelity == k.theta_hf and lf.fidelity == hf.trial.theta_lf
    assert hf.params == hf.trial.phi and hf.scenario == "lead_brakes"
    assert sampler.update(lf, (-1.0, 0.2)) is None  # any order
    record = sampler.update(hf, (-2.0, 1.0))
    assert record.outcome == "TP" and record.cost_ratio == pytest.approx(0.2)
    assert k.stats()["told"] == 1 and sampler.records == [record]


def test_the_threshold_turns_robustness_into_failure_flags():
    sampler = FalsificationSampler(kernel(), threshold=1.0)
    hf, lf = sampler.next_sample(), sampler.next_sample()
    sampler.update(hf, (0.5, 1.0))      # 0.5 < 1: failure
    r = sampler.update(lf, (1.5, 0.1))  # 1.5 ≥ 1: no failure
    assert r.hf[0] is True and r.lf[0] is False and r.outcome == "FN"
    # ρ reaches the kernel as its margin from the threshold (negative: failed).
    assert (r.hf_robustness, r.lf_robustness) == (-0.5, 0.5)
    above = FalsificationSampler(kernel(), threshold=10.0, failure_below=False)
    assert above.is_failure(11.0) and not above.is_failure(9.0)
    assert above.margin(11.0) == -1.0
    # A failure flag carries no robustness.
    flags = FalsificationSampler(kernel())
    hf, lf = flags.next_sample(), flags.next_sample()
    flags.update(hf, {"failure": True, "runtime": 1.0})
    assert flags.update(lf, (0.3, 0.1)).hf_robustness is None


def test_a_falsification_loop_learns_where_it_fails_and_which_fidelity_agrees():
    k = kernel()
    sampler = FalsificationSampler(k)
    falsify(sampler, 600)
    assert k.stats()["told"] == 300
    found = sampler.failures()
    assert found and all(t.phi["gap_m"] < 15.0 for t in found)
    # 5 Hz costs 0.5 > 0.3 and 10 Hz 1.0; 2 Hz (0.2) agrees except between 15 and 20 m.
    assert k.estimate()["rate_hz"] == 2
    gap = k.scenario_posterior("lead_brakes").means("gap_m")
    assert gap.index(max(gap)) <= 1, gap  # the failure region: the lowest bins


def test_without_a_runtime_the_wall_clock_time_is_the_cost():
    sampler = FalsificationSampler(kernel())
    falsify(sampler, 4, runtime=False)
    assert all(r.cost_ratio > 0 for r in sampler.records) and len(sampler.records) == 2


def test_baseline_trials_need_only_the_hf_sample():
    k = kernel()
    k.set_phase("baseline")
    sampler = FalsificationSampler(k)
    s = sampler.next_sample()
    assert s.role == "hf" and s.trial.phase == "baseline"
    assert sampler.update(s, {"rho": -1.0, "runtime": 2.0}).outcome is None
    assert sampler.next_sample().trial.id == s.trial.id + 1


def test_bad_results_and_unknown_samples_are_refused_naming_the_trial():
    k = kernel()
    sampler = FalsificationSampler(k)
    hf, lf = sampler.next_sample(), sampler.next_sample()
    with pytest.raises(ValueError, match=r"update\(trial 0, hf\): the robustness value is NaN"):
        sampler.update(hf, float("nan"))
    with pytest.raises(TypeError, match=r"update\(trial 0, hf\): expected a robustness value"):
        sampler.update(hf, "low")
    with pytest.raises(ValueError, match="exactly one of 'rho' or 'failure'"):
        sampler.update(hf, {"rho": 1.0, "failure": True})
    with pytest.raises(TypeError, match=r"must be \(rho, runtime\)"):
        sampler.update(hf, (1.0, 2.0, 3.0))
    sampler.update(hf, (1.0, 1.0))
    with pytest.raises(KeyError, match=r"trial 0 \(hf\) is not outstanding"):
        sampler.update(hf, 1.0)
    # A runtime the kernel refuses: TellError, and the LF sample stays outstanding.
    with pytest.raises(savme.TellError, match="trial 0: LF runtime must be finite and > 0"):
        sampler.update(lf, (1.0, -1.0))
    assert sampler.update(lf, (1.0, 0.2)).outcome == "TN"
    with pytest.raises(TypeError, match="needs a savme.Kernel"):
        FalsificationSampler(object())
    with pytest.raises(ValueError, match="threshold must be a finite number"):
        FalsificationSampler(k, threshold=float("inf"))


def test_a_cancelled_trial_hands_out_no_more_runs():
    k = kernel()
    sampler = FalsificationSampler(k)
    hf = sampler.next_sample()
    # Withdrawn through the kernel: its queued LF run is not handed out.
    k.cancel(hf.trial)
    nxt = sampler.next_sample()
    assert nxt.trial.id != hf.trial.id and nxt.role == "hf"
    with pytest.raises(KeyError, match="not outstanding"):
        sampler.update(hf, (1.0, 1.0))
    # Withdrawn through the sampler (a crashed simulation): the same, and the kernel knows.
    assert sampler.cancel(nxt).id == nxt.trial.id
    after = sampler.next_sample()
    assert after.trial.id not in (hf.trial.id, nxt.trial.id) and after.role == "hf"
    assert k.stats()["cancelled"] == 2
    falsify(sampler, 1)
    falsify(sampler, 10)
    assert k.stats()["told"] == 5
