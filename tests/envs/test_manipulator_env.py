"""ManipulatorFrictionEnv: ground truth in info, reset, termination."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.envs import ManipulatorFrictionEnv, QuinticReference
from simgap.models.friction import FrictionParams
from simgap.models.manipulator import JointDisturbance, ManipulatorParams


def test_residual_true_is_minus_thesis_friction():
    env = ManipulatorFrictionEnv()
    obs, info = env.reset(seed=0)
    rng = np.random.default_rng(0)
    seen = []
    for _ in range(200):
        a = rng.uniform(-5, 5, size=2)
        s = env.plant_state
        obs, _, _, _, info = env.step(a)
        tau = 0.1 * np.tanh(s[2:] / 6.67e-4) + 0.5 * s[2:]  # eq. 4.7 at the pre-step state
        np.testing.assert_allclose(info["residual_true"][2:], -tau, atol=1e-10)
        np.testing.assert_allclose(info["residual_true"][:2], 0.0, atol=1e-12)
        np.testing.assert_allclose(info["physical_residual_true"], tau, atol=1e-12)
        np.testing.assert_allclose(
            env.nominal_model.physical_residual(env.nominal_model.state(obs),
                                                info["residual_true"]), tau, atol=1e-10)
        seen.append(np.abs(tau).max())
    assert max(seen) > 0.1  # friction really acted


def test_no_friction_gives_zero_residual_and_disturbance_shows_up():
    env = ManipulatorFrictionEnv(friction="none")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([2.0, -1.0]))
    np.testing.assert_allclose(info["residual_true"], 0.0, atol=1e-12)
    dist = JointDisturbance(tau0=(0.3, -0.2))
    env = ManipulatorFrictionEnv(friction=None, disturbance=dist)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(2))
    np.testing.assert_allclose(info["physical_residual_true"], [0.3, -0.2], atol=1e-12)


def test_friction_params_and_true_params_accepted():
    env = ManipulatorFrictionEnv(friction=FrictionParams(fc=0.2, b=0.0),
                                 true_params=ManipulatorParams(payload=0.3))
    env.reset(seed=0)
    assert env.nominal_model.params == ManipulatorParams()
    _, _, _, _, info = env.step(np.zeros(2))
    assert np.all(np.isfinite(info["residual_true"]))


def test_reset_starts_on_reference_and_info_keys():
    ref = QuinticReference(period=1.5)
    env = ManipulatorFrictionEnv(reference=ref)
    obs, info = env.reset(seed=3)
    np.testing.assert_allclose(obs, [np.pi / 4, np.pi / 2, 0.0, 0.0])
    assert set(info) == {"t", "reference", "residual_true", "physical_residual_true",
                         "applied_action"}
    for _ in range(10):
        obs, rew, term, trunc, info = env.step(np.zeros(2))
    assert info["t"] == pytest.approx(10 * 0.002) and env.t == info["t"]
    np.testing.assert_allclose(info["reference"], ref.sample(info["t"]))
    assert rew == pytest.approx(-np.sum((obs[:2] - info["reference"][:2]) ** 2))
    assert info["reference"].shape == (6,) and info["residual_true"].shape == (4,)


def test_init_noise_and_state_option():
    env = ManipulatorFrictionEnv(init_noise=0.05)
    obs, _ = env.reset(seed=1)
    d = obs[:2] - np.array([np.pi / 4, np.pi / 2])
    assert 0 < np.abs(d).max() <= 0.05
    obs, _ = env.reset(options={"state": [0.1, 0.2, 0.3, 0.4]})
    np.testing.assert_array_equal(obs, [0.1, 0.2, 0.3, 0.4])
    with pytest.raises(ValueError, match="state"):
        env.reset(options={"state": [0.1, np.nan, 0.0, 0.0]})


def test_terminates_beyond_max_speed():
    env = ManipulatorFrictionEnv(friction=None, max_speed=5.0)
    env.reset(seed=0)
    for _ in range(2000):
        obs, _, term, _, _ = env.step(np.array([50.0, -50.0]))
        if term:
            break
    assert term and np.abs(obs[2:]).max() > 5.0


def test_plain_callable_reference():
    base = QuinticReference(period=1.0)
    env = ManipulatorFrictionEnv(reference=lambda t: base(t))
    obs, info = env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(2))
    np.testing.assert_allclose(info["reference"], base.sample(0.002))
