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
# # simgap quickstart
# Make an env, step it, and read the true residual and the nominal model it exposes.

# %%
# %matplotlib inline
import gymnasium as gym
import numpy as np

import simgap  # noqa: F401  (registers the envs)

env = gym.make("simgap/ManipulatorFriction-v0")
obs, info = env.reset(seed=0)
model = env.unwrapped.nominal_model
print("state:", list(zip(model.state_names, model.state_units, strict=True)))

# %%
obs, reward, terminated, truncated, info = env.step(np.zeros(2))
print("true residual g(x, u):", info["residual_true"])
print("nominal f(x, u):", model.f(model.state(obs), np.zeros(2)))
