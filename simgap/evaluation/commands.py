"""CLI commands of this subpackage, registered on the main typer app by ``simgap.cli``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from simgap._cli_paths import REPRODUCE_OUT, check_out
from simgap._log import error


def register(app: typer.Typer) -> None:
    """Add ``reproduce`` to ``app``."""

    @app.command()
    def reproduce(
        case: Annotated[str, typer.Option(
            "--case", help="1 | 2-1 | 2-2 | timing | all (cases, ablations, timing).")] = "all",
        quick: Annotated[bool, typer.Option("--quick", help="Short CI variant.")] = False,
        out: Annotated[Path, typer.Option(
            "--out", help="Folder for results.json, report.md and the PNGs.")
        ] = REPRODUCE_OUT,
        seed: Annotated[int, typer.Option(
            "--seed", help="Seed of envs and identifier weights.")] = 0,
        timing_runs: Annotated[int | None, typer.Option(
            "--timing-runs", help="Timing runs per method (default 100, quick 3).")] = None,
        no_timing: Annotated[bool, typer.Option(
            "--no-timing", help="Skip the timing part of --case all (a --seeds sweep never "
            "times).")] = False,
        seeds: Annotated[str | None, typer.Option(
            "--seeds", help="Sweep over seeds, e.g. 0-99 or 0,3,5-7: one run per seed and "
            "case (--case 1,2-1 or all, no timing) and OUT/summary.md.")] = None,
        jobs: Annotated[int, typer.Option(
            "--jobs", help="Parallel jobs of a sweep (local processes or Ray CPUs).")] = 1,
        ray: Annotated[bool, typer.Option(
            "--ray", help="Run the sweep on Ray (extra 'ray'): a local instance, or the "
            "cluster in RAY_ADDRESS / --ray-address.")] = False,
        ray_address: Annotated[str | None, typer.Option(
            "--ray-address", help="Join this Ray cluster (implies --ray; 'auto' finds a "
            "running one).")] = None,
    ) -> None:
        """Reproduce the thesis' Chapter 4 (Tables 4.5, 4.6, figures) into OUT."""
        if seeds is not None:
            _sweep(out, seeds, case, quick, jobs, ray_address or ray)
            return
        from simgap.evaluation.choices import CASE_CHOICES

        if case not in CASE_CHOICES:  # before the seconds of numerical imports
            error(f"--case must be one of {list(CASE_CHOICES)}, got {case!r}")
            raise typer.Exit(2)
        check_out(out)  # before the progress bar: a refused --out is the only line
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from simgap._log import line, log
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
                          progress=progress, timing=not no_timing,
                          log=lambda m: bar.console.print(line(m), markup=False, highlight=False,
                                                          soft_wrap=True))
            except SimgapError as exc:  # EvaluationError, OutputError
                bar.stop()
                error(exc)  # one plain line, never wrapped to the console's width
                raise typer.Exit(2) from None
        for path in res["files"]:
            log(f"wrote {path}")


def _sweep(out: Path, seeds: str, case: str, quick: bool, jobs: int,
           ray: bool | str) -> None:
    """``reproduce --seeds``: every (seed, case) as one job, then OUT/summary.{json,md}."""
    from simgap._log import log
    from simgap.errors import SimgapError
    from simgap.evaluation.sweep import parse_cases, reproduce_sweep
    from simgap.outputs import check_folder_target
    from simgap.sweeps import parse_seeds, progress_bar

    try:
        seed_list, cases = parse_seeds(seeds), parse_cases(case)
        check_folder_target(out)  # before the progress bar: the error is the only line
        with progress_bar(len(seed_list) * len(cases)) as tick:
            res = reproduce_sweep(out, seeds=seed_list, cases=cases, quick=quick, jobs=jobs,
                                  ray=ray or None, progress=tick)
    except SimgapError as exc:
        error(exc)
        raise typer.Exit(2) from None
    for f in res["failed"]:
        log(f"failed: case {f['case']} seed {f['seed']}: {f['error']}")
    for path in res["files"]:
        log(f"wrote {path}")
    if res["failed"]:
        raise typer.Exit(1)
