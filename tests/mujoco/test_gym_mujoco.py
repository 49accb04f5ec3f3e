"""Gymnasium's MuJoCo envs run wrapped: nominal model from env.unwrapped.model/data."""

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("mujoco")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from simgap.models.mujoco import MujocoEnvNominal, from_mujoco_env  # noqa: E402
from simgap.wrappers import IdentifierWrapper  # noqa: E402


@pytest.mark.parametrize("env_id", ["InvertedPendulum-v5", "Reacher-v5"])
def test_wrapped_mujoco_env_runs_and_passes_check_env(env_id):
    env = IdentifierWrapper(gym.make(env_id))
    model = env.nominal_model
    assert isinstance(model, MujocoEnvNominal)
    assert model.dt == pytest.approx(env.unwrapped.dt)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0)
    d = env.unwrapped.data
    np.testing.assert_array_equal(info["state_estimate"], np.r_[d.qpos, d.qvel])
    for _ in range(50):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        assert np.all(np.isfinite(info["residual_estimate"]))
        assert info["physical_residual_estimate"].shape == (len(model.joint_names),)
        if term or trunc:
            env.reset()
    env.close()


def test_nominal_of_reacher_predicts_the_env_step():
    """One env step (MuJoCo's RK4) = the nominal f integrated by RK4 over dt."""
    env = gym.make("Reacher-v5")
    env.reset(seed=1)
    model = from_mujoco_env(env)
    x = model.state(None)
    a = np.array([0.3, -0.2])
    env.step(a)
    x_next = model.state(None)
    u, h = model.input(a), model.dt
    k1 = model.f(x, u)
    k2 = model.f(x + h / 2 * k1, u)
    k3 = model.f(x + h / 2 * k2, u)
    k4 = model.f(x + h * k3, u)
    np.testing.assert_allclose(x_next, x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), atol=1e-6)


def test_not_a_mujoco_env_is_refused():
    from simgap.errors import ModelError

    with pytest.raises(ModelError, match="not a MuJoCo env"):
        from_mujoco_env(gym.make("CartPole-v1"))
