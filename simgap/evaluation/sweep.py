"""``simgap reproduce --seeds 0-99 --case 1,2-1 --jobs N [--ray]``: many seeds, one summary.

Each (seed, case) pair is one job of :func:`simgap.sweeps.run_jobs` (serial, a local
process pool, or Ray): it runs :func:`simgap.evaluation.pipeline.reproduce` into
``OUT/seed-<s>/case-<c>/`` (that run's own results.json, report.md and figures) and returns
the case's metrics. The sweep then writes ``OUT/summary.json`` and ``OUT/summary.md``: per
case, method and metric, the mean, standard deviation, minimum and maximum over the seeds
that finished, and the jobs that failed (one line each; the others are kept). A job's
numbers depend only on its seed and case, so every backend gives the serial run's results.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from simgap.evaluation.cases import ABLATION_CASES, THESIS_CASES
from simgap.evaluation.errors import EvaluationError
from simgap.outputs import output_folder
from simgap.sweeps import JobResult, run_jobs

#: Cases a sweep accepts (``all`` = the thesis cases and the ablations; timing is measured
#: once, not per seed: run ``simgap reproduce --case timing`` for it).
SWEEP_CASES = (*THESIS_CASES, *ABLATION_CASES)


def parse_cases(text: str) -> list[str]:
    """``"1,2-1"`` or ``"all"`` → case names, validated.

    Raises:
        EvaluationError: unknown case name (timing is not swept).
    """
    names: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        chosen = list(SWEEP_CASES) if part == "all" else [part]
        for c in chosen:
            if c not in SWEEP_CASES:
                raise EvaluationError(f"--case: {c!r} cannot be swept over seeds; choose from "
                                      f"{list(SWEEP_CASES)} or 'all'")
            if c not in names:
                names.append(c)
    return names


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, float]:
    out: dict[str, float] = {}
    for k, v in d.items():
        key = f"{prefix}/{k}" if prefix else str(k)
        if isinstance(v, Mapping):
            out.update(_flatten(v, key))
        elif isinstance(v, int | float) and not isinstance(v, bool) and k != "n_samples":
            out[key] = float(v)
    return out


def reproduce_job(out: str, case: str, quick: bool, seed: int) -> dict[str, Any]:
    """One (seed, case) run into ``out``; returns its primary-variant metrics, flattened."""
    from simgap.evaluation.pipeline import reproduce

    res = reproduce(Path(out), case=case, quick=quick, seed=seed)
    summary = res["cases"][case]
    primary = summary["primary_variant"]
    return {"seed": seed, "case": case, "variant": primary,
            "metrics": _flatten(summary["variants"][primary]["methods"])}


def summarise(results: Sequence[JobResult]) -> dict[str, Any]:
    """Mean, std (ddof=1 where ≥ 2 seeds), min, max per case and metric; failures listed."""
    by_case: dict[str, dict[str, list[float]]] = {}
    seeds: dict[str, list[int]] = {}
    for r in results:
        if not r.ok:
            continue
        case = r.value["case"]
        seeds.setdefault(case, []).append(r.value["seed"])
        for k, v in r.value["metrics"].items():
            by_case.setdefault(case, {}).setdefault(k, []).append(v)
    cases = {}
    for case, metrics in by_case.items():
        rows = {}
        for k, vals in metrics.items():
            a = np.asarray([v for v in vals if math.isfinite(v)])
            rows[k] = {"n": int(a.size),
                       "mean": float(a.mean()) if a.size else None,
                       "std": float(a.std(ddof=1)) if a.size > 1 else None,
                       "min": float(a.min()) if a.size else None,
                       "max": float(a.max()) if a.size else None}
        cases[case] = {"seeds": sorted(seeds[case]), "metrics": rows}
    # job args are (folder, case, quick, seed); the folder is a temporary path, not reported
    failed = [{"case": r.args[1], "seed": r.args[3], "error": r.error}
              for r in results if not r.ok]
    return {"cases": cases, "failed": failed}


def _markdown(summary: Mapping[str, Any]) -> str:
    lines = ["# simgap reproduce: sweep over seeds", ""]
    for case, c in summary["cases"].items():
        lines += [f"## Case {case} ({len(c['seeds'])} seeds)", "",
                  "| metric | mean | std | min | max |", "|---|---|---|---|---|"]
        for k, s in c["metrics"].items():
            cells = ["—" if s[f] is None else f"{s[f]:.4f}" for f in ("mean", "std", "min",
                                                                       "max")]
            lines.append(f"| {k} | " + " | ".join(cells) + " |")
        lines.append("")
    if summary["failed"]:
        lines += ["## Failed jobs", ""]
        lines += [f"- case {f['case']}, seed {f['seed']}: {f['error']}"
                  for f in summary["failed"]]
    return "\n".join(lines) + "\n"


def reproduce_sweep(out: Path | str, *, seeds: Sequence[int], cases: Sequence[str],
                    quick: bool = False, jobs: int = 1, ray: bool | str | None = None,
                    progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Run every (seed, case) pair and write ``summary.json`` / ``summary.md`` into ``out``.

    Args:
        out: output folder (one sub-folder per seed and case): new, empty, or a previous
            simgap output (replaced), written by :func:`simgap.outputs.output_folder`.
        seeds: seeds (each a non-negative integer).
        cases: case names from :data:`SWEEP_CASES`.
        quick: the short CI variant of each case.
        jobs: local worker processes (or Ray CPUs for a local Ray instance).
        ray: None for local execution, True for a local Ray instance, or an address.
        progress: called with (done, total) as jobs finish.

    Returns:
        The summary dict (as written), with ``"files"``.

    Raises:
        EvaluationError: no seeds or cases (before any job runs).
        OutputError: ``out`` holds something of the user's (refused before any job runs).
    """
    out = Path(out)
    if not seeds:
        raise EvaluationError("--seeds: no seeds given")
    if not cases:
        raise EvaluationError("--case: no cases given")
    # One transactional folder for the whole sweep (simgap.outputs): the jobs write into
    # its temporary twin beside OUT, which replaces OUT only when every job has ended.
    with output_folder(out, kind="reproduce-sweep") as tmp:
        job_list = [(str(tmp / f"seed-{s}" / f"case-{c}"), c, quick, int(s))
                    for s in seeds for c in cases]
        results = run_jobs(reproduce_job, job_list, workers=jobs, ray=ray,
                           progress=progress)
        summary = summarise(results)
        summary["meta"] = {"seeds": list(map(int, seeds)), "cases": list(cases),
                           "quick": quick, "jobs": jobs, "backend": "ray" if ray else
                           ("process pool" if jobs > 1 else "serial")}
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1), encoding="utf-8")
        (tmp / "summary.md").write_text(_markdown(summary), encoding="utf-8")
    summary["files"] = [str(out / "summary.json"), str(out / "summary.md")]
    return summary
