"""``simgap diagnose LOG1 LOG2 ... --jobs N [--ray]`` (issue 17): one summary, per-log reports.

The serial run and the 2-process pool must write identical reports and summaries; a log
that cannot be diagnosed is named with its one-line error while the others are kept, and
the exit status says so (1). Ray's equality is tested on a local 2-CPU instance in
``tests/test_sweeps.py`` (the same :func:`simgap.sweeps.run_jobs`); here under ``slow``.
"""

from __future__ import annotations

import json
import os

import pytest
from typer.testing import CliRunner

from simgap.cli import app
from simgap.outputs import MARKER
from tests.fuzz import snapshot

runner = CliRunner()


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    for name, effect, seed in (("a", "coulomb_friction:joint2:Fc=0.3", 1),
                               ("b", "viscous_friction:joint1:b=0.4", 2)):
        res = runner.invoke(app, ["record", str(d / f"{name}.csv"), "--duration", "4",
                                  "--effect", effect, "--seed", str(seed), "--no-truth"])
        assert res.exit_code == 0, res.output
    (d / "bad.csv").write_text("t,q1\n0,1\n0.1,2\n")  # the arm's columns are missing
    return d


def _run(logs, out, *extra):
    args = ["diagnose", str(logs / "a.csv"), str(logs / "bad.csv"), str(logs / "b.csv"),
            str(logs / "a.csv"), "--model", "manipulator2dof", "--no-figures", "--out",
            str(out), *extra]
    return runner.invoke(app, args)


def _tree(folder):
    out = {}
    for root, _dirs, files in os.walk(folder):
        for f in files:
            p = os.path.join(root, f)
            if f not in (MARKER,):
                out[os.path.relpath(p, folder)] = open(p, "rb").read()
    return out


def test_batch_serial_and_pool_identical_failed_log_named(logs, tmp_path):
    before = snapshot(logs)
    serial = _run(logs, tmp_path / "serial")
    pool = _run(logs, tmp_path / "pool", "--jobs", "2")
    assert snapshot(logs) == before  # the inputs are untouched
    for res in (serial, pool):
        assert res.exit_code == 1, res.output  # one log failed: documented status 1
        assert "3 of 4 recordings diagnosed" in res.output
        failed = [ln for ln in res.output.splitlines() if "failed:" in ln]
        assert len(failed) == 1 and "bad.csv" in failed[0] and "RecordingError" in failed[0]
    s = json.loads((tmp_path / "serial" / "summary.json").read_text())
    p = json.loads((tmp_path / "pool" / "summary.json").read_text())
    assert s.pop("meta")["backend"] == "serial" and p.pop("meta")["backend"] == "process pool"
    assert s == p
    rows = s["recordings"]
    assert [r["ok"] for r in rows] == [True, False, True, True]
    assert [r.get("report") for r in rows] == ["a/report.md", None, "b/report.md",
                                               "a-2/report.md"]
    assert rows[0]["mismatch"] and any("joint 2" in e for e in rows[0]["effects"])
    assert s["failed"] == [{"recording": str(logs / "bad.csv"), "error": rows[1]["error"]}]
    # every file of every per-log report is byte-identical between the backends
    ts, tp = _tree(tmp_path / "serial"), _tree(tmp_path / "pool")
    ts.pop("summary.json"), tp.pop("summary.json")
    ts.pop("summary.md"), tp.pop("summary.md")
    assert ts.keys() == tp.keys() and {"a/report.json", "b/report.json",
                                       "a-2/report.json"} <= ts.keys()
    assert ts == tp
    md = (tmp_path / "serial" / "summary.md").read_text()
    assert "| failed |" in md and "bad.csv" in md and "[a/report.md](a/report.md)" in md


def test_batch_refuses_bad_options_before_any_work(logs, tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    before = snapshot(tmp_path)
    for extra, words in ((["--out", str(tmp_path / "mine")], "not a previous simgap output"),
                         (["--out", str(logs)], "holds the input file"),
                         (["--out", str(tmp_path / "o"), "--jobs", "0"], "--jobs")):
        res = runner.invoke(app, ["diagnose", str(logs / "a.csv"), str(logs / "b.csv"),
                                  "--model", "manipulator2dof", *extra])
        assert res.exit_code == 2, res.output
        lines = [ln for ln in res.output.strip().splitlines() if ln]
        assert len(lines) == 1 and words in lines[0], res.output
    assert snapshot(tmp_path) == before


@pytest.mark.slow
def test_batch_on_local_ray_matches_serial(logs, tmp_path):
    pytest.importorskip("ray")
    serial = _run(logs, tmp_path / "serial")
    ray = _run(logs, tmp_path / "ray", "--ray", "--jobs", "2")
    assert serial.exit_code == ray.exit_code == 1, ray.output
    s = json.loads((tmp_path / "serial" / "summary.json").read_text())
    r = json.loads((tmp_path / "ray" / "summary.json").read_text())
    s.pop("meta"), r.pop("meta")
    assert s == r
