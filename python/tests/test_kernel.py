"""The kernel API: construction, bad arguments, ask/tell, phases, snapshots, prior transfer."""

import json

import pytest

import savme


def fidelity():
    return savme.Space(
        [
            savme.Discrete("rate_hz", [2, 5, 10]),
            savme.Boolean("disable_shadows"),
            savme.Continuous("view_m", 10, 5000, bins=10, scale="log"),
        ]
    )


THETA_HF = {"rate_hz": 10, "disable_shadows": False, "view_m": 5000.0}


def phi():
    return savme.Space([savme.Continuous("gap_m", 5, 50, bins=9), savme.Discrete("weather", ["sun", "rain"])])


def kernel(**kw):
    """The paper's SAVME unless a test says otherwise (the tuned default is tested on its own:
    test_the_default_method_is_savmes_search_by_cost)."""
    args = dict(fidelity=fidelity(), theta_hf=THETA_HF, scenarios={"lead_brakes": phi()}, budget=0.3, seed=7,
                method="paper")
    args.update(kw)
    return savme.Kernel(**args)


def runs(trial):
    """A deterministic stand-in simulator: fails below a gap of 15 m; 2 Hz misses the failure."""
    fails = trial.phi["gap_m"] < 15.0
    hf = (fails, 1.0)
    if not trial.paired:
        return hf, None
    lf_fails = fails and trial.theta_lf["rate_hz"] > 2
    return hf, (lf_fails, trial.theta_lf["rate_hz"] / 10.0)


def trained_kernel():
    """300 training trials of the stand-in simulator (failure below a gap of 15 m)."""
    k = kernel()
    for _ in range(300):
        t = k.ask()
        hf, lf = runs(t)
        k.tell(t, hf=hf, lf=lf)
    return k


def test_trials_carry_phase_scenario_and_dicts_in_space_order():
    k = kernel()
    t = k.ask()
    assert (t.id, t.phase, t.scenario, t.paired) == (0, "train", "lead_brakes", True)
    assert list(t.phi) == ["gap_m", "weather"]
    assert list(t.theta_lf) == ["rate_hz", "disable_shadows", "view_m"]
    assert 5 <= t.phi["gap_m"] <= 50 and t.phi["weather"] in ("sun", "rain")
    assert t.theta_lf["rate_hz"] in (2, 5, 10) and isinstance(t.theta_lf["disable_shadows"], bool)
    assert 10 <= t.theta_lf["view_m"] <= 5000
    batch = k.ask(3)
    assert [b.id for b in batch] == [1, 2, 3]
    assert [p.id for p in k.pending()] == [0, 1, 2, 3]
    assert k.stats() == {"asked": 4, "told": 0, "cancelled": 0}


def test_tell_returns_the_record_and_credits_by_table_ii():
    k = kernel()
    t = k.ask()
    r = k.tell(t, hf=(True, 2.0), lf=(True, 0.4))  # agreed, ratio 0.2 <= 0.3
    assert (r.id, r.outcome, r.cost_ratio) == (t.id, "TP", 0.2)
    assert r.credit == {"fidelity": True, "scenario": True}
    assert r.hf == (True, 2.0) and r.lf == (True, 0.4) and r.trial == t
    t = k.ask()
    r = k.tell(t.id, hf=(False, 1.0), lf=(False, 0.5))  # agreed but too expensive
    assert (r.outcome, r.credit) == ("TN", {"fidelity": False, "scenario": False})
    t = k.ask()
    r = k.tell(t, hf=(True, 1.0), lf=(False, 0.1))  # LF missed a failure
    assert (r.outcome, r.credit) == ("FN", {"fidelity": False, "scenario": True})
    d = r.to_dict()
    assert d["outcome"] == "FN" and d["observation"]["paired"]["lf"] == {"failure": False, "runtime": 0.1}
    assert k.stats()["told"] == 3


def test_learning_moves_the_fidelity_estimate_to_the_cheap_agreeing_setting():
    k = trained_kernel()
    # Only 2 Hz runs within the budget (cost ratio 0.2; 5 Hz 0.5, 10 Hz 1.0): it is credited
    # whenever it agrees (it misses failures, but most trials do not fail).
    post = k.fidelity_posterior()
    means = post.means("rate_hz")
    assert means.index(max(means)) == 0, means
    assert k.estimate()["rate_hz"] == 2
    assert k.estimate("mean")["rate_hz"] == 2
    gap = k.scenario_posterior("lead_brakes").means("gap_m")
    assert max(gap[:3]) > max(gap[4:]), gap  # failures live below 15 m


def test_phases_evaluate_baseline_test():
    k = kernel()
    for _ in range(50):
        t = k.ask()
        k.tell(t, *runs(t))
    k.set_phase("evaluate")
    assert k.phase == "evaluate"
    before = k.fidelity_posterior()
    e = k.ask()
    assert e.phase == "evaluate" and e.theta_lf == k.estimate()
    r = k.tell(e, hf=(True, 1.0), lf=(True, 0.1))
    assert r.credit == {"fidelity": None, "scenario": None}
    assert k.fidelity_posterior() == before
    k.set_phase("baseline")
    b = k.ask()
    assert b.phase == "baseline" and b.theta_lf is None and not b.paired
    with pytest.raises(savme.TellError, match=f"trial {b.id} has no θ_LF and takes the HF run only"):
        k.tell(b, hf=(True, 1.0), lf=(True, 0.1))
    assert k.tell(b, hf=(False, 1.0)).outcome is None
    k.set_phase("test")
    assert k.ask().phase == "test"
    # A trial keeps the phase it was asked in.
    k.set_phase("train")
    k.set_phase("evaluate")
    t = k.ask()
    k.set_phase("train")
    assert k.tell(t, hf=(True, 1.0), lf=(True, 0.1)).credit["fidelity"] is None


