"""What an Optuna user expects of the kernel: its trial history (`Kernel.trials()`, a pandas
DataFrame), an `optimize` loop with timeout and callbacks, `Trial.from_dict`, pickling; and
typed accessors so that ordinary arithmetic on φ and θ type-checks."""

import copy
import pickle

import pytest

import savme
from test_kernel import kernel, runs


def test_trials_hold_every_told_trial_with_phi_theta_runs_and_outcome():
    k = kernel()
    told = []
    for _ in range(12):
        t = k.ask()
        hf, lf = runs(t)
        told.append(k.tell(t, hf=hf, lf=lf))
    cancelled = k.ask()
    k.cancel(cancelled)
    history = k.trials()
    assert list(history) == told, "told trials only, in tell order"
    rows = history.rows()
    assert len(rows) == 12
    first = rows[0]
    t = told[0].trial
    assert first["id"] == t.id and first["scenario"] == t.scenario and first["phase"] == "train"
    assert first["phi.gap_m"] == t.phi["gap_m"] and first["theta_lf.rate_hz"] == t.theta_lf["rate_hz"]
    assert (first["hf_failure"], first["hf_runtime"]) == told[0].hf
    assert (first["lf_failure"], first["lf_runtime"]) == told[0].lf
    assert first["outcome"] == told[0].outcome and first["cost_ratio"] == told[0].cost_ratio


def test_to_pandas_gives_one_row_per_trial():
    try:
        import pandas
    except ImportError:
        import os
        import sys

        message = "pandas is not installed (python/develop.sh installs it): SKIPPING the DataFrame check"
        if os.environ.get("SAVME_REQUIRE_PYTHON_PACKAGE") == "1":
            pytest.fail(message + " — but SAVME_REQUIRE_PYTHON_PACKAGE=1 requires it")
        print("\n*** " + message + " ***", file=sys.stderr)
        pytest.skip(message)
    k = kernel()
    k.optimize(runs, 9)
    df = k.trials().to_pandas()
    assert isinstance(df, pandas.DataFrame)
    assert len(df) == 9 and {"phi.gap_m", "theta_lf.rate_hz", "hf_failure", "outcome"} <= set(df.columns)
    assert list(df["id"]) == [r.id for r in k.trials()]


def test_a_resumed_journal_keeps_its_history(tmp_path):
    journal = tmp_path / "k.journal"
    k = kernel(journal=journal)
    k.optimize(runs, 7)
    before = list(k.trials())
    k.close()
    again = savme.Kernel.resume(journal)
    assert list(again.trials()) == before
    again.optimize(runs, 3)
    assert len(again.trials()) == 10


def test_optimize_runs_n_trials_calls_back_and_matches_a_hand_written_loop():
    by_hand = kernel()
    for _ in range(20):
        t = by_hand.ask()
        hf, lf = runs(t)
        by_hand.tell(t, hf=hf, lf=lf)
    k = kernel()
    seen = []
    told = k.optimize(runs, 20, callbacks=[lambda kernel, record: seen.append((kernel, record.id))])
    assert [r.to_dict() for r in told] == [r.to_dict() for r in by_hand.trials()]
    assert [i for _, i in seen] == [r.id for r in told] and all(x is k for x, _ in seen)
    assert k.to_json() == by_hand.to_json()


def test_optimize_stops_at_the_timeout():
    import time

    k = kernel()

    def slow(trial):
        time.sleep(0.05)
        return runs(trial)

    told = k.optimize(slow, 1000, timeout=0.3)
    assert 1 <= len(told) < 50
    assert k.stats()["told"] == len(told) and not k.pending()


