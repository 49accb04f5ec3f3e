"""Does a candidate model predict held-out data better? A test with an honest floor.

Comparing a fitted effect's held-out error with the *sensor* noise floor calls any effect
significant as soon as the nominal model has structure error larger than the noise (a
car on circles: the error left after fitting is 10–20× the sensor noise). The test here
compares the two models' held-out losses directly, as in the Diebold–Mariano test of
predictive accuracy:

* the per-sample loss difference dₖ = e₀ₖ² − e₁ₖ² (nominal minus candidate, summed over
  channels after dividing each by its own scale) is averaged over blocks of B samples, with
  B ≥ 2τ (τ the integrated autocorrelation time of d, :mod:`.errormodel`), so that blocks
  are nearly independent;
* the statistic is the one-sided t of the block means, with (blocks − 1) degrees of
  freedom; its spread comes from the data's own loss differences, which include whatever
  model-structure error remains, not from an assumed sensor noise;
* the effect size is reported beside it (the held-out share of the loss removed), never
  used as a gate.

Blocks never straddle a gap: the caller passes segment labels and blocks are formed inside
each segment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from simgap.diagnosis.errormodel import autocorrelation_time
from simgap.errors import DiagnosisError

#: Fewest blocks for which a t statistic is reported.
MIN_BLOCKS = 4


@dataclass(frozen=True)
class GainTest:
    """Held-out predictive gain of a candidate over a baseline.

    Attributes:
        statistic: one-sided t of the mean loss difference (baseline − candidate).
        p_value: P(T ≥ statistic) under "no gain" (nan when it cannot be tested).
        blocks: number of independent blocks used.
        block_length: samples per block.
        share_removed: (L₀ − L₁)/L₀ on the held-out data (effect size; may be < 0).
        testable: False when the data hold too few independent blocks (say so, do not
            guess).
        reason: why it cannot be tested, when ``testable`` is False.
    """

    statistic: float
    p_value: float
    blocks: int
    block_length: int
    share_removed: float
    testable: bool
    reason: str = ""


def predictive_gain(e0: np.ndarray, e1: np.ndarray, segments: np.ndarray | None = None,
                    scale: np.ndarray | None = None) -> GainTest:
    """Test whether residuals ``e1`` (candidate) are smaller than ``e0`` (baseline).

    Args:
        e0: baseline held-out errors, shape (N,) or (N, C) (channel units).
        e1: candidate held-out errors, same shape.
        segments: optional (N,) integer labels of contiguous segments (blocks stay inside).
        scale: optional (C,) per-channel scale (channel units) so that channels add up as
            dimensionless losses; default each channel's baseline RMS.

    Returns:
        The :class:`GainTest`.

    Raises:
        DiagnosisError: on mismatched shapes or non-finite errors.
    """
    a = np.asarray(e0, dtype=np.float64)
    b = np.asarray(e1, dtype=np.float64)
    if a.shape != b.shape or a.ndim not in (1, 2):
        raise DiagnosisError(f"predictive_gain: error arrays of shapes {a.shape} and "
                             f"{b.shape} do not match")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise DiagnosisError("predictive_gain: non-finite held-out errors")
    if a.ndim == 1:
        a, b = a[:, None], b[:, None]
    if scale is None:
        scale = np.sqrt(np.mean(a**2, axis=0))
    scale = np.where(np.asarray(scale, dtype=np.float64) > 0, scale, 1.0)
    loss0 = np.sum((a / scale) ** 2, axis=1)
    loss1 = np.sum((b / scale) ** 2, axis=1)
    d = loss0 - loss1
    total0 = float(np.sum(loss0))
    share = float(np.sum(d) / total0) if total0 > 0 else 0.0
    seg = np.zeros(d.size, dtype=np.int64) if segments is None else np.asarray(segments)
    tau = autocorrelation_time(d)
    block = int(max(1, np.ceil(2.0 * tau)))
    means = []
    for label in np.unique(seg):
        ds = d[seg == label]
        nb = ds.size // block
        if nb:
            means.append(ds[: nb * block].reshape(nb, block).mean(axis=1))
    m = np.concatenate(means) if means else np.zeros(0)
    if m.size < MIN_BLOCKS:
        return GainTest(statistic=float("nan"), p_value=float("nan"), blocks=int(m.size),
                        block_length=block, share_removed=share, testable=False,
                        reason=f"the held-out part holds {m.size} independent blocks of "
                               f"{block} samples (needs {MIN_BLOCKS})")
    sd = float(np.std(m, ddof=1))
    if sd == 0.0:
        t = float("inf") if m.mean() > 0 else (0.0 if m.mean() == 0 else float("-inf"))
    else:
        t = float(m.mean() / (sd / np.sqrt(m.size)))
    p = float(stats.t.sf(t, df=m.size - 1))
    return GainTest(statistic=t, p_value=p, blocks=int(m.size), block_length=block,
                    share_removed=share, testable=True)
