"""Env throughput benchmark: prints JSON.

Measures, for each simgap env, steps per second of the bare class and through ``gym.make``
(with its PassiveEnvChecker / OrderEnforcing / TimeLimit wrappers), and the per-call cost of
the physics kernels alone (``plant_step``, ``true_residual``). Each number is the median of
``--repeats`` timed runs after a warm-up (numba compilation excluded); ``*_per_s`` use wall
time, ``*_per_cpu_s`` this process's CPU time (the one-core rate when the machine is shared).
Target: each bare env >= 20,000 steps/s on one core.

    .venv/bin/python benchmarks/bench_envs.py [--steps 20000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import gymnasium as gym
import numpy as np

import simgap  # noqa: F401 - registers the envs
from simgap.envs import BicycleTireEnv, ManipulatorFrictionEnv
from simgap.models import bicycle as bic
from simgap.models import manipulator as man

TARGET = 20_000.0


def _median_rate(fn, n: int, repeats: int, clock=time.perf_counter) -> float:
    """Median of ``n / seconds`` over ``repeats`` calls of ``fn(n)``, timed by ``clock``."""
    fn(min(n, 1000))  # warm-up
    rates = []
    for _ in range(repeats):
        t0 = clock()
        fn(n)
        rates.append(n / (clock() - t0))
    return statistics.median(rates)


def _env_runner(env: gym.Env, actions: np.ndarray):
    env.reset(seed=0)

    def run(n: int) -> None:
        step = env.step
        m = len(actions)
        for k in range(n):
            _, _, term, trunc, _ = step(actions[k % m])
            if term or trunc:
                env.reset()

    return run


def _kernel_us(fn, n: int, repeats: int, clock=time.perf_counter) -> float:
    return 1e6 / _median_rate(fn, n, repeats, clock)


def bench(steps: int, repeats: int) -> dict:
    """Run all measurements and return the JSON-ready result."""
    rng = np.random.default_rng(0)
    cases = {
        "manipulator": (ManipulatorFrictionEnv, "simgap/ManipulatorFriction-v0",
                        rng.uniform(-2.0, 2.0, size=(1000, 2))),
        "bicycle": (BicycleTireEnv, "simgap/BicycleTire-v0",
                    rng.uniform(-0.05, 0.05, size=(1000, 2))),
    }
    out: dict = {}
    for name, (cls, env_id, actions) in cases.items():
        bare = cls()
        made = gym.make(env_id, max_episode_steps=10**9)
        res = {
            "bare_steps_per_s": _median_rate(_env_runner(bare, actions), steps, repeats),
            "gym_make_steps_per_s": _median_rate(_env_runner(made, actions), steps, repeats),
            # CPU time of this process: robust when other jobs share the cores
            "bare_steps_per_cpu_s": _median_rate(_env_runner(bare, actions), steps, repeats,
                                                 time.process_time),
            "gym_make_steps_per_cpu_s": _median_rate(_env_runner(made, actions), steps,
                                                     repeats, time.process_time),
        }
        theta = bare.plant_theta
        s = bare.plant_state
        u = np.ascontiguousarray(actions[0])
        if name == "manipulator":
            la = bare.nominal_params.array
            dt, n_sub = bare.dt, bare.n_substeps

            def step_k(n, s=s, u=u, theta=theta, dt=dt, n_sub=n_sub):
                for _ in range(n):
                    man.plant_step(s, u, theta, dt, n_sub)

            def resid_k(n, s=s, u=u, theta=theta, la=la):
                for _ in range(n):
                    man.true_residual(s, u, theta, la)
        else:
            th_nom = np.concatenate([bare.nominal_params.array, [bare.vx]])
            dt, n_sub = bare.dt, bare.n_substeps

            def step_k(n, s=s, u=u, theta=theta, dt=dt, n_sub=n_sub):
                for _ in range(n):
                    bic.plant_step(s, u, theta, dt, n_sub)

            def resid_k(n, s=s, u=u, theta=theta, th_nom=th_nom):
                for _ in range(n):
                    bic.true_residual_vs(s, u, theta, th_nom)
        res["plant_step_us"] = _kernel_us(step_k, steps, repeats)
        res["plant_step_cpu_us"] = _kernel_us(step_k, steps, repeats, time.process_time)
        res["true_residual_us"] = _kernel_us(resid_k, steps, repeats)
        res["true_residual_cpu_us"] = _kernel_us(resid_k, steps, repeats, time.process_time)
        res["n_substeps"] = bare.n_substeps
        res["bare_cpu_us_per_step"] = 1e6 / res["bare_steps_per_cpu_s"]
        res["env_overhead_cpu_us"] = res["bare_cpu_us_per_step"] - res["plant_step_cpu_us"]
        res["meets_target"] = max(res["bare_steps_per_s"], res["bare_steps_per_cpu_s"]) >= TARGET
        out[name] = {k: (round(v, 2) if isinstance(v, float) else v) for k, v in res.items()}
        made.close()
    out["target_bare_steps_per_s"] = TARGET
    out["steps"] = steps
    out["repeats"] = repeats
    out["statistic"] = "median"
    out["python"] = platform.python_version()
    out["machine"] = platform.machine()
    out["cpu_count"] = os.cpu_count()
    out["load_avg_1min"] = round(os.getloadavg()[0], 2)
    return out


def main() -> None:
    """Command-line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20_000, help="steps per timed run")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs (median reported)")
    args = ap.parse_args()
    if args.steps < 1 or args.repeats < 1:
        ap.error("--steps and --repeats must be >= 1")
    print(json.dumps(bench(args.steps, args.repeats), indent=2))


if __name__ == "__main__":
    main()
