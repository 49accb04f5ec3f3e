"""VectorIdentifierWrapper: batched kernel, autoreset steps are not learned from."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import simgap  # noqa: F401 - registers the envs
from simgap.wrappers import IdentifierWrapper, VectorIdentifierWrapper
from tests.wrappers.toy import DampedPendulumEnv

LENGTHS = (7, 11, 1000)  # episode lengths: rows 0 and 1 autoreset at different steps


def _actions(steps, n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2, 2, size=(steps, n, 1)).astype(np.float32)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
@pytest.mark.parametrize("kind", ["integral", "minibatch"])
def test_vector_rows_equal_single_wrapped_envs(mode, kind):
    """Row i learns exactly what an IdentifierWrapper on sub-env i learns when it is reset by
    hand at episode ends: the autoreset step contributes nothing."""
    steps = 40
    venv = VectorIdentifierWrapper(
        SyncVectorEnv([lambda n=n: DampedPendulumEnv(max_steps=n) for n in LENGTHS],
                      autoreset_mode=mode), kind)
    acts = _actions(steps, len(LENGTHS))
    venv.reset(seed=0)
    skipped = np.zeros(len(LENGTHS), dtype=int)
    for k in range(steps):
        _, _, term, trunc, info = venv.step(acts[k])
        if mode == AutoresetMode.NEXT_STEP:
            skipped += ~info["_residual_estimate"]
    if mode == AutoresetMode.NEXT_STEP:
        assert skipped.tolist() == [5, 3, 0]  # 40 steps: resets after 7 (+1) and 11 (+1)
    for i, n in enumerate(LENGTHS):
        single = IdentifierWrapper(DampedPendulumEnv(max_steps=n), kind)
        single.reset(seed=i)
        k = 0
        while k < steps:
            _, _, term, trunc, _ = single.step(acts[k, i])
            k += 1
            if term or trunc:
                single.reset()
                if mode == AutoresetMode.NEXT_STEP:
                    k += 1  # the vector env spends this action on the reset
        if kind == "minibatch":  # indices come from one Generator per batch: compare data
            # buffer rows [x̂_k (n) | u_k (m) | d_k (n)]: u and the measured d are the data;
            # x̂ follows the weights (auto: baseline 2 on the observer's estimate)
            n = venv.identifier.n_states
            np.testing.assert_array_equal(venv.identifier._buf[i][:, n:],
                                          single.identifier._buf[0][:, n:])
            np.testing.assert_array_equal(venv.identifier._cnt[i], single.identifier._cnt[0])
        else:
            np.testing.assert_array_equal(venv.identifier.W[i], single.identifier.W)
            np.testing.assert_array_equal(venv.identifier.V[i], single.identifier.V)


def test_make_vec_bicycle_infos_and_seeded_reset():
    envs = gym.make_vec("simgap/BicycleTire-v0", num_envs=2, vectorization_mode="sync")
    venv = VectorIdentifierWrapper(envs, "integral")
    venv.reset(seed=1)
    venv.action_space.seed(1)
    acts = [venv.action_space.sample() for _ in range(30)]
    g1 = [venv.step(a)[4]["residual_estimate"] for a in acts]
    info = venv.step(acts[0])[4]
    for key in ("residual_estimate", "state_estimate", "estimation_error",
                "physical_residual_estimate", "axle_force_residual_estimate"):
        assert info[key].shape == (2, 2) and info[f"_{key}"].all()
    k_inv = envs.get_attr("nominal_model")[0].K_inv
    np.testing.assert_allclose(info["axle_force_residual_estimate"][0],
                               k_inv @ info["residual_estimate"][0], rtol=1e-12)
    venv.reset(seed=1)  # seeded: identifiers back to the reset point, same run again
    g2 = [venv.step(a)[4]["residual_estimate"] for a in acts]
    np.testing.assert_array_equal(np.array(g1), np.array(g2))
    venv.freeze()
    w = venv.identifier.W
    for a in acts:
        assert venv.step(a)[4]["identifier_frozen"].all()
    np.testing.assert_array_equal(venv.identifier.W, w)
