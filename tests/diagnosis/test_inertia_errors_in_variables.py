"""Issue 13 (vehicle): inertia ratios must not be fitted from derivative noise.

The single-track residual is Delta = K⁻¹(dx/dt − f(x, u)) with dx/dt differentiated from the
recorded vy and r. A mass ratio written as a multiplier of the *measured* lateral
acceleration (m·ay with ay = dvy/dt + vx·r) has a regressor that carries the residual's own
derivative noise (errors in variables). Alone, that bias is small (ratio 0.998 on clean
circles), but along the near-symmetry of the steady turns (mass and both tire laws scaled
together) the regressors' physical parts cancel and only the noise is left: the joint fit
shrinks the whole equation, to ratios of 0.15-0.28 on clean steady circles. That gain is
real held out (the noise *is* smaller), so it let a mass ratio with a rear stiffness ratio and
a front saturation stand in for a turn-following yaw offset outside the vocabulary.

The vocabulary fits the inertias in the force form of their equation instead
(``simgap.models.bicycle._fit_inertia``): an inertia ρ divides the forces, the coordinate is
1/ρ − 1 and the regressor is the nominal tire forces' acceleration, read from the filtered
states and inputs only.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.scenarios import circles
from simgap.diagnosis.systems import BicycleSystem
from simgap.models.bicycle import VOCABULARY
from simgap.recordings import Recording

SLOW = os.environ.get("SIMGAP_SLOW") == "1"


def _fit(name: str):
    return next(s for s in VOCABULARY if s.name == name).fit


def _scale_fit(seed: int, measured: bool) -> tuple[float, float]:
    """Mass ratio and its standard error, fitted jointly with both axles' stiffness ratios
    (whitened least squares on the valid rows) on clean steady circles."""
    form = BicycleSystem()
    p = form.prepare(circles([], 500 + seed).recording)
    ctx = form.context(p)
    sig = {**p.signals, "idx": np.arange(p.n)}
    ok = p.valid & p.fit_mask[:, 0]
    w = 1.0 / p.noise_rms
    one = np.ones(1)
    if measured:  # the equation-error form: −(ratio − 1)·m·ay, ay measured
        mass = -np.outer(sig["dvy"] + sig["vx"] * sig["r"], form.K_inv[:, 0])
    else:
        mass = _fit("mass_mismatch").fn(one, (), sig, None, ctx)
    cols = [mass] + [_fit("cornering_stiffness").fn(one, (), sig, i, ctx) for i in (0, 1)]
    x = np.column_stack([(c * w)[ok].ravel() for c in cols])
    y = (p.residual * w)[ok].ravel()
    theta, *_ = np.linalg.lstsq(x, y, rcond=None)
    s2 = np.sum((y - x @ theta) ** 2) / (len(y) - 3)
    se = float(np.sqrt(s2 * np.linalg.inv(x.T @ x)[0, 0]))
    if measured:
        return 1.0 + float(theta[0]), se
    ratio = 1.0 / (1.0 + float(theta[0]))
    return ratio, se * ratio**2


@pytest.mark.parametrize("seed", [0, 1])
def test_a_mass_ratio_of_one_is_not_fitted_below_one_from_noise(seed: int) -> None:
    # the equation-error form with the measured acceleration: the scale slides to noise
    old, _ = _scale_fit(seed, measured=True)
    assert old < 0.5
    ratio, se = _scale_fit(seed, measured=False)
    assert 0.0 < se < 0.05
    assert abs(ratio - 1.0) < 3.0 * se, (ratio, se)


def test_the_inertia_regressors_read_no_derivative() -> None:
    """Changing the measured derivatives leaves the inertia terms' contribution unchanged."""
    form = BicycleSystem()
    p = form.prepare(circles([], 500).recording)
    ctx = form.context(p)
    sig = {**p.signals, "idx": np.arange(p.n)}
    noisy = {**sig, "dvy": sig["dvy"] + 5.0, "dr": sig["dr"] - 3.0}
    for name in ("mass_mismatch", "yaw_inertia_mismatch"):
        spec = _fit(name)
        assert not spec.uses_derivatives
        np.testing.assert_array_equal(spec.fn(np.array([0.1]), (), sig, None, ctx),
                                      spec.fn(np.array([0.1]), (), noisy, None, ctx))


def test_an_inertia_ratio_alone_is_exact_in_the_force_form() -> None:
    """ρ·m·ay = F: the residual of a heavier vehicle is (1/ρ − 1)·K⁻¹·(F/m, 0) exactly."""
    form = BicycleSystem()
    p = form.prepare(circles([], 500).recording)
    ctx = form.context(p)
    sig = {**p.signals, "idx": np.arange(p.n)}
    rho = 1.2
    spec = _fit("mass_mismatch")
    (theta,), _ = spec.from_report({"ratio": rho}, None)
    assert theta == pytest.approx(1.0 / rho - 1.0)
    forces = np.column_stack([form.stiffness[0] * sig["alpha_f"],
                              form.stiffness[1] * sig["alpha_r"]])
    ay = forces.sum(axis=1) / form.params.m
    want = (1.0 / rho - 1.0) * np.outer(ay, form.K_inv[:, 0])
    np.testing.assert_allclose(spec.fn(np.array([theta]), (), sig, None, ctx), want,
                               rtol=1e-12, atol=1e-9)
    vals, errs, _ = spec.to_report(None, np.array([theta]), (), np.array([[1e-4]]), None)
    assert vals["ratio"] == pytest.approx(rho)
    assert errs["ratio"] == pytest.approx(1e-2 * rho**2)


@pytest.mark.parametrize("seed", [1, 2] if not SLOW else [0, 1, 2, 3, 4])
def test_turn_following_yaw_offset_names_no_stand_in(seed: int) -> None:
    """Seeds 1-2 of the benchmark's out-of-vocabulary row named a rear stiffness ratio and a
    front saturation (with a mass ratio 0.88-0.92 kept as a combination) while the measured
    acceleration was the mass regressor; with the force form nothing is named."""
    off = float(np.random.default_rng(2000 + seed).uniform(0.08, 0.2))
    rec = circles([], seed, turn_yaw_offset=off).recording
    rep = diagnose(Recording(rec.name, dict(rec.columns)), "bicycle")
    assert rep.effects == [], [(e["effect"], e["channel"]) for e in rep.effects]
    assert rep.significant and rep.data["mismatch"]["segments"]
