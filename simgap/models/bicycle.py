"""Single-track (bicycle) vehicle lateral dynamics (``spec/models.md``, thesis eq. 2.4-2.7).

State x = (vy, r): lateral velocity at the CG (m/s) and yaw rate (rad/s). Input
u = (delta_f, delta_r): road-wheel steering angles (rad). Longitudinal speed vx (m/s) is a
measured, slowly varying parameter (> 1 m/s). Nominal: dx/dt = A x + B u; residual
g = K·Delta with axle-force deviations Delta = (Delta_f, Delta_r) (N).

The "true" plant used by the env has state s = (vy, r, alpha_f_lag, alpha_r_lag,
delta_f_act, delta_r_act); the lag states are used only when tire relaxation or steering
lag is on.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numba import njit

from simgap.errors import ModelError
from simgap.models.base import BaseNominalModel, validate_positive
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
from simgap.models.integrators import rk4_combine, rk4_stage
from simgap.models.nbcache import guard_cache
from simgap.models.slots import Slots
from simgap.models.tires import MagicFormulaTire, linear_force, magic_formula, relaxation_rate

PARAM_FIELDS = ("m", "Iz", "lf", "lr", "C_af", "C_ar", "g", "mu")
STATE_NAMES = ("vy", "r")
STATE_UNITS = ("m/s", "rad/s")
INPUT_NAMES = ("delta_f", "delta_r")
INPUT_UNITS = ("rad", "rad")
RECORDING_COLUMNS = ("t", "vx", "vy", "r", "delta_f", "delta_r")
MIN_VX = 1.0  # m/s: below it the slip-angle model is singular

#: Layout of the plant array: the vehicle parameters, then the plant's options. The tires
#: read the per-axle road friction ``mu_f`` / ``mu_r`` (0 = that axle's tire is linear, no
#: saturation); the parameter block's ``mu`` is :attr:`Plant.true_params` ``.mu`` (the axles'
#: common μ, their mean where they differ) and no kernel reads it.
PLANT_FIELDS = PARAM_FIELDS + ("vx", "mf_C", "mf_E", "mu_f", "mu_r", "relax_f", "relax_r",
                               "steer_lag", "ay0", "dr0")
#: Slots of :attr:`BicycleParams.array`, of the nominal kernel array (params + vx) and of
#: the plant array; the nominal array opens the plant array, so both share the slots below.
PARAMS = Slots(*PARAM_FIELDS)
NOMINAL = Slots(*PARAM_FIELDS, "vx")
PLANT = Slots(*PLANT_FIELDS)
assert PARAMS.prefix_of(NOMINAL) and NOMINAL.prefix_of(PLANT)
# Module-level ints generated from the names (numba freezes them as constants).
M, IZ, LF, LR, C_AF, C_AR, G, MU = (PLANT[n] for n in PARAM_FIELDS)
VX, MF_C, MF_E = PLANT["vx"], PLANT["mf_C"], PLANT["mf_E"]
MU_F, MU_R = PLANT["mu_f"], PLANT["mu_r"]
RELAX_F, RELAX_R, STEER_LAG = PLANT["relax_f"], PLANT["relax_r"], PLANT["steer_lag"]
AY0, DR0 = PLANT["ay0"], PLANT["dr0"]


@dataclass(frozen=True, kw_only=True)
class BicycleParams:
    """Vehicle parameters (defaults: the spec's mid-size sedan).

    Attributes:
        m: vehicle mass (kg).
        Iz: yaw inertia (kg·m²).
        lf: CG to front axle (m).
        lr: CG to rear axle (m).
        C_af: front axle cornering stiffness (N/rad).
        C_ar: rear axle cornering stiffness (N/rad).
        g: gravity (m/s²).
        mu: road friction coefficient (-), used only by nonlinear tire models.
    """

    m: float = 1600.0
    Iz: float = 2800.0
    lf: float = 1.25
    lr: float = 1.55
    C_af: float = 100000.0
    C_ar: float = 120000.0
    g: float = 9.81
    mu: float = 1.0

    def __post_init__(self) -> None:
        for name in PARAM_FIELDS:
            validate_positive(f"BicycleParams.{name}", getattr(self, name))

    @cached_property
    def array(self) -> np.ndarray:
        """Kernel array, fields :data:`PARAM_FIELDS`."""
        return np.array([getattr(self, n) for n in PARAM_FIELDS], dtype=np.float64)

    @property
    def wheelbase(self) -> float:
        """L = lf + lr (m)."""
        return self.lf + self.lr

    def axle_loads(self) -> tuple[float, float]:
        """Static axle normal loads (Fz_f, Fz_r) in N."""
        return axle_loads(self.array)

    def understeer_gradient(self) -> float:
        """K_us = (m/L)(lr/C_af − lf/C_ar) (rad·s²/m)."""
        return self.m / self.wheelbase * (self.lr / self.C_af - self.lf / self.C_ar)


def check_vx(vx: float) -> float:
    """Validate a longitudinal speed (m/s): finite and above :data:`MIN_VX`."""
    v = float(vx)
    if not np.isfinite(v) or v <= MIN_VX:
        raise ValueError(f"vx must be a finite speed above {MIN_VX} m/s, got {vx!r}")
    return v


# --------------------------------------------------------------------------- kernels
@njit(cache=True)
def slip_angles(vy, r, delta_f, delta_r, vx, lf, lr):  # pragma: no cover - compiled
    """Axle slip angles (rad): α_f = δ_f − (vy + lf·r)/vx, α_r = δ_r − (vy − lr·r)/vx."""
    return delta_f - (vy + lf * r) / vx, delta_r - (vy - lr * r) / vx


@njit(cache=True)
def axle_loads(pa):  # pragma: no cover - compiled
    """Static axle loads Fz_f = m·g·lr/L, Fz_r = m·g·lf/L (N)."""
    big_l = pa[LF] + pa[LR]
    return pa[M] * pa[G] * pa[LR] / big_l, pa[M] * pa[G] * pa[LF] / big_l


@njit(cache=True)
def body_derivative(vy, r, fyf, fyr, vx, pa):  # pragma: no cover - compiled
    """Force balance eq. 2.4-2.5: dvy/dt = (Fyf+Fyr)/m − vx·r, dr/dt = (lf·Fyf − lr·Fyr)/Iz."""
    return (fyf + fyr) / pa[M] - vx * r, (pa[LF] * fyf - pa[LR] * fyr) / pa[IZ]


@njit(cache=True, inline="always")
def nominal_entries(vy, r, u1, u2, theta):  # pragma: no cover - compiled
    """Nominal (dvy/dt, dr/dt) = A x + B u (linear tires) on scalars; theta = params + [vx]."""
    vx = theta[VX]
    af, ar = slip_angles(vy, r, u1, u2, vx, theta[LF], theta[LR])
    return body_derivative(vy, r, linear_force(af, theta[C_AF]),
                           linear_force(ar, theta[C_AR]), vx, theta)


@njit(cache=True)
def nominal_derivative(x, u, theta):  # pragma: no cover - compiled
    """Nominal f(x, u) = A x + B u (linear tires); theta = params array + [vx]."""
    out = np.empty(2)
    out[0], out[1] = nominal_entries(x[0], x[1], u[0], u[1], theta)
    return out


@njit(cache=True)
def nominal_derivatives(x, u, theta):  # pragma: no cover - compiled
    """:func:`nominal_derivative` of every row of x (N, 2), u (N, 2): (N, 2)."""
    out = np.empty((x.shape[0], 2))
    for i in range(x.shape[0]):
        out[i, 0], out[i, 1] = nominal_entries(x[i, 0], x[i, 1], u[i, 0], u[i, 1], theta)
    return out


@njit(cache=True, inline="always")
def _forces(s0, s1, s2, s3, s4, s5, u1, u2, theta):  # pragma: no cover - compiled
    vx, mu_f, mu_r, c_mf, e_mf = theta[VX], theta[MU_F], theta[MU_R], theta[MF_C], theta[MF_E]
    relax_f, relax_r, lag = theta[RELAX_F], theta[RELAX_R], theta[STEER_LAG]
    d_f = s4 if lag > 0.0 else u1
    d_r = s5 if lag > 0.0 else u2
    af_ss, ar_ss = slip_angles(s0, s1, d_f, d_r, vx, theta[LF], theta[LR])
    af = s2 if relax_f > 0.0 else af_ss
    ar = s3 if relax_r > 0.0 else ar_ss
    if mu_f > 0.0 or mu_r > 0.0:  # a saturating (Magic Formula) tire on some axle
        fzf, fzr = axle_loads(theta)
        fyf = magic_formula(af, theta[C_AF], fzf, mu_f, c_mf, e_mf) if mu_f > 0.0 \
            else linear_force(af, theta[C_AF])
        fyr = magic_formula(ar, theta[C_AR], fzr, mu_r, c_mf, e_mf) if mu_r > 0.0 \
            else linear_force(ar, theta[C_AR])
    else:
        fyf = linear_force(af, theta[C_AF])
        fyr = linear_force(ar, theta[C_AR])
    return fyf, fyr, af_ss, ar_ss


@njit(cache=True)
def plant_forces(s, u, theta):  # pragma: no cover - compiled
    """True axle forces (N) and the steady-state slip angles (rad) of the plant."""
    return _forces(s[0], s[1], s[2], s[3], s[4], s[5], u[0], u[1], theta)


@njit(cache=True, inline="always")
def _derivative(s0, s1, s2, s3, s4, s5, u1, u2, theta):  # pragma: no cover - compiled
    vx, relax_f, relax_r, lag = theta[VX], theta[RELAX_F], theta[RELAX_R], theta[STEER_LAG]
    fyf, fyr, af_ss, ar_ss = _forces(s0, s1, s2, s3, s4, s5, u1, u2, theta)
    dvy, dr = body_derivative(s0, s1, fyf, fyr, vx, theta)
    d2 = relaxation_rate(s2, af_ss, vx, relax_f) if relax_f > 0.0 else 0.0
    d3 = relaxation_rate(s3, ar_ss, vx, relax_r) if relax_r > 0.0 else 0.0
    d4 = (u1 - s4) / lag if lag > 0.0 else 0.0
    d5 = (u2 - s5) / lag if lag > 0.0 else 0.0
    return dvy + theta[AY0], dr + theta[DR0], d2, d3, d4, d5


@njit(cache=True)
def plant_derivative(s, u, theta):  # pragma: no cover - compiled
    """True dynamics of the 6-entry plant state (see the module docstring)."""
    out = np.empty(6)
    out[0], out[1], out[2], out[3], out[4], out[5] = _derivative(
        s[0], s[1], s[2], s[3], s[4], s[5], u[0], u[1], theta)
    return out


@njit(cache=True, inline="always")
def plant_rk4(s0, s1, s2, s3, s4, s5, u1, u2, theta, dt, n_sub):  # pragma: no cover
    """:func:`plant_derivative` advanced by dt (s) with n_sub RK4 sub-steps, on scalars.

    The same operations in the same order as ``integrators.rk4(plant_derivative, ...)``
    (stage formulas :func:`~simgap.models.integrators.rk4_stage` / ``rk4_combine``), so
    bit-identical to it without an array per stage (a test pins the equality).
    """
    h = dt / n_sub
    half = 0.5 * h
    h6 = h / 6.0
    for _ in range(n_sub):
        a0, a1, a2, a3, a4, a5 = _derivative(s0, s1, s2, s3, s4, s5, u1, u2, theta)
        b0, b1, b2, b3, b4, b5 = _derivative(
            rk4_stage(s0, half, a0), rk4_stage(s1, half, a1), rk4_stage(s2, half, a2),
            rk4_stage(s3, half, a3), rk4_stage(s4, half, a4), rk4_stage(s5, half, a5),
            u1, u2, theta)
        c0, c1, c2, c3, c4, c5 = _derivative(
            rk4_stage(s0, half, b0), rk4_stage(s1, half, b1), rk4_stage(s2, half, b2),
            rk4_stage(s3, half, b3), rk4_stage(s4, half, b4), rk4_stage(s5, half, b5),
            u1, u2, theta)
        d0, d1, d2, d3, d4, d5 = _derivative(
            rk4_stage(s0, h, c0), rk4_stage(s1, h, c1), rk4_stage(s2, h, c2),
            rk4_stage(s3, h, c3), rk4_stage(s4, h, c4), rk4_stage(s5, h, c5), u1, u2, theta)
        s0, s1, s2, s3, s4, s5 = (rk4_combine(s0, h6, a0, b0, c0, d0),
                                  rk4_combine(s1, h6, a1, b1, c1, d1),
                                  rk4_combine(s2, h6, a2, b2, c2, d2),
                                  rk4_combine(s3, h6, a3, b3, c3, d3),
                                  rk4_combine(s4, h6, a4, b4, c4, d4),
                                  rk4_combine(s5, h6, a5, b5, c5, d5))
    return s0, s1, s2, s3, s4, s5


@njit(cache=True)
def plant_step(s, u, theta, dt, n_sub):  # pragma: no cover - compiled
    """Advance the plant by dt (s) with n_sub RK4 sub-steps (disk-cached; see plant_rk4)."""
    out = np.empty(6)
    out[0], out[1], out[2], out[3], out[4], out[5] = plant_rk4(
        s[0], s[1], s[2], s[3], s[4], s[5], u[0], u[1], theta, dt, n_sub)
    return out


@njit(cache=True)
def true_residual_vs(s, u, theta, theta_nom):  # pragma: no cover - compiled
    """Compute the true g(x, u) against a nominal with other vehicle parameters.

    Like :func:`true_residual`, but the nominal f uses ``theta_nom`` = nominal params array
    + [vx], for plants whose vehicle parameters differ from the nominal ones.
    """
    out = np.empty(2)
    out[0], out[1] = residual_entries(s[0], s[1], s[2], s[3], s[4], s[5], u[0], u[1], theta,
                                      theta_nom)
    return out


@njit(cache=True, inline="always")
def residual_entries(s0, s1, s2, s3, s4, s5, u1, u2, theta,
                     theta_nom):  # pragma: no cover - compiled
    """:func:`true_residual_vs` on scalars: (g_vy, g_r) in m/s², rad/s²."""
    d0, d1, _, _, _, _ = _derivative(s0, s1, s2, s3, s4, s5, u1, u2, theta)
    f0, f1 = nominal_entries(s0, s1, u1, u2, theta_nom)
    return d0 - f0, d1 - f1


@njit(cache=True)
def true_residual(s, u, theta):  # pragma: no cover - compiled
    """True g(x, u) = dx/dt_true − f_nom(x, u) at plant state s, commanded input u.

    The nominal uses the plant array's vehicle parameters and the commanded steering; with
    the spec's plant (same parameters) this is K·Delta with Delta the tire-force deviation.
    """
    return true_residual_vs(s, u, theta, theta)


@njit(cache=True, inline="always")
def axle_force_entries(g_vy, g_r, k_inv):  # pragma: no cover - compiled
    """Axle-force deviations (Delta_f, Delta_r) = K⁻¹ g (N) from g = (g_vy, g_r) (m/s², rad/s²)."""
    return k_inv[0, 0] * g_vy + k_inv[0, 1] * g_r, k_inv[1, 0] * g_vy + k_inv[1, 1] * g_r


@njit(cache=True)
def axle_force_rows(g, k_inv):  # pragma: no cover - compiled
    """:func:`axle_force_entries` of every row of g (N, 2): Delta (N, 2) in N.

    Written out rather than a BLAS product, whose matrix-vector and matrix-matrix kernels
    round differently: one row and many rows give the same bits (single and vector envs).
    """
    out = np.empty((g.shape[0], 2))
    for i in range(g.shape[0]):
        out[i, 0], out[i, 1] = axle_force_entries(g[i, 0], g[i, 1], k_inv)
    return out


def plant_array(params: BicycleParams, vx: float, *, tire: MagicFormulaTire | None = None,
                mu: tuple[float | None, float | None] | None = None,
                relaxation_length: float | tuple[float, float] = 0.0, steering_lag: float = 0.0,
                lateral_bias: float = 0.0, yaw_bias: float = 0.0) -> np.ndarray:
    """Flat array for :func:`plant_derivative`, fields :data:`PLANT_FIELDS`.

    Args:
        params: true vehicle parameters.
        vx: longitudinal speed (m/s).
        tire: Magic Formula shape, or ``None`` for linear tires on both axles.
        mu: road friction (-) of the Magic Formula tire per axle, (front, rear); ``None``
            for an axle keeps its tire linear. Default (with ``tire``): ``params.mu`` on both
            axles. Needs ``tire``.
        relaxation_length: tire relaxation length σ (m), one value or (front, rear); 0 = off.
        steering_lag: first-order lag of the road-wheel angle behind the command (s); 0 = off.
        lateral_bias: constant lateral acceleration on the body (m/s²), e.g. road bank.
        yaw_bias: constant yaw acceleration (rad/s²).
    """
    relax = (relaxation_length, relaxation_length) if np.isscalar(relaxation_length) \
        else tuple(relaxation_length)
    for v in relax:
        validate_positive("relaxation_length", v, allow_zero=True)
    validate_positive("steering_lag", steering_lag, allow_zero=True)
    if tire is None and mu is not None:
        raise ValueError(f"per-axle mu {mu!r} needs a Magic Formula tire (tire=...)")
    axle_mu = (params.mu, params.mu) if mu is None else tuple(mu)
    if len(axle_mu) != 2:
        raise ValueError(f"mu needs (front, rear) values, got {mu!r}")
    mus = [0.0 if tire is None or m is None else validate_positive("mu", m) for m in axle_mu]
    mf = tire if tire is not None else MagicFormulaTire()
    extra = [check_vx(vx), mf.C, mf.E, mus[0], mus[1], relax[0], relax[1], steering_lag,
             lateral_bias, yaw_bias]
    if not np.all(np.isfinite(extra)):
        raise ValueError(f"plant options must be finite, got {extra!r}")
    return np.concatenate([params.array, np.array(extra, dtype=np.float64)])


def has_lag_states(theta: np.ndarray) -> bool:
    """True when a plant array integrates tire-relaxation or steering-lag states."""
    return bool(theta[RELAX_F] > 0.0 or theta[RELAX_R] > 0.0 or theta[STEER_LAG] > 0.0)


def has_steering_lag(theta: np.ndarray) -> bool:
    """True when the road-wheel angle of a plant array lags the command (plant state 4:6)."""
    return bool(theta[STEER_LAG] > 0.0)


def system_matrices(params: BicycleParams, vx: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A, B, K of thesis eq. 2.7 at speed vx (m/s): dx/dt = A x + B u + K Delta."""
    vx = check_vx(vx)
    m, iz, lf, lr, caf, car = (params.m, params.Iz, params.lf, params.lr, params.C_af,
                               params.C_ar)
    a = np.array([[-(caf + car) / (m * vx), -(caf * lf - car * lr) / (m * vx) - vx],
                  [-(lf * caf - lr * car) / (iz * vx), -(lf**2 * caf + lr**2 * car) / (iz * vx)]])
    b = np.array([[caf / m, car / m], [lf * caf / iz, -lr * car / iz]])
    k = np.array([[1.0 / m, 1.0 / m], [lf / iz, -lr / iz]])
    return a, b, k


def state_derivative(x: np.ndarray, u: np.ndarray, params: BicycleParams,
                     vx: float | np.ndarray) -> np.ndarray:
    """Nominal dx/dt = A x + B u for x = (vy, r), u = (delta_f, delta_r) (rad).

    Vectorised: ``x`` and ``u`` may have shape (N, 2) with ``vx`` of shape (N,) — how the
    diagnosis evaluates a recording whose speed varies.
    """
    x = np.asarray(x, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    vx = np.asarray(vx, dtype=np.float64)
    if np.any(~np.isfinite(vx)) or np.any(vx <= MIN_VX):
        raise ValueError(f"vx must be finite and above {MIN_VX} m/s")
    af, ar = slip_angles(x[..., 0], x[..., 1], u[..., 0], u[..., 1], vx, params.lf, params.lr)
    dvy, dr = body_derivative(x[..., 0], x[..., 1], params.C_af * af, params.C_ar * ar, vx,
                              params.array)
    return np.stack([dvy, dr], axis=-1)


# --------------------------------------------------------------------------- nominal model
class BicycleNominal(BaseNominalModel):
    """Nominal model ``bicycle`` of ``spec/models.md`` (protocol in ``base.py``).

    The physical residual is the axle-force deviation Delta = K⁻¹ g (N).
    """

    name = "bicycle"
    state_names = STATE_NAMES
    state_units = STATE_UNITS
    input_names = INPUT_NAMES
    input_units = INPUT_UNITS
    obs_names = STATE_NAMES
    obs_units = STATE_UNITS
    recording_columns = RECORDING_COLUMNS

    def __init__(self, params: BicycleParams | None = None, vx: float = 20.0,
                 dt: float = 0.01) -> None:
        validate_positive("dt", dt)
        self.params = params if params is not None else BicycleParams()
        self.vx = check_vx(vx)
        self.dt = float(dt)
        self.A, self.B, self.K = system_matrices(self.params, self.vx)
        self.K_inv = np.linalg.inv(self.K)
        self._theta = np.concatenate([self.params.array, [self.vx]])

    def __repr__(self) -> str:
        return f"BicycleNominal(params={self.params!r}, vx={self.vx}, dt={self.dt})"

    @property
    def residual_names(self) -> tuple[str, ...]:
        """Axle lateral-force deviations."""
        return ("Delta_f", "Delta_r")

    @property
    def residual_units(self) -> tuple[str, ...]:
        """N per axle."""
        return ("N", "N")

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal f(x, u) = A x + B u (eq. 2.7)."""
        return nominal_derivative(np.asarray(x, dtype=np.float64),
                                  np.asarray(u, dtype=np.float64), self._theta)

    def states(self, obs: np.ndarray) -> np.ndarray:
        """:meth:`state` of every row of ``obs`` (N, 2): a float64 copy (no per-row calls)."""
        return np.array(obs, dtype=np.float64)

    def f_rows(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """:meth:`f` of every row of x (N, 2), u (N, 2) in one kernel call."""
        return nominal_derivatives(np.ascontiguousarray(x, dtype=np.float64),
                                   np.ascontiguousarray(u, dtype=np.float64), self._theta)

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """State residual g (…, 2) → axle force deviations Delta = K⁻¹ g (N)."""
        g = np.asarray(g, dtype=np.float64)
        if g.shape == (2,):  # one residual (the env's step): the scalar kernel, no row copy
            return np.array(axle_force_entries(g[0], g[1], self.K_inv))
        rows = np.ascontiguousarray(g.reshape(-1, 2))
        return axle_force_rows(rows, self.K_inv).reshape(g.shape)

    def with_speed(self, vx: float) -> BicycleNominal:
        """The same model at another longitudinal speed (m/s)."""
        return BicycleNominal(self.params, vx=vx, dt=self.dt)


# --------------------------------------------------------------------------- plant
AXLES = ("front_axle", "rear_axle")
_ANY = (-math.inf, math.inf)
_NONNEG = (0.0, math.inf)


def _saturation(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    for a in (0, 1) if j is None else (j,):
        acc["mu"][a] = v["mu"]


def _stiffness(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    key = ("C_af", "C_ar")[j]
    acc["kw"][key] = acc["kw"][key] * v["ratio"]


def _scale(key: str) -> Callable[[dict, int | None, Mapping[str, float]], None]:
    def write(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
        acc["kw"][key] = acc["kw"][key] * v["ratio"]
    return write


def _value(key: str, name: str) -> Callable[[dict, int | None, Mapping[str, float]], None]:
    def write(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
        acc[key] = v[name]
    return write


def _relaxation(acc: dict, j: int | None, v: Mapping[str, float]) -> None:
    for a in (0, 1) if j is None else (j,):
        acc["relax"][a] += v["length"]


# --------------------------------------------------------------------------- fit side
# Contributions of the vocabulary to the axle-force residual Delta = K⁻¹(dx/dt − f) (N per
# axle, thesis eq. 2.4-2.7), used by the diagnosis (``FitSpec.fn``). ``sig``: ``vy``, ``r``,
# ``dvy``, ``dr``, ``vx``, ``delta_f``, ``delta_r``, ``alpha_f``, ``alpha_r`` (N,) and
# ``idx``; ``ctx``: the diagnosis' EffectContext (stiffness, loads, tire, K_inv, ...).
AXLE_KEYS = (("alpha_f", "delta_f"), ("alpha_r", "delta_r"))


def _fit_saturation(lin, nl, sig, i, ctx):
    alpha = sig[AXLE_KEYS[i][0]]
    ca, fz = ctx.stiffness[i], ctx.loads[i]
    fy = magic_formula(alpha, ca, fz, nl[0], ctx.tire.C, ctx.tire.E)
    return on_channel(fy - ca * alpha, i, 2)


def _fit_stiffness(lin, nl, sig, i, ctx):
    """Cornering-stiffness ratio − 1 times the axle's linear tire force C·α (N).

    The fit reads ``alpha_f_ref``/``alpha_r_ref`` where the form provides them: the slip
    angle from the filtered states carries their noise, which the residual carries too
    (through the nominal tire force), the errors in variables that shrank the joint scale
    of mass and both tire laws on clean circles to 0.89-0.92 once the mass regressor was
    instrumented exactly; projected on the same instruments as the inertia terms'
    (:meth:`simgap.diagnosis.systems.BicycleSystem.reference_accelerations`) it is 1.00. A
    simulation reads the slip angle itself.
    """
    key = AXLE_KEYS[i][0]
    alpha = sig[key + "_ref"] if key + "_ref" in sig else sig[key]
    return on_channel(lin[0] * ctx.stiffness[i] * alpha, i, 2)


def _fit_steer_lag(lin, nl, sig, i, ctx):
    """Force change (N) from the road-wheel angle lagging the command.

    It goes through the axle's tire law of the same model — the Magic Formula if a
    tire_saturation term with mu is fitted on this axle (``ctx.axle_mu``), else the linear
    tire — so that the two effects compose exactly.
    """
    lagged = ctx.lagged_steering(i, nl[0])[sig["idx"]]
    d_delta = lagged - sig[AXLE_KEYS[i][1]]
    mu = ctx.axle_mu.get(i)
    if mu is None:
        return on_channel(ctx.stiffness[i] * d_delta, i, 2)
    alpha = sig[AXLE_KEYS[i][0]]
    ca, fz = ctx.stiffness[i], ctx.loads[i]
    fy = magic_formula(alpha + d_delta, ca, fz, mu, ctx.tire.C, ctx.tire.E) - \
        magic_formula(alpha, ca, fz, mu, ctx.tire.C, ctx.tire.E)
    return on_channel(fy, i, 2)


def _fit_lateral(lin, nl, sig, i, ctx):
    return lin[0] * np.outer(np.ones(sig["vy"].shape[0]), ctx.K_inv[:, 0])


def _fit_yaw(lin, nl, sig, i, ctx):
    return lin[0] * np.outer(np.ones(sig["vy"].shape[0]), ctx.K_inv[:, 1])


def _fit_mass(lin, nl, sig, i, ctx):
    """Mass ratio − 1 times the lateral acceleration ay (m/s²), as axle forces (N).

    The fit reads ``ay_ref`` where the form provides it (the measured ay projected on
    instruments that carry none of the residual's derivative noise: errors in variables,
    :meth:`simgap.diagnosis.systems.BicycleSystem.reference_accelerations`); a simulation,
    ``dvy + vx·r``.
    """
    ay = sig["ay_ref"] if "ay_ref" in sig else sig["dvy"] + sig["vx"] * sig["r"]
    return -lin[0] * np.outer(ay, ctx.K_inv[:, 0])


def _fit_yaw_inertia(lin, nl, sig, i, ctx):
    """Yaw-inertia ratio − 1 times dr/dt (rad/s²), as axle forces (N).

    ``dr_ref`` where the form provides it, as :func:`_fit_mass` reads ``ay_ref``.
    """
    dr = sig["dr_ref"] if "dr_ref" in sig else sig["dr"]
    return -lin[0] * np.outer(dr, ctx.K_inv[:, 1])


def _ratio_report(effect, lin, nl, cov, context):
    """Report ratio = 1 + internal (ratio − 1)."""
    return ({"ratio": float(1.0 + lin[0])}, {"ratio": stderr_of(cov, 0)}, {"ratio": "-"})


def _ratio_coords(params, context):
    """Fit coordinate of a reported ratio: ratio − 1 (inverse of :func:`_ratio_report`)."""
    return (params["ratio"] - 1.0,), ()


def _ratio_fit(scope: str, lower: float, upper: float, fn: Any, *,
               uses_derivatives: bool = False, symmetric_with: tuple[str, ...] = ()
               ) -> FitSpec:
    """A ratio fitted as ratio − 1 within [lower, upper] and reported as the ratio."""
    return FitSpec(scope=scope, lin=("ratio_minus_1",), lin_units=("-",), lin_lower=(lower,),
                   lin_upper=(upper,), uses_derivatives=uses_derivatives, fn=fn,
                   to_report=_ratio_report, from_report=_ratio_coords,
                   symmetric_with=symmetric_with)


#: Mass, yaw inertia and every tire force scaled by one factor leave the motion unchanged:
#: an inertia ratio is named only where it is determined with both axles' tire-law scales
#: (cornering stiffness ratios) freed beside it.
_TIRE_SCALE = ("cornering_stiffness",)


def _steering_lag_for_data(effect, sig, axle, ctx):
    """No steering lag on an axle whose recorded command (rad) does not vary.

    A lag of a constant command has no effect on the motion, so its time constant cannot be
    fitted.
    """
    key = ("delta_f", "delta_r")[axle]
    return None if np.ptp(sig[key]) < 1e-6 else effect


#: The vehicle's effect vocabulary (``spec/diagnosis.md``) plus the injection-only
#: ``tire_relaxation``, in fold order.
VOCABULARY = (
    EffectSpec(name="tire_saturation", label="tire saturation", scope="channel",
               all_channels=True,
               params=(Param(name="mu", unit="-", bounds=(1e-9, math.inf), inject=(0.5, 0.8)),),
               write=_saturation,
               fit=FitSpec(scope="axle", nl=("mu",), nl_units=("-",), nl_bounds=((0.1, 3.0),),
                           nl_grid=((0.4, 0.7, 1.0, 1.5, 2.5),), nl_vanishes=("high",),
                           fn=_fit_saturation)),
    EffectSpec(name="cornering_stiffness", label="cornering stiffness off", scope="channel",
               params=(Param(name="ratio", unit="-", bounds=(1e-9, math.inf),
                             inject=(0.7, 0.85)),),
               write=_stiffness, fit=_ratio_fit("axle", -0.7, 1.5, _fit_stiffness)),
    EffectSpec(name="lateral_bias", label="lateral bias", scope="system",
               params=(Param(name="ay0", unit="m/s²", bounds=_ANY, inject=(0.2, 0.5),
                             signed=True),),
               write=_value("lateral_bias", "ay0"),
               fit=FitSpec(scope="vehicle", lin=("ay0",), lin_units=("m/s²",),
                           lin_lower=(-math.inf,), fn=_fit_lateral)),
    EffectSpec(name="yaw_bias", label="yaw bias", scope="system",
               params=(Param(name="dr0", unit="rad/s²", bounds=_ANY, inject=(0.08, 0.2),
                             signed=True),),
               write=_value("yaw_bias", "dr0"),
               fit=FitSpec(scope="vehicle", lin=("dr0",), lin_units=("rad/s²",),
                           lin_lower=(-math.inf,), fn=_fit_yaw)),
    EffectSpec(name="mass_mismatch", label="mass mismatch", scope="system",
               params=(Param(name="ratio", unit="-", bounds=(1e-9, math.inf),
                             inject=(1.1, 1.25)),),
               write=_scale("m"),
               fit=_ratio_fit("vehicle", -0.5, 1.0, _fit_mass, uses_derivatives=True,
                              symmetric_with=_TIRE_SCALE)),
    EffectSpec(name="yaw_inertia_mismatch", label="yaw inertia mismatch", scope="system",
               params=(Param(name="ratio", unit="-", bounds=(1e-9, math.inf),
                             inject=(1.15, 1.3)),),
               write=_scale("Iz"),
               fit=_ratio_fit("vehicle", -0.5, 1.0, _fit_yaw_inertia, uses_derivatives=True,
                              symmetric_with=_TIRE_SCALE)),
    EffectSpec(name="steering_lag", label="steering lag", scope="channel", all_channels=True,
               params=(Param(name="tau", unit="s", bounds=_NONNEG, inject=(0.04, 0.15)),),
               write=_value("steering_lag", "tau"), needs=("tire_saturation",),
               fit=FitSpec(scope="axle", nl=("tau",), nl_units=("s",), nl_bounds=((1e-3, 0.5),),
                           nl_grid=((0.02, 0.05, 0.1, 0.3),), nl_vanishes=("low",), latency=True,
                           fn=_fit_steer_lag,
                           for_data=_steering_lag_for_data)),
    EffectSpec(name="tire_relaxation", label="tire relaxation", scope="channel",
               all_channels=True, vocabulary=False,
               params=(Param(name="length", unit="m", bounds=_NONNEG),),
               write=_relaxation),
)


def _fold(plant: Plant) -> Folded:
    """Plant → effective vehicle parameters, tire, options → kernel array :data:`PLANT`.

    Each axle's tire reads its own road μ (``mu_f``, ``mu_r``): ``tire_saturation`` on one
    axle saturates that axle only, the other keeps its linear tire; without a channel it acts
    on both. The parameters' ``mu`` is the axles' common μ (their mean where they differ, a
    summary no tire reads).
    """
    p = plant.params
    acc: dict[str, Any] = {"kw": {f: getattr(p, f) for f in PARAM_FIELDS}, "mu": [None, None],
                           "steering_lag": 0.0, "lateral_bias": 0.0, "yaw_bias": 0.0,
                           "relax": [0.0, 0.0]}
    for e in plant.effects:
        plant.schema.effect(e.name).write(acc, channel_index(AXLES, e.channel), e.params)
    mus = [m for m in acc["mu"] if m is not None]
    if mus:
        acc["kw"]["mu"] = float(np.mean(mus))
    params = p if acc["kw"] == {f: getattr(p, f) for f in PARAM_FIELDS} \
        else BicycleParams(**acc["kw"])
    opts = plant.options
    tire = MagicFormulaTire(C=opts["mf_C"], E=opts["mf_E"]) if mus else None
    theta = plant_array(params, opts["vx"], tire=tire, mu=tuple(acc["mu"]) if mus else None,
                        relaxation_length=tuple(acc["relax"]),
                        steering_lag=acc["steering_lag"], lateral_bias=acc["lateral_bias"],
                        yaw_bias=acc["yaw_bias"])
    return Folded(params, theta, {"tire": tire, "axle_mu": tuple(acc["mu"]),
                                  "steering_lag": acc["steering_lag"],
                                  "lateral_bias": acc["lateral_bias"],
                                  "yaw_bias": acc["yaw_bias"], "relax": tuple(acc["relax"])})


_MF = MagicFormulaTire()
#: The vehicle's plant declaration; ``PLANT_SCHEMA.plant(params, effects, vx=...)``.
PLANT_SCHEMA = PlantSchema(system="bicycle", params_cls=BicycleParams, channels=AXLES,
                           vocabulary=VOCABULARY,
                           options={"vx": 20.0, "mf_C": _MF.C, "mf_E": _MF.E}, fold=_fold)


def make_plant(params: BicycleParams | None = None, vx: float = 20.0, *,
               tire: MagicFormulaTire | None = None,
               relaxation_length: float | tuple[float, float] = 0.0,
               steering_lag: float = 0.0, lateral_bias: float = 0.0, yaw_bias: float = 0.0,
               effects: tuple[EffectInstance, ...] = ()) -> Plant:
    """The vehicle's :class:`Plant` from the env's keyword form.

    The keywords mean what :func:`plant_array`'s do; μ is ``params.mu`` where ``tire``
    saturates.
    """
    p = params if params is not None else BicycleParams()
    relax = (relaxation_length, relaxation_length) if np.isscalar(relaxation_length) \
        else tuple(relaxation_length)
    if len(relax) != 2:
        raise ModelError(f"relaxation_length needs 1 or 2 values, got {relaxation_length!r}")
    inst: list[EffectInstance] = []
    if tire is not None:
        inst.append(EffectInstance("tire_saturation", None, {"mu": p.mu}))
    for a, length in zip(AXLES, relax, strict=True):
        validate_positive("relaxation_length", length, allow_zero=True)
        if length != 0.0:
            inst.append(EffectInstance("tire_relaxation", a, {"length": float(length)}))
    validate_positive("steering_lag", steering_lag, allow_zero=True)
    for name, key, v in (("steering_lag", "tau", steering_lag),
                         ("lateral_bias", "ay0", lateral_bias), ("yaw_bias", "dr0", yaw_bias)):
        if not math.isfinite(float(v)):
            raise ModelError(f"{name} must be finite, got {v!r}")
        if float(v) != 0.0:
            inst.append(EffectInstance(name, None, {key: float(v)}))
    mf = tire if tire is not None else MagicFormulaTire()
    return PLANT_SCHEMA.plant(p, tuple(inst) + tuple(effects), vx=check_vx(vx), mf_C=mf.C,
                              mf_E=mf.E)


guard_cache(globals(), ("simgap.models.integrators", "simgap.models.slots",
                        "simgap.models.tires"))
