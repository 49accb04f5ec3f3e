"""Held-out vehicle variants (``benchmarks/diagnosis_vehicle_variants.py``, issue 13 s8).

Quick: one effect and one clean log on a few variants the diagnosis was never tuned on.
SIMGAP_SLOW=1: every vocabulary effect × 2 seeds and 5 clean logs per variant. On the
low-passed yaw-rate column a 10 Hz upstream filter delays r by ≈ 25 ms, which a steering lag
would do too: it was named on clean logs (``benchmarks/results/diagnosis_s8-veh_causes.md``);
now the latency is stated and not named (``FitSpec.latency``), so a true steering lag is not
named there either, and the mass ratio is still missed (an expected failure).
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

from simgap.diagnosis.proof import draw
from tests.conftest import REPO_ROOT

SLOW = os.environ.get("SIMGAP_SLOW") == "1"


def _bench():
    spec = importlib.util.spec_from_file_location(
        "diagnosis_vehicle_variants", REPO_ROOT / "benchmarks" / "diagnosis_vehicle_variants.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


V = _bench()


def test_the_variants_change_the_log() -> None:
    base = V.generate_bicycle([], duration=V.DURATION, seed=0)
    for name in V.VARIANTS:
        rec = V.recording(name, [], 0)
        assert rec.n != base.n or any(not np.array_equal(rec[c], base[c])
                                      for c in ("vx", "r", "delta_f")), name
    q = V.recording("quantised_steering", [], 0)["delta_f"]
    assert np.allclose(q / V.STEER_STEP, np.round(q / V.STEER_STEP))


@pytest.mark.parametrize(("variant", "effect"), [("fast_35ms", "mass_mismatch"),
                                                 ("log_50hz", "steering_lag")])
def test_an_effect_is_named_on_a_held_out_variant(variant: str, effect: str) -> None:
    out = V.case(variant, [draw(effect, np.random.default_rng(1000))], 0)
    assert out["named"] and not out["extra"], out


@pytest.mark.parametrize("variant", ["slow_8ms", "quantised_steering"])
def test_a_clean_held_out_variant_names_nothing(variant: str) -> None:
    out = V.case(variant, [], 100)
    assert out["found"] == [], out


def test_an_upstream_low_pass_of_the_yaw_rate_is_no_steering_lag() -> None:
    """A 10 Hz filter on r delays the logged motion by ≈ 25 ms, as a steering lag would: a
    clean log named a steering lag of that size (s8-veh). The error model sees the filter
    (r's upper half band is not white), so the latency is fitted and stated, not named."""
    from simgap.diagnosis.pipeline import diagnose
    rep = diagnose(V.recording("imu_lowpass", [], 100), "bicycle")
    assert rep.effects == []
    (lag,) = [e for e in rep.data["tried"] if e["effect"] == "steering_lag"
              and e["decision"] == "not identifiable"]
    assert "r was low-passed before logging" in lag["reason"]
    assert 0.015 < float(lag["reason"].split("(")[1].split(" s)")[0]) < 0.04


@pytest.mark.skipif(not SLOW, reason="slow: set SIMGAP_SLOW=1")
@pytest.mark.parametrize("variant", [pytest.param(v, marks=pytest.mark.xfail(
    strict=True, reason="r low-passed upstream: a steering lag cannot be told from the "
    "filter's lag (not named, by design) and the mass ratio is missed"))
    if v == "imu_lowpass" else v for v in V.VARIANTS])
def test_every_effect_on_every_variant(variant: str) -> None:
    res = V.run([variant], list(V.EFFECTS), 2, 5)
    s = res["summary"][variant]
    assert s["errors"] == 0 and s["clean_named"] == 0, s
    assert s["named"] == s["cases"] and s["with_extra"] == 0, \
        [(r["effect"], r["seed"], r.get("found")) for r in res["rows"] if not r.get("named")
         or r.get("extra")]
