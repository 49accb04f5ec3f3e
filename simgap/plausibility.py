"""Plausibility of a recording and of parameter overrides against the model's SI units.

A recording can be perfectly well-formed and still be in the wrong units: time in ms or µs,
angles in degrees, a torque logged in mN·m or with its sign flipped, a corrupt 1e300 cell.
The diagnosis would then "explain" a unit error with invented physics, or fail deep inside
a fit. These checks name the column, the evidence and the likely unit instead, each for a
reason that can be stated:

* **magnitude**: SI signals of the modelled systems never exceed :data:`MAX_ABS` in size,
  and a column whose largest value is below :data:`MIN_ABS` (but not zero) is a scale error;
* **motion**: if every state column is constant there is nothing to diagnose;
* **sample period vs the model's time scale**: the nominal model is linearised at
  :data:`RATE_POINTS` rows along the recording (:func:`model_rate`, median over the rows);
  its fastest mode |λ|max (1/s) must be resolved (Nyquist: dt |λ|max < π) and not be
  absurdly oversampled (dt |λ|max > :data:`MIN_DT_RATE`). A period outside that which lands
  inside once divided by 10³, 10⁶ or 10⁹ is named as time in ms, µs or ns if the recording
  read so still spans :data:`MIN_SPAN` time constants (a period only slightly too long gets
  no unit guess). A model with no intrinsic rate (pure inertia) falls back to the declared
  :data:`DT_RANGE`;
* **kinematic consistency** (mechanical systems with q and dq columns): the recorded
  velocity must be the time derivative of the recorded position; the least-squares ratio
  dq / (dq/dt) names degrees (57.3), ms time (10³) or a flipped sign (−1);
* **effort** (after the residual is computed): the recorded torque/force against what the
  nominal model needs for the recorded motion, M(q) ddq + bias; a strongly correlated ratio
  near −1 is a flipped sign, beyond ×30 (or below ÷30) a unit factor such as ×1000; a
  motion that needs over 30× the recorded effort (RMS) is degrees or a unit factor (missing
  physics such as friction only ever adds effort the model does not need, never removes
  that much);
* **bicycle ranges**: road-wheel steering above π/2 rad is degrees, vx above 70 m/s is
  km/h, a yaw rate above 2π rad/s is deg/s (the model's declared range of validity);
* **unit hypotheses through the model** (bicycle, after filtering): vx enters the lateral
  dynamics through the frame rotation −vx r and the slip angles, so a speed logged in km/h
  (or mph) at any speed makes the nominal model explain the recorded (dvy, dr) far worse
  than the same log read in m/s. Every column the model reads in m/s is under test (vx and
  the states the adapter declares in m/s, i.e. vy, whose derivative scales with it), each
  subset of them in each candidate unit: a logger writes vx and vy in km/h together.
  :func:`check_unit_hypotheses` compares the share of the recorded derivative the model
  leaves unexplained as recorded and under each reading, and names the columns and unit
  when one explains the data :data:`HYPOTHESIS_GAIN` × better (and leaves under
  :data:`HYPOTHESIS_FIT` unexplained). On every generated m/s log tried (8–30 m/s,
  with and without missing tire physics) both wrong readings were worse than the right one,
  so the test did not fire on a correct log; strong missing physics at low speed (tire
  saturation μ = 0.6 or a 0.1 s steering lag at 8 m/s) can hide a km/h log from it, since
  the model then fails under every reading;
* **steering consistency** (bicycle): the yaw rate against the kinematic yaw rate
  vx δ_f / L of the recorded steering; a correlated ratio below 0 is a flipped steering
  sign, outside 1/30..30 a unit factor;
* **parameters** (``--params``): a non-zero value must lie within :data:`PARAM_RATIO` of the
  model's nominal value (a 1e300 kg mass or a 1e-300 kg·m² inertia is refused).

Every failure raises :class:`~simgap.errors.RecordingError` (recordings) or
:class:`~simgap.errors.DiagnosisError` (parameters) with one line.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from simgap.errors import DiagnosisError, RecordingError

#: Largest |value| of a physical signal in SI units (rad, m/s, N·m, N ...).
MAX_ABS = 1e12
#: A non-zero column whose largest |value| is below this is a scale error.
MIN_ABS = 1e-30
#: Declared sample-period range (s), used only for models with no intrinsic rate.
DT_RANGE = (1e-5, 0.5)
#: Below this dt |λ|max a recording has over 10⁵ samples per fastest time constant: a
#: time column in the wrong unit, not a real sample rate.
MIN_DT_RATE = 1e-5
#: A time unit (ms, µs) is suggested only if the recording read in it still spans this many
#: time constants of the model's fastest mode.
MIN_SPAN = 20.0
#: Rows along the recording at which the nominal model is linearised (median rate).
RATE_POINTS = 9
#: Nyquist: a mode of rate |λ| (1/s) needs dt |λ| < π to be resolved at all.
MAX_DT_RATE = math.pi
#: A unit hypothesis must leave this many times less of the derivative unexplained ...
HYPOTHESIS_GAIN = 2.0
#: ... and itself leave at most this share (RMS) unexplained (a reading under which the
#: model still fails is no evidence for it). On generated bicycle logs at 8–30 m/s the
#: right units leave 0.05 (no missing physics) to 2.4 (μ = 0.6 saturation at 8 m/s)
#: unexplained, the same logs in km/h 2.6–9.
HYPOTHESIS_FIT = 2.0
#: Candidate speed units of a column the model reads in m/s: (factor to m/s, name).
SPEED_UNITS = ((1 / 3.6, "km/h"), (0.44704, "mph"))
#: Accepted ratio of a non-zero parameter override to the nominal value.
PARAM_RATIO = 1e3
#: |ratio| beyond which a kinematic or effort ratio is a unit error (not noise or friction).
RATIO_FLAG = 30.0
#: Correlation needed before a ratio is trusted.
MIN_CORRELATION = 0.8
#: Bicycle ranges: road-wheel angle (rad), speed (m/s), yaw rate (rad/s).
MAX_STEER = math.pi / 2
MAX_VX = 70.0
MAX_YAW_RATE = 2 * math.pi

_FACTORS = ((180 / math.pi, "degrees instead of radians"), (1e3, "a ×1000 unit factor"),
            (1e6, "a ×10⁶ unit factor"), (math.pi / 180, "degrees where radians are expected "
                                          "(or the reverse)"), (1e-3, "a ÷1000 unit factor"))


def _likely(ratio: float) -> str:
    if ratio < 0:
        return "a flipped sign" + ("" if abs(abs(ratio) - 1) < 0.3 else
                                   f" and {_likely(-ratio)}")
    for f, what in _FACTORS:
        if abs(math.log(ratio / f)) < math.log(1.3):
            return what
    return f"a unit or scale error (×{ratio:.3g})"


def _row(name: str, i: int) -> str:
    return f"row {i + 1} (line {i + 2})" if name.lower().endswith(".csv") else f"row {i + 1}"


def check_magnitudes(name: str, columns: Mapping[str, np.ndarray], time: str = "t") -> None:
    """Refuse |values| beyond :data:`MAX_ABS` and non-zero columns entirely below MIN_ABS."""
    for col, v in columns.items():
        if col == time or v.size == 0:
            continue
        a = np.abs(v)
        big = a > MAX_ABS
        if big.any():
            i = int(np.argmax(big))
            raise RecordingError(f"{name}: column {col!r} {_row(name, i)}: value {v[i]:.6g} is "
                                 f"beyond any physical value in SI units (|x| > {MAX_ABS:g}); "
                                 "a corrupt cell or a scale error")
        top = float(a.max())
        if 0 < top < MIN_ABS:
            raise RecordingError(f"{name}: column {col!r}: largest value {top:.3g} is "
                                 f"implausibly small for SI units (< {MIN_ABS:g}); a scale "
                                 "error")


def check_motion(name: str, columns: Mapping[str, np.ndarray], states: Sequence[str]) -> None:
    """Refuse a recording whose state columns are all constant (nothing to diagnose)."""
    if states and all(np.ptp(columns[c]) == 0 for c in states):
        raise RecordingError(f"{name}: columns {', '.join(states)} are constant: the recording "
                             "shows no motion, so there is nothing to diagnose")


def model_rate(system: Any, columns: Mapping[str, np.ndarray]) -> float | None:
    """Fastest rate |λ|max (1/s) of the nominal model linearised along the recording.

    Mechanical adapters: x = (q, dq), dx/dt = (dq, M(q)⁻¹(−bias(q, dq))) at zero input,
    differentiated by central differences. Bicycle adapters: the eigenvalues of A(vx) (thesis
    eq. 2.7) at the recorded speed. The rate is the median over :data:`RATE_POINTS` rows
    spread over the recording (one odd pose, e.g. where gravity's gradient vanishes, does
    not decide). Returns None when the model has no intrinsic rate (pure inertia) or cannot
    be evaluated.
    """
    cols = getattr(system, "columns", None)
    if cols is None:
        return None
    n = len(next(iter(columns.values())))
    rows = np.unique(np.linspace(0, n - 1, RATE_POINTS).astype(int))
    rates = []
    for k in rows:
        point = {c: float(v[k]) for c, v in columns.items()}
        try:
            if getattr(cols, "vx", None) and hasattr(getattr(system, "params", None), "C_af"):
                from simgap.models.bicycle import system_matrices

                a = system_matrices(system.params, max(point[cols.vx], 1.0 + 1e-6))[0]
            elif hasattr(system, "mass") and hasattr(system, "inverse_dynamics"):
                a = _mechanical_jacobian(system, point)
            else:
                return None
            rates.append(float(np.max(np.abs(np.linalg.eigvals(a)))))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, TypeError, KeyError,
                IndexError):
            continue
    rates = [r for r in rates if math.isfinite(r)]  # rows in a gap (NaN) give no evidence
    rate = float(np.median(rates)) if rates else math.nan
    return rate if math.isfinite(rate) and rate > 1e-9 else None


def _mechanical_jacobian(system: Any, point: Mapping[str, float]) -> np.ndarray:
    cols = system.columns
    q0 = np.array([point[c] for c in cols.q])
    dq0 = np.array([point[c] for c in cols.dq]) if cols.dq else np.zeros_like(q0)
    n = q0.size

    def f(x: np.ndarray) -> np.ndarray:
        q, dq = x[None, :n], x[None, n:]
        bias = system.inverse_dynamics(q, dq, np.zeros_like(q))[0]
        return np.concatenate([x[n:], np.linalg.solve(system.mass(q)[0], -bias)])

    x0 = np.concatenate([q0, dq0])
    jac = np.empty((2 * n, 2 * n))
    for i in range(2 * n):
        h = 1e-6 * max(1.0, abs(x0[i]))
        e = np.zeros(2 * n)
        e[i] = h
        jac[:, i] = (f(x0 + e) - f(x0 - e)) / (2 * h)
    return jac


def check_sample_period(name: str, t: np.ndarray, time: str = "t",
                        rate: float | None = None) -> None:
    """The median sample period against the model's fastest rate ``rate`` (1/s).

    With a rate the plausible periods are MIN_DT_RATE/rate .. π/rate (resolved at all, not
    absurdly oversampled); without one, :data:`DT_RANGE`. A period that lands inside once
    divided by 10³, 10⁶ or 10⁹ is named as ms, µs or ns, provided the recording read in
    that unit still spans :data:`MIN_SPAN` time constants 1/rate; otherwise (e.g. a period
    only slightly too long) no unit is guessed.
    """
    dt = float(np.median(np.diff(t)))
    if rate:
        lo, hi = MIN_DT_RATE / rate, MAX_DT_RATE / rate
        why = (f"the nominal model's fastest mode (|λ| = {rate:.3g} 1/s, time constant "
               f"{1 / rate:.3g} s) needs {lo:.3g}–{hi:.3g} s")
    else:
        lo, hi = DT_RANGE
        why = f"outside the declared {lo:g}–{hi:g} s of this model (it has no intrinsic rate)"
    if lo <= dt <= hi:
        return
    hint = ""
    span = float(t[-1] - t[0])
    for f, unit in ((1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds")):
        # read in that unit the period must fit, and the recording still span MIN_SPAN
        # time constants (a slightly too long period is not ms: ÷1000 would leave a
        # recording far too short to show the model's dynamics)
        if lo <= dt / f <= hi and (not rate or span / f * rate >= MIN_SPAN):
            hint = f"; is {time!r} in {unit}? (convert it to seconds)"
            break
    raise RecordingError(f"{name}: column {time!r}: median sample period {dt:.3g} s is "
                         f"implausible: {why}{hint}")


def unexplained(measured: np.ndarray, predicted: np.ndarray) -> float:
    """Share (RMS) of a measured derivative the model leaves unexplained, mean over states."""
    num = np.mean((measured - predicted) ** 2, axis=0)
    den = np.maximum(np.mean(measured**2, axis=0), np.finfo(float).tiny)
    return float(np.mean(np.sqrt(num / den)))


def check_unit_hypotheses(name: str, columns: Sequence[str], unit: str,
                          hypotheses: Sequence[tuple[float, str]],
                          misfit: Callable[[float, tuple[str, ...]], float]) -> None:
    """Name the unit of some columns when the nominal model explains the data far better in it.

    Every non-empty subset of ``columns`` is read in every candidate unit (a log may hold
    one speed in km/h, or all of them), and the best reading is compared with the recording
    as it is.

    Args:
        name: recording name.
        columns: the columns the model reads in ``unit`` (e.g. every speed column).
        unit: the SI unit the model reads them in (e.g. ``"m/s"``).
        hypotheses: (factor to the SI unit, unit name) of each candidate unit.
        misfit: ``misfit(f, cols)`` is the share of the recorded derivative the nominal model
            leaves unexplained when the columns ``cols`` are multiplied by ``f``
            (:func:`unexplained`); ``misfit(1.0, ())`` is the recording as it is.

    Raises:
        RecordingError: a reading leaves :data:`HYPOTHESIS_GAIN` × less unexplained than
            the recording as it is, and at most :data:`HYPOTHESIS_FIT`.
    """
    base = misfit(1.0, ())
    if not math.isfinite(base):
        return
    subsets = [sub for k in range(1, len(columns) + 1)
               for sub in itertools.combinations(tuple(columns), k)]
    scored = [(misfit(f, sub), f, what, sub) for sub in subsets for f, what in hypotheses]
    best, f, what, sub = min(scored, key=lambda s: s[0] if math.isfinite(s[0]) else math.inf)
    if math.isfinite(best) and best <= HYPOTHESIS_FIT and best * HYPOTHESIS_GAIN <= base:
        which = ("column " if len(sub) == 1 else "columns ") + ", ".join(map(repr, sub))
        it = "it" if len(sub) == 1 else "them"
        raise RecordingError(f"{name}: {which}: the nominal model leaves {base:.0%} of the "
                             f"recorded motion unexplained reading {it} in {unit}, {best:.0%} "
                             f"reading {it} in {what}; likely {what} — convert to {unit} "
                             f"(× {f:.4g}, i.e. ÷ {1 / f:.4g})")


def _ratio(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares ratio y ≈ k x and the correlation of x and y."""
    xx = float(np.dot(x, x))
    yy = float(np.dot(y, y))
    if xx <= 0 or yy <= 0:
        return 1.0, 0.0
    xy = float(np.dot(x, y))
    return xy / xx, xy / math.sqrt(xx * yy)