def test_refused_tells_raise_tell_error_naming_the_trial_and_change_nothing():
    k = kernel()
    t = k.ask()
    before = k.to_json()
    cases = [
        (dict(trial=99, hf=(True, 1.0), lf=(True, 0.1)), "trial 99 was never asked"),
        (dict(trial=t.id, hf=(True, 1.0)), f"trial {t.id} is a train trial and needs a paired"),
        (dict(trial=t.id, hf=(True, float("nan")), lf=(True, 0.1)), f"trial {t.id}: HF runtime must be finite"),
        (dict(trial=t.id, hf=(True, 1.0), lf=(True, 0.0)), f"trial {t.id}: LF runtime must be finite"),
        (dict(trial=t.id, hf=(True, -1.0), lf=(True, 0.1)), "HF runtime"),
        (dict(trial=t.id, hf=(True, 5e-324), lf=(True, 1.0)), "not a finite number"),
    ]
    for kwargs, message in cases:
        with pytest.raises(savme.TellError, match=message):
            k.tell(kwargs.pop("trial"), **kwargs)
        assert k.to_json() == before
    assert issubclass(savme.TellError, ValueError)
    k.tell(t, hf=(True, 1.0), lf=(True, 0.1))
    with pytest.raises(savme.TellError, match=f"trial {t.id} was already told"):
        k.tell(t, hf=(True, 1.0), lf=(True, 0.1))
    with pytest.raises(savme.TellError, match=f"trial {t.id} was already told"):
        k.cancel(t)


def test_bad_tell_arguments_are_type_errors_naming_the_argument():
    k = kernel()
    t = k.ask()
    with pytest.raises(TypeError, match=r"tell\(trial 0, hf=…\): expected a \(failure: bool, runtime: float\)"):
        k.tell(t, hf=True, lf=(True, 0.1))
    with pytest.raises(TypeError, match=r"lf=…"):
        k.tell(t, hf=(True, 1.0), lf=(True, "fast"))
    with pytest.raises(TypeError, match="expected a Trial or a trial id"):
        k.tell("zero", hf=(True, 1.0), lf=(True, 0.1))
    with pytest.raises(TypeError, match="expected a Trial or a trial id"):
        k.tell(-1, hf=(True, 1.0), lf=(True, 0.1))
    assert k.stats()["told"] == 0


def test_a_run_may_carry_its_robustness():
    k = kernel()
    t = k.ask()
    r = k.tell(t, hf=(True, 1.0, -0.5), lf=(False, 0.2, 0.3))
    paired = r.to_dict()["observation"]["paired"]
    assert (paired["hf"]["robustness"], paired["lf"]["robustness"]) == (-0.5, 0.3)
    t = k.ask()
    with pytest.raises(savme.TellError, match="robustness must be a finite number"):
        k.tell(t, hf=(True, 1.0, float("nan")), lf=(True, 0.2))
    with pytest.raises(TypeError, match="triple"):
        k.tell(t, hf=(True, 1.0, 2.0, 3.0), lf=(True, 0.2))


def test_bad_spaces_and_configurations_name_the_variable_or_scenario():
    with pytest.raises(ValueError, match="log-scaled variable `view` needs 0 < lo"):
        savme.Continuous("view", 0, 100, scale="log")
    with pytest.raises(ValueError, match="continuous variable `gap` needs lo < hi"):
        savme.Continuous("gap", 5, 5)
    with pytest.raises(ValueError, match="`gap` needs at least one bin"):
        savme.Continuous("gap", 1, 5, bins=0)
    with pytest.raises(ValueError, match='continuous variable `gap`: scale must be "linear", "log" or "shifted-log", got "cubic"'):
        savme.Continuous("gap", 1, 5, scale="cubic")
    with pytest.raises(ValueError, match="discrete variable `rate` lists the value 2 twice"):
        savme.Discrete("rate", [2, 2])
    with pytest.raises(ValueError, match="discrete variable `rate` has no values"):
        savme.Discrete("rate", [])
    with pytest.raises(TypeError, match=r"Discrete\(\"rate\"\) value 1: expected a bool, int, float or str, got list"):
        savme.Discrete("rate", [2, [3]])
    with pytest.raises(ValueError, match="variable `a` is defined twice"):
        savme.Space([savme.Boolean("a"), savme.Boolean("a")])
    with pytest.raises(ValueError, match="the space has no variables"):
        savme.Space([])
    with pytest.raises(ValueError, match="no value for variable `view_m`"):
        kernel(theta_hf={"rate_hz": 10, "disable_shadows": False})
    with pytest.raises(ValueError, match="unknown variable `speed`"):
        kernel(theta_hf=dict(THETA_HF, speed=3))
    with pytest.raises(ValueError, match="value 7 is outside variable `rate_hz`"):
        kernel(theta_hf=dict(THETA_HF, rate_hz=7))
    with pytest.raises(ValueError, match=r"C_budget must lie in \(0, 1\], got 0"):
        kernel(budget=0.0)
    with pytest.raises(ValueError, match="scenario `a` has weight -1"):
        kernel(scenarios=[("a", phi(), -1.0)])
    with pytest.raises(ValueError, match="no scenarios"):
        kernel(scenarios={})
    with pytest.raises(TypeError, match="scenario `a` needs a savme.Space"):
        kernel(scenarios={"a": [savme.Boolean("x")]})
    with pytest.raises(ValueError, match='unknown estimator "median"'):
        kernel(estimator="median")
    with pytest.raises(ValueError, match="prior counts must be finite and > 0"):
        kernel(prior=(0.0, 1.0))
    with pytest.raises(ValueError, match="seed must be a whole number from 0 to 18446744073709551615, got -1"):
        kernel(seed=-1)
    k = kernel()
    with pytest.raises(ValueError, match='unknown phase "warmup"'):
        k.set_phase("warmup")
    with pytest.raises(KeyError, match="unknown scenario `cut_in` \\(known: lead_brakes\\)"):
        k.scenario_posterior("cut_in")
    with pytest.raises(KeyError, match="unknown variable `speed`"):
        k.fidelity_posterior().arms("speed")
    with pytest.raises(ValueError, match="n must be between 1 and"):
        k.ask(0)
    assert k.stats()["asked"] == 0


