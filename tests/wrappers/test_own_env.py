"""A user's own env: the nominal model passed as ``model=``; Dict observations gain a key."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from simgap.errors import IdentifierError
from simgap.wrappers import IdentifierWrapper, ResidualObservation
from tests.wrappers.toy import DampedPendulumEnv, PendulumNominal


class NoModelEnv(DampedPendulumEnv):
    """The toy pendulum without a ``nominal_model`` attribute (a third-party env)."""

    def __init__(self) -> None:
        super().__init__()
        self._model = self.nominal_model
        del self.nominal_model

    def step(self, action):  # the toy's physics reads its dt from the model it carries
        self.nominal_model = self._model
        try:
            return super().step(action)
        finally:
            del self.nominal_model


class DictPendulumNominal(PendulumNominal):
    """The model maps the Dict observation to its state x = (theta, omega)."""

    def state(self, obs):
        return np.asarray(obs["state"], dtype=np.float64)


class DictObsEnv(gym.Wrapper):
    """The toy pendulum with a Dict observation {"state": ..., "goal": ...}."""

    def __init__(self) -> None:
        super().__init__(DampedPendulumEnv())
        self.observation_space = gym.spaces.Dict({
            "state": self.env.observation_space,
            "goal": gym.spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)})
        self.nominal_model = DictPendulumNominal()

    def _obs(self, s):
        return {"state": s, "goal": np.zeros(1, dtype=np.float32)}

    def reset(self, **kw):
        s, info = self.env.reset(**kw)
        return self._obs(s), info

    def step(self, action):
        s, r, te, tr, info = self.env.step(action)
        return self._obs(s), r, te, tr, info


def test_model_keyword_for_env_without_nominal_model() -> None:
    with pytest.raises(IdentifierError, match="model=..."):
        IdentifierWrapper(NoModelEnv())
    env = IdentifierWrapper(NoModelEnv(), "instantaneous", model=PendulumNominal())
    env.reset(seed=0)
    for _ in range(50):
        _, _, _, _, info = env.step(np.array([0.5]))
    assert np.all(np.isfinite(info["residual_estimate"]))
    assert np.any(info["residual_estimate"] != 0.0)  # the identifier ran


def test_model_keyword_overrides_the_env_model() -> None:
    own = PendulumNominal()
    env = IdentifierWrapper(DampedPendulumEnv(), model=own)
    assert env.nominal_model is own


def test_residual_observation_on_dict_adds_keys() -> None:
    env = ResidualObservation(IdentifierWrapper(DictObsEnv(), model=DictPendulumNominal()),
                              include_error=True)
    space = env.observation_space
    assert isinstance(space, gym.spaces.Dict)
    assert set(space.spaces) == {"state", "goal", "residual_estimate", "estimation_error"}
    obs, _ = env.reset(seed=0)
    assert obs in space and np.all(obs["residual_estimate"] == 0.0)
    for _ in range(20):
        obs, _, _, _, info = env.step(np.array([0.3]))
    assert obs in space
    np.testing.assert_allclose(obs["residual_estimate"],
                               np.clip(info["residual_estimate"]
                                       / info["residual_observation_scale"], -10, 10))
    assert space["residual_estimate"].high.max() == 10.0
    np.testing.assert_array_equal(obs["goal"], np.zeros(1, dtype=np.float32))


def test_residual_observation_rejects_other_spaces_with_a_hint() -> None:
    class Discrete(DampedPendulumEnv):
        def __init__(self) -> None:
            super().__init__()
            self.observation_space = gym.spaces.Discrete(3)

    with pytest.raises(IdentifierError, match="Box or Dict"):
        ResidualObservation(IdentifierWrapper(Discrete()))
