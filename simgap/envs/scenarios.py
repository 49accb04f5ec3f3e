"""Reusable scenarios: joint references, a tracking controller and steering programs.

Manipulator (thesis Sec. 4.3.1):

* :class:`QuinticReference`: the thesis' periodic quintic between q_d = (π/4, π/2) and
  (3π/4, −π/2). The thesis does not give the cycle duration T; we use ``period=2.0`` s per
  one-way move (so a full back-and-forth cycle lasts 4 s).
* :class:`RandomWaypointReference`: rest-to-rest quintics between random waypoints, for richer
  excitation (reproducible from an integer seed).
* :class:`FeedbackLinearizationController`: thesis eq. 4.8-4.9 on the *nominal* model.

Bicycle (thesis Sec. 4.4.1, Fig. 4.4): the thesis prints no numbers for its manoeuvres, so
:func:`step_steer`, :func:`slalom` and :func:`chirp` use values chosen to reach the Magic
Formula tire's nonlinear range at vx = 20 m/s, mu = 1 (peak lateral acceleration 5-8 m/s²;
checked in ``tests/envs/test_scenarios.py``). Each returns a :class:`SteeringProgram`, a
callable t (s) -> (delta_f, delta_r) (rad) that is 0 outside ``[0, duration]``.
:class:`YawRateReference` is the bicycle env's default yaw-rate reference.

References expose ``sample(t)`` returning ``(q_d, dq_d, ddq_d)`` flattened into one (6,) array
(rad, rad/s, rad/s²); that is the allocation-light form the env calls every step.
``__call__(t)`` returns the three (2,) arrays.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from simgap.models.manipulator import ManipulatorNominal
from simgap.models.nbcache import guard_cache

__all__ = [
    "FeedbackLinearizationController",
    "QuinticReference",
    "RandomWaypointReference",
    "SteeringProgram",
    "YawRateReference",
    "chirp",
    "open_loop",
    "slalom",
    "step_steer",
]


@njit(cache=True, inline="always")
def quintic_profile(tau, two):  # pragma: no cover - compiled
    """Rest-to-rest quintic s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on τ ∈ [0, 1] and its derivatives.

    ``two`` is 2.0 passed at run time: ``x ** two`` then stays libm's ``pow`` (what Python's
    ``x ** 2`` calls), where a literal 2 would compile to ``x * x``, which differs from
    ``pow`` in the last bit for about 0.1 % of inputs.
    """
    t2 = tau * tau
    t3 = t2 * tau
    s = t3 * (10.0 - 15.0 * tau + 6.0 * t2)
    ds = 30.0 * t2 * (1.0 - tau) ** two
    dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)
    return s, ds, dds


@njit(cache=True, inline="always")
def segment_entries(a0, a1, b0, b1, tau, duration, two):  # pragma: no cover - compiled
    """Quintic from (a0, a1) to (b0, b1) (rad) at normalised time τ over ``duration`` (s).

    Returns (q_d1, q_d2, dq_d1, dq_d2, ddq_d1, ddq_d2) in rad, rad/s, rad/s².
    """
    s, ds, dds = quintic_profile(tau, two)
    d0, d1 = b0 - a0, b1 - a1
    v = ds / duration
    acc = dds / (duration * duration)
    return a0 + d0 * s, a1 + d1 * s, d0 * v, d1 * v, d0 * acc, d1 * acc


@njit(cache=True, inline="always")
def quintic_sample_entries(t, s0, s1, e0, e1, period, two):  # pragma: no cover - compiled
    """:meth:`QuinticReference.sample` on scalars (the native vector env calls it per row)."""
    if t <= 0.0:
        return segment_entries(s0, s1, e0, e1, 0.0, period, two)
    k, rem = divmod(t, period)
    tau = rem / period
    if int(k) % 2 == 0:
        return segment_entries(s0, s1, e0, e1, tau, period, two)
    return segment_entries(e0, e1, s0, s1, tau, period, two)


@njit(cache=True)
def _segment_kernel(a0, a1, b0, b1, tau, duration, two):  # pragma: no cover - compiled
    return segment_entries(a0, a1, b0, b1, tau, duration, two)


@njit(cache=True)
def _quintic_kernel(t, s0, s1, e0, e1, period, two):  # pragma: no cover - compiled
    return quintic_sample_entries(t, s0, s1, e0, e1, period, two)


def _segment(a: np.ndarray, b: np.ndarray, tau: float, duration: float) -> np.ndarray:
    """Quintic from a to b (rad) at normalised time τ over ``duration`` (s), packed (6,)."""
    return np.array(_segment_kernel(float(a[0]), float(a[1]), float(b[0]), float(b[1]),
                                    float(tau), float(duration), 2.0))


def _pair(name: str, value: float | tuple[float, float]) -> np.ndarray:
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (2,)).copy()
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return arr


class _JointReference:
    """Common interface: ``sample(t) -> (6,)`` and ``__call__(t) -> (q_d, dq_d, ddq_d)``."""

    def sample(self, t: float) -> np.ndarray:  # pragma: no cover - abstract
        """Packed (q_d, dq_d, ddq_d) at time t (s): rad, rad/s, rad/s²."""
        raise NotImplementedError

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, dq_d, ddq_d) at time t (s), each shape (2,): rad, rad/s, rad/s²."""
        r = self.sample(t)
        return r[0:2], r[2:4], r[4:6]


