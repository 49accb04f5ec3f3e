"""Env test helpers: quiet the env checkers' advice that does not apply."""

from __future__ import annotations

import warnings
from contextlib import contextmanager


@contextmanager
def quiet_checkers():
    """Silence the checkers' advice that does not apply (unbounded observation Box, the
    SB3 preference for [-1, 1] float32 actions, no spec for render modes)."""
    with warnings.catch_warnings():
        for msg in (".*infinity.*", ".*symmetric and normalized.*", ".*alternative render.*",
                    ".*normalized space.*"):
            warnings.filterwarnings("ignore", message=msg)
        yield
