# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Residual RL with and without the learned residual in the observation
# A SAC agent (stable-baselines3) corrects the nominal-inverting yaw-rate controller of the
# bicycle at 20 m/s on roads whose friction μ is drawn per episode from U(0.45, 0.9). One
# variant sees (vy, r, r_ref, ṙ_ref); the other also sees the online identifier's ĝ, scaled by
# its running RMS (`ResidualObservation`). The task is the registered env
# `simgap/YawRateResidualRL-v0` (docs/rl-task.md). Both run the same identifier, and
# `Monitor(info_keywords=...)` logs its per-episode error. The full experiment is
# `benchmarks/rl_residual.py` (5 seeds per variant, learning curves with 95 % bands); with
# `SIMGAP_QUICK=1` this notebook runs a few hundred steps.

# %%
# %matplotlib inline
import os
from pathlib import Path

from IPython.display import Image, display

from simgap.control.figures import rl_curves_figure
from simgap.control.rl import RL_INFO_KEYWORDS, VARIANTS, RLTask, make_rl_env, train_agent

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)
steps, seeds = (120, [0]) if QUICK else (15_000, [0, 1, 2])
task = RLTask(episode_seconds=0.5) if QUICK else RLTask()
for variant in VARIANTS:
    print(variant, make_rl_env(variant, task).observation_space)

# %%
runs = [train_agent(v, s, steps, task=task) for s in seeds for v in VARIANTS]
for run in runs:
    last = run["episodes"][-1]
    print(f"{run['variant']:8s} seed {run['seed']}: final return {run['final_return_mean']:.3f}"
          f" (base controller {sum(run['base_returns']) / len(run['base_returns']):.3f}); "
          + ", ".join(f"{k}={last[k]:.3g}" for k in RL_INFO_KEYWORDS))

# %%
rl_curves_figure(runs, steps, OUT / "rl_curves.png", overwrite=True)
display(Image(filename=str(OUT / "rl_curves.png")))
