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
# # Cases 2-1 and 2-2: bicycle lateral dynamics with saturating tires (thesis Sec. 4.4)
#
# The truth is a Magic Formula tire with **tire relaxation** (the force follows a lagged slip
# angle): a transient effect the network inputs (vy, r, δf, δr) do not see, standing in for
# the thesis' CarMaker roll and load-transfer dynamics. The ablation with relaxation off tests
# the thesis' explanation of baseline 1's poor consistency. Freeze times follow the thesis'
# figures: 4 s / 10 s (step-steer), 15 s / 25 s (slalom). These cases are short and always
# run in full.

# %%
# %matplotlib inline
import os
from pathlib import Path

from simgap.evaluation.cases import METHOD_LABELS, get_case
from simgap.evaluation.claims import check_claims, verdict
from simgap.evaluation.figures import plot_consistency, plot_online
from simgap.evaluation.runner import run_case

OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)

results = {name: run_case(get_case(name), seed=0)
           for name in ("2-1", "2-2", "2-1-norelax", "2-2-norelax")}

# %% [markdown]
# ## Accuracy and consistency (primary metric: state rows, m/s² and rad/s²) and the claims

# %%
for name, res in results.items():
    m = res.metrics[res.primary_variant]
    print(f"Case {name}")
    for kind, v in m.items():
        print(f"  {METHOD_LABELS[kind]:28s} accuracy {v['accuracy']:.4f}  consistency "
              f"{ {k: round(x, 4) for k, x in v['consistency'].items()} }")
    kinds = ("instantaneous", "minibatch", "integral")
    claims = check_claims([m[k]["accuracy"] for k in kinds],
                          {fk: [m[k]["consistency"][fk] for k in kinds]
                           for fk in m["instantaneous"]["consistency"]})
    print("  claims:", {c: verdict(v) for c, v in claims.items()})

# %% [markdown]
# ## Step-steer: online estimation (Fig. 4.5) and the frozen front-axle force vs slip angle
# (Fig. 4.6): the target shows the Magic Formula saturation plus the relaxation transients.

# %%
plot_online(results["2-1"], OUT / "case2_1_online.png")

# %%
plot_consistency(results["2-1"], OUT / "case2_1_consistency.png")

# %% [markdown]
# ## Slalom (Fig. 4.7 / 4.8)

# %%
plot_consistency(results["2-2"], OUT / "case2_2_consistency.png")
