"""A 1-DOF damped pendulum: a rigid body on a revolute joint under gravity, with damping.

The nominal model of a swinging rig (a pendulum released from a deflection, a door, a
hanging link)::

    J ddq + b dq + m g l sin q = u            (J in kg·m², b in N·m·s/rad, m g l in N·m)

so ``M(q) = [[J]]`` and ``bias(q, dq) = b dq + m g l sin q``. Its damping ``b`` is the
model's *own* per-joint term (:meth:`PendulumNominal.nominal_coefficients`): a diagnosis
may correct it either way ("the nominal damping is 15 % too high" is an answer), while a
Coulomb friction the model lacks can only be added.

Identifier state x = (q, p) with momentum p = J dq, as for the other mechanical models:

    dq/dt = p / J,   dp/dt = u − b p/J − m g l sin q

Recording columns (canonical names): ``t, q, dq, u``; ``dq`` may be absent, the diagnosis
then differentiates ``q``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simgap.models.base import OneDofMechanicalModel, validate_positive


@dataclass(frozen=True, kw_only=True)
class PendulumParams:
    """Parameters of a damped pendulum.

    Attributes:
        inertia: moment of inertia about the joint J (kg·m²).
        mgl: gravity torque amplitude m·g·l (N·m): the torque at q = π/2.
        damping: viscous damping b (N·m·s/rad), ≥ 0.
    """

    inertia: float = 0.05
    mgl: float = 1.0
    damping: float = 0.01

    def __post_init__(self) -> None:
        validate_positive("PendulumParams.inertia", self.inertia, "kg·m²")
        validate_positive("PendulumParams.mgl", self.mgl, "N·m")
        validate_positive("PendulumParams.damping", self.damping, "N·m·s/rad",
                          allow_zero=True)

    @property
    def natural_frequency(self) -> float:
        """Small-swing angular frequency sqrt(mgl / J) (rad/s)."""
        return float(np.sqrt(self.mgl / self.inertia))


class PendulumNominal(OneDofMechanicalModel):
    """Nominal model of a damped pendulum driven by a joint torque ``u``.

    Args:
        params: inertia, gravity torque and damping.
        dt: step period (s) when the model is stepped in an env.
        channel: name of the joint in diagnosis reports (default ``"joint1"``).
        name: model name used in reports.
    """

    state_units = ("rad", "kg·m²/s")
    obs_units = ("rad", "rad/s")
    input_units = ("N·m",)

    def __init__(self, params: PendulumParams | None = None, dt: float = 0.002, *,
                 channel: str = "joint1", name: str = "pendulum") -> None:
        validate_positive("dt", dt, "s")
        params = PendulumParams() if params is None else params
        if not isinstance(params, PendulumParams):
            raise TypeError(f"params must be PendulumParams, got {type(params).__name__}")
        self.params = params
        self.dt = float(dt)
        self.channel_names = (channel,)
        self.name = name

    @property
    def joint_inertia(self) -> float:
        """J (kg·m²)."""
        return self.params.inertia

    def nominal_coefficients(self) -> dict[str, tuple[float, ...]]:
        """The model's own per-joint passive terms: ``damping`` (N·m·s/rad)."""
        return {"damping": (float(self.params.damping),)}

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal derivative (p/J, u − b p/J − mgl sin q) (rows ok)."""
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        p = self.params
        dq = x[..., 1] / p.inertia
        return np.stack([dq, u[..., 0] - p.damping * dq - p.mgl * np.sin(x[..., 0])], axis=-1)

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Damping and gravity torque b dq + mgl sin q (N·m), shaped like dq."""
        p = self.params
        return p.damping * np.asarray(dq, dtype=np.float64) + \
            p.mgl * np.sin(np.asarray(q, dtype=np.float64))