def check_kinematics(name: str, columns: Mapping[str, np.ndarray], t: np.ndarray,
                     pairs: Sequence[tuple[str, str]]) -> None:
    """Each velocity column must be the derivative of its position column (same units)."""
    for qc, dqc in pairs:
        dq_num = np.gradient(columns[qc], t)
        k, rho = _ratio(dq_num, columns[dqc])
        if rho > MIN_CORRELATION and 1 / 1.5 <= k <= 1.5:
            continue
        if abs(rho) >= MIN_CORRELATION and (k < 0 or not 1 / RATIO_FLAG <= k <= RATIO_FLAG
                                            or abs(math.log(k / (180 / math.pi))) < 0.3
                                            or abs(math.log(k * 180 / math.pi)) < 0.3):
            raise RecordingError(f"{name}: column {dqc!r} is {k:.4g} × the time derivative of "
                                 f"{qc!r} (correlation {rho:.2f}); expected 1: likely "
                                 f"{_likely(k)} in {qc!r}, {dqc!r} or the time column")


def check_effort(name: str, recorded: np.ndarray, needed: np.ndarray,
                 columns: Sequence[str]) -> None:
    """Recorded torques/forces (N·m or N) against what the nominal model needs, per column.

    Args:
        name: recording name.
        recorded: (N, C) recorded (scaled) inputs.
        needed: (N, C) M(q) ddq + bias(q, dq) of the nominal model for the recorded motion.
        columns: input column names.
    """
    for j, col in enumerate(columns):
        need_rms = float(np.sqrt(np.mean(needed[:, j] ** 2)))
        rec_rms = float(np.sqrt(np.mean(recorded[:, j] ** 2)))
        if rec_rms == 0.0:
            # no input at all (a free decay, u ≡ 0): what the nominal "needs" is then the
            # mismatch itself, with no recorded scale to compare it with
            continue
        if need_rms > RATIO_FLAG * rec_rms:
            # no missing physics makes a motion cheaper by this much: the motion's units
            # (degrees) or the input's scale are wrong
            raise RecordingError(f"{name}: column {col!r}: the recorded motion needs "
                                 f"{need_rms:.3g} (RMS, SI) by the nominal model but the "
                                 f"column holds {rec_rms:.3g}; likely angles in degrees or a "
                                 "unit factor in the positions, velocities or this column")
        k, rho = _ratio(needed[:, j], recorded[:, j])
        if abs(rho) < MIN_CORRELATION:
            continue  # effects the model lacks dominate: the residual will show them
        if k < -0.3 or not 1 / RATIO_FLAG <= abs(k) <= RATIO_FLAG:
            raise RecordingError(f"{name}: column {col!r} is {k:.3g} × the torque/force the "
                                 f"nominal model needs for the recorded motion (correlation "
                                 f"{rho:.2f}); likely {_likely(k)}")


