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

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from simgap.models.base import BaseNominalModel, validate_positive
from simgap.models.integrators import rk4
from simgap.models.tires import MagicFormulaTire, linear_force, magic_formula, relaxation_rate

PARAM_FIELDS = ("m", "Iz", "lf", "lr", "C_af", "C_ar", "g", "mu")
STATE_NAMES = ("vy", "r")
STATE_UNITS = ("m/s", "rad/s")
INPUT_NAMES = ("delta_f", "delta_r")
INPUT_UNITS = ("rad", "rad")
RECORDING_COLUMNS = ("t", "vx", "vy", "r", "delta_f", "delta_r")
MIN_VX = 1.0  # m/s: below it the slip-angle model is singular


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
    big_l = pa[2] + pa[3]
    return pa[0] * pa[6] * pa[3] / big_l, pa[0] * pa[6] * pa[2] / big_l


@njit(cache=True)
def body_derivative(vy, r, fyf, fyr, vx, pa):  # pragma: no cover - compiled
    """Force balance eq. 2.4-2.5: dvy/dt = (Fyf+Fyr)/m − vx·r, dr/dt = (lf·Fyf − lr·Fyr)/Iz."""
    return (fyf + fyr) / pa[0] - vx * r, (pa[2] * fyf - pa[3] * fyr) / pa[1]


@njit(cache=True)
def nominal_derivative(x, u, theta):  # pragma: no cover - compiled
    """Nominal f(x, u) = A x + B u (linear tires); theta = params array + [vx]."""
    vx = theta[8]
    af, ar = slip_angles(x[0], x[1], u[0], u[1], vx, theta[2], theta[3])
    dvy, dr = body_derivative(x[0], x[1], linear_force(af, theta[4]), linear_force(ar, theta[5]),
                              vx, theta)
    out = np.empty(2)
    out[0] = dvy
    out[1] = dr
    return out


#: Layout of the plant array after the 8 vehicle parameters.
PLANT_FIELDS = PARAM_FIELDS + ("vx", "tire_model", "mf_C", "mf_E", "relax_f", "relax_r",
                               "steer_lag", "ay0", "dr0")


@njit(cache=True)
def plant_forces(s, u, theta):  # pragma: no cover - compiled
    """True axle forces (N) and the steady-state slip angles (rad) of the plant."""
    vx, tire, c_mf, e_mf = theta[8], theta[9], theta[10], theta[11]
    relax_f, relax_r, lag = theta[12], theta[13], theta[14]
    d_f = s[4] if lag > 0.0 else u[0]
    d_r = s[5] if lag > 0.0 else u[1]
    af_ss, ar_ss = slip_angles(s[0], s[1], d_f, d_r, vx, theta[2], theta[3])
    af = s[2] if relax_f > 0.0 else af_ss
    ar = s[3] if relax_r > 0.0 else ar_ss
    if tire > 0.5:
        fzf, fzr = axle_loads(theta)
        fyf = magic_formula(af, theta[4], fzf, theta[7], c_mf, e_mf)
        fyr = magic_formula(ar, theta[5], fzr, theta[7], c_mf, e_mf)
    else:
        fyf = linear_force(af, theta[4])
        fyr = linear_force(ar, theta[5])
    return fyf, fyr, af_ss, ar_ss


@njit(cache=True)
def plant_derivative(s, u, theta):  # pragma: no cover - compiled
    """True dynamics of the 6-entry plant state (see the module docstring)."""
    vx, relax_f, relax_r, lag = theta[8], theta[12], theta[13], theta[14]
    fyf, fyr, af_ss, ar_ss = plant_forces(s, u, theta)
    dvy, dr = body_derivative(s[0], s[1], fyf, fyr, vx, theta)
    out = np.zeros(6)
    out[0] = dvy + theta[15]
    out[1] = dr + theta[16]
    if relax_f > 0.0:
        out[2] = relaxation_rate(s[2], af_ss, vx, relax_f)
    if relax_r > 0.0:
        out[3] = relaxation_rate(s[3], ar_ss, vx, relax_r)
    if lag > 0.0:
        out[4] = (u[0] - s[4]) / lag
        out[5] = (u[1] - s[5]) / lag
    return out


@njit(cache=False)  # takes a kernel argument: numba cannot cache it
def plant_step(s, u, theta, dt, n_sub):  # pragma: no cover - compiled
    """Advance the plant by dt (s) with n_sub RK4 sub-steps (the env's step)."""
    return rk4(plant_derivative, s, u, theta, dt, n_sub)


@njit(cache=True)
def true_residual_vs(s, u, theta, theta_nom):  # pragma: no cover - compiled
    """Compute the true g(x, u) against a nominal with other vehicle parameters.

    Like :func:`true_residual`, but the nominal f uses ``theta_nom`` = nominal params array
    + [vx], for plants whose vehicle parameters differ from the nominal ones.
    """
    d = plant_derivative(s, u, theta)
    f = nominal_derivative(s[:2], u, theta_nom)
    out = np.empty(2)
    out[0] = d[0] - f[0]
    out[1] = d[1] - f[1]
    return out


@njit(cache=True)
def true_residual(s, u, theta):  # pragma: no cover - compiled
    """True g(x, u) = dx/dt_true − f_nom(x, u) at plant state s, commanded input u.

    The nominal uses the plant array's vehicle parameters and the commanded steering; with
    the spec's plant (same parameters) this is K·Delta with Delta the tire-force deviation.
    """
    return true_residual_vs(s, u, theta, theta)


def plant_array(params: BicycleParams, vx: float, *, tire: MagicFormulaTire | None = None,
                relaxation_length: float | tuple[float, float] = 0.0, steering_lag: float = 0.0,
                lateral_bias: float = 0.0, yaw_bias: float = 0.0) -> np.ndarray:
    """Flat array for :func:`plant_derivative`, fields :data:`PLANT_FIELDS`.

    Args:
        params: true vehicle parameters.
        vx: longitudinal speed (m/s).
        tire: Magic Formula shape, or ``None`` for linear tires.
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
    mf = tire if tire is not None else MagicFormulaTire()
    extra = [check_vx(vx), 1.0 if tire is not None else 0.0, mf.C, mf.E, relax[0], relax[1],
             steering_lag, lateral_bias, yaw_bias]
    if not np.all(np.isfinite(extra)):
        raise ValueError(f"plant options must be finite, got {extra!r}")
    return np.concatenate([params.array, np.array(extra, dtype=np.float64)])


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

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """State residual g (…, 2) → axle force deviations Delta = K⁻¹ g (N)."""
        return np.asarray(g, dtype=np.float64) @ self.K_inv.T

    def with_speed(self, vx: float) -> BicycleNominal:
        """The same model at another longitudinal speed (m/s)."""
        return BicycleNominal(self.params, vx=vx, dt=self.dt)
