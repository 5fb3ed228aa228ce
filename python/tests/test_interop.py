"""Python and the CLI share the kernel and the journal format: the same seed gives the same
trials as the Rust kernel behind `savme serve`, and each resumes the other's journals."""

import json
import os
import pathlib
import shutil
import subprocess
import sys
import time
import warnings

import pytest

import savme
from conftest import REPO, paired, serve

FIXTURES = REPO / "tests" / "fixtures"


def toy_kernel_by_hand(seed=1):
    """The toy simulator's kernel (src/toy.rs), built with the Python API."""
    lin = lambda name, lo, hi: savme.Continuous(name, lo, hi, bins=6)
    fidelity = savme.Space(
        [
            savme.Discrete("rate_hz", [5, 10, 20, 50, 100]),
            savme.Discrete("integrator", ["euler", "rk4"]),
            savme.Boolean("disable_sensor_noise"),
            savme.Continuous("horizon_s", 3.0, 15.0, bins=4),
        ]
    )
    scenarios = {
        "stopped_obstacle": savme.Space([lin("ego_speed", 5.0, 35.0), lin("gap", 10.0, 120.0)]),
        "braking_lead": savme.Space(
            [lin("ego_speed", 10.0, 35.0), lin("headway", 8.0, 60.0), lin("lead_decel", 1.0, 9.0)]
        ),
    }
    theta_hf = {"rate_hz": 100, "integrator": "rk4", "disable_sensor_noise": False, "horizon_s": 15.0}
    return savme.Kernel(fidelity=fidelity, theta_hf=theta_hf, scenarios=scenarios, seed=seed)


def outcome_of(trial):
    """A deterministic rule for both sides: fail when fast; LF at 5 Hz misses it."""
    fails = trial["phi"]["ego_speed"] > 25.0
    if trial["theta_lf"] is None:
        return fails, None
    lf = fails and trial["theta_lf"]["rate_hz"] > 5
    return fails, lf


def test_the_python_api_builds_the_same_configuration_as_the_cli(example_config):
    assert json.loads(toy_kernel_by_hand().config_json()) == json.loads(example_config)


def test_same_seed_same_trials_and_records_as_the_rust_kernel(savme_bin, example_config, tmp_path):
    cfg = tmp_path / "kernel.json"
    cfg.write_text(example_config)
    py_trials, py_records = [], []
    k = toy_kernel_by_hand()
    requests = []
    for i in range(40):
        t = k.ask()
        hf, lf = outcome_of(t.to_dict())
        rec = k.tell(t, hf=(hf, 1.0), lf=(lf, 0.1 + 0.01 * i))
        py_trials.append(t.to_dict())
        py_records.append(rec.to_dict())
        requests += [{"op": "ask"}, {"op": "tell", "id": t.id, "observation": paired(hf, lf, 1.0, 0.1 + 0.01 * i)}]
    k.set_phase("evaluate")
    requests += [{"op": "phase", "phase": "evaluate"}, {"op": "ask", "n": 5}]
    evaluate = [t.to_dict() for t in k.ask(5)]
    responses = serve(savme_bin, requests, "--config", str(cfg))
    cli_trials = [r["trials"][0] for r in responses[0:80:2]]
    cli_records = [r["record"] for r in responses[1:80:2]]
    assert py_trials == cli_trials
    assert py_records == cli_records
    assert responses[-1]["trials"] == evaluate


def test_python_resumes_a_journal_the_cli_wrote(savme_bin, example_config, tmp_path):
    cfg, journal = tmp_path / "kernel.json", tmp_path / "serve.journal"
    cfg.write_text(example_config)
    first = serve(savme_bin, [{"op": "ask", "n": 6}], "--config", str(cfg), "--journal", str(journal))
    trials = first[0]["trials"]
    tells = [
        {"op": "tell", "id": t["id"], "observation": paired(*(x or False for x in outcome_of(t)))}
        for t in trials[:4]
    ]
    serve(savme_bin, tells + [{"op": "cancel", "id": trials[4]["id"]}, {"op": "phase", "phase": "test"}], "--journal", str(journal))
    shutil.copy(journal, tmp_path / "copy.journal")
    k = savme.Kernel.resume(journal)
    assert k.stats() == {"asked": 6, "told": 4, "cancelled": 1}
    assert [t.to_dict() for t in k.pending()] == [trials[5]]
    assert k.phase == "test"
    nxt = k.ask()
    cli_next = serve(savme_bin, [{"op": "ask"}], "--journal", str(tmp_path / "copy.journal"))[0]["trials"][0]
    assert nxt.to_dict() == cli_next
    # And a journal written by an earlier savme (tests/fixtures) resumes too.
    old = tmp_path / "old.journal"
    shutil.copy(FIXTURES / "serve-toy.journal.jsonl", old)
    resumed = savme.Kernel.resume(old)
    assert resumed.stats() == {"asked": 8, "told": 5, "cancelled": 0}
    assert resumed.phase == "evaluate"


