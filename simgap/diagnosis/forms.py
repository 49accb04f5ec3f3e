"""Residual forms: the explicit interface between a recording, a nominal model and the fit.

A *residual form* turns a recording into immutable :class:`Prepared` data (the filtered
signals, the physical residual per channel and its noise floor) and simulates the nominal
and augmented models over that data for the comparison. The form itself keeps nothing from
a recording: one form serves any number of recordings, and every consumer (the
:class:`~simgap.diagnosis.fit.Fitter`, :func:`~simgap.diagnosis.compare.compare`, the
report, the MJCF correction) receives the :class:`Prepared` value explicitly. Its arrays are
read-only.

Two forms exist (in :mod:`simgap.diagnosis.systems`), one per kind of residual, not per
built-in vs user model:

* mechanical inverse dynamics, tau − M(q) ddq − bias(q, dq) (N·m per revolute joint, N per
  prismatic one; columns and units from the model): ``MechanicalSystem``, for the
  two-link arm (with its fast kernels and payload effect) and any other
  :class:`~simgap.models.base.MechanicalNominalModel` alike;
* the axle-force residual Delta = K⁻¹ g of the bicycle: ``BicycleSystem``.

:class:`ResidualForm` states the interface. Effects do not see the form: an effect's
contribution receives an immutable :class:`EffectContext` holding only what effects may read
(the Coulomb smoothing, gravity torques, axle stiffnesses, …), built by
:meth:`ResidualForm.context` for one prepared recording and one set of terms. Coupling
between terms (a steering lag goes through the Magic Formula of a tire_saturation term on
the same axle) is carried by the context, not by state stored on the form.

:func:`mass_split` is the one place where a model's terms are split into the part
proportional to the state derivatives (mass-type terms: A(x)·dx/dt) and the rest (b(x)), which
both forms use to solve for dx/dt.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from simgap.diagnosis.residual import ResidualResult
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


def _read_only(a: Any) -> np.ndarray:
    """``a`` as a read-only float array (a view: no copy unless ``a`` is not an array)."""
    arr = np.asarray(a)
    view = arr.view()
    view.flags.writeable = False
    return view


def _frozen_map(m: Mapping[str, Any]) -> Mapping[str, np.ndarray]:
    return MappingProxyType({k: _read_only(v) for k, v in m.items()})


@dataclass(frozen=True, kw_only=True, eq=False)
class Prepared(ResidualResult):
    """One recording as a residual form prepared it: immutable data, no form state.

    Besides the :class:`~simgap.diagnosis.residual.ResidualResult` fields (time grid,
    residual, noise floor, filtered ``signals``, smoother, column noise), all arrays
    read-only. ``raw`` is empty: nothing reads the raw grid columns after ``prepare``, so
    they are not kept (memory per sample, issue 17).

    Attributes:
        inputs: the logged inputs as held over each sample, scaled (N, n_inputs), e.g. N·m
            or rad; what the rollouts replay.
        held_input: the hold-averaged inputs (N, n) an input delay shifts (mechanical
            forms), or ``None``.
        coulomb_sigma: tanh smoothing velocity of Coulomb/Stribeck terms per joint (rad/s
            or m/s), or ``None`` (bicycle).
        fit_mask: rows (N, C) whose residual is determinate enough to fit and score.
        state_columns: where the state's columns live in ``signals``, as (signal name,
            column or ``None`` for a 1-D signal), e.g. q and dq of the arm or (vy, r): the
            forms give these, so the state is not stored twice (:meth:`state_at`).
        state: the filtered recorded state per row (N, n_states), if given instead of
            ``state_columns``; else ``None``.
        state_derivative: the measured derivative of the compared states per row.
        derivatives: the signals that are state derivatives, as (signal name, column or
            ``None`` for a 1-D signal); what :meth:`zero_derivatives` and
            :func:`mass_split` set.
        plan: how the form filtered this recording (form-specific, e.g. the mechanical
            form's inner filter, equation kernel and whether velocities came from the
            positions), or ``None``.

    The inherited ``segment`` (gaps split a recording; a rollout never crosses one),
    ``valid`` (rows whose filter window stays inside their segment), ``column_models``,
    ``warnings`` and ``effective_samples`` come from the form's error model and grid.
    """

    inputs: np.ndarray
    held_input: np.ndarray | None = None
    coulomb_sigma: np.ndarray | None = None
    fit_mask: np.ndarray
    state_columns: tuple[tuple[str, int | None], ...] = ()
    state: np.ndarray | None = None
    state_derivative: np.ndarray
    raw: Mapping[str, np.ndarray] = field(default_factory=dict)
    derivatives: tuple[tuple[str, int | None], ...]
    plan: Any = None
    #: Memo of pure functions of this data (lagged steering, tip-point regressors): values
    #: derived from the read-only arrays, never observable state.
    memo: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("t", "residual", "noise_rms", "inputs", "held_input", "coulomb_sigma",
                     "fit_mask", "state", "state_derivative", "segment", "valid",
                     "effective_samples"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _read_only(value))
        object.__setattr__(self, "signals", _frozen_map(self.signals))
        object.__setattr__(self, "raw", _frozen_map(self.raw))
        object.__setattr__(self, "column_noise", MappingProxyType(dict(self.column_noise)))
        object.__setattr__(self, "column_models", MappingProxyType(dict(self.column_models)))

    @property
    def n(self) -> int:
        """Number of rows of the uniform grid."""
        return len(self.t)

    @property
    def dt(self) -> float:
        """Sample period of the uniform grid (s)."""
        return float(self.smoother.dt)

    def rows(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """Filtered signals at rows ``idx`` (new arrays), plus ``idx``."""
        out = {k: v[idx] for k, v in self.signals.items()}
        out["idx"] = idx
        return out

    def zero_derivatives(self, sig: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Signals with the state derivatives set to zero (splits mass-type terms)."""
        out = dict(sig)
        for key in dict.fromkeys(k for k, _ in self.derivatives):
            out[key] = np.zeros_like(sig[key])
        return out

    def state_at(self, idx: np.ndarray | slice) -> np.ndarray:
        """The filtered recorded state at rows ``idx`` (a new array, columns in order)."""
        if self.state is not None:
            return self.state[idx]
        sig = self.signals
        if not self.state_columns:  # a stateless form: (rows, 0)
            return np.zeros((len(self.t), 0))[idx]
        return np.stack([sig[k][idx] if j is None else sig[k][idx, j]
                         for k, j in self.state_columns], axis=-1)

    def derivative_at(self, idx: np.ndarray) -> np.ndarray:
        """The measured state derivative at rows ``idx``."""
        return self.state_derivative[idx]


