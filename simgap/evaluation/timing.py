"""Per-step compute time of the identifiers (thesis Sec. 4.5.2, Table 4.6).

Protocol: the Case 1 rollout is recorded once; for each method, ``n_runs`` independent runs
each build a fresh identifier (same seed: identical conditions) and feed it the recorded
transitions, timing every ``Identifier.step`` call with :func:`time.perf_counter_ns`
(only the call is inside the timed window; data indexing is outside). Before the runs one
untimed warm-up step per method triggers numba's JIT/cache load, so compilation is not counted.

Statistics over all runs of a method (ms):

* mean: mean of all per-step times;
* run-wise max: mean and standard deviation (ddof = 0) over runs of each run's largest step;
* global peak: the largest step of all runs;
* deadline misses at ``deadline_ms`` (2 ms = 500 Hz): the share of runs with at least one
  step over the deadline (%, errata 6) and the share of steps over it (%).

The same statistics are also computed from the thread's CPU time of each call
(:func:`time.thread_time_ns`, read just outside the wall-clock window): a step that was
descheduled by the OS (another process ran) is long in wall time but not in CPU time, so the
CPU-time table separates the algorithm's own bursts (baseline 2's periodic SGD) from the
machine's load. The thesis' protocol is the wall-clock one.

Timings depend on the machine and its load; :func:`machine_info` records what ran them.
"""

from __future__ import annotations

import os
import platform
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.reproducibility import Transitions

#: Thesis Table 4.6 (ms, %), (baseline 1, baseline 2, proposed).
THESIS_TABLE_4_6: dict[str, tuple[float, float, float]] = {
    "mean_ms": (0.0047, 0.0118, 0.0050),
    "runmax_mean_ms": (0.2172, 1.0565, 0.2273),
    "runmax_std_ms": (0.1977, 2.7081, 0.1807),
    "peak_ms": (1.4914, 21.806, 1.6880),
    "miss_runs_pct": (0.0, 8.0, 0.0),
}


def machine_info() -> dict[str, Any]:
    """CPU model, core count, load, OS, Python and library versions of this machine."""
    import numba

    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        load = [round(v, 2) for v in os.getloadavg()]
    except (OSError, AttributeError):
        load = None
    try:
        affinity = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        affinity = None
    return {"cpu": cpu or platform.machine(), "logical_cores": os.cpu_count(),
            "usable_cores": affinity, "load_average_1_5_15min": load,
            "platform": platform.platform(), "python": sys.version.split()[0],
            "numpy": np.__version__, "numba": numba.__version__}


