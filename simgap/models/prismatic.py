"""A 1-DOF rigid axis: a mass on a prismatic joint or a rotor on a revolute joint.

The nominal model of a single driven axis with nothing but inertia::

    M ddq = u                      (M in kg and u in N, or M in kg·m² and u in N·m)

so ``M(q) = [[M]]`` and ``bias(q, dq) = 0``. It is the simplest
:class:`~simgap.models.base.MechanicalNominalModel`; the diagnosis computes the left-out
force by inverse dynamics, tau_d = u − M ddq, and names friction, offsets and springs
from there. Examples: the EMPS positioning axis (``examples/emps_model.py``), a motor with
a flywheel.

Like the manipulator (thesis eq. 2.3), the identifier state is x = (q, p) with momentum
p = M dq:

    dq/dt = p / M,   dp/dt = u           (nominal f)
    g(x, u) = (0, −tau_d)               (residual; M ddq + tau_d = u)

Recording columns (canonical names): ``t, q, dq, u``; ``dq`` may be absent, the diagnosis
then differentiates ``q``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simgap.models.base import OneDofMechanicalModel, validate_positive

#: Units of (position, velocity, effort, inertia, momentum) per joint kind.
JOINT_UNITS = {
    "prismatic": ("m", "m/s", "N", "kg", "kg·m/s"),
    "revolute": ("rad", "rad/s", "N·m", "kg·m²", "kg·m²/s"),
}


@dataclass(frozen=True, kw_only=True)
class RigidAxisParams:
    """Parameters of a 1-DOF rigid axis.

    Attributes:
        mass: moved mass (kg) for a prismatic joint, or inertia (kg·m²) for a revolute one.
        joint: ``"prismatic"`` (q in m, force in N) or ``"revolute"`` (q in rad, torque in
            N·m).
    """

    mass: float
    joint: str = "prismatic"

    def __post_init__(self) -> None:
        validate_positive("RigidAxisParams.mass", self.mass)
        if self.joint not in JOINT_UNITS:
            raise ValueError(f"RigidAxisParams.joint must be one of {sorted(JOINT_UNITS)}, "
                             f"got {self.joint!r}")


class RigidAxisNominal(OneDofMechanicalModel):
    """Nominal model of a 1-DOF rigid mass/rotor driven by a force/torque ``u``.

    Args:
        params: mass (or inertia) and joint kind.
        dt: step period (s) when the model is stepped in an env.
        channel: name of the joint in diagnosis reports (default ``"joint1"``).
        name: model name used in reports.
    """

    def __init__(self, params: RigidAxisParams, dt: float = 0.001, *, channel: str = "joint1",
                 name: str = "rigid_axis") -> None:
        validate_positive("dt", dt)
        if not isinstance(params, RigidAxisParams):
            raise TypeError(f"params must be RigidAxisParams, got {type(params).__name__}")
        if not channel or not isinstance(channel, str):
            raise ValueError(f"channel must be a non-empty string, got {channel!r}")
        self.params = params
        self.dt = float(dt)
        self.channel_names = (channel,)
        self.name = name
        pos, vel, eff, _, mom = JOINT_UNITS[params.joint]
        self.state_units = (pos, mom)
        self.obs_units = (pos, vel)
        self.input_units = (eff,)

    @property
    def joint_inertia(self) -> float:
        """M (kg, prismatic) or J (kg·m², revolute)."""
        return self.params.mass

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Return the nominal derivative (p/M, u), the 1-DOF case of thesis eq. 2.3 (rows ok)."""
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        return np.stack([x[..., 1] / self.params.mass, u[..., 0]], axis=-1)

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """No velocity or gravity terms: zeros shaped like dq (N or N·m)."""
        return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(dq)))
