"""The test session's ROS domain (tests/conftest.py): make test runs two pytest-xdist workers, and each must
have a domain of its own, or one worker's graph would answer the other's clients."""

import conftest


def test_each_xdist_worker_of_a_run_takes_a_domain_of_its_own(monkeypatch):
    monkeypatch.delenv("IMPURITY_TEST_DOMAIN_ID", raising=False)
    domains = []
    for worker in ("gw0", "gw1", "gw2"):
        monkeypatch.setenv("PYTEST_XDIST_WORKER", worker)
        domains.append(conftest.session_domain_id())
    assert len(set(domains)) == 3 and all(20 <= d <= 192 for d in domains)
    assert domains[1] == domains[0] + 1  # the run's domain plus the worker's number


def test_a_fixed_domain_is_kept_without_workers_and_offset_with_them(monkeypatch):
    monkeypatch.setenv("IMPURITY_TEST_DOMAIN_ID", "42")
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    assert conftest.session_domain_id() == 42
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw1")
    assert conftest.session_domain_id() == 43
