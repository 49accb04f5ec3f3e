"""2-DOF planar manipulator in a vertical plane (``spec/models.md``, thesis eq. 2.2-2.3).

Joint angles q = (q1, q2) in rad: q1 from the horizontal x-axis to link 1, q2 relative to
link 1; gravity along -y. Rigid-body terms M(q), C(q, dq), G(q) are numba kernels over a
flat link array (see :attr:`ManipulatorParams.array`). Two state forms are used:

* simulation state s = (q1, q2, dq1, dq2) (rad, rad/s): what the env integrates;
* identifier state x = (q1, q2, p1, p2) with p = M(q) dq (kg·m²/s), thesis eq. 2.3:

      dq/dt = M⁻¹ p,   dp/dt = Cᵀ dq − G + u          (nominal f)
      g(x, u) = (0, 0, −tau_d)                        (residual)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numba import njit

from simgap.models import friction as fr
from simgap.models.base import MechanicalNominalModel, validate_positive
from simgap.models.effects import (
    EffectInstance,
    EffectSpec,
    FitSpec,
    Folded,
    Param,
    Plant,
    PlantSchema,
    channel_index,
    on_channel,
    stderr_of,
)
from simgap.models.friction import FRICTION_FIELDS, FrictionParams, joint_friction
from simgap.models.integrators import rk4_combine, rk4_stage
from simgap.models.nbcache import guard_cache
from simgap.models.slots import Slots

#: Layout of :attr:`ManipulatorParams.array`.
LINK_FIELDS = ("m1", "lc1", "I1", "m2", "lc2", "I2", "l1", "Im1", "Im2", "g")
STATE_NAMES = ("q1", "q2", "p1", "p2")
STATE_UNITS = ("rad", "rad", "kg·m²/s", "kg·m²/s")
OBS_NAMES = ("q1", "q2", "dq1", "dq2")
OBS_UNITS = ("rad", "rad", "rad/s", "rad/s")
INPUT_NAMES = ("tau1", "tau2")
INPUT_UNITS = ("N·m", "N·m")
RECORDING_COLUMNS = ("t", "q1", "q2", "dq1", "dq2", "tau1", "tau2")
N_JOINTS = 2
#: Per-joint bias/spring fields of :attr:`JointDisturbance.array`
#: (tau0 + k·(q − q0) + k3·q³).
DISTURBANCE_FIELDS = ("tau0", "k", "q0", "k3")
#: Layout of the plant array: link parameters, per-joint friction rows, per-joint
#: bias/spring rows. Every kernel slot below is generated from these names.
LINK = Slots(*LINK_FIELDS)
PLANT = Slots(*LINK_FIELDS, ("friction", FRICTION_FIELDS, N_JOINTS),
              ("disturbance", DISTURBANCE_FIELDS, N_JOINTS))
assert LINK.prefix_of(PLANT)
M1, LC1, I1, M2, LC2, I2, L1, IM1, IM2, G = (LINK[n] for n in LINK_FIELDS)
FRICTION, FRICTION_STRIDE = PLANT["friction"], PLANT.stride("friction")
DISTURBANCE, DISTURBANCE_STRIDE = PLANT["disturbance"], PLANT.stride("disturbance")
TAU0, K, Q0, K3 = (PLANT.field("disturbance", n) for n in DISTURBANCE_FIELDS)


@dataclass(frozen=True, kw_only=True)
class ManipulatorParams:
    """Physical parameters of the two-link arm (defaults: thesis Table 4.2).

    Attributes:
        m: link mass, both links (kg).
        l: link length (m).
        lc: joint-to-centre-of-mass distance (m).
        I: link inertia about its centre of mass (kg·m²).
        Im: motor rotor inertia added to each diagonal entry of M (kg·m²).
        g: gravitational acceleration (m/s²).
        payload: point mass at the tip of link 2 (kg). Not part of the nominal model; used
            to build "true" plants that differ from it.
        extra_inertia: extra inertia on each joint's diagonal of M (kg·m²); likewise 0 in the
            nominal model.
    """

    m: float = 2.465
    l: float = 0.2  # noqa: E741 - the spec's name
    lc: float = 0.13888
    I: float = 0.06911  # noqa: E741 - the spec's name
    Im: float = 0.008118
    g: float = 9.81
    payload: float = 0.0
    extra_inertia: tuple[float, float] = field(default=(0.0, 0.0))

    def __post_init__(self) -> None:
        for name in ("m", "l", "lc", "I"):
            validate_positive(f"ManipulatorParams.{name}", getattr(self, name))
        for name in ("Im", "g", "payload"):
            validate_positive(f"ManipulatorParams.{name}", getattr(self, name), allow_zero=True)
        if len(self.extra_inertia) != 2:
            raise ValueError(f"extra_inertia needs two values, got {self.extra_inertia!r}")
        for v in self.extra_inertia:
            validate_positive("ManipulatorParams.extra_inertia", v, allow_zero=True)

    @cached_property
    def array(self) -> np.ndarray:
        """Link-level kernel array, fields :data:`LINK_FIELDS` (payload folded into link 2)."""
        m2 = self.m + self.payload
        lc2 = (self.m * self.lc + self.payload * self.l) / m2
        i2 = self.I + self.m * (self.lc - lc2) ** 2 + self.payload * (self.l - lc2) ** 2
        vals = {"m1": self.m, "lc1": self.lc, "I1": self.I, "m2": m2, "lc2": lc2, "I2": i2,
                "l1": self.l, "Im1": self.Im + self.extra_inertia[0],
                "Im2": self.Im + self.extra_inertia[1], "g": self.g}
        return np.array([vals[n] for n in LINK_FIELDS], dtype=np.float64)


@dataclass(frozen=True, kw_only=True)
class JointDisturbance:
    """Non-friction joint torques a real arm may have: bias and springs (per joint).

    tau = tau0 + k·(q − q0) + k3·q³, added to tau_d. Attributes: tau0 (N·m), k (N·m/rad),
    q0 (rad), k3 (N·m/rad³; > 0 hardening, < 0 softening).
    """

    tau0: tuple[float, float] = (0.0, 0.0)
    k: tuple[float, float] = (0.0, 0.0)
    q0: tuple[float, float] = (0.0, 0.0)
    k3: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        for name in DISTURBANCE_FIELDS:
            vals = getattr(self, name)
            if len(vals) != 2 or not np.all(np.isfinite(vals)):
                raise ValueError(f"JointDisturbance.{name} needs two finite values, got {vals!r}")

    @cached_property
    def array(self) -> np.ndarray:
        """Kernel array, shape (2, 4): columns :data:`DISTURBANCE_FIELDS`."""
        return np.ascontiguousarray(np.array([getattr(self, n) for n in DISTURBANCE_FIELDS],
                                             dtype=np.float64).T)


# --------------------------------------------------------------------------- kernels
# Scalar helpers carry the physics once; the array-returning kernels and the allocation-free
# plant derivative (the env's hot path: 80 evaluations per 2 ms step) are built on them.
@njit(cache=True, inline="always")
def _mass_entries(q2, la):  # pragma: no cover - compiled
    m1, lc1, i1, m2, lc2, i2, l1, im1, im2 = la[M1], la[LC1], la[I1], la[M2], la[LC2], la[I2], \
        la[L1], la[IM1], la[IM2]
    c2 = np.cos(q2)
    m11 = m1 * lc1**2 + i1 + m2 * (l1**2 + lc2**2 + 2.0 * l1 * lc2 * c2) + i2 + im1
    m12 = m2 * (lc2**2 + l1 * lc2 * c2) + i2
    m22 = m2 * lc2**2 + i2 + im2
    return m11, m12, m22


@njit(cache=True, inline="always")
def _coriolis_entries(q2, dq1, dq2, la):  # pragma: no cover - compiled
    h = -la[M2] * la[L1] * la[LC2] * np.sin(q2)
    return h * dq2, h * (dq1 + dq2), -h * dq1


@njit(cache=True, inline="always")
def _gravity_entries(q1, q2, la):  # pragma: no cover - compiled
    m1, lc1, m2, lc2, l1, g = la[M1], la[LC1], la[M2], la[LC2], la[L1], la[G]
    c12 = np.cos(q1 + q2)
    return (m1 * lc1 + m2 * l1) * g * np.cos(q1) + m2 * lc2 * g * c12, m2 * lc2 * g * c12


@njit(cache=True)
def mass_matrix(q, la):  # pragma: no cover - compiled
    """Inertia matrix M(q) (kg·m²), spec ``M11, M12, M22``."""
    m11, m12, m22 = _mass_entries(q[1], la)
    out = np.empty((2, 2))
    out[0, 0] = m11
    out[0, 1] = m12
    out[1, 0] = m12
    out[1, 1] = m22
    return out


@njit(cache=True)
def coriolis_matrix(q, dq, la):  # pragma: no cover - compiled
    """Coriolis/centrifugal matrix C(q, dq) (kg·m²/s), spec ``C`` with h = −m2·l1·lc2·sin q2."""
    c11, c12, c21 = _coriolis_entries(q[1], dq[0], dq[1], la)
    out = np.empty((2, 2))
    out[0, 0] = c11
    out[0, 1] = c12
    out[1, 0] = c21
    out[1, 1] = 0.0
    return out


@njit(cache=True)
def gravity_vector(q, la):  # pragma: no cover - compiled
    """Gravity torques G(q) (N·m), spec ``G1, G2``."""
    g1, g2 = _gravity_entries(q[0], q[1], la)
    out = np.empty(2)
    out[0] = g1
    out[1] = g2
    return out


@njit(cache=True)
def potential_energy(q, la):  # pragma: no cover - compiled
    """Gravitational potential energy V(q) (J); G = ∂V/∂q."""
    m1, lc1, m2, lc2, l1, g = la[M1], la[LC1], la[M2], la[LC2], la[L1], la[G]
    return (m1 * lc1 + m2 * l1) * g * np.sin(q[0]) + m2 * lc2 * g * np.sin(q[0] + q[1])


@njit(cache=True)
def solve2(a, b):  # pragma: no cover - compiled
    """Solve the 2×2 system a·x = b by Cramer's rule."""
    det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    out = np.empty(2)
    out[0] = (a[1, 1] * b[0] - a[0, 1] * b[1]) / det
    out[1] = (a[0, 0] * b[1] - a[1, 0] * b[0]) / det
    return out


