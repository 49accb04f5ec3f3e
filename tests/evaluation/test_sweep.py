"""``simgap reproduce --seeds``: a sweep gives the serial runs' numbers, from any backend."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.sweep import _markdown, parse_cases, reproduce_sweep, summarise
from simgap.sweeps import JobResult


def test_process_pool_sweep_equals_the_serial_sweep(tmp_path):
    serial = reproduce_sweep(tmp_path / "a", seeds=[0, 1], cases=["2-1"], quick=True)
    pooled = reproduce_sweep(tmp_path / "b", seeds=[0, 1], cases=["2-1"], quick=True, jobs=2)
    assert serial["failed"] == [] and pooled["failed"] == []
    assert serial["cases"] == pooled["cases"]
    m = serial["cases"]["2-1"]["metrics"]["integral/accuracy"]
    assert m["n"] == 2 and m["min"] <= m["mean"] <= m["max"]
    # Seed 0's run is the plain single-seed run.
    one = json.loads((tmp_path / "a" / "seed-0" / "case-2-1" / "results.json").read_text())
    prim = one["cases"]["2-1"]["primary_variant"]
    acc0 = one["cases"]["2-1"]["variants"][prim]["methods"]["integral"]["accuracy"]
    assert acc0 in (m["min"], m["max"])
    assert (tmp_path / "a" / "summary.md").read_text().startswith("# simgap reproduce")


def test_bad_sweep_arguments_are_rejected_before_any_run(tmp_path):
    with pytest.raises(EvaluationError, match="timing"):
        parse_cases("1,timing")
    assert parse_cases("all")[:3] == ["1", "2-1", "2-2"]
    proc = subprocess.run([sys.executable, "-m", "simgap.cli", "reproduce", "--seeds", "5-2",
                           "--out", str(tmp_path / "x")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "--seeds" in proc.stderr and not (tmp_path / "x").exists()


def test_failed_jobs_are_reported_by_case_and_seed():
    ok = JobResult(index=0, args=("/tmp/x", "2-1", True, 0),
                   value={"seed": 0, "case": "2-1", "metrics": {"integral/accuracy": 0.5}})
    bad = JobResult(index=1, args=("/tmp/y", "2-1", True, 7), error="ValueError: boom")
    s = summarise([ok, bad])
    assert s["failed"] == [{"case": "2-1", "seed": 7, "error": "ValueError: boom"}]
    assert s["cases"]["2-1"]["seeds"] == [0]
    assert "- case 2-1, seed 7: ValueError: boom" in _markdown(s)


def test_sweep_refuses_a_folder_with_the_users_files(tmp_path):
    from simgap.errors import OutputError

    (tmp_path / "mine.txt").write_text("x")
    with pytest.raises(OutputError):
        reproduce_sweep(tmp_path, seeds=[0], cases=["2-1"], quick=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]
