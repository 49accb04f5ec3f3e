"""How `simgap diagnose` scales with the length of a recording (issues 13 and 17).

Manipulator recordings at 500 Hz (hidden Coulomb friction at joint 2 and viscous friction at
joint 1, seed 0) of 60 s, 600 s and 3600 s are written to Parquet once; each is then
diagnosed in a fresh subprocess (so that one run's memory never counts in another's), which
measures:

* ``diagnose_s``, ``report_s``: wall time of :func:`simgap.diagnosis.diagnose` on the
  file's path (reading included, as ``simgap diagnose`` does) and of
  :func:`~simgap.diagnosis.report.write_report` (figures and report.html included);
* ``rss_before_mb``: resident memory after imports and a warm-up diagnosis of the file's
  first 4 s (numba compiles once per process: ``warmup_4s_s``), and ``peak_rss_mb``: the
  peak resident memory after that (``VmHWM``, reset by ``/proc/self/clear_refs``; where
  that is unavailable ``resource.getrusage(RUSAGE_SELF).ru_maxrss``);
* ``bytes_per_sample``: (peak − before) / samples, the memory the diagnosis itself needs per
  sample, and ``peak_bytes_per_sample``: the whole process's peak / samples.

``--trace`` adds one more subprocess per length that runs the diagnosis under
``tracemalloc`` (slower) and records the largest live allocations, by source line, at the
end of the effect selection (where the peak sits) and the ones the returned Report keeps.

Targets: 60 s diagnosed in ≤ 10 s on 2 cores, cost linear in length, ≤ 0.5 KB per sample
(issue 17). Usage::

    .venv/bin/python benchmarks/diagnosis_scaling.py                # 60, 600, 3600 s
    .venv/bin/python benchmarks/diagnosis_scaling.py --quick        # 60 and 600 s
    .venv/bin/python benchmarks/diagnosis_scaling.py --trace --out benchmarks/results/x.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import emit

RATE_HZ = 500.0
TARGET_60S_S = 10.0
TARGET_BYTES_PER_SAMPLE = 512.0


def _status_kb(field: str) -> float:
    """A ``/proc/self/status`` memory field (kB); NaN where there is no /proc."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return float(line.split()[1])
    except OSError:
        pass
    return float("nan")


