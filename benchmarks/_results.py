"""Shared ending of the diagnosis benchmarks: machine facts, JSON to stdout and a file."""

from __future__ import annotations

import json
import os
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
