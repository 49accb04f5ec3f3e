"""Named joint-friction terms (thesis eq. 4.7 and its usual extensions).

Each term is a pure function of the joint velocity dq (rad/s) returning a torque (N·m) that
opposes motion; they are numba-compiled and work on scalars and arrays alike.
:class:`FrictionParams` bundles per-joint coefficients; :data:`FRICTION_MODELS` names the
presets an env accepts (``friction="thesis"``).

    tau_friction = coulomb(dq, fc, sigma) + viscous(dq, b) + stribeck(dq, fs, fc, vs, sigma)
                   + quadratic(dq, c2)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

#: Layout of one joint's row in the friction array passed to compiled kernels.
FRICTION_FIELDS = ("fc", "sigma", "b", "fs", "vs", "c2")
FC, SIGMA, B, FS, VS, C2 = (FRICTION_FIELDS.index(n) for n in FRICTION_FIELDS)


@njit(cache=True)
def coulomb(dq, fc, sigma):  # pragma: no cover - compiled
    """Coulomb friction smoothed by tanh: fc·tanh(dq/sigma) (N·m); sigma in rad/s."""
    return fc * np.tanh(dq / sigma)


@njit(cache=True)
def viscous(dq, b):  # pragma: no cover - compiled
    """Viscous friction b·dq (N·m); b in N·m·s/rad."""
    return b * dq


@njit(cache=True)
def stribeck(dq, fs, fc, vs, sigma):  # pragma: no cover - compiled
    """Extra static friction near zero speed: (fs − fc)·exp(−(dq/vs)²)·tanh(dq/sigma) (N·m).

    fs is the breakaway (static) torque, vs the Stribeck velocity (rad/s).
    """
    return (fs - fc) * np.exp(-((dq / vs) ** 2)) * np.tanh(dq / sigma)


@njit(cache=True)
def quadratic(dq, c2):  # pragma: no cover - compiled
    """Quadratic (velocity-squared) drag c2·dq·|dq| (N·m); c2 in N·m·s²/rad²."""
    return c2 * dq * np.abs(dq)


@njit(cache=True)
def joint_friction(dq, fc, sigma, b, fs, vs, c2=0.0):  # pragma: no cover - compiled
    """Total friction torque (N·m) of one joint.

    Coulomb + viscous, + Stribeck if fs ≠ fc, + quadratic drag if c2 ≠ 0.
    """
    tau = coulomb(dq, fc, sigma) + viscous(dq, b)
    if fs != fc:
        tau += stribeck(dq, fs, fc, vs, sigma)
    if c2 != 0.0:
        tau += quadratic(dq, c2)
    return tau


@njit(cache=True)
def friction_torque(dq, fa):  # pragma: no cover - compiled
    """Total friction torque per joint (N·m) for velocities ``dq`` and rows ``fa`` (n×5)."""
    out = np.empty(dq.shape[0])
    for i in range(dq.shape[0]):
        out[i] = joint_friction(dq[i], fa[i, FC], fa[i, SIGMA], fa[i, B], fa[i, FS], fa[i, VS],
                                fa[i, C2])
    return out


def _pair(name: str, value: float | tuple[float, ...], *, positive: bool) -> tuple[float, float]:
    vals = (float(value), float(value)) if np.isscalar(value) else tuple(float(v) for v in value)
    if len(vals) != 2:
        raise ValueError(f"friction parameter {name} needs 1 or 2 values, got {value!r}")
    for v in vals:
        if not np.isfinite(v) or v < 0 or (positive and v == 0):
            raise ValueError(f"friction parameter {name} must be finite and "
                             f"{'positive' if positive else 'non-negative'}, got {value!r}")
    return vals  # type: ignore[return-value]


@dataclass(frozen=True, kw_only=True)
class FrictionParams:
    """Per-joint friction coefficients of a two-joint arm (scalars apply to both joints).

    Attributes:
        fc: Coulomb friction torque (N·m).
        sigma: tanh smoothing velocity of the Coulomb term (rad/s; thesis Table 4.2, see the
            errata on its unit).
        b: viscous coefficient (N·m·s/rad).
        fs: static (breakaway) torque for the Stribeck term (N·m); ``None`` means fs = fc,
            i.e. no Stribeck effect.
        vs: Stribeck velocity (rad/s).
        c2: quadratic drag coefficient (N·m·s²/rad²).
    """

    fc: float | tuple[float, float] = 0.1
    sigma: float | tuple[float, float] = 6.67e-4
    b: float | tuple[float, float] = 0.5
    fs: float | tuple[float, float] | None = None
    vs: float | tuple[float, float] = 0.05
    c2: float | tuple[float, float] = 0.0

    def __post_init__(self) -> None:
        _pair("fc", self.fc, positive=False)
        _pair("sigma", self.sigma, positive=True)
        _pair("b", self.b, positive=False)
        _pair("vs", self.vs, positive=True)
        _pair("c2", self.c2, positive=False)
        if self.fs is not None:
            _pair("fs", self.fs, positive=False)

    @cached_property
    def array(self) -> np.ndarray:
        """Kernel array, shape (2, len(FRICTION_FIELDS)), columns :data:`FRICTION_FIELDS`."""
        fc = _pair("fc", self.fc, positive=False)
        fs = fc if self.fs is None else _pair("fs", self.fs, positive=False)
        cols = {"fc": fc, "sigma": _pair("sigma", self.sigma, positive=True),
                "b": _pair("b", self.b, positive=False), "fs": fs,
                "vs": _pair("vs", self.vs, positive=True),
                "c2": _pair("c2", self.c2, positive=False)}
        return np.ascontiguousarray(np.array([cols[n] for n in FRICTION_FIELDS],
                                             dtype=np.float64).T)

    def torque(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque (N·m) for joint velocities ``dq`` (rad/s), shape (2,)."""
        return friction_torque(np.asarray(dq, dtype=np.float64), self.array)


#: Presets accepted by name. "thesis" is eq. 4.7 with Table 4.2 values.
FRICTION_MODELS: dict[str, FrictionParams | None] = {
    "thesis": FrictionParams(),
    "coulomb": FrictionParams(fc=0.1, b=0.0),
    "viscous": FrictionParams(fc=0.0, b=0.5),
    "stribeck": FrictionParams(fc=0.1, b=0.5, fs=0.3, vs=0.05),
    "none": None,
}


def resolve_friction(friction: str | FrictionParams | None) -> FrictionParams | None:
    """Turn a preset name, a :class:`FrictionParams` or ``None`` into params (or ``None``)."""
    if friction is None or isinstance(friction, FrictionParams):
        return friction
    if isinstance(friction, str):
        if friction not in FRICTION_MODELS:
            raise ValueError(f"unknown friction model {friction!r}; "
                             f"choose one of {sorted(FRICTION_MODELS)} or pass FrictionParams")
        return FRICTION_MODELS[friction]
    raise ValueError(f"friction must be a name, FrictionParams or None, got {friction!r}")
