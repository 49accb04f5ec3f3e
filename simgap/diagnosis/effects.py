"""The effect vocabulary (``spec/diagnosis.md``), one object per effect.

Each effect object holds its name, parameters with units and bounds, plain-words label and
model function.

An effect's function maps parameters and the recording's filtered signals to its
contribution to the physical residual, shape (N, n_channels): joint torques tau_d (N·m) for
mechanical systems (the left-out term of M ddq + C dq + G + tau_d = u, spec ``models.md``),
axle lateral-force deviations Delta (N) for the bicycle (thesis eq. 2.4-2.7). Parameters are
split into *linear* ones (the contribution is linear in them: fitted by bounded least
squares) and *nonlinear* ones (Stribeck velocity vs, tire mu, steering lag tau: fitted by
``scipy.optimize.least_squares`` around a coarse grid).

Signals (``sig``) by system:

* mechanical: ``q``, ``dq``, ``ddq`` arrays (N, n) in rad (m), rad/s, rad/s²;
* bicycle: ``vy``, ``r``, ``dvy``, ``dr``, ``vx``, ``delta_f``, ``delta_r``, ``alpha_f``,
  ``alpha_r`` (N,) in SI units, and ``idx`` (row indices into the full recording, used by
  effects with memory such as the steering lag).

The system adapter passed as ``sys`` supplies model quantities (coulomb smoothing, gravity
torques, payload regressor, axle stiffnesses, loads, K⁻¹, the lag filter) and, through
``set_context``, what other terms of the same model imply (the steering lag goes through a
tire_saturation term's Magic Formula on the same axle).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simgap.models.tires import magic_formula

EffectFn = Callable[[np.ndarray, np.ndarray, Mapping[str, np.ndarray], int | None, Any],
                    np.ndarray]


@dataclass(frozen=True, kw_only=True)
class Effect:
    """One vocabulary effect.

    Attributes:
        name: vocabulary name (``spec/diagnosis.md``).
        label: plain words for the report ("Coulomb friction").
        scope: ``joint`` / ``axle`` (one channel, one candidate per channel), ``arm`` /
            ``vehicle`` (all channels at once).
        lin: linear parameter names (internal form).
        lin_units: their SI units.
        lin_lower: lower bounds of the linear parameters (physical sign constraints, or
            plausibility limits).
        lin_upper: upper plausibility limits (default: none). A fit that ends on a
            plausibility limit (any bound other than a sign bound at 0) means the effect is
            being forced onto data it does not describe; such a term is not named.
        nl: nonlinear parameter names.
        nl_units: their SI units.
        nl_bounds: (low, high) per nonlinear parameter.
        nl_grid: starting values tried per nonlinear parameter.
        uses_derivatives: the contribution depends on accelerations (mass-type effects).
        generalizes: names of simpler effects this one contains as a special case (same
            channel); ties go to the simpler one without a collinearity warning.
        fn: the model, ``fn(lin, nl, sig, index, sys) -> (N, n_channels)``.
        to_report: maps internal parameters to the reported ones (see :func:`identity`).
    """

    name: str
    label: str
    scope: str
    lin: tuple[str, ...] = ()
    lin_units: tuple[str, ...] = ()
    lin_lower: tuple[float, ...] = ()
    lin_upper: tuple[float, ...] | None = None
    nl: tuple[str, ...] = ()
    nl_units: tuple[str, ...] = ()
    nl_bounds: tuple[tuple[float, float], ...] = ()
    nl_grid: tuple[tuple[float, ...], ...] = ()
    uses_derivatives: bool = False
    generalizes: tuple[str, ...] = ()
    fn: EffectFn = field(repr=False)
    to_report: Callable[..., tuple[dict[str, float], dict[str, float], dict[str, str]]] | None = \
        field(default=None, repr=False)

    @property
    def upper(self) -> tuple[float, ...]:
        """Upper bounds of the linear parameters."""
        return self.lin_upper if self.lin_upper is not None else (np.inf,) * len(self.lin)

    @property
    def n_params(self) -> int:
        """Number of fitted parameters."""
        return len(self.lin) + len(self.nl)

    def __call__(self, lin: np.ndarray, nl: np.ndarray, sig: Mapping[str, np.ndarray],
                 index: int | None, sys: Any) -> np.ndarray:
        """Contribution to the residual, (N, n_channels), in channel units."""
        return self.fn(np.asarray(lin, dtype=np.float64), np.asarray(nl, dtype=np.float64),
                       sig, index, sys)


def identity_report(effect: Effect, lin: np.ndarray, nl: np.ndarray, cov: np.ndarray,
                    context: Mapping[str, Any]) -> tuple[dict, dict, dict]:
    """Report the internal parameters as they are; stderr from the covariance diagonal."""
    names = effect.lin + effect.nl
    units = effect.lin_units + effect.nl_units
    vals = np.concatenate([lin, nl])
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return ({n: float(v) for n, v in zip(names, vals, strict=True)},
            {n: float(s) for n, s in zip(names, se, strict=True)},
            dict(zip(names, units, strict=True)))


def _one(sig: Mapping[str, np.ndarray], index: int, values: np.ndarray, n_ch: int) -> np.ndarray:
    out = np.zeros((values.shape[0], n_ch))
    out[:, index] = values
    return out


# --------------------------------------------------------------------------- mechanical
def _coulomb(lin, nl, sig, j, sys):
    dq = sig["dq"][:, j]
    return _one(sig, j, lin[0] * np.tanh(dq / sys.coulomb_sigma[j]), sys.n_channels)


def _viscous(lin, nl, sig, j, sys):
    return _one(sig, j, lin[0] * sig["dq"][:, j], sys.n_channels)


def _stribeck(lin, nl, sig, j, sys):
    dq = sig["dq"][:, j]
    bump = np.exp(-((dq / nl[0]) ** 2)) * np.tanh(dq / sys.coulomb_sigma[j])
    return _one(sig, j, lin[0] * bump, sys.n_channels)


def _bias(lin, nl, sig, j, sys):
    return _one(sig, j, np.full(sig["q"].shape[0], lin[0]), sys.n_channels)


def _spring(lin, nl, sig, j, sys):
    return _one(sig, j, lin[0] * sig["q"][:, j] + lin[1], sys.n_channels)


def _inertia(lin, nl, sig, j, sys):
    return _one(sig, j, lin[0] * sig["ddq"][:, j], sys.n_channels)


def _gravity(lin, nl, sig, j, sys):
    return lin[0] * sys.gravity(sig["q"])


def _payload(lin, nl, sig, j, sys):
    return lin[0] * sys.payload_regressor(sig["q"], sig["dq"], sig["ddq"])


def _stribeck_report(effect, lin, nl, cov, context):
    """Fs = Fc + (Fs − Fc): the breakaway torque includes the Coulomb level if one is named."""
    fc, var_fc, cov_a_fc = context.get("Fc", 0.0), context.get("var_Fc", 0.0), \
        context.get("cov_A_Fc", 0.0)
    var_fs = cov[0, 0] + var_fc + 2.0 * cov_a_fc
    return ({"Fs": float(lin[0] + fc), "vs": float(nl[0])},
            {"Fs": float(np.sqrt(max(var_fs, 0.0))), "vs": float(np.sqrt(max(cov[1, 1], 0.0)))},
            {"Fs": "N·m", "vs": "rad/s"})


def _spring_report(effect, lin, nl, cov, context):
    """Tau = k q + c  →  k (q − q0) with q0 = −c/k (delta method for its stderr)."""
    k, c = float(lin[0]), float(lin[1])
    q0 = -c / k if k != 0 else float("nan")
    grad = np.array([c / k**2, -1.0 / k]) if k != 0 else np.array([np.nan, np.nan])
    var_q0 = float(grad @ cov[:2, :2] @ grad)
    return ({"k": k, "q0": q0}, {"k": float(np.sqrt(max(cov[0, 0], 0.0))),
                                 "q0": float(np.sqrt(max(var_q0, 0.0)))},
            {"k": "N·m/rad", "q0": "rad"})


MECHANICAL_EFFECTS: tuple[Effect, ...] = (
    Effect(name="coulomb_friction", label="Coulomb friction", scope="joint", lin=("Fc",),
           lin_units=("N·m",), lin_lower=(0.0,), fn=_coulomb),
    Effect(name="viscous_friction", label="viscous friction", scope="joint", lin=("b",),
           lin_units=("N·m·s",), lin_lower=(0.0,), fn=_viscous),
    Effect(name="stribeck_friction", label="Stribeck friction", scope="joint", lin=("Fs",),
           lin_units=("N·m",), lin_lower=(0.0,), nl=("vs",), nl_units=("rad/s",),
           nl_bounds=((1e-3, 2.0),), nl_grid=((0.01, 0.03, 0.1, 0.3),),
           generalizes=("coulomb_friction",), fn=_stribeck, to_report=_stribeck_report),
    Effect(name="torque_bias", label="torque bias", scope="joint", lin=("tau0",),
           lin_units=("N·m",), lin_lower=(-np.inf,), fn=_bias),
    Effect(name="spring", label="spring", scope="joint", lin=("k", "c"),
           lin_units=("N·m/rad", "N·m"), lin_lower=(-np.inf, -np.inf),
           generalizes=("torque_bias",), fn=_spring, to_report=_spring_report),
    Effect(name="inertia_mismatch", label="extra inertia", scope="joint", lin=("dI",),
           lin_units=("kg·m²",), lin_lower=(0.0,), lin_upper=(0.5,), uses_derivatives=True,
           fn=_inertia),
    Effect(name="gravity_mismatch", label="gravity mismatch", scope="arm", lin=("dG",),
           lin_units=("-",), lin_lower=(-0.5,), lin_upper=(0.5,), fn=_gravity),
)
PAYLOAD = Effect(name="payload_mass", label="payload mass", scope="arm", lin=("mp",),
                 lin_units=("kg",), lin_lower=(0.0,), lin_upper=(10.0,), uses_derivatives=True,
                 fn=_payload)


# --------------------------------------------------------------------------- bicycle
AXLE_KEYS = (("alpha_f", "delta_f"), ("alpha_r", "delta_r"))


def _saturation(lin, nl, sig, i, sys):
    alpha = sig[AXLE_KEYS[i][0]]
    ca, fz = sys.stiffness[i], sys.loads[i]
    fy = magic_formula(alpha, ca, fz, nl[0], sys.tire.C, sys.tire.E)
    return _one(sig, i, fy - ca * alpha, 2)


def _stiffness(lin, nl, sig, i, sys):
    return _one(sig, i, lin[0] * sys.stiffness[i] * sig[AXLE_KEYS[i][0]], 2)


def _steer_lag(lin, nl, sig, i, sys):
    """Force change (N) from the road-wheel angle lagging the command.

    It goes through the axle's tire law of the same model — the Magic Formula if a
    tire_saturation term with mu is fitted on this axle (``sys.axle_mu``), else the linear
    tire — so that the two effects compose exactly.
    """
    lagged = sys.lagged_steering(i, nl[0])[sig["idx"]]
    d_delta = lagged - sig[AXLE_KEYS[i][1]]
    mu = getattr(sys, "axle_mu", {}).get(i)
    if mu is None:
        return _one(sig, i, sys.stiffness[i] * d_delta, 2)
    alpha = sig[AXLE_KEYS[i][0]]
    ca, fz = sys.stiffness[i], sys.loads[i]
    fy = magic_formula(alpha + d_delta, ca, fz, mu, sys.tire.C, sys.tire.E) - \
        magic_formula(alpha, ca, fz, mu, sys.tire.C, sys.tire.E)
    return _one(sig, i, fy, 2)


def _lateral(lin, nl, sig, i, sys):
    return lin[0] * np.outer(np.ones(sig["vy"].shape[0]), sys.K_inv[:, 0])


def _yaw(lin, nl, sig, i, sys):
    return lin[0] * np.outer(np.ones(sig["vy"].shape[0]), sys.K_inv[:, 1])


def _mass(lin, nl, sig, i, sys):
    ay = sig["dvy"] + sig["vx"] * sig["r"]
    return -lin[0] * np.outer(ay, sys.K_inv[:, 0])


def _yaw_inertia(lin, nl, sig, i, sys):
    return -lin[0] * np.outer(sig["dr"], sys.K_inv[:, 1])


def _ratio_report(effect, lin, nl, cov, context):
    """Report ratio = 1 + internal (ratio − 1)."""
    return ({"ratio": float(1.0 + lin[0])}, {"ratio": float(np.sqrt(max(cov[0, 0], 0.0)))},
            {"ratio": "-"})


BICYCLE_EFFECTS: tuple[Effect, ...] = (
    Effect(name="tire_saturation", label="tire saturation", scope="axle", nl=("mu",),
           nl_units=("-",), nl_bounds=((0.1, 3.0),), nl_grid=((0.4, 0.7, 1.0, 1.5, 2.5),),
           fn=_saturation),
    Effect(name="cornering_stiffness", label="cornering stiffness off", scope="axle",
           lin=("ratio_minus_1",), lin_units=("-",), lin_lower=(-0.7,), lin_upper=(1.5,),
           fn=_stiffness,
           to_report=_ratio_report),
    Effect(name="steering_lag", label="steering lag", scope="axle", nl=("tau",),
           nl_units=("s",), nl_bounds=((1e-3, 0.5),), nl_grid=((0.02, 0.05, 0.1, 0.3),),
           fn=_steer_lag),
    Effect(name="lateral_bias", label="lateral bias", scope="vehicle", lin=("ay0",),
           lin_units=("m/s²",), lin_lower=(-np.inf,), fn=_lateral),
    Effect(name="yaw_bias", label="yaw bias", scope="vehicle", lin=("dr0",),
           lin_units=("rad/s²",), lin_lower=(-np.inf,), fn=_yaw),
    Effect(name="mass_mismatch", label="mass mismatch", scope="vehicle",
           lin=("ratio_minus_1",), lin_units=("-",), lin_lower=(-0.5,), lin_upper=(1.0,),
           uses_derivatives=True, fn=_mass, to_report=_ratio_report),
    Effect(name="yaw_inertia_mismatch", label="yaw inertia mismatch", scope="vehicle",
           lin=("ratio_minus_1",), lin_units=("-",), lin_lower=(-0.5,), lin_upper=(1.0,),
           uses_derivatives=True, fn=_yaw_inertia, to_report=_ratio_report),
)

VOCABULARY: dict[str, Effect] = {e.name: e for e in MECHANICAL_EFFECTS + (PAYLOAD,)
                                 + BICYCLE_EFFECTS}


def report_params(effect: Effect, lin: np.ndarray, nl: np.ndarray, cov: np.ndarray,
                  context: Mapping[str, Any] | None = None) -> tuple[dict, dict, dict]:
    """Return the reported (parameters, stderr, units) of a fitted effect."""
    fn = effect.to_report or identity_report
    return fn(effect, np.asarray(lin), np.asarray(nl), np.asarray(cov), dict(context or {}))