class QuinticReference(_JointReference):
    """Thesis Sec. 4.3.1 reference: quintic from ``q_start`` to ``q_end`` and back, repeating.

    Each one-way move is a rest-to-rest quintic (zero velocity and acceleration at both ends)
    lasting ``period`` seconds; odd moves run backwards, so q_d has period 2·``period``. The
    thesis calls the one-way duration T and does not give its value: 2 s is our choice.

    Args:
        q_start: q_d(0) (rad), thesis (π/4, π/2).
        q_end: q_d(T) (rad), thesis (3π/4, −π/2).
        period: duration T of one move (s), > 0.
    """

    def __init__(self, q_start: tuple[float, float] = (math.pi / 4, math.pi / 2),
                 q_end: tuple[float, float] = (3 * math.pi / 4, -math.pi / 2),
                 period: float = 2.0) -> None:
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"QuinticReference period must be a positive time in s, "
                             f"got {period!r}")
        self.q_start = _pair("q_start", q_start)
        self.q_end = _pair("q_end", q_end)
        self.period = float(period)

    def __repr__(self) -> str:
        return (f"QuinticReference(q_start={tuple(self.q_start)}, q_end={tuple(self.q_end)}, "
                f"period={self.period})")

    def sample(self, t: float) -> np.ndarray:
        """Packed (q_d, dq_d, ddq_d) at time t (s); t < 0 holds the start point."""
        return np.array(_quintic_kernel(float(t), *self.params, 2.0))

    @property
    def params(self) -> tuple[float, float, float, float, float]:
        """(q_start1, q_start2, q_end1, q_end2, period) for :func:`quintic_sample_entries`."""
        return (float(self.q_start[0]), float(self.q_start[1]), float(self.q_end[0]),
                float(self.q_end[1]), self.period)


