"""Nominal models for Gymnasium's own envs: "any env" examples for the identifiers.

A stock env has no ``nominal_model``; a user attaches one and wraps the env::

    env = gym.make("Pendulum-v1")
    env.unwrapped.nominal_model = PendulumNominal(g=9.0)   # the user's guess; the env has 10
    env = IdentifierWrapper(env)                            # default kind and "auto" preset

* :class:`PendulumNominal` (``Pendulum-v1``, 20 Hz): state [θ, ω] with θ = atan2(sin, cos)
  from the observation, declared periodic (index 0); input the torque (N·m).
* :class:`MountainCarNominal` (``MountainCarContinuous-v0``): state [position, velocity] in
  the env's units per step (Δt = 1 step, called 1 s here); input the force command.

Each is written from the env's documented equations with the user's own parameter values,
so the residual the identifier learns is exactly what the user got wrong plus what the env
does beyond the ODE (its semi-implicit Euler step, its speed clip).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simgap.models.base import BaseNominalModel


@dataclass(frozen=True, kw_only=True)
class PendulumNominal(BaseNominalModel):
    """Nominal model of Gymnasium's ``Pendulum-v1``: θ̈ = 3g/(2l) sin θ + 3u/(m l²).

    θ = 0 is upright (the env's convention). Attributes are the user's values.

    Attributes:
        g: gravity (m/s²); the env's default is 10.0.
        m: mass (kg), env 1.0.
        length: length l (m), env 1.0.
        dt: step period (s), env 0.05.
    """

    g: float = 10.0
    m: float = 1.0
    length: float = 1.0
    dt: float = 0.05
    name: str = "pendulum_v1"
    state_names: tuple[str, ...] = ("theta", "omega")
    state_units: tuple[str, ...] = ("rad", "rad/s")
    input_names: tuple[str, ...] = ("torque",)
    input_units: tuple[str, ...] = ("N·m",)
    periodic_states: tuple[int, ...] = (0,)

    def state(self, obs: np.ndarray) -> np.ndarray:
        """[θ, ω] from the observation [cos θ, sin θ, ω] (θ = atan2, in (−π, π])."""
        o = np.asarray(obs, dtype=np.float64).reshape(-1)
        return np.array([np.arctan2(o[1], o[0]), o[2]])

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """[ω, 3g/(2l) sin θ + 3u/(m l²)] (rad/s, rad/s²)."""
        return np.array([x[1], 1.5 * self.g / self.length * np.sin(x[0])
                         + 3.0 / (self.m * self.length ** 2) * u[0]])


@dataclass(frozen=True, kw_only=True)
class MountainCarNominal(BaseNominalModel):
    """Nominal model of ``MountainCarContinuous-v0``: v̇ = power·u − hill·cos(3 p).

    Attributes:
        power: force gain per step, env 0.0015.
        hill: gravity term of the hill, env 0.0025.
        dt: one env step (the env has no time unit; 1 "s" = 1 step).
    """

    power: float = 0.0015
    hill: float = 0.0025
    dt: float = 1.0
    name: str = "mountain_car_continuous"
    state_names: tuple[str, ...] = ("position", "velocity")
    state_units: tuple[str, ...] = ("m", "m/s")
    input_names: tuple[str, ...] = ("force",)
    input_units: tuple[str, ...] = ("1",)

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """[v, power·u − hill·cos(3p)] per step."""
        return np.array([x[1], self.power * u[0] - self.hill * np.cos(3.0 * x[0])])
