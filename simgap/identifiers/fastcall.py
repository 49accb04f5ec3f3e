"""The fast path of ``Identifier.step``: the C caller ``_call`` + the kernel as a C function.

One identifier's step costs ≈ 0.4 µs of arithmetic, but calling the numba kernel through
numba's dispatcher adds ≈ 0.3 µs (type resolution and wrapping of six arrays) and
``np.empty`` for the returned ĝ another 0.1-0.2 µs. The optional C extension
``simgap.identifiers._call`` (source ``_call.c``, built by ``setup.py`` when a C compiler is
available) checks the four input arrays with NumPy's C macros, allocates ĝ and calls
:func:`~simgap.identifiers.kernels.c_observer_step` (the same numba row code compiled as a
C function) directly. No numerics live in C.

Without the extension (no compiler at install time) or if the C function cannot be built,
:func:`observer_stepper` returns ``None`` and ``Identifier.step`` calls the numba kernel
the usual way: same results bit for bit (tested), ≈ 0.5 µs slower per step. Setting the
environment variable ``SIMGAP_NO_C_CALLER`` (to anything non-empty) before import does the
same on purpose (the benchmark uses it to measure both paths).
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np

from simgap.identifiers import kernels as K

try:  # the optional C extension (setup.py builds it when a compiler is present)
    from simgap.identifiers import _call
except ImportError:  # pragma: no cover - exercised on machines without a compiler
    _call = None

#: Why the fast path is off (``None`` while it is available or not yet tried).
UNAVAILABLE: str | None = None
if _call is None:
    UNAVAILABLE = ("the C extension simgap.identifiers._call is not built (no working C "
                   "compiler at install time; pip's build output says why)")
elif os.environ.get("SIMGAP_NO_C_CALLER"):
    UNAVAILABLE = "switched off by the environment variable SIMGAP_NO_C_CALLER"


def available() -> bool:
    """True if the C caller is built and the C kernel compiles (compiles it on first call)."""
    global UNAVAILABLE
    if UNAVAILABLE is not None:
        return False
    try:
        K.c_observer_step()
    except Exception as exc:  # noqa: BLE001 - any numba failure: use the dispatcher instead
        UNAVAILABLE = f"numba could not compile the C kernel: {exc}"
        return False
    return True


def observer_stepper(state: np.ndarray, n: int,
                     fallback: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                                        np.ndarray] | None = None
                     ) -> Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                                   np.ndarray | None] | None:
    """A callable ``(x, u, f, x_next) -> ĝ`` stepping the one-row ``state``.

    It returns a new ĝ array (n) on success. If an argument is not a float64, 1-D,
    C-contiguous array or the kernel reports a failure (the row is then unchanged), it returns
    ``fallback(x, u, f, x_next)``, or ``None`` without a fallback (the caller then takes the
    general path). With a fallback that takes the general path (converts, or raises the typed
    error) the callable can replace ``Identifier.step`` outright: an instance attribute that
    Python calls without a frame of its own (≈ 0.13 µs of a ≈ 0.4 µs step saved). Returns
    ``None`` instead of a callable if the fast path is unavailable (:data:`UNAVAILABLE` says
    why).
    """
    if not available():
        return None
    return _call.Stepper(K.c_observer_step().address, state, n, fallback)
