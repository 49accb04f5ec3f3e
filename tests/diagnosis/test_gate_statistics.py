"""The statistics of the gates on realistic clean logs (issue 13): a mismatch is a held-out
dependence on the operating point, not a residual above a white floor; the logged input's
lag is decided by the equation; jittered stamps around a fixed rate are not interpolated.

Each case failed before (clean logs flagged as a mismatch, or an effect named on a clean
log) and has a counterpart that must keep the old behaviour, so that the decisions can fail
both ways."""

import numpy as np
import pytest

from simgap.diagnosis import artefacts as art
from simgap.diagnosis.generate import InjectedEffect, generate_bicycle, generate_manipulator
from simgap.diagnosis.locate import SIGNIFICANCE
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.residual import segmented_grid
from simgap.diagnosis.significance import structure_test
from simgap.diagnosis.systems import MechanicalSystem
from simgap.models.manipulator import ManipulatorNominal
from simgap.recordings import Recording

PAIRS = {"dq1": "q1", "dq2": "q2"}


def _prepare(rec):
    return MechanicalSystem(ManipulatorNominal()).prepare(rec)


def _blind(rec):
    return Recording(rec.name, dict(rec.columns))


# ---------------------------------------------------------------- the structure test
def _ar1(n, phi, std, rng):
    from scipy.signal import lfilter

    w = rng.normal(0.0, std * np.sqrt(1 - phi**2), n)
    w[0] = rng.normal(0.0, std)
    return lfilter([1.0], [1.0, -phi], w)


def test_structure_test_ignores_coloured_noise_and_finds_a_function_of_the_state():
    rng = np.random.default_rng(0)
    n = 30000
    t = np.arange(n) * 0.01
    x = np.sin(0.7 * t) + 0.3 * np.sin(2.3 * t)          # an operating-point variable
    noise = _ar1(n, 0.95, 1.0, rng)                       # strongly correlated, large
    fit, test = np.arange(0, 21000, 3), np.arange(21000, n, 3)
    false = 0
    for s in range(20):
        e = _ar1(n, 0.95, 1.0, np.random.default_rng(100 + s))
        false += structure_test(e, {"x": x}, fit, test).significant(0.01)
    assert false <= 1                                     # holds its level (N/τ samples)
    g = structure_test(noise + 0.5 * np.tanh(3 * x), {"x": x}, fit, test)
    assert g.significant(0.01) and g.variable == "x" and g.share_removed > 0


def test_structure_test_says_when_it_cannot_test():
    g = structure_test(np.zeros(50), {"x": np.zeros(50)}, np.arange(40), np.arange(40, 50))
    assert not g.testable and not g.significant(0.01) and g.reason


# ---------------------------------------------------------------- the mismatch gate
@pytest.mark.parametrize("model", ["manipulator2dof", "bicycle"])
def test_clean_log_with_coloured_noise_is_not_a_mismatch(model):
    """2 % AR(1) noise (50 ms) lifts the residual above the white floor (7x for the arm,
    1.4x for the car): not physics."""
    rec = (generate_manipulator(seed=500, duration=20.0) if model == "manipulator2dof"
           else generate_bicycle(seed=500, duration=40.0))
    rec = art.ARTEFACTS["coloured_noise"].apply(rec, PAIRS if model == "manipulator2dof"
                                                else {}, np.random.default_rng(9500))
    rep = diagnose(_blind(rec), model)
    ch = rep.data["mismatch"]["channels"]
    assert any(c["residual_rms"] > SIGNIFICANCE * c["noise_rms"] for c in ch)  # above floor
    assert not rep.significant and not rep.effects, ch
    assert all(c["structure"]["testable"] for c in ch)


def test_real_effect_under_coloured_noise_is_still_a_mismatch():
    """The same noise with a Coulomb friction: named, and its channel significant."""
    eff = InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.3})
    rec = art.ARTEFACTS["coloured_noise"].apply(
        generate_manipulator([eff], seed=500, duration=20.0), PAIRS, np.random.default_rng(9500))
    rep = diagnose(_blind(rec), "manipulator2dof")
    assert rep.significant
    ch = {c["channel"]: c for c in rep.data["mismatch"]["channels"]}
    assert ch["joint2"]["significant"]
    assert ch["joint2"]["structure"]["variable"] == "dq2"


