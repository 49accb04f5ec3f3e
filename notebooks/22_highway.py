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
# # highway-env lane keeping on Magic Formula tires, with the identifier running inside
# `simgap/PacejkaLaneKeeping-v0` is highway-env's lane-keeping task with a
# `PacejkaBicycleVehicle` (highway-env's bicycle with saturating tires) on a μ = 0.3 road, and
# the observation taken after the step. The `IdentifierWrapper` runs on it with the linear
# bicycle built from highway-env's own vehicle constants; we compare its axle-force residual
# estimate with the truth.

# %%
# %matplotlib inline
import os
from pathlib import Path

import matplotlib.pyplot as plt

from simgap.highway.experiments import identify_lane_keeping

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)
run = identify_lane_keeping(mu=0.3, seconds=4.0 if QUICK else 40.0)
print(run.scores(last_seconds=2.0 if QUICK else 10.0))

# %%
fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
for i, (ax, axle) in enumerate(zip(axes, ("front", "rear"), strict=True)):
    ax.plot(run.t, run.axle_true[:, i], label="true")
    ax.plot(run.t, run.axle_estimate[:, i], label="identified (K⁻¹ĝ)")
    ax.set_ylabel(f"{axle} axle residual (N)")
    ax.legend()
axes[-1].set_xlabel("time (s)")
axes[0].set_title("highway-env lane keeping, Magic Formula tires, μ = 0.3")
fig.tight_layout()
fig.savefig(OUT / "highway_axle_residual.png", dpi=120)
