"""Residual RL for yaw-rate tracking near the tire limit, with or without ĝ in the observation.

Task (:func:`make_rl_env`): the bicycle at 20 m/s tracks a sinusoidal yaw-rate reference whose
lateral acceleration (vx·amplitude) is close to μ·g, on a road whose friction μ is drawn
uniformly from ``mu_range`` at every reset (from the env's seeded Generator), so the agent
cannot memorise one tire curve. The agent acts on top of the nominal-inverting
:class:`~simgap.control.compensation.YawRateController`: δ_f = δ_inv + ``action_scale``·a,
a ∈ [−1, 1] (residual RL). Reward: ``reward_scale`` × the env's −(r − r_ref)² (rad²/s²).

Observation (float32): (vy, r, r_ref(t + dt), ṙ_ref(t + dt)) in m/s, rad/s, rad/s, rad/s²;
the ``residual`` variant appends the identifier's ĝ (:class:`~simgap.wrappers.
ResidualObservation`, m/s², rad/s²). Both variants run the same online identifier inside an
:class:`~simgap.wrappers.IdentifierWrapper` (equal compute), and
:class:`EpisodeResidualError` writes the episode's identifier errors into the last step's
``info`` so that ``Monitor(info_keywords=RL_INFO_KEYWORDS)`` logs them per episode.

stable-baselines3 and torch (extra ``rl``) are imported only by :func:`train_agent`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from simgap.control.compensation import YawRateController
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.scenarios import YawRateReference
from simgap.wrappers import IdentifierWrapper, ResidualObservation

#: Per-episode keys that :class:`EpisodeResidualError` adds (logged by ``Monitor``).
RL_INFO_KEYWORDS = ("residual_error_rms", "residual_true_rms", "estimation_error_rms", "mu")
VARIANTS = ("plain", "residual")


@dataclass(frozen=True, kw_only=True)
class RLTask:
    """Settings of the residual-RL yaw-rate task.

    Attributes:
        vx: speed (m/s).
        mu_range: (low, high) road friction drawn per episode (-).
        amplitude: reference amplitude (rad/s).
        period: reference period (s).
        episode_seconds: episode length (s).
        action_scale: steering correction per unit action (rad).
        identifier: identifier kind run in both variants.
        reward_scale: the agent's reward is −reward_scale·(r − r_ref)² (SAC's entropy term
            would swamp the raw rad²/s² values, ~1e-4 per step).
    """

    vx: float = 20.0
    mu_range: tuple[float, float] = (0.45, 0.9)
    amplitude: float = 0.22
    period: float = 4.0
    episode_seconds: float = 4.0
    action_scale: float = 0.05
    identifier: str = "instantaneous"
    reward_scale: float = 100.0

    def __post_init__(self) -> None:
        lo, hi = self.mu_range
        if not (0 < lo <= hi and math.isfinite(hi)):
            raise ValueError(f"mu_range must satisfy 0 < low <= high, got {self.mu_range!r}")
        if not (self.episode_seconds > 0 and self.action_scale > 0 and self.reward_scale > 0):
            raise ValueError("episode_seconds (s), action_scale (rad) and reward_scale must be "
                             "positive")


class RandomFriction(gym.Wrapper):
    """Draw the road friction μ ~ U(mu_range) at every reset (``options={"mu": v}`` fixes it).

    Sets the env's plant to ``plant.with_effect("tire_saturation", mu=μ)`` (same tire and
    options, new μ; ``env.unwrapped.mu`` follows); adds ``info["mu"]`` at reset and every
    step.
    """

    def __init__(self, env: gym.Env, mu_range: tuple[float, float]) -> None:
        super().__init__(env)
        if not isinstance(env.unwrapped, BicycleTireEnv):
            raise TypeError("RandomFriction needs a BicycleTireEnv")
        self.mu_range = (float(mu_range[0]), float(mu_range[1]))
        self.mu = float(env.unwrapped.mu)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[Any, dict[str, Any]]:
        """Set a new μ, then reset the env."""
        base = self.env.unwrapped
        if seed is not None:
            base.reset(seed=seed)  # seed the env's Generator before drawing μ
        opts = dict(options or {})
        mu = opts.pop("mu", None)
        self.mu = float(mu) if mu is not None else float(base.np_random.uniform(*self.mu_range))
        plant = base.plant
        # one road μ for both axles; with linear truth tires μ only sets the parameter
        base.plant = plant.with_effect("tire_saturation", mu=self.mu) \
            if plant.has("tire_saturation") else plant.with_params(mu=self.mu)
        obs, info = self.env.reset(options=opts or None)
        info["mu"] = self.mu
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step and report μ."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        info["mu"] = self.mu
        return obs, reward, terminated, truncated, info


class EpisodeResidualError(gym.Wrapper):
    """Accumulate the identifier's errors over an episode; report them at its last step.

    Adds to ``info`` on the terminating/truncating step: ``residual_error_rms`` (RMS of
    ĝ − g over the episode, both states), ``residual_true_rms`` (RMS of g), and
    ``estimation_error_rms`` (RMS of x̃); units as the state derivatives / states.
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self._acc = np.zeros(3)
        self._n = 0

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Start a new accumulation."""
        self._acc[:] = 0.0
        self._n = 0
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step and accumulate; summarise at the episode's end."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        g, gt = info["residual_estimate"], info["residual_true"]
        xt = info["estimation_error"]
        self._acc += (np.mean((g - gt) ** 2), np.mean(gt ** 2), np.mean(xt ** 2))
        self._n += 1
        if terminated or truncated:
            rms = np.sqrt(self._acc / self._n)
            info["residual_error_rms"] = float(rms[0])
            info["residual_true_rms"] = float(rms[1])
            info["estimation_error_rms"] = float(rms[2])
        return obs, reward, terminated, truncated, info


class ResidualSteering(gym.Wrapper):
    """Residual RL: the agent's a ∈ [−1, 1] corrects the nominal-inverting yaw controller.

    The inner env gets (δ_inv + scale·a, 0) rad. Observation: (vy, r, r_ref(t+dt),
    ṙ_ref(t+dt)) plus whatever the inner observation appends beyond (vy, r) (e.g. ĝ),
    float32. Reward: ``task.reward_scale`` × the inner reward. ``info["base_steering"]`` is
    δ_inv (rad).
    """

    def __init__(self, env: gym.Env, task: RLTask) -> None:
        super().__init__(env)
        base = env.unwrapped
        self.dt = float(base.dt)
        self.scale = float(task.action_scale)
        self.reward_scale = float(task.reward_scale)
        self.reference = base.reference
        self.controller = YawRateController(base.nominal_model, self.reference,
                                            steer_limit=float(base.steer_limit[0]))
        inner = env.observation_space
        extra = int(np.prod(inner.shape)) - 2
        high = np.full(4 + extra, np.inf, dtype=np.float32)
        self.observation_space = gym.spaces.Box(-high, high, dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self._obs = np.zeros(2)
        self._t = 0.0

    def _observe(self, obs: Any, t: float) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float64).reshape(-1)
        h = 1e-3
        t1 = t + self.dt
        ref = float(self.reference(t1))
        dref = (float(self.reference(t1 + h)) - float(self.reference(t1 - h))) / (2 * h)
        return np.concatenate([o[:2], [ref, dref], o[2:]]).astype(np.float32)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset; t = 0."""
        obs, info = self.env.reset(**kwargs)
        self._obs = np.asarray(obs, dtype=np.float64).reshape(-1)[:2]
        self._t = 0.0
        return self._observe(obs, 0.0), info

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Apply δ_inv + scale·a on the front axle."""
        a = float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], -1.0, 1.0))
        base = self.controller(self._obs, self._t)
        delta = np.array([base[0] + self.scale * a, 0.0])
        obs, reward, terminated, truncated, info = self.env.step(delta)
        self._t = float(info["t"])
        self._obs = np.asarray(obs, dtype=np.float64).reshape(-1)[:2]
        info["base_steering"] = float(base[0])
        return (self._observe(obs, self._t), self.reward_scale * float(reward), terminated,
                truncated, info)


def make_rl_env(variant: str, task: RLTask | None = None, *, identifier_seed: int = 0
                ) -> gym.Env:
    """Build the residual-RL env: ``variant`` ``"plain"`` or ``"residual"`` (ĝ appended).

    Chain: BicycleTireEnv → TimeLimit → RandomFriction → IdentifierWrapper
    (→ ResidualObservation) → EpisodeResidualError → ResidualSteering.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    task = task or RLTask()
    env: gym.Env = BicycleTireEnv(vx=task.vx, mu=task.mu_range[1],
                                  reference=YawRateReference(amplitude=task.amplitude,
                                                             period=task.period))
    n_steps = int(round(task.episode_seconds / env.unwrapped.dt))
    env = gym.wrappers.TimeLimit(env, max_episode_steps=n_steps)
    env = RandomFriction(env, task.mu_range)
    env = IdentifierWrapper(env, task.identifier, seed=identifier_seed,
                            reset_identifier_on_seed=False)
    if variant == "residual":
        env = ResidualObservation(env)
    env = EpisodeResidualError(env)
    return ResidualSteering(env, task)


