"""Identify the axle-force residual of the Pacejka lane-keeping env (tests, notebook)."""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from simgap.highway.registration import HIGHWAY_LANE_KEEPING_ID, register_highway_envs
from simgap.identifiers import IdentifierConfig
from simgap.wrappers import IdentifierWrapper


@dataclass(frozen=True)
class AxleIdentification:
    """Per-step traces of one identification run (k = 0 … N−1).

    Attributes:
        t: time after each step (s).
        action: the action in [−1, 1].
        steering: front steering angle (rad).
        axle_true: true axle-force residual (N), (N, 2).
        axle_estimate: the identifier's estimate K⁻¹ĝ (N), (N, 2).
        state: (vy, r) after each step (m/s, rad/s), (N, 2).
    """

    t: np.ndarray
    action: np.ndarray
    steering: np.ndarray
    axle_true: np.ndarray
    axle_estimate: np.ndarray
    state: np.ndarray

    def scores(self, last_seconds: float) -> dict[str, list[float]]:
        """RMS of the truth, RMS error and correlation per axle over the last seconds."""
        sel = self.t > self.t[-1] - last_seconds
        tr, es = self.axle_true[sel], self.axle_estimate[sel]
        return {"rms_true_N": np.sqrt(np.mean(tr**2, axis=0)).tolist(),
                "rms_error_N": np.sqrt(np.mean((es - tr) ** 2, axis=0)).tolist(),
                "correlation": [float(np.corrcoef(tr[:, i], es[:, i])[0, 1]) for i in (0, 1)]}


def steering_excitation(t: float) -> float:
    """Two-sine action in [−1, 1] (0.12 at 0.4 Hz + 0.06 at 1.1 Hz) that saturates the tires."""
    return 0.12 * np.sin(2 * np.pi * 0.4 * t) + 0.06 * np.sin(2 * np.pi * 1.1 * t)


def identify_lane_keeping(*, mu: float = 0.3, seconds: float = 20.0,
                          identifier: str = "instantaneous", seed: int = 0,
                          config: IdentifierConfig | None = None) -> AxleIdentification:
    """Drive ``simgap/PacejkaLaneKeeping-v0`` open loop and identify its axle residual.

    Args:
        mu: road friction (-).
        seconds: run length (s).
        identifier: identifier kind inside the :class:`~simgap.wrappers.IdentifierWrapper`.
        seed: reset seed and identifier seed.
        config: identifier configuration (default: the wrapper's, the ``auto`` preset).
    """
    if not register_highway_envs():
        raise ImportError("highway-env is not installed: pip install 'simgap[highway]'")
    env = IdentifierWrapper(gym.make(HIGHWAY_LANE_KEEPING_ID, config={"mu": mu}), identifier,
                            seed=seed, config=config)
    env.reset(seed=seed)
    dt = env.unwrapped.nominal_model.dt
    model = env.unwrapped.nominal_model
    n = int(round(seconds / dt))
    rows = []
    for k in range(n):
        t = k * dt
        a = np.array([steering_excitation(t)])
        obs, _, _, _, info = env.step(a)
        rows.append((t + dt, a[0], model.input(a)[0], info["axle_force_residual_true"],
                     info["axle_force_residual_estimate"], model.state(obs)))
    env.close()
    cols = list(zip(*rows, strict=True))
    return AxleIdentification(*(np.asarray(c) for c in cols))
