"""Benchmark the identifiers (issue 3): prints one JSON object.

* per-step time of ``Identifier.step`` called from Python, each kind: 100 runs of
  ``--steps`` steps on a recorded thesis manipulator trajectory; every call timed with
  ``perf_counter_ns`` (the timer's own cost is reported and NOT subtracted); statistics
  mean, p50, p99, p99.9, max in µs. The same runs are also timed as whole loops
  (``loop_timed_mean_us``: the mean without the per-call timer). Baseline 2's burst steps
  (those with an SGD update) are also reported separately, and for the observer laws the
  mean of the bare calls on the same transitions (the C caller ``_call.Stepper``, which
  allocates ĝ, and the numba kernel ``observer_step_single`` through numba's dispatcher), to
  split them from the Python method around them; and the loop-timed mean through numba's
  dispatcher instead of the C caller (``dispatcher_path_loop_timed_mean_us``: the speed
  without the optional C extension). ``call_path`` says which path ``Identifier.step`` took.
* batched: ``BatchIdentifier.step`` with N = 1024 rows, µs per instance-step (the API call,
  which splits the rows of the observer laws over numba's threads from 256 rows up), and the
  bare kernel calls without the Python wrapper on one thread and on all threads; best and
  median of 5 repeats.
* wrapped env loop: steps/s of ``IdentifierWrapper(gym.make(id))`` with a fixed action,
  next to the bare env's steps/s; best and median of 5 repeats.

Targets (issue 3): proposed ≤ 1.2 µs mean, p99.9 ≤ 5 µs; batched ≤ 0.3 µs per
instance-step; wrapped env ≥ 20,000 steps/s.

Usage: ``python benchmarks/bench_identifiers.py [--runs 100] [--steps 1000] [--out F.json]``
(``tests/test_benchmarks.py`` runs a tiny variant to keep the script working).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np
from rich.console import Console

import simgap  # noqa: F401 - registers the envs
from simgap.envs.scenarios import FeedbackLinearizationController
from simgap.identifiers import KINDS, BatchIdentifier, fastcall, make_identifier, preset
from simgap.identifiers import kernels as K
from simgap.wrappers import IdentifierWrapper

#: Repeats of the throughput measurements; "best" is the least-contended repeat (as
#: ``timeit`` reports), "median" the typical one on the shared machine.
REPEATS = 5
#: Repeats of the batched measurements (each ≈ 0.05 s: more of them steady the median).
BATCH_REPEATS = 15


def record(steps: int):
    env = gym.make("simgap/ManipulatorFriction-v0").unwrapped
    model = env.nominal_model
    ctrl = FeedbackLinearizationController(model, env.reference)
    obs, _ = env.reset(seed=0)
    x = np.zeros((steps + 1, 4))
    u = np.zeros((steps, 2))
    f = np.zeros((steps, 4))
    x[0] = model.state(obs)
    for k in range(steps):
        a = ctrl(obs, k * env.dt)
        obs, *_ = env.step(a)
        u[k] = np.clip(a, env.action_space.low, env.action_space.high)
        x[k + 1] = model.state(obs)
        f[k] = model.f(x[k], u[k])
    return x, u, f


def stats(ns: np.ndarray) -> dict[str, float]:
    us = ns / 1e3
    return {"mean_us": float(us.mean()), "p50_us": float(np.percentile(us, 50)),
            "p99_us": float(np.percentile(us, 99)), "p999_us": float(np.percentile(us, 99.9)),
            "max_us": float(us.max()), "n": int(us.size)}


def per_step(kind: str, x, u, f, runs: int) -> dict:
    steps = u.shape[0]
    times = np.empty(runs * steps, dtype=np.int64)
    burst = np.zeros(runs * steps, dtype=bool)
    clock = time.perf_counter_ns
    rows = [(x[k], u[k], f[k], x[k + 1]) for k in range(steps)]
    warm = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind))
    for r in rows[:50]:
        warm.step(*r)
    i = 0
    for run in range(runs):
        ident = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind),
                                seed=run)
        step = ident.step
        for xk, uk, fk, xn in rows:
            before = ident.n_updates
            t0 = clock()
            step(xk, uk, fk, xn)
            t1 = clock()
            times[i] = t1 - t0
            burst[i] = kind == "minibatch" and ident.n_updates != before
            i += 1
    # the same runs timed as whole loops: the mean cost of a step without the per-call
    # timer (whose own cost and cache disturbance the per-call figures above include)
    loop_us = loop_means(kind, rows, runs)
    out = {"all": stats(times),
           "loop_timed_mean_us": float(np.mean(loop_us)),
           "loop_timed_median_of_runs_us": float(np.median(loop_us))}
    if kind != "minibatch":
        # the same loops through numba's dispatcher instead of the C caller (the path taken
        # when simgap/identifiers/_call.c is not built)
        disp = loop_means(kind, rows, runs, dispatcher=True)
        out["dispatcher_path_loop_timed_mean_us"] = float(np.mean(disp))
        # the same transitions through the bare calls, without the Identifier.step method
        ident = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind))
        g = np.empty(4)
        args = [(ident._state, xk, uk, fk, xn, g) for xk, uk, fk, xn in rows]
        kern = K.ready("observer_step_single")
        t0 = time.perf_counter()
        for a in args:
            kern(*a)
        out["bare_kernel_call_mean_us"] = (time.perf_counter() - t0) / len(args) * 1e6
        ident = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind))
        if ident._hot is not None:
            hot = ident._hot
            t0 = time.perf_counter()
            for xk, uk, fk, xn in rows:
                hot(xk, uk, fk, xn)
            out["bare_c_caller_call_mean_us"] = (time.perf_counter() - t0) / len(rows) * 1e6
    if kind == "minibatch":
        out["burst_steps"] = stats(times[burst])
        out["non_burst_steps"] = stats(times[~burst])
    return out


def loop_means(kind: str, rows: list, runs: int, dispatcher: bool = False) -> list[float]:
    """Per-step mean (µs) of each run timed as one loop; ``dispatcher``: without the C caller."""
    clock = time.perf_counter_ns
    out = []
    for run in range(runs):
        ident = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind),
                                seed=run)
        if dispatcher:
            ident._hot = None
            ident._step_kernel = K.ready("observer_step_single")
            vars(ident).pop("step", None)  # the C caller's instance attribute: the method
        step = ident.step
        t0 = clock()
        for xk, uk, fk, xn in rows:
            step(xk, uk, fk, xn)
        out.append((clock() - t0) / len(rows) / 1e3)
    return out


def auto_scale_cost(kind: str, rows: list, runs: int) -> dict:
    """Cost of the running scales: ``auto`` with and without them, interleaved runs.

    Without = ``preset("auto", kind, dt)`` with ``scale_rate=0`` (the auto preset before the
    scales, same kernel; the integral law's noise gate, which needs the scales, off too);
    per-step means of whole loops (µs), alternating A, B, A, B …; the ratio of the medians
    and of the best runs (the least contended, as ``timeit`` reports: on a loaded machine a
    run is either clean or preempted, so medians swing). ``thesis`` is the thesis
    manipulator preset in the same rotation (``ratio_vs_thesis``: the whole ``auto`` step
    against it).
    """
    clock = time.perf_counter_ns
    cfg = preset("auto", kind, dt=0.002)
    cfgs = {"without_scales": cfg.replace(scale_rate=0.0, a_d_clean=0.0, eta1_clean=0.0,
                                          eta2_clean=0.0),
            "with_scales": cfg, "thesis": preset("manipulator", kind)}
    means: dict[str, list[float]] = {k: [] for k in cfgs}
    for run in range(runs):
        for name, c in cfgs.items():
            ident = make_identifier(kind, 4, 2, 0.002, config=c, seed=run)
            step = ident.step
            t0 = clock()
            for xk, uk, fk, xn in rows:
                step(xk, uk, fk, xn)
            means[name].append((clock() - t0) / len(rows) / 1e3)
    med = {k: float(np.median(v)) for k, v in means.items()}
    best = {k: float(np.min(v)) for k, v in means.items()}
    return {"median_us": med, "ratio": med["with_scales"] / med["without_scales"],
            "best_us": best, "ratio_best": best["with_scales"] / best["without_scales"],
            "ratio_vs_thesis": med["with_scales"] / med["thesis"],
            "ratio_vs_thesis_best": best["with_scales"] / best["thesis"], "runs": runs}


def batched(kind: str, n_env: int, reps: int) -> dict:
    rng = np.random.default_rng(0)
    cfg = preset("manipulator", kind)
    ident = BatchIdentifier(kind, n_env, 4, 2, 0.002, config=cfg)
    x = rng.normal(size=(n_env, 4)) * 0.5
    u = rng.normal(size=(n_env, 2))
    f = rng.normal(size=(n_env, 4)) * 0.1
    xn = x + 0.002 * f
    ident.step(x, u, f, xn)

    calls = {"api_us_per_instance_step": lambda: ident.step(x, u, f, xn)}
    if kind != "minibatch":
        xf, uf, ff, xnf = (a.reshape(-1) for a in (x, u, f, xn))
        args = (ident._state, xf, uf, ff, xnf)
        serial, threaded = K.ready("observer_step"), K.ready("observer_step_parallel")
        calls["kernel_one_thread_us_per_instance_step"] = lambda: serial(*args)
        calls["kernel_all_threads_us_per_instance_step"] = lambda: threaded(*args)
    # the calls take turns within each repeat, so a disturbed stretch of time hits all of
    # them rather than one
    per: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(BATCH_REPEATS):
        for name, fn in calls.items():
            t0 = time.perf_counter()
            for _ in range(reps):
                fn()
            per[name].append((time.perf_counter() - t0) / reps / n_env * 1e6)
    res = {"n_envs": n_env, "repeats": BATCH_REPEATS, "calls_per_repeat": reps}
    res.update({name: {"best_us": min(v), "median_us": float(np.median(v))}
                for name, v in per.items()})
    if kind != "minibatch":
        res["threads"] = numba.get_num_threads()
    return res


def env_loop(env_id: str, steps: int, wrapped: bool, kind: str = "integral") -> dict:
    env = gym.make(env_id, max_episode_steps=10**9)
    if wrapped:
        env = IdentifierWrapper(env, kind)
    env.reset(seed=0)
    a = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)
    for _ in range(100):
        env.step(a)
    rates = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(a)
        rates.append(steps / (time.perf_counter() - t0))
    return {"best": max(rates), "median": float(np.median(rates))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--env-steps", type=int, default=5000)
    ap.add_argument("--batch-calls", type=int, default=200, help="calls per batched repeat")
    ap.add_argument("--out", type=Path, default=None, help="also write the JSON here")
    ap.add_argument("--scales-only", action="store_true",
                    help="only the running-scales cost of the auto preset (printed)")
    args = ap.parse_args()
    if min(args.runs, args.steps, args.batch, args.env_steps, args.batch_calls) < 1:
        ap.error("--runs, --steps, --batch, --env-steps and --batch-calls must be >= 1")
    console = Console(stderr=True)
    with console.status("recording the thesis manipulator trajectory"):
        x, u, f = record(args.steps)
    clock = time.perf_counter_ns
    t = np.array([-(clock() - clock()) for _ in range(100000)])
    result: dict = {
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "load_average_1min": os.getloadavg()[0],
                    "note": "2 cores shared with other jobs; timings noisy"},
        "timer_overhead_ns_p50": float(np.percentile(t, 50)),
        "call_path": ("C caller (simgap.identifiers._call)" if fastcall.available()
                      else f"numba dispatcher: {fastcall.UNAVAILABLE}"),
        "per_step": {}, "batched": {}, "env_steps_per_s": {}, "auto_scale_cost": {},
        "targets": {"integral_mean_us": 1.2, "integral_p999_us": 5.0,
                    "batched_us_per_instance_step": 0.3, "wrapped_env_steps_per_s": 20000},
    }
    rows = [(x[k], u[k], f[k], x[k + 1]) for k in range(args.steps)]
    for k in KINDS:
        with console.status(f"auto preset, running scales on / off (interleaved): {k}"):
            result["auto_scale_cost"][k] = auto_scale_cost(k, rows, args.runs)
    if args.scales_only:
        print(json.dumps(result, indent=2))
        return
    for k in KINDS:
        with console.status(f"per-step timing: {k} ({args.runs} runs × {args.steps} steps)"):
            result["per_step"][k] = per_step(k, x, u, f, args.runs)
        with console.status(f"batched N={args.batch}: {k}"):
            result["batched"][k] = batched(k, args.batch, args.batch_calls)
    for env_id in ("simgap/ManipulatorFriction-v0", "simgap/BicycleTire-v0"):
        with console.status(f"env loop: {env_id}"):
            result["env_steps_per_s"][env_id] = {
                "bare": env_loop(env_id, args.env_steps, False),
                "wrapped_integral": env_loop(env_id, args.env_steps, True),
                "wrapped_minibatch": env_loop(env_id, args.env_steps, True, "minibatch")}
    result["machine"]["load_average_1min_end"] = os.getloadavg()[0]
    result["verdict"] = verdict(result)
    text = json.dumps(result, indent=2)
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")


def verdict(result: dict) -> dict[str, dict]:
    """Each issue-3 target next to the value measured in this run and whether it is met."""
    tg = result["targets"]
    integral = result["per_step"]["integral"]
    batch = result["batched"]["integral"]["api_us_per_instance_step"]["median_us"]
    env = min(v[w]["median"] for v in result["env_steps_per_s"].values()
              for w in ("wrapped_integral", "wrapped_minibatch"))
    rows = {"integral_mean_us (loop-timed)": (integral["loop_timed_mean_us"],
                                               tg["integral_mean_us"], "<="),
            "integral_mean_us (each call timed)": (integral["all"]["mean_us"],
                                                   tg["integral_mean_us"], "<="),
            "integral_p999_us (each call timed)": (integral["all"]["p999_us"],
                                                   tg["integral_p999_us"], "<="),
            "batched_us_per_instance_step": (batch, tg["batched_us_per_instance_step"], "<="),
            "wrapped_env_steps_per_s (slowest median)": (env, tg["wrapped_env_steps_per_s"],
                                                          ">=")}
    return {k: {"measured": v, "target": t,
                "met": bool(v <= t if op == "<=" else v >= t)} for k, (v, t, op) in rows.items()}


if __name__ == "__main__":
    main()