def test_several_scenarios_with_weights():
    k = kernel(scenarios=[("often", phi(), 9.0), ("rare", phi(), 1.0)])
    names = [t.scenario for t in k.ask(400)]
    assert 300 < names.count("often") < 390, names.count("often")
    assert k.scenarios == ["often", "rare"]


def test_cancel_withdraws_a_pending_trial():
    k = kernel()
    a, b = k.ask(2)
    assert k.cancel(a) == a
    assert [t.id for t in k.pending()] == [b.id]
    assert k.stats() == {"asked": 2, "told": 0, "cancelled": 1}
    with pytest.raises(savme.TellError, match=f"trial {a.id} was already told or cancelled"):
        k.tell(a, hf=(True, 1.0), lf=(True, 0.1))


def test_snapshot_round_trip_asks_the_same_trials():
    k = kernel()
    for _ in range(20):
        t = k.ask()
        k.tell(t, *runs(t))
    k.ask(2)  # pending trials survive the snapshot
    copy = savme.Kernel.from_json(k.to_json())
    assert copy.pending() == k.pending()
    assert copy.ask(5) == k.ask(5)
    with pytest.raises(ValueError, match="snapshot is not valid JSON"):
        savme.Kernel.from_json('{"config": 1}')


def test_same_seed_same_trials_and_another_seed_other_trials():
    a, b, c = kernel(seed=3), kernel(seed=3), kernel(seed=4)
    for _ in range(30):
        ta, tb, tc = a.ask(), b.ask(), c.ask()
        assert ta == tb
        a.tell(ta, *runs(ta))
        b.tell(tb, *runs(tb))
        c.tell(tc, *runs(tc))
    assert a.to_json() == b.to_json() != c.to_json()


def test_fidelity_prior_transfer_is_the_power_prior():
    trained = kernel()
    for _ in range(100):
        t = trained.ask()
        trained.tell(t, *runs(t))
    post = trained.fidelity_posterior()
    for strength in (1.0, 0.5):
        fresh = kernel(scenarios={"cut_in": phi()}, fidelity_prior=post, prior_strength=strength)
        got = fresh.fidelity_posterior()
        for name in post.names:
            expected = [(1 + strength * (a - 1), 1 + strength * (b - 1)) for a, b in post.arms(name)]
            flat = [x for arm in got.arms(name) for x in arm]
            assert flat == pytest.approx([x for arm in expected for x in arm])
        assert fresh.estimate() == trained.estimate()
    # Through JSON too (a posterior saved after meta-training).
    restored = savme.Posterior.from_json(post.to_json())
    assert restored == post
    with pytest.raises(ValueError, match="prior strength must be finite and > 0"):
        kernel(fidelity_prior=post, prior_strength=0.0)
    other = savme.Space([savme.Boolean("x")])
    with pytest.raises(ValueError, match="fidelity prior"):
        kernel(fidelity=other, theta_hf={"x": True}, fidelity_prior=post)


def test_the_configuration_round_trips_through_config_json():
    k = kernel()
    again = savme.Kernel.from_config(k.config_json())
    assert again.ask(10) == k.ask(10)
    with pytest.raises(ValueError, match="kernel configuration: .*line 1"):
        savme.Kernel.from_config("{")


def test_reprs_and_accessors():
    k = kernel()
    assert repr(k).startswith('Kernel(phase="train", budget=0.3')
    assert k.theta_hf == THETA_HF and list(k.theta_hf) == ["rate_hz", "disable_shadows", "view_m"]
    assert k.fidelity == fidelity() and k.budget == 0.3 and k.journal is None
    t = k.ask()
    assert repr(t).startswith("Trial(id=0, phase='train', scenario='lead_brakes', phi={'gap_m': ")
    assert t.to_dict()["phi"] == t.phi
    assert repr(savme.Discrete("w", ["sun", 2, True])) == "Discrete(\"w\", ['sun', 2, True])"
    assert fidelity()["view_m"].range == (10.0, 5000.0, 10, "log")
    assert fidelity()["rate_hz"].values == [2, 5, 10]
    assert savme.Space.from_json(fidelity().to_json()) == fidelity()
    with pytest.raises(KeyError, match="unknown variable `nope`"):
        fidelity()["nope"]