def check_bicycle(name: str, columns: Mapping[str, np.ndarray], steer: Sequence[str],
                  vx: str | None, yaw_rate: str | None,
                  steer_scale: Sequence[float] | None = None) -> None:
    """Road-wheel angle in rad, speed in m/s, yaw rate in rad/s (ranges of a road vehicle)."""
    scale = steer_scale or (1.0,) * len(steer)
    for c, s in zip(steer, scale, strict=True):
        top = float(np.max(np.abs(columns[c] * s)))
        if top > MAX_STEER:
            raise RecordingError(f"{name}: column {c!r}: road-wheel angle up to {top:.3g} rad "
                                 f"(> π/2); likely degrees — convert to radians")
    if vx and float(np.max(np.abs(columns[vx]))) > MAX_VX:
        top = float(np.max(np.abs(columns[vx])))
        raise RecordingError(f"{name}: column {vx!r}: speed up to {top:.3g} m/s "
                             f"(> {MAX_VX:g} m/s = {MAX_VX * 3.6:g} km/h); likely km/h — "
                             "divide by 3.6")
    if yaw_rate and float(np.max(np.abs(columns[yaw_rate]))) > MAX_YAW_RATE:
        top = float(np.max(np.abs(columns[yaw_rate])))
        raise RecordingError(f"{name}: column {yaw_rate!r}: yaw rate up to {top:.3g} rad/s "
                             "(> one turn per second); likely deg/s — convert to rad/s")


