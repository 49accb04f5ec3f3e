"""``simgap reproduce``: run the thesis cases and timing, write results.json, report.md, PNGs.

Outputs are first written into a temporary folder beside ``out`` and moved into place only
when complete (:func:`simgap.outputs.output_folder`): an interrupted or failed run leaves no
half-written report, and an ``out`` holding anything but a previous simgap output is refused.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable
from pathlib import Path
from typing import Any

from simgap.evaluation.cases import ABLATION_CASES, THESIS_CASES, get_case
from simgap.evaluation.choices import CASE_CHOICES
from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.report import build_results, render_markdown, to_json
from simgap.evaluation.runner import CaseResult, record_case, run_case
from simgap.outputs import output_folder

#: Timing runs per method (full, quick) and the quick timing horizon (s).
TIMING_RUNS = 100
QUICK_TIMING_RUNS = 3
QUICK_TIMING_SECONDS = 4.0

Progress = Callable[[str, int, int], None]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("simgap")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def _plan(case: str) -> tuple[list[str], bool]:
    if case not in CASE_CHOICES:
        raise EvaluationError(f"--case must be one of {list(CASE_CHOICES)}, got {case!r}")
    if case == "all":
        return [*THESIS_CASES, *ABLATION_CASES], True
    if case == "timing":
        return [], True
    return [case], False


def reproduce(out: Path | str, *, case: str = "all", quick: bool = False, seed: int = 0,
              timing_runs: int | None = None, progress: Progress | None = None,
              log: Callable[[str], None] | None = None, timing: bool = True
              ) -> dict[str, Any]:
    """Run cases and/or timing and write ``results.json``, ``report.md`` and PNGs to ``out``.

    Args:
        out: output folder (new, empty, or a previous simgap output, which is replaced).
        case: ``"1"``, ``"2-1"``, ``"2-2"``, ``"timing"`` or ``"all"`` (the three cases, the
            relaxation-off ablations and timing).
        quick: the short CI variant (Case 1 over 20 s, freeze 12 s / 20 s; timing 3 runs of
            4 s); the bicycle cases are short and always run in full.
        seed: seed of the env resets and the identifiers' initial weights.
        timing_runs: timing runs per method (default 100, quick 3).
        progress: callback ``progress(task, done, total)``.
        log: callback for one-line messages.
        timing: False skips the timing part of ``case="all"`` (``--no-timing``).

    Returns:
        The results dict (as written to ``results.json``) with ``"files"``: written paths.

    Raises:
        EvaluationError: bad arguments (nothing is written).
        OutputError: ``out`` is a file or a folder with other content (nothing is written).
    """
    from matplotlib.figure import Figure  # noqa: F401 - fail early if matplotlib is missing

    from simgap.evaluation.figures import plot_consistency, plot_online, plot_timing
    from simgap.evaluation.timing import run_timing

    names, do_timing = _plan(case)
    if not timing:
        if not names:
            raise EvaluationError("--no-timing with --case timing leaves nothing to run")
        do_timing = False
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise EvaluationError(f"--seed must be a non-negative integer, got {seed!r}")
    if timing_runs is not None and (isinstance(timing_runs, bool)
                                    or not isinstance(timing_runs, int) or timing_runs < 1):
        raise EvaluationError(f"timing runs must be a positive integer, got {timing_runs!r}")
    say = log or (lambda _msg: None)
    with output_folder(out, kind="reproduce") as tmp:
        case_results: list[CaseResult] = []
        figures: dict[str, list[str]] = {}
        case1_tr = None
        for name in names:
            c = get_case(name)
            say(f"case {name}: {c.title}")
            rec = record_case(c, quick=quick, seed=seed)
            if name == "1":
                case1_tr = rec[0]
            cr = run_case(c, quick=quick, seed=seed, progress=progress, transitions=rec)
            case_results.append(cr)
            stem = f"case{name.replace('-', '_')}"
            files = [f"{stem}_online.png", f"{stem}_consistency.png"]
            plot_online(cr, tmp / files[0])
            plot_consistency(cr, tmp / files[1])
            figures[name] = files
        timing = None
        if do_timing:
            n_runs = timing_runs or (QUICK_TIMING_RUNS if quick else TIMING_RUNS)
            c1 = get_case("1")
            if case1_tr is None:
                say("timing: recording Case 1")
                case1_tr, _ = record_case(c1, quick=quick, seed=seed,
                                          duration=QUICK_TIMING_SECONDS if quick else None)
            tr = case1_tr
            if quick:
                tr = tr.head(int(round(QUICK_TIMING_SECONDS / tr.dt)))
            say(f"timing: {n_runs} runs × {len(tr)} steps per method")
            timing = run_timing(tr, n_runs=n_runs, seed=seed, progress=progress)
            plot_timing(timing, tmp / "timing.png")
            figures["timing"] = ["timing.png"]
        meta = {"quick": quick, "seed": seed, "case": case,
                "created_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
                "command": f"simgap reproduce --case {case}{' --quick' if quick else ''} "
                           f"--seed {seed}",
                "version": _version()}
        results = build_results(case_results, timing, meta)
        (tmp / "results.json").write_text(to_json(results), encoding="utf-8")
        (tmp / "report.md").write_text(render_markdown(results, figures), encoding="utf-8")
        written = [Path(out) / f.name for f in sorted(tmp.iterdir())]
    results["files"] = [str(p) for p in written]
    return results
