"""Roll a policy out in any Gymnasium env and stack the transitions into numpy arrays."""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

Policy = Callable[[np.ndarray, float], np.ndarray]


@dataclass(frozen=True)
class Rollout:
    """Stacked transitions k = 0 … N−1 of one episode (N ≤ the requested steps).

    Attributes:
        t: time at the start of each transition (s), shape (N,).
        obs: observation before the step, (N, obs_dim).
        action: action passed to ``step`` (before any clipping by the env), (N, act_dim).
        reward: (N,).
        next_obs: observation after the step, (N, obs_dim).
        terminated: (N,) bool.
        truncated: (N,) bool.
        info: per step info, stacked for keys whose values are numbers or numpy arrays
            (e.g. ``info["residual_true"]`` has shape (N, n)); other keys are dropped.
    """

    t: np.ndarray
    obs: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    next_obs: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.t.shape[0])


def _stackable(value: Any) -> bool:
    return isinstance(value, np.ndarray | numbers.Number | np.generic)


def _env_dt(env: gym.Env) -> float:
    """Step period (s) of an env: its ``dt`` or its nominal model's, else 1."""
    base = env.unwrapped
    for obj in (base, getattr(base, "nominal_model", None)):
        dt = getattr(obj, "dt", None)
        if isinstance(dt, numbers.Real) and dt > 0:
            return float(dt)
    return 1.0


def rollout(env: gym.Env, policy: Policy, n_steps: int, *, seed: int | None = None,
            progress: bool = False, options: dict[str, Any] | None = None) -> Rollout:
    """Reset ``env`` and run ``policy(obs, t)`` for up to ``n_steps`` steps.

    Stops after the first terminated or truncated transition. The time passed to the policy
    is ``info["t"]`` of the previous step when the env provides it (the simgap envs do),
    otherwise k·dt with dt from ``env.unwrapped.dt`` or its nominal model.

    Args:
        env: any Gymnasium env (bare or wrapped).
        policy: callable (obs, t) → action.
        n_steps: maximum number of transitions, ≥ 1.
        seed: passed to ``env.reset``.
        progress: show a rich progress bar.
        options: passed to ``env.reset``.

    Returns:
        The stacked :class:`Rollout`.
    """
    from simgap.envs._common import check_count  # numba: imported on use, so that
    # `import simgap` (env registration, the CLI's argument checks) stays light
    n_steps = check_count("n_steps", n_steps)
    dt = _env_dt(env)
    obs, info = env.reset(seed=seed, options=options)
    ts, obs_l, act_l, rew_l, next_l, term_l, trunc_l = [], [], [], [], [], [], []
    infos: dict[str, list] = {}
    t = float(info.get("t", 0.0))

    bar = None
    if progress:
        from rich.progress import Progress

        bar = Progress(transient=True)
        task = bar.add_task("rollout", total=n_steps)
        bar.start()
    try:
        for k in range(n_steps):
            action = np.asarray(policy(obs, t))
            next_obs, reward, terminated, truncated, info = env.step(action)
            ts.append(t)
            obs_l.append(obs)
            act_l.append(action)
            rew_l.append(float(reward))
            next_l.append(next_obs)
            term_l.append(bool(terminated))
            trunc_l.append(bool(truncated))
            for key, value in info.items():
                if _stackable(value):
                    infos.setdefault(key, []).append(value)
            obs = next_obs
            t = float(info["t"]) if "t" in info else (k + 1) * dt
            if bar is not None and (k % 100 == 0 or k == n_steps - 1):
                bar.update(task, completed=k + 1)
            if terminated or truncated:
                break
    finally:
        if bar is not None:
            bar.stop()
    n = len(ts)
    stacked = {key: np.asarray(vals) for key, vals in infos.items() if len(vals) == n}
    return Rollout(t=np.asarray(ts), obs=np.asarray(obs_l), action=np.asarray(act_l),
                   reward=np.asarray(rew_l), next_obs=np.asarray(next_l),
                   terminated=np.asarray(term_l), truncated=np.asarray(trunc_l), info=stacked)