def check_steering(name: str, columns: Mapping[str, np.ndarray], steer: str, yaw_rate: str,
                   vx: str, wheelbase: float, scale: float = 1.0) -> None:
    """The yaw rate must follow the front steering like a bicycle's (sign and size).

    The kinematic (Ackermann) yaw rate of a bicycle is r = vx δ_f / L; understeer makes the
    real one smaller, never of the opposite sign or 30× larger. A strongly correlated
    least-squares ratio r / (vx δ_f / L) below 0 names a flipped steering sign, above 30 a
    steering column too small by a unit factor, below 1/30 one too large (degrees).
    """
    kin = columns[vx] * columns[steer] * scale / wheelbase
    k, rho = _ratio(kin, columns[yaw_rate])
    if abs(rho) < MIN_CORRELATION:
        return
    if k < 0:
        why = f"likely a flipped sign in {steer!r}"
    elif k > RATIO_FLAG:
        why = f"{steer!r} looks about {k:.3g}× too small: likely a unit factor (e.g. mrad)"
    elif k < 1 / RATIO_FLAG:
        why = f"{steer!r} looks about {1 / k:.3g}× too large: likely degrees"
    else:
        return
    raise RecordingError(f"{name}: column {yaw_rate!r} is {k:.3g} × the kinematic yaw rate "
                         f"vx·{steer}/L of the recorded steering (correlation {rho:.2f}); "
                         f"expected 0..1 (understeer); {why}")


