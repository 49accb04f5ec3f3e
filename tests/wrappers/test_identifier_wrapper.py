"""IdentifierWrapper / ResidualObservation on a user-defined env and on the simgap envs."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import simgap  # noqa: F401 - registers the envs
from simgap.identifiers import IdentifierError, make_identifier, preset
from simgap.wrappers import IdentifierWrapper, ResidualObservation
from tests.wrappers.toy import DampedPendulumEnv

KEYS = ("residual_estimate", "state_estimate", "estimation_error", "identifier_frozen",
        "physical_residual_estimate")


def _rollout(env, steps, seed=0):
    obs, info = env.reset(seed=seed)
    env.action_space.seed(seed)
    infos = []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        infos.append(info)
        if term or trunc:
            obs, _ = env.reset()
    return infos


def test_toy_pendulum_learns_damping_and_info_is_consistent():
    """A user env: the wrapper's ĝ is exactly the identifier's, and the learned residual
    tracks the left-out damping better than the network-off observer does."""
    env = IdentifierWrapper(DampedPendulumEnv(damping=1.0, max_steps=10_000), "instantaneous",
                            config=preset("manipulator", "instantaneous"))
    model = env.unwrapped.nominal_model
    shadow = make_identifier("instantaneous", 2, 1, model.dt)
    obs, info = env.reset(seed=1)
    np.testing.assert_array_equal(info["state_estimate"], obs)
    shadow.reset_observer(obs)
    err = []
    for k in range(3000):
        a = np.array([2.0 * np.sin(3.0 * k * model.dt)], dtype=np.float32)  # near resonance
        x = obs
        obs, r, term, trunc, info = env.step(a)
        assert set(KEYS) <= set(info)
        g = shadow.step(x, a.astype(np.float64), model.f(x, a.astype(np.float64)), obs)
        np.testing.assert_array_equal(info["residual_estimate"], g)
        np.testing.assert_array_equal(info["physical_residual_estimate"], g)  # default
        np.testing.assert_array_equal(info["estimation_error"], obs - info["state_estimate"])
        assert info["identifier_frozen"] is False
        err.append((info["residual_estimate"][1], info["residual_true"][1]))
    g_hat, g_true = np.array(err[-500:]).T  # last 5 s
    # network off leaves an error of RMS(g_true) ≈ 1.4 rad/s²; measured after 30 s: ≈ 0.13
    assert np.sqrt(np.mean((g_hat - g_true) ** 2)) < 0.5 * np.sqrt(np.mean(g_true ** 2))


def test_freeze_and_learning_across_resets():
    env = IdentifierWrapper(DampedPendulumEnv(max_steps=50), "integral")
    _rollout(env, 120)  # crosses two ordinary resets
    w_learned = env.identifier.W
    fresh = make_identifier("integral", 2, 1, 0.01, config=preset("auto", "integral", dt=0.01))
    assert not np.array_equal(w_learned, fresh.W)
    env.reset()  # ordinary reset keeps the weights
    np.testing.assert_array_equal(env.identifier.W, w_learned)
    env.freeze()
    infos = [env.step(env.action_space.sample())[4] for _ in range(20)]
    assert all(i["identifier_frozen"] for i in infos)
    np.testing.assert_array_equal(env.identifier.W, w_learned)
    env.unfreeze()
    env.reset(seed=3)  # seeded: back to the reset point (construction)
    np.testing.assert_array_equal(env.identifier.W, fresh.W)


def test_seeded_resets_reproduce_runs():
    env = IdentifierWrapper(DampedPendulumEnv(max_steps=40), "minibatch",
                            config=preset("manipulator", "minibatch").replace(update_period=3,
                                                                               batch_size=8))
    a = [i["residual_estimate"] for i in _rollout(env, 100, seed=4)]
    b = [i["residual_estimate"] for i in _rollout(env, 100, seed=4)]
    np.testing.assert_array_equal(np.array(a), np.array(b))


def test_wrapper_rejects_envs_without_nominal_model():
    with pytest.raises(IdentifierError, match="nominal_model"):
        IdentifierWrapper(gym.make("CartPole-v1"))
    with pytest.raises(IdentifierError, match="n_states, n_inputs"):
        IdentifierWrapper(DampedPendulumEnv(), make_identifier("integral", 4, 2, 0.01))


@pytest.mark.parametrize("env_id", ["simgap/ManipulatorFriction-v0", "simgap/BicycleTire-v0"])
def test_simgap_envs_wrapped_pass_gymnasium_check_env(env_id):
    """The wrapper passes and adds no warning of its own to those of the bare env."""
    env = IdentifierWrapper(gym.make(env_id), "integral")
    with warnings.catch_warnings(record=True) as bare:
        warnings.simplefilter("always")
        check_env(gym.make(env_id).unwrapped, skip_render_check=True)
    with warnings.catch_warnings(record=True) as wrapped:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    extra = {str(w.message) for w in wrapped} - {str(w.message) for w in bare}
    assert {m for m in extra if "wrapper applied to it" not in m} == set()
    obs_env = ResidualObservation(gym.make(env_id), include_error=True)
    check_env(obs_env, skip_render_check=True)


@pytest.mark.parametrize("env_id", ["simgap/ManipulatorFriction-v0", "simgap/BicycleTire-v0"])
def test_simgap_envs_wrapped_pass_sb3_check_env(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(IdentifierWrapper(gym.make(env_id), "minibatch"), warn=True)
    sb3_checker.check_env(ResidualObservation(gym.make(env_id)), warn=True)


def test_bicycle_axle_force_estimates_and_manipulator_torques():
    env = IdentifierWrapper(gym.make("simgap/BicycleTire-v0"), "integral")
    model = env.unwrapped.nominal_model
    assert env.identifier.config == preset("auto", "integral", dt=model.dt)  # the default
    env.reset(seed=0)
    info = env.step(env.action_space.sample())[4]
    np.testing.assert_allclose(info["axle_force_residual_estimate"],
                               model.K_inv @ info["residual_estimate"], rtol=1e-12)
    np.testing.assert_array_equal(info["axle_force_residual_estimate"],
                                  info["physical_residual_estimate"])
    env = IdentifierWrapper(gym.make("simgap/ManipulatorFriction-v0"), "integral")
    assert env.identifier.config == preset("auto", "integral", dt=0.002)
    env.reset(seed=0)
    info = env.step(env.action_space.sample())[4]
    np.testing.assert_array_equal(info["physical_residual_estimate"],
                                  -info["residual_estimate"][2:])
    assert "axle_force_residual_estimate" not in info


def test_residual_observation_appends_g_hat():
    env = ResidualObservation(DampedPendulumEnv(), include_error=True, scale=None)
    assert env.observation_space.shape == (6,)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs[2:], 0.0)
    obs, r, term, trunc, info = env.step(np.array([0.5], dtype=np.float32))
    assert env.observation_space.contains(obs)
    np.testing.assert_array_equal(obs[2:4], info["residual_estimate"])
    np.testing.assert_array_equal(obs[4:], info["estimation_error"])
    assert "residual_observation_scale" not in info


def test_residual_observation_scales_by_the_running_rms():
    """Default: ĝ / RMS of every ĝ so far, per component, clipped to ±10; seeded resets
    restore the statistics with the identifier, so a seeded run repeats exactly."""
    env = ResidualObservation(DampedPendulumEnv(), include_error=True)
    assert env.scale_mode == "running"
    assert np.all(env.observation_space.high[2:] == 10.0)
    gs, xs, obs_rows = [], [], []
    env.reset(seed=0)
    for k in range(300):
        obs, _, _, _, info = env.step(np.array([np.sin(0.05 * k)], dtype=np.float32))
        assert env.observation_space.contains(obs)
        gs.append(info["residual_estimate"])
        xs.append(info["estimation_error"])
        obs_rows.append(obs)
    g, x = np.array(gs), np.array(xs)
    s = np.sqrt(np.mean(g**2, axis=0))
    np.testing.assert_allclose(info["residual_observation_scale"], s, rtol=1e-12)
    np.testing.assert_allclose(obs[2:4], np.clip(g[-1] / s, -10, 10), rtol=1e-12)
    np.testing.assert_allclose(obs[4:], np.clip(x[-1] / np.sqrt(np.mean(x**2, axis=0)),
                                                -10, 10), rtol=1e-12)
    assert np.max(np.abs(g)) > 0 and 0.1 < np.sqrt(np.mean(np.array(obs_rows)[100:, 2:4]**2)) < 3
    env.reset(seed=0)
    again = [env.step(np.array([np.sin(0.05 * k)], dtype=np.float32))[0] for k in range(300)]
    np.testing.assert_array_equal(np.array(again), np.array(obs_rows))


def test_residual_observation_declared_scale_and_bad_scales():
    env = ResidualObservation(DampedPendulumEnv(), include_error=True, scale=[2.0, 0.5],
                              clip=5.0)
    env.reset(seed=0)
    a_d = abs(env.identifier_wrapper.identifier.config.a_d)
    for _ in range(50):
        obs, _, _, _, info = env.step(np.array([0.7], dtype=np.float32))
    np.testing.assert_allclose(obs[2:4], np.clip(info["residual_estimate"] / [2.0, 0.5], -5, 5),
                               rtol=1e-6)
    np.testing.assert_allclose(obs[4:], np.clip(info["estimation_error"] * a_d / [2.0, 0.5],
                                                -5, 5), rtol=1e-6)
    for bad in ("rms", 0.0, [1.0, -1.0], [1.0, 2.0, 3.0], float("nan")):
        with pytest.raises(IdentifierError, match="scale"):
            ResidualObservation(DampedPendulumEnv(), scale=bad)
    with pytest.raises(IdentifierError, match="clip"):
        ResidualObservation(DampedPendulumEnv(), clip=0)
    with pytest.raises(IdentifierError, match="already contains"):
        ResidualObservation(IdentifierWrapper(DampedPendulumEnv()), identifier="minibatch")


def test_residual_observation_declared_scale_uses_the_gated_observer_gain():
    """x̃·|a_d| / s with the a_d the observer runs with: the integral law's noise gate moves it.

    At Δt = 2 ms the ``auto`` integral law's gate is on (a_d = −50, a_d_clean = −100 s⁻¹);
    on this clean pendulum ρ⁺ → 1, so the configured a_d would under-read the residual
    error by up to 2×.
    """
    inner = DampedPendulumEnv(max_steps=2000)
    inner.nominal_model.dt = 0.002
    env = ResidualObservation(inner, include_error=True, scale=[2.0, 0.5], clip=1e9)
    ident = env.identifier_wrapper.identifier
    cfg = ident.config
    assert cfg.a_d_clean != 0.0 and ident.observer_gain == cfg.a_d  # ρ⁺ = 0 before data
    env.reset(seed=0)
    for k in range(1500):
        obs, _, _, _, info = env.step(np.array([np.sin(0.01 * k)], dtype=np.float32))
        gain = ident.observer_gain
        np.testing.assert_allclose(obs[4:], info["estimation_error"] * abs(gain) / [2.0, 0.5],
                                   rtol=1e-6, atol=1e-30)
    assert cfg.a_d_clean <= gain < 1.2 * cfg.a_d  # the gate has moved it well past a_d
    batch_gain = ident._observer_gains()
    assert batch_gain.shape == (1,) and batch_gain[0] == gain
