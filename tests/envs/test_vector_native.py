"""Native vector envs: bit-identical to the sync vector env, and the fused step kernel."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import simgap
from simgap.envs.manipulator_vector import ManipulatorVectorEnv
from simgap.envs.scenarios import QuinticReference, RandomWaypointReference
from simgap.errors import EnvError
from simgap.models import manipulator as man
from simgap.models.friction import resolve_friction
from simgap.models.integrators import rk4
from simgap.wrappers import IdentifierWrapper, VectorIdentifierWrapper


def _same_infos(a: dict, b: dict) -> None:
    assert set(a) == set(b)
    for key in a:
        x, y = np.asarray(a[key]), np.asarray(b[key])
        assert x.dtype == y.dtype and np.array_equal(x, y), key


def _pair(n: int, **kwargs):
    native = gym.make_vec(simgap.MANIPULATOR_ID, num_envs=n, **kwargs)
    sync = gym.make_vec(simgap.MANIPULATOR_ID, num_envs=n, vectorization_mode="sync", **kwargs)
    assert isinstance(native, ManipulatorVectorEnv)
    return native, sync


def test_arm_native_equals_sync_over_resets_bit_for_bit():
    """3,000 vector steps with truncations (TimeLimit 150) and terminations (max_speed)."""
    n = 4
    native, sync = _pair(n, max_episode_steps=150, init_noise=0.05, max_speed=4.0)
    rng = np.random.default_rng(0)
    o1, i1 = native.reset(seed=7)
    o2, i2 = sync.reset(seed=7)
    assert np.array_equal(o1, o2)
    _same_infos(i1, i2)
    ends = {"term": 0, "trunc": 0}
    for k in range(3000):
        if k == 1500:  # a re-seeded reset mid-run
            o1, i1 = native.reset(seed=11)
            o2, i2 = sync.reset(seed=11)
            assert np.array_equal(o1, o2)
            _same_infos(i1, i2)
        act = (rng.normal(size=(n, 2)) * 25.0).astype(np.float32)
        r1, r2 = native.step(act), sync.step(act)
        for x, y in zip(r1[:4], r2[:4], strict=True):
            assert x.dtype == y.dtype and np.array_equal(x, y), k
        _same_infos(r1[4], r2[4])
        ends["term"] += int(r1[2].sum())
        ends["trunc"] += int(r1[3].sum())
    assert ends["term"] > 5 and ends["trunc"] > 5  # both reset paths were exercised


def test_arm_native_wrapped_equals_wrapped_sync():
    native, sync = _pair(3, max_episode_steps=120, init_noise=0.02)
    vn, vs = VectorIdentifierWrapper(native), VectorIdentifierWrapper(sync)
    assert vn._batched and not vs._batched  # one shared model: no per-row Python calls
    rng = np.random.default_rng(1)
    _same_infos(vn.reset(seed=0)[1], vs.reset(seed=0)[1])
    for k in range(400):
        act = (rng.normal(size=(3, 2)) * 10.0).astype(np.float32)
        r1, r2 = vn.step(act), vs.step(act)
        assert np.array_equal(r1[0], r2[0]), k
        _same_infos(r1[4], r2[4])
    np.testing.assert_array_equal(vn.identifier.W, vs.identifier.W)


def test_arm_native_reset_state_option_and_errors():
    native, sync = _pair(2)
    s = (0.1, -0.2, 0.3, 0.0)
    o1, i1 = native.reset(seed=0, options={"state": s})
    o2, i2 = sync.reset(seed=0, options={"state": s})
    assert np.array_equal(o1, o2)
    _same_infos(i1, i2)
    with pytest.raises(EnvError, match="NaN"):
        native.step(np.array([[0.0, np.nan], [0.0, 0.0]]))
    with pytest.raises(EnvError, match="shape"):
        native.step(np.zeros((3, 2)))
    with pytest.raises(EnvError, match="dtype"):
        native.step(np.zeros((2, 2), dtype=int))
    with pytest.raises(EnvError, match="reset_mask"):
        native.reset(options={"reset_mask": np.array([True, False])})
    with pytest.raises(EnvError, match="before step"):
        gym.make_vec(simgap.MANIPULATOR_ID, num_envs=2).step(np.zeros((2, 2)))
    with pytest.raises(EnvError, match="QuinticReference only"):
        gym.make_vec(simgap.MANIPULATOR_ID, num_envs=2,
                     reference=RandomWaypointReference(seed=0))


def test_fused_transition_equals_the_kernels_one_by_one():
    """plant_step / transition equal RK4 over plant_derivative (the integrator's array form)."""
    theta = man.make_plant(friction=resolve_friction("stribeck")).array
    la_nom = man.ManipulatorParams().array
    rng = np.random.default_rng(3)
    for _ in range(300):
        s = rng.normal(size=4) * (1.0, 1.0, 0.01 if rng.random() < 0.3 else 2.0, 2.0)
        u = rng.normal(size=2) * 20.0
        s_new, g, tau = man.transition(s, u, theta, la_nom, 0.002, 20)
        ref = rk4(man.plant_derivative, s, u, theta, 0.002, 20)
        assert np.array_equal(s_new, ref)
        assert np.array_equal(man.plant_step(s, u, theta, 0.002, 20), ref)
        assert np.array_equal(g, man.true_residual(s, u, theta, la_nom))
        assert np.array_equal(tau, man.tau_d(s[:2], s[2:], theta))


def _quintic_python(t: float, qs, qe, period: float) -> list[float]:
    """The reference's formula in plain Python floats (as shipped before it was compiled)."""
    def seg(a, b, tau):
        t2 = tau * tau
        s = t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2)
        ds = 30.0 * t2 * (1.0 - tau) ** 2
        dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)
        d0, d1 = b[0] - a[0], b[1] - a[1]
        v, acc = ds / period, dds / (period * period)
        return [a[0] + d0 * s, a[1] + d1 * s, d0 * v, d1 * v, d0 * acc, d1 * acc]
    if t <= 0.0:
        return seg(qs, qe, 0.0)
    k, rem = divmod(t, period)
    return seg(qs, qe, rem / period) if int(k) % 2 == 0 else seg(qe, qs, rem / period)


