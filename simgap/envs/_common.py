"""Small helpers shared by the envs: argument checks and the per-step action check."""

from __future__ import annotations

import numbers

import gymnasium as gym
import numpy as np
from numba import njit

from simgap.errors import EnvError


@njit(cache=True)
def _finite_clip(a, lo, hi, out):  # pragma: no cover - compiled
    """Clip ``a`` into [lo, hi] into ``out``; return False (out untouched) if a is not finite."""
    for i in range(a.shape[0]):
        if not np.isfinite(a[i]):
            return False
    for i in range(a.shape[0]):
        out[i] = min(max(a[i], lo[i]), hi[i])
    return True


class StepBeforeResetError(EnvError, gym.error.ResetNeeded):
    """``step`` was called before ``reset`` (also a gymnasium ``ResetNeeded``)."""


def check_reset(done: bool, env: str) -> None:
    """Raise :class:`StepBeforeResetError` unless ``reset`` has been called."""
    if not done:
        raise StepBeforeResetError(f"{env}: call reset() before step()")


def check_action(action: object, shape: tuple[int, ...], what: str) -> np.ndarray:
    """The one action check of every simgap env: real floating dtype, exact shape, finite.

    Nothing is reshaped or cast silently: a (1, 2) array for a (2,) action, an integer,
    complex, boolean or string action, or a NaN/inf entry is an error, so the env state
    is left untouched.

    Args:
        action: the action passed to ``step``.
        shape: the action space's shape.
        what: description used in error messages, e.g. ``"joint torques (N·m)"``.

    Returns:
        A float64 copy of the action.

    Raises:
        EnvError: one line naming the shape/dtype/value that is wrong.
    """
    a = _float_array(action, shape, what)
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        _not_finite(a, what)
    return a


def one_line(value: object, width: int = 60) -> str:
    """``repr(value)`` on one line, cut to ``width`` characters ("..." when longer).

    Runs of whitespace, newlines included, become one space.
    """
    text = " ".join(repr(value).split())
    return text if len(text) <= width else text[:width - 3] + "..."


def _float_array(action: object, shape: tuple[int, ...], what: str) -> np.ndarray:
    """The action as an array of real floating dtype and exact ``shape`` (not copied)."""
    try:
        a = np.asarray(action)
    except Exception as err:  # ragged lists and the like
        raise EnvError(f"action {one_line(action)}: not an array of {what} "
                       f"({' '.join(str(err).split())})") from None
    if a.dtype.kind != "f":
        raise EnvError(f"action {one_line(action)} has dtype {a.dtype}; expected real floating-"
                       f"point {what} of shape {shape} (e.g. numpy float32/float64)")
    if a.shape != shape:
        raise EnvError(f"action must have shape {shape} ({what}), got shape {a.shape}")
    return a


def _not_finite(a: np.ndarray, what: str) -> None:
    raise EnvError(f"action contains NaN or inf: {one_line(a.astype(np.float64), 120)} ({what}); "
                   f"the step was not taken")


def prepare_action(action: object, low: np.ndarray, high: np.ndarray, what: str) -> np.ndarray:
    """Validate an action as :func:`check_action` does and clip it into the box [low, high].

    Args:
        action: array of shape ``low.shape``, real floating dtype.
        low: lower bounds (float64).
        high: upper bounds (float64).
        what: description used in error messages, e.g. ``"joint torques (N·m)"``.

    Returns:
        A new float64 array, clipped.

    Raises:
        EnvError: wrong shape or dtype, or a NaN/inf entry (the env state is left untouched).
    """
    a = _float_array(action, low.shape, what)
    if a.dtype != np.float64 and a.dtype != np.float32:  # float16, longdouble: exact cast
        a = a.astype(np.float64)
    out = np.empty_like(low)
    if not _finite_clip(a, low, high, out):  # the finiteness check and the clip in one call
        _not_finite(a, what)
    return out


def state_option(options: dict | None, size: int, what: str) -> np.ndarray | None:
    """``options["state"]`` of a ``reset`` as a float64 array (size,), or None if not given.

    Args:
        options: the ``options`` passed to ``reset``.
        size: the number of state values.
        what: the values' names and units for the error message, e.g. ``"vy m/s, r rad/s"``.

    Raises:
        ValueError: wrong size or a non-finite value.
    """
    state = None if options is None else options.get("state")
    if state is None:
        return None
    x = np.array(state, dtype=np.float64)
    if x.shape != (size,) or not np.all(np.isfinite(x)):
        raise ValueError(f"options['state'] must be {size} finite values ({what}), "
                         f"got {state!r}")
    return x


def check_count(name: str, value: object) -> int:
    """Return ``value`` as an int >= 1, or raise ``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or int(value) < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def check_pair(name: str, value: object, unit: str) -> np.ndarray:
    """Turn a positive scalar or per-channel pair into a float64 array (2,), or raise."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(2, float(arr))
    if arr.shape != (2,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be a positive finite number or pair ({unit}), "
                         f"got {value!r}")
    return arr


def check_render_mode(render_mode: str | None, modes: list[str]) -> str | None:
    """Accept ``None`` or one of ``modes``."""
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode must be None or one of {modes}, got {render_mode!r}")
    return render_mode