def test_a_closed_kernel_refuses_calls():
    with kernel() as k:
        k.ask()
    with pytest.raises(ValueError, match="the kernel is closed"):
        k.ask()


def test_an_estimation_from_the_posteriors_covers_the_true_failure_probability():
    # Under the uniform nominal, P(gap < 15 m) = (15 − 5) / (50 − 5) = 2/9.
    k = trained_kernel()
    before = k.to_json()
    est = k.estimation(epsilon=0.2, seed=3)
    assert k.to_json() == before, "estimating changes nothing in the kernel"
    for _ in range(3000):
        t = est.ask()
        assert t["round"] is None and t["weight"] <= 5.0 + 1e-9
        assert abs(t["weight"] - t["p"] / t["q"]) < 1e-12
        est.tell(t["id"], t["phi"]["gap_m"] < 15.0)
    e = est.estimate()
    assert e["runs"] == 3000 and est.told == 3000
    assert e["total"]["lo"] <= 2 / 9 <= e["total"]["hi"], e["total"]
    with pytest.raises(savme.TellError, match="trial 0 is not pending"):
        est.tell(0, True)


def test_a_refined_estimation_waits_for_each_round_and_a_normal_nominal_is_used():
    k = trained_kernel()
    nominal = {"lead_brakes": {"gap_m": {"distribution": "normal", "mean": 30.0, "sd": 6.0}}}
    est = k.estimation(epsilon=0.1, seed=1, nominal=nominal, refine=(2, 50))
    for r in range(2):
        assert est.round == r
        asked = [est.ask() for _ in range(50)]
        assert all(t["round"] == r for t in asked)
        assert est.ask() is None, "the round waits for its outcomes"
        for t in asked:
            est.tell(t["id"], t["phi"]["gap_m"] < 15.0)
    assert est.round is None and est.ask()["round"] is None
    assert est.estimate()["runs"] == 0 and est.told == 100
    assert "Estimation(scenarios=['lead_brakes'], told=100)" == repr(est)


def test_reused_refinement_rounds_count_in_the_estimate():
    k = trained_kernel()
    est = k.estimation(epsilon=0.1, seed=1, refine=(2, 50), refine_reuse=1)
    terms = []
    while est.told < 150:
        t = est.ask()
        failure = t["phi"]["gap_m"] < 15.0
        est.tell(t["id"], failure)
        if t["round"] != 0:  # the last round and the runs after the pilot
            terms.append(t["weight"] if failure else 0.0)
    e = est.estimate()
    assert e["runs"] == 100 and est.told == 150
    assert abs(e["total"]["mean"] - sum(terms) / len(terms)) < 1e-12


def test_a_joint_estimation_fits_a_mixture_from_failures_and_robustness():
    k = trained_kernel()
    est = k.estimation(epsilon=0.1, seed=2, refine=(2, 100), joint_components=3)
    same = k.estimation(epsilon=0.1, seed=2, refine=(2, 100), joint_components=3)
    product = k.estimation(epsilon=0.1, seed=2, refine=(2, 100))
    first = []
    while est.told < 400:
        t, u = est.ask(), same.ask()
        assert t == u, "the same seed and outcomes give the same draws"
        first.append(t["phi"])
        gap = t["phi"]["gap_m"]
        assert abs(t["weight"] - t["p"] / t["q"]) < 1e-12 and t["weight"] <= 10.0 + 1e-9
        for e in (est, same):
            e.tell(t["id"], gap < 15.0, robustness=gap - 15.0)
    drawn = []
    while product.told < 400:
        t = product.ask()
        drawn.append(t["phi"])
        product.tell(t["id"], t["phi"]["gap_m"] < 15.0)
    assert first[:100] == drawn[:100], "the first round is the product proposal's"
    assert first[200:] != drawn[200:], "after the pilot the joint proposal draws"
    assert est.estimate()["runs"] == 200
    with pytest.raises(savme.TellError, match="robustness must be a finite number, got NaN"):
        t = est.ask()
        est.tell(t["id"], False, robustness=float("nan"))


def test_a_multi_fidelity_estimation_runs_its_pilot_at_lf_and_estimates_from_hf():
    # The LF fails below 20 m (false alarms on 15–20 m); the HF below 15 m: P = 2/9.
    k = trained_kernel()
    est = k.estimation(epsilon=0.2, seed=4, refine=(2, 100), pilot_fidelity="lf")
    while est.told < 200:
        t = est.ask()
        assert t["fidelity"] == "lf" and t["round"] is not None
        est.tell(t["id"], t["phi"]["gap_m"] < 20.0)
    assert est.estimate()["runs"] == 0, "no LF outcome is in the estimate"
    while est.told < 3200:
        t = est.ask()
        assert "fidelity" not in t and t["round"] is None
        est.tell(t["id"], t["phi"]["gap_m"] < 15.0)
    e = est.estimate()
    assert e["runs"] == 3000
    assert e["total"]["lo"] <= 2 / 9 <= e["total"]["hi"], e["total"]


