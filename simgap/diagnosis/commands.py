"""CLI commands of this subpackage, registered on the main typer app by ``simgap.cli``."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Add this subpackage's commands to ``app`` (none yet)."""