def test_quintic_kernel_equals_python_floats():
    """Compiled reference = Python's float arithmetic (incl. libm pow for ``** 2``)."""
    ref = QuinticReference(q_start=(0.3, -1.1), q_end=(2.0, 0.7), period=1.3)
    qs, qe = (0.3, -1.1), (2.0, 0.7)
    ts = np.concatenate([np.arange(0, 40000) * 0.002, np.random.default_rng(0).uniform(
        -1, 50, 20000)])
    for t in ts:
        assert ref.sample(float(t)).tolist() == _quintic_python(float(t), qs, qe, 1.3)
    assert math.isclose(ref.sample(1.3)[0], 2.0)


def test_cache_guard_recompiles_after_a_dependency_changes(tmp_path):
    """A cached kernel reading another module's constant sees that constant change."""
    (tmp_path / "dep17.py").write_text("SLOT = 1\n")
    (tmp_path / "kern17.py").write_text(textwrap.dedent("""
        from numba import njit
        import dep17
        from simgap.models.nbcache import guard_cache
        S = dep17.SLOT

        @njit(cache=True)
        def k():
            return S

        guard_cache(globals(), ("dep17",))
    """))
    run = [sys.executable, "-c", "import kern17; print(kern17.k())"]
    # no .pyc: Python revalidates bytecode by whole-second mtime and size, and the two
    # same-size versions of dep17.py below are often written within one second
    env = {"PYTHONPATH": str(tmp_path), "PATH": "", "PYTHONDONTWRITEBYTECODE": "1"}
    assert subprocess.run(run, env=env, capture_output=True, text=True,
                          check=True).stdout.strip() == "1"
    (tmp_path / "dep17.py").write_text("SLOT = 2\n")  # kern17.py itself is unchanged
    assert subprocess.run(run, env=env, capture_output=True, text=True,
                          check=True).stdout.strip() == "2"


