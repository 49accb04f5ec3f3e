"""The speed bar of issue 17 in one run: native vs sync vector envs, wrapped vs bare, single env.

Measured here, in one process, interleaved (every repeat runs each variant once, in turn)
and reported as medians over ``--repeats``:

* env-steps/s of the native vector env (``gym.make_vec(id, N)``, the registered
  ``vector_entry_point``) and of the sync one (``vectorization_mode="sync"``) at each N,
  bare and with :class:`~simgap.wrappers.VectorIdentifierWrapper` (integral law);
* single-env steps/s of the bare env class (as ``bench_envs.py``);
* in fresh processes (warm numba cache): ``import simgap``, the first ``gym.make``, its
  ``reset`` and the first ``step``;
* with ``--filed TREE`` (a checkout of the commit issue 17 was filed against, main before
  the native env's merge f6e2d0d, i.e. ``git worktree add --detach /tmp/old17 e48587a``
  with the ``_call`` extension built in place): the sync vector env **as filed**
  (``sync_filed_bare``), timed by a persistent worker process that imports that checkout
  (``benchmarks/_vector_worker.py``, ``PYTHONPATH=TREE``, same interpreter unless
  ``--filed-python``; numba caches are the checkout's own), in the same interleaved
  repeats, with ``ratio_native_over_sync_filed_bare``. ``ratio_native_over_sync_bare`` is
  against today's sync env, which the fused single-env kernel of the same issue made
  faster.

Rates are given per wall second and per CPU second of this process (``*_cpu``: the one-core
rate when the machine is shared); ratios (native/sync, wrapped/bare) come from the same
repeat and are the robust numbers on a loaded machine. The load average is recorded before
and after. The sweep numbers are copied from ``results/bench_sweeps.json`` (their own run
and load) when ``--sweep-seeds 0``, else measured in this run by ``bench_sweeps.py``
(serial vs ``--jobs 2`` vs local Ray, 10 seeds by default); the diagnosis memory per
sample is measured in this run by the diagnosis scaling benchmark's child
(``diagnosis_scaling.py``: a generated 500 Hz arm log per length, diagnosed in a fresh
process; peak RSS above the RSS before, per sample), at the lengths of ``--diag-durations``
(empty: skipped).

    .venv/bin/python benchmarks/bench_vector.py [--ns 1,16,256,1024] [--repeats 5] \
        [--budget 0.4] [--fresh 5] [--diag-durations 60,3600] \
        [--filed /tmp/old17] [--out benchmarks/results/bench_vector.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from _vector_worker import rate as _rate

import simgap
from simgap.wrappers import VectorIdentifierWrapper

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
ENVS = {"manipulator": simgap.MANIPULATOR_ID, "bicycle": simgap.BICYCLE_ID}
#: Targets of issue 17 (env-steps/s at N >= 256 on one core; ratios at N = 256).
TARGETS = {"manipulator": {"native_at_256": 250_000.0, "ratio_at_256": 7.0},
           "bicycle": {"native_at_256": 500_000.0, "ratio_at_256": 10.0},
           "wrapped_over_bare": 0.85, "single_arm_steps_per_s": 80_000.0,
           "first_step_s": 0.3, "import_s": 0.2}
FRESH = """
import time
t0 = time.perf_counter()
import simgap
t1 = time.perf_counter()
import gymnasium as gym
import numpy as np
env = gym.make(simgap.{env_id})
t2 = time.perf_counter()
env.reset(seed=0)
t3 = time.perf_counter()
env.step(np.zeros(env.action_space.shape, dtype=np.float32))
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def _has_native(env_id: str) -> bool:
    return gym.spec(env_id).vector_entry_point is not None


def _make(env_id: str, n: int, mode: str, wrapped: bool):
    kw = {} if mode == "native" else {"vectorization_mode": "sync"}
    env = gym.make_vec(env_id, num_envs=n, **kw)
    return VectorIdentifierWrapper(env) if wrapped else env


