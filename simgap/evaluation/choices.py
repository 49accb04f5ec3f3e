"""Values ``simgap reproduce --case`` accepts (a light module: the CLI checks them first)."""

from __future__ import annotations

#: Values accepted by ``--case``.
CASE_CHOICES: tuple[str, ...] = ("1", "2-1", "2-2", "timing", "all")
