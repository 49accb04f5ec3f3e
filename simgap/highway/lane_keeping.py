"""``simgap/PacejkaLaneKeeping-v0``: highway-env's lane keeping with Magic Formula tires.

Differences from highway-env's ``lane-keeping-v0`` (:class:`LaneKeepingEnv`), all
configurable through ``config``:

* the ego vehicle is a :class:`~simgap.highway.vehicle.PacejkaBicycleVehicle` with road
  friction ``config["mu"]`` (-) and speed ``config["speed"]`` (m/s, highway-env: 8.3);
* highway-env's ``LaneKeepingEnv.step`` observes the state *before* simulating the step, so its
  observation lags the action by one step; here the observation is taken after the step, so
  (obs_k, action_k, obs_{k+1}) is a transition, as the identifier needs;
* simulation and policy frequency 100 Hz (highway-env: 10 Hz; the identifier's explicit
  Euler observer with A_d = −40·I needs Δt ≤ 0.05 s), no observation noise by default
  (highway-env: ``state_noise`` = ``derivative_noise`` = 0.05).

Observation: highway-env's ``AttributesObservation`` dict ``state`` = (y (m), ψ (rad),
vy (m/s), r (rad/s)) as (4, 1), ``derivative`` (4, 1), ``reference_state`` (4, 1). Action: one
value in [−1, 1] mapped linearly to the steering range ±π/3 rad. Reward: highway-env's
1 − (lateral offset / lane width)².

``env.unwrapped.nominal_model`` is a :class:`HighwayBicycleNominal`: the linear bicycle with
highway-env's own vehicle constants (mass, inertia, axle distances, cornering stiffness
2·FRICTION) at the configured speed, reading (vy, r) from ``obs["state"]`` and mapping the
action to (δ_f, δ_r = 0) rad. ``info`` carries ``residual_true`` (g = dx/dt − f(x, u) at the
pre-step state and the applied steering, m/s² and rad/s²), ``axle_force_residual_true``
(K⁻¹ g, N), ``mu`` and ``t`` (s).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from highway_env import utils
from highway_env.envs.lane_keeping_env import LaneKeepingEnv

from simgap.envs._common import check_action, check_reset
from simgap.highway.vehicle import PacejkaBicycleVehicle
from simgap.models.bicycle import BicycleNominal, BicycleParams
from simgap.models.tires import MagicFormulaTire


class HighwayBicycleNominal(BicycleNominal):
    """Linear bicycle (thesis eq. 2.7) with highway-env's vehicle constants.

    Args:
        vehicle: the vehicle whose constants (MASS, INERTIA_Z, LENGTH_A/B, FRICTION_*) are used.
        vx: longitudinal speed (m/s).
        dt: policy period (s).
        steering_range: (low, high) steering (rad) that actions −1 and 1 map to.
    """

    def __init__(self, vehicle: PacejkaBicycleVehicle, vx: float, dt: float,
                 steering_range: tuple[float, float]) -> None:
        c_f, c_r = vehicle.axle_stiffness
        params = BicycleParams(m=float(vehicle.MASS), Iz=float(vehicle.INERTIA_Z),
                               lf=float(vehicle.LENGTH_A), lr=float(vehicle.LENGTH_B),
                               C_af=c_f, C_ar=c_r, mu=float(vehicle.MU))
        super().__init__(params, vx=vx, dt=dt)
        self.steering_range = (float(steering_range[0]), float(steering_range[1]))

    def state(self, obs: Any) -> np.ndarray:
        """(vy, r) (m/s, rad/s) from the observation dict's ``state`` (or a (4,) array)."""
        s = obs["state"] if isinstance(obs, dict) else obs
        s = np.asarray(s, dtype=np.float64).reshape(-1)
        return s[2:4].copy()

    def input(self, action: Any) -> np.ndarray:
        """Map an action in [−1, 1] to (δ_f, 0) rad, as highway-env's ContinuousAction does."""
        a = float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], -1.0, 1.0))
        return np.array([float(utils.lmap(a, [-1, 1], list(self.steering_range))), 0.0])


