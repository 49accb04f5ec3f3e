"""Residual forms: the explicit interface between a recording, a nominal model and the fit.

A *residual form* turns a recording into a physical residual per channel and simulates the
nominal and augmented models for the comparison. Two forms exist (in
:mod:`simgap.diagnosis.systems`), one per kind of residual, not per built-in vs user model:

* mechanical inverse dynamics, tau − M(q) ddq − bias(q, dq) (N·m per revolute joint, N per
  prismatic one; units from the model): ``MechanicalSystem`` (the two-link arm, with its
  fast kernels and the payload effect) and ``ModelMechanicalSystem`` (any other
  :class:`~simgap.models.base.MechanicalNominalModel`);
* the axle-force residual Delta = K⁻¹ g of the bicycle: ``BicycleSystem``.

:class:`ResidualForm` states the interface the pipeline, :class:`~simgap.diagnosis.fit.Fitter`
and :func:`~simgap.diagnosis.compare.compare` use. Effects do not see the form: an effect's
contribution receives an immutable :class:`EffectContext` holding only what effects may read
(the Coulomb smoothing, gravity torques, axle stiffnesses, …), built by
:meth:`ResidualForm.context` for one set of terms. Coupling between terms (a steering lag
goes through the Magic Formula of a tire_saturation term on the same axle) is carried by the
context, not by state stored on the form.

Not done yet (issue 12): ``prepare`` still keeps the filtered signals on the form (one form
object per recording) instead of returning them as immutable data.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from simgap.diagnosis.residual import ResidualResult, Smoother
from simgap.recordings import Recording

#: A fitted or candidate term as the forms see it: (effect, channel index or None, linear
#: parameters, nonlinear parameters).
Term = tuple[Any, int | None, Any, Any]


@dataclass(frozen=True, kw_only=True)
class EffectContext:
    """What an effect's contribution may read besides the signals (read-only).

    Attributes:
        n_channels: number of residual channels.
        coulomb_sigma: tanh smoothing velocity of Coulomb/Stribeck terms per joint (rad/s
            or m/s); mechanical forms.
        gravity: ``q (N, n) -> bias(q, 0)`` per row (N·m or N); mechanical forms.
        payload_regressor: ``(q, dq, ddq) -> torque per kg at the tip`` (N·m/kg); the arm.
        stiffness: nominal cornering stiffness per axle (N/rad); bicycle.
        loads: vertical load per axle (N); bicycle.
        tire: Magic-Formula shape; bicycle.
        K_inv: inverse of the force-to-acceleration map K (bicycle), shape (2, 2).
        lagged_steering: ``(axle, tau) -> road-wheel angle (rad) per row``; bicycle.
        axle_mu: friction coefficient of the tire_saturation term per axle, when the same
            model has one (the steering lag composes with it).
        t: the uniform time grid (s); mechanical forms (the input delay).
        held_input: the logged inputs as held between samples (N·m or N), (N, n);
            mechanical forms.
    """

    n_channels: int
    coulomb_sigma: np.ndarray | None = None
    gravity: Callable[[np.ndarray], np.ndarray] | None = None
    payload_regressor: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    stiffness: tuple[float, float] | None = None
    loads: tuple[float, float] | None = None
    tire: Any = None
    K_inv: np.ndarray | None = None
    lagged_steering: Callable[[int, float], np.ndarray] | None = None
    axle_mu: Mapping[int, float] = field(default_factory=dict)
    t: np.ndarray | None = None
    held_input: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "axle_mu", MappingProxyType(dict(self.axle_mu)))
        for name in ("coulomb_sigma", "K_inv"):
            value = getattr(self, name)
            if value is not None:
                value = np.array(value, dtype=np.float64)
                value.setflags(write=False)
                object.__setattr__(self, name, value)


@runtime_checkable
class ResidualForm(Protocol):
    """The interface of a residual form (see the module docstring).

    Attributes:
        name: model name in the report.
        channels: residual channel names, e.g. ``joint1`` or ``front_axle``.
        channel_units: unit of each channel's residual.
        state_names, state_units: the simulated state (rollout comparison).
        derivative_names, derivative_units: the compared derivatives.
        rollout_horizon: default comparison window (s).
        columns: the recording columns the form reads (canonical names).
        t: the uniform time grid after :meth:`prepare` (s).
        smoother: the derivative filter after :meth:`prepare`.
    """

    name: str
    channels: tuple[str, ...]
    channel_units: tuple[str, ...]
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    derivative_names: tuple[str, ...]
    derivative_units: tuple[str, ...]
    rollout_horizon: float
    columns: Any
    t: np.ndarray
    smoother: Smoother

    def prepare(self, rec: Recording) -> ResidualResult:
        """Filter the recording, compute the residual and its noise floor."""

    def candidates(self) -> list[tuple[Any, int | None, str]]:
        """Vocabulary effects to test: (effect, channel index or None, channel name)."""

    def context(self, terms: Sequence[Term] = ()) -> EffectContext:
        """The effects' context for one model made of ``terms``."""

    def rows(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """Filtered signals at rows ``idx`` (plus ``idx``)."""

    def zero_derivatives(self, sig: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Signals with the state derivatives set to zero (splits mass-type terms)."""

    def fit_mask(self) -> np.ndarray:
        """Rows (N, C) whose residual is determinate enough to fit and score."""

    def locate_variables(self) -> dict[str, tuple[np.ndarray, str]]:
        """Variables the residual may depend on: name -> (values on the grid, unit)."""

    def state_at(self, idx: np.ndarray) -> np.ndarray:
        """Filtered recorded state at rows ``idx``."""

    def derivative_at(self, idx: np.ndarray) -> np.ndarray:
        """Measured state derivative at rows ``idx``."""

    def predicted_derivative(self, idx: np.ndarray, effects: Sequence[Term]) -> np.ndarray:
        """Model derivative (nominal + ``effects``) at the recorded states and inputs."""

    def step(self, s: np.ndarray, k: np.ndarray, effects: Sequence[Term],
             dt: float) -> np.ndarray:
        """One RK4 step of a batch of states with the recorded inputs of rows ``k``."""
