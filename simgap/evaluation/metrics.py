"""The metrics of the reproducibility test (thesis Sec. 4.1, Table 4.5), defined precisely.

All metrics are root-mean-square errors pooled over the selected channels and samples:

    RMSE(a, b; P, S) = sqrt( (1 / (|S|·c)) Σ_{k∈S} ‖P (a_k − b_k)‖² )

where a_k, b_k are residual vectors (state units/s), P is a c × n channel map (a row selection
or a linear change of units, :class:`Channels`) and S a set of sample indices (a time window).

* **Estimation accuracy** = RMSE(ĝ_online, g_target; P, {k : t_k ∈ [t_start, t_end)}), the
  online output against the target over the whole online run (``t_end`` = end of the run).
* **Model consistency (T_f)** = RMSE(ĝ^frz_{T_f}, g_target; P, {k : t_k ∈ [t_start, T_f)}),
  the frozen model re-evaluated on the history before T_f against the target.
* **Frozen vs online (T_f)** = RMSE(ĝ^frz_{T_f}, ĝ_online; P, same window): how well the
  frozen model "identically reproduces the historical estimation results" (Sec. 4.1).

``t_start`` = 0 is the primary definition (the thesis says "the whole history"); a later
``t_start`` (a "settled" window without the initial learning transient) is reported as an
alternative. Which channels P covers is a choice of the case (:mod:`simgap.evaluation.cases`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.reproducibility import ReproducibilityResult


@dataclass(frozen=True)
class Channels:
    """Which residual channels a metric covers and in which unit: y = P g.

    Attributes:
        name: short identifier, e.g. ``"momentum_rows"``.
        label: human-readable description for reports.
        unit: SI unit of y.
        matrix: P, shape (c, n): a row selection (0/1 entries) or a linear unit change
            (e.g. the bicycle's K⁻¹ from state units to axle forces in N).
    """

    name: str
    label: str
    unit: str
    matrix: np.ndarray

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=np.float64)
        if m.ndim != 2 or m.shape[0] < 1 or not np.all(np.isfinite(m)):
            raise EvaluationError(f"Channels.matrix must be a finite (c, n) array, got shape "
                                  f"{m.shape}")
        object.__setattr__(self, "matrix", m)

    @classmethod
    def rows(cls, name: str, label: str, unit: str, rows: Sequence[int], n: int) -> Channels:
        """Select ``rows`` of an n-vector."""
        p = np.zeros((len(rows), n))
        for i, r in enumerate(rows):
            if not 0 <= int(r) < n:
                raise EvaluationError(f"channel row {r} is outside 0..{n - 1}")
            p[i, int(r)] = 1.0
        return cls(name=name, label=label, unit=unit, matrix=p)

    def apply(self, g: np.ndarray) -> np.ndarray:
        """Map g of shape (K, n) to y = P g of shape (K, c)."""
        g = np.asarray(g, dtype=np.float64)
        if g.shape[-1] != self.matrix.shape[1]:
            raise EvaluationError(f"channels {self.name!r} expect {self.matrix.shape[1]} "
                                  f"residual entries, got {g.shape[-1]}")
        return g @ self.matrix.T


def rmse(a: np.ndarray, b: np.ndarray, channels: Channels | None = None) -> float:
    """Pooled RMSE of a − b over all samples and (selected) channels; NaN when empty.

    Args:
        a: (K, n) residuals.
        b: (K, n) residuals.
        channels: channel map P (default: all entries as they are).

    Returns:
        The RMSE in the channels' unit.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise EvaluationError(f"rmse needs equal shapes, got {a.shape} and {b.shape}")
    d = a - b if channels is None else channels.apply(a - b)
    if d.size == 0:
        return float("nan")
    return float(np.sqrt(np.mean(d * d)))


def window_mask(t: np.ndarray, t_start: float, t_stop: float) -> np.ndarray:
    """Boolean mask of samples with t_start ≤ t < t_stop (s)."""
    t = np.asarray(t, dtype=np.float64)
    return (t >= t_start - 1e-9) & (t < t_stop - 1e-9)


def reproducibility_metrics(result: ReproducibilityResult, channels: Channels | None = None,
                            *, t_start: float = 0.0, frozen_inputs: str | None = None
                            ) -> dict[str, Any]:
    """Accuracy, consistency and frozen-vs-online RMSEs of one result (module docstring).

    Args:
        result: a :class:`~simgap.evaluation.reproducibility.ReproducibilityResult`.
        channels: channel map P (default: all state rows).
        t_start: start of the window (s); 0 = the whole history.
        frozen_inputs: ``None`` (as the result was computed), ``"x_bar"`` (the online network
            inputs) or ``"state"`` (measured [x_k; u_k]): which history the frozen model
            re-evaluates; a different choice than the result's re-predicts with the frozen
            copy.

    Returns:
        ``{"accuracy": float, "consistency": {T_f: float}, "frozen_vs_online": {T_f: float},
        "n_samples": int}`` with T_f keys as strings of the freeze time in s (e.g. ``"180"``).
    """
    t = result.t
    t_end = float(t[-1]) + 1e-6 if t.size else 0.0
    m = window_mask(t, t_start, t_end + 1.0)
    acc = rmse(result.g_online[m], result.target[m], channels)
    cons: dict[str, float] = {}
    repro: dict[str, float] = {}
    for fm in result.frozen:
        th = t[:fm.n_history]
        mk = window_mask(th, t_start, fm.t_freeze)
        key = freeze_key(fm.t_freeze)
        g_frz = fm.g_frozen
        if frozen_inputs is not None and frozen_inputs != result.frozen_inputs:
            if frozen_inputs not in ("x_bar", "state"):
                raise EvaluationError(f"frozen_inputs must be 'x_bar' or 'state', got "
                                      f"{frozen_inputs!r}")
            src = result.x_bar if frozen_inputs == "x_bar" else result.x_bar_state
            g_frz = fm.identifier.predict(src[:fm.n_history]) if fm.n_history else g_frz
        cons[key] = rmse(g_frz[mk], result.target[:fm.n_history][mk], channels)
        repro[key] = rmse(g_frz[mk], result.g_online[:fm.n_history][mk], channels)
    return {"accuracy": acc, "consistency": cons, "frozen_vs_online": repro,
            "n_samples": int(np.count_nonzero(m))}


def freeze_key(t_freeze: float) -> str:
    """JSON key of a freeze time: ``180.0`` → ``"180"``, ``2.5`` → ``"2.5"``."""
    return f"{t_freeze:g}"