# ---------------------------------------------------------------- the input's lag
def test_point_sampled_input_of_a_faster_controller_gets_its_lag():
    """A 500 Hz loop logged at 100 Hz: its torque lags by half a controller period (1 ms),
    not half a log period (5 ms, ZOH). Read as held, the clean log was flagged (2x the
    floor) and seed 502 named quadratic drag."""
    for seed in (500, 502):
        rec = art.downsample(generate_manipulator(seed=seed, duration=20.0), 100.0)
        res = _prepare(rec)
        assert 0.05 < res.plan.hold < 0.2, res.plan.hold       # ≈ 0.1 log samples
        assert any("log samples after they are logged" in w for w in res.warnings)
        rep = diagnose(_blind(rec), "manipulator2dof")
        assert not rep.significant and not rep.effects, rep.effects


def test_command_held_at_the_log_rate_keeps_zoh():
    """A 100 Hz controller logged at 100 Hz holds its commands: ZOH stays (bit for bit)."""
    res = _prepare(generate_manipulator(seed=500, duration=20.0, rate=100.0))
    assert res.plan.hold == 0.5
    assert not any("log samples after" in w for w in res.warnings)


def test_an_unmodelled_effect_does_not_tilt_the_lag():
    """A 500 Hz log (ZOH at the log rate) with a quadratic drag: fitted on the raw
    residual, the lag went to 0.34 sample (p = 1e-8) and the drag was no longer named."""
    from simgap.diagnosis.proof import draw, run_case

    inj = draw("quadratic_drag", np.random.default_rng(1004))
    res = _prepare(generate_manipulator([inj], seed=4, duration=20.0))
    assert res.plan.hold == 0.5
    case = run_case([inj], "manipulator2dof", 4, duration=20.0)
    assert case.named and case.param_error < 0.2, case.found


def test_explicit_input_hold_is_obeyed():
    from simgap.diagnosis.systems import MANIPULATOR_COLUMNS

    rec = art.downsample(generate_manipulator(seed=500, duration=10.0), 100.0)
    cols = type(MANIPULATOR_COLUMNS)(q=("q1", "q2"), dq=("dq1", "dq2"), u=("tau1", "tau2"),
                                     input_hold="zoh")
    res = MechanicalSystem(ManipulatorNominal(), columns=cols).prepare(rec)
    assert res.plan.hold == 0.5


# ---------------------------------------------------------------- jittered stamps
def test_jittered_stamps_are_put_back_on_their_rate():
    clean = generate_manipulator(seed=500, duration=10.0)
    rec = art.jitter(clean, 0.2 * 0.002, np.random.default_rng(0))
    grid = segmented_grid(rec.t, {k: rec[k] for k in ("q1", "dq1", "tau1")})
    assert grid.retimed and grid.resampled
    assert np.array_equal(grid.columns["q1"], rec["q1"])      # values kept, not interpolated
    assert np.allclose(grid.t, clean.t, atol=0.05 * 0.002)     # the true instants
    res = _prepare(rec)
    assert abs(res.column_noise["q1"] / 1e-4 - 1.0) < 0.2     # the sensor's, not timing error
    assert any("jitter around a fixed rate" in w for w in res.warnings)


def test_irregular_sampling_with_true_stamps_is_interpolated():
    """Samples really taken at irregular instants (20 % dropped): the stamps are the timing."""
    clean = generate_manipulator(seed=500, duration=10.0)
    keep = np.sort(np.random.default_rng(0).choice(clean.n, size=int(0.8 * clean.n),
                                                   replace=False))
    grid = segmented_grid(clean.t[keep], {"q1": clean["q1"][keep]})
    assert grid.resampled and not grid.retimed


def test_true_irregular_instants_near_their_slots_are_interpolated():
    """Sampled at t_k + δ_k with correct stamps (|δ| < 0.45 dt): the stamps predict better."""
    clean = generate_manipulator(seed=500, duration=10.0, noise_q=1e-6, noise_dq=1e-5)
    dt = 0.002
    rng = np.random.default_rng(1)
    t_true = clean.t + np.clip(rng.normal(0.0, 0.2 * dt, clean.n), -0.45 * dt, 0.45 * dt)
    cols = {k: np.interp(t_true, clean.t, clean[k]) for k in ("q1", "q2", "dq1", "dq2")}
    grid = segmented_grid(t_true, cols)
    assert grid.resampled and not grid.retimed


def test_structure_entry_is_in_the_report():
    rep = diagnose(generate_manipulator(seed=501, duration=10.0), "manipulator2dof")
    for c in rep.data["mismatch"]["channels"]:
        s = c["structure"]
        assert set(s) >= {"test", "p_value", "level", "variable", "share_removed",
                          "effective_samples", "testable"}