@njit(cache=True, inline="always")
def _tau_d_joint(i, qi, dqi, theta):  # pragma: no cover - compiled
    """Left-out torque at joint i from the plant array (friction row, then bias/springs)."""
    f = FRICTION + FRICTION_STRIDE * i
    d = DISTURBANCE + DISTURBANCE_STRIDE * i
    tau = joint_friction(dqi, theta[f + fr.FC], theta[f + fr.SIGMA], theta[f + fr.B],
                         theta[f + fr.FS], theta[f + fr.VS], theta[f + fr.C2]) \
        + theta[d + TAU0] + theta[d + K] * (qi - theta[d + Q0])
    if theta[d + K3] != 0.0:
        tau += cubic_spring(qi, theta[d + K3])
    return tau


@njit(cache=True)
def cubic_spring(q, k3):  # pragma: no cover - compiled
    """Cubic (hardening k3 > 0, softening k3 < 0) spring torque k3·q³ (N·m); k3 in N·m/rad³."""
    return k3 * q * q * q


@njit(cache=True)
def dead_zone(u, d):  # pragma: no cover - compiled
    """Effort an actuator with a dead zone of half-width d applies for the command u.

    u − clip(u, −d, d): zero inside ±d, the command shifted towards zero by d outside it
    (u and d in N·m or N, d ≥ 0). The pure-numpy form (``dead_zone.py_func``) works on
    arrays alike.
    """
    return u - np.minimum(np.maximum(u, -d), d)


@njit(cache=True)
def tau_d(q, dq, theta):  # pragma: no cover - compiled
    """Left-out joint torque tau_d(q, dq) (N·m) of the plant array: friction + bias/spring."""
    out = np.empty(2)
    out[0] = _tau_d_joint(0, q[0], dq[0], theta)
    out[1] = _tau_d_joint(1, q[1], dq[1], theta)
    return out


@njit(cache=True, inline="always")
def _momentum_entries(q2, dq1, dq2, la):  # pragma: no cover - compiled
    m11, m12, m22 = _mass_entries(q2, la)
    return m11 * dq1 + m12 * dq2, m12 * dq1 + m22 * dq2


@njit(cache=True)
def momentum_state(obs, la):  # pragma: no cover - compiled
    """Observation (q, dq) → identifier state (q, p = M(q) dq) (thesis eq. 2.3)."""
    out = np.empty(4)
    out[0] = obs[0]
    out[1] = obs[1]
    out[2], out[3] = _momentum_entries(obs[1], obs[2], obs[3], la)
    return out


