from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from simgap.cli import app
from simgap.evaluation.cases import METHODS, get_case
from simgap.evaluation.runner import run_case
from simgap.outputs import MARKER

runner = CliRunner()


def test_reproduce_case_2_1_writes_report_json_and_figures(tmp_path):
    out = tmp_path / "rep"
    res = runner.invoke(app, ["reproduce", "--case", "2-1", "--quick", "--out", str(out)])
    assert res.exit_code == 0, res.output
    names = sorted(p.name for p in out.iterdir())
    assert names == [MARKER, "case2_1_consistency.png", "case2_1_online.png", "report.md",
                     "results.json"]  # the marker lets a rerun replace this output
    assert all((out / n).stat().st_size > 10_000 for n in names if n.endswith(".png"))
    data = json.loads((out / "results.json").read_text())
    c = data["cases"]["2-1"]
    assert c["freeze_times_s"] == [4.0, 10.0]
    assert c["primary_variant"] == "state_rows|full|x_bar"
    prim = c["variants"][c["primary_variant"]]["methods"]
    assert set(prim) == set(METHODS)
    for m in prim.values():
        assert np.isfinite(m["accuracy"]) and set(m["consistency"]) == {"4", "10"}
    assert set(c["claims"]) == {"b1_best_accuracy", "p_beats_b1_consistency", "p_close_to_b2"}
    md = (out / "report.md").read_text()
    assert "Table 4.5" in md and "0.6955" in md and "case2_1_online.png" in md
    # nothing but the outputs is left beside the folder (the temp dir was removed)
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_reproduce_timing_quick(tmp_path):
    out = tmp_path / "t"
    res = runner.invoke(app, ["reproduce", "--case", "timing", "--quick", "--timing-runs", "2",
                              "--out", str(out)])
    assert res.exit_code == 0, res.output
    t = json.loads((out / "results.json").read_text())["timing"]
    assert t["settings"]["n_runs"] == 2 and t["settings"]["n_steps"] == 2000
    for kind in METHODS:
        s = t["summary"][kind]
        assert 0 < s["mean_ms"] <= s["runmax_mean_ms"] <= s["peak_ms"]
        assert len(t["run_max_ms"][kind]) == 2
    assert t["machine"]["python"] and t["machine"]["numba"]
    assert (out / "timing.png").exists()


@pytest.mark.parametrize("args, msg", [(["--case", "3"], "--case"),
                                       (["--case", "1", "--seed", "-2"], "--seed"),
                                       (["--case", "timing", "--timing-runs", "0"], "timing")])
def test_bad_arguments_exit_2_and_write_nothing(tmp_path, args, msg):
    out = tmp_path / "x"
    res = runner.invoke(app, ["reproduce", *args, "--out", str(out)])
    assert res.exit_code == 2
    assert msg in res.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_out_is_a_file_is_rejected(tmp_path):
    f = tmp_path / "file"
    f.write_text("keep")
    res = runner.invoke(app, ["reproduce", "--case", "2-1", "--quick", "--out", str(f)])
    assert res.exit_code == 2 and f.read_text() == "keep"


def test_case_1_quick_is_deterministic_and_learns():
    case = get_case("1")
    a = run_case(case, quick=True, seed=1, methods=("instantaneous",))
    b = run_case(case, quick=True, seed=1, methods=("instantaneous",))
    ra, rb = a.results["instantaneous"], b.results["instantaneous"]
    np.testing.assert_array_equal(ra.g_online, rb.g_online)
    m = a.metrics[a.primary_variant]["instantaneous"]
    target_rms = float(np.sqrt(np.mean(a.transitions.target[:, 2:] ** 2)))
    # baseline 1 learns the friction within 20 s: its frozen model beats ĝ ≡ 0 by far
    assert m["consistency"]["20"] < 0.2 * target_rms


@pytest.mark.slow
def test_full_case_1_runs_all_methods_without_divergence():
    cr = run_case(get_case("1"), quick=False, seed=0)
    assert not cr.diverged
    for m in cr.metrics[cr.primary_variant].values():
        assert np.isfinite(m["accuracy"]) and set(m["consistency"]) == {"180", "220"}


def test_no_timing_as_the_issue_spells_the_sweep_and_refuses_timing_alone(tmp_path):
    # issue 17's command line: `reproduce --seeds ... --case ... --no-timing --jobs N` (a
    # sweep never times, so the flag is accepted as is)
    out = tmp_path / "sweep"
    res = runner.invoke(app, ["reproduce", "--seeds", "0", "--case", "2-1", "--quick",
                              "--no-timing", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "summary.md").exists()
    # nothing left to run: one line, exit 2, nothing written
    bad = tmp_path / "bad"
    res = runner.invoke(app, ["reproduce", "--case", "timing", "--no-timing", "--out", str(bad)])
    assert res.exit_code == 2
    assert "--no-timing with --case timing" in res.output
    assert not bad.exists()