def identifier_wrapper(env: gym.Env) -> IdentifierWrapper:
    """The :class:`~simgap.wrappers.IdentifierWrapper` inside a wrapper chain."""
    e: Any = env
    while isinstance(e, gym.Wrapper):
        if isinstance(e, IdentifierWrapper):
            return e
        e = e.env
    raise ValueError("no IdentifierWrapper in this env")


def evaluate_policy_returns(env: gym.Env, act: Any, mus: tuple[float, ...], *,
                            seed: int = 0) -> list[float]:
    """Episode return of ``act(obs) -> action`` on each μ in ``mus`` (deterministic)."""
    out = []
    for i, mu in enumerate(mus):
        obs, _ = env.reset(seed=seed + i, options={"mu": mu})
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, _ = env.step(act(obs))
            total += float(r)
            done = term or trunc
        out.append(total)
    return out


def train_agent(variant: str, seed: int, total_steps: int, *, task: RLTask | None = None,
                log_dir: str | None = None, eval_mus: tuple[float, ...] = (0.45, 0.6, 0.9)
                ) -> dict[str, Any]:
    """Train SAC on one variant and seed; return the learning curve and final returns.

    SAC (stable-baselines3) with a (64, 64) MLP, batch 128, one gradient step per env step,
    ``torch.set_num_threads(1)``, seeded through SB3's ``seed``. The final evaluation runs on
    a fresh env whose identifier starts from the training identifier's learned state (the
    agent was trained on that identifier's ĝ; a fresh, untrained one would feed it inputs it
    never saw).

    Returns a dict with ``episodes`` (one row per training episode: return ``r``, length
    ``l``, wall time ``t``, env ``step`` at its end and the identifier errors of
    :data:`RL_INFO_KEYWORDS`), and
    ``final_returns`` / ``final_return_mean`` (deterministic policy on ``eval_mus``) next to
    ``base_returns`` (action 0: the nominal-inverting controller alone).
    """
    import torch
    from stable_baselines3 import SAC
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.monitor import Monitor

    class _Episodes(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.rows: list[dict[str, Any]] = []

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                ep = info.get("episode")
                if ep is not None:
                    self.rows.append({**{k: float(v) for k, v in ep.items()},
                                      "step": int(self.num_timesteps)})
            return True

    torch.set_num_threads(1)
    task = task or RLTask()
    path = None if log_dir is None else f"{log_dir}/{variant}_s{seed}"
    env = Monitor(make_rl_env(variant, task, identifier_seed=seed), filename=path,
                  info_keywords=RL_INFO_KEYWORDS)
    model = SAC("MlpPolicy", env, seed=seed, learning_starts=min(500, total_steps // 4),
                policy_kwargs={"net_arch": [64, 64]}, batch_size=128, verbose=0, device="cpu")
    cb = _Episodes()
    model.learn(total_timesteps=int(total_steps), callback=cb)
    eval_env = make_rl_env(variant, task, identifier_seed=seed)
    identifier_wrapper(eval_env).identifier.load_state_dict(
        identifier_wrapper(env).identifier.state_dict())

    def act(o: np.ndarray) -> np.ndarray:
        return model.predict(o, deterministic=True)[0]

    final = evaluate_policy_returns(eval_env, act, eval_mus, seed=10_000 + seed)
    base = evaluate_policy_returns(eval_env, lambda o: np.zeros(1, dtype=np.float32),
                                   eval_mus, seed=10_000 + seed)
    return {
        "variant": variant, "seed": seed, "total_steps": int(total_steps),
        "episodes": cb.rows,
        "final_returns": final, "final_return_mean": float(np.mean(final)),
        "base_returns": base, "eval_mus": list(eval_mus),
    }
