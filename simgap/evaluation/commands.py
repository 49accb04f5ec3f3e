"""CLI commands of this subpackage, registered on the main typer app by ``simgap.cli``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    """Add ``reproduce`` to ``app``."""

    @app.command()
    def reproduce(
        case: Annotated[str, typer.Option(
            "--case", help="1 | 2-1 | 2-2 | timing | all (cases, ablations, timing).")] = "all",
        quick: Annotated[bool, typer.Option("--quick", help="Short CI variant.")] = False,
        out: Annotated[Path, typer.Option(
            "--out", help="Folder for results.json, report.md and the PNGs.")
        ] = Path("reproduce-output"),
        seed: Annotated[int, typer.Option(
            "--seed", help="Seed of envs and identifier weights.")] = 0,
        timing_runs: Annotated[int | None, typer.Option(
            "--timing-runs", help="Timing runs per method (default 100, quick 3).")] = None,
    ) -> None:
        """Reproduce the thesis' Chapter 4 (Tables 4.5, 4.6, figures) into OUT."""
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from simgap.errors import SimgapError
        from simgap.evaluation.pipeline import reproduce as run

        console = Console(stderr=True)
        tasks: dict[str, int] = {}
        with Progress(TextColumn("{task.description}"), BarColumn(),
                      TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(),
                      console=console, transient=False) as bar:

            def progress(task: str, done: int, total: int) -> None:
                if task not in tasks:
                    tasks[task] = bar.add_task(task, total=total)
                bar.update(tasks[task], completed=done, total=total)

            try:
                res = run(out, case=case, quick=quick, seed=seed, timing_runs=timing_runs,
                          progress=progress, log=lambda m: bar.console.log(m))
            except SimgapError as exc:  # EvaluationError, OutputError
                bar.stop()
                console.print(f"error: {exc}", style="red", markup=False)
                raise typer.Exit(2) from None
        for path in res["files"]:
            console.log(f"wrote {path}")
