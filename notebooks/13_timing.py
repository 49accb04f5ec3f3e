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
# # Per-step compute time of the identifiers (thesis Sec. 4.5.2, Table 4.6)
#
# Each method runs on the recorded Case 1 transitions; every `Identifier.step` call is timed
# with `time.perf_counter_ns`. The thesis used 100 runs of the whole case; `SIMGAP_QUICK=1`
# times 2 runs of 4 s. Timings depend on the machine and its load, recorded below.

# %%
# %matplotlib inline
import os
from pathlib import Path

from simgap.evaluation.cases import get_case
from simgap.evaluation.figures import plot_timing
from simgap.evaluation.runner import record_case
from simgap.evaluation.timing import THESIS_TABLE_4_6, run_timing

QUICK = os.environ.get("SIMGAP_QUICK") == "1"
OUT = Path(os.environ.get("SIMGAP_NOTEBOOK_OUT", "notebook-output"))
OUT.mkdir(parents=True, exist_ok=True)

tr, _ = record_case(get_case("1"), duration=4.0 if QUICK else None)
timing = run_timing(tr, n_runs=2 if QUICK else 100)
print(timing["machine"])

# %%
for kind, s in timing["summary"].items():
    print(f"{kind:14s} mean {s['mean_ms']:.4f} ms, run-wise max {s['runmax_mean_ms']:.4f} ± "
          f"{s['runmax_std_ms']:.4f} ms, peak {s['peak_ms']:.4f} ms, misses "
          f"{s['miss_runs_pct']:.0f} % of runs / {s['miss_steps_pct']:.4f} % of steps")
print("thesis:", THESIS_TABLE_4_6)

# %%
plot_timing(timing, OUT / "timing.png")
