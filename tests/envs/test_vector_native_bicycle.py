"""The bicycle's native vector env: bit-identical to the sync vector env, wrapped and bare."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import simgap
from simgap.envs.bicycle_vector import BicycleVectorEnv
from simgap.envs.manipulator import ManipulatorFrictionEnv
from simgap.envs.scenarios import YawRateReference
from simgap.errors import EnvError
from simgap.models import bicycle as bic
from simgap.wrappers import VectorIdentifierWrapper


def _same_infos(a: dict, b: dict) -> None:
    assert set(a) == set(b)
    for key in a:
        x, y = np.asarray(a[key]), np.asarray(b[key])
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), key


def _pair(n: int, **kwargs):
    native = gym.make_vec(simgap.BICYCLE_ID, num_envs=n, **kwargs)
    sync = gym.make_vec(simgap.BICYCLE_ID, num_envs=n, vectorization_mode="sync", **kwargs)
    assert isinstance(native, BicycleVectorEnv)
    return native, sync


def _run_both(native, sync, steps: int, scale: float, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    n = native.num_envs
    o1, i1 = native.reset(seed=7)
    o2, i2 = sync.reset(seed=7)
    assert np.array_equal(o1, o2)
    _same_infos(i1, i2)
    ends = {"term": 0, "trunc": 0}
    for k in range(steps):
        if k == steps // 2:  # a re-seeded reset mid-run
            o1, i1 = native.reset(seed=11)
            o2, i2 = sync.reset(seed=11)
            assert np.array_equal(o1, o2)
            _same_infos(i1, i2)
        # beyond the steering limit at times (clipped), slow drifts that spin some cars out
        act = (rng.normal(size=(n, 2)) * scale + 0.2 * math.sin(k / 40.0)).astype(np.float32)
        r1, r2 = native.step(act), sync.step(act)
        for x, y in zip(r1[:4], r2[:4], strict=True):
            assert x.dtype == y.dtype and np.array_equal(x, y), k
        _same_infos(r1[4], r2[4])
        ends["term"] += int(r1[2].sum())
        ends["trunc"] += int(r1[3].sum())
    return ends


def test_bicycle_native_equals_sync_over_resets_bit_for_bit():
    """3,000 vector steps with truncations (TimeLimit 120) and terminations (sideslip)."""
    native, sync = _pair(5, max_episode_steps=120, max_sideslip=0.1)
    ends = _run_both(native, sync, 3000, 0.15, 0)
    assert ends["term"] > 5 and ends["trunc"] > 5  # both reset paths were exercised


def test_bicycle_native_with_every_plant_option_equals_sync():
    """Relaxation, steering lag, biases, other μ and vx: the model's kernels cover them."""
    native, sync = _pair(3, max_episode_steps=90, mu=0.6, vx=15.0, relaxation_length=(0.4, 0.7),
                         steering_lag=0.05, lateral_bias=0.3, yaw_bias=-0.1,
                         reference=YawRateReference(amplitude=0.3, period=4.0))
    _run_both(native, sync, 600, 0.1, 1)
    # a new plant assigned to the template acts on every row from the next step on
    for env in (native, *sync.envs):
        env.unwrapped.plant = env.unwrapped.plant.with_effect("yaw_bias", None, dr0=0.2)
    _run_both(native, sync, 300, 0.1, 2)


def test_bicycle_native_wrapped_equals_wrapped_sync():
    native, sync = _pair(3, max_episode_steps=100, max_sideslip=0.15)
    vn, vs = VectorIdentifierWrapper(native), VectorIdentifierWrapper(sync)
    assert vn._batched and not vs._batched  # one shared model: no per-row Python calls
    rng = np.random.default_rng(1)
    _same_infos(vn.reset(seed=0)[1], vs.reset(seed=0)[1])
    for k in range(500):
        act = (rng.normal(size=(3, 2)) * 0.1).astype(np.float32)
        r1, r2 = vn.step(act), vs.step(act)
        assert np.array_equal(r1[0], r2[0]), k
        _same_infos(r1[4], r2[4])
    np.testing.assert_array_equal(vn.identifier.W, vs.identifier.W)


