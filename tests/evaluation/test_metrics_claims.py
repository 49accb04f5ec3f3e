from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.evaluation.cases import THESIS_TABLE_4_5, get_case
from simgap.evaluation.claims import check_claims, check_timing_claims, verdict
from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.metrics import Channels, freeze_key, rmse, window_mask
from simgap.evaluation.timing import summarize


def test_rmse_pools_channels_and_samples():
    a = np.array([[1.0, 0.0], [0.0, 0.0]])
    b = np.zeros((2, 2))
    assert rmse(a, b) == pytest.approx(0.5)  # sqrt(1/4)
    ch = Channels.rows("first", "first row", "u", (0,), 2)
    assert rmse(a, b, ch) == pytest.approx(math.sqrt(0.5))
    scaled = Channels(name="x2", label="", unit="", matrix=np.array([[2.0, 0.0]]))
    assert rmse(a, b, scaled) == pytest.approx(math.sqrt(2.0))
    assert math.isnan(rmse(np.empty((0, 2)), np.empty((0, 2))))
    with pytest.raises(EvaluationError):
        rmse(a, b[:1])
    with pytest.raises(EvaluationError):
        Channels.rows("bad", "", "", (5,), 2)


def test_window_and_keys():
    t = np.arange(5) * 0.5
    np.testing.assert_array_equal(window_mask(t, 0.5, 1.5), [False, True, True, False, False])
    assert freeze_key(180.0) == "180" and freeze_key(2.5) == "2.5"


def test_bicycle_front_force_channel_is_k_inverse():
    case = get_case("2-1")
    ch = {c.name: c for c in case.channels}["front_axle_force"]
    from simgap.models.bicycle import BicycleNominal

    nom = BicycleNominal(vx=20.0)
    delta = np.array([[1500.0, -300.0]])
    g = delta @ nom.K.T  # state residual of these axle forces
    np.testing.assert_allclose(ch.apply(g), [[1500.0]], rtol=1e-12)


def test_claims_on_the_thesis_own_table():
    c1 = THESIS_TABLE_4_5["1"]
    got = check_claims(c1["accuracy"], c1["consistency"])
    # B1 0.1238 best; P below B1 at 180 and 220 s; at 180 s P (0.1109) is nearer B1 (0.1344)
    # than B2 (0.0427), so "closer to B2" fails there
    assert got == {"b1_best_accuracy": True, "p_beats_b1_consistency": True,
                   "p_close_to_b2": False}
    c22 = THESIS_TABLE_4_5["2-2"]
    assert check_claims(c22["accuracy"], c22["consistency"])["b1_best_accuracy"] is False


def test_claims_missing_values_and_verdicts():
    got = check_claims([0.1, None, 0.2], {"1": [0.3, 0.2, 0.1]})
    assert got["b1_best_accuracy"] is None
    assert got["p_beats_b1_consistency"] is True and got["p_close_to_b2"] is True
    assert verdict(None) == "n/a" and verdict(False) == "not reproduced"
    # worse than both baselines is not "close to B2", even though B2 is the nearer one
    assert check_claims([0.1, 0.2, 0.3], {"4": [0.41, 0.54, 0.59]})["p_close_to_b2"] is False
    assert check_claims([0.1, 0.2, 0.3], {"4": [0.6, 0.2, 0.3]})["p_close_to_b2"] is True
    assert check_claims([0.1, 0.2, 0.3], {"4": [0.4, 0.2, 0.35]})["p_close_to_b2"] is False


def test_timing_summary_and_claims():
    ns = np.array([[1_000, 3_000_000, 2_000], [1_000, 1_000, 1_000]], dtype=np.int64)
    s = summarize(ns, deadline_ms=2.0)
    assert s["mean_ms"] == pytest.approx((0.001 + 3.0 + 0.002 + 3 * 0.001) / 6)
    assert s["runmax_mean_ms"] == pytest.approx((3.0 + 0.001) / 2)
    assert s["runmax_std_ms"] == pytest.approx(abs(3.0 - 0.001) / 2)
    assert s["peak_ms"] == pytest.approx(3.0)
    assert s["miss_runs_pct"] == 50.0 and s["miss_steps_pct"] == pytest.approx(100 / 6)
    ok = {"mean_ms": 0.01, "runmax_mean_ms": 0.1, "peak_ms": 0.5, "miss_runs_pct": 0.0}
    bad = {"mean_ms": 0.02, "runmax_mean_ms": 1.0, "peak_ms": 9.0, "miss_runs_pct": 8.0}
    assert check_timing_claims({"instantaneous": ok, "minibatch": bad, "integral": ok}) == \
        {"b2_worst_case": True, "only_b2_misses": True}
    assert check_timing_claims({"instantaneous": bad, "minibatch": ok, "integral": ok}) == \
        {"b2_worst_case": False, "only_b2_misses": False}
