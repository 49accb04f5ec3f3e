"""Axle lateral-force laws: linear, Magic Formula (``spec/models.md``), relaxation length.

Functions are numba-compiled and accept scalars or arrays. Forces in N, slip angles in rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from simgap.models.base import validate_positive


@njit(cache=True)
def linear_force(alpha, c_alpha):  # pragma: no cover - compiled
    """Linear axle force C_a·alpha (N), thesis eq. 2.6; c_alpha in N/rad."""
    return c_alpha * alpha


@njit(cache=True)
def magic_formula(alpha, c_alpha, fz, mu, c_shape, e_curv):  # pragma: no cover - compiled
    """Simplified Pacejka Magic Formula axle force (N), spec ``bicycle``.

    D = mu·Fz, B = C_a/(C·D), Fy = D·sin(C·atan(B·α − E·(B·α − atan(B·α)))), so that
    B·C·D = C_a (the slope at zero slip equals the linear tire's).

    Args:
        alpha: slip angle (rad).
        c_alpha: axle cornering stiffness C_a (N/rad).
        fz: axle normal load (N).
        mu: road friction coefficient (-).
        c_shape: shape factor C (-), 1.3 in the spec.
        e_curv: curvature factor E (-), -0.5 in the spec.
    """
    d = mu * fz
    b = c_alpha / (c_shape * d)
    ba = b * alpha
    return d * np.sin(c_shape * np.arctan(ba - e_curv * (ba - np.arctan(ba))))


@njit(cache=True)
def relaxation_rate(alpha_lag, alpha_ss, vx, length):  # pragma: no cover - compiled
    """Slip-angle lag dα/dt = (vx/σ)(α_ss − α) (rad/s): tires build force over distance σ (m)."""
    return (vx / length) * (alpha_ss - alpha_lag)


@dataclass(frozen=True, kw_only=True)
class MagicFormulaTire:
    """Shape of the Magic Formula axle law (the peak comes from mu·Fz, the slope from C_a).

    Attributes:
        C: shape factor (-).
        E: curvature factor (-).
    """

    C: float = 1.3
    E: float = -0.5

    def __post_init__(self) -> None:
        validate_positive("MagicFormulaTire.C", self.C)
        if not np.isfinite(self.E) or self.E >= 1.0:
            raise ValueError(f"MagicFormulaTire.E must be finite and < 1, got {self.E!r}")

    def force(self, alpha: np.ndarray, c_alpha: float, fz: float, mu: float) -> np.ndarray:
        """Axle force (N) at slip angle ``alpha`` (rad)."""
        return magic_formula(np.asarray(alpha, dtype=np.float64), float(c_alpha), float(fz),
                             float(mu), self.C, self.E)
