"""The ``simgap`` command line (typer).

Each subpackage registers its own commands in a ``commands.py`` module so that this file
stays a thin index: ``demo`` (here), ``reproduce`` (evaluation), ``diagnose`` and ``record``
(diagnosis). Exit status 2 means bad input.

Every command writes into one output-folder scheme, ``simgap-report/<name>/`` by default
(:mod:`simgap._cli_paths`): ``demo``, ``reproduce``, and ``<recording stem>`` for
``diagnose``.
Progress goes to stderr as plain lines (:mod:`simgap._log`); arguments are checked before
the numerical modules are imported.
"""

from __future__ import annotations

from pathlib import Path

import typer

from simgap._cli_paths import DEMO_OUT
from simgap.diagnosis import commands as diagnosis_commands
from simgap.evaluation import commands as evaluation_commands

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  context_settings={"help_option_names": ["-h", "--help"]},
                  help="simgap: the gap between a simulator and the real system.")


def _version(value: bool) -> None:
    if value:
        from simgap import __version__

        typer.echo(f"simgap {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", "-V", is_eager=True,
                                       callback=_version,
                                       help="Print the version and exit.")) -> None:
    """simgap: the gap between a simulator and the real system."""


@app.command()
def demo(out: Path = typer.Option(DEMO_OUT, "--out",
                                  help="Folder for the figures and index.html."),
         seed: int = typer.Option(0, help="Seed of the rollouts.")) -> None:
    """Run the main job on built-in data and write figures and index.html to OUT."""
    if out.exists() and not out.is_dir():
        diagnosis_commands._fail(f"{out}: exists and is not a folder")
    from simgap.demo import run_demo

    run_demo(out, seed=seed)


diagnosis_commands.register(app)
evaluation_commands.register(app)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
