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

The fit now reads the accelerations projected on instruments made of the logged inputs only
(two-stage least squares, ``BicycleSystem.reference_accelerations``).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from simgap.diagnosis.generate import InjectedEffect
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.proof import run_case
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
    if measured:  # the measured acceleration as the regressor (before)
        sig = {k: v for k, v in sig.items() if k not in ("ay_ref", "dr_ref")}
    ok = p.valid & p.fit_mask[:, 0]
    w = 1.0 / p.noise_rms
    one = np.ones(1)
    cols = [_fit("mass_mismatch").fn(one, (), sig, None, ctx)]
    cols += [_fit("cornering_stiffness").fn(one, (), sig, i, ctx) for i in (0, 1)]
    x = np.column_stack([(c * w)[ok].ravel() for c in cols])
    y = (p.residual * w)[ok].ravel()
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    s2 = np.sum((y - x @ coef) ** 2) / (len(y) - 3)
    return 1.0 + float(coef[0]), float(np.sqrt(s2 * np.linalg.inv(x.T @ x)[0, 0]))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_mass_ratio_of_one_is_not_fitted_below_one_from_noise(seed: int) -> None:
    # the measured acceleration as the regressor: the common scale slides to the noise
    old, _ = _scale_fit(seed, measured=True)
    assert old < 0.5
    # instrumented (accelerations and, since s8, the slip angles too): within 2 % of 1
    # (s7, accelerations only: 2-3 % low, the slip angles' filtered-state noise). The
    # standard error is larger than s7's 0.01-0.02: the speed-scheduled first stage no
    # longer leaves a physical misfit in the mass regressor that broke the symmetry
    ratio, se = _scale_fit(seed, measured=False)
    assert se < 0.03
    assert abs(ratio - 1.0) < 0.02, (ratio, se)


def test_reference_accelerations_ignore_the_derivative_noise() -> None:
    """Noise added to the measured derivatives barely moves the instrumented ones (only its
    projection on a few input-made instruments is left), while the signal stays."""
    form = BicycleSystem()
    p = form.prepare(circles([], 500).recording)
    sig = p.signals
    rows = np.flatnonzero(p.valid)
    rng = np.random.default_rng(0)
    noisy = {**sig, "dvy": sig["dvy"] + rng.normal(0.0, 1.0, p.n),
             "dr": sig["dr"] + rng.normal(0.0, 0.2, p.n)}
    bounds = p.smoother.bounds
    a = form.reference_accelerations(sig, p.inputs, p.smoother.dt, rows, bounds)
    b = form.reference_accelerations(noisy, p.inputs, p.smoother.dt, rows, bounds)
    # what is left is the noise's projection on k instruments: about √(k/N) of it
    assert np.std(b["ay_ref"] - a["ay_ref"]) < 0.1 * 1.0
    assert np.std(b["dr_ref"] - a["dr_ref"]) < 0.1 * 0.2
    ay = sig["dvy"] + sig["vx"] * sig["r"]
    assert np.corrcoef(a["ay_ref"][rows], ay[rows])[0, 1] > 0.99


def test_steering_lag_and_mass_are_both_named() -> None:
    """The proof's pair: the inertia regressor must carry the steering lag's force too (a
    regressor of the nominal tire forces alone left its ΔF·(1/ρ − 1) unmodelled and the mass
    was then reported as not identifiable)."""
    effects = [InjectedEffect(effect="steering_lag", params={"tau": 0.08}),
               InjectedEffect(effect="mass_mismatch", params={"ratio": 1.15})]
    res = run_case(effects, "bicycle", 53, duration=40.0)
    assert res.named and res.param_error <= 0.02, res.found
    assert not res.extra


@pytest.mark.parametrize("seed", [1, 2] if not SLOW else [0, 1, 2, 3, 4])
def test_turn_following_yaw_offset_names_no_stand_in(seed: int) -> None:
    """Seeds 1-2 of the benchmark's out-of-vocabulary row named a rear stiffness ratio and a
    front saturation (with a mass ratio 0.88-0.92 kept as a combination) while the measured
    acceleration was the mass regressor; instrumented, nothing is named."""
    off = float(np.random.default_rng(2000 + seed).uniform(0.08, 0.2))
    rec = circles([], seed, turn_yaw_offset=off).recording
    rep = diagnose(Recording(rec.name, dict(rec.columns)), "bicycle")
    assert rep.effects == [], [(e["effect"], e["channel"]) for e in rep.effects]
    assert rep.significant and rep.data["mismatch"]["segments"]