class RandomWaypointReference(_JointReference):
    """Rest-to-rest quintic segments between uniformly random waypoints (rich excitation).

    Waypoints are drawn uniformly in the box [low, high] (rad) and segment durations uniformly
    in ``period_range`` (s), from ``numpy.random.default_rng(seed)``, lazily as t grows. The
    sequence depends only on the seed, not on the order of queries. Every waypoint is a
    velocity reversal, which exercises the friction's zero-velocity crossings.

    Args:
        seed: integer seed of the waypoint sequence.
        low: lower corner of the waypoint box (rad); default (π/6, −3π/4).
        high: upper corner (rad); default (5π/6, 3π/4), containing the thesis' range.
        period_range: (min, max) segment duration (s), 0 < min ≤ max.
    """

    _CHUNK = 64

    def __init__(self, seed: int, low: tuple[float, float] = (math.pi / 6, -3 * math.pi / 4),
                 high: tuple[float, float] = (5 * math.pi / 6, 3 * math.pi / 4),
                 period_range: tuple[float, float] = (1.0, 3.0)) -> None:
        self.low = _pair("low", low)
        self.high = _pair("high", high)
        if np.any(self.high < self.low):
            raise ValueError(f"RandomWaypointReference needs low <= high, got low={low!r}, "
                             f"high={high!r}")
        pmin, pmax = (float(v) for v in period_range)
        if not (np.isfinite(pmin) and np.isfinite(pmax) and 0 < pmin <= pmax):
            raise ValueError(f"period_range must satisfy 0 < min <= max (s), got "
                             f"{period_range!r}")
        self.seed = int(seed)
        self.period_range = (pmin, pmax)
        self._rng = np.random.default_rng(self.seed)
        self._points: list[np.ndarray] = [self._rng.uniform(self.low, self.high)]
        self._times: list[float] = [0.0]  # start time of each waypoint
        self._durations: list[float] = []

    def __repr__(self) -> str:
        return (f"RandomWaypointReference(seed={self.seed}, low={tuple(self.low)}, "
                f"high={tuple(self.high)}, period_range={self.period_range})")

    def _extend(self, t: float) -> None:
        while self._times[-1] <= t:
            for _ in range(self._CHUNK):
                dur = float(self._rng.uniform(*self.period_range))
                self._points.append(self._rng.uniform(self.low, self.high))
                self._durations.append(dur)
                self._times.append(self._times[-1] + dur)

    @property
    def waypoints(self) -> np.ndarray:
        """Waypoints generated so far (rad), shape (n, 2)."""
        return np.array(self._points)

    def sample(self, t: float) -> np.ndarray:
        """Packed (q_d, dq_d, ddq_d) at time t (s); t < 0 holds the first waypoint."""
        t = float(t)
        if t <= 0.0:
            return _segment(self._points[0], self._points[0], 0.0, 1.0)
        self._extend(t)
        i = bisect.bisect_right(self._times, t) - 1
        dur = self._durations[i]
        return _segment(self._points[i], self._points[i + 1], (t - self._times[i]) / dur, dur)


def _gain_matrix(name: str, value: float | tuple[float, float]) -> np.ndarray:
    arr = _pair(name, value)
    if np.any(arr <= 0):
        raise ValueError(f"{name} gains must be positive, got {value!r}")
    return arr


class FeedbackLinearizationController:
    """Computed-torque tracking controller, thesis eq. 4.8-4.9, on the nominal model.

        u = M(q) v + C(q, dq) dq + G(q),   v = ddq_d + Kd (dq_d − dq) + Kp (q_d − q)

    The thesis gives no gains; the defaults Kp = 100 s⁻², Kd = 20 s⁻¹ per joint make each
    joint's error dynamics critically damped with ω_n = 10 rad/s. Friction is not compensated
    (it is the unknown residual), so the tracking error is the friction's footprint.

    Args:
        model: nominal model giving M, C, G.
        reference: joint reference with ``sample(t)`` (or a callable returning
            (q_d, dq_d, ddq_d)).
        Kp: position gains (s⁻²), scalar or per joint, > 0.
        Kd: velocity gains (s⁻¹), scalar or per joint, > 0.
    """

    def __init__(self, model: ManipulatorNominal, reference: Callable | None = None,
                 Kp: float | tuple[float, float] = 100.0,  # noqa: N803 - thesis names
                 Kd: float | tuple[float, float] = 20.0) -> None:  # noqa: N803
        self.model = model
        self.reference = reference if reference is not None else QuinticReference()
        self.Kp = _gain_matrix("Kp", Kp)
        self.Kd = _gain_matrix("Kd", Kd)

    def __call__(self, obs: np.ndarray, t: float) -> np.ndarray:
        """Joint torques u (N·m), shape (2,), for observation (q, dq) at time t (s)."""
        obs = np.asarray(obs, dtype=np.float64)
        q, dq = obs[:2], obs[2:4]
        ref = _sample_reference(self.reference, t)
        v = ref[4:6] + self.Kd * (ref[2:4] - dq) + self.Kp * (ref[0:2] - q)
        return self.model.M(q) @ v + self.model.bias(q, dq)


def _sample_reference(reference: Callable, t: float) -> np.ndarray:
    """Packed (6,) reference from an object with ``sample`` or a (q_d, dq_d, ddq_d) callable."""
    sample = getattr(reference, "sample", None)
    if sample is not None:
        return sample(t)
    return np.concatenate([np.asarray(a, dtype=np.float64).reshape(2)
                           for a in reference(t)])


