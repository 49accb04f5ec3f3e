"""Native vector env of ``simgap/ManipulatorFriction-v0`` (``gym.make_vec`` default mode).

One numba call per vector step advances every row: action clip, the model's transition
(:func:`simgap.models.manipulator.transition_entries`: RK4 physics, true residual, tau_d),
the quintic reference, reward, termination, ``TimeLimit`` truncation and the ``NEXT_STEP``
autoreset, writing the (N, …) info arrays in place. Equal bit for bit to
``gym.make_vec(MANIPULATOR_ID, N, vectorization_mode="sync")`` (see
:mod:`simgap.envs.vector_base`; ``tests/envs/test_vector_native.py`` pins it).

Supported: every keyword of :class:`~simgap.envs.manipulator.ManipulatorFrictionEnv` with
the default :class:`~simgap.envs.scenarios.QuinticReference` (any ``q_start``, ``q_end``,
``period``). Another reference, ``render_mode`` or ``reset(options={"reset_mask": …})``
raise :class:`~simgap.errors.EnvError` naming ``vectorization_mode="sync"``, which supports
them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from simgap.envs.manipulator import ManipulatorFrictionEnv, tracking_outcome
from simgap.envs.scenarios import QuinticReference, quintic_sample_entries
from simgap.envs.vector_base import NativeVectorEnv
from simgap.models.manipulator import residual_entries, transition_entries
from simgap.models.nbcache import guard_cache


@njit(cache=True, inline="always")
def _write_info(i, t, r, g3, g4, tau1, tau2, u1, u2, t_out, ref_out, g_out, tau_out,
                u_out):  # pragma: no cover - compiled
    """Row i of the info arrays: t, reference (6), g = (0, 0, g3, g4), tau_d, applied u."""
    t_out[i] = t
    for j in range(6):
        ref_out[i, j] = r[j]
    g_out[i, 0] = 0.0
    g_out[i, 1] = 0.0
    g_out[i, 2] = g3
    g_out[i, 3] = g4
    tau_out[i, 0] = tau1
    tau_out[i, 1] = tau2
    u_out[i, 0] = u1
    u_out[i, 1] = u2


@njit(cache=True)
def _row_reset(i, s, k, noise, theta, la_nom, ref_p, two, t_out, ref_out, g_out, tau_out,
               u_out):  # pragma: no cover - compiled
    """Row i back on the reference at t = 0 (plus ``noise`` on q), reset info written."""
    r = quintic_sample_entries(0.0, ref_p[0], ref_p[1], ref_p[2], ref_p[3], ref_p[4], two)
    s[i, 0] = r[0] + noise[i, 0]
    s[i, 1] = r[1] + noise[i, 1]
    s[i, 2] = r[2]
    s[i, 3] = r[3]
    k[i] = 0
    g3, g4, tau1, tau2 = residual_entries(s[i, 0], s[i, 1], s[i, 2], s[i, 3], 0.0, 0.0, theta,
                                          la_nom)
    _write_info(i, 0.0, r, g3, g4, tau1, tau2, 0.0, 0.0, t_out, ref_out, g_out, tau_out, u_out)


@njit(cache=True)
def vector_step(s, k, a, reset_rows, noise, low, high, theta, la_nom, dt, n_sub, ref_p, two,
                max_speed, max_steps, obs, rew, term, trunc, t_out, ref_out, g_out, tau_out,
                u_out):  # pragma: no cover - compiled
    """One vector step of N arms (all arrays (N, …), written in place).

    Rows with ``reset_rows`` True are reset (``NEXT_STEP``: their action is ignored), the
    others take a transition of ``dt`` s with ``a`` clipped into [low, high]. On return
    ``reset_rows`` holds the rows the next step resets (terminated or truncated).
    ``max_steps`` < 0: no ``TimeLimit``.
    """
    n = s.shape[0]
    for i in range(n):
        if reset_rows[i]:
            _row_reset(i, s, k, noise, theta, la_nom, ref_p, two, t_out, ref_out, g_out,
                       tau_out, u_out)
            rew[i] = 0.0
            term[i] = False
            trunc[i] = False
        else:
            u1 = min(max(a[i, 0], low[0]), high[0])
            u2 = min(max(a[i, 1], low[1]), high[1])
            n1, n2, n3, n4, g3, g4, tau1, tau2 = transition_entries(
                s[i, 0], s[i, 1], s[i, 2], s[i, 3], u1, u2, theta, la_nom, dt, n_sub)
            s[i, 0] = n1
            s[i, 1] = n2
            s[i, 2] = n3
            s[i, 3] = n4
            k[i] += 1
            t = k[i] * dt
            r = quintic_sample_entries(t, ref_p[0], ref_p[1], ref_p[2], ref_p[3], ref_p[4], two)
            rew[i], term[i] = tracking_outcome(n1, n2, n3, n4, r[0], r[1], max_speed)
            trunc[i] = max_steps >= 0 and k[i] >= max_steps
            _write_info(i, t, r, g3, g4, tau1, tau2, u1, u2, t_out, ref_out, g_out, tau_out,
                        u_out)
        for j in range(4):
            obs[i, j] = s[i, j]
        reset_rows[i] = term[i] or trunc[i]


class ManipulatorVectorEnv(NativeVectorEnv):
    """N arms of :class:`~simgap.envs.manipulator.ManipulatorFrictionEnv` in one kernel.

    Made by ``gym.make_vec(MANIPULATOR_ID, num_envs=N)`` (the registered
    ``vector_entry_point``); see the module docstring for what it supports.

    Args:
        num_envs: N.
        max_episode_steps: per-row ``TimeLimit`` (5,000 from the registration).
        **kwargs: the sub-env's keyword arguments (one plant for all rows).
    """

    state_size = 4
    state_doc = "q1, q2, dq1, dq2"
    action_doc = "joint torques (N·m)"

    def __init__(self, num_envs: int = 1, max_episode_steps: int | None = None,
                 **kwargs: Any) -> None:
        single = self._make_single(ManipulatorFrictionEnv, QuinticReference, kwargs)
        super().__init__(single, num_envs, max_episode_steps)
        nn = self.num_envs
        self._s = np.zeros((nn, 4))
        self._k = np.zeros(nn, dtype=np.int64)
        self._noise = np.zeros((nn, 2))
        self._zeros = np.zeros((nn, 2))
        self._ref_p = np.array(single.reference.params)

    def _new_outputs(self) -> tuple[np.ndarray, ...]:
        nn = self.num_envs
        return (np.empty((nn, 4)), np.empty(nn), np.empty(nn, dtype=bool),
                np.empty(nn, dtype=bool), np.empty(nn), np.empty((nn, 6)), np.empty((nn, 4)),
                np.empty((nn, 2)), np.empty((nn, 2)))

    def _fresh_rows(self, rows: np.ndarray) -> None:
        """The initial-state noise of ``rows`` (as the sub-env draws it at reset), rad."""
        w = self.single_env.init_noise
        for i in np.flatnonzero(rows):
            self._noise[i] = self._rng(i).uniform(-w, w, size=2)

    def _run(self, actions: np.ndarray, rows: np.ndarray) -> tuple[Any, ...]:
        env = self.single_env
        out = self._new_outputs()
        steps = -1 if self.max_episode_steps is None else self.max_episode_steps
        vector_step(self._s, self._k, actions, rows, self._noise, self._low, self._high,
                    self._plant_params(), env._la_nom_params, env.dt, env.n_substeps,
                    self._ref_p, 2.0, env.max_speed, steps, *out)
        obs, rew, term, trunc, t, ref, g, tau, u = out
        info = self._masks({"t": t, "reference": ref, "residual_true": g,
                            "physical_residual_true": tau, "applied_action": u})
        return obs, rew, term, trunc, info

    def _on_reset(self) -> None:
        """The sub-env's reference parameters (it may have been given a new one)."""
        self._ref_p = np.array(self.single_env.reference.params)

    def _run_state(self, state: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset info at a given state for every row (``options["state"]``)."""
        env = self.single_env
        from simgap.models.manipulator import tau_d, true_residual

        nn = self.num_envs
        self._s[:] = state
        self._k[:] = 0
        g = np.tile(true_residual(state, np.zeros(2), env._theta, env._la_nom), (nn, 1))
        tau = np.tile(tau_d(state[:2], state[2:], env._theta), (nn, 1))
        ref = np.tile(np.asarray(env.reference.sample(0.0), dtype=np.float64), (nn, 1))
        info = self._masks({"t": np.zeros(nn), "reference": ref, "residual_true": g,
                            "physical_residual_true": tau, "applied_action": np.zeros((nn, 2))})
        return self._s.copy(), info


guard_cache(globals(), ("simgap.envs.manipulator", "simgap.envs.scenarios",
                        "simgap.models.friction", "simgap.models.integrators",
                        "simgap.models.manipulator", "simgap.models.slots"))
