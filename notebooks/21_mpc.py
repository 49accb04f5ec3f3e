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
# # Sampling MPC with the nominal model and with nominal + frozen residual network
# MPPI yaw-rate tracking on a μ = 0.5 road at 20 m/s (reference lateral acceleration 0.98 μg).
# Variants: nominal model alone, the exact plant (a simulation-only bound), and the nominal
# model plus each identifier's frozen network (pre-trained on a front-steer slalom).
# The full run is `benchmarks/bench_mpc.py`; `SIMGAP_QUICK=1` runs one identifier briefly.

# %%
# %matplotlib inline
import os
from pathlib import Path

from IPython.display import Image, display

from simgap.control import MPCConfig
from simgap.control.experiments import BicycleTask, mpc_study
from simgap.control.figures import mpc_figure

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)
kinds = ("minibatch",) if QUICK else ("instantaneous", "integral", "minibatch")
config = MPCConfig(n_samples=128, n_iter=2) if QUICK else MPCConfig()
res = mpc_study(kinds=kinds, train_seconds=5.0 if QUICK else 60.0,
                eval_seconds=1.0 if QUICK else 8.0, task=BicycleTask(amplitude=0.24),
                config=config)

# %%
for name, v in res["variants"].items():
    print(f"{name:22s} yaw-rate RMSE {v['rmse_rad_s']:.4f} rad/s, peak {v['max_abs_rad_s']:.4f}"
          f" rad/s, compute per step p50 {1e3 * v['compute_s']['p50']:.2f} ms")
mpc_figure(res, OUT / "mpc.png", overwrite=True)
display(Image(filename=str(OUT / "mpc.png")))
