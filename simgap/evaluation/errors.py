"""Errors of the evaluation package."""

from __future__ import annotations

from simgap.errors import EvaluationError

__all__ = ["EvaluationError"]
