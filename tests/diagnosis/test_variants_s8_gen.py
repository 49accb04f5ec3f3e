"""Held-out artefact variants (s8-gen): a lagged motion is no input delay.

* **A velocity column that lags its angle** (a backward difference: half a sample; a
  drive's moving average: its group delay) fitted as an input delay at both joints on every
  clean log of a 2^20-count encoder with a backward-difference velocity
  (``benchmarks/diagnosis_variants.py``, variant ``enc_2p20``): the lag is measured against
  the angle's zero-phase derivative and the angle is differentiated instead.
* **Angles low-passed before logging** (a causal 2nd-order Butterworth at 20 Hz) lag the
  logged input by the filter's group delay, which no log can tell from an actuator delay:
  the delay is fitted but reported as not identifiable, not named.
* **A torque column clipped at a saturation level** (2 % of the samples) left a real
  torque bias "not confirmed" on the test part: rows whose equation reads a clipped sample
  are not fitted or scored.
"""

import numpy as np
from scipy.signal import butter, lfilter

from simgap.diagnosis.artefacts import finite_difference, quantise
from simgap.diagnosis.errormodel import LAG_Z, clipped, column_error_model, velocity_lag
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.pipeline import diagnose
from simgap.recordings import Recording

PAIRS = {"dq1": "q1", "dq2": "q2"}


def _blind(rec: Recording) -> Recording:
    return Recording(rec.name, dict(rec.columns))


def _butter(rec: Recording, columns, cutoff_hz: float) -> Recording:
    b, a = butter(2, cutoff_hz, fs=1.0 / float(np.median(np.diff(rec.t))))
    cols = dict(rec.columns)
    for c in columns:
        cols[c] = rec[c][0] + lfilter(b, a, rec[c] - rec[c][0])
    return Recording(rec.name, cols)


def _signal(dt: float = 0.002):
    t = np.arange(0.0, 20.0, dt)
    q = np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 1.9 * t)
    dq = 2 * np.pi * (0.7 * np.cos(2 * np.pi * 0.7 * t) + 0.3 * 1.9 * np.cos(2 * np.pi * 1.9 * t))
    return t, q, dq


def test_velocity_lag_measures_a_backward_difference():
    rng = np.random.default_rng(0)
    dt = 0.002
    _, q, dq = _signal(dt)
    qn = q + rng.normal(0.0, 1e-4, q.size)
    lag, se = velocity_lag(qn, dq + rng.normal(0.0, 2e-3, q.size), dt)
    assert abs(lag) < LAG_Z * se                      # a consistent pair: no lag
    bd = np.empty_like(qn)
    bd[1:] = np.diff(qn) / dt
    bd[0] = bd[1]
    lag, se = velocity_lag(qn, bd, dt)
    assert abs(lag - dt / 2) < 0.05 * dt and lag > LAG_Z * se


def test_low_passed_column_is_told_from_white_noise():
    rng = np.random.default_rng(1)
    t, q, _ = _signal()
    white = q + rng.normal(0.0, 1e-4, q.size)
    b, a = butter(2, 20.0, fs=500.0)
    low = lfilter(b, a, white)
    assert not column_error_model("q", white).low_passed
    assert column_error_model("q", low).low_passed
    assert not column_error_model("q", white[::10]).low_passed        # 50 Hz, still white


def test_backward_difference_velocity_is_no_input_delay():
    rec = generate("manipulator2dof", [], seed=500, duration=20.0)
    rec = finite_difference(quantise(rec, ["q1", "q2"], 2 * np.pi / 2**20), PAIRS)
    rep = diagnose(_blind(rec), "manipulator2dof")
    assert rep.effects == []
    assert any("dq1 lags the derivative of q1" in w for w in rep.prepared.warnings)


def test_true_input_delay_still_named_with_a_backward_difference_velocity():
    inj = InjectedEffect(effect="input_delay", channel=None, params={"delay": 0.01})
    rec = generate("manipulator2dof", [inj], seed=3, duration=20.0)
    rec = finite_difference(quantise(rec, ["q1", "q2"], 2 * np.pi / 2**20), PAIRS)
    rep = diagnose(_blind(rec), "manipulator2dof")
    assert {e["effect"] for e in rep.effects} == {"input_delay"}
    for e in rep.effects:                 # the total latency: delay + the 1 ms hold lag
        assert abs(e["input_latency"]["total"] - 0.011) < 0.002