class _Filed:
    """The sync vector env of another checkout, timed in a persistent worker process.

    Args:
        tree: the checkout (put first on the worker's ``PYTHONPATH``; its working directory).
        python: the interpreter to run the worker with.
    """

    def __init__(self, tree: Path, python: str) -> None:
        env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1")
        self.proc = subprocess.Popen([python, str(ROOT / "benchmarks" / "_vector_worker.py")],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     env=env, cwd=tree)
        self.simgap_file = self._ask("where")
        if not Path(self.simgap_file).resolve().is_relative_to(tree.resolve()):
            raise SystemExit(f"the filed worker imported {self.simgap_file}, not {tree}")

    def _ask(self, line: str) -> str:
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        answer = self.proc.stdout.readline()
        if not answer:
            raise SystemExit(f"the filed worker died (exit {self.proc.wait()})")
        return answer.strip()

    def rate(self, env_id: str, n: int, budget: float) -> tuple[float, float]:
        """(env-steps per wall s, per CPU s of the worker) of the checkout's sync env."""
        wall, cpu = self._ask(f"time {env_id} sync {n} {budget!r}").split()
        return float(wall), float(cpu)

    def close_envs(self) -> None:
        self._ask("close")

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def _ratio(num: list, den: list) -> float:
    """Median over repeats of the per-repeat ratio of CPU rates (same repeat, interleaved)."""
    return statistics.median(a[1] / b[1] for a, b in zip(num, den, strict=True))


def _vector(ns: list[int], repeats: int, budget: float, sync_max_n: int,
            filed: _Filed | None = None) -> dict:
    variants = [("native", False), ("native", True), ("sync", False), ("sync", True)]
    out: dict = {}
    for name, env_id in ENVS.items():
        if not _has_native(env_id):
            out[name] = {"native": "not built (no vector_entry_point registered)"}
            continue
        rows = {}
        for n in ns:
            envs = {}
            for mode, wrapped in variants:
                if mode == "sync" and n > sync_max_n:
                    continue
                e = _make(env_id, n, mode, wrapped)
                e.reset(seed=0)
                envs[(mode, wrapped)] = e
            samples: dict = {k: [] for k in envs}
            with_filed = filed is not None and n <= sync_max_n
            if with_filed:
                samples[("sync_filed", False)] = []
                filed.rate(env_id, n, min(budget, 0.05))  # untimed: make, compile, warm
            for _ in range(repeats):  # interleaved: each variant once per repeat
                for key, e in envs.items():
                    samples[key].append(_rate(e, n, budget))
                if with_filed:
                    samples[("sync_filed", False)].append(filed.rate(env_id, n, budget))
            row = {}
            for (mode, wrapped), s in samples.items():
                tag = f"{mode}_{'wrapped' if wrapped else 'bare'}"
                row[tag] = statistics.median(r[0] for r in s)
                row[f"{tag}_cpu"] = statistics.median(r[1] for r in s)
            pairs = {}
            if ("sync", False) in samples:
                pairs["ratio_native_over_sync_bare"] = (("native", False), ("sync", False))
                pairs["ratio_native_over_sync_wrapped"] = (("native", True), ("sync", True))
            if with_filed:
                pairs["ratio_native_over_sync_filed_bare"] = (("native", False),
                                                              ("sync_filed", False))
                pairs["ratio_sync_over_sync_filed_bare"] = (("sync", False),
                                                            ("sync_filed", False))
            pairs["ratio_wrapped_over_bare_native"] = (("native", True), ("native", False))
            for ratio, (a, b) in pairs.items():
                row[ratio] = _ratio(samples[a], samples[b])
            rows[str(n)] = row
            for e in envs.values():
                e.close()
            if with_filed:
                filed.close_envs()
            print(f"{name} N={n}: " + ", ".join(f"{k} {v:,.0f}" for k, v in row.items()
                                                 if not k.startswith("ratio")),
                  file=sys.stderr)
        out[name] = rows
    return out


def _single(repeats: int, budget: float) -> dict:
    from simgap.envs import BicycleTireEnv, ManipulatorFrictionEnv

    out = {}
    for name, cls in (("manipulator", ManipulatorFrictionEnv), ("bicycle", BicycleTireEnv)):
        env = cls()
        env.reset(seed=0)
        samples = [_rate(_Single(env), 1, budget) for _ in range(repeats)]
        out[name] = {"bare_steps_per_s": statistics.median(s[0] for s in samples),
                     "bare_steps_per_cpu_s": statistics.median(s[1] for s in samples)}
    return out


class _Single:
    """A single env seen through the ``_rate`` interface (no autoreset needed: 1 episode)."""

    def __init__(self, env: gym.Env) -> None:
        self.env = env
        self.action_space = env.action_space

    def step(self, a: np.ndarray) -> None:
        self.env.step(a)


