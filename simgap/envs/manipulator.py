"""``simgap/ManipulatorFriction-v0``: the thesis' 2-DOF arm with joint friction (Sec. 4.3.1).

The plant is the rigid body of ``spec/models.md`` (``true_params``) plus a left-out joint
torque tau_d: friction (default thesis eq. 4.7 with Table 4.2 values) and an optional
:class:`~simgap.models.manipulator.JointDisturbance`. The nominal model
(``env.unwrapped.nominal_model``) is the rigid body with ``nominal_params`` and no tau_d.
All physics is in :mod:`simgap.models.manipulator`; ``step`` only calls its kernels.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial
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
from simgap.envs.scenarios import QuinticReference, _sample_reference
from simgap.errors import EnvError
from simgap.models.base import validate_positive
from simgap.models.effects import Plant
from simgap.models.friction import FrictionParams, resolve_friction
from simgap.models.manipulator import (
    PLANT_SCHEMA,
    JointDisturbance,
    ManipulatorNominal,
    ManipulatorParams,
    make_plant,
    tau_d,
    transition,
    true_residual,
)
from simgap.models.nbcache import guard_cache

FRICTION_DEFAULT = resolve_friction("thesis")


@njit(cache=True, inline="always")
def tracking_outcome(q1, q2, dq1, dq2, ref1, ref2, max_speed):  # pragma: no cover - compiled
    """Reward −|q − q_ref|² (rad²) and termination after a step to (q1, q2, dq1, dq2).

    The episode ends where a joint speed exceeds ``max_speed`` (rad/s) or an angle is not
    finite. The one formula of the single env (through ``py_func``, Python floats) and the
    native vector env's kernel (compiled): the same IEEE operations, the same bits.
    """
    e1 = q1 - ref1
    e2 = q2 - ref2
    return -(e1 * e1 + e2 * e2), not (abs(dq1) <= max_speed and abs(dq2) <= max_speed
                                      and math.isfinite(q1) and math.isfinite(q2))


_outcome = tracking_outcome.py_func  # the env's step: no dispatch per call

class ManipulatorFrictionEnv(PlantEnv):
    """Two-link arm in a vertical plane tracking a joint reference, with unmodelled friction.

    * Observation (q1, q2, dq1, dq2) in rad, rad, rad/s, rad/s (float64, unbounded Box).
    * Action: joint torques (tau1, tau2) in N·m, Box [−torque_limit, torque_limit]. Finite
      actions outside the box are clipped (the clipped torque is what acts and what
      ``residual_true`` uses); NaN/inf raise ``ValueError`` and leave the state unchanged.
    * Step: zero-order hold of the torque for ``dt`` s, integrated with ``n_substeps`` RK4
      sub-steps (20 × 0.1 ms by default; the stiff tanh friction needs them, see the errata).
    * Reward: −‖q − q_d‖² (rad²) at the time after the step.
    * Termination: a joint speed above ``max_speed`` (rad/s) or a non-finite state. The bare env
      never truncates; ``gym.make`` adds a 5,000-step (10 s) ``TimeLimit``.
    * Reset: q = q_d(0) + U(−init_noise, init_noise) per joint (from ``self.np_random``),
      dq = dq_d(0). The thesis says "initial joint positions and velocities are set to zero",
      which conflicts with its q_d(0) = (π/4, π/2) (errata): we start on the reference.
      ``options={"state": (q1, q2, dq1, dq2)}`` starts elsewhere (noise is then not added).

    ``info`` (every step and at reset):

    * ``"t"``: time after the step (s), exactly k·dt.
    * ``"reference"``: (q_d, dq_d, ddq_d) at that time, shape (6,) (rad, rad/s, rad/s²).
    * ``"residual_true"``: the true g(x_k, u_k) (4,) of this transition in the identifier
      state (q, p) of the nominal model (thesis eq. 2.3): (0, 0, −tau_d) when the rigid body is
      the nominal one (units rad/s, rad/s, N·m, N·m). At reset: at the initial state with u = 0.
    * ``"physical_residual_true"``: tau_d (N·m, (2,)) at the pre-step state.
    * ``"applied_action"``: the torque that acted (N·m, (2,)), i.e. the action after clipping
      (zeros at reset). Identifiers should use it as u when actions may leave the box.

    The plant is one :class:`~simgap.models.effects.Plant` (``env.unwrapped.plant``): pass
    ``plant=`` directly, or the keyword sugar ``friction``, ``disturbance``, ``true_params``,
    which is turned into named effect instances. ``true_params``, ``friction``,
    ``disturbance`` and ``plant_theta`` are read-only views of it.

    Args:
        render_mode: ``None`` or ``"rgb_array"`` (side view of the arm and its reference).
        plant: the truth as a manipulator ``Plant``; excludes ``friction``, ``disturbance``
            and ``true_params``.
        friction: preset name (``"thesis"``, ``"coulomb"``, ``"viscous"``, ``"stribeck"``,
            ``"none"``), a :class:`FrictionParams`, or ``None`` (no friction).
        disturbance: extra joint bias/spring torques of the plant.
        true_params: the plant's rigid body (default: ``nominal_params``).
        nominal_params: the nominal model's parameters (default: thesis Table 4.2).
        dt: step period (s), 0.002 (500 Hz) in the thesis.
        n_substeps: RK4 sub-steps per step.
        reference: joint reference with ``sample(t)`` or a callable t → (q_d, dq_d, ddq_d)
            (default :class:`QuinticReference`).
        torque_limit: symmetric action bound (N·m), scalar or per joint.
        init_noise: half-width of the uniform noise on q at reset (rad).
        max_speed: joint-speed bound beyond which the episode terminates (rad/s).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}
    plant_schema = PLANT_SCHEMA

    def __init__(self, render_mode: str | None = None, *, plant: Plant | None = None,
                 friction: str | FrictionParams | None = "thesis",
                 disturbance: JointDisturbance | None = None,
                 true_params: ManipulatorParams | None = None,
                 nominal_params: ManipulatorParams | None = None,
                 dt: float = 0.002, n_substeps: int = 20,
                 reference: Callable | None = None,
                 torque_limit: float | tuple[float, float] = 50.0,
                 init_noise: float = 0.0, max_speed: float = 100.0) -> None:
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        self.dt = validate_positive("dt", dt, "s")
        self.n_substeps = check_count("n_substeps", n_substeps)
        self.torque_limit = check_pair("torque_limit", torque_limit, "N·m")
        self.init_noise = validate_positive("init_noise", init_noise, "rad", allow_zero=True)
        self.max_speed = validate_positive("max_speed", max_speed, "rad/s")
        friction = resolve_friction(friction)
        if disturbance is not None and not isinstance(disturbance, JointDisturbance):
            raise ValueError(f"disturbance must be a JointDisturbance or None, got "
                             f"{disturbance!r}")
        for name, p in (("true_params", true_params), ("nominal_params", nominal_params)):
            if p is not None and not isinstance(p, ManipulatorParams):
                raise ValueError(f"{name} must be ManipulatorParams or None, got {p!r}")
        self.nominal_params = nominal_params if nominal_params is not None \
            else ManipulatorParams()
        if plant is not None:
            if (friction, disturbance, true_params) != (FRICTION_DEFAULT, None, None):
                raise EnvError("give either plant= or friction/disturbance/true_params")
        else:
            plant = make_plant(true_params if true_params is not None else self.nominal_params,
                               friction=friction, disturbance=disturbance)
        self.plant = plant
        self.reference = reference if reference is not None else QuinticReference()
        if not callable(self.reference) and not hasattr(self.reference, "sample"):
            raise ValueError(f"reference must be callable, got {reference!r}")
        self.nominal_model = ManipulatorNominal(self.nominal_params, dt=self.dt)

        # Precomputed kernel arrays (the hot path allocates nothing it does not return).
        self._la_nom = np.ascontiguousarray(self.nominal_params.array)
        self._la_nom_params = tuple(self._la_nom.tolist())  # for the step kernel
        sample = getattr(self.reference, "sample", None)
        self._ref_sample = sample if sample is not None \
            else partial(_sample_reference, self.reference)

        # plant state s = (q1, q2, dq1, dq2) (rad, rad/s)
        self._init_plant(4, 4, -self.torque_limit, self.torque_limit.copy())

    def _info(self, g: np.ndarray, tau: np.ndarray, t: float, ref: np.ndarray,
              u: np.ndarray) -> dict[str, Any]:
        return {"t": t, "reference": ref, "residual_true": g, "physical_residual_true": tau,
                "applied_action": u}

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start on the reference (see the class docstring); ``options["state"]`` overrides."""
        super().reset(seed=seed)
        self._k = 0
        ref = np.asarray(self._ref_sample(0.0), dtype=np.float64)
        s = state_option(options, 4, "q1, q2, dq1, dq2")
        if s is not None:
            self._s = s
        else:
            q = ref[0:2] + self.np_random.uniform(-self.init_noise, self.init_noise, size=2)
            self._s = np.concatenate([q, ref[2:4]])
        self._last_u = np.zeros(2)
        s = self._s
        g = true_residual(s, self._zero_u, self._theta, self._la_nom)
        tau = tau_d(s[:2], s[2:], self._theta)
        return s.copy(), self._info(g, tau, 0.0, ref, self._zero_u.copy())

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply joint torques (N·m) for dt seconds."""
        u = self._action(action, "joint torques (N·m)")
        s_new, g, tau = transition(self._s, u, self._theta_params, self._la_nom_params,
                                   self.dt, self.n_substeps)
        self._s = s_new
        self._last_u = u
        self._k += 1
        t = self._k * self.dt
        ref = self._ref_sample(t)
        q1, q2, dq1, dq2 = s_new.tolist()
        reward, terminated = _outcome(q1, q2, dq1, dq2, float(ref[0]), float(ref[1]),
                                      self.max_speed)
        return s_new.copy(), reward, terminated, False, self._info(g, tau, t, ref, u)

    def _make_renderer(self) -> Any:
        from simgap.envs.rendering import ArmRenderer

        return ArmRenderer(self.true_params.l, self.true_params.l)

    def _draw(self) -> np.ndarray:
        """Side view of the arm (blue) and its reference (gray)."""
        ref = np.asarray(self._ref_sample(self.t), dtype=np.float64)
        return self._renderer.draw(self._s[:2], ref[:2], self.t, self._last_u)

    def _check_plant(self, plant: Plant) -> None:
        if plant.has("input_delay"):
            raise EnvError("the env does not simulate an input_delay (a transport delay of "
                           "the command); simgap record / diagnosis.generate does")
        if plant.has("dead_zone"):
            raise EnvError("the env does not simulate an actuator dead_zone; simgap record "
                           "/ diagnosis.generate does")

    @property
    def friction(self) -> FrictionParams:
        """The plant's joint friction (read-only view of :attr:`plant`)."""
        return self._plant.folded.extras["friction"]

    @property
    def disturbance(self) -> JointDisturbance:
        """The plant's joint bias/spring torques (read-only view of :attr:`plant`)."""
        return self._plant.folded.extras["disturbance"]


guard_cache(globals())  # drop cached kernels when a module they compile in changes
