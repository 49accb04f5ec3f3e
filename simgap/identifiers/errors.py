"""Typed errors of the identifiers (both are ``ValueError`` subclasses)."""

from __future__ import annotations


class IdentifierError(ValueError):
    """Bad input to an identifier: wrong shape, non-finite value, bad config or file."""


class IdentifierDivergedError(IdentifierError):
    """The weights or the state estimate became non-finite or left the documented bound."""
