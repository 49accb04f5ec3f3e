"""benchmarks/downstream.py builds the old-vs-new tables from the studies' JSON; the highway
study's quick variant runs."""

from __future__ import annotations

import importlib.util
import json
import shutil

import pytest

from tests.conftest import REPO_ROOT

RESULTS = REPO_ROOT / "benchmarks" / "results"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "benchmarks" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_tables_put_new_numbers_beside_the_previous_ones(tmp_path):
    for f in ("compensation.json", "bench_mpc.json", "downstream_previous.json"):
        shutil.copy(RESULTS / f, tmp_path / f)
    comp = json.loads((tmp_path / "compensation.json").read_text())
    comp["manipulator_rmse_rad"]["integral"]["frozen"] = 0.0123  # a "new" number
    (tmp_path / "compensation.json").write_text(json.dumps(comp))
    md = _load("downstream").tables(tmp_path)
    row = next(line for line in md.splitlines() if line.startswith("| arm (rad) | integral"))
    prev = json.loads((tmp_path / "downstream_previous.json").read_text())
    old = prev["compensation"]["auto_previous"]["arm_integral"]
    assert row.split("|")[3].strip().startswith("0.012 /")
    assert row.split("|")[4].strip() == f"{old[0]:.3f} / {old[1]:.3f}"
    assert "nominal+integral" in md and "(highway_identifiers.json missing)" in md


def test_highway_study_quick(tmp_path):
    pytest.importorskip("highway_env")
    mod = _load("highway_identifiers")
    res = mod.main(["--seconds", "2", "--out", str(tmp_path)])
    assert set(res["auto"]) == set(res["thesis_bicycle"]) == set(mod.KINDS)
    assert all(len(v["correlation"]) == 2 for v in res["auto"].values())
    assert (tmp_path / "highway_identifiers.json").exists()


def test_seed_spread_quick():
    mod = _load("downstream_seeds")
    res = mod.run([0], train=2.0, evals=0.5)
    rows = res["compensation"]["0"]
    assert all(len(rows[f"{p}_{k}"]) == 2 for p in ("arm", "car")
               for k in ("instantaneous", "integral", "minibatch"))
    assert set(res["mpc"]["0"]) == {"nominal", "exact plant (bound)", "nominal+instantaneous",
                                    "nominal+integral", "nominal+minibatch"}
    assert rows["arm_exact"] < rows["arm_plain"]