def _reset_peak() -> None:
    """Reset the peak resident memory (VmHWM) to the current one (Linux, clear_refs 5)."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as fh:
            fh.write("5")
    except OSError:
        pass


def _peak_kb() -> float:
    import resource

    hwm = _status_kb("VmHWM")
    return hwm if hwm == hwm else float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def _effects():
    from simgap.diagnosis.generate import InjectedEffect

    return [InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.2}),
            InjectedEffect(effect="viscous_friction", channel="joint1", params={"b": 0.2})]


def child(path: str, trace: bool, report: bool = True) -> dict:
    """One measured diagnosis of the recording at ``path`` (runs in its own process).

    The file is diagnosed by path, as ``simgap diagnose`` does (reading included).
    """
    import numpy as np

    from simgap.diagnosis.pipeline import diagnose
    from simgap.diagnosis.report import write_report

    out: dict = {}
    # warm-up on the first 4 s: numba's compilation (time and memory) is paid once per
    # process and is not a cost per sample; reported on its own
    t0 = time.perf_counter()
    diagnose(path, "manipulator2dof", duration=4.0)
    out["warmup_4s_s"] = round(time.perf_counter() - t0, 3)
    if trace:
        return {**out, **_traced(path)}
    _reset_peak()
    before = _status_kb("VmRSS")
    t0 = time.perf_counter()
    rep = diagnose(path, "manipulator2dof")
    out["diagnose_s"] = round(time.perf_counter() - t0, 3)
    after_diag = _peak_kb()
    if report:
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            write_report(rep, Path(d) / "r")
            out["report_s"] = round(time.perf_counter() - t0, 3)
    peak = _peak_kb()
    n = int(rep.data["samples"])
    out.update({
        "samples": n,
        "rss_before_mb": round(before / 1024, 1),
        "peak_rss_diagnose_mb": round(after_diag / 1024, 1),
        "peak_rss_mb": round(peak / 1024, 1),
        "bytes_per_sample": round((after_diag - before) * 1024 / n, 1),
        "bytes_per_sample_with_report": round((peak - before) * 1024 / n, 1) if report
        else None,
        "peak_bytes_per_sample": round(peak * 1024 / n, 1),
        "us_per_sample": round(1e6 * out["diagnose_s"] / n, 2),
        "effects_found": [f"{e['effect']}@{e['channel']}" for e in rep.effects],
        "unexplained_fraction": float(np.round(rep.data["unexplained_fraction"], 4)),
    })
    return out


def _top(snapshot, n: int = 8) -> list[dict]:
    stats = snapshot.statistics("lineno")
    root = str(Path(__file__).resolve().parents[1])
    return [{"where": f"{s.traceback[0].filename.replace(root + os.sep, '')}:"
                      f"{s.traceback[0].lineno}",
             "mb": round(s.size / 2**20, 1), "blocks": s.count} for s in stats[:n]]


def _stage_peaks(stages: dict, tracemalloc) -> object:
    """Wrap the pipeline's stages to record each one's traced peak (MB above its start).

    Returns a function that undoes the wrapping.
    """
    from simgap.diagnosis import fit as fit_mod
    from simgap.diagnosis import pipeline
    from simgap.diagnosis import systems as sys_mod

    targets = [(sys_mod.MechanicalSystem, "prepare", "prepare"),
               (fit_mod.Fitter, "__init__", "fitter_init"),
               (fit_mod.Fitter, "select", "select"),
               (pipeline, "compare", "compare")]
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in targets]

    def wrap(fn, label):
        def inner(*a, **k):
            start = tracemalloc.get_traced_memory()[0]
            tracemalloc.reset_peak()
            try:
                return fn(*a, **k)
            finally:
                cur, peak = tracemalloc.get_traced_memory()
                stages[label] = {"start_mb": round(start / 2**20, 1),
                                 "peak_above_start_mb": round((peak - start) / 2**20, 1),
                                 "end_above_start_mb": round((cur - start) / 2**20, 1)}
        return inner

    for (obj, name, label), (_, _, fn) in zip(targets, saved, strict=True):
        setattr(obj, name, wrap(fn, label))

    def restore() -> None:
        for obj, name, fn in saved:
            setattr(obj, name, fn)
    return restore


def _traced(path: str) -> dict:
    """Largest live allocations at the end of the selection and in the returned Report."""
    import tracemalloc

    from simgap.diagnosis import fit as fit_mod
    from simgap.diagnosis.pipeline import diagnose

    at_select: dict = {}
    original = fit_mod.Fitter.select

    def select(self, candidates):
        sel = original(self, candidates)
        at_select["top"] = _top(tracemalloc.take_snapshot())
        at_select["traced_mb"] = round(tracemalloc.get_traced_memory()[0] / 2**20, 1)
        return sel

    fit_mod.Fitter.select = select
    stages: dict = {}
    restore = _stage_peaks(stages, tracemalloc)
    tracemalloc.start()
    t0 = time.perf_counter()
    rep = diagnose(path, "manipulator2dof")
    elapsed = time.perf_counter() - t0
    current, peak = tracemalloc.get_traced_memory()
    # the stages reset tracemalloc's peak: the run's peak is the largest of theirs
    peak = max([peak] + [int((v["start_mb"] + v["peak_above_start_mb"]) * 2**20)
                         for v in stages.values()])
    kept = _top(tracemalloc.take_snapshot())
    tracemalloc.stop()
    restore()
    fit_mod.Fitter.select = original
    n = int(rep.data["samples"])
    del rep
    return {"samples": n,"traced_diagnose_s": round(elapsed, 2),
            "traced_peak_mb": round(peak / 2**20, 1),
            "traced_peak_bytes_per_sample": round(peak / n, 1),
            "report_keeps_mb": round(current / 2**20, 1),
            "report_keeps_bytes_per_sample": round(current / n, 1),
            "stage_peaks_mb": stages,
            "at_end_of_selection": at_select, "report_keeps_top": kept}


def _run_child(path: Path, trace: bool, report: bool = True) -> dict:
    cmd = [sys.executable, __file__, "--child", str(path)] + (["--trace"] if trace else []) \
        + ([] if report else ["--no-report"])
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600,
                          env={**os.environ, "PYTHONHASHSEED": "0"})
    if proc.returncode != 0:
        raise RuntimeError(f"child failed on {path.name}: {proc.stderr[-2000:]}")
    return json.loads(proc.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--durations", default=None,
                    help="comma-separated lengths in s (default 60,600,3600)")
    ap.add_argument("--quick", action="store_true", help="60 and 600 s only")
    ap.add_argument("--trace", action="store_true",
                    help="also run the shortest length under tracemalloc")
    ap.add_argument("--report-max", type=float, default=600.0,
                    help="time write_report only up to this length (s)")
    ap.add_argument("--out", type=Path, default=None, help="also write the JSON here")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--no-report", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.trace, not args.no_report)))
        return
    durations = [float(d) for d in (args.durations or
                                    ("60,600" if args.quick else "60,600,3600")).split(",")]
    from simgap._log import log
    from simgap.diagnosis.generate import generate_manipulator
    from simgap.recordings import write_recording

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for dur in durations:
            log(f"generating {dur:g} s at {RATE_HZ:g} Hz")
            rec = generate_manipulator(_effects(), duration=dur, rate=RATE_HZ, seed=0)
            path = Path(tmp) / f"arm_{int(dur)}s.parquet"
            write_recording(path, rec.columns)
            del rec
            log(f"diagnosing {dur:g} s in a fresh process")
            row = {"duration_s": dur, **_run_child(path, False, dur <= args.report_max)}
            if args.trace and dur == durations[0]:
                log(f"diagnosing {dur:g} s under tracemalloc")
                row["tracemalloc"] = _run_child(path, True, False)
            rows.append(row)
            log(f"  {dur:g} s: {row['diagnose_s']} s, {row['bytes_per_sample']} B/sample")
    first, last = rows[0], rows[-1]
    sixty = next((r for r in rows if r["duration_s"] == 60.0), None)
    res = {
        "benchmark": "simgap diagnose manipulator2dof at 500 Hz: wall time and memory vs "
                     "length (one fresh process per length)",
        "rows": rows,
        "time_per_sample_ratio_longest_vs_shortest": round(
            last["us_per_sample"] / first["us_per_sample"], 3),
        "targets": {"diagnose_60s_s": TARGET_60S_S,
                    "bytes_per_sample": TARGET_BYTES_PER_SAMPLE,
                    "linear": "time per sample of the longest within 1.5x of the shortest"},
        "meets": {
            "diagnose_60s": None if sixty is None else bool(sixty["diagnose_s"]
                                                            <= TARGET_60S_S),
            "linear": bool(last["us_per_sample"] <= 1.5 * first["us_per_sample"]),
            "bytes_per_sample": bool(max(r["bytes_per_sample"] for r in rows)
                                     <= TARGET_BYTES_PER_SAMPLE),
        },
    }
    emit(res, args.out)


if __name__ == "__main__":
    main()
