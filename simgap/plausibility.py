"""Plausibility of a recording and of parameter overrides against the model's SI units.

A recording can be perfectly well-formed and still be in the wrong units: time in ms or µs,
angles in degrees, a torque logged in mN·m or with its sign flipped, a corrupt 1e300 cell.
The diagnosis would then "explain" a unit error with invented physics, or fail deep inside
a fit. These checks name the column, the evidence and the likely unit instead, each for a
reason that can be stated:

* **magnitude**: SI signals of the modelled systems never exceed :data:`MAX_ABS` in size,
  and a column whose largest value is below :data:`MIN_ABS` (but not zero) is a scale error;
* **motion**: if every state column is constant there is nothing to diagnose;
* **sample period**: the systems' dynamics live between :data:`DT_RANGE` (s); a period
  outside it that lands inside once divided by 10³ or 10⁶ is time in ms or µs;
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
  km/h (slower km/h logs are not caught by this range), a yaw rate above 2π rad/s is deg/s;
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
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from simgap.errors import DiagnosisError, RecordingError

#: Largest |value| of a physical signal in SI units (rad, m/s, N·m, N ...).
MAX_ABS = 1e12
#: A non-zero column whose largest |value| is below this is a scale error.
MIN_ABS = 1e-30
#: Plausible sample periods (s) of the modelled mechanical and vehicle systems.
DT_RANGE = (1e-5, 0.5)
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


def check_sample_period(name: str, t: np.ndarray, time: str = "t") -> None:
    """Refuse a median sample period outside :data:`DT_RANGE`, naming ms/µs when it fits."""
    dt = float(np.median(np.diff(t)))
    lo, hi = DT_RANGE
    if lo <= dt <= hi:
        return
    hint = ""
    for f, unit in ((1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds")):
        if lo <= dt / f <= hi:
            hint = f"; is {time!r} in {unit}? (convert it to seconds)"
            break
    raise RecordingError(f"{name}: column {time!r}: median sample period {dt:.3g} s is outside "
                         f"the plausible {lo:g}–{hi:g} s for this model's dynamics{hint}")


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
    check_sample_period(rec.name, data[time], time)
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


def check_prepared(rec: Any, system: Any) -> None:
    """Checks on the prepared adapter: recorded effort vs the nominal model's need."""
    sig = getattr(system, "sig", None)
    inverse = getattr(system, "inverse_dynamics", None)
    if sig is None or inverse is None or "ddq" not in sig:
        return
    check_effort(rec.name, sig["u"], inverse(sig["q"], sig["dq"], sig["ddq"]),
                 system.columns.u)