# --------------------------------------------------------------------------- bicycle
@dataclass(frozen=True, kw_only=True)
class SteeringProgram:
    """Open-loop steering t (s) -> (delta_f, delta_r) (rad); zero outside [0, duration].

    Attributes:
        name: label for plots.
        duration: length of the manoeuvre (s).
        front: callable t -> delta_f (rad), vectorised over numpy arrays.
        rear: callable t -> delta_r (rad), vectorised over numpy arrays.
    """

    name: str
    duration: float
    front: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    rear: Callable[[np.ndarray], np.ndarray] = field(repr=False)

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        """Steering angles (rad): shape (2,) for scalar t, (N, 2) for an array of times."""
        ta = np.asarray(t, dtype=np.float64)
        inside = (ta >= 0.0) & (ta <= self.duration)
        out = np.stack([np.where(inside, self.front(ta), 0.0),
                        np.where(inside, self.rear(ta), 0.0)], axis=-1)
        return out

    def act(self, obs: np.ndarray, t: float) -> np.ndarray:
        """Policy form ``policy(obs, t)`` for :func:`simgap.envs.rollout.rollout`."""
        return self(t)


def open_loop(program: Callable[[float], np.ndarray]) -> Callable[[np.ndarray, float], np.ndarray]:
    """Turn a program t -> action into a policy (obs, t) -> action."""
    return lambda obs, t: np.asarray(program(t), dtype=np.float64)