def test_bicycle_native_reset_state_option_and_errors():
    native, sync = _pair(2, relaxation_length=0.5)
    o1, i1 = native.reset(seed=0, options={"state": (0.3, -0.1)})
    o2, i2 = sync.reset(seed=0, options={"state": (0.3, -0.1)})
    assert np.array_equal(o1, o2)
    _same_infos(i1, i2)
    act = np.full((2, 2), 0.05, dtype=np.float32)
    r1, r2 = native.step(act), sync.step(act)  # the lag states started at the same slip
    assert np.array_equal(r1[0], r2[0])
    _same_infos(r1[4], r2[4])
    with pytest.raises(EnvError, match="NaN"):
        native.step(np.array([[0.0, np.nan], [0.0, 0.0]]))
    with pytest.raises(EnvError, match="shape"):
        native.step(np.zeros((3, 2)))
    with pytest.raises(EnvError, match="reset_mask"):
        native.reset(options={"reset_mask": np.array([True, False])})
    with pytest.raises(EnvError, match="before step"):
        gym.make_vec(simgap.BICYCLE_ID, num_envs=2).step(np.zeros((2, 2)))
    with pytest.raises(EnvError, match="YawRateReference only"):
        gym.make_vec(simgap.BICYCLE_ID, num_envs=2, reference=lambda t: 0.1)


def test_scalar_kernels_equal_the_array_kernels():
    """residual_entries = true_residual_vs; axle forces: one row = many rows = K⁻¹g."""
    rng = np.random.default_rng(5)
    theta = bic.make_plant(bic.BicycleParams(), 20.0, tire=bic.MagicFormulaTire(),
                           relaxation_length=(0.3, 0.5), steering_lag=0.04).array
    theta_nom = np.concatenate([bic.BicycleParams(m=1500.0).array, [20.0]])
    model = bic.BicycleNominal()
    gs = rng.normal(size=(300, 2)) * (3.0, 1.0)
    rows = model.physical_residual(None, gs)
    np.testing.assert_allclose(rows, gs @ model.K_inv.T, rtol=1e-12)
    for g, row in zip(gs, rows, strict=True):
        assert np.array_equal(model.physical_residual(None, g), row)
    for _ in range(200):
        s = rng.normal(size=6) * (1.0, 0.5, 0.05, 0.05, 0.05, 0.05)
        u = rng.normal(size=2) * 0.1
        g = bic.true_residual_vs(s, u, theta, theta_nom)
        d = bic.plant_derivative(s, u, theta)
        f = bic.nominal_derivative(s[:2], u, theta_nom)
        assert np.array_equal(g, d[:2] - f)
    x, u = rng.normal(size=(50, 2)), rng.normal(size=(50, 2)) * 0.1
    f_rows = model.f_rows(x, u)
    for i in range(50):
        assert np.array_equal(f_rows[i], model.f(x[i], u[i]))


def test_yaw_rate_reference_equals_python_floats():
    ref = YawRateReference(amplitude=0.3, period=4.7)
    ts = np.concatenate([np.arange(0, 40000) * 0.01,
                         np.random.default_rng(0).uniform(-1, 500, 20000)])
    for t in ts:
        assert ref(float(t)) == 0.3 * math.sin(2.0 * math.pi * float(t) / 4.7)


def test_step_kernels_read_the_plant_assigned_after_construction():
    """The parameter tuples the kernels take follow ``env.plant = ...`` (single and vector)."""
    base = ManipulatorFrictionEnv()
    plant = base.plant.with_effect("torque_bias", "joint1", tau0=0.3)
    changed = ManipulatorFrictionEnv()
    changed.plant = plant
    fresh = ManipulatorFrictionEnv(plant=plant)
    native = gym.make_vec(simgap.MANIPULATOR_ID, num_envs=2)
    native.plant = plant
    runs = []
    for env in (base, changed, fresh):
        env.reset(seed=0)
        runs.append([env.step(np.array([1.0, -0.5]))[0] for _ in range(30)][-1])
    assert np.array_equal(runs[1], runs[2]) and not np.array_equal(runs[0], runs[1])
    native.reset(seed=0)
    for _ in range(30):
        obs = native.step(np.tile([1.0, -0.5], (2, 1)))[0]
    assert np.array_equal(obs[0], runs[2])