def _fresh(runs: int) -> dict:
    """Medians over fresh processes (the first run warms numba's cache and is dropped)."""
    out = {}
    for name in ENVS:
        env_id = "MANIPULATOR_ID" if name == "manipulator" else "BICYCLE_ID"
        code = FRESH.format(env_id=env_id)
        times = []
        for _ in range(runs + 1):
            proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                  check=True, cwd=ROOT)
            times.append([float(v) for v in proc.stdout.split()])
        times = times[1:]
        keys = ("import_s", "make_s", "reset_s", "first_step_s")
        out[name] = {k: statistics.median(t[i] for t in times) for i, k in enumerate(keys)}
        out[name]["make_reset_step_s"] = statistics.median(sum(t[1:]) for t in times)
    return out


def _sweeps(seeds: int) -> dict:
    """The sweep bar, measured in this run: ``bench_sweeps.py --seeds N`` in a child process
    (serial vs a local process pool of 2 vs local Ray with 2 CPUs, one after the other);
    with ``seeds == 0`` the numbers of ``results/bench_sweeps.json``'s own run instead."""
    import tempfile

    if seeds > 0:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "sweeps.json"
            subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_sweeps.py"),
                            "--seeds", str(seeds), "--out", str(out)], check=True, cwd=ROOT,
                           stdout=subprocess.DEVNULL)
            s = json.loads(out.read_text())
        source = "measured in this run (benchmarks/bench_sweeps.py, child process)"
        return {"sweeps": _sweep_row(s, source)}
    sweeps = RESULTS / "bench_sweeps.json"
    if sweeps.exists():
        return {"sweeps": _sweep_row(json.loads(sweeps.read_text()),
                                     "benchmarks/results/bench_sweeps.json (its own run)")}
    return {"sweeps": "measured elsewhere (benchmarks/bench_sweeps.py); no JSON found"}


def _sweep_row(s: dict, source: str) -> dict:
    return {"source": source, "seeds": s.get("seeds"), "case": s.get("case"),
            "wall_s": {k: v["wall_s"] for k, v in s["runs"].items()},
            "load_before": {k: v["load_before"] for k, v in s["runs"].items()},
            "identical_to_serial": s.get("identical_to_serial")}


def _diagnosis(durations: list[float]) -> dict:
    """Diagnosis memory and time per sample at each length (``diagnosis_scaling``'s child)."""
    import tempfile

    import diagnosis_scaling as ds

    from simgap.diagnosis.generate import generate_manipulator
    from simgap.recordings import write_recording

    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for dur in durations:
            rec = generate_manipulator(ds._effects(), duration=dur, rate=ds.RATE_HZ, seed=0)
            path = Path(tmp) / f"arm_{int(dur)}s.parquet"
            write_recording(path, rec.columns)
            del rec
            load = os.getloadavg()[0]
            r = ds._run_child(path, False, False)
            rows[f"{dur:g}"] = {k: r[k] for k in ("samples", "diagnose_s", "us_per_sample",
                                                  "rss_before_mb", "peak_rss_diagnose_mb",
                                                  "bytes_per_sample", "effects_found")}
            rows[f"{dur:g}"]["load_before"] = load
            print(f"diagnosis {dur:g} s: {r['bytes_per_sample']} B/sample, "
                  f"{r['diagnose_s']} s", file=sys.stderr)
    return {"source": "benchmarks/diagnosis_scaling.py child, this run (500 Hz arm log, "
                      "fresh process, peak RSS above the RSS before / samples)",
            "target_bytes_per_sample": ds.TARGET_BYTES_PER_SAMPLE, "rows": rows}


