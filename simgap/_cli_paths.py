"""The one output-folder scheme of the command line: ``simgap-report/<name>/``.

``simgap demo`` writes to ``simgap-report/demo``, ``simgap reproduce`` to
``simgap-report/reproduce`` and ``simgap diagnose RUN.csv`` to ``simgap-report/RUN``
(``spec/diagnosis.md``'s default, :func:`simgap.diagnosis.pipeline.default_out_dir`).
"""

from __future__ import annotations

from pathlib import Path

#: Root of every command's default output folder (relative to the working directory).
REPORT_ROOT = Path("simgap-report")


def default_out(name: str) -> Path:
    """``simgap-report/<name>``: the default output folder of a command."""
    return REPORT_ROOT / name


#: ``simgap demo``'s default output folder.
DEMO_OUT = default_out("demo")
#: ``simgap reproduce``'s default output folder.
REPRODUCE_OUT = default_out("reproduce")
