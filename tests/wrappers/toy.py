"""A user-defined env: a damped pendulum whose nominal model leaves out the damping."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from simgap.models.base import BaseNominalModel
from simgap.systems import SystemSpec, register_system


class PendulumNominal(BaseNominalModel):
    """Undamped pendulum, mass 1 kg, length 1 m: dθ/dt = ω, dω/dt = −g sin θ + τ."""

    name = "toy_pendulum"
    state_names = ("theta", "omega")
    state_units = ("rad", "rad/s")
    input_names = ("torque",)
    input_units = ("N·m",)
    dt = 0.01

    def f(self, x, u):
        return np.array([x[1], -9.81 * np.sin(x[0]) + u[0]])


# A user system: the wrappers take its identifier preset from the registry (Table 4.3's).
register_system(SystemSpec(name="toy_pendulum", identifier_preset="manipulator"), replace=True)


class DampedPendulumEnv(gym.Env):
    """Truth: the nominal pendulum plus viscous damping −b ω (RK4, 10 sub-steps)."""

    metadata = {"render_modes": []}

    def __init__(self, damping: float = 0.5, max_steps: int = 300):
        self.nominal_model = PendulumNominal()
        self.b = damping
        self.max_steps = max_steps
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(2,), dtype=np.float64)
        self.action_space = gym.spaces.Box(-2.0, 2.0, shape=(1,), dtype=np.float32)
        self._s = np.zeros(2)
        self._k = 0

    def _deriv(self, s, u):
        return np.array([s[1], -9.81 * np.sin(s[0]) + u - self.b * s[1]])

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._s = self.np_random.uniform(-1.0, 1.0, size=2)
        self._k = 0
        return self._s.copy(), {}

    def step(self, action):
        u = float(np.clip(action, -2.0, 2.0)[0])
        s, h = self._s, self.nominal_model.dt / 10
        for _ in range(10):
            k1 = self._deriv(s, u)
            k2 = self._deriv(s + h / 2 * k1, u)
            k3 = self._deriv(s + h / 2 * k2, u)
            k4 = self._deriv(s + h * k3, u)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        self._s = s
        self._k += 1
        info = {"residual_true": np.array([0.0, -self.b * s[1]])}
        return s.copy(), -float(s[0] ** 2), False, self._k >= self.max_steps, info