def time_runs(make: Callable[[], Any], transitions: Transitions, n_runs: int,
              progress: Callable[[int, int], None] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Time every ``step`` of ``n_runs`` fresh identifiers on ``transitions``.

    Args:
        make: builds a fresh identifier (called once per run).
        transitions: the recorded rollout.
        n_runs: number of runs, ≥ 1.
        progress: callback ``progress(done_runs, n_runs)``.

    Returns:
        (wall, cpu): int64 arrays (n_runs, n_steps) of per-step wall-clock times
        (``perf_counter_ns``) and thread CPU times (``thread_time_ns``), in ns.
    """
    if isinstance(n_runs, bool) or not isinstance(n_runs, int) or n_runs < 1:
        raise EvaluationError(f"n_runs must be a positive integer, got {n_runs!r}")
    x, u, f, xn = transitions.x, transitions.u, transitions.f, transitions.x_next
    n = len(transitions)
    rows = [(x[k], u[k], f[k], xn[k]) for k in range(n)]
    out = np.empty((n_runs, n), dtype=np.int64)
    cpu = np.empty((n_runs, n), dtype=np.int64)
    clock = time.perf_counter_ns
    cpu_clock = time.thread_time_ns
    warm = make()
    warm.step(*rows[0])
    for run in range(n_runs):
        ident = make()
        step = ident.step
        d = out[run]
        c = cpu[run]
        for k in range(n):
            xk, uk, fk, xnk = rows[k]
            c0 = cpu_clock()
            t0 = clock()
            step(xk, uk, fk, xnk)
            t1 = clock()
            c[k] = cpu_clock() - c0
            d[k] = t1 - t0
        if progress is not None:
            progress(run + 1, n_runs)
    return out, cpu


def summarize(times_ns: np.ndarray, deadline_ms: float = 2.0) -> dict[str, float]:
    """Table 4.6 statistics of one method (module docstring) from (runs, steps) ns times."""
    t = np.asarray(times_ns, dtype=np.float64) / 1e6
    if t.ndim != 2 or t.size == 0:
        raise EvaluationError(f"times must be a non-empty (runs, steps) array, got {t.shape}")
    run_max = t.max(axis=1)
    miss = t > deadline_ms
    return {"mean_ms": float(t.mean()), "median_ms": float(np.median(t)),
            "p99_ms": float(np.percentile(t, 99)),
            "runmax_mean_ms": float(run_max.mean()), "runmax_std_ms": float(run_max.std()),
            "peak_ms": float(t.max()),
            "miss_runs_pct": float(100.0 * np.mean(miss.any(axis=1))),
            "miss_steps_pct": float(100.0 * miss.mean()),
            "n_runs": int(t.shape[0]), "n_steps": int(t.shape[1])}


def run_timing(transitions: Transitions, *, n_runs: int = 100, seed: int = 0,
               methods: tuple[str, ...] = ("instantaneous", "minibatch", "integral"),
               deadline_ms: float = 2.0, system: str = "manipulator",
               progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Table 4.6: time ``n_runs`` runs of every method on ``transitions``.

    Args:
        transitions: the recording (Case 1's, or a prefix of it for a quick run).
        n_runs: runs per method.
        seed: identifier seed (the same for every run: identical conditions).
        methods: identifier kinds.
        deadline_ms: the real-time deadline (ms), 2 ms = 500 Hz.
        system: identifier preset system.
        progress: callback ``progress(task, done, total)``.

    Returns:
        ``{"settings", "machine", "summary": {method: stats}, "summary_cpu": {method: stats
        from thread CPU time}, "raw": {method: {run_max_ms, hist_edges_ms, hist_counts}}}``
        (JSON-serialisable).
    """
    from simgap.identifiers import make_identifier, preset

    if not (np.isfinite(deadline_ms) and deadline_ms > 0):
        raise EvaluationError(f"deadline_ms must be a positive time in ms, got {deadline_ms!r}")
    summary: dict[str, Any] = {}
    summary_cpu: dict[str, Any] = {}
    raw: dict[str, Any] = {}
    edges = np.logspace(-4, 2.5, 131)  # 0.1 µs .. 316 ms
    for kind in methods:
        cfg = preset(system, kind)

        def make(kind: str = kind, cfg: Any = cfg) -> Any:
            return make_identifier(kind, transitions.n_states, transitions.n_inputs,
                                   transitions.dt, config=cfg, seed=seed)

        cb = None
        if progress is not None:
            def cb(done: int, total: int, _k: str = kind) -> None:
                progress(f"timing: {_k}", done, total)

        times, cpu = time_runs(make, transitions, n_runs, progress=cb)
        summary[kind] = summarize(times, deadline_ms)
        summary_cpu[kind] = summarize(cpu, deadline_ms)
        del cpu
        ms = times / 1e6
        counts, _ = np.histogram(np.clip(ms, edges[0], edges[-1]), bins=edges)
        raw[kind] = {"run_max_ms": ms.max(axis=1).tolist(), "hist_edges_ms": edges.tolist(),
                     "hist_counts": counts.tolist()}
    return {"settings": {"n_runs": n_runs, "n_steps": len(transitions),
                         "duration_s": float(len(transitions) * transitions.dt),
                         "dt_s": transitions.dt, "deadline_ms": deadline_ms, "seed": seed,
                         "timed_call": "Identifier.step(x, u, f, x_next)",
                         "clock": "time.perf_counter_ns",
                         "cpu_clock": "time.thread_time_ns"},
            "machine": machine_info(), "summary": summary, "summary_cpu": summary_cpu,
            "raw": raw}
