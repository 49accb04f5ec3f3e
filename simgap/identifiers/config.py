"""Identifier configuration and the thesis presets (Table 4.3 manipulator, Table 4.4 bicycle).

Choices the thesis leaves open (see ``spec/thesis-errata.md``), made here once:

* A_d = ``a_d`` · I_n (n × n, n = number of identifier states; errata: the printed I₂ₓ₂ is
  too small for the manipulator's 4 states). Must be negative (Hurwitz).
* "(W0, V0) = (s_W, s_V) with random initialization" is read as a scale: entries drawn
  uniformly from [−s_W, s_W] and [−s_V, s_V] by ``numpy.random.default_rng(seed)``
  (:func:`~simgap.identifiers.network.init_weights`). No bias terms (none are printed).
* Observer laws (eq. 3.6-3.7): η, ρ are used exactly as printed, integrated by Euler with Δt.
* Baseline 2 (eq. 4.2-4.4): the printed η multiplies the exact gradient of J_mb as printed
  (eq. 4.3). The one-step prediction error is Δt (ĝ − g), so in terms of the residual error
  the step is η·Δt² (manipulator: 1e3 · 4e-6 = 4e-3 for Ŵ). Applying the printed η to the
  residual-space gradient instead (η/Δt² here) diverges: measured, IdentifierDivergedError
  within the first 10 s of the thesis manipulator case.
* Divergence: :class:`~simgap.identifiers.errors.IdentifierDivergedError` once Ŵ, V̂ or x̂
  is non-finite or √(‖Ŵ‖_F² + ‖V̂‖_F²) exceeds ``max_weight_norm`` (default 1e6, five orders of
  magnitude above anything the thesis settings reach on its cases).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

from simgap.identifiers.errors import IdentifierError

Kind = Literal["instantaneous", "integral", "minibatch"]
System = Literal["manipulator", "bicycle"]
KINDS: tuple[str, ...] = ("instantaneous", "integral", "minibatch")
SYSTEMS: tuple[str, ...] = ("manipulator", "bicycle")
#: Integer codes of the error signals inside the numba kernels.
KIND_CODES: dict[str, int] = {"instantaneous": 0, "integral": 1, "minibatch": 2}


@dataclass(frozen=True, kw_only=True)
class IdentifierConfig:
    """Hyper-parameters of one identifier (defaults: Table 4.3, proposed method).

    Attributes:
        n_hidden: hidden width n_h of ĝ = Ŵ tanh(V̂ x̄).
        w0_scale: Ŵ_0 entries uniform in [−w0_scale, w0_scale] (state units/s).
        v0_scale: V̂_0 entries uniform in [−v0_scale, v0_scale] (1/input units).
        a_d: diagonal of the Hurwitz observer matrix A_d = a_d · I (1/s), eq. 3.1; < 0.
        eta1: learning rate η1 of Ŵ (eq. 3.6 / 4.4).
        eta2: learning rate η2 of V̂ (eq. 3.7 / 4.4).
        rho1: leakage ρ1 of Ŵ (eq. 3.6), per unit ‖x̃‖ and second.
        rho2: leakage ρ2 of V̂ (eq. 3.7).
        lam: forgetting factor λ of the integral error state z (1/s), eq. 3.9 / 4.6.
        buffer_size: sliding-window length B of baseline 2 (transitions).
        batch_size: mini-batch size M of baseline 2.
        update_period: P_upd, steps between baseline-2 SGD updates.
        max_weight_norm: divergence bound on √(‖Ŵ‖_F² + ‖V̂‖_F²) (so on each of them).
    """

    n_hidden: int = 20
    w0_scale: float = 1e-2
    v0_scale: float = 1e-2
    a_d: float = -40.0
    eta1: float = 4e1
    eta2: float = 6e3
    rho1: float = 1e-2
    rho2: float = 1e-2
    lam: float = 2.0
    buffer_size: int = 2000
    batch_size: int = 64
    update_period: int = 10
    max_weight_norm: float = 1e6

    def __post_init__(self) -> None:
        for name in ("n_hidden", "buffer_size", "batch_size", "update_period"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise IdentifierError(f"IdentifierConfig.{name} must be a positive integer, "
                                      f"got {v!r}")
        for name in ("w0_scale", "v0_scale", "eta1", "eta2", "rho1", "rho2", "lam",
                     "max_weight_norm"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) \
                    or v < 0:
                raise IdentifierError(f"IdentifierConfig.{name} must be a finite non-negative "
                                      f"number, got {v!r}")
        if self.max_weight_norm <= 0:
            raise IdentifierError("IdentifierConfig.max_weight_norm must be positive, "
                                  f"got {self.max_weight_norm!r}")
        if isinstance(self.a_d, bool) or not isinstance(self.a_d, int | float) \
                or not math.isfinite(self.a_d) or self.a_d >= 0:
            raise IdentifierError("IdentifierConfig.a_d must be a finite negative number "
                                  f"(A_d = a_d·I must be Hurwitz), got {self.a_d!r}")

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict of the fields."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> IdentifierConfig:
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise IdentifierError(f"unknown IdentifierConfig field(s) {unknown}")
        return cls(**d)

    def replace(self, **changes: Any) -> IdentifierConfig:
        """Return a copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)


_LEARNING_RATES: dict[str, dict[str, tuple[float, float]]] = {
    # Table 4.3 (manipulator) and Table 4.4 (bicycle): (η1, η2) per method.
    "manipulator": {"instantaneous": (1e2, 8e3), "minibatch": (1e3, 5e4),
                    "integral": (4e1, 6e3)},
    "bicycle": {"instantaneous": (5e2, 1.0), "minibatch": (5e2, 0.2), "integral": (5e2, 0.1)},
}
_COMMON: dict[str, dict[str, Any]] = {
    "manipulator": dict(n_hidden=20, w0_scale=1e-2, v0_scale=1e-2, a_d=-40.0, rho1=1e-2,
                        rho2=1e-2, lam=2.0, buffer_size=2000, batch_size=64, update_period=10),
    "bicycle": dict(n_hidden=20, w0_scale=1e1, v0_scale=1e-2, a_d=-40.0, rho1=1e-5,
                    rho2=1e-5, lam=10.0, buffer_size=200, batch_size=32, update_period=5),
}


def check_kind(kind: str) -> str:
    """Return ``kind`` or raise :class:`IdentifierError` naming the allowed values."""
    if kind not in KINDS:
        raise IdentifierError(f"unknown identifier kind {kind!r}; expected one of {KINDS}")
    return kind


def preset(system: System | str, kind: Kind | str) -> IdentifierConfig:
    """Return the thesis configuration of one method on one system.

    Args:
        system: ``"manipulator"`` (Table 4.3) or ``"bicycle"`` (Table 4.4).
        kind: ``"instantaneous"`` (baseline 1), ``"minibatch"`` (baseline 2) or
            ``"integral"`` (proposed).

    Returns:
        The frozen :class:`IdentifierConfig`. Fields a method does not use (λ for baseline 1,
        A_d / ρ for baseline 2, the buffer for the observer laws) keep the table's values
        for the other methods and are ignored.
    """
    if system not in SYSTEMS:
        raise IdentifierError(f"unknown preset system {system!r}; expected one of {SYSTEMS}")
    check_kind(kind)
    eta1, eta2 = _LEARNING_RATES[system][kind]
    return IdentifierConfig(eta1=eta1, eta2=eta2, **_COMMON[system])
