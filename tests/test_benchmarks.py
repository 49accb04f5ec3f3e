"""The benchmark scripts run (tiny variants): their JSON has every field the notes quote.

Speed targets are checked by the benchmarks themselves, not here (these machines are noisy).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(script: str, *args: str) -> dict:
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / script), *args],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout)


def test_bench_identifiers_quick(tmp_path):
    out = tmp_path / "bench.json"
    res = _run("bench_identifiers.py", "--runs", "2", "--steps", "200", "--batch", "300",
               "--batch-calls", "3", "--env-steps", "300", "--out", str(out))
    assert json.loads(out.read_text()) == res
    for kind in ("instantaneous", "integral", "minibatch"):
        stats = res["per_step"][kind]["all"]
        assert stats["n"] == 400
        assert 0 < stats["p50_us"] <= stats["p99_us"] <= stats["p999_us"] <= stats["max_us"]
        assert res["batched"][kind]["api_us_per_instance_step"]["median_us"] > 0
    assert res["per_step"]["minibatch"]["burst_steps"]["n"] > 0
    assert res["batched"]["integral"]["threads"] >= 1
    for row in res["verdict"].values():
        assert row["measured"] > 0 and isinstance(row["met"], bool)


def test_bench_envs_quick():
    res = _run("bench_envs.py", "--steps", "300", "--repeats", "1")
    assert res["manipulator"]["bare_steps_per_s"] > 0
    assert res["bicycle"]["bare_steps_per_s"] > 0


def test_diagnosis_artefacts_quick(tmp_path):
    out = tmp_path / "art.json"
    res = _run("diagnosis_artefacts.py", "--seeds", "1", "--clean", "1",
               "--effects", "coulomb_friction", "--artefacts", "quantised_encoder,gap",
               "--out", str(out))
    assert json.loads(out.read_text()) == res
    assert set(res["summary"]) == {"quantised_encoder", "gap"}
    for row in res["rows"]:
        assert row["effect"] == "coulomb_friction"
        assert "error" in row or isinstance(row["named"], bool)
    assert res["summary"]["gap"]["cases"] == 1
    assert {"clean_with_named_effects", "clean_flagged_mismatch"} <= set(res["summary"]["gap"])
    assert len(res["clean"]) == 3      # the arm for both, the bicycle has no encoder positions


def test_bench_sweeps_quick():
    # Ray's own equality is tested in tests/test_sweeps.py (its start-up costs ~20 s).
    res = _run("bench_sweeps.py", "--seeds", "2", "--jobs", "2", "--backends", "process_pool")
    assert set(res["runs"]) == {"serial", "process_pool"}
    assert all(res["identical_to_serial"].values())
    for run in res["runs"].values():
        assert run["wall_s"] > 0 and run["failed"] == 0


def test_bench_auto_quick(tmp_path):
    """The bar benchmark of the auto preset runs (tiny: 300 Pendulum-v1 steps, no case)."""
    out = tmp_path / "bar.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_auto.py"),
                           "--seeds", "0", "--cases", "--pendulum-steps", "300", "--out",
                           str(out)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    doc = json.loads(out.read_text())
    rows = [r for r in doc["rows"] if r["scenario"] == "Pendulum-v1"]
    assert sorted(r["kind"] for r in rows) == ["instantaneous", "integral", "minibatch"]
    for r in rows:
        assert r["diverged"] is None and 0 < r["max_abs_g_hat"] < 100
        assert isinstance(r["met"], bool)
    assert (tmp_path / "bar_pendulum.png").stat().st_size > 0


def test_bench_vector_quick(tmp_path):
    out = tmp_path / "bench_vector.json"
    res = _run("bench_vector.py", "--ns", "1,4", "--repeats", "1", "--budget", "0.01",
               "--fresh", "1", "--diag-durations", "6", "--out", str(out))
    assert json.loads(out.read_text()) == res
    diag = res["diagnosis_rss_per_sample"]["rows"]["6"]
    assert diag["samples"] > 2000 and diag["bytes_per_sample"] == diag["bytes_per_sample"]
    for system in ("manipulator", "bicycle"):
        row = res["vector"][system]["4"]
        for key in ("native_bare", "native_wrapped", "sync_bare", "sync_wrapped"):
            assert row[key] > 0 and row[f"{key}_cpu"] > 0
        assert row["ratio_native_over_sync_bare"] > 0
    assert res["single"]["manipulator"]["bare_steps_per_s"] > 0
    fresh = res["fresh"]["manipulator"]
    assert all(fresh[k] > 0 for k in ("import_s", "make_s", "reset_s", "first_step_s"))
    assert set(res["verdict"]) >= {"single_arm_bare_cpu", "first_step_arm", "import_simgap"}


def test_bench_vector_filed_worker_quick():
    # The filed-baseline path, with this checkout standing in for the filing commit's (the
    # real run points --filed at a checkout of it): the worker process times its sync env in
    # the same repeats and the ratios to it are recorded.
    res = _run("bench_vector.py", "--ns", "2", "--repeats", "2", "--budget", "0.01",
               "--fresh", "0", "--diag-durations", "", "--filed", str(ROOT))
    assert Path(res["filed"]["simgap_imported_from"]).resolve().is_relative_to(ROOT)
    for system in ("manipulator", "bicycle"):
        row = res["vector"][system]["2"]
        assert row["sync_filed_bare"] > 0 and row["sync_filed_bare_cpu"] > 0
        assert row["ratio_native_over_sync_filed_bare"] > 0
        assert row["ratio_sync_over_sync_filed_bare"] > 0


def test_diagnosis_variants_quick(tmp_path):
    """The held-out variants table runs (one variant, one effect, one clean log)."""
    out = tmp_path / "var.json"
    res = _run("diagnosis_variants.py", "--variants", "enc_2p20", "--effects",
               "coulomb_friction", "--clean", "1", "--out", str(out))
    assert json.loads(out.read_text()) == res
    s = res["summary"]["enc_2p20"]
    assert s["cases"] == 1 and s["clean"] == 1 and s["errors"] == 0
    assert s["clean_with_named_effects"] == 0          # a backward difference is no delay
    assert {"ok", "wrong_effect_named", "named_with_extra_effects"} <= set(s)
