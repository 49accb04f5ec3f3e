"""``simgap diagnose LOG1 LOG2 ... --jobs N [--ray]``: many recordings, one summary table.

Each recording is one job of :func:`simgap.sweeps.run_jobs` (serial, a local process pool,
or Ray): :func:`diagnose_job` diagnoses it against the same nominal model and writes its
full report into ``OUT/<recording stem>/`` (report.md, report.json, figures, the augmented
model). The batch then writes ``OUT/summary.json`` and ``OUT/summary.md``: one row per
recording, in the order given, with what was found or the one-line error that stopped it
(the other recordings are kept). The whole of ``OUT`` is one transactional folder
(:func:`simgap.outputs.output_folder`): it appears only when every job has ended.

A diagnosis depends only on its recording, model and options, so the serial run, the
process pool and Ray write identical reports and summaries (``tests/test_diagnose_batch.py``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from simgap.outputs import output_folder
from simgap.sweeps import JobResult, run_jobs


def diagnose_any(recording: str | os.PathLike, model: str, params: Mapping | None = None,
                 columns: str | os.PathLike | None = None,
                 input_hold: str | None = None) -> Any:
    """Diagnose one recording against a built-in model, a model file or an MJCF file.

    ``input_hold``: ``--input-hold`` (``None``: the column map's or the model's).

    Raises:
        SimgapError: bad recording, model, parameters or column map (one line).
    """
    if str(model).lower().endswith(".xml"):  # an MJCF file (simgap.diagnosis.mujoco)
        from simgap.diagnosis.mujoco import diagnose_mjcf

        return diagnose_mjcf(model, recording, columns=columns, input_hold=input_hold)
    from simgap.diagnosis.pipeline import diagnose

    return diagnose(recording, model, dict(params) if params else None, columns=columns,
                    input_hold=input_hold)


def diagnose_job(recording: str, model: str, params: dict | None, columns: str | None,
                 out: str, figures: bool, input_hold: str | None = None) -> dict[str, Any]:
    """One recording's diagnosis written into ``out``; returns its summary row.

    Raises:
        SimgapError: the recording cannot be diagnosed (reported by name, others kept).
    """
    from simgap.diagnosis.report import summary_lines, write_report
    from simgap.limits import check_recording_file

    check_recording_file(recording)  # a missing log, a FIFO, an overlong header: unopened
    report = diagnose_any(recording, model, params, columns, input_hold)
    write_report(report, out, figures=figures)
    data = report.data
    fit = data.get("fit", {})
    return {"samples": data.get("samples"),
            "mismatch": bool(data.get("mismatch", {}).get("significant", False)),
            "effects": [e.get("summary", "") for e in data.get("effects", [])],
            "nominal_score": fit.get("nominal", {}).get("rollout_score"),
            "augmented_score": fit.get("augmented", {}).get("rollout_score"),
            "summary": summary_lines(data)}


def report_folders(recordings: Sequence[str | os.PathLike]) -> list[str]:
    """One folder name per recording: its stem, made unique by ``-2``, ``-3``, ... in order."""
    names: list[str] = []
    seen: set[str] = set()
    for rec in recordings:
        stem = Path(rec).stem or "recording"
        name, k = stem, 1
        while name in seen:
            k += 1
            name = f"{stem}-{k}"
        seen.add(name)
        names.append(name)
    return names


def summarise(recordings: Sequence[str | os.PathLike], folders: Sequence[str],
              results: Sequence[JobResult]) -> dict[str, Any]:
    """The summary table: one row per recording, in the order given."""
    rows = []
    for rec, folder, r in zip(recordings, folders, results, strict=True):
        row: dict[str, Any] = {"recording": str(rec), "ok": r.ok}
        if r.ok:
            row.update(report=f"{folder}/report.md", **r.value)
        else:
            row["error"] = r.error
        rows.append(row)
    failed = [{"recording": row["recording"], "error": row["error"]}
              for row in rows if not row["ok"]]
    return {"recordings": rows, "failed": failed}


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _score(v: Any) -> str:
    return "—" if v is None else f"{v:.3g}"


def markdown(summary: Mapping[str, Any], model: str) -> str:
    """``summary.md``: the table of every recording's outcome."""
    rows = summary["recordings"]
    lines = [f"# simgap diagnose: {len(rows)} recordings against {model}", "",
             f"{len(rows) - len(summary['failed'])} diagnosed, {len(summary['failed'])} "
             "failed. Held-out simulation error is RMSE / state std over the held-out "
             "windows (nominal → augmented).", "",
             "| recording | mismatch | effects found | held-out error | report |",
             "|---|---|---|---|---|"]
    for row in rows:
        if row["ok"]:
            effects = "; ".join(row["effects"]) or "none"
            lines.append(f"| {_cell(row['recording'])} | "
                         f"{'yes' if row['mismatch'] else 'no'} | {_cell(effects)} | "
                         f"{_score(row['nominal_score'])} → {_score(row['augmented_score'])} "
                         f"| [{row['report']}]({row['report']}) |")
        else:
            lines.append(f"| {_cell(row['recording'])} | failed | {_cell(row['error'])} | "
                         "— | — |")
    return "\n".join(lines) + "\n"


def diagnose_batch(out: Path | str, recordings: Sequence[str | os.PathLike], model: str, *,
                   params: Mapping | None = None, columns: str | os.PathLike | None = None,
                   figures: bool = True, jobs: int = 1, ray: bool | str | None = None,
                   inputs: Sequence = (),
                   progress: Callable[[int, int], None] | None = None,
                   input_hold: str | None = None) -> dict[str, Any]:
    """Diagnose every recording and write per-recording reports plus one summary.

    Args:
        out: output folder: new, empty, or a previous simgap output (replaced); refused if
            it is or holds an input.
        recordings: the logs, each diagnosed against ``model`` with the same options.
        model: built-in model name, ``path.py:NAME`` or an MJCF ``.xml``.
        params: nominal parameter overrides (built-in models).
        columns: column map file.
        figures: write each report's PNG figures.
        jobs: local worker processes (or Ray CPUs for a local Ray instance).
        ray: None for local execution, True for a local Ray instance, or an address.
        inputs: further input files (parameter, column-map, model files) ``out`` must not be
            or hold.
        progress: called with (done, total) as recordings finish.
        input_hold: ``--input-hold`` for every recording (``None``: the column map's or
            the model's).

    Returns:
        The summary (as written to ``summary.json``) with ``"files"``.

    Raises:
        OutputError: ``out`` is refused (before any job runs).
        SweepError: bad ``jobs`` or Ray unavailable.
    """
    from simgap.diagnosis.report import finite_json

    out = Path(out)
    recs = [str(r) for r in recordings]
    folders = report_folders(recs)
    every_input = (*recs, *(i for i in inputs if i is not None))
    with output_folder(out, kind="diagnose-batch", inputs=every_input) as tmp:
        job_list = [(rec, model, dict(params) if params else None,
                     None if columns is None else str(columns), str(tmp / folder), figures,
                     input_hold)
                    for rec, folder in zip(recs, folders, strict=True)]
        results = run_jobs(diagnose_job, job_list, workers=jobs, ray=ray, progress=progress)
        summary = summarise(recs, folders, results)
        summary["meta"] = {"model": model, "jobs": jobs, "backend": "ray" if ray else
                           ("process pool" if jobs > 1 else "serial")}
        summary = finite_json(summary)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False),
                                          encoding="utf-8")
        (tmp / "summary.md").write_text(markdown(summary, model), encoding="utf-8")
    summary["files"] = [str(out / "summary.json"), str(out / "summary.md")]
    return summary