def test_the_cli_resumes_a_journal_python_wrote(savme_bin, example_config, tmp_path):
    journal = tmp_path / "py.journal"
    k = savme.Kernel.from_config(example_config, journal=journal)
    assert k.journal == journal
    trials = k.ask(5)
    for t in trials[:3]:
        hf, lf = outcome_of(t.to_dict())
        k.tell(t, hf=(hf, 1.0), lf=(lf, 0.2))
    k.cancel(trials[3])
    k.set_phase("evaluate")
    expected_next = savme.Kernel.from_json(k.to_json()).ask()
    k.close()  # releases the journal's lock
    r = serve(savme_bin, [{"op": "stats"}, {"op": "pending"}, {"op": "ask"}], "--journal", str(journal))
    assert r[0]["stats"] == {"asked": 5, "told": 3, "cancelled": 1} and r[0]["phase"] == "evaluate"
    assert r[1]["trials"] == [trials[4].to_dict()]
    assert r[2]["trials"][0] == expected_next.to_dict()
    # Back to Python: the CLI's ask is in the journal.
    again = savme.Kernel.resume(journal)
    assert [t.id for t in again.pending()] == [trials[4].id, expected_next.id]
    # Resuming with the same configuration is fine; another one is refused.
    again.close()
    savme.Kernel.from_config(example_config, journal=journal).close()
    other = json.loads(example_config)
    other["seed"] = 2
    with pytest.raises(savme.JournalError, match="was started with a different configuration"):
        savme.Kernel.from_config(json.dumps(other), journal=journal)


def test_a_journal_held_by_a_running_server_is_refused_naming_its_pid(savme_bin, example_config, tmp_path):
    cfg, journal = tmp_path / "kernel.json", tmp_path / "held.journal"
    cfg.write_text(example_config)
    proc = subprocess.Popen(
        [savme_bin, "serve", "--config", str(cfg), "--journal", str(journal)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        proc.stdin.write('{"op":"ask"}\n')
        proc.stdin.flush()
        assert json.loads(proc.stdout.readline())["ok"]
        with pytest.raises(savme.JournalError, match=f"in use by another savme process \\(pid {proc.pid}\\)"):
            savme.Kernel.resume(journal)
    finally:
        proc.stdin.close()
        proc.wait(timeout=30)
    assert savme.Kernel.resume(journal).stats()["asked"] == 1


def test_python_is_refused_while_another_python_kernel_holds_the_journal(example_config, tmp_path):
    journal = tmp_path / "j"
    k = savme.Kernel.from_config(example_config, journal=journal)
    # The same process: said so (it read "another savme process (pid <this pid>)").
    with pytest.raises(savme.JournalError, match=rf"already open in this process \(pid {os.getpid()}\).*close\(\) or drop the one that holds it first"):
        savme.Kernel.resume(journal)
    k.close()
    savme.Kernel.resume(journal)


def test_a_torn_last_line_is_dropped_with_a_warning_and_a_bad_line_is_named(example_config, tmp_path):
    journal = tmp_path / "torn.journal"
    with savme.Kernel.from_config(example_config, journal=journal) as k:
        k.ask(2)
    text = journal.read_text()
    journal.write_text(text + '{"event":"ask","tri')
    with pytest.warns(RuntimeWarning, match="line 4 was cut off mid-write"):
        k = savme.Kernel.resume(journal)
    assert k.stats()["asked"] == 2
    k.ask()
    k.close()
    lines = journal.read_text().splitlines()
    assert len(lines) == 4 and all(json.loads(l) for l in lines)
    lines[2] = lines[2].replace('"event":"ask"', '"event":"fly"')
    journal.write_text("\n".join(lines) + "\n")
    with pytest.raises(savme.JournalError, match=f"{journal}, line 3: unknown variant `fly`"):
        savme.Kernel.resume(journal)
    with pytest.raises(savme.JournalError, match="missing.journal: no journal to resume"):
        savme.Kernel.resume(tmp_path / "missing.journal")
    assert not (tmp_path / "missing.journal").exists()
    (tmp_path / "empty.journal").write_text("")
    with pytest.raises(savme.JournalError, match="empty.journal holds no journal yet"):
        savme.Kernel.resume(tmp_path / "empty.journal")


def test_a_python_process_killed_mid_campaign_resumes_from_its_journal(example_config, tmp_path):
    """kill -9 a Python process in its ask/tell loop; the journal it left resumes: nothing told
    is lost, the pending trials are known, and the run continues as an uninterrupted one."""
    journal = tmp_path / "killed.journal"
    script = tmp_path / "loop.py"
    script.write_text(
        "import sys, savme\n"
        f"k = savme.Kernel.from_config(open({str(tmp_path / 'kernel.json')!r}).read(), journal=sys.argv[1])\n"
        "print('started', flush=True)\n"
        "while True:\n"
        "    t = k.ask()\n"
        "    k.tell(t, hf=(t.phi['ego_speed'] > 25, 1.0), lf=(t.phi['ego_speed'] > 25, 0.2))\n"
    )
    (tmp_path / "kernel.json").write_text(example_config)
    proc = subprocess.Popen([sys.executable, str(script), str(journal)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    while journal.stat().st_size < 200_000:
        time.sleep(0.02)
    proc.kill()  # SIGKILL
    proc.wait()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the kill may cut the last line
        k = savme.Kernel.resume(journal)
    stats = k.stats()
    assert stats["told"] > 100 and stats["asked"] - stats["told"] <= 1
    # The same calls without a kill give the same state and the same next trials.
    ref = savme.Kernel.from_config(example_config)
    for _ in range(stats["told"]):
        t = ref.ask()
        ref.tell(t, hf=(t.phi["ego_speed"] > 25, 1.0), lf=(t.phi["ego_speed"] > 25, 0.2))
    for p in k.pending():
        assert ref.ask() == p
    assert k.ask(5) == ref.ask(5)
