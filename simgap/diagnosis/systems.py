"""System adapters: how a recording and a nominal model become residual channels.

An adapter knows, for one kind of nominal model, which recording columns hold time, states
and inputs (:class:`AdapterColumns`), how to compute the physical residual from filtered
signals, which vocabulary effects apply, and how to simulate nominal and augmented models
for the comparison. Two adapters exist:

* :class:`MechanicalSystem`: any :class:`~simgap.models.base.MechanicalNominalModel`
  (M(q) ddq + bias(q, dq) = tau). Residual = joint torque (N·m, or N for prismatic joints)
  tau − (M(q) ddq + bias(q, dq)) = tau_d. Velocities may be recorded or differentiated from
  positions; inputs may be scaled (e.g. a motor constant times a voltage).
* :class:`BicycleSystem`: :class:`~simgap.models.bicycle.BicycleNominal` with per-sample
  vx; residual = axle-force deviation Delta = K⁻¹(dx/dt − f(x, u; vx)) (N).

An adapter keeps nothing from a recording: :meth:`prepare` returns the recording's filtered
signals, residual and noise floor as immutable :class:`~simgap.diagnosis.forms.Prepared`
data, which every later step receives explicitly. Slip angles, the RK4 stages and the
mass-type split are the ``models/`` and :mod:`~simgap.diagnosis.forms` functions. The noise
floor of each channel is the propagated column error (white noise or quantisation,
:func:`simgap.diagnosis.residual.noise_floor`) combined with :data:`NUMERICAL_FLOOR` times
the channel's modelled force/torque RMS. The built-in arm's residual is the kernel-filtered
equation in momentum form (no second derivative, no smoothing bias; see
:mod:`simgap.diagnosis.residual`); recordings with time gaps are split into segments
(``segment`` per row), filtered per segment, and no row whose filter window leaves its
segment is fitted.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numba import njit
from scipy.ndimage import uniform_filter1d
from scipy.signal import lfilter, savgol_coeffs

from simgap.diagnosis.effects import ARM_EFFECTS, BICYCLE_EFFECTS, MECHANICAL_EFFECTS, Effect
from simgap.diagnosis.errormodel import LAG_Z, MAD_TO_STD, clipped, velocity_lag
from simgap.diagnosis.forms import EffectContext, Prepared, mass_split
from simgap.diagnosis.identifiability import Symmetry
from simgap.diagnosis.residual import (
    MAX_WINDOW_S,
    POLYORDER,
    KernelFilter,
    Smoother,
    choose_window,
    effective_counts,
    error_models,
    grid_warnings,
    noise_floor,
    noise_of,
    noise_std,
    segmented_grid,
)
from simgap.diagnosis.significance import likelihood_ratio
from simgap.errors import ColumnMapError, CustomModelError
from simgap.models import manipulator as man
from simgap.models.base import MechanicalNominalModel
from simgap.models.bicycle import BicycleNominal, axle_loads, slip_angles, state_derivative
from simgap.models.effects import format_unit
from simgap.models.integrators import rk4_batch_step
from simgap.models.nbcache import guard_cache
from simgap.models.tires import MagicFormulaTire
from simgap.recordings import Recording
from simgap.schema import RecordingSchema


@dataclass(frozen=True, kw_only=True)
class AdapterColumns:
    """Which recording columns hold the model's quantities (the adapters' own view).

    Users describe their files with :class:`simgap.recordings.ColumnMap` instead; this
    class was ``simgap.diagnosis.systems.ColumnMap`` (a deprecated alias for one release).

    Attributes:
        t: time column (s).
        q: generalised positions (rad or m), one column per joint (mechanical) — or, for the
            bicycle, the state columns (vy, r).
        dq: generalised velocities (rad/s or m/s); ``None`` = differentiate ``q``.
        u: inputs (joint torques/forces, or steering angles), one column per input.
        u_scale: factor applied to each input column (e.g. motor gain N/V); default 1.
        vx: longitudinal speed column (bicycle only).
        input_hold: ``"zoh"`` if each logged input is held until the next sample (the
            logged value at t_k acts on [t_k, t_k+1)); the residual then uses the average of
            the inputs before and after each sample. ``"sample"`` uses the value as is (a
            point sample of an input that changes between log samples, e.g. a 500 Hz
            controller logged at 100 Hz). ``"auto"`` (default): the mechanical form decides
            from the data (:func:`choose_hold`); the bicycle form holds (``"zoh"``).
    """

    t: str = "t"
    q: tuple[str, ...]
    dq: tuple[str, ...] | None = None
    u: tuple[str, ...]
    u_scale: tuple[float, ...] | None = None
    vx: str | None = None
    input_hold: str = "auto"

    @property
    def required(self) -> tuple[str, ...]:
        """All columns the recording must have."""
        cols = (self.t,) + self.q + (self.dq or ()) + self.u
        return cols + ((self.vx,) if self.vx else ())


def declared_hold(model: Any) -> str:
    """The input hold a model declares: its column map's, else its recording schema's.

    ``"auto"`` (the diagnosis decides from the data) when neither declares one.
    """
    cmap = getattr(model, "column_map", None)
    hold = getattr(cmap, "input_hold", None)
    if hold is not None:
        return hold
    try:
        return RecordingSchema.of(model).input_hold
    except ColumnMapError:
        return "auto"


MANIPULATOR_COLUMNS = AdapterColumns(q=("q1", "q2"), dq=("dq1", "dq2"), u=("tau1", "tau2"))
STICK_WIDTHS = 3.0
#: Relative floor added to the noise floor: residuals below 0.1 % of the modelled force or
#: torque RMS are numerical (derivative estimation, sample-and-hold) even in noise-free data.
NUMERICAL_FLOOR = 1e-3
#: The residual's high-band error (robust std) over the white floor's above which the
#: equation's filter is chosen for the larger error (a factor 2 in std, as
#: :data:`simgap.diagnosis.errormodel.HF_EXCESS` in power).
ERROR_EXCESS = 2.0
#: Longest kernel window (s) when it is chosen for such an error.
EXCESS_WINDOW_S = 0.25
#: Level of the test that gives logged inputs another lag than a held command's (ZOH).
HOLD_ALPHA = 0.01
#: Rows per block where a per-row product with M(q) is evaluated in blocks (M(q) is
#: (N, n, n); blocks keep the transient at a fixed size, ≈ 0.5 MB, the values are the same
#: per row).
MASS_BLOCK_ROWS = 1 << 12
#: Time constants (s) of the lagged steering commands among the vehicle's instruments
#: (:meth:`BicycleSystem.instruments`), spanning the steering lag's range.
INSTRUMENT_LAGS = (0.02, 0.05, 0.1, 0.2, 0.4, 1.0)
#: Width (s) of the centred moving average of the measured speed in the speed-scheduled
#: instruments (:meth:`BicycleSystem.instruments`): its sample noise is averaged out, the
#: speed's own variation (seconds to tens of seconds) kept.
INSTRUMENT_SPEED_WINDOW_S = 1.0
#: Relative speed range (peak to peak over mean) below which the speed is held constant
#: and the instruments are the commands' alone.
INSTRUMENT_SPEED_PTP = 1e-3
#: Effects of the vehicle's vocabulary that another effect needs (its coupling declaration).
_NEEDED = frozenset(n for e in BICYCLE_EFFECTS for n in e.needs)
BICYCLE_COLUMNS = AdapterColumns(q=("vy", "r"), u=("delta_f", "delta_r"), vx="vx")


@dataclass(frozen=True)
class _Plan:
    """How a mechanical recording is filtered: inner filter and the equation's kernel.

    ``hold``: lag of the logged inputs in log samples (½: held until the next sample).

    ``kernel`` None: constant mass matrix (or a model other than the built-in arm), the
    Savitzky–Golay signals are used directly.
    """

    inner: Smoother
    kernel: KernelFilter | None
    velocity_from_q: bool
    hold: float = 0.5


#: Quantile intervals per state variable of the nuisance model the input's lag is fitted
#: beside (a continuous piecewise-linear function of each variable).
LAG_NUISANCE_BINS = 16


def _hat_basis(x: np.ndarray, jump: bool) -> list[tuple[np.ndarray, np.ndarray | None, int]]:
    """A variable's piecewise-linear (hat) basis: [(interval index, position in it, size)].

    Knots at :data:`LAG_NUISANCE_BINS` + 1 quantiles of ``x`` (and at 0 with ``jump``); a
    row in interval i at relative position λ has the value 1 − λ on hat i and λ on hat
    i + 1. ``jump`` adds the indicator of x > 0 (position None): a step at zero.
    """
    knots = np.unique(np.quantile(x, np.linspace(0.0, 1.0, LAG_NUISANCE_BINS + 1)))
    if jump:
        knots = np.unique(np.concatenate([knots, [0.0]]))
    if knots.size < 2:
        return [(np.zeros(x.size, dtype=np.int32), None, 1)]
    i = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, knots.size - 2)
    lam = (x - knots[i]) / np.diff(knots)[i]
    out = [(i.astype(np.int32), lam, int(knots.size))]
    if jump:
        out.append(((x > 0).astype(np.int32), None, 2))
    return out


class _StateNuisance:
    """Least-squares fits on functions of the state, to clear columns of them (Frisch–Waugh).

    The nuisance model is additive in the state variables (each column of ``state``, e.g.
    q1, q2, q̇1, q̇2): a continuous piecewise-linear function of each (:func:`_hat_basis`),
    with a step at zero where ``jumps`` says (the velocities: Coulomb friction changes sign
    there). Any friction, drag, spring, offset or gravity error, whatever its shape, is
    such a function. Quantile-bin indicators (piecewise constant) were used before: their
    staircase left a sawtooth of a viscous friction and the smoothed step of a Coulomb
    friction in ``y``, correlated with the input's rate, and tilted the lag (measured: a
    600 s arm log with Coulomb + viscous friction, lag 0.1 sample rejected ZOH at
    p = 10⁻⁸ in both halves; with this basis the lag is ≈ 0.55, ZOH kept).

    The design is never formed (issue 17's memory bar): its normal equations are weighted
    co-occurrence sums of the hats (``np.bincount``), solved by least squares on the small
    (P, P) system (minimum norm: the hats of each variable sum to one), and the fit is
    subtracted by indexing. The Gram matrix depends on the state only: it is built once
    here and serves every :meth:`clear`.
    """

    def __init__(self, state: np.ndarray, jumps: Sequence[bool] | None = None) -> None:
        jumps = [False] * state.shape[1] if jumps is None else list(jumps)
        self.parts = [b for x, j in zip(state.T, jumps, strict=True) for b in _hat_basis(x, j)]
        self.offsets = np.concatenate([[0], np.cumsum([m for _, _, m in self.parts])])
        p = int(self.offsets[-1])
        self.gram = np.zeros((p, p))
        for a in range(len(self.parts)):
            oa, ma = self.offsets[a], self.parts[a][2]
            for b in range(a, len(self.parts)):
                ob, mb = self.offsets[b], self.parts[b][2]
                block = np.zeros((ma, mb))
                for ia, wa in self._terms(a):
                    for ib, wb in self._terms(b):
                        w = wa if wb is None else (wb if wa is None else wa * wb)
                        block += np.bincount(ia.astype(np.int64) * mb + ib, weights=w,
                                             minlength=ma * mb).reshape(ma, mb)
                self.gram[oa:oa + ma, ob:ob + mb] = block
                self.gram[ob:ob + mb, oa:oa + ma] = block.T

    def _terms(self, k: int) -> list[tuple[np.ndarray, np.ndarray | None]]:
        """(index, weight or None) pairs of part k's nonzero basis values per row."""
        i, lam, _ = self.parts[k]
        return [(i, None)] if lam is None else [(i, 1.0 - lam), (i + 1, lam)]

    def clear(self, y: np.ndarray) -> np.ndarray:
        """``y`` (n, C) minus its least-squares fit on the state functions (a new array)."""
        rhs = np.zeros((self.gram.shape[0], y.shape[1]))
        for a in range(len(self.parts)):
            oa, ma = self.offsets[a], self.parts[a][2]
            for ia, wa in self._terms(a):
                for c in range(y.shape[1]):
                    rhs[oa:oa + ma, c] += np.bincount(
                        ia, weights=y[:, c] if wa is None else wa * y[:, c], minlength=ma)
        coef, *_ = np.linalg.lstsq(self.gram, rhs, rcond=None)
        out = y.copy()
        for k in range(len(self.parts)):
            table = coef[self.offsets[k]:self.offsets[k + 1]]
            for i, w in self._terms(k):
                out -= table[i] if w is None else w[:, None] * table[i]
        return out


def _off_state(y: np.ndarray, nuisance: _StateNuisance,
               linear: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """``y`` (n, C) minus its least-squares fit on functions of the state (Frisch–Waugh).

    ``linear``, optional: per channel c, ``linear[c]`` (n, k) more regressors fitted jointly
    with the state functions (each channel its own coefficients), *already cleared* of them
    (``nuisance.clear``): ``y`` is cleared of the state functions, then of those (the same
    least squares as one joint design).
    """
    out = nuisance.clear(y)
    if linear is not None:
        for c, x in enumerate(linear):
            beta, *_ = np.linalg.lstsq(x, out[:, c], rcond=None)
            out[:, c] -= x @ beta
    return out


def _lag_test(r0: np.ndarray, d: np.ndarray):
    """Least-squares input lag a ∈ [0, ½] of r(a) = r0 + 2a·d and its held-out test.

    Each channel is weighted by its residual's mean square. Returns (a, the likelihood
    ratio result) when a < ½ fits significantly better than ZOH at :data:`HOLD_ALPHA`
    (:func:`.significance.likelihood_ratio`, N/τ effective samples, one degree of freedom),
    else (½, ``None``).
    """
    w = 1.0 / np.maximum(np.mean(r0**2, axis=0), 1e-300)
    den = float(np.sum(w * np.sum(d * d, axis=0)))
    if den <= 0.0:
        return 0.5, None
    lag = float(np.clip(-0.5 * np.sum(w * np.sum(r0 * d, axis=0)) / den, 0.0, 0.5))
    if lag == 0.5:
        return 0.5, None
    g = likelihood_ratio(r0 + d, r0 + 2.0 * lag * d, dof=1)
    if not (g.testable and g.p_value < HOLD_ALPHA and g.share_removed > 0):
        return 0.5, None
    return lag, g


def _lag_of(hold: str) -> float:
    """Lag (log samples) of an ``input_hold`` name: ``"sample"`` 0, held (ZOH) ½."""
    return 0.0 if hold == "sample" else 0.5


def _held(u: np.ndarray, hold: str | float, interval: bool = False) -> np.ndarray:
    """The input at each sample instant t_k: the logged one at t_k − lag·Δt.

    ``hold`` is the lag in log samples (0 ≤ lag ≤ 1, linear interpolation) or an
    ``input_hold`` name (``"sample"``: 0, as logged; otherwise ½: a command held until the
    next sample, the mean of the values before and after the instant).

    ``interval``: the input's mean over the two sample intervals [t_{k−1}, t_{k+1}] instead
    (the interval form of the equation, :class:`~.residual.KernelFilter`): weights
    (¼ + a/2, ½, ¼ − a/2) on (u_{k−1}, u_k, u_{k+1}) for a lag a; a = ½ is a command held
    over each interval (ZOH, (u_{k−1} + u_k)/2, exact, the same values as without
    ``interval``), a = 0 the trapezoid mean of an input that varies between point samples.
    The weights are linear in a, as the lag's test needs (:meth:`MechanicalSystem._choose_hold`).
    """
    lag = _lag_of(hold) if isinstance(hold, str) else float(hold)
    if lag == 0.0 and not interval:
        return u
    out = u.copy()
    if lag == 0.5:   # the ZOH default, written as before (bit-identical)
        out[1:] = 0.5 * (u[1:] + u[:-1])
    elif not interval:
        out[1:] = u[1:] - lag * (u[1:] - u[:-1])
    else:
        out[1:-1] = (0.25 + 0.5 * lag) * u[:-2]
        out[1:-1] += 0.5 * u[1:-1]
        out[1:-1] += (0.25 - 0.5 * lag) * u[2:]
        out[-1] = u[-1] - lag * (u[-1] - u[-2])
    return out


@njit(cache=True)
def _manip_batch(la, q, dq, ddq):  # pragma: no cover - compiled
    """Inverse dynamics M ddq + C dq + G per row (N·m) with the model's kernels."""
    n = q.shape[0]
    out = np.empty((n, 2))
    for k in range(n):
        out[k] = (man.mass_matrix(q[k], la) @ ddq[k] + man.coriolis_matrix(q[k], dq[k], la)
                  @ dq[k] + man.gravity_vector(q[k], la))
    return out


@njit(cache=True)
def _tau_d_batch(theta, q, dq):  # pragma: no cover - compiled
    """Left-out torque tau_d(q, dq) per row (N·m) of a plant array."""
    n = q.shape[0]
    out = np.empty((n, 2))
    for k in range(n):
        out[k] = man.tau_d(q[k], dq[k], theta)
    return out


@njit(cache=True)
def _manip_mass_batch(la, q):  # pragma: no cover - compiled
    n = q.shape[0]
    out = np.empty((n, 2, 2))
    for k in range(n):
        out[k] = man.mass_matrix(q[k], la)
    return out


class MechanicalSystem:
    """The mechanical residual form, for any :class:`MechanicalNominalModel`.

    One form for the built-in arm and every user model (``path.py:NAME``, MJCF); what
    differs comes from the model or the data:

    * columns, channels and units come from the model: the canonical columns
      (``obs_names`` = positions + velocities, ``input_names``), positions/velocities in
      ``obs_units``, efforts in ``residual_units`` (N for a prismatic joint), and every
      vocabulary parameter's unit is written for the joint (viscous b in N·s/m, Coulomb Fc
      in N, …); velocities are read when recorded and derived from positions otherwise;
    * the vocabulary is scaled to the data as each effect declares (``FitSpec.for_data``):
      the Stribeck velocity vs is bounded by a share of the joint's largest recorded speed
      (the vocabulary's bounds, in rad/s, mean nothing for a slider moving at 0.1 m/s; see
      ``tests/diagnosis/test_real_emps.py``), and whole-arm ``gravity_mismatch`` is not
      tested when the model has no gravity torque on the recorded positions. A model whose
      vocabulary bounds are written for it says ``vocabulary_scaled_to_data = False`` (the
      two-link arm);
    * where the model declares its own per-joint terms (``nominal_coefficients()``, e.g.
      ``{"damping": (...), "frictionloss": (...)}``), the vocabulary entries that correct
      them (:attr:`~simgap.models.effects.FitSpec.corrects`) may go negative down to −(the
      nominal value): "the nominal damping is 15 % too high" is an answer;
    * the two-link arm (``ManipulatorNominal``) gets fast batched kernels and its own
      effects (payload at the tip, cubic stiffness).

    Args:
        model: the nominal model.
        columns: the recording columns; default: the model's canonical ones.
        name: model name for the report (default: the model's ``name``).
        channels: channel names (default: the model's ``channel_names``, else
            ``joint1..n``).
        velocities: whether the recording holds the velocities (canonical ``dq`` columns);
            ``None``: recorded unless the model's column map leaves them out. Only with the
            default ``columns``.
    """

    #: The effects' context does not depend on the model's terms (:meth:`context`): a
    #: term's basis depends on its own values only, so the fitter may cache it.
    context_couples = False
    kind = "mechanical"
    #: Input columns of the prepared signals (the filtered torques; their rates stratify the
    #: split's blocks by input activity, :func:`.validation.block_activity`).
    input_signals = ("u",)

    def __init__(self, model: MechanicalNominalModel, columns: AdapterColumns | None = None,
                 name: str | None = None, channels: Sequence[str] | None = None, *,
                 velocities: bool | None = None) -> None:
        if columns is None:
            q, dq, u = _mechanical_names(model)
            if velocities is None:  # decided by the model's declaration and column map
                recorded = set(getattr(model, "recording_columns", ()))
                cmap = getattr(model, "column_map", None)
                velocities = all(c in recorded and (cmap is None or c in cmap.columns)
                                 for c in dq)
            columns = AdapterColumns(q=q, dq=dq if velocities else None, u=u,
                                     input_hold=declared_hold(model))
        self.model = model
        self.columns = columns
        self.n_channels = len(columns.q)
        if len(columns.u) != self.n_channels or (columns.dq and len(columns.dq) !=
                                                 self.n_channels):
            raise ValueError("column map needs one q, (dq) and u column per joint")
        self.name = name or _label(model)
        if channels is None:
            own = tuple(getattr(model, "channel_names", ()) or ())
            channels = own if len(own) == self.n_channels else None
        self.channels = tuple(channels or (f"joint{i + 1}" for i in range(self.n_channels)))
        self.position_units, self.channel_units = _joint_units(model, self.n_channels)
        self.is_manipulator = isinstance(model, man.ManipulatorNominal)
        self.scaled_to_data = bool(getattr(model, "vocabulary_scaled_to_data", True))
        self.state_names = tuple(columns.q) + tuple(columns.dq or
                                                     (f"d{c}" for c in columns.q))
        self.state_units = self.position_units + tuple(f"{p}/s" for p in self.position_units)
        self.derivative_names = tuple(f"dd{c}" for c in columns.q)
        self.derivative_units = tuple(f"{p}/s²" for p in self.position_units)
        self.rollout_horizon = 0.2

    # -- model quantities --------------------------------------------------------------
    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray,
                         model: MechanicalNominalModel | None = None) -> np.ndarray:
        """M(q) ddq + bias(q, dq) per row (N·m)."""
        m = model or self.model
        if isinstance(m, man.ManipulatorNominal):
            q, dq = np.ascontiguousarray(q), np.ascontiguousarray(dq)
            out = _manip_batch(m.params.array, q, dq, np.ascontiguousarray(ddq))
            theta = getattr(m, "theta", None)  # augmented arm: friction, bias, spring
            return out + _tau_d_batch(theta, q, dq) if theta is not None else out
        return np.array([m.inverse_dynamics(q[k], dq[k], ddq[k]) for k in range(q.shape[0])])

    def mass(self, q: np.ndarray) -> np.ndarray:
        """M(q) per row, shape (N, n, n)."""
        if self.is_manipulator:
            return _manip_mass_batch(self.model.params.array, np.ascontiguousarray(q))
        return np.array([self.model.M(q[k]) for k in range(q.shape[0])])

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Velocity-independent torques bias(q, 0) = G(q) per row (N·m)."""
        z = np.zeros_like(q)
        return self.inverse_dynamics(q, z, z)

    def payload_regressor(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Torque per kg of point mass at the tip of link 2 (N·m/kg), whole arm."""
        p = self.model.params
        heavy = man.ManipulatorNominal(dataclasses.replace(p, payload=p.payload + 1.0))
        return self.inverse_dynamics(q, dq, ddq, heavy) - self.inverse_dynamics(q, dq, ddq)

    def candidates(self, prepared: Prepared) -> list[tuple[Effect, int | None, str]]:
        """Vocabulary effects to test: (effect, channel index or None, channel name).

        In the model's units, as corrections of its own terms where it has them, and
        scaled to the data by each effect's ``for_data`` (see the class docstring).
        """
        base: list[tuple[Effect, int | None, str]] = []
        for e in MECHANICAL_EFFECTS + (ARM_EFFECTS if self.is_manipulator else ()):
            if e.scope == "joint":  # the arm's own effects (payload, cubic stiffness) last
                base += [(e, j, self.channels[j]) for j in range(self.n_channels)]
            else:
                base.append((e, None, "arm"))
        own = getattr(self.model, "nominal_coefficients", None)
        coefficients = own() if callable(own) else {}
        sig, ctx = prepared.signals, self.context(prepared)
        out = []
        for effect, j, channel in base:
            k = 0 if j is None else j
            effect = effect.in_units(effort=self.channel_units[k],
                                     position=self.position_units[k])
            if j is not None and coefficients:  # signed corrections of the nominal's terms
                effect = effect.with_nominal(coefficients, j)
            if self.scaled_to_data and effect.for_data is not None:
                effect = effect.for_data(effect, sig, j, ctx)
                if effect is None:
                    continue
            if j is not None:
                effect = self._resolvable(effect, j, ctx)
                if effect is None:
                    continue
            out.append((effect, j, channel))
        return out

    def _resolvable(self, effect: Effect, j: int, ctx: EffectContext) -> Effect | None:
        """The effect with its velocity scales no smaller than the fit can resolve.

        Rows of a joint slower than :data:`STICK_WIDTHS` Coulomb widths (about 2 stds of
        the filtered velocity noise each) are never fitted (:meth:`_fit_mask`). A nonlinear
        parameter in velocity units (Stribeck's vs) below that speed describes a bump the
        fit sees only by its far tail, where its amplitude is unbounded: measured on a
        2π/4096 rad encoder (velocity noise 0.015 rad/s, mask 0.093 rad/s), the Stribeck
        fit went to vs = 0.007 rad/s, Fs = 620 N·m (true 0.21 rad/s, 0.30 N·m), a spike on
        a few rows that lost on held-out data. The same width is where the fitted Coulomb
        term, a function of the *measured* velocity, blurs the true friction step: a
        narrower bump only takes up that blur (measured: a 600 s arm log with Coulomb
        friction, vs = 5.1e-3 rad/s = 1.8 widths, 0.4 % of the validation residual at
        p = 10⁻⁵; named on the 3600 s log). Its lower bound is raised to that speed (start
        grid clipped to it; a fit that ends on it is at its plausibility limit); an effect
        whose whole range lies below it is not tried.
        """
        speed = f"{self.position_units[j]}/s"
        if not any(u == speed for u in effect.nl_units):
            return effect
        floor = STICK_WIDTHS * float(ctx.coulomb_sigma[j])
        bounds, grid = [], []
        for u, (lo, hi), g in zip(effect.nl_units, effect.nl_bounds, effect.nl_grid,
                                  strict=True):
            if u != speed or lo >= floor:
                bounds.append((lo, hi))
                grid.append(g)
                continue
            if hi <= floor:
                return None
            bounds.append((floor, hi))
            kept = tuple(v for v in g if floor < v < hi)
            first = float(np.sqrt(floor * (kept or (hi,))[0]))  # between floor and grid
            grid.append(kept if len(kept) >= len(g) else (first, *kept))
        return dataclasses.replace(effect, nl_bounds=tuple(bounds), nl_grid=tuple(grid))

    # -- signals and residual ----------------------------------------------------------
    def _signals(self, raw: Mapping[str, np.ndarray], plan: _Plan, *,
                 residual_only: bool = False) -> dict[str, np.ndarray]:
        """States by the inner filter, acceleration, inputs (see the module docstring).

        ``residual_only``: with a kernel filter, only what :meth:`_residual` reads (q, dq,
        u_held; the same values), not ddq and the filtered u (noise-floor passes).
        """
        c, sm = self.columns, plan.inner
        qr = np.stack([raw[k] for k in c.q], axis=1)
        q = sm(qr)
        dqr = None if plan.velocity_from_q else np.stack([raw[k] for k in c.dq], axis=1)
        dq = sm(qr, 1) if dqr is None else sm(dqr)
        del qr
        scale = np.asarray(c.u_scale or (1.0,) * len(c.u))
        held = _held(np.stack([raw[k] for k in c.u], axis=1), plan.hold,
                     interval=plan.kernel is not None) * scale
        if residual_only and plan.kernel is not None:
            return {"q": q, "dq": dq, "u_held": held}
        if plan.kernel is not None:
            ddq = plan.kernel(dq, 1)
        else:
            ddq = sm(np.stack([raw[k] for k in c.q], axis=1), 2) if dqr is None \
                else sm(dqr, 1)
        return {"q": q, "dq": dq, "ddq": ddq, "u": sm(held), "u_held": held}

    def _mass_rate_dq(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Ṁ(q) q̇ per row (N·m): central difference of M along q̇ (M(q ± ε q̇)), ε in s."""
        speed = float(np.max(np.abs(dq))) if dq.size else 0.0
        if speed == 0.0:
            return np.zeros_like(dq)
        eps = 1e-5 / speed
        out = np.empty(dq.shape)
        for a in range(0, len(q), MASS_BLOCK_ROWS):
            qb, dqb = q[a:a + MASS_BLOCK_ROWS], dq[a:a + MASS_BLOCK_ROWS]
            rate = (self.mass(qb + eps * dqb) - self.mass(qb - eps * dqb)) / (2.0 * eps)
            out[a:a + MASS_BLOCK_ROWS] = np.einsum("nij,nj->ni", rate, dqb)
        return out

    def _mass_times(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """M(q) v per row (N·m for v = q̇ in rad/s: the momentum), in row blocks."""
        out = np.empty(v.shape)
        for a in range(0, len(q), MASS_BLOCK_ROWS):
            out[a:a + MASS_BLOCK_ROWS] = np.einsum(
                "nij,nj->ni", self.mass(q[a:a + MASS_BLOCK_ROWS]), v[a:a + MASS_BLOCK_ROWS])
        return out

    def _residual(self, sig: Mapping[str, np.ndarray], kernel: KernelFilter | None
                  ) -> np.ndarray:
        """K*[u − bias(q, q̇) + Ṁq̇] − K'*[M(q) q̇]: the filtered equation (no q̈).

        Without a kernel (constant mass matrix, or a model other than the built-in arm):
        u − M ddq − bias(q, dq) of the filtered signals.
        """
        q, dq = sig["q"], sig["dq"]
        if kernel is None:
            return sig["u"] - self.inverse_dynamics(q, dq, sig["ddq"])
        # the same operations as K*[u − bias + Ṁq̇] − K'*[M q̇], ordered so that each
        # (N, n) temporary is freed as soon as it is used (the peak memory of prepare)
        # (in the interval form the held input is already its interval mean: kernel.held)
        d_momentum = kernel(self._mass_times(q, dq), 1)
        rest = self._mass_rate_dq(q, dq)
        rest -= self.inverse_dynamics(q, dq, np.zeros_like(q))
        out = kernel(rest)
        del rest
        out += kernel.held(sig["u_held"])
        out -= d_momentum
        return out

    def residual_of(self, raw: Mapping[str, np.ndarray], plan: _Plan) -> np.ndarray:
        """The residual (N, n) of raw grid columns through a prepared recording's ``plan``."""
        return self._residual(self._signals(raw, plan, residual_only=True), plan.kernel)

    def _choose_hold(self, raw: Mapping[str, np.ndarray], plan: _Plan
                     ) -> tuple[_Plan, str | None]:
        """How the logged inputs acted between samples: the input's lag in log samples.

        A log written at the controller's rate holds each command until the next sample
        (ZOH: the input at the instant t_k is the mean of u_{k−1} and u_k, a lag of half a
        sample). A log written slower than the controller runs (a 500 Hz loop logged at
        100 Hz) holds point samples of an input that changes in between: read as held, it
        lags by half a *log* period (5 ms at 100 Hz), and the clean residual grows with the
        torque's rate of change (measured: 2x the noise floor on clean 100 Hz arm logs, and
        named as quadratic drag once); its true lag is half a *controller* period (1 ms).
        The recording does not say which; the equation does. The residual is linear in the
        input, so the input at t_k − a·Δt (linear interpolation, 0 ≤ a ≤ ½; in the interval
        form, :func:`_held` with ``interval``, its interval mean with weights linear in a)
        gives r(a) = r(0) + 2a·(r(½) − r(0)), and the lag a is the least-squares one of the
        equation (each channel weighted by its residual's mean square, valid rows) after
        both r(0) and r(½) − r(0) are cleared of any dependence on the state
        (:func:`_off_state`): an unmodelled effect is a function of the state and must not
        tilt the lag (measured: a quadratic drag on a 500 Hz log pulled it from ½ to 0.34
        sample, p = 10⁻⁸, and took a fifth of the drag with it). ZOH
        (a = ½, the documented default) is kept unless r(a) fits significantly better: the
        selection's likelihood ratio (:func:`.significance.likelihood_ratio`, N/τ
        effective samples per channel, one degree of freedom) at :data:`HOLD_ALPHA`. An
        explicit ``input_hold`` of the columns (``"zoh"``, ``"sample"``) is obeyed.

        A lag of the input and an input delay are the same thing: a delay shorter than half
        a log period is taken up here and never named as an effect (a hold cannot be told
        from it); a longer delay is named on top of the lag chosen here.

        Returns:
            (the plan with its ``hold`` lag, a one-line note when it is not ZOH).
        """
        if self.columns.input_hold != "auto":
            return dataclasses.replace(plan, hold=_lag_of(self.columns.input_hold)), None
        held = self.residual_of(raw, plan)
        sampled = self.residual_of(raw, dataclasses.replace(plan, hold=0.0))
        valid = (plan.kernel or plan.inner).valid(len(held))
        sig = self._signals(raw, plan)                         # q, dq: the same values
        state = np.concatenate([sig["q"], sig["dq"]], axis=1)[valid]
        mass = self._mass_nuisance(sig, plan)[valid] if plan.kernel is not None else None
        jumps = [False] * sig["q"].shape[1] + [True] * sig["dq"].shape[1]   # at q̇ = 0
        del sig
        held -= sampled                                        # r(½) − r(0), in place
        nuisance = _StateNuisance(state, jumps)
        if mass is not None:      # each channel's regressors, cleared once for both uses
            mass = [nuisance.clear(mass[:, c, :]) for c in range(mass.shape[1])]
        d = _off_state(held[valid], nuisance, mass)
        r0 = _off_state(sampled[valid], nuisance, mass)
        del held, sampled, state, mass, nuisance
        lag, g = _lag_test(r0, d)
        if g is None:
            return plan, None
        # The hold is a property of the logging chain, the same over the whole log: a lag
        # other than ZOH must replicate in both halves (measured: a 600 s log at the
        # controller's rate rejected ZOH at p = 3e-26 on the whole log, carried by one
        # second near standstill where an unmodelled Coulomb friction tilts the fit, while
        # 60 s windows elsewhere kept ZOH; the selection then named a spurious input delay).
        half = len(r0) // 2
        for part in (slice(0, half), slice(half, None)):
            if _lag_test(r0[part], d[part])[1] is None:
                return plan, None
        return dataclasses.replace(plan, hold=lag), (
            f"inputs act {lag:.2f} log samples after they are logged "
            f"({1e3 * lag * plan.inner.dt:.3g} ms), not half a sample as a command held until "
            "the next log sample would: the log is slower than the controller that produced "
            "it? (held-out likelihood ratio "
            f"{g.statistic:.3g}, p = {g.p_value:.2g}, residual mean square "
            f"{100 * g.share_removed:.0f} % lower); an input delay shorter than half a log "
            "sample cannot be told from this and is not named")

    def _mass_nuisance(self, sig: Mapping[str, np.ndarray], plan: _Plan) -> np.ndarray:
        """Per channel, the mass-type regressors of the vocabulary (N, C, k), filtered.

        An unmodelled mass (a payload, an inertia error) leaves A(q)·q̈ in the residual: a
        function of the acceleration, which the hold's state bins (q, q̇) cannot clear and
        which correlates with the input's rate. Left in, it swamped the lag's test: a
        0.25–0.35 kg payload on 100 Hz logs of a 500 Hz loop kept ZOH (5 ms lag instead of
        the true 1 ms; the clean logs chose 0.10–0.11 sample), and the lag's leftover was
        then named as a viscous friction or a quadratic drag at joint 1. Regressors: each
        channel's own acceleration (an inertia error) and, on the arm, the payload's torque
        per kg (:meth:`payload_regressor`), through the equation's filter.

        Used on the kernel route only (M(q) not constant: the arm), where it was measured.
        On the Savitzky–Golay route (MuJoCo models) the acceleration regressor, which carries
        the same derivative noise as the residual and the input itself, tilted the lag of a
        clean MuJoCo log to 0.27–0.32 sample (ZOH rejected in both halves, p < 0.01) and a
        spurious 0.4 ms input delay was named at both joints.
        """
        ddq = sig["ddq"]
        cols = [ddq]
        if self.is_manipulator:
            sm = plan.kernel if plan.kernel is not None else plan.inner
            cols.append(sm(self.payload_regressor(sig["q"], sig["dq"], ddq)))
        return np.stack(cols, axis=2)

    def _constant_mass(self, q: np.ndarray) -> bool:
        """Whether M(q) is the same at (up to 200) recorded positions (relative 1e-9)."""
        m = self.mass(np.ascontiguousarray(q[:: max(1, len(q) // 200)]))
        return bool(np.allclose(m, m[0], rtol=1e-9, atol=0.0))

    def _plan(self, raw: Mapping[str, np.ndarray], dt: float,
              bounds: tuple[tuple[int, int], ...], noise: Mapping[str, float],
              from_q: bool, max_seconds: float = MAX_WINDOW_S
              ) -> tuple[_Plan, np.ndarray, np.ndarray]:
        """(filter plan, inner filter weights, velocity noise per joint) of a recording.

        ``max_seconds``: longest kernel window (s).
        """
        c = self.columns
        shortest = min(b - a for a, b in bounds)
        src = c.q if from_q else c.dq
        qr = np.stack([raw[k] for k in c.q], axis=1)
        if not self.is_manipulator or self._constant_mass(qr):
            # M constant: M·ddq is linear in q, the Savitzky–Golay route has no nonlinear
            # smoothing bias in it (and keeps the published EMPS results); see residual.py.
            # Other models than the built-in arm keep it too for now: on MuJoCo models the
            # momentum form named their armature as an inertia mismatch (M(q) from the
            # model's mass matrix does not hold everything its inverse dynamics does).
            w = choose_window([raw[k] for k in src], dt, deriv=2 if from_q else 1,
                              noise=[noise[k] for k in src], length=shortest)
            plan = _Plan(inner=Smoother(w, dt, bounds), kernel=None, velocity_from_q=from_q)
            pre = savgol_coeffs(w, POLYORDER, deriv=0, delta=dt, use="conv")
            vel_noise = np.asarray([noise[k] / (dt if from_q else 1.0) for k in src])
            return plan, pre, vel_noise
        inner_w = choose_window([raw[k] for k in src], dt, deriv=1 if from_q else 0,
                                noise=[noise[k] for k in src], length=shortest)
        pre = savgol_coeffs(inner_w, POLYORDER, deriv=1 if from_q else 0, delta=dt,
                            use="conv")
        k_w = choose_window([raw[k] for k in src], dt, deriv=2 if from_q else 1,
                            noise=[noise[k] for k in src], kind="kernel", pre=pre,
                            length=shortest, max_seconds=max_seconds)
        plan = _Plan(inner=Smoother(inner_w, dt, bounds),
                     kernel=KernelFilter(k_w, dt, bounds, interval=True),
                     velocity_from_q=from_q)
        return plan, pre, np.asarray([noise[k] for k in src])

    def _clipped_rows(self, raw: Mapping[str, np.ndarray], smoother: Any,
                      warn: list[str]) -> np.ndarray:
        """Rows (N, n) whose equation reads a clipped input sample (not fitted, not scored).

        A logged input held on its saturation level (:func:`.errormodel.clipped`) is not
        the input that acted while the true one exceeded the limit: the residual there is
        the clip, no effect. Every row whose filter window (one window wide, across gaps
        too: a little more is left out there, never less) touches such a sample is left
        out of fitting and scoring for that channel, and the report says so. Built-in arm
        only (one input column per channel).
        """
        c = self.columns
        n = len(next(iter(raw.values())))
        out = np.zeros((n, self.n_channels), dtype=bool)
        if not self.is_manipulator or len(c.u) != self.n_channels:
            return out
        for j, k in enumerate(c.u):
            hit = clipped(raw[k])
            if not hit.any():
                continue
            near = np.convolve(hit.astype(float), np.ones(smoother.window), mode="same") > 0
            out[:, j] = near
            lo, hi = float(np.min(raw[k][hit])), float(np.max(raw[k][hit]))
            warn.append(f"{k} is clipped: {int(hit.sum())} samples sit on its saturation "
                        f"level{'s' if lo != hi else ''} ({lo:.4g}"
                        f"{'' if lo == hi else f', {hi:.4g}'}); the {int(near.sum())} rows "
                        "whose equation reads them are not fitted or scored (the logged "
                        "input is not the one that acted there)")
        return out

    def _lagged_velocities(self, raw: Mapping[str, np.ndarray], grid: Any,
                           models: Mapping[str, Any], bad: list[tuple[str, str]]
                           ) -> list[str]:
        """One line per velocity column that lags (or leads) its angle's derivative.

        A velocity logged δ late (a backward difference: half a sample; a drive's moving
        average or low-pass: its group delay) fits as an input delay δ on a clean log
        (:func:`simgap.diagnosis.errormodel.velocity_lag`). When the angle's own error is
        modelled (white or quantised), the angle's derivative has no such lag and is used
        instead (on MuJoCo and user models too: measured, a backward-difference velocity
        named a 0.7-0.9 ms actuator delay at both joints of clean MJCF arm logs).
        """
        c, out = self.columns, []
        done = {v for v, _ in bad}
        for v, p in zip(c.dq, c.q, strict=True):
            # the angle's derivative is a remedy only when the angle's own error is modelled:
            # not when it too is heavy-tailed or low-passed (a 10 Hz Butterworth angle lags
            # more and smears a friction reversal more than a drive's moving-average dq)
            if v in done or models[p].low_passed or (models[p].heavy_tailed
                                                     and not models[p].quantisation_dominant):
                continue
            lag, se = velocity_lag(raw[p], raw[v], grid.dt, grid.segment)
            if abs(lag) > LAG_Z * se:
                out.append(f"{v} {'lags' if lag > 0 else 'leads'} the derivative of {p} by "
                           f"{1e3 * abs(lag):.3g} ms ({abs(lag) / se:.0f} standard errors; a "
                           "backward difference or a filter upstream?): a lag of the "
                           f"velocity would read as an input delay; differentiating {p} "
                           "instead")
        return out

    def prepare(self, rec: Recording) -> Prepared:
        """Filter the recording; the residual (N·m or N), its noise floor, the signals."""
        c = self.columns
        grid = segmented_grid(rec[c.t], {k: rec[k] for k in c.required if k != c.t})
        t, dt, bounds = grid.t, grid.dt, grid.bounds
        # the grid's own columns (new arrays, never the recording's): no second copy
        raw = {k: np.asarray(v, dtype=np.float64) for k, v in grid.columns.items()}
        warn = grid_warnings(grid)
        models = error_models(raw, grid.segment)
        from_q = not c.dq
        lagged: list[str] = []
        if c.dq:
            # the angle's derivative is a remedy only when the angle's own error is modelled
            # (white or quantised): when it too shows unmodelled heavy tails (both columns
            # filtered, or interpolated timing errors of a jittered log) the recorded
            # velocity is kept; both columns are reported by the error model's notes.
            # A heavy-tailed velocity whose high frequencies are still white (kinks of the
            # signal at a coarse rate: friction reversals, torque steps) is kept too.
            bad = [(v, p) for v, p in zip(c.dq, c.q, strict=True)
                   if (models[v].filtered_upstream or models[v].quantisation_dominant)
                   and not (models[p].heavy_tailed and not models[p].quantisation_dominant)]
            lagged = self._lagged_velocities(raw, grid, models, bad)
            if lagged:
                from_q = True
                warn += lagged
            if bad:
                from_q = True
                warn += [(f"{v} is quantised (step {models[v].quantum:.4g}, a finite "
                          "difference?)" if models[v].quantisation_dominant else
                          f"{v} looks filtered upstream (kurtosis of its third differences "
                          f"{models[v].kurtosis:.3g}, white noise gives 3)") +
                         f"; differentiating {p} instead" for v, p in bad]
        noise = noise_of(models, warn, c.q if from_q else c.dq)
        if from_q and c.dq:  # a replaced column: its one line says so, not its model's note
            warn = [w for w in warn if not any(w in models[v].notes for v in c.dq
                                               if models[v].filtered_upstream
                                               or models[v].quantisation_dominant)]
        if not self.is_manipulator:  # MuJoCo/user models: main's estimate until re-validated
            noise = {k: noise_std(v) for k, v in raw.items()}
        plan, pre, vel_noise = self._plan(raw, dt, bounds, noise, from_q)
        plan, hold_note = self._choose_hold(raw, plan)
        warn += [hold_note] if hold_note else []
        kernel = plan.kernel
        smoother = kernel if kernel is not None else plan.inner
        sig = self._signals(raw, plan)
        res = self._residual(sig, kernel)
        # a quantised angle's rounding error is propagated as a staircase, not as white noise
        quant = {k: (models[k].quantum, sig["q"][:, j]) for j, k in enumerate(c.q)
                 if self.is_manipulator and models[k].quantisation_dominant}
        white = {k: (models[k].white_std if k in quant else v) for k, v in noise.items()}
        floor = noise_floor(raw, white, lambda r: self.residual_of(r, plan), res,
                            quantised=quant)
        if kernel is not None and not quant:   # a staircase's error is modelled as such
            excess = self._error_excess(raw, plan, res, white)
            if excess > ERROR_EXCESS:
                src = c.q if from_q else c.dq
                scaled = {k: v * excess if k in src else v for k, v in noise.items()}
                new, pre_x, vel_x = self._plan(raw, dt, bounds, scaled, from_q,
                                               max_seconds=EXCESS_WINDOW_S)
                if new.kernel.window != kernel.window:
                    warn.append(
                        f"the residual's high-frequency error is {excess:.3g}x what the "
                        "columns' white noise explains (coloured or under-estimated "
                        "measurement error): the equation's filter is chosen for that "
                        f"error ({kernel.window} -> {new.kernel.window} samples)")
                    plan, pre, vel_noise = dataclasses.replace(new, hold=plan.hold), pre_x, \
                        vel_x
                    kernel = smoother = plan.kernel
                    sig = self._signals(raw, plan)
                    res = self._residual(sig, kernel)
                    quant = {k: (models[k].quantum, sig["q"][:, j]) for j, k in enumerate(c.q)
                             if self.is_manipulator and models[k].quantisation_dominant}
                    floor = noise_floor(raw, white, lambda r: self.residual_of(r, plan), res,
                                        quantised=quant)
        model_rms = np.sqrt(np.mean(self.inverse_dynamics(sig["q"], sig["dq"], sig["ddq"]) ** 2,
                                    axis=0))
        floor = np.hypot(floor, NUMERICAL_FLOOR * model_rms)
        # Coulomb smoothing: below ~2 std of the filtered velocity noise the sign is unknown.
        gain = float(np.sqrt(np.sum(pre**2)))
        sigma = np.maximum(2.0 * vel_noise * gain, 1e-4)
        scale = np.asarray(c.u_scale or (1.0,) * len(c.u))
        u_hold = np.stack([raw[k] for k in c.u], axis=1) * scale
        valid = smoother.valid(len(t))
        clip = self._clipped_rows(raw, smoother, warn)
        return Prepared(t=t, residual=res, noise_rms=floor, signals=sig,
                        smoother=smoother, resampled=grid.resampled, column_noise=noise,
                        segment=grid.segment, column_models=models,
                        warnings=tuple(dict.fromkeys(warn)),
                        effective_samples=effective_counts(res, valid, grid.segment),
                        valid=valid, plan=plan, inputs=u_hold,
                        # what an input delay shifts
                        held_input=_held(u_hold, plan.hold, interval=kernel is not None),
                        coulomb_sigma=sigma,
                        fit_mask=self._fit_mask(sig, sigma, valid) & ~clip,
                        state_columns=tuple((k, j) for k in ("q", "dq")
                                            for j in range(sig["q"].shape[1])),
                        state_derivative=sig["ddq"],
                        derivatives=tuple(("ddq", j) for j in range(self.n_channels)))

    def _error_excess(self, raw: Mapping[str, np.ndarray], plan: _Plan, res: np.ndarray,
                      white: Mapping[str, float]) -> float:
        """How much larger the residual's high-frequency error is than the columns' explain.

        The band is the kernel's upper pass band, r − K*r: physics (a function of the
        operating point, of the trajectory's bandwidth) is mostly removed there, the
        differentiated measurement error is not. Its robust std (1.4826·MAD, so that the
        sparse kinks of a friction reversal do not count) is compared with the same band of
        the propagated white floor (:func:`noise_floor`, same statistic). White column
        noise gives ≤ 1; a velocity with 2 % AR(1) noise of 50 ms correlation time gives
        ≈ 4–6 (its k-th differences see only the innovations).

        Returns:
            The largest ratio over the channels (1.0 when the floor is zero).
        """
        kernel = plan.kernel

        def high(r: np.ndarray) -> np.ndarray:
            return r - kernel(r)

        valid = kernel.valid(len(res))
        base = high(res)
        rng = np.random.default_rng(0)
        noisy = {k: v + rng.normal(0.0, white.get(k, 0.0), size=v.shape) for k, v in
                 raw.items()}
        change = high(self.residual_of(noisy, plan)) - base
        del noisy

        def robust(x: np.ndarray) -> np.ndarray:
            return MAD_TO_STD * np.median(np.abs(x[valid]), axis=0)

        floor = robust(change)
        mine = robust(base)
        ratio = np.where(floor > 0, mine / np.where(floor > 0, floor, 1.0), 1.0)
        return float(np.max(ratio)) if ratio.size else 1.0

    def _fit_mask(self, sig: Mapping[str, np.ndarray], sigma: np.ndarray,
                  valid: np.ndarray | None = None) -> np.ndarray:
        """Rows (N, n) whose joint residual is determinate: |dq| above 3 Coulomb widths.

        Below it the joint may be stuck, where friction takes any value up to breakaway and
        its sign is unknowable from the velocity; those samples are left out of fitting and
        scoring for that joint (they stay in the located residual). Rows whose filter window
        leaves their segment (``valid`` False) are not fitted either. (Requiring every row of
        the window to slide, as the filtered equation strictly would, tipped the EMPS
        selection from torque_bias to an aliased spring: not done.)
        """
        sliding = np.abs(sig["dq"]) >= STICK_WIDTHS * sigma
        return sliding if valid is None else sliding & valid[:, None]

    def effect_context(self, coulomb_sigma: np.ndarray | None = None, *,
                       t: np.ndarray | None = None,
                       held_input: np.ndarray | None = None) -> EffectContext:
        """Effects' context from its data: Coulomb smoothing, gravity, payload regressor.

        Args:
            coulomb_sigma: smoothing velocity per joint (rad/s or m/s); default 1e-3.
            t: the time grid (s), for an input delay.
            held_input: the hold-averaged inputs, for an input delay.
        """
        sigma = np.full(self.n_channels, 1e-3) if coulomb_sigma is None else coulomb_sigma
        return EffectContext(n_channels=self.n_channels, coulomb_sigma=sigma,
                             gravity=self.gravity,
                             payload_regressor=self.payload_regressor if self.is_manipulator
                             else None, t=t, held_input=held_input)

    def context(self, prepared: Prepared, terms: Sequence[tuple] = ()) -> EffectContext:
        """Effects' context: Coulomb smoothing, gravity, payload regressor, held input.

        The time grid and the held input serve the input delay. Mechanical terms do not
        couple, so ``terms`` changes nothing.
        """
        return self.effect_context(prepared.coulomb_sigma, t=prepared.t,
                                   held_input=prepared.held_input)

    def locate_variables(self, prepared: Prepared) -> dict[str, tuple[np.ndarray, str]]:
        """Variables the residual may depend on: name -> (values on the grid, unit)."""
        sig, out = prepared.signals, {}
        for j, c in enumerate(self.columns.q):
            out[c] = (sig["q"][:, j], self.state_units[j])
        for j, c in enumerate(self.state_names[self.n_channels:]):
            out[c] = (sig["dq"][:, j], self.state_units[self.n_channels + j])
        for j, c in enumerate(self.derivative_names):
            out[c] = (sig["ddq"][:, j], self.derivative_units[j])
        return out

    # -- simulation --------------------------------------------------------------------
    def _effect_split(self, effects, q, dq, ctx: EffectContext):
        """tau_d(q, dq, ddq) = A(q) ddq + b(q, dq) of the fitted effects, per row."""
        zero = {"q": q, "dq": dq, "ddq": np.zeros((q.shape[0], self.n_channels))}
        return mass_split(effects, zero, tuple(("ddq", j) for j in range(self.n_channels)),
                          self.n_channels, ctx)

    def acceleration(self, q, dq, u, effects, ctx: EffectContext | None = None) -> np.ndarray:
        """Ddq (rad/s²) of the nominal (+ fitted effects): (M + A) ddq = u − bias − b."""
        z = np.zeros_like(q)
        rhs = u - self.inverse_dynamics(q, dq, z)
        mass = self.mass(q)
        if effects:
            a, b = self._effect_split(effects, q, dq, ctx or self.effect_context())
            mass = mass + a
            rhs = rhs - b
        return np.linalg.solve(mass, rhs[..., None])[..., 0]

    def _delayed(self, prepared: Prepared, effects, rows: np.ndarray
                 ) -> tuple[list, np.ndarray | None]:
        """(effects not on the input, per-row acting input or None).

        The acting input is the held input passed, per channel and in the effects' order,
        through each ``on_input`` effect's ``input_map`` (a delay, a dead zone).
        """
        maps = [(eff, j, np.asarray(nl, dtype=np.float64)) for eff, j, lin, nl in effects
                if getattr(eff, "on_input", False)]
        if not maps:
            return list(effects), None
        t, held = prepared.t, prepared.held_input
        u = held.copy()
        for eff, j, nl in maps:
            u[:, j] = eff.input_map(nl, t, u[:, j])
        rest = [e for e in effects if not getattr(e[0], "on_input", False)]
        return rest, u[rows]

    def derivative(self, prepared: Prepared, idx: np.ndarray, effects) -> np.ndarray:
        """Model ddq at the recorded states and (delayed, if an effect says) inputs."""
        sig = prepared.signals
        ctx = self.context(prepared, effects)
        rest, u = self._delayed(prepared, effects, idx)
        if u is not None:
            u_late = sig["u"][idx] - (prepared.held_input[idx] - u)
            return self.acceleration(sig["q"][idx], sig["dq"][idx], u_late, rest, ctx)
        return self.acceleration(sig["q"][idx], sig["dq"][idx], sig["u"][idx], effects, ctx)

    def step(self, prepared: Prepared, s: np.ndarray, k: np.ndarray, effects,
             dt: float) -> np.ndarray:
        """One RK4 step of a batch of states s = (q, dq) with the recorded input of rows k.

        The input is delayed where an input-delay effect says.
        """
        nc = self.n_channels
        ctx = self.context(prepared, effects)
        effects, delayed = self._delayed(prepared, effects, k)
        u = prepared.inputs[k] if delayed is None else delayed

        def deriv(x):
            return np.concatenate([x[:, nc:], self.acceleration(x[:, :nc], x[:, nc:], u,
                                                                effects, ctx)], axis=1)
        return rk4_batch_step(deriv, s, dt)


class BicycleSystem:
    """Adapter for :class:`BicycleNominal` with the measured, varying vx (see module doc)."""

    kind = "bicycle"
    #: Variables whose sign is the direction of motion (turn direction); not vx, which is
    #: positive whenever the car drives forward.
    direction_variables = ("vy", "r")
    #: Input columns of the prepared signals (their rates stratify the split's blocks by
    #: input activity, :func:`.validation.block_activity`).
    input_signals = ("delta_f", "delta_r")
    #: The vocabulary holds no offset whose sign follows the turn direction: a named effect
    #: must beat one (:meth:`.fit.Fitter._demote_direction_offsets`).
    direction_offset_probe = True
    #: Mass, yaw inertia and both axles' tire laws scaled by one factor leave the motion
    #: unchanged: of the equivalent descriptions that explain the data as well, the one with
    #: the fewest terms is named (:meth:`.fit.Fitter._simplest_members`).
    symmetries = (Symmetry(members=("mass_mismatch", "yaw_inertia_mismatch",
                                    "cornering_stiffness"),
                           description="mass, yaw inertia and both axles' tire laws "
                                       "(cornering stiffness) scaled by one factor"),)

    def __init__(self, model: BicycleNominal | None = None,
                 columns: AdapterColumns = BICYCLE_COLUMNS, name: str | None = None,
                 tire: MagicFormulaTire | None = None) -> None:
        self.model = model or BicycleNominal()
        self.params = self.model.params
        self.columns = columns
        self.name = name or getattr(self.model, "name", None) or "bicycle"
        self.channels = ("front_axle", "rear_axle")
        self.channel_units = ("N", "N")
        self.n_channels = 2
        self.K_inv = self.model.K_inv
        self.stiffness = (self.params.C_af, self.params.C_ar)
        self.loads = axle_loads(self.params.array)
        self.tire = tire or MagicFormulaTire()
        self.state_names = ("vy", "r")
        self.state_units = ("m/s", "rad/s")
        self.derivative_names = ("dvy", "dr")
        self.derivative_units = ("m/s²", "rad/s²")
        self.rollout_horizon = 1.0

    def candidates(self, prepared: Prepared) -> list[tuple[Effect, int | None, str]]:
        """Vocabulary effects to test, adapted to the data by each effect's ``for_data``.

        E.g. the steering lag only on axles whose command varies, as declared in
        :mod:`simgap.models.bicycle`.
        """
        base: list[tuple[Effect, int | None, str]] = []
        for e in BICYCLE_EFFECTS:
            if e.scope == "axle":
                for i in range(2):
                    base.append((e, i, self.channels[i]))
            else:
                base.append((e, None, "vehicle"))
        ctx = self.context(prepared)
        out = []
        for e, i, channel in base:
            if e.for_data is not None:
                e = e.for_data(e, prepared.signals, i, ctx)
                if e is None:
                    continue
            out.append((e, i, channel))
        return out

    def _slips(self, vy, r, delta_f, delta_r, vx) -> tuple[np.ndarray, np.ndarray]:
        return slip_angles(vy, r, delta_f, delta_r, vx, self.params.lf, self.params.lr)

    def _signals(self, raw: Mapping[str, np.ndarray], sm: Smoother) -> dict[str, np.ndarray]:
        c = self.columns
        vy_c, r_c = c.q
        scale = np.asarray(c.u_scale or (1.0, 1.0))
        u = sm(_held(np.stack([raw[k] for k in c.u], axis=1), c.input_hold)) * scale
        vx = sm(raw[c.vx])
        sig = {"vy": sm(raw[vy_c]), "r": sm(raw[r_c]), "dvy": sm(raw[vy_c], 1),
               "dr": sm(raw[r_c], 1), "vx": np.maximum(vx, 1.0 + 1e-6), "delta_f": u[:, 0],
               "delta_r": u[:, 1]}
        sig["alpha_f"], sig["alpha_r"] = self._slips(sig["vy"], sig["r"], sig["delta_f"],
                                                     sig["delta_r"], sig["vx"])
        return sig

    def _residual(self, sig: Mapping[str, np.ndarray]) -> np.ndarray:
        x = np.stack([sig["vy"], sig["r"]], axis=1)
        u = np.stack([sig["delta_f"], sig["delta_r"]], axis=1)
        dx = np.stack([sig["dvy"], sig["dr"]], axis=1)
        g = dx - state_derivative(x, u, self.params, sig["vx"])
        return g @ self.K_inv.T

    @staticmethod
    def instruments(inputs: np.ndarray, dt: float,
                    bounds: Sequence[tuple[int, int]] | None,
                    speed: np.ndarray | None = None) -> np.ndarray:
        """(N, k) instruments of the inertia terms: functions of the logged inputs only.

        A constant and, per axle whose command varies, the command and its first-order
        lagged copies of :data:`INSTRUMENT_LAGS` (a linear vehicle's states are linear
        filters of the command; a steering lag is one), each with its cube (a saturating
        tire). Nothing read from the lateral states: their filtered noise is in the
        residual too (through f(x, u) and vx·r), so a state-based instrument would carry it.

        With ``speed`` (the measured forward speed, m/s, which the single-track model takes
        as given) varying, each command and lagged copy also enters times the relative
        speed v̄/mean(v̄) − 1, v̄ its centred moving average over
        :data:`INSTRUMENT_SPEED_WINDOW_S` (the response to a steering command scales with
        the speed: the steady yaw gain is vx/(L(1 + K·vx²))). Without them, a speed that
        varies by ±15 % left 0.47 m/s² of the lateral acceleration outside the projection
        (the derivative noise is 0.15 m/s²; measured on a noise-free 40 s proof log): a
        physical part of the mass regressor missing, so that a mass ratio explained the
        data worse than its symmetric equivalent in tire-law and yaw-inertia ratios. With
        them 0.05 m/s². The moving average leaves 1/(window samples) of a sample's speed
        noise in it, whose share of the residual (through vx·r) is itself small.
        """
        cols = [np.ones(inputs.shape[0])]
        rel = None
        if speed is not None:
            v = np.asarray(speed, dtype=np.float64)
            width = max(1, int(round(INSTRUMENT_SPEED_WINDOW_S / dt)))
            vbar = np.concatenate([uniform_filter1d(v[lo:hi], size=min(width, hi - lo),
                                                    mode="nearest")
                                   for lo, hi in bounds or ((0, len(v)),)])
            mean = float(np.mean(vbar))
            if mean > 0 and np.ptp(vbar) > INSTRUMENT_SPEED_PTP * mean:
                rel = vbar / mean - 1.0
        for axle in range(inputs.shape[1]):
            d = inputs[:, axle]
            if np.ptp(d) < 1e-6:
                continue
            lagged = [d]
            for tau in INSTRUMENT_LAGS:
                a = np.exp(-dt / tau)
                lagged.append(np.concatenate([
                    lfilter([0.0, 1.0 - a], [1.0, -a], d[lo:hi] - d[lo]) + d[lo]
                    for lo, hi in bounds or ((0, len(d)),)]))
            cols += lagged + [x**3 for x in lagged]
            if rel is not None:
                cols += [x * rel for x in lagged]
        return np.column_stack(cols)

    def reference_accelerations(self, sig: Mapping[str, np.ndarray], inputs: np.ndarray,
                                dt: float, rows: np.ndarray,
                                bounds: Sequence[tuple[int, int]] | None
                                ) -> dict[str, np.ndarray]:
        """Accelerations for the inertia terms' regressors, without the residual's noise.

        Errors in variables: the measured ay = dvy/dt + vx·r and dr/dt carry the derivative
        noise that is also in the residual dx/dt − f. A regressor read from them is fitted
        towards shrinking that noise: along the near-symmetry of steady turns (mass and both
        tire laws scaled together) only the noise is left, and clean circles fitted a mass
        ratio of 0.15-0.28 with both stiffness ratios beside it. Here each acceleration is
        replaced by its least-squares projection on :meth:`instruments` (functions of the
        logged inputs only, fitted on ``rows``): the fit with it is the two-stage
        least-squares (instrumental-variable) estimate, consistent because the inputs'
        noise is independent of the residual's. It stays exact beside other force effects
        (a steering lag, a saturation), which the acceleration itself contains.

        The slip angles of the cornering-stiffness terms are projected on the same
        instruments (``alpha_f_ref``, ``alpha_r_ref``): their filtered-state noise is in the
        residual too (through the nominal tire force). Along the symmetry it was all that
        was left once the accelerations were instrumented: clean circles fitted the joint
        scale at 0.89-0.92 with the exact ay, 1.00 with exact slip angles as well.

        Args:
            sig: filtered signals (``dvy``, ``dr``, ``vx``, ``r``, ``alpha_f``, ``alpha_r``).
            inputs: the logged inputs (N, 2), rad.
            dt: sample step (s).
            rows: the rows the first stage is fitted on (filter window inside the segment).
            bounds: segments (rows between gaps); ``None`` = one segment.

        Returns:
            ``ay_ref`` (m/s²), ``dr_ref`` (rad/s²), ``alpha_f_ref`` and ``alpha_r_ref``
            (rad), (N,) each.
        """
        z = self.instruments(inputs, dt, bounds, speed=sig["vx"])
        scale = np.sqrt(np.mean(z[rows] ** 2, axis=0))
        z = z / np.where(scale > 0, scale, 1.0)
        acc = np.column_stack([sig["dvy"] + sig["vx"] * sig["r"], sig["dr"],
                               sig["alpha_f"], sig["alpha_r"]])
        beta, *_ = np.linalg.lstsq(z[rows], acc[rows], rcond=None)
        ref = z @ beta
        return {"ay_ref": ref[:, 0], "dr_ref": ref[:, 1], "alpha_f_ref": ref[:, 2],
                "alpha_r_ref": ref[:, 3]}

    def prepare(self, rec: Recording) -> Prepared:
        """Filter the recording; Delta = K⁻¹ g (N), its noise floor and the signals."""
        c = self.columns
        grid = segmented_grid(rec[c.t], {k: rec[k] for k in c.required if k != c.t})
        t, dt, bounds = grid.t, grid.dt, grid.bounds
        # the grid's own columns (new arrays, never the recording's): no second copy
        raw = {k: np.asarray(v, dtype=np.float64) for k, v in grid.columns.items()}
        if np.any(raw[c.vx] <= 1.0):
            i = int(np.argmax(raw[c.vx] <= 1.0))
            raise ValueError(f"{rec.name}: column {c.vx!r} row {i + 1}: vx = {raw[c.vx][i]!r} "
                             "m/s, the bicycle model needs vx > 1 m/s")
        warn = grid_warnings(grid)
        models = error_models(raw, grid.segment)
        noise = noise_of(models, warn, c.q)
        window = choose_window([raw[k] for k in c.q], dt, deriv=1,
                               noise=[noise[k] for k in c.q],
                               length=min(b - a for a, b in bounds))
        sm = Smoother(window, dt, bounds)
        sig = self._signals(raw, sm)
        res = self._residual(sig)
        floor = noise_floor(raw, noise, lambda r: self._residual(self._signals(r, sm)), res)
        inputs = np.stack([raw[k] for k in c.u], axis=1) * np.asarray(c.u_scale or (1.0, 1.0))
        sig.update(self.reference_accelerations(sig, inputs, dt,
                                                np.flatnonzero(sm.valid(len(t))), bounds))
        tire = np.stack([self.stiffness[0] * sig["alpha_f"], self.stiffness[1] * sig["alpha_r"]],
                        axis=1)  # modelled (linear) axle forces, N
        floor = np.hypot(floor, NUMERICAL_FLOOR * np.sqrt(np.mean(tire**2, axis=0)))
        scale = np.asarray(c.u_scale or (1.0,) * len(c.u))
        valid = sm.valid(len(t))
        # rows whose filter window lies inside their segment (all rows without gaps)
        ok = valid if len(bounds) > 1 else np.ones(len(t), dtype=bool)
        return Prepared(t=t, residual=res, noise_rms=floor, signals=sig, smoother=sm,
                        resampled=grid.resampled, column_noise=noise, segment=grid.segment,
                        column_models=models, warnings=tuple(dict.fromkeys(warn)),
                        effective_samples=effective_counts(res, valid, grid.segment),
                        valid=valid, inputs=np.stack([raw[k] for k in c.u], axis=1) * scale,
                        fit_mask=np.repeat(ok[:, None], 2, axis=1),
                        state_columns=(("vy", None), ("r", None)),
                        state_derivative=np.stack([sig["dvy"], sig["dr"]], axis=1),
                        derivatives=(("dvy", None), ("dr", None)))

    @staticmethod
    def lagged_steering(prepared: Prepared, axle: int, tau: float) -> np.ndarray:
        """Road-wheel angle (rad) of a first-order lag tau (s) behind the command.

        Exact for a command held over each sample (ZOH): the raw logged command is filtered,
        not the hold-averaged one (which already lags by half a sample). Memoised on the
        prepared data (a pure function of it).
        """
        memo = prepared.memo.setdefault("lagged_steering", {})
        key = (axle, round(float(tau), 12))
        if key not in memo:
            a = np.exp(-prepared.smoother.dt / max(tau, 1e-9))
            parts = []  # per segment: the lag restarts after a time gap
            for lo, hi in prepared.smoother.bounds or ((0, prepared.n),):
                d = prepared.inputs[lo:hi, axle]
                parts.append(lfilter([0.0, 1.0 - a], [1.0, -a], d - d[0]) + d[0])
            out = np.concatenate(parts)
            out.flags.writeable = False
            memo[key] = out
            if len(memo) > 64:
                memo.pop(next(iter(memo)))
        return memo[key]

    def context(self, prepared: Prepared, terms: Sequence[tuple] = ()) -> EffectContext:
        """Effects' context for one model made of ``terms``.

        Args:
            prepared: the prepared recording (its lag filter input).
            terms: (effect, axle index, lin, nl) of one model. The terms other effects
                ``need`` (the vocabulary's coupling: a steering lag needs the
                tire_saturation of its axle) give their nonlinear value per axle
                (``axle_mu``), which the needing effect composes with.
        """
        return EffectContext(n_channels=2, stiffness=self.stiffness, loads=self.loads,
                             tire=self.tire, K_inv=self.K_inv,
                             lagged_steering=partial(self.lagged_steering, prepared),
                             axle_mu={i: float(nl[0]) for eff, i, _lin, nl in terms
                                      if eff.name in _NEEDED and len(nl)})

    def locate_variables(self, prepared: Prepared) -> dict[str, tuple[np.ndarray, str]]:
        """Variables the residual may depend on: name -> (values, unit)."""
        s = prepared.signals
        return {"alpha_f": (s["alpha_f"], "rad"), "alpha_r": (s["alpha_r"], "rad"),
                "vy": (s["vy"], "m/s"), "r": (s["r"], "rad/s"),
                "delta_f": (s["delta_f"], "rad"), "ay": (s["dvy"] + s["vx"] * s["r"], "m/s²"),
                "vx": (s["vx"], "m/s"), "dr": (s["dr"], "rad/s²")}

    # -- simulation --------------------------------------------------------------------
    def _deriv(self, prepared: Prepared, x, idx, effects, u, ctx: EffectContext):
        vx = prepared.signals["vx"][idx]
        f = state_derivative(x, u, self.params, vx)
        if not effects:
            return f
        af, ar = self._slips(x[:, 0], x[:, 1], u[:, 0], u[:, 1], vx)
        sig = {"vy": x[:, 0], "r": x[:, 1], "vx": vx, "delta_f": u[:, 0], "delta_r": u[:, 1],
               "alpha_f": af, "alpha_r": ar, "idx": idx,
               "dvy": np.zeros(len(idx)), "dr": np.zeros(len(idx))}
        k = self.model.K
        d, b = mass_split(effects, sig, prepared.derivatives, 2, ctx)
        # dx = f + K (b + D dx)  →  (I − K D) dx = f + K b
        lhs = np.eye(2)[None] - np.einsum("ij,njk->nik", k, d)
        return np.linalg.solve(lhs, (f + b @ k.T)[..., None])[..., 0]

    def derivative(self, prepared: Prepared, idx: np.ndarray, effects) -> np.ndarray:
        """Model (dvy, dr) at the recorded (filtered) states and inputs."""
        sig = prepared.signals
        u = np.stack([sig["delta_f"][idx], sig["delta_r"][idx]], axis=1)
        return self._deriv(prepared, prepared.state_at(idx), idx, effects, u,
                           self.context(prepared, effects))

    def step(self, prepared: Prepared, s: np.ndarray, k: np.ndarray, effects,
             dt: float) -> np.ndarray:
        """One RK4 step of a batch of (vy, r) with the recorded input and vx of rows k."""
        u = prepared.inputs[k]
        ctx = self.context(prepared, effects)
        return rk4_batch_step(lambda x: self._deriv(prepared, x, k, effects, u, ctx), s, dt)


# --------------------------------------------------------------------------- adapters
#: Kept for one release: the bound now lives with the Stribeck vocabulary entry.
STRIBECK_MAX_SHARE = man.STRIBECK_MAX_SHARE


def _mechanical_names(model: Any) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """Canonical (positions, velocities, inputs) column names of a mechanical model."""
    obs = tuple(getattr(model, "obs_names", ()))
    n = len(model.input_names)
    if len(obs) != 2 * n:
        raise CustomModelError(f"{_label(model)}: a mechanical model needs obs_names = "
                               f"positions + velocities (2 × {n} names), got {obs}")
    return obs[:n], obs[n:], tuple(model.input_names)


def _joint_units(model: Any, n: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(position units, effort units) per joint; revolute SI units by default."""
    obs_units = tuple(getattr(model, "obs_units", ()))
    pos = obs_units[:n] if len(obs_units) == 2 * n else ("rad",) * n
    eff = tuple(getattr(model, "residual_units", ()) or ())
    if len(eff) != n or any(u.startswith("(") for u in eff):
        eff = tuple(model.input_units) if len(model.input_units) == n else ("N·m",) * n
    return pos, eff


#: Revolute-joint units of the old vocabulary tables and their templates (format_unit).
_REVOLUTE_TEMPLATES = {"N·m·s": "{effort}·s/{position}", "N·m/rad": "{effort}/{position}",
                       "N·m": "{effort}", "rad/s²": "{position}/s²", "rad/s": "{position}/s",
                       "rad": "{position}", "kg·m²": "{inertia}"}


def translate_unit(unit: str, position: str, effort: str) -> str:
    """Rewrite a unit written for a revolute joint (rad, N·m) for this joint.

    Example: for a prismatic joint (m, N), ``N·m·s`` (viscous b) becomes ``N·s/m`` and
    ``kg·m²`` (inertia) becomes ``kg``. The vocabulary itself holds unit templates filled
    by :func:`simgap.models.effects.format_unit`; this maps the revolute spelling to its
    template and fills it.
    """
    if position == "rad" and effort == "N·m":
        return unit
    return format_unit(_REVOLUTE_TEMPLATES.get(unit, unit), effort=effort, position=position)


def _label(model: Any) -> str:
    return getattr(model, "name", None) or type(model).__name__


def __getattr__(name: str) -> Any:
    """Deprecated aliases, kept for one release.

    ``ColumnMap`` is now :class:`AdapterColumns`; ``ModelMechanicalSystem`` is
    :class:`MechanicalSystem` (one mechanical form).
    """
    if name == "ModelMechanicalSystem":
        warnings.warn("simgap.diagnosis.systems.ModelMechanicalSystem is deprecated: "
                      "MechanicalSystem is the one mechanical form (columns and units from "
                      "the model)", DeprecationWarning, stacklevel=2)
        return MechanicalSystem
    if name == "ColumnMap":
        warnings.warn("simgap.diagnosis.systems.ColumnMap is deprecated: describe a file with "
                      "simgap.recordings.ColumnMap (diagnose(..., columns=)); the adapters' "
                      "own column spec is simgap.diagnosis.systems.AdapterColumns",
                      DeprecationWarning, stacklevel=2)
        return AdapterColumns
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


guard_cache(globals())  # drop cached kernels when a module they compile in changes