def test_an_objective_that_raises_cancels_its_trial():
    k = kernel()
    calls = {"n": 0}

    def flaky(trial):
        calls["n"] += 1
        if calls["n"] % 3 == 0:
            raise ConnectionError("simulator host down")
        return runs(trial)

    told = k.optimize(flaky, 9, catch=(ConnectionError,))
    assert len(told) == 6 and k.stats() == {"asked": 9, "told": 6, "cancelled": 3}
    with pytest.raises(ConnectionError, match="simulator host down"):
        k.optimize(flaky, 9)
    assert not k.pending(), "the raising trial was cancelled"
    with pytest.raises(TypeError, match=r"objective\(trial \d+\) must return \(hf, lf\)"):
        k.optimize(lambda t: True, 1)
    with pytest.raises(ValueError, match=r"n_trials must be an int >= 0 or None \(no limit\), got -1"):
        k.optimize(runs, -1)
    with pytest.raises(ValueError, match="timeout must be a finite number"):
        k.optimize(runs, 1, timeout=float("inf"))


def test_optimize_takes_what_optunas_optimize_takes():
    """catch= a single exception class (Optuna's `catch=ValueError`), timeout= without
    n_trials; a bare callable for callbacks= (Optuna refuses it too, after its first trial)
    is a TypeError naming the argument before any trial runs."""
    k = kernel()
    calls = {"n": 0}

    def flaky(trial):
        calls["n"] += 1
        if calls["n"] % 2 == 0:
            raise ValueError("bad run")
        return runs(trial)

    told = k.optimize(flaky, 6, catch=ValueError)
    assert len(told) == 3 and k.stats() == {"asked": 6, "told": 3, "cancelled": 3}
    with pytest.raises(ValueError, match="bad run"):
        k.optimize(flaky, 6, catch=KeyError)
    with pytest.raises(TypeError, match="catch must be an exception class or a tuple of them; 'x' is not"):
        k.optimize(runs, 1, catch=("x",))
    asked = k.stats()["asked"]
    with pytest.raises(TypeError, match=r"callbacks must be a list of callables \(as in Optuna\), got the callable .*give callbacks=\[cb\]"):
        k.optimize(runs, 3, callbacks=lambda kernel, record: None)
    assert k.stats()["asked"] == asked, "refused before any trial"
    before = k.stats()["told"]
    told = k.optimize(runs, timeout=0.2)
    assert len(told) > 0 and k.stats()["told"] == before + len(told) and not k.pending()


def test_a_trial_and_a_record_pickle_and_cross_a_process_pool():
    """Trials go to worker processes of a multiprocessing pool (pickled there and back),
    each run there, and are told here — the same records as a loop in this process."""
    import multiprocessing

    k = kernel()
    trials = k.ask(6)
    assert [pickle.loads(pickle.dumps(t)) for t in trials] == trials
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        results = pool.map(runs, trials)
        echoed = pool.map(copy.copy, trials)
    assert echoed == trials
    records = [k.tell(t, hf, lf) for t, (hf, lf) in zip(trials, results)]
    by_hand = kernel()
    assert [by_hand.tell(t, *runs(t)) for t in by_hand.ask(6)] == records
    assert pickle.loads(pickle.dumps(records[0])) == records[0]
    assert copy.deepcopy(records[-1]).to_dict() == records[-1].to_dict()


def test_the_history_keeps_all_the_last_n_or_no_told_records():
    k = kernel(history=5)
    assert k.history_limit == 5
    told = k.optimize(runs, 12)
    assert [r.id for r in told] == [r.id for r in k.trials()] == list(range(7, 12))
    restored = pickle.loads(pickle.dumps(k))
    assert restored.history_limit == 5 and list(restored.trials()) == list(k.trials())
    restored.optimize(runs, 2)
    assert [r.id for r in restored.trials()] == list(range(9, 14))
    none = kernel(history=False)
    assert none.history_limit == 0
    assert len(none.optimize(runs, 12)) == 0 and len(none.trials()) == 0
    same = kernel()
    same.optimize(runs, 12)
    assert none.stats()["told"] == 12 and none.to_json() == same.to_json(), "the history changes nothing else"
    assert kernel(history=True).history_limit is None and kernel().history_limit is None
    with pytest.raises(ValueError, match="^history must be a whole number from 0 to .*, got -1$"):
        kernel(history=-1)
    with pytest.raises(TypeError, match="^history must be True .*, False .* or an int N .*, got 'all'$"):
        kernel(history="all")


