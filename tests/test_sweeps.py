"""Sweeps: serial, local process pool and local Ray give the same results in the same order."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from simgap.errors import SimgapError
from simgap.sweeps import SweepError, parse_seeds, run_jobs


def seeded_job(seed: int, n: int) -> list[float]:
    """A deterministic job: a seeded draw and a reduction (picklable, module level)."""
    x = np.random.default_rng(seed).normal(size=n)
    if seed == 3:
        raise ValueError(f"seed {seed} fails on purpose\nsecond line")
    return [float(x.sum()), float(np.cumsum(x)[-1])]


JOBS = [(s, 1000) for s in range(6)]


def _check(results):
    serial = run_jobs(seeded_job, JOBS)
    assert [r.index for r in results] == list(range(len(JOBS)))
    assert [r.value for r in results] == [r.value for r in serial]
    assert [r.ok for r in results] == [s != 3 for s in range(6)]
    assert results[3].error == "ValueError: seed 3 fails on purpose"


def test_serial_runs_every_job_and_reports_the_failed_one():
    ticks = []
    res = run_jobs(seeded_job, JOBS, progress=lambda d, t: ticks.append((d, t)))
    assert ticks[-1] == (6, 6) and len(ticks) == 6
    _check(res)


def test_process_pool_matches_the_serial_run():
    _check(run_jobs(seeded_job, JOBS, workers=2))


@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="extra 'ray' not installed")
def test_local_ray_with_two_cpus_matches_the_serial_run():
    _check(run_jobs(seeded_job, JOBS, workers=2, ray=True))


def test_bad_options_are_one_line_errors():
    with pytest.raises(SweepError, match="--jobs"):
        run_jobs(seeded_job, JOBS, workers=0)
    assert issubclass(SweepError, SimgapError)
    assert parse_seeds("0-3,7, 5") == [0, 1, 2, 3, 5, 7]
    for bad in ("a", "3-1", "-2", "1-", "0-999999"):
        with pytest.raises(SweepError, match="--seeds"):
            parse_seeds(bad)


@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="extra 'ray' not installed")
def test_ray_start_up_failure_is_one_line(monkeypatch):
    """Ray raises a bare Exception when its node times out at start-up (overloaded machine)."""
    import ray

    def timeout(**kwargs):
        raise Exception("The current node timed out during startup. This could happen\n...")

    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", timeout)
    with pytest.raises(SweepError, match=r"^--ray: cannot start or join Ray \(The current node "
                       r"timed out during startup. This could happen\)$"):
        run_jobs(seeded_job, JOBS, workers=2, ray=True)
