"""Campaigns kept in PostgreSQL (storage=, campaign=): the same trials as in a directory,
resume from the database, clear errors that never show the password.

The server is a throwaway one that tests/it/python_package.rs starts (initdb in a temporary
directory) and passes as $SAVME_TEST_POSTGRES_URL. Without it these tests skip loudly, and with
SAVME_REQUIRE_POSTGRES=1 they fail instead.
"""

import os

import pytest

import savme
from test_campaign import problem, protocol, toy

URL = os.environ.get("SAVME_TEST_POSTGRES_URL")


@pytest.fixture
def url():
    if not URL:
        message = "no PostgreSQL server ($SAVME_TEST_POSTGRES_URL, set by tests/it/python_package.rs)"
        if os.environ.get("SAVME_REQUIRE_POSTGRES") == "1":
            pytest.fail(message + ", and SAVME_REQUIRE_POSTGRES=1")
        pytest.skip("SKIPPED: " + message)
    return URL


def test_a_campaign_in_postgresql_equals_one_in_a_directory_and_resumes_from_it(url, tmp_path):
    p = protocol()
    in_dir = savme.Campaign(p, problem(), out=tmp_path / "dir", jobs=2).run(toy)
    calls = {"n": 0}

    def flaky(scenario, phi, theta):
        calls["n"] += 1
        if calls["n"] == 40:
            raise RuntimeError("license server unreachable")
        return toy(scenario, phi, theta)

    with pytest.raises(savme.CampaignError, match="license server unreachable"):
        savme.Campaign(p, problem(), out=tmp_path / "db", jobs=1, storage=url, campaign="py-a").run(flaky)
    # Nothing of the campaign's trials is in the output directory: they are in the database.
    assert not (tmp_path / "db" / "trials.jsonl").exists()
    resumed = savme.Campaign(None, problem(), out=tmp_path / "db", jobs=2, resume=True,
                             storage=url, campaign="py-a").run(toy)
    assert 0 < resumed.replayed < p.total_trials
    assert resumed.replayed + resumed.ran == p.total_trials
    assert resumed.table_md == in_dir.table_md
    assert resumed.report["budgets"] == in_dir.report["budgets"]
    # Starting it again is refused; resuming the finished campaign replays everything.
    with pytest.raises(savme.CampaignError, match="already holds a campaign"):
        savme.Campaign(p, problem(), out=tmp_path / "again", storage=url, campaign="py-a").run(toy)
    again = savme.Campaign(None, problem(), out=tmp_path / "db", resume=True,
                           storage=url, campaign="py-a").run(toy)
    assert again.replayed == p.total_trials and again.ran == 0


def test_storage_arguments_are_checked_and_the_password_is_never_shown(url, tmp_path):
    p = protocol()
    with pytest.raises(ValueError, match="storage= needs campaign=NAME"):
        savme.Campaign(p, problem(), storage=url)
    with pytest.raises(ValueError, match="campaign= names a campaign in a database"):
        savme.Campaign(p, problem(), campaign="x")
    with pytest.raises(ValueError, match="not a PostgreSQL connection URL") as bad:
        savme.Campaign(p, problem(), storage="postgresql://savme:hunter2@[::1", campaign="x")
    assert "hunter2" not in str(bad.value)
    with pytest.raises(savme.CampaignError, match="no campaign to resume"):
        savme.Campaign(None, problem(), resume=True, storage=url, campaign="never-started")
    # A wrong password: the error names the database, never the password.
    wrong = url.replace("://savme:", "://savme:Wr0ngPassw0rd-", 1)
    assert wrong != url
    with pytest.raises(savme.CampaignError, match="password authentication failed") as e:
        savme.Campaign(p, problem(), out=tmp_path / "w", storage=wrong, campaign="w").run(toy)
    assert "Wr0ngPassw0rd" not in str(e.value) and "127.0.0.1" in str(e.value)
    password = url.split("://", 1)[1].split("@", 1)[0].split(":", 1)[1]
    assert password not in str(e.value)