def test_control_variates_pair_hf_and_lf_runs_and_keep_the_estimate_unbiased():
    # HF fails below 15 m (P = 2/9 under the uniform nominal); the LF below 15.5 m, at a
    # twentieth of the cost: the calibration chooses to use it.
    k = trained_kernel()
    est = k.estimation(epsilon=0.2, seed=4, control_calibration=100)
    calibration = [est.ask() for _ in range(200)]
    assert est.ask() is None, "the calibration waits for its outcomes"
    for hf, lf in zip(calibration[::2], calibration[1::2]):
        assert hf["control"] == lf["control"] == "calibration" and hf["phi"] == lf["phi"]
        assert "fidelity" not in hf and lf["fidelity"] == "lf"
    for t in calibration:
        lf = t.get("fidelity") == "lf"
        est.tell(t["id"], t["phi"]["gap_m"] < (15.5 if lf else 15.0), cost=0.05 if lf else 1.0)
    assert est.estimate()["runs"] == 0, "the calibration is not part of the estimate"
    while est.told < 3200:
        t = est.ask()
        lf = t.get("fidelity") == "lf"
        assert t["control"] in ("paired", "extra")
        est.tell(t["id"], t["phi"]["gap_m"] < (15.5 if lf else 15.0), cost=0.05 if lf else 1.0)
    e = est.estimate()
    control = e["scenarios"][0]["control"]
    assert control["plan"]["use_lf"] and control["plan"]["rho"] > 0.8, control
    assert control["lf_runs"] > e["runs"] > 100
    assert e["total"]["lo"] <= 2 / 9 <= e["total"]["hi"], e["total"]
    with pytest.raises(savme.TellError, match="cost must be a finite number ≥ 0, got -1"):
        est.tell(est.ask()["id"], False, cost=-1.0)


def test_bad_estimation_arguments_name_what_is_wrong():
    k = trained_kernel()
    with pytest.raises(ValueError, match=r"epsilon .* must lie in \(0, 1\], got 0"):
        k.estimation(epsilon=0.0)
    with pytest.raises(ValueError, match="refine needs at least 1 round"):
        k.estimation(refine=(0, 10))
    with pytest.raises(ValueError, match="refine reuse: 3 rounds to reuse .* only 2 pilot rounds"):
        k.estimation(refine=(2, 10), refine_reuse=3)
    with pytest.raises(ValueError, match=r"refine_reuse: 1 pilot rounds to reuse, but no refine"):
        k.estimation(refine_reuse=1)
    with pytest.raises(ValueError, match="unknown variable `gap` of scenario `lead_brakes`"):
        k.estimation(nominal={"lead_brakes": {"gap": {"distribution": "uniform"}}})
    with pytest.raises(ValueError, match="nominal: unknown variant `gamma`"):
        k.estimation(nominal={"lead_brakes": {"gap_m": {"distribution": "gamma"}}})
    with pytest.raises(TypeError, match="nominal: expected"):
        k.estimation(nominal=[1, 2])
    with pytest.raises(ValueError, match='tilt: unknown tilt "sideways"'):
        k.estimation(tilt="sideways")
    with pytest.raises(ValueError, match=r"joint_components: the joint proposal is fitted by the cross-entropy pilot rounds: give refine=\(rounds, runs\) too"):
        k.estimation(joint_components=4)
    with pytest.raises(ValueError, match=r"joint_components: must lie in 1..=64, got 0"):
        k.estimation(refine=(2, 10), joint_components=0)
    with pytest.raises(ValueError, match=r"pilot_fidelity: \"lf\" runs .* give refine=\(rounds, runs\) too"):
        k.estimation(pilot_fidelity="lf")
    with pytest.raises(ValueError, match=r"refine_reuse: 1 pilot rounds to reuse, but the pilot runs at low fidelity"):
        k.estimation(refine=(2, 10), refine_reuse=1, pilot_fidelity="lf")
    with pytest.raises(ValueError, match=r'pilot_fidelity: expected "hf" or "lf", got "mf"'):
        k.estimation(pilot_fidelity="mf")
    with pytest.raises(ValueError, match=r"control: calibration must be at least 2 pairs .* got 1"):
        k.estimation(control_calibration=1)
    with pytest.raises(ValueError, match=r"control_extra: 3 extra LF runs per pair need control_calibration"):
        k.estimation(control_extra=3)
    with pytest.raises(ValueError, match=r"control: extra must lie in 0..=64 LF runs per pair, got 65"):
        k.estimation(control_calibration=10, control_extra=65)


def test_extreme_but_finite_ranges_are_refused_naming_the_variable():
    # hi - lo overflows: every draw would be NaN (a panic at the first ask before).
    with pytest.raises(ValueError, match="continuous variable `gap` has a range too wide to compute with"):
        savme.Continuous("gap", -1e308, 1e308)
    with pytest.raises(ValueError, match="continuous variable `view` has a range too wide"):
        savme.Continuous("view", 1e-308, 1e308, scale="log")
    wide = savme.Continuous("gap", -8e307, 8e307, bins=4)
    k = kernel(scenarios={"lead_brakes": savme.Space([wide])})
    for _ in range(8):
        x = k.ask().phi["gap"]
        assert -8e307 <= x <= 8e307


