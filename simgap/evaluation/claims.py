"""The thesis' claims (Sec. 4.3-4.5) as checks on a table of RMSEs, and diagnostics.

Claims on Table 4.5 (per case, three methods B1 = instantaneous, B2 = mini-batch,
P = integral):

* ``b1_best_accuracy``: baseline 1 has the best (lowest) online estimation accuracy RMSE.
* ``p_beats_b1_consistency``: the proposed law's consistency RMSE is below baseline 1's at
  every freeze time.
* ``p_close_to_b2``: the proposed law comes close to baseline 2's consistency. Made precise
  with the thesis' own wording (Sec. 4.5.1, "its model consistency remains consistently
  closer to Baseline 2 than to Baseline 1"): at every freeze time, cons_P ≤ cons_B2, or
  cons_B2 < cons_P < cons_B1 with cons_P − cons_B2 < cons_B1 − cons_P. A proposed law worse
  than both baselines does not count as "close to B2" even when B2 is the nearer one.

Claims on Table 4.6 (Sec. 4.5.2):

* ``b2_worst_case``: baseline 2 has the largest mean run-wise maximum and global peak.
* ``only_b2_misses``: baseline 1 and the proposed law miss no deadline; baseline 2 misses.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

#: Claim identifiers and their wording (Table 4.5).
CLAIMS: dict[str, str] = {
    "b1_best_accuracy": "Baseline 1 has the best online estimation accuracy",
    "p_beats_b1_consistency": "The proposed law's frozen-model consistency beats baseline 1's "
                              "at both freeze times",
    "p_close_to_b2": "The proposed law comes close to baseline 2's consistency without a "
                     "buffer (better than B2, or between B2 and B1 and nearer B2)",
}
#: Claim identifiers and their wording (Table 4.6).
TIMING_CLAIMS: dict[str, str] = {
    "b2_worst_case": "Baseline 2 has the largest mean run-wise maximum and global peak",
    "only_b2_misses": "Baseline 1 and the proposed law miss no 2 ms deadline; baseline 2 does",
}


def check_claims(accuracy: Sequence[float], consistency: Mapping[str, Sequence[float]]
                 ) -> dict[str, bool | None]:
    """Evaluate the Table 4.5 claims on one case's numbers.

    Args:
        accuracy: (B1, B2, P) accuracy RMSEs.
        consistency: freeze-time key → (B1, B2, P) consistency RMSEs.

    Returns:
        claim id → True / False, or None when a number is missing (a method diverged).
    """
    acc = [float(v) if v is not None else np.nan for v in accuracy]
    out: dict[str, bool | None] = {}
    out["b1_best_accuracy"] = None if np.any(np.isnan(acc)) else \
        bool(acc[0] < acc[1] and acc[0] < acc[2])
    beats, close = [], []
    for vals in consistency.values():
        b1, b2, p = (float(v) if v is not None else np.nan for v in vals)
        if np.isnan(b1) or np.isnan(b2) or np.isnan(p):
            beats.append(None)
            close.append(None)
            continue
        beats.append(p < b1)
        close.append(p <= b2 or (b2 < p < b1 and p - b2 < b1 - p))
    out["p_beats_b1_consistency"] = None if (not beats or None in beats) else all(beats)
    out["p_close_to_b2"] = None if (not close or None in close) else all(close)
    return out


def check_timing_claims(summary: Mapping[str, Mapping[str, float]]) -> dict[str, bool | None]:
    """Evaluate the Table 4.6 claims on a timing summary (method → statistics)."""
    need = ("instantaneous", "minibatch", "integral")
    if not all(k in summary for k in need):
        return {k: None for k in TIMING_CLAIMS}
    b1, b2, p = (summary[k] for k in need)
    worst = (b2["runmax_mean_ms"] > max(b1["runmax_mean_ms"], p["runmax_mean_ms"])
             and b2["peak_ms"] > max(b1["peak_ms"], p["peak_ms"]))
    misses = (b1["miss_runs_pct"] == 0 and p["miss_runs_pct"] == 0
              and b2["miss_runs_pct"] > 0)
    return {"b2_worst_case": bool(worst), "only_b2_misses": bool(misses)}


def verdict(value: bool | None) -> str:
    """'reproduced' / 'not reproduced' / 'n/a'."""
    if value is None:
        return "n/a"
    return "reproduced" if value else "not reproduced"


def weight_drift(results: Mapping[str, Any]) -> dict[str, float]:
    """Relative change of the weights between the first and last freeze time, per method.

    ‖[Ŵ, V̂]_{T_last} − [Ŵ, V̂]_{T_first}‖_F / ‖[Ŵ, V̂]_{T_last}‖_F: how much the model still
    moves late in the run (the thesis attributes B1's inconsistency to fluctuating weights).
    """
    out = {}
    for kind, res in results.items():
        a, b = res.frozen[0], res.frozen[-1]
        wa = np.concatenate([a.W.ravel(), a.V.ravel()])
        wb = np.concatenate([b.W.ravel(), b.V.ravel()])
        if wa.size == 0 or wa.shape != wb.shape:
            out[kind] = float("nan")
            continue
        out[kind] = float(np.linalg.norm(wb - wa) / max(np.linalg.norm(wb), 1e-300))
    return out
