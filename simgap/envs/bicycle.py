"""``simgap/BicycleTire-v0``: single-track lateral dynamics with saturating tires (Sec. 4.4.1).

The truth is the bicycle of ``spec/models.md`` with Magic Formula axle forces (road friction
``mu``), optionally with tire relaxation, steering lag and constant biases; the nominal model
(``env.unwrapped.nominal_model``) is the linear-tire bicycle (thesis eq. 2.7). The thesis' truth
was IPG CarMaker with Pacejka 5.2 tires, which is not available: this env is a stand-in whose
residual is known exactly. All physics is in :mod:`simgap.models.bicycle`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit

from simgap.envs._common import (
    check_count,
    check_pair,
    check_render_mode,
    state_option,
)
from simgap.envs.base import PlantEnv
from simgap.envs.scenarios import YawRateReference
from simgap.errors import EnvError
from simgap.models.base import validate_positive
from simgap.models.bicycle import (
    PLANT_SCHEMA,
    BicycleNominal,
    BicycleParams,
    check_vx,
    has_steering_lag,
    make_plant,
    plant_forces,
    plant_step,
    slip_angles,
    true_residual_vs,
)
from simgap.models.effects import Plant
from simgap.models.nbcache import guard_cache
from simgap.models.tires import MagicFormulaTire

TIRE_MODELS = ("magic_formula", "linear")


@njit(cache=True, inline="always")
def tracking_outcome(vy, r, r_ref, vy_max):  # pragma: no cover - compiled
    """Reward −(r − r_ref)² ((rad/s)²) and termination after a step to (vy, r).

    The episode ends where |vy| > vy_max (m/s) or the yaw rate is not finite. The one
    formula of the single env (through ``py_func``, Python floats) and the native vector
    env's kernel (compiled): the same IEEE operations, the same bits.
    """
    err = r - r_ref
    return -(err * err), not (abs(vy) <= vy_max and math.isfinite(r))


_outcome = tracking_outcome.py_func  # the env's step: no dispatch per call


def _resolve_tire(tire: str | MagicFormulaTire | None) -> MagicFormulaTire | None:
    if isinstance(tire, MagicFormulaTire):
        return tire
    if tire == "magic_formula":
        return MagicFormulaTire()
    if tire == "linear" or tire is None:
        return None
    raise ValueError(f"unknown tire model {tire!r}; choose one of {list(TIRE_MODELS)} "
                     f"or pass a MagicFormulaTire")


class BicycleTireEnv(PlantEnv):
    """Single-track vehicle at constant speed tracking a yaw-rate reference.

    * Observation (vy, r): lateral velocity at the CG (m/s) and yaw rate (rad/s), float64.
    * Action (delta_f, delta_r): front and rear road-wheel steering angles (rad), Box
      [−steer_limit, steer_limit]. Finite actions outside are clipped (the clipped angle is
      what acts and what ``residual_true`` uses); NaN/inf raise ``ValueError`` and leave the
      state unchanged.
    * Step: zero-order hold for ``dt`` s, ``n_substeps`` RK4 sub-steps.
    * Reward: −(r − r_ref)² (rad²/s²) at the time after the step.
    * Termination: |sideslip| = |atan(vy/vx)| above ``max_sideslip`` (rad; the car is
      spinning out and the single-track model no longer holds) or a non-finite state. The bare
      env never truncates; ``gym.make`` adds a 3,500-step (35 s) ``TimeLimit``.
    * Reset: straight running, vy = r = 0, steering and slip lags at rest;
      ``options={"state": (vy, r)}`` starts elsewhere.

    ``info`` (every step and at reset): ``"t"`` time after the step (s); ``"r_ref"`` the
    reference yaw rate then (rad/s); ``"residual_true"`` the true g(x_k, u_k) (2,) of this
    transition (m/s², rad/s²) against the nominal model; ``"axle_force_residual_true"`` and
    ``"physical_residual_true"`` the axle-force deviations (Delta_f, Delta_r) = K_nom⁻¹ g (N).
    ``"applied_action"`` the steering command after clipping (rad; zeros at reset). At reset
    the residual is evaluated at the initial state with zero steering.

    The plant is one :class:`~simgap.models.effects.Plant` (``env.unwrapped.plant``): pass
    ``plant=`` directly, or the keyword sugar below (``mu``, ``tire``, ``relaxation_length``,
    ``steering_lag``, ``lateral_bias``, ``yaw_bias``, ``true_params``), which is turned into
    named effect instances. ``mu``, ``tire``, ``true_params`` and ``plant_theta`` are
    read-only views of it; change the truth with ``env.plant = env.plant.with_effect(...)``.

    Args:
        render_mode: ``None`` or ``"rgb_array"`` (top view with axle force arrows).
        plant: the truth as a bicycle ``Plant`` (its ``vx`` option is the env's speed);
            excludes the plant keywords below.
        vx: constant longitudinal speed (m/s), > 1 (default 20, or the plant's).
        mu: road friction of the truth tires (-); ``None`` keeps ``true_params.mu`` (1.0 by
            default). A given value overrides ``true_params.mu``.
        tire: ``"magic_formula"`` (spec defaults C = 1.3, E = −0.5), ``"linear"`` (truth equals
            the nominal tire), or a :class:`MagicFormulaTire`.
        relaxation_length: tire relaxation length (m), scalar or (front, rear); 0 = off.
        steering_lag: first-order lag of the road-wheel angle behind the command (s); 0 = off.
        lateral_bias: constant lateral acceleration on the body (m/s²), e.g. road bank.
        yaw_bias: constant yaw acceleration (rad/s²).
        true_params: the truth vehicle (default: the spec's sedan).
        nominal_params: the nominal model's vehicle (default: the spec's sedan).
        dt: step period (s), 0.01 in the thesis.
        n_substeps: RK4 sub-steps per step.
        reference: callable t (s) → r_ref (rad/s); default :class:`YawRateReference`.
        steer_limit: action bound (rad), scalar or per axle.
        max_sideslip: sideslip bound (rad) in (0, π/2).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}
    plant_schema = PLANT_SCHEMA

    def __init__(self, render_mode: str | None = None, *, plant: Plant | None = None,
                 vx: float | None = None,
                 mu: float | None = None,
                 tire: str | MagicFormulaTire = "magic_formula",
                 relaxation_length: float | tuple[float, float] = 0.0,
                 steering_lag: float = 0.0, lateral_bias: float = 0.0, yaw_bias: float = 0.0,
                 true_params: BicycleParams | None = None,
                 nominal_params: BicycleParams | None = None,
                 dt: float = 0.01, n_substeps: int = 4,
                 reference: Callable[[float], float] | None = None,
                 steer_limit: float | tuple[float, float] = 0.5,
                 max_sideslip: float = 0.35) -> None:
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        if plant is not None and (not isinstance(plant, Plant)
                                  or plant.schema is not PLANT_SCHEMA):
            raise EnvError(f"plant must be a bicycle Plant, got {plant!r}")
        self.vx = check_vx(vx if vx is not None else
                           plant.options["vx"] if plant is not None else 20.0)
        self.dt = validate_positive("dt", dt, "s")
        self.n_substeps = check_count("n_substeps", n_substeps)
        self.steer_limit = check_pair("steer_limit", steer_limit, "rad")
        self.max_sideslip = validate_positive("max_sideslip", max_sideslip, "rad")
        if self.max_sideslip >= math.pi / 2:
            raise ValueError(f"max_sideslip must be below pi/2 rad, got {max_sideslip!r}")
        for name, p in (("true_params", true_params), ("nominal_params", nominal_params)):
            if p is not None and not isinstance(p, BicycleParams):
                raise ValueError(f"{name} must be BicycleParams or None, got {p!r}")
        self.nominal_params = nominal_params if nominal_params is not None else BicycleParams()
        if plant is not None:
            given = (mu, tire, relaxation_length, steering_lag, lateral_bias, yaw_bias,
                     true_params)
            if given != (None, "magic_formula", 0.0, 0.0, 0.0, 0.0, None):
                raise EnvError("give either plant= or the plant keywords (mu, tire, "
                               "relaxation_length, steering_lag, lateral_bias, yaw_bias, "
                               "true_params)")
        else:
            truth = true_params if true_params is not None else BicycleParams()
            if mu is not None:
                truth = replace(truth, mu=validate_positive("mu", mu, "-"))
            for name, v in (("lateral_bias", lateral_bias), ("yaw_bias", yaw_bias)):
                if not math.isfinite(float(v)):
                    raise ValueError(f"{name} must be finite, got {v!r}")
            plant = make_plant(truth, self.vx, tire=_resolve_tire(tire),
                               relaxation_length=relaxation_length, steering_lag=steering_lag,
                               lateral_bias=float(lateral_bias), yaw_bias=float(yaw_bias))
        self.plant = plant
        self.reference = reference if reference is not None else YawRateReference()
        if not callable(self.reference):
            raise ValueError(f"reference must be a callable t -> r_ref (rad/s), got {reference!r}")
        self.nominal_model = BicycleNominal(self.nominal_params, vx=self.vx, dt=self.dt)

        self._theta_nom = np.concatenate([self.nominal_params.array, [self.vx]])
        self._k_inv = np.ascontiguousarray(self.nominal_model.K_inv)
        self._vy_max = self.vx * math.tan(self.max_sideslip)
        # plant state (vy, r, alpha_f_lag, alpha_r_lag, delta_f_act, delta_r_act) in m/s,
        # rad/s, rad, rad, rad, rad
        self._init_plant(2, 6, -self.steer_limit, self.steer_limit.copy())

    def _info(self, g: np.ndarray, t: float, r_ref: float, u: np.ndarray) -> dict[str, Any]:
        delta = self.nominal_model.physical_residual(None, g)
        return {"t": t, "r_ref": r_ref, "residual_true": g,
                "axle_force_residual_true": delta, "physical_residual_true": delta.copy(),
                "applied_action": u}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Straight running (or ``options["state"]`` = (vy, r)), steering at rest."""
        super().reset(seed=seed)
        self._k = 0
        s = np.zeros(6)
        x = state_option(options, 2, "vy m/s, r rad/s")
        if x is not None:
            s[:2] = x
            # relaxation lags start at the steady-state slip of that motion (zero steering)
            s[2], s[3] = slip_angles(x[0], x[1], 0.0, 0.0, self.vx, self.true_params.lf,
                                     self.true_params.lr)
        self._s = s
        self._last_u = np.zeros(2)
        g = true_residual_vs(s, self._zero_u, self._theta, self._theta_nom)
        return s[:2].copy(), self._info(g, 0.0, float(self.reference(0.0)), self._zero_u.copy())

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply road-wheel angles (rad) for dt seconds."""
        u = self._action(action, "steering angles (rad)")
        s = self._s
        g = true_residual_vs(s, u, self._theta, self._theta_nom)
        s_new = plant_step(s, u, self._theta, self.dt, self.n_substeps)
        self._s = s_new
        self._last_u = u
        self._k += 1
        t = self._k * self.dt
        r_ref = float(self.reference(t))
        vy, r = s_new[:2].tolist()
        reward, terminated = _outcome(vy, r, r_ref, self._vy_max)
        return s_new[:2].copy(), reward, terminated, False, self._info(g, t, r_ref, u)

    def _make_renderer(self) -> Any:
        from simgap.envs.rendering import CarRenderer

        return CarRenderer(self.true_params.lf, self.true_params.lr)

    def _draw(self) -> np.ndarray:
        """Top view with true (red) and linear (gray) axle forces."""
        fyf, fyr, af, ar = plant_forces(self._s, self._last_u, self._theta)
        p = self.nominal_params
        delta = self._s[4:6] if has_steering_lag(self._theta) else self._last_u
        return self._renderer.draw(self.vx, self._s[0], self._s[1], delta,
                                   np.array([fyf, fyr]), np.array([p.C_af * af, p.C_ar * ar]),
                                   self.t)

    def _check_plant(self, plant: Plant) -> None:
        if plant.options["vx"] != self.vx:
            raise EnvError(f"the plant's vx = {plant.options['vx']!r} m/s differs from the env's "
                           f"{self.vx!r} m/s; the speed is fixed per env")

    @property
    def mu(self) -> float:
        """Road friction μ of the truth (-), read-only view of :attr:`plant`.

        The μ both axles share (``true_params.mu``; with linear tires the parameter no tire
        reads). Where the axles differ (``tire_saturation`` per axle, or on one axle only)
        there is no one μ: read :attr:`mu_axles`.

        Raises:
            EnvError: the axles' road friction differs.
        """
        front, rear = self.mu_axles
        if front != rear:
            raise EnvError(f"the truth's road friction differs per axle (front {front}, rear "
                           f"{rear}; None = linear tire): read env.unwrapped.mu_axles")
        return self._plant.true_params.mu

    @property
    def mu_axles(self) -> tuple[float | None, float | None]:
        """(front, rear) road friction μ (-) of the truth's tires; ``None``: linear tire there.

        Read-only view of :attr:`plant` (the kernel's ``mu_f`` / ``mu_r``).
        """
        return self._plant.folded.extras["axle_mu"]

    @property
    def tire(self) -> MagicFormulaTire | None:
        """The truth's Magic-Formula shape, ``None`` for linear tires (view of :attr:`plant`)."""
        return self._plant.folded.extras["tire"]


guard_cache(globals())  # drop cached kernels when a module they compile in changes
