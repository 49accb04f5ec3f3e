"""SAC with and without the identifier's ĝ in the observation (issue 6), equal budgets.

Task: residual RL on top of the nominal-inverting yaw-rate controller, bicycle at 20 m/s,
reference lateral acceleration near μ·g, μ ~ U(0.45, 0.9) per episode (simgap.control.rl).
Writes ``rl_residual.json`` (per run: training episodes with the identifier's per-episode
errors logged by Monitor(info_keywords=...), final deterministic returns on μ = 0.45, 0.6, 0.9
and the base controller's returns) and ``rl_residual.png`` (learning curves, mean ± std over
seeds). ``--smoke`` runs a few hundred steps per variant.

Usage: .venv/bin/python benchmarks/rl_residual.py [--steps 15000] [--seeds 0 1 2] [--smoke]
       (seeds in parallel: --seeds 0 1 --name a; --seeds 2 --name b; --merge out/a.json out/b.json)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np


def summarise(runs: list[dict], steps: int, seeds: list[int], wall_s: float) -> dict:
    from simgap.control.rl import RL_INFO_KEYWORDS, VARIANTS, RLTask

    summary: dict = {}
    for variant in VARIANTS:
        finals = [r["final_return_mean"] for r in runs if r["variant"] == variant]
        last = [float(np.mean([e["r"] for e in r["episodes"][-5:]])) for r in runs
                if r["variant"] == variant and r["episodes"]]
        err = [float(np.mean([e["residual_error_rms"] for e in r["episodes"]])) for r in runs
               if r["variant"] == variant and r["episodes"]]
        summary[variant] = {"final_return_mean": float(np.mean(finals)),
                            "final_return_std": float(np.std(finals)),
                            "per_seed": finals,
                            "last5_train_return_mean": float(np.mean(last)) if last else None,
                            "identifier_residual_error_rms": float(np.mean(err)) if err else None}
    summary["base_controller_return_mean"] = float(np.mean(
        [b for r in runs for b in r["base_returns"]]))
    task = RLTask()
    return {"benchmark": "rl_residual", "algorithm": "SAC", "steps_per_run": steps,
            "seeds": seeds, "task": task.__dict__ | {"mu_range": list(task.mu_range)},
            "eval_mus": runs[0]["eval_mus"] if runs else None,
            "monitor_info_keywords": list(RL_INFO_KEYWORDS), "summary": summary,
            "runs": runs, "wall_s": wall_s,
            "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                        "note": "shared 2-core machine; timings are noisy"}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=15_000, help="env steps per run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--smoke", action="store_true", help="300 steps, one seed")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--name", default=None, help="output file stem (default rl_residual)")
    ap.add_argument("--merge", type=Path, nargs="+", default=None,
                    help="combine the runs of earlier JSON outputs (e.g. seeds run in parallel)")
    args = ap.parse_args()
    from rich.progress import Progress

    from simgap.control.figures import rl_curves_figure
    from simgap.control.rl import VARIANTS, train_agent

    args.out.mkdir(parents=True, exist_ok=True)
    name = args.name or ("rl_residual_smoke" if args.smoke else "rl_residual")
    if args.merge:
        parts = [json.loads(p.read_text()) for p in args.merge]
        runs = [r for p in parts for r in p["runs"]]
        steps = parts[0]["steps_per_run"]
        seeds = sorted({r["seed"] for r in runs})
        result = summarise(runs, steps, seeds, sum(p["wall_s"] for p in parts))
        result["merged_from"] = [str(p) for p in args.merge]
        result["wall_s_note"] = "sum over the merged parts, which may have run in parallel"
    else:
        steps, seeds = (300, [0]) if args.smoke else (args.steps, args.seeds)
        runs = []
        t0 = time.time()
        with Progress() as bar:
            task = bar.add_task("SAC runs", total=len(seeds) * len(VARIANTS))
            for seed in seeds:
                for variant in VARIANTS:
                    t1 = time.time()
                    run = train_agent(variant, seed, steps)
                    run["wall_s"] = time.time() - t1
                    runs.append(run)
                    bar.console.print(f"{variant:8s} seed {seed}: final mean return "
                                      f"{run['final_return_mean']:.3f} (base "
                                      f"{np.mean(run['base_returns']):.3f}), "
                                      f"{run['wall_s']:.0f} s")
                    bar.advance(task)
        result = summarise(runs, steps, seeds, time.time() - t0)
    (args.out / f"{name}.json").write_text(json.dumps(result, indent=1))
    rl_curves_figure(result["runs"], steps, args.out / f"{name}.png")
    print(json.dumps({"summary": result["summary"], "json": str(args.out / f"{name}.json")},
                     indent=1))


if __name__ == "__main__":
    main()