@njit(cache=True)
def momentum_states(obs, la):  # pragma: no cover - compiled
    """:func:`momentum_state` of every row of ``obs`` (N, 4)."""
    out = np.empty((obs.shape[0], 4))
    for i in range(obs.shape[0]):
        out[i, 0] = obs[i, 0]
        out[i, 1] = obs[i, 1]
        out[i, 2], out[i, 3] = _momentum_entries(obs[i, 1], obs[i, 2], obs[i, 3], la)
    return out


@njit(cache=True)
def velocity_state(x, la):  # pragma: no cover - compiled
    """Identifier state (q, p) → observation (q, dq = M(q)⁻¹ p)."""
    m11, m12, m22 = _mass_entries(x[1], la)
    det = m11 * m22 - m12 * m12
    out = np.empty(4)
    out[0] = x[0]
    out[1] = x[1]
    out[2] = (m22 * x[2] - m12 * x[3]) / det
    out[3] = (m11 * x[3] - m12 * x[2]) / det
    return out


@njit(cache=True, inline="always")
def _nominal_entries(x1, x2, x3, x4, u1, u2, la):  # pragma: no cover - compiled
    m11, m12, m22 = _mass_entries(x2, la)
    det = m11 * m22 - m12 * m12
    dq1 = (m22 * x3 - m12 * x4) / det
    dq2 = (m11 * x4 - m12 * x3) / det
    c11, c12, c21 = _coriolis_entries(x2, dq1, dq2, la)
    g1, g2 = _gravity_entries(x1, x2, la)
    # (Cᵀ dq)_1 and (Cᵀ dq)_2 (C22 = 0)
    return dq1, dq2, c11 * dq1 + c21 * dq2 - g1 + u1, c12 * dq1 - g2 + u2


@njit(cache=True)
def nominal_derivative(x, u, la):  # pragma: no cover - compiled
    """Nominal f(x, u) of thesis eq. 2.3 in the (q, p) state."""
    out = np.empty(4)
    out[0], out[1], out[2], out[3] = _nominal_entries(x[0], x[1], x[2], x[3], u[0], u[1], la)
    return out


@njit(cache=True)
def nominal_derivatives(x, u, la):  # pragma: no cover - compiled
    """:func:`nominal_derivative` of every row of x (N, 4), u (N, 2)."""
    out = np.empty((x.shape[0], 4))
    for i in range(x.shape[0]):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = _nominal_entries(
            x[i, 0], x[i, 1], x[i, 2], x[i, 3], u[i, 0], u[i, 1], la)
    return out


