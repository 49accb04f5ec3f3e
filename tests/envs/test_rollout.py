"""rollout(): stacking, early stop, any env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import simgap  # noqa: F401 - registers the envs
from simgap.envs import BicycleTireEnv, rollout


def test_rollout_shapes_and_times():
    env = BicycleTireEnv()
    ro = rollout(env, lambda obs, t: np.array([0.02 * np.sin(t), 0.0]), 50, seed=0)
    assert len(ro) == 50
    assert ro.obs.shape == (50, 2) and ro.next_obs.shape == (50, 2) and ro.action.shape == (50, 2)
    np.testing.assert_allclose(ro.t, np.arange(50) * 0.01)
    np.testing.assert_array_equal(ro.obs[1:], ro.next_obs[:-1])
    assert ro.info["residual_true"].shape == (50, 2)
    np.testing.assert_allclose(ro.info["t"], ro.t + 0.01)


def test_rollout_stops_on_truncation_via_gym_make():
    env = gym.make("simgap/BicycleTire-v0", max_episode_steps=7)
    ro = rollout(env, lambda obs, t: np.zeros(2), 100, seed=0, progress=True)
    assert len(ro) == 7 and ro.truncated[-1] and not ro.truncated[:-1].any()


def test_rollout_on_foreign_env_and_bad_n():
    env = gym.make("Pendulum-v1")
    ro = rollout(env, lambda obs, t: np.array([0.0], dtype=np.float32), 5, seed=0)
    assert ro.obs.shape == (5, 3)
    np.testing.assert_allclose(ro.t, np.arange(5) * env.unwrapped.dt)
    with pytest.raises(ValueError, match="n_steps"):
        rollout(env, lambda obs, t: np.zeros(1), 0)