def check_params(cls: type, overrides: Mapping[str, Any], model: str) -> None:
    """Refuse non-zero overrides further than :data:`PARAM_RATIO` from the nominal value."""
    defaults = {f.name: f.default for f in dataclasses.fields(cls)
                if f.default is not dataclasses.MISSING}
    for k, v in overrides.items():
        ref = defaults.get(k)
        vals = np.ravel(np.asarray(v, dtype=object))
        refs = np.ravel(np.asarray(ref if ref is not None else np.nan, dtype=object))
        for i, x in enumerate(vals):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                continue  # the model's own checks name the type
            r = refs[i] if i < refs.size else np.nan
            x = float(x)
            if not math.isfinite(x):
                raise DiagnosisError(f"--params {k} = {x!r}: not a finite number")
            if x == 0 or r is None or not isinstance(r, (int, float)) or not math.isfinite(r):
                continue
            if r == 0:
                if abs(x) > PARAM_RATIO**2:
                    raise DiagnosisError(f"--params {k} = {x:.3g} for model {model}: beyond "
                                         f"the physical range (|value| <= {PARAM_RATIO**2:g})")
                continue
            ratio = x / r
            if ratio < 0 or not 1 / PARAM_RATIO <= ratio <= PARAM_RATIO:
                raise DiagnosisError(f"--params {k} = {x:.3g} for model {model}: {ratio:.3g} "
                                     f"× the nominal {r:g}; outside the physical range "
                                     f"(1/{PARAM_RATIO:g} to {PARAM_RATIO:g} × nominal, same "
                                     "sign)")