def test_low_passed_angles_delay_not_named():
    rec = generate("manipulator2dof", [], seed=501, duration=20.0)
    rec = _butter(rec, ["q1", "q2", "dq1", "dq2"], 20.0)
    rep = diagnose(_blind(rec), "manipulator2dof")
    assert rep.effects == []
    assert "low-passed before logging" in rep.data["verdict"]


# ---------------------------------------------------------------- clipped input column
def test_clipped_levels_told_from_a_quantised_peak():
    t = np.linspace(0.0, 20.0, 10001)
    x = np.sin(t)
    step = 2.0 / 4096                                    # a 12-bit DAC over ±1
    assert not clipped(np.round(x / step) * step).any()  # its top level is no clip
    assert not clipped(x).any()
    hit = clipped(np.clip(x, -0.9, 0.9))
    assert hit.any() and np.array_equal(hit, np.abs(x) >= 0.9)


def test_clipped_torque_rows_not_fitted():
    """A torque column clipped at its 98th percentile hid a torque bias (not confirmed)."""
    inj = InjectedEffect(effect="torque_bias", channel="joint2",
                         params={"tau0": 0.1803464344937657})
    rec = generate("manipulator2dof", [inj], seed=0, duration=20.0)
    cols = dict(rec.columns)
    for c in ("tau1", "tau2"):
        lim = float(np.quantile(np.abs(cols[c]), 0.98))
        cols[c] = np.clip(cols[c], -lim, lim)
    rep = diagnose(Recording(rec.name, cols), "manipulator2dof")
    assert [(e["effect"], e["channel"]) for e in rep.effects] == [("torque_bias", "joint2")]
    assert abs(rep.effects[0]["parameters"]["tau0"] - 0.1803) < 0.2 * 0.1803
    assert any("tau2 is clipped" in w for w in rep.prepared.warnings)


def test_backward_difference_velocity_is_no_delay_on_an_mjcf():
    """The same lag on a MuJoCo model's log (measured: a 0.7-0.9 ms delay named before)."""
    import pytest
    pytest.importorskip("mujoco")
    from pathlib import Path

    from simgap.diagnosis.mjcf_record import record_mjcf
    from simgap.diagnosis.mujoco import diagnose_mjcf

    xml = Path(__file__).resolve().parents[2] / "examples" / "mujoco" / "arm2dof.xml"
    cols = record_mjcf(xml, duration=20.0, seed=0)
    for q in [k for k in cols if k.startswith("q_")]:
        d = np.empty_like(cols[q])
        d[1:] = np.diff(cols[q]) / np.diff(cols["t"])
        d[0] = d[1]
        cols["d" + q] = d
    rep = diagnose_mjcf(xml, Recording("mj", cols))
    assert rep.effects == []


def test_low_passed_angle_keeps_the_velocity_column():
    """A 10 Hz-filtered angle is no remedy for a moving-average dq (Coulomb read as Stribeck).

    Its derivative lags 22.5 ms and smears the friction reversal more than the drive's
    10-sample moving average of dq does; differentiating it named a Stribeck friction
    (vs = 1.3 rad/s) for a Coulomb friction of 0.18 N·m at joint 2.
    """
    inj = InjectedEffect(effect="coulomb_friction", channel="joint2",
                         params={"Fc": 0.1803464344937657})
    rec = generate("manipulator2dof", [inj], seed=0, duration=20.0)
    rec = _butter(rec, ["q1", "q2"], 10.0)
    cols = dict(rec.columns)
    for c in ("dq1", "dq2"):
        cols[c] = cols[c][0] + lfilter(np.full(10, 0.1), [1.0], cols[c] - cols[c][0])
    rep = diagnose(Recording(rec.name, cols), "manipulator2dof")
    assert [(e["effect"], e["channel"]) for e in rep.effects] == [("coulomb_friction",
                                                                   "joint2")]
    assert not any("differentiating q" in w for w in rep.prepared.warnings)
