"""Gymnasium's own envs with a user's nominal model: periodic angles, the auto default."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from simgap.identifiers import KINDS, IdentifierError
from simgap.models.base import wrap_angle
from simgap.models.stock import MountainCarNominal, PendulumNominal
from simgap.wrappers import IdentifierWrapper


def _pendulum(kind: str, g: float = 9.0, **kw) -> IdentifierWrapper:
    env = gym.make("Pendulum-v1")
    env.unwrapped.nominal_model = PendulumNominal(g=g)
    return IdentifierWrapper(env, kind, **kw)


def test_wrap_angle_maps_into_half_open_interval():
    a = np.array([np.pi, -np.pi, 3 * np.pi, 0.1 - 2 * np.pi, 7.0])
    w = wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    assert w[0] == np.pi and w[1] == np.pi


@pytest.mark.parametrize("kind", KINDS)
def test_pendulum_v1_learns_with_wrapped_angles(kind):
    """2000 random-torque steps (100 s): no divergence, x̃ wrapped, below the observer alone.

    The bar benchmark (``benchmarks/bench_auto.py``) runs 10,000 steps against ≤ 0.5.
    """
    errs = {}
    for frozen in (True, False):
        rng = np.random.default_rng(0)
        env = _pendulum(kind, seed=0, frozen=frozen)
        env.reset(seed=0)
        e = []
        crossings = 0
        th_prev = None
        for _ in range(2000):
            obs, _, term, trunc, info = env.step(rng.uniform(-2.0, 2.0, size=1))
            th = np.arctan2(obs[1], obs[0])
            if th_prev is not None and abs(th - th_prev) > np.pi:
                crossings += 1
            th_prev = th
            assert np.all(np.abs(info["estimation_error"]) < 5.0)  # wrapped, never ≈ 2π
            assert -np.pi < info["state_estimate"][0] <= np.pi
            e.append(np.linalg.norm(info["estimation_error"]))
            if term or trunc:
                env.reset()
                th_prev = None
        assert crossings > 0  # the angle did pass ±π
        errs[frozen] = np.median(e[-500:])
    assert errs[False] < 0.7 * errs[True]


def test_mountain_car_continuous_wrapped():
    env = gym.make("MountainCarContinuous-v0")
    env.unwrapped.nominal_model = MountainCarNominal(hill=0.002)  # the user's guess; env 0.0025
    env = IdentifierWrapper(env)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(500):
        _, _, term, trunc, info = env.step(rng.uniform(-1.0, 1.0, size=1))
        assert np.all(np.isfinite(info["residual_estimate"]))
        if term or trunc:
            env.reset()
    assert env.identifier.config.normalize_gradients  # the auto default


def test_bad_periodic_states_is_a_typed_error():
    env = gym.make("Pendulum-v1")
    env.unwrapped.nominal_model = PendulumNominal().__class__(periodic_states=(5,))
    with pytest.raises(IdentifierError, match="periodic_states"):
        IdentifierWrapper(env)