def test_the_failure_flag_is_a_bool_or_a_numpy_bool_nothing_merely_truthy():
    k = kernel()
    t = k.ask()
    for bad, kind in [(0.7, "float"), (None, "NoneType"), (1, "int"), ("yes", "str"), ((True,), "tuple")]:
        with pytest.raises(TypeError, match=rf"tell\(trial {t.id}, hf=…\): the failure flag \(first of the pair\) must be a bool or a numpy bool, got {kind}"):
            k.tell(t, hf=(bad, 1.0), lf=(True, 0.1))
    # A swapped (runtime, failure) pair.
    with pytest.raises(TypeError, match=r"lf=…\): the failure flag .* got float 0.1"):
        k.tell(t, hf=(True, 1.0), lf=(0.1, True))
    assert k.stats()["told"] == 0
    np = pytest.importorskip("numpy")
    k.tell(t, hf=(np.bool_(True), 1.0), lf=(np.bool_(True), 0.1))
    assert k.stats()["told"] == 1


def test_a_str_of_values_and_a_negative_n_are_named():
    with pytest.raises(TypeError, match=r"Discrete\(\"x\"\): values must be a list of values, got the str 'abc'"):
        savme.Discrete("x", "abc")
    k = kernel()
    with pytest.raises(ValueError, match="n must be between 1 and 100000, got -1"):
        k.ask(-1)
    assert k.stats()["asked"] == 0


def test_a_theta_hf_given_as_a_str_is_named_as_no_number():
    with pytest.raises(ValueError, match="value far of variable `view_m` is not a number; the variable is continuous"):
        kernel(theta_hf=dict(THETA_HF, view_m="far"))


def test_a_trial_of_another_kernel_is_refused_not_credited_to_this_ones_trial_of_that_id():
    a, b = kernel(seed=1), kernel(seed=2)
    ta, tb = a.ask(), b.ask()
    assert ta.id == tb.id and ta != tb
    for call in (lambda: b.tell(ta, hf=(True, 1.0), lf=(True, 0.1)), lambda: b.cancel(ta)):
        with pytest.raises(ValueError, match=f"trial {ta.id} was asked by another Kernel"):
            call()
    assert (b.stats()["told"], b.stats()["cancelled"]) == (0, 0)
    # The same trial from a restored snapshot of the kernel that asked it is this kernel's.
    restored = savme.Kernel.from_json(a.to_json())
    restored.tell(ta, hf=(True, 1.0), lf=(True, 0.1))
    b.tell(tb, hf=(True, 1.0), lf=(True, 0.1))


def test_a_prior_strength_without_a_prior_is_refused_naming_it():
    for strength, shown in ((-1.0, "-1"), (0.5, "0.5")):
        with pytest.raises(ValueError, match=rf"prior_strength = {shown} without fidelity_prior"):
            kernel(prior_strength=strength)
    prior = trained_kernel().fidelity_posterior()
    with pytest.raises(ValueError, match="strength"):
        kernel(fidelity_prior=prior, prior_strength=-1.0)


def test_runs_carry_their_robustness_through_tell_records_and_journals(tmp_path):
    k = kernel(journal=tmp_path / "j.jsonl")
    t = k.ask()
    r = k.tell(t, hf=(False, 2.0, 0.75), lf=(False, 0.4), lf_robustness=1.5)
    assert (r.hf_robustness, r.lf_robustness) == (0.75, 1.5)
    assert r.to_dict()["observation"]["paired"]["hf"] == {"failure": False, "runtime": 2.0, "robustness": 0.75}
    t = k.ask()
    r = k.tell(t, hf=(True, 1.0), lf=(True, 0.2), robustness=-0.5)
    assert (r.hf_robustness, r.lf_robustness) == (-0.5, None)
    k.close()
    assert open(tmp_path / "j.jsonl").read().count('"robustness"') == 3
    again = savme.Kernel.resume(tmp_path / "j.jsonl")
    assert again.stats()["told"] == 2
    t = again.ask()
    before = again.to_json()
    with pytest.raises(savme.TellError, match=f"trial {t.id}: HF robustness must be a finite number"):
        again.tell(t, hf=(False, 1.0, float("nan")), lf=(False, 0.1))
    with pytest.raises(ValueError, match="robustness is given twice"):
        again.tell(t, hf=(False, 1.0, 0.5), lf=(False, 0.1), robustness=0.5)
    with pytest.raises(ValueError, match="lf_robustness without an lf run"):
        again.tell(t, hf=(False, 1.0), lf_robustness=0.5)
    with pytest.raises(TypeError, match=r"or a \(failure, runtime, robustness: float\) triple"):
        again.tell(t, hf=(False, 1.0, "near"), lf=(False, 0.1))
    assert again.to_json() == before


