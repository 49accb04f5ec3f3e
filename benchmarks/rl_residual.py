"""SAC with and without the identifier's scaled ĝ in the observation, equal budgets (issue 14).

Task: ``simgap/YawRateResidualRL-v0`` (simgap.control.rl): residual RL on top of the
nominal-inverting yaw-rate controller, bicycle at 20 m/s, reference lateral acceleration near
μ·g, μ ~ U(0.45, 0.9) per episode; action a ∈ [−1, 1] → δ_inv + 0.05 rad · a; observation
(vy, r, r_ref, ṙ_ref) and, in the ``residual`` variant, ĝ divided by its running RMS
(ResidualObservation's default ``scale="running"``, clipped to ±10). Both variants run the
same online identifier (the task's kind, ``auto`` preset).

Per seed and variant: SAC for ``--steps`` env steps; every ``--eval-every`` steps the
deterministic policy is evaluated on μ = 0.45 / 0.6 / 0.9 (one 4 s episode each, the
identifier copied from the training env). Runs are interleaved (seed 0 plain, seed 0
residual, seed 1 ...) and the JSON is rewritten after every run (``"complete": false`` until
the last; the PNG too), so an interrupted job keeps balanced, usable results; ``--resume``
skips the runs already in it; ``"completed_seeds"`` lists the seeds finished with every
variant, ``"seeds_pending"`` the rest. Writes ``rl_residual.json`` and ``rl_residual.png``
(learning curves: mean over seeds with a 95 % t-interval band). Progress on stderr.

Usage (defaults: 6 seeds × 2 variants × 30,000 steps; 12 runs of 10-11 min each at a load
of about 7 on the shared 2-core machine, see docs/downstream.md):
    nohup .venv/bin/python benchmarks/rl_residual.py > rl.log 2>&1 &
    .venv/bin/python benchmarks/rl_residual.py --quick      # CI: 1 seed, a few hundred steps
Split over processes (same total compute, less wall time), then merge:
    .venv/bin/python benchmarks/rl_residual.py --seeds 0 1 2 --name rl_a &
    .venv/bin/python benchmarks/rl_residual.py --seeds 3 4 5 --name rl_b &
    .venv/bin/python benchmarks/rl_residual.py --merge benchmarks/results/rl_a.json \
        benchmarks/results/rl_b.json
An extra residual variant with the same seeds and budget, e.g. a declared ĝ scale instead of
the running RMS, compared with the main result (Mann-Whitney, one figure):
    .venv/bin/python benchmarks/rl_residual.py --variants residual --residual-scale 1.0 0.5 \
        --name rl_residual_fixedscale --against benchmarks/results/rl_residual.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def summarise(runs: list[dict]) -> dict:
    """Per variant: final deterministic returns (mean, 95 % CI, per seed), training tail,
    identifier error; and a two-sided Mann-Whitney U test of the final returns."""
    from scipy import stats

    from simgap.control.rl import VARIANTS, mean_ci95

    summary: dict = {}
    for variant in VARIANTS:
        rs = sorted((r for r in runs if r["variant"] == variant), key=lambda r: r["seed"])
        if not rs:
            continue
        finals = np.array([r["final_return_mean"] for r in rs])
        mean, half = mean_ci95(finals)
        last = [float(np.mean([e["r"] for e in r["episodes"][-5:]])) for r in rs
                if r["episodes"]]
        err = [float(np.mean([e["residual_error_rms"] for e in r["episodes"]])) for r in rs
               if r["episodes"]]
        true = [float(np.mean([e["residual_true_rms"] for e in r["episodes"]])) for r in rs
                if r["episodes"]]
        per_mu = np.array([r["final_returns"] for r in rs]).mean(axis=0)
        summary[variant] = {
            "seeds": [r["seed"] for r in rs],
            "final_return_mean": float(mean), "final_return_ci95": float(half),
            "final_return_std": float(finals.std(ddof=1)) if len(finals) > 1 else 0.0,
            "final_return_median": float(np.median(finals)),
            "per_seed": finals.tolist(), "per_mu_mean": per_mu.tolist(),
            "last5_train_return_mean": float(np.mean(last)) if last else None,
            "identifier_residual_error_rms": float(np.mean(err)) if err else None,
            "identifier_residual_true_rms": float(np.mean(true)) if true else None,
            "wall_s_per_run": float(np.mean([r.get("wall_s", np.nan) for r in rs]))}
    plain = [r["final_return_mean"] for r in runs if r["variant"] == "plain"]
    resid = [r["final_return_mean"] for r in runs if r["variant"] == "residual"]
    if len(plain) >= 2 and len(resid) >= 2:
        u = stats.mannwhitneyu(resid, plain, alternative="two-sided")
        summary["residual_vs_plain_mannwhitney_p"] = float(u.pvalue)
    base = [b for r in runs for b in r["base_returns"]]
    summary["base_controller_return_mean"] = float(np.mean(base)) if base else None
    return summary


def completed_seeds(runs: list[dict], variants: tuple[str, ...] | list[str] | None = None
                    ) -> list[int]:
    """Seeds whose runs finished for every variant run (the balanced, usable ones)."""
    from simgap.control.rl import VARIANTS

    pairs = {(r["seed"], r["variant"]) for r in runs}
    return sorted({s for s, _ in pairs if all((s, v) in pairs for v in variants or VARIANTS)})


def against(runs: list[dict], main_path: Path, out_png: Path) -> dict:
    """Compare this job's ``residual`` runs (e.g. a declared ĝ scale) with a main result.

    Two-sided Mann-Whitney U tests of the final returns against the main JSON's ``plain``
    and ``residual`` runs; writes one figure with the three variants (this job's runs drawn
    as ``residual_fixed``). The main result must have the same steps per run.
    """
    from scipy import stats

    from simgap.control.figures import rl_curves_figure

    main = json.loads(main_path.read_text())
    mine = [r for r in runs if r["variant"] == "residual"]
    steps = {r["total_steps"] for r in mine} | {r["total_steps"] for r in main["runs"]}
    if len(steps) != 1:
        sys.exit(f"--against: {main_path} has other steps per run")
    finals = [r["final_return_mean"] for r in mine]
    out: dict = {"file": str(main_path), "seeds": sorted(r["seed"] for r in mine),
                 "main_seeds": main.get("completed_seeds", main["settings"]["seeds"])}
    for variant in ("plain", "residual"):
        other = [r["final_return_mean"] for r in main["runs"] if r["variant"] == variant]
        if len(other) >= 2 and len(finals) >= 2:
            out[f"mannwhitney_p_vs_{variant}"] = float(
                stats.mannwhitneyu(finals, other, alternative="two-sided").pvalue)
    rl_curves_figure(main["runs"] + [{**r, "variant": "residual_fixed"} for r in mine],
                     steps.pop(), out_png, overwrite=True)
    return out


def write_json(path: Path, data: dict) -> None:
    """Write ``data`` to ``path`` through a temporary file (never a half-written JSON)."""
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def load_string() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True,
                              check=False).stdout.strip()
    except OSError:
        return "unknown"


def merge(parts: list[Path], path: Path, against_path: Path | None = None) -> dict:
    """Combine the runs of JSON outputs with equal settings but for their seeds.

    Parts may be interrupted runs (``"complete": false``); seeds that did not finish with
    every variant are dropped, so both variants keep the same seeds.
    """
    from simgap.control.figures import rl_curves_figure

    datas = [json.loads(p.read_text()) for p in parts]
    strip = [{k: v for k, v in d["settings"].items() if k != "seeds"} for d in datas]
    if any(s != strip[0] for s in strip):
        sys.exit("--merge: the parts differ in settings other than seeds")
    runs = sorted((r for d in datas for r in d["runs"]), key=lambda r: (r["seed"], r["variant"]))
    pairs = {(r["seed"], r["variant"]) for r in runs}
    if len(pairs) != len(runs):
        sys.exit("--merge: a seed and variant occurs in more than one part")
    from simgap.control.rl import VARIANTS

    # an interrupted part may end with half a seed: keep only seeds run with every variant
    variants = datas[0]["settings"].get("variants", VARIANTS)
    whole = set(completed_seeds(runs, variants))
    runs = [r for r in runs if r["seed"] in whole]
    res = {**datas[0], "complete": True, "settings": {**datas[0]["settings"],
                                    "seeds": sorted({r["seed"] for r in runs}),
                                    "variants": list(variants)},
           "completed_seeds": completed_seeds(runs, variants),
           "seeds_pending": sorted({s for d in datas for s in d["settings"]["seeds"]}
                                   - whole),
           "runs": runs, "summary": summarise(runs),
           "wall_s_total": sum(d["wall_s_total"] for d in datas),
           "wall_s_note": "sum over the merged parts (processes that ran at the same time)",
           "merged_from": [{"file": str(p), "seeds": d["settings"]["seeds"],
                            "wall_s": d["wall_s_total"], "load_at_start": d["load_at_start"],
                            "load_at_end": d["load_at_end"]} for p, d in zip(parts, datas,
                                                                           strict=True)]}
    if against_path is not None:
        res["summary"]["against"] = against(runs, against_path, path.with_suffix(".png"))
    else:
        rl_curves_figure(runs, res["settings"]["steps_per_run"], path.with_suffix(".png"),
                         overwrite=True)
    write_json(path, res)
    print(json.dumps({"summary": res["summary"], "json": str(path)}, indent=1))
    return res


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=30_000, help="env steps per run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5])
    ap.add_argument("--eval-every", type=int, default=1_500,
                    help="env steps between deterministic evaluations")
    ap.add_argument("--quick", action="store_true",
                    help="1 seed, 250 steps, 1 s episodes (the CI variant)")
    ap.add_argument("--resume", action="store_true",
                    help="keep the runs already in the output JSON (same settings)")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--name", default=None, help="output stem (default rl_residual)")
    ap.add_argument("--residual-scale", type=float, nargs="+", default=None,
                    help="a declared ĝ scale for the residual variant (m/s² and rad/s², one "
                         "value or one per component) instead of the running RMS")
    ap.add_argument("--variants", nargs="+", choices=["plain", "residual"],
                    default=["plain", "residual"], help="variants to run (default both)")
    ap.add_argument("--against", type=Path, default=None,
                    help="a main result JSON: compare this job's residual runs with its plain "
                         "and residual runs (Mann-Whitney) and draw all three in the PNG")
    ap.add_argument("--merge", type=Path, nargs="+", default=None,
                    help="combine complete JSON outputs of the same settings run for different "
                         "seeds (e.g. two processes) into --name")
    args = ap.parse_args(argv)
    from simgap.control.figures import rl_curves_figure
    from simgap.control.rl import RL_INFO_KEYWORDS, RL_TASK_ID, VARIANTS, RLTask, train_agent

    if args.quick:
        steps, seeds, every = 250, [0], 100
        task, eval_mus = RLTask(episode_seconds=1.0), (0.5,)
    else:
        steps, seeds, every = args.steps, args.seeds, args.eval_every
        task, eval_mus = RLTask(), (0.45, 0.6, 0.9)
    if args.residual_scale is not None:
        declared = args.residual_scale[0] if len(args.residual_scale) == 1 \
            else tuple(args.residual_scale)
        task = dataclasses.replace(task, residual_scale=declared)
    name = args.name or ("rl_residual_quick" if args.quick else "rl_residual")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / f"{name}.json"
    settings = {"algorithm": "SAC (stable-baselines3), MlpPolicy (64, 64), batch 128, "
                             "1 gradient step per env step, ent_coef auto from 0.01, "
                             "learning_starts 500, torch 1 thread",
                "env_id": RL_TASK_ID, "steps_per_run": steps, "seeds": seeds,
                "eval_every": every, "eval_mus": list(eval_mus),
                "variants": [v for v in VARIANTS if v in args.variants],
                "task": {**task.__dict__, "mu_range": list(task.mu_range)},
                "observation_scale": "ResidualObservation scale='running' (per-component "
                                     "cumulative RMS of ĝ), clip ±10"
                if task.residual_scale == "running" else
                f"ResidualObservation declared scale {task.residual_scale} (m/s², rad/s²), "
                "clip ±10"}
    settings = json.loads(json.dumps(settings))  # as read back by --resume (lists)
    if args.merge:
        return merge(args.merge, path, args.against)
    runs: list[dict] = []
    if args.resume and path.exists():
        old = json.loads(path.read_text())
        if old.get("settings") != settings:
            sys.exit(f"--resume: {path} was written with other settings; remove it or drop "
                     "--resume")
        runs = old["runs"]
    done = {(r["variant"], r["seed"]) for r in runs}
    variants = settings["variants"]
    todo = [(s, v) for s in seeds for v in variants if (v, s) not in done]
    started = time.time()
    wall_before = sum(r.get("wall_s", 0.0) for r in runs)
    load_start = load_string()
    print(f"[rl_residual] {len(todo)} runs of {steps} steps ({len(done)} already done); "
          f"load: {load_start}", file=sys.stderr, flush=True)

    def result(complete: bool) -> dict:
        return {"benchmark": "rl_residual", "complete": complete, "settings": settings,
                "monitor_info_keywords": list(RL_INFO_KEYWORDS),
                "summary": summarise(runs) if runs else {},
                "completed_seeds": completed_seeds(runs, variants),
                "seeds_pending": [s for s in seeds if s not in completed_seeds(runs, variants)],
                "runs": runs,
                "wall_s_total": wall_before + time.time() - started,
                "load_at_start": load_start, "load_at_end": load_string(),
                "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                            "note": "shared 2-core machine, one process; timings are noisy"}}

    for i, (seed, variant) in enumerate(todo):
        t1 = time.time()

        def progress(step: int, mean: float, variant: str = variant, seed: int = seed,
                     t1: float = t1) -> None:
            print(f"[rl_residual]   {variant} seed {seed}: step {step:6d}, eval return "
                  f"{mean:8.3f} ({time.time() - t1:.0f} s)", file=sys.stderr, flush=True)

        run = train_agent(variant, seed, steps, task=task, eval_mus=eval_mus,
                          eval_every=every, progress=progress)
        run["wall_s"] = time.time() - t1
        runs.append(run)
        print(f"[rl_residual] run {i + 1}/{len(todo)}: {variant} seed {seed}: final "
              f"{run['final_return_mean']:.3f} (base {np.mean(run['base_returns']):.3f}), "
              f"{run['wall_s']:.0f} s", file=sys.stderr, flush=True)
        write_json(path, result(complete=False))
        rl_curves_figure(runs, steps, args.out / f"{name}.png", overwrite=True)
    res = result(complete=True)
    if args.against is not None:
        res["summary"]["against"] = against(runs, args.against, args.out / f"{name}.png")
    else:
        rl_curves_figure(runs, steps, args.out / f"{name}.png", overwrite=True)
    write_json(path, res)
    print(json.dumps({"summary": res["summary"], "json": str(path)}, indent=1))
    return res


if __name__ == "__main__":
    main()
