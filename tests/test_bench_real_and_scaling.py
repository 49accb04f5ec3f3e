"""Quick variants of the EMPS-protocol and diagnosis-scaling benchmarks (issue 13/17).

The full runs write benchmarks/results/emps_protocol.json and diagnosis_scaling.json; here
the same scripts run tiny variants and their JSON must carry every field the notes quote.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.test_benchmarks import _run

ROOT = Path(__file__).resolve().parents[1]


def test_emps_protocol_quick(tmp_path, shared_dir) -> None:
    out = tmp_path / "emps.json"
    res = _run("emps_protocol.py", "--test-seconds", "1", "--out", str(out))
    assert json.loads(out.read_text()) == res
    assert res["protocol"]["init_window_samples"] == 20
    assert res["gtau_N_per_V"] == pytest.approx(35.15065188248547)
    assert {e["effect"] for e in res["effects_named"]} >= {"viscous_friction",
                                                           "coulomb_friction"}
    r = res["results"]
    for name in ("simgap_augmented", "nominal", "published_physics"):
        assert not r[name]["diverged"] and r[name]["rmse_m"] > 0
    # over the first second the friction-free nominal already drifts far more than the
    # augmented model, which stays within a few mm like the published physics model
    assert r["nominal"]["rmse_m"] > 10 * r["simgap_augmented"]["rmse_m"]
    assert r["simgap_augmented"]["rmse_m"] < 3 * r["published_physics"]["rmse_m"]
    assert set(res["published_quoted_rmse"]["values"]) == {"LSTM", "RNN", "FIR-MLP", "GRU"}


def test_emps_protocol_result_file_is_complete() -> None:
    res = json.loads((ROOT / "benchmarks" / "results" / "emps_protocol.json").read_text())
    assert res["protocol"]["test_seconds"] > 24.0          # the whole pulse set
    for name in ("simgap_augmented", "nominal", "published_physics"):
        assert "rmse_m" in res["results"][name]


def test_diagnosis_scaling_quick(tmp_path) -> None:
    out = tmp_path / "scaling.json"
    res = _run("diagnosis_scaling.py", "--durations", "6,12", "--out", str(out))
    assert json.loads(out.read_text()) == res
    assert [r["duration_s"] for r in res["rows"]] == [6.0, 12.0]
    for row in res["rows"]:
        assert row["samples"] == int(row["duration_s"] * 500) + 1
        assert row["diagnose_s"] > 0 and row["peak_rss_mb"] >= row["rss_before_mb"] > 0
        assert row["bytes_per_sample"] >= 0 and row["us_per_sample"] > 0
    assert set(res["meets"]) == {"diagnose_60s", "linear", "bytes_per_sample"}
    assert res["meets"]["diagnose_60s"] is None             # no 60 s row in this variant