def _verdict(res: dict) -> dict:
    v: dict = {}
    for name in ENVS:
        rows = res["vector"].get(name)
        if not isinstance(rows, dict) or "256" not in rows:
            continue
        t = TARGETS[name]
        r = rows["256"]
        best = max(rows[n]["native_bare_cpu"] for n in rows if int(n) >= 256)
        v[name] = {"native_at_256_up_cpu": {"measured": best, "target": t["native_at_256"],
                                            "met": best >= t["native_at_256"]}}
        if "ratio_native_over_sync_bare" in r:
            q = r["ratio_native_over_sync_bare"]
            v[name]["ratio_at_256"] = {"measured": q, "target": t["ratio_at_256"],
                                       "met": q >= t["ratio_at_256"]}
        if "ratio_native_over_sync_filed_bare" in r:  # the bar against the env as filed
            q = r["ratio_native_over_sync_filed_bare"]
            v[name]["ratio_at_256_vs_filed"] = {"measured": q, "target": t["ratio_at_256"],
                                                "met": q >= t["ratio_at_256"]}
        w = r["ratio_wrapped_over_bare_native"]
        v[name]["wrapped_over_bare_at_256"] = {"measured": w,
                                               "target": TARGETS["wrapped_over_bare"],
                                               "met": w >= TARGETS["wrapped_over_bare"]}
        # the other reading: wrapped >= 0.85x the bare target (env-steps/s)
        wb = max(rows[n]["native_wrapped_cpu"] for n in rows if int(n) >= 256)
        wt = TARGETS["wrapped_over_bare"] * t["native_at_256"]
        v[name]["wrapped_at_256_up_cpu"] = {"measured": wb, "target": wt, "met": wb >= wt}
    diag = res.get("diagnosis_rss_per_sample")
    if isinstance(diag, dict) and diag["rows"]:
        worst = max(r["bytes_per_sample"] for r in diag["rows"].values())
        v["diagnosis_bytes_per_sample"] = {"measured": worst,
                                           "target": diag["target_bytes_per_sample"],
                                           "met": worst <= diag["target_bytes_per_sample"]}
    s = res["single"]["manipulator"]["bare_steps_per_cpu_s"]
    v["single_arm_bare_cpu"] = {"measured": s, "target": TARGETS["single_arm_steps_per_s"],
                                "met": s >= TARGETS["single_arm_steps_per_s"]}
    if res["fresh"]:
        f = res["fresh"]["manipulator"]
        v["first_step_arm"] = {"measured": f["first_step_s"], "target": TARGETS["first_step_s"],
                               "met": f["first_step_s"] <= TARGETS["first_step_s"]}
        v["import_simgap"] = {"measured": f["import_s"], "target": TARGETS["import_s"],
                              "met": f["import_s"] <= TARGETS["import_s"]}
    return v


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ns", default="1,16,256,1024")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--budget", type=float, default=0.4, help="seconds per timed sample")
    ap.add_argument("--sync-max-n", type=int, default=1024)
    ap.add_argument("--fresh", type=int, default=5, help="fresh processes (0: skip)")
    ap.add_argument("--diag-durations", default="60,3600",
                    help="diagnosis lengths in s for the memory per sample ('' skips)")
    ap.add_argument("--filed", type=Path, default=None,
                    help="checkout of the filing commit: also time its sync env (sync_filed)")
    ap.add_argument("--filed-python", default=sys.executable,
                    help="interpreter for the --filed worker (default: this one)")
    ap.add_argument("--sweep-seeds", type=int, default=10,
                    help="seeds of the sweep bar run in this run (0: copy bench_sweeps.json)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    ns = [int(n) for n in args.ns.split(",")]
    res: dict = {"cpus": os.cpu_count(), "repeats": args.repeats, "budget_s": args.budget,
                 "load_before": os.getloadavg()}
    filed = _Filed(args.filed, args.filed_python) if args.filed is not None else None
    if filed is not None:
        head = subprocess.run(["git", "-C", str(args.filed), "rev-parse", "HEAD"],
                              capture_output=True, text=True)
        res["filed"] = {"tree": str(args.filed), "commit": head.stdout.strip() or None,
                        "simgap_imported_from": filed.simgap_file,
                        "python": args.filed_python,
                        "how": "persistent worker process (benchmarks/_vector_worker.py) "
                               "importing the checkout, interleaved with this process's "
                               "variants in every repeat; ratios per repeat on CPU rates"}
    try:
        res["vector"] = _vector(ns, args.repeats, args.budget, args.sync_max_n, filed)
    finally:
        if filed is not None:
            filed.close()
    res["single"] = _single(args.repeats, args.budget)
    res["fresh"] = _fresh(args.fresh) if args.fresh > 0 else {}
    res["load_after"] = os.getloadavg()
    res.update(_sweeps(args.sweep_seeds))
    durations = [float(d) for d in args.diag_durations.split(",") if d.strip()]
    res["diagnosis_rss_per_sample"] = _diagnosis(durations) if durations else \
        "skipped (--diag-durations '')"
    res["verdict"] = _verdict(res)
    text = json.dumps(res, indent=1)
    if args.out is not None:
        args.out.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
