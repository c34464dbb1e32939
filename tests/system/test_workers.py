"""derive.derivation.workers: calls shared among forked worker processes come back in order, an error in
one is raised in the caller, and DERIVE_JOBS is read as the house reads any input."""
import os

import pytest

from derive.errors import UsageError
from derive.derivation.workers import job_count, run_all


def _pid_and_square(x):
    return os.getpid(), x * x


def _fails(x):
    raise ValueError(f"call {x} failed")


def test_results_come_back_in_the_order_of_the_calls():
    out = run_all([(_pid_and_square, (k,)) for k in range(12)], jobs=2)
    assert [sq for _, sq in out] == [k * k for k in range(12)]
    assert os.getpid() not in {pid for pid, _ in out}      # made by the workers, not here


def test_one_job_makes_the_calls_here():
    out = run_all([(_pid_and_square, (k,)) for k in range(3)], jobs=1)
    assert out == [(os.getpid(), k * k) for k in range(3)]


def test_an_error_in_a_worker_is_raised_in_the_caller():
    with pytest.raises(ValueError, match="call 3 failed"):
        run_all([(_pid_and_square, (1,)), (_fails, (3,))], jobs=2)


@pytest.mark.parametrize("text", ["0", "-1", "two", "1.5"])
def test_a_bad_job_count_is_a_usage_error(monkeypatch, text):
    monkeypatch.setenv("DERIVE_JOBS", text)
    with pytest.raises(UsageError, match="DERIVE_JOBS"):
        job_count()


def test_the_job_count_is_read_from_the_environment(monkeypatch):
    monkeypatch.setenv("DERIVE_JOBS", "3")
    assert job_count() == 3