def test_the_search_is_chosen_by_name_or_parameters_and_is_deterministic():
    assert "search" not in kernel().config_json()
    assert '"elite_mixture"' in kernel(search="elite").config_json()
    k = kernel(search={"explore": 0.3, "tries": 2})
    assert '"explore": 0.3' in k.config_json() and '"tries": 2' in k.config_json()

    def drive(k, n=120):
        trials = []
        for _ in range(n):
            t = k.ask()
            hf, lf = runs(t)
            k.tell(t, hf=hf + (t.phi["gap_m"] - 15.0,), lf=lf)
            trials.append(t)
        return trials

    # A separable failure region (gap < 15 m, 22 % of one variable's range) is the bins' best
    # case: seed 7, 120 trials, bins 112 failures, elite 99. The elite search must stay close
    # (its gain is on joint corners: kernel/tests/search.rs and docs/RESULTS.md).
    elite, bins = drive(kernel(search="elite")), drive(kernel())

    def fails(trials):
        return sum(t.phi["gap_m"] < 15.0 for t in trials)

    assert fails(elite) >= 0.75 * fails(bins), (fails(elite), fails(bins))
    assert [t.phi for t in drive(kernel(search="elite"), 40)] == [t.phi for t in elite[:40]]
    for bad, message in [
        ("joint", 'search = "joint": give "bins", "elite"'),
        ({"explore": 2.0}, r"search parameter `explore` = 2 is outside \[0, 1\]"),
        ({"shape": 1.0}, "unknown field `shape`"),
    ]:
        with pytest.raises(ValueError, match=message):
            kernel(search=bad)
    with pytest.raises(TypeError, match="search: give"):
        kernel(search=3)


def test_pairing_a_fraction_leaves_settled_learning_trials_hf_only():
    # Once the fidelity posterior has settled (pair_settle observations on the arm with the
    # highest mean of every variable), about pair_fraction of the train trials are paired.
    k = kernel(pair_fraction=0.25, pair_settle=5)
    assert json.loads(k.config_json())["pairing"] == {"fraction": 0.25, "settle": 5}
    paired = []
    for _ in range(400):
        t = k.ask()
        hf, lf = runs(t)
        paired.append(t.paired)
        if not t.paired:
            assert t.theta_lf is None
            with pytest.raises(savme.TellError, match=f"trial {t.id} has no θ_LF"):
                k.tell(t, hf=hf, lf=(False, 0.2))
        r = k.tell(t, hf=hf, lf=lf)
        if not t.paired:
            assert r.credit == {"fidelity": None, "scenario": hf[0]}
    assert all(paired[:5]) and 60 < sum(paired) < 200, sum(paired)
    assert '"pairing"' not in kernel().config_json()
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(ValueError, match=r"pair_fraction = .* is outside \(0, 1\]"):
            kernel(pair_fraction=bad)


def test_the_default_method_is_savmes_search_by_cost():
    base = dict(fidelity=fidelity(), theta_hf=THETA_HF, scenarios=[("a", phi(), 1.0), ("b", phi(), 1.0)])
    tuned = json.loads(savme.Kernel(**base).config_json())
    assert tuned["search"]["model"] == "elite_mixture" and tuned["search"]["per_cost"] is True
    assert tuned["deployment"] == {"learn": True, "exploit": True}
    assert tuned["allocation"] == {"rule": "cost_rate", "floor": 0.6, "warmup": 4, "half_life": 20.0}
    paper = json.loads(savme.Kernel(**base, method="paper").config_json())
    assert not {"search", "deployment", "allocation"} & set(paper)
    # A value given wins over the method's.
    mixed = json.loads(savme.Kernel(**base, allocation="weights", deployment="frozen").config_json())
    assert "allocation" not in mixed and "deployment" not in mixed and "search" in mixed
    k = savme.Kernel(**base)
    for _ in range(20):  # the cost-rate allocation keeps a ledger per scenario
        t = k.ask()
        hf, lf = runs(t)
        k.tell(t, hf=hf, lf=lf)
    ledgers = json.loads(k.to_json())["ledgers"]
    assert [l["trials"] for l in ledgers] and sum(l["trials"] for l in ledgers) == 20
    with pytest.raises(ValueError, match='method = "best": give "tuned"'):
        savme.Kernel(**base, method="best")
    with pytest.raises(ValueError, match='allocation = "even": give "weights"'):
        savme.Kernel(**base, allocation="even")


def runs_with_false_alarms(trial):
    """The stand-in simulator of `runs`, but the LF run at 2 Hz raises false alarms below a
    gap of 30 m and costs 0.05; the others agree with HF."""
    fails = trial.phi["gap_m"] < 15.0
    if not trial.paired:
        return (fails, 1.0), None
    rate = trial.theta_lf["rate_hz"]
    lf = fails or (rate == 2 and trial.phi["gap_m"] < 30.0)
    return (fails, 1.0), (lf, 0.05 if rate == 2 else rate / 40.0)


