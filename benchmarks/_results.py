"""Shared parts of the diagnosis benchmarks: clean-log counts, machine facts, JSON output."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any


def emit(res: dict[str, Any], out: Path | None) -> None:
    """Add the load (1/5/15 min) and core count to ``res``, print it, write it to ``out``."""
    res["loadavg_1_5_15"] = [round(x, 2) for x in os.getloadavg()]
    res["cpu_count"] = os.cpu_count()
    text = json.dumps(res, indent=2)
    if out:
        out.write_text(text + "\n", encoding="utf-8")
    print(text)


def clean_counts(clean: list[dict[str, Any]]) -> dict[str, int]:
    """Counts over diagnosed clean logs: how many, with effects named, with a mismatch flagged."""
    return {"clean": len(clean),
            "clean_with_named_effects": sum(bool(r.get("found")) for r in clean),
            "clean_flagged_mismatch": sum(bool(r.get("significant")) for r in clean)}


def markdown_table(first: str, columns: list[tuple[str, str]],
                   summary: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """Lines of a Markdown table: one row per ``summary`` key, one column per (title, key)."""
    lines = [f"| {first} | " + " | ".join(t for t, _ in columns) + " |",
             "|" + "---|" * (len(columns) + 1)]
    lines += [f"| {k} | " + " | ".join(str(s[c]) for _, c in columns) + " |"
              for k, s in summary.items()]
    return lines


def write_table(out: dict[str, Any], table: str, path: Path | None) -> None:
    """A table benchmark's ending: Markdown on stderr, JSON on stdout and to ``path``."""
    print(table, file=sys.stderr)
    text = json.dumps(out, indent=1, default=float)
    if path is not None:
        path.write_text(text)
    print(text)
