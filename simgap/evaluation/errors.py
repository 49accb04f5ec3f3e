"""Errors of the evaluation package."""

from __future__ import annotations


class EvaluationError(ValueError):
    """Bad input to the evaluation (freeze times, cases, options, recordings)."""