def test_the_tuned_kernel_chooses_theta_lf_by_evidence_as_a_campaign_does():
    # The tuned method's θ_LF* is the campaign's (Protocol().theta_lf_choice: evidence) and
    # `savme example-config`'s; the paper's MAP is one argument away.
    base = dict(fidelity=fidelity(), theta_hf=THETA_HF, scenarios={"lead_brakes": phi()}, seed=3)
    campaign = savme.Protocol(["a"], ["b"]).to_dict()["theta_lf_choice"]
    assert campaign == "evidence"
    assert json.loads(savme.Kernel(**base).config_json())["estimator"] == campaign
    # (protocol.json leaves the paper's MAP out, as it was written before the key existed)
    paper = savme.Protocol(["a"], ["b"], method="paper").to_dict().get("theta_lf_choice", "map")
    assert json.loads(savme.Kernel(**base, method="paper").config_json())["estimator"] == paper == "map"
    assert json.loads(savme.Kernel(**base, estimator="map").config_json())["estimator"] == "map"
    assert json.loads(savme.Kernel(**base, method="paper", estimator="evidence").config_json())[
        "estimator"] == "evidence"

    differed = 0
    for seed in (1, 2, 3):  # seed 1 alone has states where MAP and evidence differ
        k = savme.Kernel(**dict(base, seed=seed))
        for _ in range(80):
            t = k.ask()
            hf, lf = runs_with_false_alarms(t)
            k.tell(t, hf=hf, lf=lf)
            assert k.estimate() == k.estimate("evidence")
            differed += k.estimate("map") != k.estimate("evidence")
    assert differed > 0, "the test needs a state where MAP and evidence choose differently"
    behind = k.estimate_evidence()
    assert [s["variable"] for s in behind] == ["rate_hz", "disable_shadows", "view_m"]
    for s in behind:
        assert s["tried"] == s["tp"] + s["tn"] + s["fp"] + s["fn"] > 0, s
        passes = s["fp"] + s["tn"]
        assert s["false_alarm_rate"] == (s["fp"] / passes if passes else None), s
    # The false alarms of 2 Hz are charged: evidence never settles on it here.
    assert k.estimate()["rate_hz"] != 2
    # MAP's arms, with the same tallies.
    assert k.estimate_evidence("map")[0]["arm"] == [2, 5, 10].index(k.estimate("map")["rate_hz"])

    p = savme.Kernel(**base, method="paper")
    for _ in range(10):
        t = p.ask()
        hf, lf = runs_with_false_alarms(t)
        p.tell(t, hf=hf, lf=lf)
    assert p.estimate() == p.estimate("map")
    assert p.estimate_evidence() is None


def test_an_adaptive_deployment_keeps_teaching_the_search_in_the_evaluate_phase():
    # deployment: what the evaluate phase (evaluation, screening) does with what the search
    # learned. Frozen (the default, the paper's) credits nothing; adaptive credits the φ search
    # with the HF run and never the fidelity bandit.
    assert '"deployment"' not in kernel(search="elite").config_json()
    for name, credited in (("frozen", False), ("adaptive", True)):
        k = kernel(search="elite", deployment=name)
        for _ in range(40):
            t = k.ask()
            hf, lf = runs(t)
            k.tell(t, hf=hf, lf=lf)
        k.set_phase("evaluate")
        t = k.ask()
        hf, lf = runs(t)
        r = k.tell(t, hf=hf, lf=lf)
        assert r.credit == {"fidelity": None, "scenario": hf[0] if credited else None}
    assert json.loads(kernel(search="elite", deployment="exploit").config_json())[
        "deployment"] == {"learn": False, "exploit": True}
    with pytest.raises(ValueError, match='deployment = "greedy": give "frozen", "exploit"'):
        kernel(deployment="greedy")


def test_scenario_priors_start_p_psi_from_a_transferred_posterior_as_the_json_configuration_does():
    # Meta-testing's φ transfer: the keyword has the name and shape of a configuration's
    # `scenario_priors` ([{"scenario": name, "posterior": Posterior}]).
    learned = trained_kernel().scenario_posterior("lead_brakes")
    base = dict(fidelity=fidelity(), theta_hf=THETA_HF, scenarios={"lead_brakes": phi(), "cut_in": phi()}, seed=5)
    fresh = savme.Kernel(**base)
    k = savme.Kernel(**base, scenario_priors=[{"scenario": "lead_brakes", "posterior": learned}])
    assert k.scenario_posterior("lead_brakes").to_json() == learned.to_json()
    assert k.scenario_posterior("lead_brakes").to_json() != fresh.scenario_posterior("lead_brakes").to_json()
    assert k.scenario_posterior("cut_in").to_json() == fresh.scenario_posterior("cut_in").to_json()
    # The same kernel as the JSON configuration carrying it (Kernel.from_config, savme serve).
    config = json.loads(fresh.config_json())
    config["scenario_priors"] = [{"scenario": "lead_brakes", "posterior": json.loads(learned.to_json())}]
    from_json = savme.Kernel.from_config(json.dumps(config))
    assert json.loads(from_json.config_json()) == json.loads(k.config_json())
    assert [from_json.ask().phi for _ in range(20)] == [k.ask().phi for _ in range(20)]
    # Refused, named.
    with pytest.raises(ValueError, match="φ prior of scenario `ghost`"):
        savme.Kernel(**base, scenario_priors=[{"scenario": "ghost", "posterior": learned}])
    with pytest.raises(ValueError, match="φ prior of scenario `cut_in`"):
        savme.Kernel(**base, scenario_priors=[{"scenario": "cut_in", "posterior": fresh.fidelity_posterior()}])
    with pytest.raises(ValueError, match=r"scenario_priors\[0\]: no \"posterior\" key"):
        savme.Kernel(**base, scenario_priors=[{"scenario": "cut_in"}])
    with pytest.raises(ValueError, match=r"scenario_priors\[0\]: unknown key \"weight\""):
        savme.Kernel(**base, scenario_priors=[{"scenario": "cut_in", "posterior": learned, "weight": 1}])
    with pytest.raises(TypeError, match=r"scenario_priors\[0\]\[\"posterior\"\]: give a list"):
        savme.Kernel(**base, scenario_priors=[{"scenario": "cut_in", "posterior": learned.to_json()}])
    with pytest.raises(TypeError, match="scenario_priors: give a list"):
        savme.Kernel(**base, scenario_priors={"lead_brakes": learned})
