"""`simgap record` / `simgap diagnose`: end to end, bad input → one line, exit 2, nothing
half-written; hypothesis fuzz of the CLI on malformed recordings."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from simgap.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    out = d / "arm.csv"
    res = runner.invoke(app, ["record", str(out), "--model", "manipulator2dof", "--effect",
                              "coulomb_friction:joint2:Fc=0.2", "--duration", "8",
                              "--seed", "1"])
    assert res.exit_code == 0, res.output
    return out


def test_record_then_diagnose(recorded, tmp_path):
    truth = json.loads((recorded.parent / "arm.csv.truth.json").read_text())
    assert truth["injected"][0]["effect"] == "coulomb_friction"
    out = tmp_path / "rep"
    res = runner.invoke(app, ["diagnose", str(recorded), "--model", "manipulator2dof",
                              "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "Coulomb friction at joint 2" in res.output
    data = json.loads((out / "report.json").read_text())
    assert data["schema"] == 1 and data["model"] == "manipulator2dof"
    assert data["mismatch"]["significant"] is True
    assert [e["effect"] for e in data["effects"]] == ["coulomb_friction"]
    e = data["effects"][0]
    assert e["channel"] == "joint2" and abs(e["parameters"]["Fc"] - 0.2) < 0.02
    assert set(e) >= {"effect", "channel", "parameters", "stderr", "explained_fraction", "text"}
    f = data["fit"]
    assert set(f) >= {"split", "nominal", "augmented"}
    assert len(f["nominal"]["rollout_rmse"]) == 4 and len(f["nominal"]["derivative_rmse"]) == 2
    assert {s["channel"] for s in data["mismatch"]["segments"]} <= {"joint1", "joint2"}
    assert any(r["variable"] == "dq2" for r in data["mismatch"]["regions"])
    for name in ("report.md", "residual_time.png", "residual_vs_variable.png",
                 "simulation.png", "augmented_model.json"):
        assert (out / name).stat().st_size > 0
    md = (out / "report.md").read_text()
    assert "![residual over time](residual_time.png)" in md


def test_bicycle_cli(tmp_path):
    rec = tmp_path / "car.parquet"
    res = runner.invoke(app, ["record", str(rec), "--model", "bicycle", "--effect",
                              "lateral_bias:ay0=0.4", "--duration", "20", "--no-truth"])
    assert res.exit_code == 0, res.output
    assert not (tmp_path / "car.parquet.truth.json").exists()
    res = runner.invoke(app, ["diagnose", str(rec), "--model", "bicycle", "--out",
                              str(tmp_path / "r"), "--no-figures"])
    assert res.exit_code == 0, res.output
    data = json.loads((tmp_path / "r" / "report.json").read_text())
    assert [e["effect"] for e in data["effects"]] == ["lateral_bias"]
    assert data["effects"][0]["channel"] == "vehicle"
    assert {c["channel"] for c in data["mismatch"]["channels"]} == {"front_axle", "rear_axle"}


def _bad(args, tmp_path, *words):
    out = tmp_path / "out"
    res = runner.invoke(app, args + ["--out", str(out)])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.strip().splitlines() if ln]
    assert len(lines) == 1, res.output
    for w in words:
        assert w in lines[0], lines[0]
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_bad_inputs(recorded, tmp_path):
    text = recorded.read_text().splitlines()
    cases = {
        "missing.csv": ([ln.rsplit(",", 1)[0] for ln in text], "missing column 'tau2'"),
        "nonnum.csv": (text[:5] + [text[5].replace(",", ",x", 1)] + text[6:], "non-numeric"),
        "nan.csv": (text[:9] + [text[9].rsplit(",", 1)[0] + ",nan"] + text[10:], "not finite"),
        "time.csv": (text[:30] + [text[29]] + text[31:], "strictly increase"),
        "short.csv": (text[:20], "too few samples"),
    }
    for name, (lines, words) in cases.items():
        p = tmp_path / name
        p.write_text("\n".join(lines) + "\n")
        _bad(["diagnose", str(p), "--model", "manipulator2dof"], tmp_path, name, words)
    params = tmp_path / "p.json"
    params.write_text('{"mass": 3}')
    _bad(["diagnose", str(recorded), "--model", "manipulator2dof", "--params", str(params)],
         tmp_path, "unknown parameter 'mass'")
    params.write_text("{not json")
    _bad(["diagnose", str(recorded), "--model", "manipulator2dof", "--params", str(params)],
         tmp_path, "p.json", "not valid JSON")
    _bad(["diagnose", str(recorded), "--model", "tank"], tmp_path, "unknown model 'tank'")
    _bad(["diagnose", str(tmp_path / "none.csv"), "--model", "bicycle"], tmp_path,
         "does not exist")
    _bad(["diagnose", str(recorded), "--model", "bicycle"], tmp_path, "missing column")


def test_record_bad_effect(tmp_path):
    for eff, words in (("warp_drive:k=1", "unknown effect"),
                       ("coulomb_friction:joint7:Fc=0.1", "needs a channel"),
                       ("coulomb_friction:joint1:Fc=abc", "not a number"),
                       ("coulomb_friction:joint1:b=0.1", "takes parameters")):
        res = runner.invoke(app, ["record", str(tmp_path / "x.csv"), "--effect", eff])
        assert res.exit_code == 2, res.output
        assert words in res.output and len(res.output.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(rows=st.integers(0, 120), bad=st.sampled_from(["", "nan", "x", "1e400", "-", "inf"]),
       where=st.integers(0, 200), drop=st.sampled_from([None, "t", "q1", "tau2"]),
       shuffle=st.booleans())
def test_fuzz_cli(tmp_path, rows, bad, where, drop, shuffle):
    """Malformed recordings: exit 2 with one line and no report, or a valid report."""
    rng = np.random.default_rng(rows)
    cols = [c for c in ("t", "q1", "q2", "dq1", "dq2", "tau1", "tau2") if c != drop]
    t = np.arange(rows) * 0.002
    if shuffle and rows > 2:
        t[rows // 2], t[rows // 2 - 1] = t[rows // 2 - 1], t[rows // 2]
    lines = [",".join(cols)]
    for i in range(rows):
        vals = [f"{t[i]:.4f}" if c == "t" else f"{rng.normal():.4f}" for c in cols]
        if i == where % max(rows, 1):
            vals[where % len(vals)] = bad
        lines.append(",".join(vals))
    p = tmp_path / "f.csv"
    p.write_text("\n".join(lines) + "\n")
    out = tmp_path / "fo"
    res = runner.invoke(app, ["diagnose", str(p), "--model", "manipulator2dof", "--out",
                              str(out), "--no-figures"])
    if res.exit_code == 0:
        assert (out / "report.json").exists()
    else:
        assert res.exit_code == 2, (res.output, res.exception)
        assert len(res.output.strip().splitlines()) == 1
        assert not out.exists()


def test_diagnosis_is_deterministic(recorded):
    from simgap.diagnosis.pipeline import diagnose

    a = diagnose(recorded, "manipulator2dof").data
    b = diagnose(recorded, "manipulator2dof").data
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def test_bicycle_speed_too_low(tmp_path):
    from simgap.diagnosis.generate import generate_bicycle
    from simgap.recordings import write_recording

    rec = generate_bicycle([], duration=5, seed=0)
    cols = dict(rec.columns)
    cols["vx"] = cols["vx"].copy()
    cols["vx"][100] = 0.5
    p = write_recording(tmp_path / "slow.csv", cols)
    _bad(["diagnose", str(p), "--model", "bicycle"], tmp_path, "slow", "'vx'", "row 101",
         "vx > 1 m/s")
