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

import sys
from pathlib import Path

import typer
from typer.core import TyperGroup
from typer.exceptions import Abort, TyperException

from simgap._cli_paths import DEMO_OUT, check_out
from simgap._log import error
from simgap.diagnosis import commands as diagnosis_commands
from simgap.evaluation import commands as evaluation_commands


class _OneLineErrors(TyperGroup):
    """Usage errors (bad option value, missing argument) as one ``error:`` line, exit 2.

    typer would draw a multi-line panel; simgap's contract is one line for every bad input.
    """

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True,
             **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, **extra)
        try:
            rv = super().main(args, prog_name, complete_var, False, **extra)
        except TyperException as err:
            if type(err).__name__ == "NoArgsIsHelpError":  # bare `simgap`: show the help
                typer.echo(err.format_message())
            else:
                error(err.format_message())
            sys.exit(err.exit_code)
        except Abort:
            error("aborted")
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


app = typer.Typer(add_completion=False, no_args_is_help=True, cls=_OneLineErrors,
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
    check_out(out)  # a file, or a folder of the user's: one line before any work
    from simgap.demo import run_demo
    from simgap.errors import SimgapError

    try:
        run_demo(out, seed=seed)
    except SimgapError as err:  # e.g. --out holds the user's files (simgap.outputs)
        error(err)
        raise typer.Exit(2) from None


diagnosis_commands.register(app)
evaluation_commands.register(app)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
