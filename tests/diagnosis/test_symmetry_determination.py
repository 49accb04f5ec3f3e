"""Which directions of the single-track vocabulary are symmetries, from its own equations,
and the test that decides whether a ratio is determined with its partners freed.

With the axle forces F = (Cf·αf, Cr·αr) the motion obeys m·ay = Ff + Fr and
Iz·dr/dt = lf·Ff − lr·Fr. Scaling m, Iz, Cf and Cr together by one factor leaves it
unchanged (an exact null direction of the fit); with Iz held, mass and both stiffnesses
scaled change the yaw equation by Iz·dr/dt, so the mass ratio is determined exactly as far
as the data hold yaw acceleration (none on steady turns).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from simgap.diagnosis.identifiability import REL_TOL, determination
from simgap.errors import DiagnosisError
from simgap.models.bicycle import VOCABULARY, BicycleNominal, BicycleParams

VX = 20.0
NAMES = ("mass", "cf", "cr", "iz")


def _spec(name: str):
    return next(s for s in VOCABULARY if s.name == name).fit


def _columns(steady: bool, ratio: float = 1.15, n: int = 4000, seed: int = 0):
    """Fit-form regressors (mass, Cf, Cr, Iz) on exact single-track data of a vehicle whose
    mass is ``ratio`` × nominal; ``steady``: axle forces with no yaw moment (dr/dt = 0)."""
    p = BicycleParams()
    nom = BicycleNominal(p, vx=VX)
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 40.0, n)
    ff = 3000.0 * np.sin(0.3 * t) + 500.0 * rng.normal(size=n)
    fr = ff * p.lf / p.lr if steady else 2500.0 * np.cos(0.7 * t) + 500.0 * rng.normal(size=n)
    ay = (ff + fr) / (ratio * p.m)
    dr = (p.lf * ff - p.lr * fr) / p.Iz
    r = ay / VX
    sig = {"vy": np.zeros(n), "r": r, "vx": np.full(n, VX), "dvy": ay - VX * r, "dr": dr,
           "alpha_f": ff / p.C_af, "alpha_r": fr / p.C_ar}
    ctx = SimpleNamespace(K_inv=nom.K_inv, stiffness=(p.C_af, p.C_ar))
    one = np.ones(1)
    cols = [_spec("mass_mismatch").fn(one, (), sig, None, ctx),
            _spec("cornering_stiffness").fn(one, (), sig, 0, ctx),
            _spec("cornering_stiffness").fn(one, (), sig, 1, ctx),
            _spec("yaw_inertia_mismatch").fn(one, (), sig, None, ctx)]
    return np.column_stack([c.ravel() for c in cols]), sig, ctx


def test_mass_inertia_and_both_tire_laws_scaled_together_are_an_exact_symmetry():
    j, _, _ = _columns(steady=False)
    ratio = 1.15
    # the direction (ratio, 1, 1, 1) in the fit's linear ratio coordinates moves nothing
    assert np.linalg.norm(j @ np.array([ratio, 1.0, 1.0, 1.0])) < 1e-9 * np.linalg.norm(j)
    det = determination(j, NAMES, ["mass"], [ratio - 1.0, 0.0, 0.0, 0.0])
    assert det.retained[0] < REL_TOL**2
    assert not det.determined(3.0)


def test_with_the_yaw_inertia_held_the_mass_ratio_is_determined_by_yaw_acceleration():
    j, sig, _ = _columns(steady=False)
    det = determination(j[:, :3], NAMES[:3], ["mass"], [0.15, 0.0, 0.0], noise_std=1.0)
    assert det.retained[0] > 0.01
    # what freeing the partners leaves of the mass column is what they leave of the yaw
    # inertia regressor (Iz·dr/dt), scaled by −1/ratio
    def left(col):
        return col - j[:, 1:3] @ np.linalg.lstsq(j[:, 1:3], col, rcond=None)[0]
    np.testing.assert_allclose(left(j[:, 0]), -left(j[:, 3]) / 1.15,
                               atol=1e-9 * np.abs(left(j[:, 0])).max())
    assert np.std(sig["dr"]) > 0


def test_on_steady_turns_the_mass_ratio_is_not_determined():
    j, sig, _ = _columns(steady=True)
    assert np.abs(sig["dr"]).max() < 1e-9
    det = determination(j[:, :3], NAMES[:3], ["mass"], [0.15, 0.0, 0.0], noise_std=1.0)
    assert det.retained[0] < REL_TOL**2
    assert not det.determined(3.0)


def test_standard_error_is_the_joint_information_and_ignores_units():
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=500), rng.normal(size=500)
    c = a + b + 0.1 * rng.normal(size=500)
    j = np.column_stack([c, a, b])
    vals = [0.2, 0.05, -0.03]
    det = determination(j, ["x", "y", "z"], ["x"], vals, noise_std=0.5)
    cov = 0.25 * np.linalg.inv(j.T @ j)
    np.testing.assert_allclose(det.standard_error[0], np.sqrt(cov[0, 0]), rtol=1e-9)
    # 1 − R² of x on (y, z)
    fit = j[:, 1:] @ np.linalg.lstsq(j[:, 1:], c, rcond=None)[0]
    np.testing.assert_allclose(det.retained[0], np.sum((c - fit) ** 2) / np.sum(c**2),
                               rtol=1e-9)
    # the same data in other units: the same verdict and z
    other = determination(j * [1000.0, 1.0, 3.6], ["x", "y", "z"], ["x"],
                          [vals[0] / 1000.0, vals[1], vals[2] / 3.6], noise_std=0.5)
    np.testing.assert_allclose(other.z, det.z, rtol=1e-9)
    # only the tested value enters z: the partners' values do not
    moved = determination(j, ["x", "y", "z"], ["x"], [0.2, -0.4, 0.7], noise_std=0.5)
    np.testing.assert_allclose(moved.z, det.z)


def test_determination_rejects_bad_input():
    j = np.ones((10, 2))
    with pytest.raises(DiagnosisError, match="unknown"):
        determination(j, ["a", "b"], ["c"], [0.0, 0.0])
    with pytest.raises(DiagnosisError, match="do not match"):
        determination(j, ["a", "b"], ["a"], [0.0])
    with pytest.raises(DiagnosisError, match="non-finite"):
        determination(np.full((3, 2), np.nan), ["a", "b"], ["a"], [0.0, 0.0])