def check_recording(rec: Any, system: Any) -> None:
    """All checks that need only the recording and the adapter's column map (before work).

    Args:
        rec: the validated :class:`~simgap.recordings.Recording`.
        system: a diagnosis adapter with a ``columns`` map (``t``, ``q``, ``dq``, ``u``,
            ``u_scale``, ``vx``); adapters without one are only magnitude-checked.
    """
    cols = getattr(system, "columns", None)
    time = getattr(cols, "t", "t")
    data = {k: np.asarray(v, dtype=np.float64) for k, v in rec.columns.items()}
    check_magnitudes(rec.name, data, time)
    if cols is None:
        return
    check_sample_period(rec.name, data[time], time, model_rate(system, data))
    states = tuple(cols.q) + tuple(cols.dq or ())
    check_motion(rec.name, data, states)
    if getattr(cols, "vx", None):  # the bicycle family: states (vy, r), steering inputs
        check_bicycle(rec.name, data, cols.u, cols.vx, cols.q[1] if len(cols.q) > 1 else None,
                      cols.u_scale)
        p = getattr(system, "params", None)
        if p is not None and hasattr(p, "lf") and len(cols.q) > 1:
            check_steering(rec.name, data, cols.u[0], cols.q[1], cols.vx, p.lf + p.lr,
                           (cols.u_scale or (1.0,))[0])
    elif cols.dq:
        check_kinematics(rec.name, data, data[time], list(zip(cols.q, cols.dq, strict=True)))