def mass_split(terms: Sequence[Term], sig0: Mapping[str, np.ndarray],
               derivatives: Sequence[tuple[str, int | None]], n_channels: int,
               ctx: EffectContext) -> tuple[np.ndarray, np.ndarray]:
    """Split terms' contributions into A(x)·dx/dt + b(x) (the mass-type part and the rest).

    Args:
        terms: (effect, channel index, lin, nl) of one model; terms acting on the input
            (``on_input``, e.g. an input delay) are left out: the form shifts the input.
        sig0: signals at the evaluated rows with every state derivative zero.
        derivatives: the derivative signals as (name, column or ``None``), in the order of
            A's columns.
        n_channels: residual channels C.
        ctx: the effects' context.

    Returns:
        ``a`` of shape (N, C, len(derivatives)) and ``b`` of shape (N, C), channel units.
    """
    n = len(next(iter(sig0.values())))
    b = np.zeros((n, n_channels))
    a = np.zeros((n, n_channels, len(derivatives)))
    for eff, idx, lin, nl in terms:
        if getattr(eff, "on_input", False):
            continue
        base = eff(lin, nl, sig0, idx, ctx)
        b += base
        if eff.uses_derivatives:
            for j, (key, col) in enumerate(derivatives):
                unit = dict(sig0)
                if col is None:
                    unit[key] = np.ones(n)
                else:
                    unit[key] = np.zeros(sig0[key].shape)
                    unit[key][:, col] = 1.0
                a[:, :, j] += eff(lin, nl, unit, idx, ctx) - base
    return a, b


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

    def prepare(self, rec: Recording) -> Prepared:
        """Filter the recording; the residual, its noise floor and the signals, immutable."""

    def candidates(self, prepared: Prepared) -> list[tuple[Any, int | None, str]]:
        """Vocabulary effects to test: (effect, channel index or None, channel name)."""

    def context(self, prepared: Prepared, terms: Sequence[Term] = ()) -> EffectContext:
        """The effects' context for one model made of ``terms``."""

    def locate_variables(self, prepared: Prepared) -> dict[str, tuple[np.ndarray, str]]:
        """Variables the residual may depend on: name -> (values on the grid, unit)."""

    def derivative(self, prepared: Prepared, idx: np.ndarray,
                   effects: Sequence[Term]) -> np.ndarray:
        """Model derivative (nominal + ``effects``) at the recorded states and inputs."""

    def step(self, prepared: Prepared, s: np.ndarray, k: np.ndarray,
             effects: Sequence[Term], dt: float) -> np.ndarray:
        """One RK4 step of a batch of states with the recorded inputs of rows ``k``."""
