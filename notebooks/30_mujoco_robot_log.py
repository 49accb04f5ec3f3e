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
# # Why doesn't my MuJoCo robot match the log?
#
# You have an MJCF of your robot and a log of the real one (time, joint positions,
# velocities if you have them, commanded joint torques). Simulated with the logged torques,
# the MJCF drifts away from the log. This notebook goes from the log to a corrected MJCF:
#
# 1. make a log — here by MuJoCo itself, from a "real" MJCF that differs from the nominal
#    one by things a real robot often has and its MJCF lacks: viscous joint damping at the
#    elbow, dry friction (`frictionloss`) at the shoulder and a 0.3 kg payload at the tip;
# 2. `simgap diagnose LOG --model arm.xml` (here its Python twin, `diagnose_mjcf`): where
#    the log differs from the MJCF, which named physics is missing, at which joint, with which
#    parameter;
# 3. the corrected MJCF (`augmented_model.xml`): a copy of yours with only those changes,
#    each commented, and how much better MuJoCo's own simulation of it predicts the held-out
#    part of the log.
#
# The nominal MJCF is the thesis' two-link arm (`examples/mujoco/arm2dof.xml`). With
# `SIMGAP_QUICK=1` the log is 5 s long, otherwise 20 s.

# %%
# %matplotlib inline
import os
from pathlib import Path

import matplotlib.pyplot as plt
import mujoco
import numpy as np
import pandas as pd

from simgap.diagnosis.mjcf_record import record_mjcf
from simgap.diagnosis.mjcf_writer import compile_text, holdout_rmse
from simgap.diagnosis.mujoco import diagnose_mjcf

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output")) / "mujoco_robot_log"
OUT.mkdir(parents=True, exist_ok=True)
# Jupyter runs a notebook in its own folder (notebooks/): paths start from there.
REPO = Path.cwd().parent
ARM = REPO / "examples" / "mujoco" / "arm2dof.xml"

# %% [markdown]
# ## 1. The "real" robot and its log
# The real robot is the same MJCF with three hidden changes. The diagnosis never sees this
# file: it only gets the log and the nominal MJCF.

# %%
real_xml = (ARM.read_text()
            .replace('name="shoulder" type="hinge" axis="0 0 1"',
                     'name="shoulder" type="hinge" axis="0 0 1" frictionloss="0.4"')
            .replace('name="elbow" type="hinge" axis="0 0 1"',
                     'name="elbow" type="hinge" axis="0 0 1" damping="0.2"')
            .replace('<site name="tip" pos="0.2 0 0"/>',
                     '<site name="tip" pos="0.2 0 0"/><body name="load" pos="0.2 0 0">'
                     '<inertial pos="0 0 0" mass="0.3" diaginertia="1e-6 1e-6 1e-6"/></body>'))
columns = record_mjcf(mujoco.MjModel.from_xml_string(real_xml), duration=5.0 if QUICK else 20.0,
                      seed=7)
log = OUT / "arm_log.csv"
pd.DataFrame(columns).to_csv(log, index=False)
pd.read_csv(log).head()

# %% [markdown]
# ## 2. The diagnosis
# Same as `simgap diagnose arm_log.csv --model examples/mujoco/arm2dof.xml`. Columns named
# `t, q_<joint>, dq_<joint>, tau_<joint>` are found by name; other names are mapped with
# `--columns map.json` (e.g. `{"t": {"source": "time_ms", "scale": 0.001}}`).

# %%
report = diagnose_mjcf(ARM, log)
for e in report.effects:
    print(e["summary"])

# %% [markdown]
# Each hidden change is named at its joint: MuJoCo's `frictionloss` as Coulomb friction
# (it is a dry-friction *constraint* in MuJoCo: exactly its level while the joint slides,
# anything up to it while it sticks — the diagnosis scores only the samples where the joint
# surely slides), the damping as viscous friction, the payload as a point mass at the tip
# site.

# %% [markdown]
# ## 3. The corrected MJCF, and MuJoCo's verdict on it

# %%
(OUT / "augmented_model.xml").write_text(report.mjcf_text)
print("\n".join(report.data["mjcf"]["changes"]))
print(report.mjcf_text)

# %%
rm = report.data["mjcf"]["holdout_position_rmse"]
for j, a, b, unit in zip(rm["joints"], rm["original"], rm["corrected"], rm["units"],
                         strict=True):
    print(f"{j}: held-out position RMSE {a:.2e} {unit} (original MJCF) -> {b:.2e} {unit} "
          f"(corrected MJCF), MuJoCo's own simulation of each file")

# %% [markdown]
# One 0.5 s window of the held-out part, simulated by MuJoCo from the logged state with
# the logged torques, for the original and the corrected file.

# %%
t_split = report.data["fit"]["split"]["test"][0]
t = columns["t"]
k0 = int(np.searchsorted(t, t_split))
window = {k: v[k0:k0 + int(0.5 / (t[1] - t[0]))] for k, v in columns.items()}


def simulate(model: mujoco.MjModel) -> np.ndarray:
    d = mujoco.MjData(model)
    d.qpos[:] = [window["q_shoulder"][0], window["q_elbow"][0]]
    d.qvel[:] = [window["dq_shoulder"][0], window["dq_elbow"][0]]
    out = []
    for i in range(len(window["t"])):
        out.append(d.qpos.copy())
        d.ctrl[:] = [window["tau_shoulder"][i], window["tau_elbow"][i]]
        while d.time < window["t"][i] - window["t"][0] + (t[1] - t[0]) - 1e-9:
            mujoco.mj_step(model, d)
    return np.array(out)


original = simulate(mujoco.MjModel.from_xml_path(str(ARM)))
corrected = simulate(compile_text(report.mjcf_text, ARM))
fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
for j, name in enumerate(("shoulder", "elbow")):
    ax = axes[j]
    ax.plot(window["t"], window[f"q_{name}"], "k", lw=2, label="log")
    ax.plot(window["t"], original[:, j], "C3--", label="original MJCF")
    ax.plot(window["t"], corrected[:, j], "C0:", lw=2, label="corrected MJCF")
    ax.set_ylabel(f"q_{name} (rad)")
axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
axes[-1].set_xlabel("time (s)")
axes[0].set_title("Held-out window: MuJoCo simulation of each MJCF with the logged torques")
fig.tight_layout()
fig.savefig(OUT / "heldout_window.png", dpi=120)

# %% [markdown]
# The check on the whole held-out part, on the raw log (independent of the diagnosis'
# filtering):

# %%
print("original :", holdout_rmse(ARM, columns, t_split))
print("corrected:", holdout_rmse(compile_text(report.mjcf_text, ARM), columns, t_split))
