"""Physics of the single-track vehicle and the Magic Formula tire (spec/models.md)."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.models import bicycle as bic
from simgap.models.tires import MagicFormulaTire, magic_formula

P = bic.BicycleParams()
FZF, FZR = P.axle_loads()


@pytest.mark.parametrize(("c_alpha", "fz", "mu"), [(P.C_af, FZF, 1.0), (P.C_ar, FZR, 0.6),
                                                   (P.C_af, FZF, 0.3)])
def test_magic_formula_slope_symmetry_peak(c_alpha, fz, mu):
    c, e = 1.3, -0.5
    d = mu * fz
    b = c_alpha / (c * d)
    assert b * c * d == pytest.approx(c_alpha, rel=1e-12)
    h = 1e-7
    slope = (magic_formula(h, c_alpha, fz, mu, c, e) - magic_formula(-h, c_alpha, fz, mu, c, e)) \
        / (2 * h)
    assert slope == pytest.approx(c_alpha, rel=1e-6)
    alpha = np.linspace(-0.6, 0.6, 20001)
    f = magic_formula(alpha, c_alpha, fz, mu, c, e)
    np.testing.assert_allclose(f, -f[::-1], atol=1e-9 * d)
    assert np.abs(f).max() == pytest.approx(mu * fz, rel=1e-4)
    # saturation: beyond the peak the force falls below the linear tire by a lot
    assert np.abs(f).max() < 0.5 * c_alpha * 0.6


def test_magic_formula_tire_dataclass_validation():
    with pytest.raises(ValueError, match="E"):
        MagicFormulaTire(E=1.5)
    t = MagicFormulaTire()
    assert t.force(np.array([0.0]), 1e5, 8000.0, 1.0)[0] == 0.0


def _steady_state_yaw_gain(vx: float) -> float:
    theta = bic.plant_array(P, vx, tire=None)
    s = np.zeros(6)
    delta = 0.01
    u = np.array([delta, 0.0])
    for _ in range(3000):  # 30 s: the yaw mode settles in well under 2 s
        s = bic.plant_step(s, u, theta, 0.01, 4)
    d = bic.plant_derivative(s, u, theta)
    assert np.abs(d[:2]).max() < 1e-9  # really at steady state
    return s[1] / delta


@pytest.mark.parametrize("vx", [10.0, 20.0, 35.0])
def test_linear_steady_state_yaw_gain(vx):
    expected = vx / (P.wheelbase + P.understeer_gradient() * vx**2)
    assert _steady_state_yaw_gain(vx) == pytest.approx(expected, rel=0.01)


def test_nominal_matrices_and_vectorised_derivative():
    a, b, k = bic.system_matrices(P, 20.0)
    rng = np.random.default_rng(0)
    x = rng.normal(size=(10, 2)) * [0.5, 0.2]
    u = rng.normal(size=(10, 2)) * 0.05
    f = bic.state_derivative(x, u, P, np.full(10, 20.0))
    np.testing.assert_allclose(f, x @ a.T + u @ b.T, rtol=1e-12, atol=1e-12)
    nominal = bic.BicycleNominal(P, vx=20.0)
    np.testing.assert_allclose(nominal.f(x[0], u[0]), f[0], rtol=1e-12)
    np.testing.assert_allclose(nominal.physical_residual(x[0], k @ [100.0, -50.0]),
                               [100.0, -50.0], atol=1e-9)


def test_linear_plant_has_zero_residual():
    theta = bic.plant_array(P, 20.0, tire=None)
    rng = np.random.default_rng(1)
    for _ in range(50):
        s = np.concatenate([rng.normal(size=2) * [0.5, 0.3], np.zeros(4)])
        u = rng.normal(size=2) * 0.05
        np.testing.assert_allclose(bic.true_residual(s, u, theta), 0.0, atol=1e-12)


def test_magic_formula_residual_is_k_times_force_deviation():
    theta = bic.plant_array(P, 20.0, tire=MagicFormulaTire())
    _, _, k = bic.system_matrices(P, 20.0)
    s = np.array([-0.5, 0.3, 0, 0, 0, 0])
    u = np.array([0.06, -0.01])
    af, ar = bic.slip_angles(s[0], s[1], u[0], u[1], 20.0, P.lf, P.lr)
    delta = np.array([magic_formula(af, P.C_af, FZF, 1.0, 1.3, -0.5) - P.C_af * af,
                      magic_formula(ar, P.C_ar, FZR, 1.0, 1.3, -0.5) - P.C_ar * ar])
    np.testing.assert_allclose(bic.true_residual(s, u, theta), k @ delta, rtol=1e-12)
    assert np.abs(delta).min() > 100.0  # N: well into the nonlinear range
    # against a different nominal vehicle the residual changes
    other = bic.BicycleParams(C_af=90000.0)
    g2 = bic.true_residual_vs(s, u, theta, np.concatenate([other.array, [20.0]]))
    assert not np.allclose(g2, k @ delta)


def test_check_vx():
    with pytest.raises(ValueError, match="vx"):
        bic.check_vx(1.0)
    with pytest.raises(ValueError, match="vx"):
        bic.check_vx(float("nan"))
