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
# # The reproducibility test on your own env
#
# Any Gymnasium env works if it exposes `env.unwrapped.nominal_model` (see
# `simgap.models.base`) and the target residual in `info` (here the simgap envs'
# `info["residual_true"]`). Steps: record a rollout, convert it to identifier transitions,
# run `reproducibility_test` with any identifier, compute the metrics.
#
# Here "your env" is the manipulator with a *Stribeck* friction (not the thesis' one) and a
# random-waypoint reference: every setting below is a user choice.

# %%
# %matplotlib inline
import os
from pathlib import Path

import gymnasium as gym
import numpy as np
from matplotlib.figure import Figure

import simgap  # noqa: F401  (registers the envs)
from simgap.envs import FeedbackLinearizationController, RandomWaypointReference, rollout
from simgap.evaluation.metrics import Channels, reproducibility_metrics
from simgap.evaluation.reproducibility import reproducibility_test, transitions_from_rollout
from simgap.identifiers import make_identifier, preset

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)
SECONDS = 12.0 if QUICK else 120.0

env = gym.make("simgap/ManipulatorFriction-v0", friction="stribeck",
               reference=RandomWaypointReference(seed=7),
               max_episode_steps=int(SECONDS / 0.002))
model = env.unwrapped.nominal_model
policy = FeedbackLinearizationController(model, env.unwrapped.reference)
ro = rollout(env, policy, int(SECONDS / 0.002), seed=0)
tr = transitions_from_rollout(ro, model)
print(len(tr), "transitions of", tr.n_states, "states and", tr.n_inputs, "inputs")

# %% [markdown]
# Freeze at two thirds of the run and at its end; score the friction torques (momentum rows).

# %%
freeze = (round(SECONDS * 2 / 3, 3), SECONDS)
torques = Channels.rows("torques", "joint friction torques", "N·m", (2, 3), tr.n_states)
results = {}
for kind in ("instantaneous", "minibatch", "integral"):
    ident = make_identifier(kind, tr.n_states, tr.n_inputs, tr.dt,
                            config=preset("manipulator", kind), seed=0)
    results[kind] = reproducibility_test(ident, tr, freeze)
    print(kind, reproducibility_metrics(results[kind], torques))

# %% [markdown]
# The frozen model of the last freeze time against the true joint-1 friction, over joint speed.

# %%
fig = Figure(figsize=(7, 4), layout="constrained")
ax = fig.subplots()
dq1 = tr.extra["obs"][:, 2]
ax.plot(dq1, -tr.target[:, 2], ".", ms=2, color="0.5", label="true τ_d1")
for kind, res in results.items():
    fm = res.frozen[-1]
    ax.plot(dq1[:fm.n_history], -fm.g_frozen[:, 2], ".", ms=1, label=f"{kind}, frozen")
ax.set_xlabel("joint 1 velocity (rad/s)")
ax.set_ylabel("joint 1 friction torque (N·m)")
ax.set_title(f"Stribeck friction, frozen at {freeze[-1]:g} s")
ax.legend(markerscale=5, fontsize=8)
fig.savefig(OUT / "your_env_frozen.png", dpi=100)
assert np.isfinite(reproducibility_metrics(results["integral"], torques)["accuracy"])
fig