def test_a_resumed_journal_keeps_as_much_history_as_asked(tmp_path):
    journal = tmp_path / "k.journal"
    k = kernel(journal=journal)
    k.optimize(runs, 9)
    ids = [r.id for r in k.trials()]
    k.close()
    with savme.Kernel.resume(journal, history=4) as again:
        assert [r.id for r in again.trials()] == ids[-4:]
    with savme.Kernel.resume(journal, history=False) as again:
        assert len(again.trials()) == 0 and again.stats()["told"] == 9


def test_without_history_a_kernels_memory_stays_flat():
    """~320 B per told trial is kept for trials() (the README's space; ~770 B on the paper's):
    history=False keeps none, so a kernel that tells many trials does not grow."""
    import gc
    import os

    if not os.path.exists("/proc/self/statm"):
        pytest.skip("measures the resident set through /proc (Linux)")

    def rss():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def grown(history, n=30_000):
        k = kernel(history=history)
        block = lambda m: [k.tell(k.ask(), hf=(False, 1.0), lf=(False, 0.2)) for _ in range(m)] and None
        block(2000)
        gc.collect()
        before = rss()
        block(n)
        gc.collect()
        return (rss() - before) / n

    kept, none = grown(None), grown(False)
    assert kept > 150, f"{kept:.0f} B per told trial with the history kept"
    assert none < 30, f"{none:.0f} B per told trial without history"


def test_a_kernel_pickles_with_its_history_and_asks_the_same_trials():
    k = kernel()
    k.optimize(runs, 15)
    pending = k.ask(2)
    restored = pickle.loads(pickle.dumps(k))
    assert restored.to_json() == k.to_json()
    assert list(restored.trials()) == list(k.trials())
    assert restored.pending() == pending
    assert restored.ask() == k.ask()
    assert copy.deepcopy(k).to_json() == k.to_json()


def test_a_journaled_kernel_is_not_pickled(tmp_path):
    k = kernel(journal=tmp_path / "j.journal")
    with pytest.raises(TypeError, match=r"cannot be pickled .* Kernel.resume"):
        pickle.dumps(k)


def test_trial_from_dict_round_trips_and_names_a_bad_field():
    k = kernel()
    t = k.ask()
    again = savme.Trial.from_dict(t.to_dict())
    assert again == t
    k.tell(again, *runs(again))  # this kernel's pending trial: accepted
    bad = t.to_dict()
    bad["phase"] = "training"
    with pytest.raises(ValueError, match="Trial.from_dict: unknown variant `training`"):
        savme.Trial.from_dict(bad)


def test_typed_accessors_give_the_kind_asked_or_name_the_variable():
    k = kernel()
    t = k.ask()
    gap = t.phi_as("gap_m", float)
    assert isinstance(gap, float) and gap == t.phi["gap_m"]
    assert t.phi_as("weather", str) in ("sun", "rain")
    assert isinstance(t.theta_as("rate_hz", int), int)
    assert isinstance(t.theta_as("rate_hz", float), float)  # an int is a float too
    assert isinstance(t.theta_as("disable_shadows", bool), bool)
    with pytest.raises(TypeError, match=r'theta_lf\["disable_shadows"\] is bool .*, not a float'):
        t.theta_as("disable_shadows", float)
    with pytest.raises(TypeError, match=r'phi\["weather"\] is str'):
        t.phi_as("weather", int)
    with pytest.raises(KeyError, match="phi has no variable `gap` .*gap_m"):
        t.phi_as("gap", float)
    k.set_phase("baseline")
    b = k.ask()
    with pytest.raises(ValueError, match="trial 1 is a baseline trial without theta_lf"):
        b.theta_as("rate_hz", int)


def test_the_optuna_section_of_the_python_readme_runs(tmp_path, monkeypatch, capsys):
    import re
    import runpy

    from conftest import REPO

    text = (REPO / "python" / "README.md").read_text()
    section = text.split("## Coming from Optuna", 1)[1]
    (block,) = re.findall(r"```python\n(.*?)```", section, re.S)
    script = tmp_path / "optuna_example.py"
    script.write_text(block)
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(script), run_name="__main__")
    printed = capsys.readouterr().out
    assert printed.startswith("200 {'rate_hz': "), printed
