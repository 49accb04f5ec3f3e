"""The one output-folder scheme of the command line: ``simgap-report/<name>/``.

``simgap demo`` writes to ``simgap-report/demo``, ``simgap reproduce`` to
``simgap-report/reproduce`` and ``simgap diagnose RUN.csv`` to ``simgap-report/RUN``
(``spec/diagnosis.md``'s default, :func:`simgap.diagnosis.pipeline.default_out_dir`).
"""

from __future__ import annotations

from pathlib import Path

import typer

from simgap._log import error

#: Root of every command's default output folder (relative to the working directory).
REPORT_ROOT = Path("simgap-report")


def default_out(name: str) -> Path:
    """``simgap-report/<name>``: the default output folder of a command."""
    return REPORT_ROOT / name


#: ``simgap demo``'s default output folder.
DEMO_OUT = default_out("demo")
#: ``simgap reproduce``'s default output folder.
REPRODUCE_OUT = default_out("reproduce")


def check_out(out: Path, flag: str = "--out") -> Path:
    """Refuse an output folder that may not be written, before any work or progress bar.

    One ``error:`` line (:func:`simgap._log.error`) and exit status 2 if ``out`` is a file,
    a folder holding the user's files, the root ... (:func:`simgap.outputs.check_folder_target`);
    the writer checks again when it moves the finished folder into place.
    """
    from simgap.errors import SimgapError
    from simgap.outputs import check_folder_target

    try:
        return check_folder_target(out, flag=flag)
    except SimgapError as exc:  # OutputError
        error(exc)
        raise typer.Exit(2) from None