def _smooth_step(t: np.ndarray, t0: float, rise: float) -> np.ndarray:
    """0 before t0, 1 after t0 + rise, a quintic (C²) ramp in between."""
    tau = np.clip((np.asarray(t, dtype=np.float64) - t0) / rise, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def step_steer(*, front: float = 0.06, rear: float = -0.01, t_on: float = 2.0,
               t_off: float = 8.0, rise_time: float = 0.2, duration: float = 14.0
               ) -> SteeringProgram:
    """Step-steer like thesis Fig. 4.4: a steering step held, then released.

    Both axles step together (front 0.06 rad ≈ 3.4°, rear −0.01 rad ≈ −0.6°, counter-phase),
    rising over ``rise_time`` with a C² quintic ramp (a real steering wheel has a finite rate).
    At vx = 20 m/s, mu = 1 this gives a steady lateral acceleration of about 7 m/s², where the
    Magic Formula front axle is well past its linear range. Defaults put the step on 2-8 s of a
    14 s run, so the errata's freeze times (4 s, 10 s) fall in the hold and after release.

    Args:
        front: front road-wheel angle during the step (rad).
        rear: rear road-wheel angle during the step (rad).
        t_on: start of the rise (s).
        t_off: start of the release (s), > t_on + rise_time.
        rise_time: ramp duration (s), > 0.
        duration: length of the program (s).
    """
    if not (rise_time > 0 and t_on >= 0 and t_off >= t_on + rise_time and duration >= t_off):
        raise ValueError(f"step_steer needs 0 <= t_on, t_on + rise_time <= t_off <= duration and "
                         f"rise_time > 0 (s); got t_on={t_on}, t_off={t_off}, "
                         f"rise_time={rise_time}, duration={duration}")

    def shape(t: np.ndarray) -> np.ndarray:
        return _smooth_step(t, t_on, rise_time) - _smooth_step(t, t_off, rise_time)

    return SteeringProgram(name="step-steer", duration=float(duration),
                           front=lambda t: front * shape(t), rear=lambda t: rear * shape(t))


def slalom(*, front: float = 0.07, rear: float = 0.015, frequency: float = 0.4,
           rear_phase: float = math.pi / 2, fade_in: float = 1.0, duration: float = 35.0
           ) -> SteeringProgram:
    """Slalom like thesis Fig. 4.4: sinusoidal steering on both axles (persistent excitation).

    delta_f = front·w(t)·sin(2π f t), delta_r = rear·w(t)·sin(2π f t − rear_phase) with a
    quintic fade-in w over ``fade_in`` seconds. Defaults: 0.07 rad (4°) front, 0.015 rad rear a
    quarter period behind (so the two axles' slip angles are not collinear and both residuals
    are identifiable), 0.4 Hz, 35 s (the errata's freeze times 15 s and 25 s are inside). Peak
    lateral acceleration at vx = 20 m/s, mu = 1 is about 7 m/s².

    Args:
        front: front amplitude (rad).
        rear: rear amplitude (rad).
        frequency: steering frequency (Hz), > 0.
        rear_phase: lag of the rear sine behind the front (rad).
        fade_in: amplitude ramp-in time (s), > 0.
        duration: length of the program (s).
    """
    if not (frequency > 0 and fade_in > 0 and duration > 0):
        raise ValueError(f"slalom needs positive frequency (Hz), fade_in and duration (s); got "
                         f"{frequency}, {fade_in}, {duration}")
    w = 2.0 * math.pi * frequency
    return SteeringProgram(
        name="slalom", duration=float(duration),
        front=lambda t: front * _smooth_step(t, 0.0, fade_in) * np.sin(w * t),
        rear=lambda t: rear * _smooth_step(t, 0.0, fade_in) * np.sin(w * t - rear_phase))


def chirp(*, front: float = 0.05, rear: float = 0.01, f0: float = 0.1, f1: float = 2.0,
          duration: float = 30.0) -> SteeringProgram:
    """Linear frequency sweep (``scipy.signal.chirp``) on both axles, rear in counter-phase.

    Defaults sweep 0.1 → 2 Hz over 30 s with 0.05 rad front and 0.01 rad rear amplitude: at low
    frequency this reaches about 6 m/s² lateral acceleration at vx = 20 m/s, and the sweep
    covers the yaw mode (≈1 Hz) for transient excitation.

    Args:
        front: front amplitude (rad).
        rear: rear amplitude (rad), applied with opposite sign.
        f0: start frequency (Hz), > 0.
        f1: end frequency (Hz), > 0.
        duration: sweep length (s), > 0.
    """
    if not (f0 > 0 and f1 > 0 and duration > 0):
        raise ValueError(f"chirp needs positive f0, f1 (Hz) and duration (s); got {f0}, {f1}, "
                         f"{duration}")

    def base(t: np.ndarray) -> np.ndarray:
        from scipy.signal import chirp as _scipy_chirp  # lazy: costs ~0.5 s to import

        return _scipy_chirp(t, f0=f0, t1=duration, f1=f1, method="linear", phi=-90.0)

    return SteeringProgram(name="chirp", duration=float(duration),
                           front=lambda t: front * base(t), rear=lambda t: -rear * base(t))


@dataclass(frozen=True, kw_only=True)
class YawRateReference:
    """Default yaw-rate reference of the bicycle env: r_ref(t) = amplitude·sin(2π t/period).

    Defaults 0.25 rad/s and 6 s: at vx = 20 m/s the matching lateral acceleration vx·r is
    5 m/s², inside a mu = 1 tire's reach.

    Attributes:
        amplitude: yaw-rate amplitude (rad/s).
        period: period (s), > 0.
    """

    amplitude: float = 0.25
    period: float = 6.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.amplitude) and np.isfinite(self.period) and self.period > 0):
            raise ValueError(f"YawRateReference needs a finite amplitude (rad/s) and a positive "
                             f"period (s), got {self.amplitude!r}, {self.period!r}")

    def __call__(self, t: float) -> float:
        """Return the reference yaw rate (rad/s) at time t (s)."""
        return yaw_rate_entries(float(t), self.amplitude, self.period)


@njit(cache=True, inline="always")
def yaw_rate_entries(t, amplitude, period):  # pragma: no cover - compiled
    """:class:`YawRateReference` at time t (s): amplitude·sin(2π t/period) (rad/s).

    Compiled (the native vector env calls it per row); numba's ``sin`` is libm's, as
    Python's ``math.sin``, so a call from Python equals the plain-Python formula bit for bit
    (``tests/envs/test_vector_native.py`` checks it).
    """
    return amplitude * math.sin(2.0 * math.pi * t / period)


guard_cache(globals())  # drop cached kernels when a module they compile in changes
