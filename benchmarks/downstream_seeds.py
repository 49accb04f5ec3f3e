"""Seed spread of the compensation and MPC studies (the tables of docs/downstream.md are seed 0).

Runs :func:`simgap.control.experiments.compensation_study` and
:func:`~simgap.control.experiments.mpc_study` with the default (``auto``) preset for each
seed and writes only the tracking RMSEs (rad, rad/s) to ``downstream_seeds.json``: a check of
whether a seed-0 difference between rows is larger than the seed-to-seed spread.

Usage: .venv/bin/python benchmarks/downstream_seeds.py [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path


def run(seeds: list[int], train: float = 60.0, evals: float = 8.0) -> dict:
    """``{"compensation": {seed: rows}, "mpc": {seed: rows}}`` with RMSEs only."""
    from simgap.control.experiments import BicycleTask, compensation_study, mpc_study

    out: dict = {"train_seconds": train, "eval_seconds": evals, "seeds": seeds,
                 "units": "arm: joint RMSE (rad); car: yaw-rate RMSE (rad/s)",
                 "compensation": {}, "mpc": {}, "wall_s": {}}
    for seed in seeds:
        t0 = time.time()
        c = compensation_study(train_seconds=train, eval_seconds=evals, seed=seed)
        man, bic = c["manipulator_rmse_rad"], c["bicycle"]
        rows = {"arm_plain": man["plain"], "arm_exact": man["true_residual"],
                "car_plain": bic["plain"]["rmse_rad_s"],
                "car_exact": bic["true_residual"]["rmse_rad_s"]}
        for k in ("instantaneous", "integral", "minibatch"):
            rows[f"arm_{k}"] = [man[k]["frozen"], man[k]["online"]]
            rows[f"car_{k}"] = [bic[k]["frozen"]["rmse_rad_s"], bic[k]["online"]["rmse_rad_s"]]
        out["compensation"][str(seed)] = rows
        m = mpc_study(train_seconds=train, eval_seconds=evals, task=BicycleTask(amplitude=0.24),
                      seed=seed)
        out["mpc"][str(seed)] = {n: v["rmse_rad_s"] for n, v in m["variants"].items()}
        out["wall_s"][str(seed)] = time.time() - t0
        print(f"[seeds] seed {seed}: {out['wall_s'][str(seed)]:.0f} s "
              f"(load {os.getloadavg()[0]:.1f})", file=sys.stderr, flush=True)
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args(argv)
    res = run(args.seeds)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "downstream_seeds.json").write_text(json.dumps(res, indent=1))
    print(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