class PacejkaLaneKeepingEnv(LaneKeepingEnv):
    """Lane keeping on saturating Magic Formula tires (see the module docstring)."""

    @classmethod
    def default_config(cls) -> dict:
        """highway-env's lane-keeping config plus ``mu``, ``speed``, ``tire_C``, ``tire_E``."""
        config = super().default_config()
        config.update({"simulation_frequency": 100, "policy_frequency": 100,
                       "state_noise": 0.0, "derivative_noise": 0.0, "mu": 1.0, "speed": 8.3,
                       "tire_C": 1.3, "tire_E": -0.5})
        return config

    def __init__(self, config: dict | None = None, render_mode: str | None = None) -> None:
        cfg = dict(config or {})
        mu, speed = cfg.get("mu", 1.0), cfg.get("speed", 8.3)
        if not (np.isfinite(mu) and mu > 0):
            raise ValueError(f"config['mu'] must be a positive friction coefficient, got {mu!r}")
        if not (np.isfinite(speed) and speed > 1):
            raise ValueError(f"config['speed'] must be a speed above 1 m/s, got {speed!r}")
        self.nominal_model: HighwayBicycleNominal | None = None
        super().__init__(cfg)  # LaneKeepingEnv.__init__ takes no render_mode
        self._was_reset = False  # highway-env resets inside __init__; the user has not
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or "
                             f"None, got {render_mode!r}")
        self.render_mode = render_mode
        self._build_nominal()

    def _build_nominal(self) -> None:
        freq = self.config["policy_frequency"]
        if self.config["simulation_frequency"] % freq:
            raise ValueError("simulation_frequency must be a multiple of policy_frequency")
        self.nominal_model = HighwayBicycleNominal(
            self.vehicle, vx=float(self.config["speed"]), dt=1.0 / freq,
            steering_range=tuple(self.action_type.steering_range))

    def _make_vehicles(self) -> None:
        lane = self.road.network.get_lane(("c", "d", 0))
        tire = MagicFormulaTire(C=float(self.config["tire_C"]), E=float(self.config["tire_E"]))
        ego = PacejkaBicycleVehicle(self.road, lane.position(50, -4),
                                    heading=lane.heading_at(0),
                                    speed=float(self.config["speed"]),
                                    mu=float(self.config["mu"]), tire=tire)
        self.road.vehicles.append(ego)
        self.vehicle = ego

    def _true_residual(self) -> np.ndarray:
        """G = dx/dt − f(x, u) (m/s², rad/s²) at the current state and stored action."""
        v = self.vehicle
        v.clip_actions()
        d = v.derivative_func(None, v.state)[4:6, 0]
        x = np.array([v.lateral_speed, v.yaw_rate], dtype=np.float64)
        u = np.array([float(v.action["steering"]), 0.0])
        return d - self.nominal_model.f(x, u)

    def reset(self, *, seed: int | None = None, options: dict | None = None
              ) -> tuple[Any, dict]:
        """highway-env reset, plus the residual at rest and the nominal model refreshed."""
        obs, info = super().reset(seed=seed, options=options)
        self._was_reset = True
        self._build_nominal()
        self.vehicle.act({"steering": 0.0, "acceleration": 0.0})
        g = self._true_residual()
        info.update(self._residual_info(g))
        return obs, info

    def _residual_info(self, g: np.ndarray) -> dict[str, Any]:
        return {"residual_true": g, "axle_force_residual_true": self.nominal_model.K_inv @ g,
                "mu": float(self.vehicle.MU), "t": float(self.steps) /
                float(self.config["simulation_frequency"])}

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict]:
        """Act, record the true residual, simulate, then observe (post-step state).

        Raises:
            EnvError: ``step`` before ``reset``, or an action that is not a finite float
                array of the action space's shape (the env does not advance).
        """
        check_reset(getattr(self, "_was_reset", False), "PacejkaLaneKeeping-v0")
        action = check_action(action, self.action_space.shape, "steering command in [-1, 1]")
        if self.lanes and not self.lane.on_lane(self.vehicle.position):
            self.lane = self.lanes.pop(0)
        self.store_data()
        self.action_type.act(action)
        g = self._true_residual()
        self._simulate()
        obs = self.observation_type.observe()
        reward = self._reward(action)
        info = self._residual_info(g)
        return obs, reward, self._is_terminated(), self._is_truncated(), info
