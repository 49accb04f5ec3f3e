"""Typed errors of the identifiers (both are ``ValueError`` subclasses)."""

from __future__ import annotations

from simgap.errors import IdentifierDivergedError, IdentifierError

__all__ = ["IdentifierDivergedError", "IdentifierError"]
