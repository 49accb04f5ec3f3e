"""The nominal-model protocol: what any env must expose for simgap to work on it.

An env exposes ``env.unwrapped.nominal_model``: an object following :class:`NominalModel`.
That is all the :class:`~simgap.wrappers.IdentifierWrapper` and the diagnosis need, so a
user's own env works as soon as it provides one. The contract, in words:

* ``state_names`` / ``state_units``: names and SI units of the identifier state x (n entries).
* ``input_names`` / ``input_units``: names and SI units of the input u (m entries).
* ``dt``: the env's step period in seconds.
* ``state(obs)``: maps an observation to the identifier state x (e.g. joint velocities to
  momenta for the manipulator). Must accept a 1-D observation.
* ``f(x, u)``: the nominal state derivative dx/dt = f(x, u), in state units per second.

Optional, with defaults in :class:`BaseNominalModel`:

* ``input(action)``: maps an env action to the input u (default: identity).
* ``periodic_states``: indices of the state entries that are angles, read modulo 2π and
  kept in (−π, π] (default: none). The identifier's observer error on them is wrapped
  (:func:`wrap_angle`), not the raw difference: π − ε against −π + ε is an error of 2ε.
* ``residual_names`` / ``residual_units`` / ``physical_residual(x, g)``: express a state
  residual g (state units per second) as physical quantities, e.g. joint torques (N·m) or
  axle lateral forces (N). Default: g itself, named ``g_<state>``.

Example: a 1-DOF pendulum (mass 1 kg, length 1 m) that a user wraps::

    class PendulumNominal(BaseNominalModel):
        state_names = ("theta", "omega")
        state_units = ("rad", "rad/s")
        input_names = ("torque",)
        input_units = ("N·m",)
        dt = 0.01

        def f(self, x, u):
            return np.array([x[1], -9.81 * np.sin(x[0]) + u[0]])
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class NominalModel(Protocol):
    """Structural protocol for nominal models (see the module docstring)."""

    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]
    dt: float

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Map an observation to the identifier state x."""
        ...

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal state derivative dx/dt = f(x, u)."""
        ...


class BaseNominalModel:
    """Convenience base class giving the optional parts of the protocol their defaults.

    Subclasses set ``state_names``, ``state_units``, ``input_names``, ``input_units``,
    ``dt`` and implement :meth:`f`.
    """

    name: str = "custom"
    state_names: tuple[str, ...] = ()
    state_units: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    dt: float = 0.01
    #: Indices of angle states, wrapped to (−π, π] (see the module docstring).
    periodic_states: tuple[int, ...] = ()

    @property
    def n_states(self) -> int:
        """Number of identifier states n."""
        return len(self.state_names)

    @property
    def n_inputs(self) -> int:
        """Number of inputs m."""
        return len(self.input_names)

    @property
    def residual_names(self) -> tuple[str, ...]:
        """Names of the physical residual channels (default: one per state)."""
        return tuple(f"g_{s}" for s in self.state_names)

    @property
    def residual_units(self) -> tuple[str, ...]:
        """SI units of the physical residual channels (default: state units per second)."""
        return tuple(f"({u})/s" for u in self.state_units)

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Map an observation to the identifier state x (default: identity)."""
        return np.asarray(obs, dtype=np.float64)

    def input(self, action: np.ndarray) -> np.ndarray:
        """Map an env action to the model input u (default: identity)."""
        return np.asarray(action, dtype=np.float64)

    # Row-batched forms for vector envs (``VectorIdentifierWrapper``); models with kernels
    # override them with one call, these defaults loop over the rows.
    def states(self, obs: np.ndarray) -> np.ndarray:
        """:meth:`state` of every row of ``obs`` (N, …), shape (N, n)."""
        return np.stack([np.asarray(self.state(o), dtype=np.float64).reshape(-1) for o in obs])

    def inputs(self, actions: np.ndarray) -> np.ndarray:
        """:meth:`input` of every row of ``actions`` (N, …), shape (N, m)."""
        if type(self).input is BaseNominalModel.input:
            return np.array(actions, dtype=np.float64).reshape(len(actions), -1)
        return np.stack([np.asarray(self.input(a), dtype=np.float64).reshape(-1)
                         for a in actions])

    def f_rows(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """:meth:`f` of every row of x (N, n), u (N, m), shape (N, n)."""
        return np.stack([np.asarray(self.f(xi, ui), dtype=np.float64).reshape(-1)
                         for xi, ui in zip(x, u, strict=True)])

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal state derivative dx/dt = f(x, u); subclasses implement it."""
        raise NotImplementedError

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Express a state residual g as physical channels (default: g itself)."""
        return np.asarray(g, dtype=np.float64)


class MechanicalNominalModel(BaseNominalModel):
    """A nominal model of a mechanical system M(q) ddq + bias(q, dq) = tau.

    Subclasses implement :meth:`M` and :meth:`bias`; inverse dynamics follow, which is how
    the diagnosis turns a recording into joint-torque residuals (N·m).
    """

    def M(self, q: np.ndarray) -> np.ndarray:  # noqa: N802 - the physics name
        """Mass matrix M(q) (SI: kg·m² for revolute, kg for prismatic joints)."""
        raise NotImplementedError

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Velocity and gravity terms C(q, dq) dq + G(q) (N·m or N)."""
        raise NotImplementedError

    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Torque the nominal model needs for the given motion: M(q) ddq + bias(q, dq)."""
        return self.M(q) @ ddq + self.bias(q, dq)


class OneDofMechanicalModel(MechanicalNominalModel):
    """A 1-DOF mechanical nominal model with constant inertia and momentum state.

    Identifier state x = (q, p) with p = J dq, J the constant inertia (kg·m²) or mass (kg)
    that subclasses return from :attr:`joint_inertia`; they implement :meth:`bias` and
    :meth:`f`. What follows from J alone is written here once.
    """

    recording_columns = ("t", "q", "dq", "u")
    #: Recording columns the diagnosis may derive when absent (velocity from position).
    derivable_columns = ("dq",)
    obs_names = ("q", "dq")
    input_names = ("u",)
    state_names = ("q", "p")

    #: What subclasses set in ``__init__`` (read by :meth:`__repr__` and the units below).
    params: Any
    dt: float
    channel_names: tuple[str]
    name: str

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(params={self.params!r}, dt={self.dt}, "
                f"channel={self.channel_names[0]!r}, name={self.name!r})")

    @property
    def joint_inertia(self) -> float:
        """The constant inertia J (kg·m², revolute) or mass (kg, prismatic)."""
        raise NotImplementedError

    @property
    def position_units(self) -> tuple[str, ...]:
        """Unit of q (m or rad): the observation's first unit."""
        return (self.obs_units[0],)

    @property
    def velocity_units(self) -> tuple[str, ...]:
        """Unit of dq (m/s or rad/s): the observation's second unit."""
        return (self.obs_units[1],)

    @property
    def residual_names(self) -> tuple[str, ...]:
        """Left-out force/torque at the joint."""
        return ("tau_d1",)

    @property
    def residual_units(self) -> tuple[str, ...]:
        """The input's unit: N (prismatic) or N·m (revolute)."""
        return self.input_units

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Observation (q, dq) → identifier state (q, p = J dq)."""
        out = np.array(obs, dtype=np.float64)
        out[..., 1] = self.joint_inertia * out[..., 1]
        return out

    def observation(self, x: np.ndarray) -> np.ndarray:
        """Identifier state (q, p) → observation (q, dq = p / J)."""
        out = np.array(x, dtype=np.float64)
        out[..., 1] = out[..., 1] / self.joint_inertia
        return out

    def M(self, q: np.ndarray) -> np.ndarray:  # noqa: N802 - the physics name
        """Mass matrix [[J]] (kg·m² or kg); for q of shape (..., 1) returns (..., 1, 1)."""
        q = np.asarray(q, dtype=np.float64)
        return np.full(q.shape[:-1] + (1, 1), self.joint_inertia)

    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Force/torque the nominal needs for the motion: J ddq + bias (N or N·m); rows ok."""
        return self.joint_inertia * np.asarray(ddq, dtype=np.float64) + self.bias(q, dq)

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """State residual g (…, 2) → left-out force/torque tau_d = −g[1:] (N or N·m)."""
        return -np.asarray(g, dtype=np.float64)[..., 1:]


def wrap_angle(a: np.ndarray | float) -> np.ndarray | float:
    """Angle(s) ``a`` (rad) mapped to (−π, π]: a − 2π k for the one integer k that fits."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def validate_positive(name: str, value: object, unit: str = "", *,
                      allow_zero: bool = False) -> float:
    """Return ``value`` as a float if it is a finite positive (or non-negative) number.

    Args:
        name: argument name used in the message.
        value: the value to check.
        unit: its SI unit, named in the message (optional).
        allow_zero: accept 0.

    Raises:
        ValueError: naming the argument, its unit and the bad value.
    """
    what = f" ({unit})" if unit else ""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number{what}, got {value!r}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number{what}, got {value!r}")
    return v
