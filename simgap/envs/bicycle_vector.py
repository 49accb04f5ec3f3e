"""Native vector env of ``simgap/BicycleTire-v0`` (``gym.make_vec`` default mode).

One numba call per vector step advances every row: action clip, the true residual of the
transition (:func:`simgap.models.bicycle.residual_entries`), the plant's RK4
(:func:`simgap.models.bicycle.plant_rk4`), the axle-force residual K⁻¹g, the yaw-rate
reference, reward, termination, ``TimeLimit`` truncation and the ``NEXT_STEP`` autoreset,
writing the (N, …) info arrays in place. The plant is read only through the model's
functions and its kernel array (:attr:`~simgap.models.effects.Plant.array`), so a change of
the plant layout reaches this env unchanged. Equal bit for bit to
``gym.make_vec(BICYCLE_ID, N, vectorization_mode="sync")`` (see
:mod:`simgap.envs.vector_base`; ``tests/envs/test_vector_native.py`` pins it).

Supported: every keyword of :class:`~simgap.envs.bicycle.BicycleTireEnv` with the default
:class:`~simgap.envs.scenarios.YawRateReference` (any amplitude and period). Another
reference, ``render_mode`` or ``reset(options={"reset_mask": …})`` raise
:class:`~simgap.errors.EnvError` naming ``vectorization_mode="sync"``, which supports them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from simgap.envs.bicycle import BicycleTireEnv, tracking_outcome
from simgap.envs.scenarios import YawRateReference, yaw_rate_entries
from simgap.envs.vector_base import NativeVectorEnv
from simgap.models.bicycle import axle_force_entries, plant_rk4, residual_entries
from simgap.models.nbcache import guard_cache


@njit(cache=True, inline="always")
def _write_info(i, t, r_ref, g1, g2, k_inv, u1, u2, t_out, rref_out, g_out, delta_out,
                phys_out, u_out):  # pragma: no cover - compiled
    """Row i of the info arrays: t (s), r_ref (rad/s), g, Delta = K⁻¹g (N), applied u (rad)."""
    t_out[i] = t
    rref_out[i] = r_ref
    g_out[i, 0] = g1
    g_out[i, 1] = g2
    d1, d2 = axle_force_entries(g1, g2, k_inv)
    delta_out[i, 0] = d1
    delta_out[i, 1] = d2
    phys_out[i, 0] = d1
    phys_out[i, 1] = d2
    u_out[i, 0] = u1
    u_out[i, 1] = u2


@njit(cache=True)
def vector_step(s, k, a, reset_rows, low, high, theta, theta_nom, k_inv, dt, n_sub, amp,
                period, vy_max, max_steps, obs, rew, term, trunc, t_out, rref_out, g_out,
                delta_out, phys_out, u_out):  # pragma: no cover - compiled
    """One vector step of N vehicles (all arrays (N, …), written in place).

    Rows with ``reset_rows`` True are reset to straight running (``NEXT_STEP``: their action
    is ignored), the others take a transition of ``dt`` s with ``a`` clipped into
    [low, high]. On return ``reset_rows`` holds the rows the next step resets (terminated
    or truncated). ``max_steps`` < 0: no ``TimeLimit``.
    """
    n = s.shape[0]
    for i in range(n):
        if reset_rows[i]:
            for j in range(6):
                s[i, j] = 0.0
            k[i] = 0
            g1, g2 = residual_entries(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, theta,
                                      theta_nom)
            _write_info(i, 0.0, yaw_rate_entries(0.0, amp, period), g1, g2, k_inv, 0.0, 0.0,
                        t_out, rref_out, g_out, delta_out, phys_out, u_out)
            rew[i] = 0.0
            term[i] = False
            trunc[i] = False
        else:
            u1 = min(max(a[i, 0], low[0]), high[0])
            u2 = min(max(a[i, 1], low[1]), high[1])
            s0, s1, s2, s3, s4, s5 = s[i, 0], s[i, 1], s[i, 2], s[i, 3], s[i, 4], s[i, 5]
            g1, g2 = residual_entries(s0, s1, s2, s3, s4, s5, u1, u2, theta, theta_nom)
            n0, n1, n2, n3, n4, n5 = plant_rk4(s0, s1, s2, s3, s4, s5, u1, u2, theta, dt,
                                               n_sub)
            s[i, 0] = n0
            s[i, 1] = n1
            s[i, 2] = n2
            s[i, 3] = n3
            s[i, 4] = n4
            s[i, 5] = n5
            k[i] += 1
            t = k[i] * dt
            r_ref = yaw_rate_entries(t, amp, period)
            rew[i], term[i] = tracking_outcome(n0, n1, r_ref, vy_max)
            trunc[i] = max_steps >= 0 and k[i] >= max_steps
            _write_info(i, t, r_ref, g1, g2, k_inv, u1, u2, t_out, rref_out, g_out, delta_out,
                        phys_out, u_out)
        obs[i, 0] = s[i, 0]
        obs[i, 1] = s[i, 1]
        reset_rows[i] = term[i] or trunc[i]


class BicycleVectorEnv(NativeVectorEnv):
    """N vehicles of :class:`~simgap.envs.bicycle.BicycleTireEnv` in one kernel.

    Made by ``gym.make_vec(BICYCLE_ID, num_envs=N)`` (the registered
    ``vector_entry_point``); see the module docstring for what it supports. The rows share
    one plant (``env.plant``; assigning a new one acts from the next step on).

    Args:
        num_envs: N.
        max_episode_steps: per-row ``TimeLimit`` (3,500 from the registration).
        **kwargs: the sub-env's keyword arguments (one plant for all rows).
    """

    state_size = 2
    state_doc = "vy m/s, r rad/s"
    action_doc = "steering angles (rad)"

    def __init__(self, num_envs: int = 1, max_episode_steps: int | None = None,
                 **kwargs: Any) -> None:
        single = self._make_single(BicycleTireEnv, YawRateReference, kwargs)
        super().__init__(single, num_envs, max_episode_steps)
        nn = self.num_envs
        self._s = np.zeros((nn, 6))
        self._k = np.zeros(nn, dtype=np.int64)
        self._zeros = np.zeros((nn, 2))
        self._theta_nom = tuple(single._theta_nom.tolist())  # nominal vehicle + vx (fixed)

    def _new_outputs(self) -> tuple[np.ndarray, ...]:
        nn = self.num_envs
        return (np.empty((nn, 2)), np.empty(nn), np.empty(nn, dtype=bool),
                np.empty(nn, dtype=bool), np.empty(nn), np.empty(nn), np.empty((nn, 2)),
                np.empty((nn, 2)), np.empty((nn, 2)), np.empty((nn, 2)))

    def _run(self, actions: np.ndarray, rows: np.ndarray) -> tuple[Any, ...]:
        env = self.single_env
        ref = env.reference
        out = self._new_outputs()
        steps = -1 if self.max_episode_steps is None else self.max_episode_steps
        vector_step(self._s, self._k, actions, rows, self._low, self._high,
                    self._plant_params(), self._theta_nom, env._k_inv, env.dt, env.n_substeps,
                    ref.amplitude, ref.period, env._vy_max, steps, *out)
        obs, rew, term, trunc, t, r_ref, g, delta, phys, u = out
        info = self._masks({"t": t, "r_ref": r_ref, "residual_true": g,
                            "axle_force_residual_true": delta, "physical_residual_true": phys,
                            "applied_action": u})
        return obs, rew, term, trunc, info

    def _run_state(self, state: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """Every row at the sub-env's reset state for ``options["state"]``, with its info."""
        env = self.single_env
        o, i1 = env.reset(options={"state": state})
        nn = self.num_envs
        self._s[:] = env.plant_state
        self._k[:] = 0
        info = {key: np.tile(np.asarray(v), (nn, 1)) if np.ndim(v) else
                np.full(nn, v, dtype=np.float64) for key, v in i1.items()}
        return np.tile(o, (nn, 1)), self._masks(info)


guard_cache(globals(), ("simgap.envs.bicycle", "simgap.envs.scenarios", "simgap.models.bicycle",
                        "simgap.models.integrators", "simgap.models.slots", "simgap.models.tires"))