def check_prepared(rec: Any, system: Any, prepared: Any) -> None:
    """Checks on the prepared recording: recorded effort vs the nominal model's need.

    Args:
        rec: the recording (its name).
        system: the residual form.
        prepared: what ``system.prepare(rec)`` returned (its filtered ``signals``).
    """
    sig = getattr(prepared, "signals", None)
    if sig is not None and {"vy", "r", "dvy", "dr", "vx", "delta_f"} <= set(sig) \
            and hasattr(getattr(system, "params", None), "C_af"):
        from simgap.models.bicycle import STATE_NAMES, STATE_UNITS

        cols = system.columns  # the model's m/s signals: vx, and the states declared in m/s
        names = getattr(system, "state_names", STATE_NAMES)
        units = getattr(system, "state_units", STATE_UNITS)
        speeds = {"vx": cols.vx} | {k: c for k, c, unit in zip(names, cols.q, units,
                                                               strict=True) if unit == "m/s"}
        check_speed_unit(rec.name, sig, system.params, speeds)
        return
    inverse = getattr(system, "inverse_dynamics", None)
    if sig is None or inverse is None or "ddq" not in sig:
        return
    check_effort(rec.name, sig["u"], inverse(sig["q"], sig["dq"], sig["ddq"]),
                 system.columns.u)


def check_speed_unit(name: str, sig: Mapping[str, np.ndarray], params: Any,
                     speeds: Mapping[str, str]) -> None:
    """Bicycle: are the speed columns in m/s? (vx in −vx r and the slip angles, eq. 2.7).

    Args:
        name: recording name.
        sig: the adapter's filtered signals (``vx``, ``vy``, ``r``, ``dvy``, ``dr``,
            ``delta_f``, ``delta_r``).
        params: the nominal :class:`~simgap.models.bicycle.BicycleParams`.
        speeds: every signal the model reads in m/s → its recording column (``vx`` and
            the m/s states, e.g. ``{"vx": "vx", "vy": "vy"}``); each subset is tested.
    """
    from simgap.models.bicycle import MIN_VX, state_derivative

    column_of = {c: k for k, c in speeds.items()}
    u = np.stack([sig["delta_f"], sig.get("delta_r", np.zeros_like(sig["delta_f"]))], axis=1)

    def misfit(f: float, cols: tuple[str, ...]) -> float:
        g = {column_of[c]: f for c in cols}
        vx = sig["vx"] * g.get("vx", 1.0)
        if np.any(vx <= MIN_VX):
            return math.nan  # the model is not defined at this speed: no evidence
        x = np.stack([sig["vy"] * g.get("vy", 1.0), sig["r"] * g.get("r", 1.0)], axis=1)
        dx = np.stack([sig["dvy"] * g.get("vy", 1.0), sig["dr"] * g.get("r", 1.0)], axis=1)
        return unexplained(dx, state_derivative(x, u, params, vx))

    check_unit_hypotheses(name, tuple(speeds.values()), "m/s", SPEED_UNITS, misfit)