@njit(cache=True, inline="always")
def _plant_acc(q1, q2, dq1, dq2, u1, u2, theta):  # pragma: no cover - compiled
    m11, m12, m22 = _mass_entries(q2, theta)
    c11, c12, c21 = _coriolis_entries(q2, dq1, dq2, theta)
    g1, g2 = _gravity_entries(q1, q2, theta)
    r1 = u1 - (c11 * dq1 + c12 * dq2) - g1 - _tau_d_joint(0, q1, dq1, theta)
    r2 = u2 - c21 * dq1 - g2 - _tau_d_joint(1, q2, dq2, theta)
    det = m11 * m22 - m12 * m12
    return (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det


@njit(cache=True)
def plant_acceleration(s, u, theta):  # pragma: no cover - compiled
    """True joint acceleration ddq (rad/s²) of the plant from s = (q, dq) and torques u."""
    a1, a2 = _plant_acc(s[0], s[1], s[2], s[3], u[0], u[1], theta)
    out = np.empty(2)
    out[0] = a1
    out[1] = a2
    return out


@njit(cache=True)
def plant_derivative(s, u, theta):  # pragma: no cover - compiled
    """True dynamics in the simulation state s = (q, dq): M ddq + C dq + G + tau_d = u.

    ``theta`` is :func:`plant_array` (layout :data:`PLANT`: link parameters, per-joint
    friction rows, per-joint bias/spring rows).
    """
    a1, a2 = _plant_acc(s[0], s[1], s[2], s[3], u[0], u[1], theta)
    out = np.empty(4)
    out[0] = s[2]
    out[1] = s[3]
    out[2] = a1
    out[3] = a2
    return out


@njit(cache=True, inline="always")
def _stage(q1, q2, dq1, dq2, c, k1, k2, k3, k4):  # pragma: no cover - compiled
    return (rk4_stage(q1, c, k1), rk4_stage(q2, c, k2), rk4_stage(dq1, c, k3),
            rk4_stage(dq2, c, k4))


@njit(cache=True, inline="always")
def plant_rk4(q1, q2, dq1, dq2, u1, u2, theta, dt, n_sub):  # pragma: no cover - compiled
    """:func:`plant_derivative` advanced by dt (s) with n_sub RK4 sub-steps, on scalars.

    The same floating-point operations in the same order as
    ``integrators.rk4(plant_derivative, ...)`` (its stage formulas are
    :func:`~simgap.models.integrators.rk4_stage` / ``rk4_combine``), so bit-identical to it,
    without an array per stage (a test pins the equality).
    """
    a1, a2 = _plant_acc(q1, q2, dq1, dq2, u1, u2, theta)
    return _rk4_from(q1, q2, dq1, dq2, a1, a2, u1, u2, theta, dt, n_sub)


@njit(cache=True, inline="always")
def _rk4_from(q1, q2, dq1, dq2, a1, a2, u1, u2, theta, dt, n_sub):  # pragma: no cover
    """:func:`plant_rk4` given the acceleration (a1, a2) at the start state (rad/s²).

    The first stage of the first sub-step reuses it (:func:`transition_entries` has it
    from the true residual), so the step evaluates the plant once less; same bits.
    """
    h = dt / n_sub
    half = 0.5 * h
    h6 = h / 6.0
    for j in range(n_sub):
        if j > 0:
            a1, a2 = _plant_acc(q1, q2, dq1, dq2, u1, u2, theta)
        t0, t1, t2, t3 = _stage(q1, q2, dq1, dq2, half, dq1, dq2, a1, a2)
        b1, b2 = _plant_acc(t0, t1, t2, t3, u1, u2, theta)
        v0, v1, v2, v3 = _stage(q1, q2, dq1, dq2, half, t2, t3, b1, b2)
        c1, c2 = _plant_acc(v0, v1, v2, v3, u1, u2, theta)
        w0, w1, w2, w3 = _stage(q1, q2, dq1, dq2, h, v2, v3, c1, c2)
        d1, d2 = _plant_acc(w0, w1, w2, w3, u1, u2, theta)
        q1, q2, dq1, dq2 = (rk4_combine(q1, h6, dq1, t2, v2, w2),
                            rk4_combine(q2, h6, dq2, t3, v3, w3),
                            rk4_combine(dq1, h6, a1, b1, c1, d1),
                            rk4_combine(dq2, h6, a2, b2, c2, d2))
    return q1, q2, dq1, dq2


@njit(cache=True)
def plant_step(s, u, theta, dt, n_sub):  # pragma: no cover - compiled
    """Advance the plant by dt (s) with n_sub RK4 sub-steps (disk-cached; see plant_rk4)."""
    out = np.empty(4)
    out[0], out[1], out[2], out[3] = plant_rk4(s[0], s[1], s[2], s[3], u[0], u[1], theta,
                                               dt, n_sub)
    return out


@njit(cache=True, inline="always")
def _true_residual_entries(q1, q2, dq1, dq2, u1, u2, theta, la_nom):  # pragma: no cover
    a1, a2 = _plant_acc(q1, q2, dq1, dq2, u1, u2, theta)
    return _residual_from_acc(q1, q2, dq1, dq2, u1, u2, a1, a2, la_nom)


@njit(cache=True, inline="always")
def _residual_from_acc(q1, q2, dq1, dq2, u1, u2, a1, a2, la_nom):  # pragma: no cover
    """g[2:] at s = (q, dq), u given the plant's acceleration (a1, a2) there (rad/s²)."""
    m11, m12, m22 = _mass_entries(q2, la_nom)
    c11, c12, c21 = _coriolis_entries(q2, dq1, dq2, la_nom)
    g1, g2 = _gravity_entries(q1, q2, la_nom)
    return (c11 * dq1 + c12 * dq2 + g1 + m11 * a1 + m12 * a2 - u1,
            c21 * dq1 + g2 + m12 * a1 + m22 * a2 - u2)


@njit(cache=True)
def true_residual(s, u, theta, la_nom):  # pragma: no cover - compiled
    """True g(x, u) in the nominal model's (q, p) coordinates at simulation state s.

    g = d/dt [q; M_nom(q) dq] − f_nom(x) = (0, 0, C_nom dq + G_nom + M_nom ddq_true − u),
    which equals (0, 0, −tau_d) when the plant's rigid body is the nominal one.
    """
    out = np.zeros(4)
    out[2], out[3] = _true_residual_entries(s[0], s[1], s[2], s[3], u[0], u[1], theta, la_nom)
    return out


@njit(cache=True, inline="always")
def residual_entries(q1, q2, dq1, dq2, u1, u2, theta, la_nom):  # pragma: no cover - compiled
    """(g[2], g[3], tau_d1, tau_d2) at s = (q, dq), u: :func:`true_residual`, :func:`tau_d`."""
    g3, g4 = _true_residual_entries(q1, q2, dq1, dq2, u1, u2, theta, la_nom)
    return g3, g4, _tau_d_joint(0, q1, dq1, theta), _tau_d_joint(1, q2, dq2, theta)


@njit(cache=True, inline="always")
def transition_entries(q1, q2, dq1, dq2, u1, u2, theta, la_nom, dt,
                       n_sub):  # pragma: no cover - compiled
    """One env transition on scalars: (next state (4), g[2:] (2), tau_d (2)) at s_k, u_k.

    The single env's :func:`transition` and the native vector env share it. The plant's
    acceleration at s_k is evaluated once, for the residual and the first RK4 stage.
    """
    a1, a2 = _plant_acc(q1, q2, dq1, dq2, u1, u2, theta)
    g3, g4 = _residual_from_acc(q1, q2, dq1, dq2, u1, u2, a1, a2, la_nom)
    tau1, tau2 = _tau_d_joint(0, q1, dq1, theta), _tau_d_joint(1, q2, dq2, theta)
    n1, n2, n3, n4 = _rk4_from(q1, q2, dq1, dq2, a1, a2, u1, u2, theta, dt, n_sub)
    return n1, n2, n3, n4, g3, g4, tau1, tau2


@njit(cache=True)
def transition(s, u, theta, la_nom, dt, n_sub):  # pragma: no cover - compiled
    """The env's fused step kernel: (s_{k+1}, true g(x_k, u_k) (4,), tau_d(s_k) (2,)).

    Equal bit for bit to :func:`plant_step`, :func:`true_residual` and :func:`tau_d` called
    one by one; disk-cached (``cache=True``), so a fresh process does not recompile it.
    ``theta`` and ``la_nom`` may be the arrays or tuples of their floats (the env passes
    tuples, which numba keeps as values: faster, the same bits).
    """
    s_new = np.empty(4)
    g = np.zeros(4)
    tau = np.empty(2)
    (s_new[0], s_new[1], s_new[2], s_new[3], g[2], g[3], tau[0],
     tau[1]) = transition_entries(s[0], s[1], s[2], s[3], u[0], u[1], theta, la_nom, dt, n_sub)
    return s_new, g, tau


def plant_array(params: ManipulatorParams, friction: FrictionParams | None = None,
                disturbance: JointDisturbance | None = None) -> np.ndarray:
    """Flat array for :func:`plant_derivative`, layout :data:`PLANT`."""
    fa = (friction if friction is not None else FrictionParams(fc=0.0, b=0.0)).array
    da = (disturbance if disturbance is not None else JointDisturbance()).array
    out = np.concatenate([params.array, fa.ravel(), da.ravel()])
    assert out.shape == (PLANT.size,)
    return out


def state_derivative(x: np.ndarray, u: np.ndarray, params: ManipulatorParams) -> np.ndarray:
    """Nominal dx/dt = f(x, u) (thesis eq. 2.3) for x = (q, p), u = joint torques (N·m)."""
    return nominal_derivative(np.asarray(x, dtype=np.float64), np.asarray(u, dtype=np.float64),
                              params.array)


# --------------------------------------------------------------------------- nominal model
class ManipulatorNominal(MechanicalNominalModel):
    """Nominal model ``manipulator2dof`` of ``spec/models.md`` (protocol in ``base.py``).

    Identifier state x = (q1, q2, p1, p2); observation (q1, q2, dq1, dq2); input u = joint
    torques (N·m). The physical residual is the left-out joint torque tau_d = −g[2:] (N·m).
    """

    name = "manipulator2dof"
    state_names = STATE_NAMES
    state_units = STATE_UNITS
    input_names = INPUT_NAMES
    input_units = INPUT_UNITS
    obs_names = OBS_NAMES
    obs_units = OBS_UNITS
    recording_columns = RECORDING_COLUMNS
    #: The vocabulary's fit bounds (rad/s, N·m) are written for this arm: the diagnosis uses
    #: them as declared instead of scaling them to the recorded motion (FitSpec.for_data).
    vocabulary_scaled_to_data = False

    def __init__(self, params: ManipulatorParams | None = None, dt: float = 0.002) -> None:
        validate_positive("dt", dt)
        self.params = params if params is not None else ManipulatorParams()
        self.dt = float(dt)
        self._la = self.params.array

    def __repr__(self) -> str:
        return f"ManipulatorNominal(params={self.params!r}, dt={self.dt})"

    @property
    def residual_names(self) -> tuple[str, ...]:
        """Left-out joint torques tau_d at joints 1 and 2."""
        return ("tau_d1", "tau_d2")

    @property
    def residual_units(self) -> tuple[str, ...]:
        """N·m per joint."""
        return ("N·m", "N·m")

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Observation (q, dq) → identifier state (q, p = M(q) dq)."""
        return momentum_state(np.asarray(obs, dtype=np.float64), self._la)

    def states(self, obs: np.ndarray) -> np.ndarray:
        """:meth:`state` of every row of ``obs`` (N, 4) in one kernel call."""
        return momentum_states(np.ascontiguousarray(obs, dtype=np.float64), self._la)

    def f_rows(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """:meth:`f` of every row of x (N, 4), u (N, 2) in one kernel call."""
        return nominal_derivatives(np.ascontiguousarray(x, dtype=np.float64),
                                   np.ascontiguousarray(u, dtype=np.float64), self._la)

    def observation(self, x: np.ndarray) -> np.ndarray:
        """Identifier state (q, p) → observation (q, dq = M(q)⁻¹ p)."""
        return velocity_state(np.asarray(x, dtype=np.float64), self._la)

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal f(x, u), thesis eq. 2.3."""
        return nominal_derivative(np.asarray(x, dtype=np.float64),
                                  np.asarray(u, dtype=np.float64), self._la)

    def M(self, q: np.ndarray) -> np.ndarray:  # noqa: N802
        """Inertia matrix M(q) (kg·m²)."""
        return mass_matrix(np.asarray(q, dtype=np.float64), self._la)

    def C(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:  # noqa: N802
        """Coriolis matrix C(q, dq) (kg·m²/s)."""
        return coriolis_matrix(np.asarray(q, dtype=np.float64), np.asarray(dq, dtype=np.float64),
                               self._la)

    def G(self, q: np.ndarray) -> np.ndarray:  # noqa: N802
        """Gravity torques G(q) (N·m)."""
        return gravity_vector(np.asarray(q, dtype=np.float64), self._la)

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """C(q, dq) dq + G(q) (N·m)."""
        q = np.asarray(q, dtype=np.float64)
        dq = np.asarray(dq, dtype=np.float64)
        return coriolis_matrix(q, dq, self._la) @ dq + gravity_vector(q, self._la)

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """State residual g (…, 4) → left-out joint torque tau_d = −g[2:] (N·m)."""
        return -np.asarray(g, dtype=np.float64)[..., 2:]


# --------------------------------------------------------------------------- plant
JOINTS = ("joint1", "joint2")
DEFAULT_SIGMA = 6.67e-4  # rad/s: the thesis' Coulomb smoothing velocity (Table 4.2)
_ANY = (-math.inf, math.inf)
_NONNEG = (0.0, math.inf)


# --------------------------------------------------------------------------- fit side
# Contributions of the vocabulary to the joint residual tau − M ddq − bias = tau_d (N·m or
# N per joint), used by the diagnosis (``FitSpec.fn``). Friction terms call the plant's own
# friction functions (their pure-numpy form, ``py_func``: the same expression on arrays);
# a linear coefficient multiplies the unit-coefficient shape. ``sig``: ``q``, ``dq``,
# ``ddq`` (N, n) and ``idx`` (rows of the recording); ``ctx``: the diagnosis' EffectContext.
def _fit_coulomb(lin, nl, sig, j, ctx):
    dq = sig["dq"][:, j]
    return on_channel(lin[0] * fr.coulomb.py_func(dq, 1.0, ctx.coulomb_sigma[j]), j,
                      ctx.n_channels)


def _fit_viscous(lin, nl, sig, j, ctx):
    return on_channel(lin[0] * sig["dq"][:, j], j, ctx.n_channels)


def _fit_stribeck(lin, nl, sig, j, ctx):
    """(Fs − Fc)·exp(−(dq/vs)²)·tanh(dq/σ), fitted as A = Fs − Fc on top of Coulomb's Fc."""
    dq = sig["dq"][:, j]
    bump = fr.stribeck.py_func(dq, 1.0, 0.0, nl[0], ctx.coulomb_sigma[j])
    return on_channel(lin[0] * bump, j, ctx.n_channels)


def _fit_quadratic(lin, nl, sig, j, ctx):
    return on_channel(lin[0] * fr.quadratic.py_func(sig["dq"][:, j], 1.0), j, ctx.n_channels)


def _fit_bias(lin, nl, sig, j, ctx):
    return on_channel(np.full(sig["q"].shape[0], lin[0]), j, ctx.n_channels)


def _fit_spring(lin, nl, sig, j, ctx):
    return on_channel(lin[0] * sig["q"][:, j] + lin[1], j, ctx.n_channels)


def _fit_inertia(lin, nl, sig, j, ctx):
    return on_channel(lin[0] * sig["ddq"][:, j], j, ctx.n_channels)


def _fit_cubic(lin, nl, sig, j, ctx):
    return on_channel(cubic_spring.py_func(sig["q"][:, j], lin[0]), j, ctx.n_channels)


def _fit_delay(lin, nl, sig, j, ctx):
    """Effort change (N·m or N) from the logged input acting ``nl[0]`` seconds late.

    u(t) − u(t − d) of the held input (linear interpolation on the uniform grid).
    """
    u = ctx.held_input[:, j]
    return on_channel((u - _delay_input(nl, ctx.t, u))[sig["idx"]], j, ctx.n_channels)


def _delay_input(nl, t, u):
    """The held input u(t) felt ``nl[0]`` seconds late (linear interpolation on the grid)."""
    return np.interp(t - nl[0], t, u)


def _fit_dead_zone(lin, nl, sig, j, ctx):
    """The command the actuator does not apply: u − dead_zone(u, d) = clip(u, −d, d).

    u is the channel's held input; d = ``nl[0]`` (N·m or N).
    """
    u = ctx.held_input[:, j][sig["idx"]]
    return on_channel(u - dead_zone.py_func(u, nl[0]), j, ctx.n_channels)


def _dead_zone_input(nl, t, u):
    """The effort that acts: the held command through the dead zone of half-width ``nl[0]``."""
    return dead_zone.py_func(u, nl[0])


#: Passes of the command through the dead band ±d (from one side to the other) a dead zone
#: needs to be named: where the command stays on one side, a dead zone is d·sign(u), a
#: constant torque bias.
DEAD_ZONE_MIN_PASSES = 4
#: Level of the dwell test: inside ±d the dead zone takes the whole command (contribution
#: u), where a relay d·sign(u) would take d; the command must dwell there long enough that
#: the expected χ² statistic of that difference, as the fit reads it (through the equation's
#: filter, at the rows the tests read), against the error the fit leaves there (σ per
#: independent row), reaches the χ²(1) critical value.
DEAD_ZONE_DWELL_ALPHA = 0.01


def _dead_zone_excitation(effect, lin, nl, u, noise, seen=None):
    """Why the held command ``u`` cannot identify a dead zone of half-width ``nl[0]``.

    ``u``: the channel's held input on the valid samples, in time order (N·m or N);
    ``noise``: std per independent row of the error the fit leaves at the channel (N·m or
    N); ``seen(fn)``: the contribution ``fn(command)`` as the fit reads it (see
    ``FitSpec.excitation``; ``None``: the raw samples of ``fn(u)``, one per row). A dwell
    shorter than the equation's filter window is smeared by it: its raw samples overstate
    what the fit can tell. Returns "" when it can.
    """
    from scipy.stats import chi2

    d = float(nl[0])
    inside = np.abs(u) < d
    side = np.sign(u[np.abs(u) > d])
    passes = int(np.sum(side[1:] != side[:-1]))
    if passes < DEAD_ZONE_MIN_PASSES:
        return (f"the command passes through the fitted dead band ±{d:.3g} {passes} times "
                f"(at least {DEAD_ZONE_MIN_PASSES} needed): where it stays on one side a "
                "dead zone is a constant torque bias")

    def relay_gap(v):        # dead zone − relay d·sign(v): nonzero only inside ±d
        return np.where(np.abs(v) < d, v - d * np.sign(v), 0.0)

    gap = relay_gap(u) if seen is None else seen(relay_gap)
    stat = float(np.sum(np.asarray(gap) ** 2)) / max(noise, 1e-300) ** 2
    crit = float(chi2.isf(DEAD_ZONE_DWELL_ALPHA, 1))
    if not stat >= crit:
        return (f"the command dwells inside the fitted dead band ±{d:.3g} on "
                f"{int(np.sum(inside))} of {u.size} samples: too little to tell a dead zone "
                f"from a relay d·sign(u) (expected χ² {stat:.3g} < {crit:.3g}, as the fit "
                "reads the difference through its filter against the error it leaves); "
                "a dead zone needs commands that pass through and dwell near zero")
    return ""


def _fit_gravity(lin, nl, sig, j, ctx):
    return lin[0] * ctx.gravity(sig["q"])


def _fit_payload(lin, nl, sig, j, ctx):
    return lin[0] * ctx.payload_regressor(sig["q"], sig["dq"], sig["ddq"])


def _stribeck_report(effect, lin, nl, cov, context):
    """Fs = Fc + (Fs − Fc): the breakaway torque includes the Coulomb level if one is named."""
    fc, var_fc, cov_a_fc = context.get("Fc", 0.0), context.get("var_Fc", 0.0), \
        context.get("cov_A_Fc", 0.0)
    var_fs = cov[0, 0] + var_fc + 2.0 * cov_a_fc
    return ({"Fs": float(lin[0] + fc), "vs": float(nl[0])},
            {"Fs": float(np.sqrt(max(var_fs, 0.0))), "vs": stderr_of(cov, 1)},
            {"Fs": "{effort}", "vs": "{position}/s"})


def _spring_report(effect, lin, nl, cov, context):
    """Tau = k q + c  →  k (q − q0) with q0 = −c/k (delta method for its stderr)."""
    k, c = float(lin[0]), float(lin[1])
    q0 = -c / k if k != 0 else float("nan")
    grad = np.array([c / k**2, -1.0 / k]) if k != 0 else np.array([np.nan, np.nan])
    var_q0 = float(grad @ cov[:2, :2] @ grad)
    return ({"k": k, "q0": q0}, {"k": stderr_of(cov, 0),
                                 "q0": float(np.sqrt(max(var_q0, 0.0)))},
            {"k": "{effort}/{position}", "q0": "{position}"})


#: A Stribeck velocity above this share of the joint's largest recorded speed is not a
#: low-speed effect any more: it would only reshape the Coulomb/viscous curve.
STRIBECK_MAX_SHARE = 0.25


def _stribeck_for_data(effect, sig, j, ctx):
    """Stribeck's vs bounded by :data:`STRIBECK_MAX_SHARE` of the joint's top recorded speed.

    The vocabulary's bounds, in rad/s, mean nothing for a slider moving at 0.1 m/s, and a
    "Stribeck" term with vs near the top speed only reshapes Coulomb + viscous friction (on
    the EMPS data it then displaces the Coulomb term). The start grid scales with it.
    """
    if j is None:
        return effect
    hi = max(STRIBECK_MAX_SHARE * float(np.max(np.abs(sig["dq"]), axis=0)[j]), 2e-3)
    return replace(effect, nl_bounds=((1e-3 * hi, hi),),
                   nl_grid=(tuple(hi * np.array([0.05, 0.15, 0.4, 0.9])),))


def _gravity_for_data(effect, sig, j, ctx):
    """No gravity_mismatch where the model has no gravity torque on the recorded positions."""
    q = sig["q"]
    gravity = np.abs(ctx.gravity(q)).max() if q.size else 0.0
    return None if gravity == 0.0 else effect


def _stribeck_coords(params, context):
    """Fit coordinates of a reported Stribeck term: A = Fs − Fc (same joint's Coulomb Fc)."""
    return (params["Fs"] - context.get("Fc", 0.0),), (params["vs"],)


def _spring_coords(params, context):
    """Fit coordinates of a reported spring k·(q − q0): k and c = −k·q0."""
    return (params["k"], -params["k"] * params["q0"]), ()


_INF = math.inf


def _start(plant: Plant) -> dict:
    p = plant.params
    return {"fc": [0.0, 0.0], "b": [0.0, 0.0], "fs": [None, None], "vs": [0.05, 0.05],
            "c2": [0.0, 0.0],
            "tau0": [0.0, 0.0], "k": [0.0, 0.0], "q0": [0.0, 0.0], "k3": [0.0, 0.0],
            "input_delay": [0.0, 0.0], "dead_zone": [0.0, 0.0],
            "payload": p.payload, "extra": list(p.extra_inertia), "g": p.g}


def _set(key: str, name: str) -> Callable[[dict, int | None, Mapping[str, float]], None]:
    def write(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
        acc[key][j] = v[name]
    return write


def _stribeck(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    acc["fs"][j], acc["vs"][j] = v["Fs"], v["vs"]


def _bias(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    acc["tau0"][j] += v["tau0"]


def _spring(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    acc["k"][j], acc["q0"][j] = v["k"], v["q0"]


def _delay(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    for i in (0, 1) if j is None else (j,):
        acc["input_delay"][i] = v["delay"]


def _payload(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    acc["payload"] = v["mp"]


def _gravity(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    acc["g"] = acc["g0"] * (1.0 + v["dG"])


#: The arm's effect vocabulary (``spec/diagnosis.md``), in fold order.
VOCABULARY = (
    EffectSpec(name="coulomb_friction", label="Coulomb friction", scope="channel",
               params=(Param(name="Fc", unit="{effort}", bounds=_NONNEG, inject=(0.05, 0.3)),),
               write=_set("fc", "Fc"),
               fit=FitSpec(scope="joint", lin=("Fc",), lin_units=("{effort}",), lin_lower=(0.0,),
                           corrects=(("Fc", "frictionloss"),), fn=_fit_coulomb)),
    EffectSpec(name="viscous_friction", label="viscous friction", scope="channel",
               params=(Param(name="b", unit="{effort}·s/{position}", bounds=_NONNEG,
                             inject=(0.05, 0.5)),),
               write=_set("b", "b"),
               fit=FitSpec(scope="joint", lin=("b",), lin_units=("{effort}·s/{position}",),
                           lin_lower=(0.0,), corrects=(("b", "damping"),), fn=_fit_viscous)),
    EffectSpec(name="stribeck_friction", label="Stribeck friction", scope="channel",
               params=(Param(name="Fs", unit="{effort}", bounds=_NONNEG, inject=(0.2, 0.4)),
                       Param(name="vs", unit="{position}/s", bounds=(1e-9, math.inf),
                             inject=(0.07, 0.3))),
               write=_stribeck, needs=("coulomb_friction",),
               fit=FitSpec(scope="joint", lin=("Fs",), lin_units=("{effort}",), lin_lower=(0.0,),
                           nl=("vs",), nl_units=("{position}/s",), nl_bounds=((1e-3, 2.0),),
                           nl_grid=((0.01, 0.03, 0.1, 0.3),),
                           generalizes=("coulomb_friction",), fn=_fit_stribeck,
                           to_report=_stribeck_report, from_report=_stribeck_coords,
                           for_data=_stribeck_for_data)),
    EffectSpec(name="quadratic_drag", label="quadratic drag", scope="channel",
               params=(Param(name="c", unit="{effort}·s²/{position}²", bounds=_NONNEG,
                             inject=(0.01, 0.1)),),
               write=_set("c2", "c"),
               fit=FitSpec(scope="joint", lin=("c",), lin_units=("{effort}·s²/{position}²",),
                           lin_lower=(0.0,), fn=_fit_quadratic)),
    EffectSpec(name="torque_bias", label="torque bias", scope="channel",
               params=(Param(name="tau0", unit="{effort}", bounds=_ANY, inject=(0.05, 0.3),
                             signed=True),),
               write=_bias,
               fit=FitSpec(scope="joint", lin=("tau0",), lin_units=("{effort}",),
                           lin_lower=(-_INF,), fn=_fit_bias)),
    EffectSpec(name="spring", label="spring", scope="channel",
               params=(Param(name="k", unit="{effort}/{position}", bounds=_ANY,
                             inject=(0.5, 3.0)),
                       Param(name="q0", unit="{position}", bounds=_ANY, inject=(-0.5, 0.5),
                             default=0.0)),
               write=_spring,
               fit=FitSpec(scope="joint", lin=("k", "c"),
                           lin_units=("{effort}/{position}", "{effort}"),
                           lin_lower=(-_INF, -_INF), generalizes=("torque_bias",),
                           fn=_fit_spring, to_report=_spring_report,
                           from_report=_spring_coords)),
    EffectSpec(name="payload_mass", label="payload mass", scope="system",
               params=(Param(name="mp", unit="kg", bounds=_NONNEG, inject=(0.1, 0.5)),),
               write=_payload,
               fit=FitSpec(scope="arm", lin=("mp",), lin_units=("kg",), lin_lower=(0.0,),
                           lin_upper=(10.0,), uses_derivatives=True, generic=False,
                           fn=_fit_payload)),
    EffectSpec(name="gravity_mismatch", label="gravity mismatch", scope="system",
               params=(Param(name="dG", unit="-", bounds=(-1.0, math.inf), inject=(0.02, 0.1),
                             signed=True),),
               write=_gravity,
               fit=FitSpec(scope="arm", lin=("dG",), lin_units=("-",), lin_lower=(-0.5,),
                           lin_upper=(0.5,), fn=_fit_gravity, for_data=_gravity_for_data)),
    EffectSpec(name="inertia_mismatch", label="extra inertia", scope="channel",
               params=(Param(name="dI", unit="{inertia}", bounds=_NONNEG,
                             inject=(0.015, 0.04)),),
               write=_set("extra", "dI"),
               fit=FitSpec(scope="joint", lin=("dI",), lin_units=("{inertia}",),
                           lin_lower=(0.0,), lin_upper=(0.5,), uses_derivatives=True,
                           fn=_fit_inertia)),
    EffectSpec(name="cubic_stiffness", label="cubic stiffness", scope="channel",
               params=(Param(name="k3", unit="{effort}/{position}³", bounds=_ANY,
                             inject=(0.15, 0.5), signed=True),),
               write=_set("k3", "k3"),
               # arm only for now: on the real EMPS axis a generic cubic term was named
               # together with a spring in place of the published force offset (a held-out
               # gain of 0.07 % of the residual), which the selection does not yet reject
               fit=FitSpec(scope="joint", lin=("k3",), lin_units=("{effort}/{position}³",),
                           lin_lower=(-_INF,), generic=False, fn=_fit_cubic)),
    EffectSpec(name="input_delay", label="actuator delay", scope="channel", all_channels=True,
               params=(Param(name="delay", unit="s", bounds=(0.0, 0.1),
                             inject=(0.006, 0.02)),),
               write=_delay,
               fit=FitSpec(scope="joint", nl=("delay",), nl_units=("s",),
                           nl_bounds=((1e-4, 0.1),), nl_grid=((0.002, 0.005, 0.01, 0.02, 0.05),),
                           # the arm and MJCF models; on the real EMPS pulse set a generic
                           # delay was named beside the published friction (it may stand in
                           # for the structural flexibility there), so not yet for any model
                           on_input=True, latency=True, input_map=_delay_input,
                           generic=False, fn=_fit_delay)),
    EffectSpec(name="dead_zone", label="actuator dead zone", scope="channel",
               params=(Param(name="d", unit="{effort}", bounds=_NONNEG, inject=(0.1, 0.3)),),
               write=_set("dead_zone", "d"),
               # identifiable only where the command passes through ±d and dwells inside
               # it (excitation), and where it stays determined beside a torque bias
               # (a dead zone on a command of one sign) and a Coulomb friction (a command
               # whose sign follows the velocity) at the same joint; arm only for now
               fit=FitSpec(scope="joint", nl=("d",), nl_units=("{effort}",),
                           nl_bounds=((1e-3, 5.0),), nl_grid=((0.03, 0.1, 0.3, 1.0),),
                           on_input=True, input_map=_dead_zone_input, generic=False,
                           excitation=_dead_zone_excitation,
                           confusable_with=("torque_bias", "coulomb_friction"),
                           fn=_fit_dead_zone)),
)


def _fold(plant: Plant) -> Folded:
    """Plant → (rigid-body params, friction, bias/spring) → kernel array :data:`PLANT`."""
    p = plant.params
    acc = _start(plant)
    acc["g0"] = p.g
    for e in plant.effects:
        spec = plant.schema.effect(e.name)
        spec.write(acc, channel_index(JOINTS, e.channel), e.params)
    sig = plant.options["coulomb_sigma"]
    sig = (float(sig),) * 2 if np.isscalar(sig) else tuple(float(s) for s in sig)
    fs = tuple(acc["fs"][i] if acc["fs"][i] is not None else acc["fc"][i] for i in range(2))
    friction = FrictionParams(fc=tuple(acc["fc"]), b=tuple(acc["b"]), fs=fs,
                              vs=tuple(acc["vs"]), sigma=sig, c2=tuple(acc["c2"]))
    disturbance = JointDisturbance(tau0=tuple(acc["tau0"]), k=tuple(acc["k"]),
                                   q0=tuple(acc["q0"]), k3=tuple(acc["k3"]))
    params = p
    if (acc["g"], acc["payload"], tuple(acc["extra"])) != (p.g, p.payload,
                                                           tuple(p.extra_inertia)):
        params = replace(p, g=acc["g"], payload=acc["payload"],
                         extra_inertia=tuple(acc["extra"]))
    return Folded(params, plant_array(params, friction, disturbance),
                  {"friction": friction, "disturbance": disturbance,
                   "input_delay": tuple(acc["input_delay"]),
                   "dead_zone": tuple(acc["dead_zone"])})


#: The arm's plant declaration; ``PLANT_SCHEMA.plant(params, effects)`` makes a Plant.
PLANT_SCHEMA = PlantSchema(system="manipulator2dof", params_cls=ManipulatorParams,
                           channels=JOINTS, vocabulary=VOCABULARY,
                           options={"coulomb_sigma": (DEFAULT_SIGMA, DEFAULT_SIGMA)},
                           fold=_fold)


def friction_effects(friction: FrictionParams | None) -> tuple[EffectInstance, ...]:
    """Named per-joint instances of a :class:`FrictionParams` (zero terms left out).

    The smoothing velocity sigma is a plant option (``coulomb_sigma``), not an effect. The
    Stribeck velocity of a joint without a Stribeck term does not act and is dropped.
    """
    if friction is None:
        return ()
    fa = friction.array
    out: list[EffectInstance] = []
    for j, ch in enumerate(JOINTS):
        fc, b, fs, vs, c2 = (float(fa[j, c]) for c in (fr.FC, fr.B, fr.FS, fr.VS, fr.C2))
        if fc != 0.0 or fs != fc:
            out.append(EffectInstance("coulomb_friction", ch, {"Fc": fc}))
        if b != 0.0:
            out.append(EffectInstance("viscous_friction", ch, {"b": b}))
        if fs != fc:
            out.append(EffectInstance("stribeck_friction", ch, {"Fs": fs, "vs": vs}))
        if c2 != 0.0:
            out.append(EffectInstance("quadratic_drag", ch, {"c": c2}))
    return tuple(out)


def disturbance_effects(disturbance: JointDisturbance | None) -> tuple[EffectInstance, ...]:
    """Named per-joint torque-bias and spring instances of a :class:`JointDisturbance`."""
    if disturbance is None:
        return ()
    out: list[EffectInstance] = []
    for j, ch in enumerate(JOINTS):
        if disturbance.tau0[j] != 0.0:
            out.append(EffectInstance("torque_bias", ch, {"tau0": float(disturbance.tau0[j])}))
        if disturbance.k[j] != 0.0 or disturbance.q0[j] != 0.0:
            out.append(EffectInstance("spring", ch, {"k": float(disturbance.k[j]),
                                                     "q0": float(disturbance.q0[j])}))
        if disturbance.k3[j] != 0.0:
            out.append(EffectInstance("cubic_stiffness", ch, {"k3": float(disturbance.k3[j])}))
    return tuple(out)


def make_plant(params: ManipulatorParams | None = None, *,
               friction: FrictionParams | None = None,
               disturbance: JointDisturbance | None = None,
               effects: tuple[EffectInstance, ...] = ()) -> Plant:
    """The arm's :class:`Plant` from the envs' keyword form (friction, disturbance) and effects.

    The kernel array equals ``plant_array(params, friction, disturbance)`` slot for slot
    wherever a slot acts (a test pins it).
    """
    sigma = (DEFAULT_SIGMA, DEFAULT_SIGMA) if friction is None else \
        tuple(float(s) for s in friction.array[:, fr.SIGMA])
    return PLANT_SCHEMA.plant(params, friction_effects(friction)
                              + disturbance_effects(disturbance) + tuple(effects),
                              coulomb_sigma=sigma)


guard_cache(globals(), ("simgap.models.friction", "simgap.models.integrators",
                        "simgap.models.slots"))