def test_vector_wrapper_wraps_periodic_states_as_the_single_wrapper():
    """Pendulum-v1 rows (one shared PendulumNominal): equal to per-env IdentifierWrappers."""
    from simgap.models.stock import PendulumNominal

    model = PendulumNominal(g=9.0)

    def make():
        env = gym.make("Pendulum-v1")
        env.unwrapped.nominal_model = model
        return env

    n, steps = 3, 120
    venv = VectorIdentifierWrapper(gym.vector.SyncVectorEnv([make] * n))
    assert venv._batched
    singles = [IdentifierWrapper(make()) for _ in range(n)]
    venv.reset(seed=0)
    for i, s in enumerate(singles):
        s.reset(seed=i)
    rng = np.random.default_rng(2)
    for _ in range(steps):
        act = rng.uniform(-2, 2, size=(n, 1)).astype(np.float32)
        info = venv.step(act)[4]
        for i, s in enumerate(singles):
            si = s.step(act[i])[4]
            np.testing.assert_array_equal(info["state_estimate"][i], si["state_estimate"])
            np.testing.assert_array_equal(info["estimation_error"][i], si["estimation_error"])
    assert np.all(np.abs(info["state_estimate"][:, 0]) <= np.pi)
    for i, s in enumerate(singles):
        np.testing.assert_array_equal(venv.identifier.W[i], s.identifier.W)


def test_bicycle_cacheable_plant_step_equals_rk4_over_plant_derivative():
    from simgap.models import bicycle as bic

    rng = np.random.default_rng(4)
    for opts in ({}, {"relaxation_length": (0.4, 0.6), "steering_lag": 0.05,
                      "lateral_bias": 0.3, "yaw_bias": -0.1}):
        theta = bic.plant_array(bic.BicycleParams(), 20.0, tire=bic.MagicFormulaTire(), **opts)
        for _ in range(100):
            s = rng.normal(size=6) * (1.0, 0.5, 0.05, 0.05, 0.05, 0.05)
            u = rng.normal(size=2) * 0.1
            np.testing.assert_array_equal(bic.plant_step(s, u, theta, 0.01, 4),
                                          rk4(bic.plant_derivative, s, u, theta, 0.01, 4))


def test_cache_guard_follows_imported_kernels_without_a_deps_list(tmp_path):
    """An inlined kernel of another module of the package, edited: the caller recompiles.

    numba keys ``pkg17.b.g``'s cache on ``b.py`` alone; ``guard_cache(globals())`` (no deps
    named) finds ``pkg17.a`` through the imported dispatcher ``f``, and ``pkg17.c`` reaches
    it through ``b``, so both see the edit.
    """
    pkg = tmp_path / "pkg17"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(textwrap.dedent("""
        from numba import njit

        @njit(cache=True, inline="always")
        def f():
            return 1
    """))
    guard = "from simgap.models.nbcache import guard_cache\nguard_cache(globals())\n"
    (pkg / "b.py").write_text(textwrap.dedent("""
        from numba import njit
        from pkg17.a import f

        @njit(cache=True)
        def g():
            return f() + 10
    """) + guard)
    (pkg / "c.py").write_text(textwrap.dedent("""
        from numba import njit
        from pkg17.b import g

        @njit(cache=True)
        def k():
            return g() + 100
    """) + guard)
    run = [sys.executable, "-c", "import pkg17.b, pkg17.c; print(pkg17.b.g(), pkg17.c.k())"]
    env = {"PYTHONPATH": str(tmp_path), "PATH": "", "PYTHONDONTWRITEBYTECODE": "1"}
    assert subprocess.run(run, env=env, capture_output=True, text=True,
                          check=True).stdout.split() == ["11", "111"]
    (pkg / "a.py").write_text((pkg / "a.py").read_text().replace("return 1", "return 2"))
    assert subprocess.run(run, env=env, capture_output=True, text=True,
                          check=True).stdout.split() == ["12", "112"]
