"""BicycleTireEnv: ground truth in info, options, termination."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.envs import BicycleTireEnv
from simgap.models.bicycle import BicycleParams, slip_angles
from simgap.models.tires import magic_formula


def test_axle_force_residual_is_magic_formula_minus_linear():
    env = BicycleTireEnv()
    p = env.nominal_params
    fzf, fzr = p.axle_loads()
    obs, _ = env.reset(seed=0)
    u = np.array([0.06, -0.01])
    for _ in range(150):
        x = obs
        obs, _, _, _, info = env.step(u)
        af, ar = slip_angles(x[0], x[1], u[0], u[1], env.vx, p.lf, p.lr)
        expected = [magic_formula(af, p.C_af, fzf, 1.0, 1.3, -0.5) - p.C_af * af,
                    magic_formula(ar, p.C_ar, fzr, 1.0, 1.3, -0.5) - p.C_ar * ar]
        np.testing.assert_allclose(info["axle_force_residual_true"], expected, rtol=1e-9,
                                   atol=1e-6)
        np.testing.assert_allclose(env.nominal_model.K @ info["axle_force_residual_true"],
                                   info["residual_true"], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(info["physical_residual_true"],
                                      info["axle_force_residual_true"])
    assert np.abs(info["axle_force_residual_true"]).min() > 300.0  # N, nonlinear range


def test_linear_tire_truth_has_zero_residual():
    env = BicycleTireEnv(tire="linear")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.1, 0.05]))
    np.testing.assert_allclose(info["residual_true"], 0.0, atol=1e-12)


def test_mu_overrides_true_params_and_lowers_grip():
    env = BicycleTireEnv(mu=0.5, true_params=BicycleParams(mu=0.9))
    assert env.true_params.mu == 0.5
    assert BicycleTireEnv(true_params=BicycleParams(mu=0.9)).true_params.mu == 0.9
    r = {}
    for mu in (1.0, 0.5):
        e = BicycleTireEnv(mu=mu)
        e.reset(seed=0)
        for _ in range(300):
            obs, *_ = e.step(np.array([0.06, 0.0]))
        r[mu] = obs[1]
    assert r[0.5] < r[1.0]


def test_nominal_vehicle_may_differ_from_truth():
    nom = BicycleParams(C_af=80000.0)
    env = BicycleTireEnv(tire="linear", nominal_params=nom)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.05, 0.0]))
    # truth is linear with C_af = 1e5, nominal 8e4: Delta_f = 2e4 N/rad * alpha_f at u
    np.testing.assert_allclose(info["axle_force_residual_true"], [0.05 * 20000.0, 0.0],
                               rtol=1e-9, atol=1e-6)


def test_relaxation_and_lag_options_run():
    env = BicycleTireEnv(relaxation_length=0.5, steering_lag=0.05)
    env.reset(seed=0)
    obs, _, _, _, info = env.step(np.array([0.05, 0.0]))
    env2 = BicycleTireEnv()
    env2.reset(seed=0)
    obs2, *_ = env2.step(np.array([0.05, 0.0]))
    assert abs(obs[1]) < abs(obs2[1])  # slower build-up of force
    assert np.all(np.isfinite(info["residual_true"]))


def test_reset_state_option_info_and_reward():
    env = BicycleTireEnv()
    obs, info = env.reset(options={"state": [0.2, 0.1]})
    np.testing.assert_array_equal(obs, [0.2, 0.1])
    assert set(info) == {"t", "r_ref", "residual_true", "axle_force_residual_true",
                         "physical_residual_true", "applied_action"}
    obs, rew, term, trunc, info = env.step(np.zeros(2))
    assert info["t"] == pytest.approx(0.01)
    assert rew == pytest.approx(-(obs[1] - info["r_ref"]) ** 2)
    assert info["r_ref"] == pytest.approx(env.reference(0.01))


def test_terminates_on_spin_out():
    env = BicycleTireEnv(mu=0.3)
    env.reset(seed=0)
    for _ in range(3000):
        obs, _, term, _, _ = env.step(np.array([0.5, -0.5]))
        if term:
            break
    assert term
    assert abs(np.arctan2(obs[0], env.vx)) > env.max_sideslip
