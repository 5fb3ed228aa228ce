"""savme.Campaign: the Rust campaign loop on Python simulators — outputs, determinism,
failures, resume — and the bundled driving and FMU simulators from Python."""

import json
import os
import shutil
import subprocess

import pytest

import savme
from conftest import REPO


def problem():
    fidelity = savme.Space([savme.Discrete("rate_hz", [2, 5, 10, 20]), savme.Boolean("noise")])
    return savme.Problem(
        fidelity=fidelity,
        theta_hf={"rate_hz": 20, "noise": True},
        scenarios={
            "stopped": savme.Space([savme.Continuous("speed", 5, 35, bins=6), savme.Continuous("gap", 10, 120, bins=6)]),
            "braking": savme.Space([savme.Continuous("speed", 5, 35, bins=6), savme.Continuous("gap", 5, 60, bins=6)]),
            "cut_in": savme.Space([savme.Continuous("speed", 5, 35, bins=6), savme.Continuous("gap", 5, 40, bins=6)]),
        },
    )


def protocol(**kw):
    args = dict(preset="quick", seed=3, cost="work", budgets=[0.3], train_iterations=30, eval_iterations=8,
                test_iterations=12, baseline_train_iterations=20, baseline_test_iterations=10, simulator="python-toy")
    args.update(kw)
    return savme.Protocol(["stopped", "braking"], ["cut_in"], **args)


def toy(scenario, phi, theta):
    """Braking distance v²/(2·7) beyond the gap fails; a coarse rate reacts late (more
    failures); the work is the number of steps."""
    late = 10.0 / theta["rate_hz"] * phi["speed"] * 0.05
    fails = phi["speed"] ** 2 / 14.0 + late > phi["gap"]
    return fails, int(theta["rate_hz"] * 10)


def trial_records(path):
    """The trial lines of a campaign's store (without the protocol record it begins with)."""
    return [d for d in map(json.loads, path.read_text().splitlines()) if "protocol" not in d]


def strip_wall(path):
    """The trial lines without the measured wall-clock seconds (and the store's checksum,
    which covers them)."""
    lines = []
    for d in trial_records(path):
        d.pop("c", None)
        for run in ("hf", "lf"):
            if isinstance(d.get(run), dict):
                d[run].pop("wall_seconds", None)
        lines.append(d)
    return lines


def test_a_campaign_on_a_python_simulator_writes_savme_runs_outputs(tmp_path):
    p = protocol()
    result = savme.Campaign(p, problem(), out=tmp_path / "a", jobs=2).run(toy)
    assert result.ran == p.total_trials and result.replayed == 0
    for name in ("protocol", "trials", "table", "fidelity", "summary", "breakeven", "meta_testing"):
        assert result.files[name].exists(), name
    assert len(trial_records(result.files["trials"])) == p.total_trials
    summary = json.loads(result.files["summary"].read_text())
    assert "TP-rate" in result.table_md and result.report["protocol"]["simulator"] == "python-toy"
    assert summary["report"]["budgets"][0]["budget"] == 0.3
    assert savme.Protocol.load(tmp_path / "a") == p
    # Work cost: the same seed gives the same trials, whatever the number of workers.
    again = savme.Campaign(p, problem(), out=tmp_path / "b", jobs=1).run(hf=toy, lf=toy)
    assert strip_wall(result.files["trials"]) == strip_wall(again.files["trials"])


def test_hf_and_lf_callables_get_theta_hf_and_the_learned_theta(tmp_path):
    seen = {"hf": set(), "lf": set()}

    def hf(scenario, phi, theta):
        seen["hf"].add(theta["rate_hz"])
        return toy(scenario, phi, theta)

    def lf(scenario, phi, theta):
        seen["lf"].add(theta["rate_hz"])
        return toy(scenario, phi, theta)

    savme.Campaign(protocol(), problem(), out=tmp_path, jobs=2).run(hf=hf, lf=lf)
    assert seen["hf"] == {20} and len(seen["lf"]) > 1


def test_a_raising_simulator_stops_the_campaign_naming_the_trial_and_it_resumes(tmp_path):
    p = protocol()
    calls = {"n": 0}

    def flaky(scenario, phi, theta):
        calls["n"] += 1
        if calls["n"] == 40:
            raise RuntimeError("license server unreachable")
        return toy(scenario, phi, theta)

    with pytest.raises(savme.CampaignError, match="RuntimeError: license server unreachable") as e:
        savme.Campaign(p, problem(), out=tmp_path / "r", jobs=1).run(flaky)
    assert "trial" in str(e.value)
    stored = len(trial_records(tmp_path / "r" / "trials.jsonl"))
    assert 0 < stored < p.total_trials
    result = savme.Campaign(None, problem(), out=tmp_path / "r", resume=True, jobs=1).run(toy)
    assert result.replayed == stored and result.ran == p.total_trials - stored
    full = savme.Campaign(p, problem(), out=tmp_path / "full", jobs=1).run(toy)
    assert strip_wall(result.files["trials"]) == strip_wall(full.files["trials"])


INTERRUPTED_CHILD = """
import signal; signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C as in a terminal, even if the harness that started us ignores SIGINT (a shell's background job)
import sys, time
sys.path.insert(0, sys.argv[2])
import test_campaign as t

def slow(scenario, phi, theta):
    time.sleep(0.05)
    return t.toy(scenario, phi, theta)

import savme
savme.Campaign(t.protocol(), t.problem(), out=sys.argv[1], jobs=2).run(slow)
print("the campaign finished")
"""


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_sigint_and_sigterm_stop_a_running_campaign_between_trials_saying_how_to_resume(tmp_path, signame):
    """A real SIGINT or SIGTERM to a process in Campaign.run(): the campaign stops while it
    still runs (not when it ends), the told trials are stored intact, the error says where
    it stopped and the call that resumes it, and a resumed campaign ends identical to an
    uninterrupted one. SIGINT raises KeyboardInterrupt; SIGTERM exits 143 as `savme run`
    does (it killed the process at once before, exit -15, nothing said)."""
    import signal
    import sys
    import time

    out = tmp_path / "c"
    trials = out / "trials.jsonl"
    child = subprocess.Popen(
        [sys.executable, "-c", INTERRUPTED_CHILD, str(out), str(REPO / "python" / "tests")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and child.poll() is None:
        if trials.exists() and len(trials.read_text().splitlines()) >= 10:
            break
        time.sleep(0.02)
    assert child.poll() is None, "the campaign ended before it could be interrupted"
    child.send_signal(getattr(signal, signame))
    stdout, stderr = child.communicate(timeout=60)
    assert "the campaign finished" not in stdout
    resume = f'resume it with savme.Campaign(None, problem, out="{out}", resume=True).run(...)'
    if signame == "SIGINT":
        assert child.returncode != 0
        assert "KeyboardInterrupt: stopped in " in stderr and resume in stderr, stderr
    else:
        assert child.returncode == 143, (child.returncode, stderr)
        assert "savme: SIGTERM: stopped in " in stderr and resume in stderr, stderr
    assert "(every told trial is stored)" in stderr, stderr
    p = protocol()
    stored = len(trial_records(trials))
    assert 10 <= stored < p.total_trials, stored
    result = savme.Campaign(None, problem(), out=out, resume=True, jobs=1).run(toy)
    assert result.replayed == stored and result.ran == p.total_trials - stored
    full = savme.Campaign(p, problem(), out=tmp_path / "full", jobs=1).run(toy)
    assert strip_wall(result.files["trials"]) == strip_wall(full.files["trials"])


@pytest.mark.parametrize("on_error", ["abort", "skip"])
def test_keyboardinterrupt_and_systemexit_from_a_simulator_propagate_as_they_are(tmp_path, on_error):
    """A simulator that raises KeyboardInterrupt or SystemExit (not an Exception: a request
    to stop) stops the campaign and the very exception is raised — it was wrapped in a
    CampaignError (or, with on_error="skip", the trial withdrawn and the campaign run on).
    The told trials are stored and the campaign resumes. (With "skip" the interrupted trial
    may be stored as withdrawn, as any run that raised: the resumed campaign replaces it.)"""
    p = protocol(on_error=on_error)
    for n, exc in enumerate([KeyboardInterrupt("stop now"), SystemExit(3)]):
        calls = {"n": 0}

        def stopping(scenario, phi, theta, exc=exc):
            calls["n"] += 1
            if calls["n"] == 30:
                raise exc
            return toy(scenario, phi, theta)

        out = tmp_path / f"c{n}"
        with pytest.raises(type(exc)) as e:
            savme.Campaign(p, problem(), out=out, jobs=1).run(stopping)
        assert e.value is exc
        assert calls["n"] == 30, "the campaign stopped at the exception"
        lines = trial_records(out / "trials.jsonl")
        told = [d for d in lines if "error" not in d]
        assert 0 < len(told) < p.total_trials
        assert all("KeyboardInterrupt" in d["error"] or "SystemExit" in d["error"] for d in lines if "error" in d)
        if on_error == "abort":
            assert len(told) == len(lines)
        resumed = savme.Campaign(None, problem(), out=out, resume=True, jobs=1).run(toy)
        assert resumed.replayed == len(told) and resumed.ran == p.total_trials - len(told)


def test_bad_simulator_results_and_bad_protocols_are_named(tmp_path):
    with pytest.raises(savme.CampaignError, match=r"must return the failure flag \(bool or numpy bool\), \(failure, work_units\) or \(failure, work_units or None, robustness\), got float 0.5"):
        savme.Campaign(protocol(), problem(), out=tmp_path / "x", jobs=1).run(lambda s, phi, th: 0.5)
    # 0/1 is not a failure flag (truthiness would hide a simulator returning a count or a distance).
    with pytest.raises(savme.CampaignError, match=r"got int 1"):
        savme.Campaign(protocol(), problem(), out=tmp_path / "x1", jobs=1).run(lambda s, phi, th: (1, 3))
    # A float where the work count goes (a runtime, or NaN) is named with the trial and the value.
    with pytest.raises(savme.CampaignError, match=r"trial 0 .*HF run: .*work_units \(second of \(True, nan\)\) "
                                                  r"must be a whole number ≥ 0 \(an int\), got nan \(the second item "
                                                  r"counts work units, not seconds"):
        savme.Campaign(protocol(), problem(), out=tmp_path / "nan", jobs=1).run(lambda s, phi, th: (True, float("nan")))
    with pytest.raises(savme.CampaignError, match="work"):
        # Work cost, but the simulator returns a bare flag (no work count).
        savme.Campaign(protocol(), problem(), out=tmp_path / "y", jobs=1).run(lambda s, phi, th: False)
    with pytest.raises(ValueError, match="budgets"):
        protocol(budgets=[1.5])
    with pytest.raises(ValueError, match="cost.*expected `wall` or `work`"):
        protocol(cost="steps")
    with pytest.raises(ValueError, match="nope"):
        savme.Campaign(savme.Protocol(["nope"], ["cut_in"], preset="quick"), problem(), out=tmp_path / "z").run(toy)
    with pytest.raises(TypeError, match="give both hf= and lf="):
        savme.Campaign(protocol(), problem(), out=tmp_path / "w").run(hf=toy)
    with pytest.raises(ValueError, match="high-fidelity settings θ_HF: no value for variable `noise`"):
        savme.Problem(fidelity=savme.Space([savme.Boolean("noise")]), theta_hf={}, scenarios={})
    # A campaign directory in use is refused.
    savme.Campaign(protocol(), problem(), out=tmp_path / "done", jobs=1).run(toy)
    with pytest.raises(savme.CampaignError):
        savme.Campaign(protocol(), problem(), out=tmp_path / "done", jobs=1).run(toy)


def test_a_simulator_reports_robustness_the_trials_keep_it_and_the_elite_search_uses_it(tmp_path):
    def margin(scenario, phi, theta):
        """The toy's outcome with its robustness: the gap left after braking, metres."""
        fails, work = toy(scenario, phi, theta)
        late = 10.0 / theta["rate_hz"] * phi["speed"] * 0.05
        return fails, work, phi["gap"] - phi["speed"] ** 2 / 14.0 - late

    p = protocol(search="elite")
    result = savme.Campaign(p, problem(), out=tmp_path / "e", jobs=2).run(margin)
    lines = trial_records(result.files["trials"])
    for d in lines:
        assert isinstance(d["hf"]["robustness"], float)
        assert (d["hf"]["robustness"] <= 0) == d["hf"]["failure"], d
    # Deterministic from the seed, whatever the number of workers.
    again = savme.Campaign(p, problem(), out=tmp_path / "f", jobs=1).run(margin)
    assert strip_wall(result.files["trials"]) == strip_wall(again.files["trials"])
    with pytest.raises(savme.CampaignError, match=r"HF run: .*robustness \(third of \(False, 3, nan\)\) must be a finite number, got nan"):
        savme.Campaign(p, problem(), out=tmp_path / "g", jobs=1).run(lambda s, phi, th: (False, 3, float("nan")))


def test_the_bundled_driving_simulator_from_python(tmp_path):
    sim = savme.sim.Driving("ideal")
    names = [s["name"] for s in sim.scenarios()]
    assert len(names) == 10
    phi_space = sim.phi_space("7")
    phi = {v.name: (v.range[0] + v.range[1]) / 2 for v in phi_space.variables}
    r = sim.simulate("7", phi)
    assert isinstance(r["failure"], bool) and r["work"] > 0 and r["wall_seconds"] > 0
    assert sim.simulate(names[6], phi) ["min_distance"] == r["min_distance"]  # deterministic
    assert len(savme.sim.Driving.fidelity_space()) == 16
    with pytest.raises(KeyError, match="unknown scenario `moon_landing`"):
        sim.simulate("moon_landing", phi)
    with pytest.raises(ValueError, match='perception must be "sensors" or "ideal"'):
        savme.sim.Driving("lidar-only")
    p = savme.Protocol([names[0]], [names[8]], preset="quick", simulator="savme-sim/ideal", cost="work",
                       train_iterations=6, eval_iterations=2, test_iterations=4,
                       baseline_train_iterations=4, baseline_test_iterations=3)
    result = savme.Campaign(p, savme.Problem.driving(), out=tmp_path, jobs=2).run(sim=sim)
    assert result.ran == p.total_trials


def fmu_campaign_file(savme_bin, tmp_path):
    """examples/fmu/campaign.toml (in-process) with savme's packed FMU beside it: (path, text)."""
    fmu = tmp_path / "savme-sim.fmu"
    packed = os.environ.get("SAVME_SIM_FMU")  # .ci/run packs it once for every test
    if packed:
        shutil.copy(packed, fmu)
    else:
        subprocess.run([savme_bin, "fmu", "pack", "--out", str(fmu)], check=True, capture_output=True)
    text = (REPO / "examples" / "fmu" / "campaign.toml").read_text()
    text = text.replace("isolate = true", "isolate = false")
    cfg = tmp_path / "campaign.toml"
    cfg.write_text(text)
    return cfg, text


def test_a_campaign_file_refuses_to_run_another_simulator_in_place_of_its_own(savme_bin, tmp_path):
    """savme.campaign.load(file).run(python_simulator) ran the Python function in place of the
    file's FMUs and labelled every output with the FMU; it is refused naming the file and its
    simulator, saying how to run a Python simulator; nothing is written."""
    cfg, _ = fmu_campaign_file(savme_bin, tmp_path)
    campaign = savme.campaign.load(cfg, out=tmp_path / "out")
    simulator = campaign.protocol.to_dict()["simulator"]
    for run in (lambda: campaign.run(toy), lambda: campaign.run(hf=toy, lf=toy),
                lambda: campaign.run(sim=savme.sim.Driving())):
        with pytest.raises(TypeError) as e:
            run()
        message = str(e.value)
        assert f"loaded from {cfg}" in message and simulator in message, message
        assert "call run() without a simulator" in message and "savme.Campaign(savme.Protocol(" in message, message
    assert not (tmp_path / "out").exists()


def test_fmu_campaign_files_load_and_simulate(savme_bin, tmp_path):
    cfg, text = fmu_campaign_file(savme_bin, tmp_path)
    sim = savme.fmu.Simulator(cfg)
    scenario = sim.scenarios[0]
    phi = {v.name: (v.range[0] + v.range[1]) / 2 for v in sim.phi_space(scenario).variables}
    hf = sim.simulate(scenario, phi)
    lf = sim.simulate(scenario, phi, theta=dict(sim.theta_hf, simulation_rate_hz=2), role="lf")
    assert isinstance(hf["failure"], bool) and hf["wall_seconds"] > 0 and lf["wall_seconds"] > 0
    # The FMU gives what the bundled simulator gives for the same φ (FMU scenario names are
    # the bundled ones).
    assert hf["failure"] == savme.sim.Driving().simulate(scenario, phi)["failure"]
    campaign = savme.campaign.load(cfg, out=tmp_path / "out")
    assert campaign.protocol.to_dict()["simulator"].startswith("fmu:")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[fmu]", "[fmu]\nbogus = 1", 1))
    with pytest.raises(ValueError, match=r"bad.toml, line \d+.*bogus"):
        savme.fmu.Simulator(bad)
    with pytest.raises(KeyError, match="unknown scenario `nope`"):
        sim.simulate("nope", {})
    assert scenario in sim.scenarios
    # [failure] robustness (issue 42): the output's smallest value is each run's robustness,
    # the flag still the verdict; a robustness that is not a number output is named at load.
    assert "robustness" not in hf
    flag = 'boolean = "collision"'
    rho = tmp_path / "rho.toml"
    rho.write_text(text.replace(flag, flag + '\nrobustness = "min_distance"', 1))
    run = savme.fmu.Simulator(rho).simulate(scenario, phi)
    assert run["failure"] == hf["failure"] and isinstance(run["robustness"], float), run
    assert savme.campaign.load(rho, out=tmp_path / "rho-out").protocol.to_dict()["simulator"].startswith("fmu:")
    wrong = tmp_path / "wrong.toml"
    wrong.write_text(text.replace(flag, flag + '\nrobustness = "collision"', 1))
    for load in (savme.fmu.Simulator, savme.campaign.load):
        with pytest.raises(ValueError, match=r"wrong.toml, line \d+, key `failure.robustness`: .*Boolean"):
            load(wrong)


def test_a_simulators_exception_is_chained_with_its_file_and_line(tmp_path):
    def broken(scenario, phi, theta):
        return phi["no_such_variable"] > 1  # raises KeyError here

    with pytest.raises(savme.CampaignError) as e:
        savme.Campaign(protocol(), problem(), out=tmp_path / "b", jobs=1).run(broken)
    cause = e.value.__cause__
    assert isinstance(cause, KeyError) and cause.__traceback__ is not None
    assert "test_campaign.py:" in str(e.value) and "in broken" in str(e.value), str(e.value)


def test_python_errors_speak_python_not_command_line_flags(tmp_path):
    savme.Campaign(protocol(), problem(), out=tmp_path / "c", jobs=1).run(toy)
    with pytest.raises(savme.CampaignError) as e:
        savme.Campaign(protocol(), problem(), out=tmp_path / "c", jobs=1).run(toy)
    assert "resume=True" in str(e.value) and "--" not in str(e.value), str(e.value)
    with pytest.raises(ValueError, match=r"`train_iterations`: .*-5"):
        savme.Protocol(["a"], ["b"], train_iterations=-5)


def test_a_campaign_with_cost_budgets_spends_them_and_resumes_identically(tmp_path):
    """search_budget / deploy_budget: each search and deployed stage runs until its runs have
    cost that much (work units here); a campaign stopped part-way and resumed gives the same
    trials as one run straight through."""
    p = protocol(search_budget=4000.0, deploy_budget=2000.0, window=3)
    assert p.total_trials is None and "by cost" in repr(p)
    whole = savme.Campaign(p, problem(), out=tmp_path / "whole", jobs=2).run(toy)
    lines = trial_records(whole.files["trials"])
    assert whole.ran == len(lines)

    def cost(d):
        return sum((d.get(r) or {}).get("runtime", 0.0) for r in ("hf", "lf"))

    for stage, budget in (("train@0.3", 4000.0), ("screen@0.3", 2000.0), ("test-learned@0.3", 4000.0)):
        mine = [d for d in lines if d["stage"] == stage]
        spent = sum(map(cost, mine))
        assert spent >= budget, (stage, spent)
        # Stops asking once spent: at most the window (3) of trials in flight come after.
        assert spent - sum(map(cost, mine[-3:])) < budget, (stage, spent, len(mine))
    # Stopped by a raising simulator inside meta-training, then resumed: the same trials.
    part = tmp_path / "part"
    calls = {"n": 0}

    def flaky(scenario, phi, theta):
        calls["n"] += 1
        if calls["n"] == 60:  # HF and LF runs: past the baseline, inside meta-training
            raise RuntimeError("license server unreachable")
        return toy(scenario, phi, theta)

    with pytest.raises(savme.CampaignError, match="license server unreachable"):
        savme.Campaign(p, problem(), out=part, jobs=1).run(flaky)
    stored = len(trial_records(part / "trials.jsonl"))
    assert 0 < stored < len(lines)
    resumed = savme.Campaign(None, problem(), out=part, resume=True, jobs=2).run(toy)
    assert resumed.replayed == stored
    assert strip_wall(part / "trials.jsonl") == strip_wall(whole.files["trials"])


def test_a_fidelity_ladder_screens_down_its_levels_each_with_its_own_theta(tmp_path):
    """ladder=[0.2, 0.5]: HF plus two LF levels, each meta-trained at its budget; the screening
    stage at 0.5 runs the 0.2 level first and sends its failures up to 0.5, then HF."""
    p = protocol(budgets=[0.2, 0.5], ladder=[0.2, 0.5], screen_iterations=30, test_iterations=2,
                 baseline_test_iterations=2)
    assert p.to_dict()["ladder"] == [0.2, 0.5]
    lf_rates = []

    def lf(scenario, phi, theta):
        lf_rates.append(theta["rate_hz"])
        return toy(scenario, phi, theta)

    result = savme.Campaign(p, problem(), out=tmp_path / "a", jobs=2).run(hf=toy, lf=lf)
    lines = trial_records(result.files["trials"])
    evaluated = {b: next(d for d in lines if d["stage"] == f"evaluate@{b}")["theta_lf"] for b in ("0.2", "0.5")}
    top = [d for d in lines if d["stage"] == "screen@0.5"]
    assert len(top) == 30
    for d in top:
        (rung,) = d["ladder"]
        assert rung["budget"] == 0.2 and rung["theta_lf"] == evaluated["0.2"]
        assert d["theta_lf"] == evaluated["0.5"]
        # In order: the 0.5 level only after a failure at 0.2.
        assert ("lf" in d) == bool(rung.get("lf", {}).get("failure")), d
    levels = result.report["budgets"][1]["screening"]["levels"]
    assert [lv["budget"] for lv in levels] == [0.2, 0.5]
    assert levels[0]["runs"] == sum(1 for d in top if "lf" in d["ladder"][0])
    with pytest.raises(ValueError, match=r"`ladder`: .*cheapest first"):
        protocol(budgets=[0.2, 0.5], ladder=[0.5, 0.2], screen_iterations=3)
