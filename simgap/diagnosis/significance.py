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

The block t test needs many blocks; a short validation part (a few seconds) holds only a
handful, and then even an effect that removes 97 % of a channel's error is "not
significant". :func:`likelihood_ratio` is the more powerful equivalent the selection uses:
per channel, a Gaussian held-out log-likelihood ratio whose variance is the error the
candidate leaves there (model-structure error included, never the sensor noise alone), with
the samples counted as N/τ effective ones (τ the autocorrelation time of that error,
:func:`.errormodel.effective_samples`), summed over channels and referred to χ² with as many
degrees of freedom as the candidate has parameters. On held-out data a useless extra term
*raises* the error, so under "no gain" the statistic is centred below zero and χ²(k) is a
conservative reference.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from simgap.diagnosis.errormodel import autocorrelation_time, effective_samples
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


def _pair(e0: np.ndarray, e1: np.ndarray, who: str) -> tuple[np.ndarray, np.ndarray]:
    """Both error arrays as (N, C) floats; DiagnosisError on a shape mismatch or non-finite."""
    a = np.asarray(e0, dtype=np.float64)
    b = np.asarray(e1, dtype=np.float64)
    if a.shape != b.shape or a.ndim not in (1, 2):
        raise DiagnosisError(f"{who}: error arrays of shapes {a.shape} and "
                             f"{b.shape} do not match")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise DiagnosisError(f"{who}: non-finite held-out errors")
    return (a[:, None], b[:, None]) if a.ndim == 1 else (a, b)


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
    a, b = _pair(e0, e1, "predictive_gain")
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


#: Fewest effective held-out samples (per channel that holds any error) for a test.
MIN_EFFECTIVE = 5.0


@dataclass(frozen=True)
class LikelihoodRatio:
    """Held-out likelihood ratio of a candidate over a baseline, channel by channel.

    Attributes:
        statistic: Σ_c n_eff,c · ln(SSE₀,c / SSE₁,c) (nan when it cannot be tested).
        p_value: P(χ²(dof) ≥ statistic); 1 when the statistic is ≤ 0.
        dof: parameters the candidate adds.
        effective_samples: n_eff per channel (N/τ of the candidate's held-out error).
        shares: (SSE₀,c − SSE₁,c)/SSE₀,c per channel (effect size; may be < 0).
        share_removed: mean of ``shares`` over all channels (a channel the candidate does
            not change counts 0, so that candidates acting on different channels compare).
        testable: False when the held-out part is too small to test.
        reason: why it cannot be tested, when ``testable`` is False.
    """

    statistic: float
    p_value: float
    dof: int
    effective_samples: tuple[float, ...]
    shares: tuple[float, ...]
    share_removed: float
    testable: bool
    reason: str = ""


def likelihood_ratio(e0: np.ndarray, e1: np.ndarray, dof: int) -> LikelihoodRatio:
    """Test whether held-out errors ``e1`` (candidate) are smaller than ``e0`` (baseline).

    Args:
        e0: baseline held-out errors, (N,) or (N, C), channel units (any scale per channel:
            each channel is compared with itself).
        e1: candidate held-out errors, same shape.
        dof: number of parameters the candidate adds (≥ 1).

    Returns:
        The :class:`LikelihoodRatio`.

    Raises:
        DiagnosisError: on mismatched shapes or non-finite errors.
    """
    a, b = _pair(e0, e1, "likelihood_ratio")
    dof = max(int(dof), 1)
    stat, n_effs, shares, used = 0.0, [], [], []
    for c in range(a.shape[1]):
        s0, s1 = float(a[:, c] @ a[:, c]), float(b[:, c] @ b[:, c])
        if np.array_equal(a[:, c], b[:, c]):   # the candidate does not act here
            n_effs.append(0.0)
            shares.append(0.0)
            continue
            n_effs.append(0.0)
            shares.append(0.0)
            continue
        n_eff = effective_samples(b[:, c]) if s1 > 0 else float(a.shape[0])
        n_effs.append(n_eff)
        shares.append((s0 - s1) / s0 if s0 > 0 else float("-inf"))
        used.append(c)
        if s1 == 0.0:
            stat = float("inf")
        elif s0 == 0.0:
            stat = float("-inf")
        else:
            stat += n_eff * float(np.log(s0 / s1))
    share = float(np.mean(shares)) if shares else 0.0
    if not used:   # the candidate changes nothing held out (e.g. fitted to zero)
        return LikelihoodRatio(statistic=0.0, p_value=1.0, dof=dof,
                               effective_samples=tuple(n_effs), shares=tuple(shares),
                               share_removed=0.0, testable=True)
    if min(n_effs[c] for c in used) < MIN_EFFECTIVE:
        n_min = min((n_effs[c] for c in used), default=0.0)
        return LikelihoodRatio(statistic=float("nan"), p_value=float("nan"), dof=dof,
                               effective_samples=tuple(n_effs), shares=tuple(shares),
                               share_removed=share, testable=False,
                               reason=f"the held-out part holds {n_min:.1f} effective "
                                      f"samples (needs {MIN_EFFECTIVE:g})")
    p = float(stats.chi2.sf(stat, dof)) if stat > 0 else 1.0
    return LikelihoodRatio(statistic=float(stat), p_value=p, dof=dof,
                           effective_samples=tuple(n_effs), shares=tuple(shares),
                           share_removed=share, testable=True)


#: Quantile bins of one operating-point variable in :func:`structure_test`.
STRUCTURE_BINS = 8


@dataclass(frozen=True)
class StructureTest:
    """Does a channel's residual depend on the operating point? Tested on held-out rows.

    Attributes:
        p_value: smallest per-variable p-value times the number of variables tried
            (Bonferroni), capped at 1; nan when it cannot be tested.
        statistic: the likelihood-ratio statistic of that variable.
        dof: its degrees of freedom (bins whose mean was fitted).
        variable: the variable whose binned means predict the held-out residual best.
        share_removed: share of the held-out residual's mean square those means remove
            (effect size; may be < 0).
        effective_samples: n_eff of that variable's held-out error (N/τ).
        testable: False when no variable could be tested.
        reason: why, when ``testable`` is False.
    """

    p_value: float
    statistic: float
    dof: int
    variable: str | None
    share_removed: float
    effective_samples: float
    testable: bool
    reason: str = ""

    def significant(self, alpha: float) -> bool:
        """Whether the residual's dependence on the operating point is significant."""
        return bool(self.testable and self.p_value < alpha and self.share_removed > 0)


def structure_test(residual: np.ndarray, variables: dict[str, np.ndarray],
                   fit_rows: np.ndarray, test_rows: np.ndarray,
                   bins: int = STRUCTURE_BINS) -> StructureTest:
    """Test whether one channel's residual is a function of the operating point.

    The nominal model says the residual is measurement error, whatever its spectrum: zero
    mean at every operating point. A mismatch is physics: a function of where the system
    is (friction of the velocity, a spring of the position, saturation of a slip angle).
    Coloured sensor noise, interpolation errors of jittered stamps or a controller's
    torque noise can make the residual many times the white-noise floor, yet they are not
    predictable from the operating point on data the prediction was not made from. So,
    per variable x: the residual's means in ``bins`` quantile bins of x are fitted on
    ``fit_rows`` and predict the residual on ``test_rows``; the held-out likelihood ratio
    of that prediction over "zero" (:func:`likelihood_ratio`: the variance is the error
    left, so the floor is the residual's own structure and noise, never an assumed sensor
    noise; N/τ effective samples; χ² with one degree of freedom per bin) gives a p-value;
    the smallest over the variables, times their number, is the channel's.

    Variables must not share the residual's measurement error: an acceleration estimated
    from the same noisy velocity as the residual predicts its noise (errors in variables);
    the caller passes positions, velocities and other undifferentiated quantities only.

    Args:
        residual: one channel's residual on the grid (N,), channel units.
        variables: name -> values on the grid (N,), any units.
        fit_rows: rows whose bin means are fitted.
        test_rows: held-out rows they are tested on.
        bins: quantile bins per variable.

    Returns:
        The :class:`StructureTest`.
    """
    r = np.asarray(residual, dtype=np.float64)
    fit_rows, test_rows = np.asarray(fit_rows), np.asarray(test_rows)
    best: LikelihoodRatio | None = None
    best_name, tried = None, 0
    for name, x in variables.items():
        x = np.asarray(x, dtype=np.float64)
        if fit_rows.size < 2 * bins or test_rows.size == 0 or np.ptp(x[fit_rows]) == 0:
            continue
        edges = np.unique(np.quantile(x[fit_rows], np.linspace(0.0, 1.0, bins + 1)))
        if edges.size < 3:
            continue
        nb = edges.size - 1
        k_fit = np.clip(np.searchsorted(edges, x[fit_rows], side="right") - 1, 0, nb - 1)
        k_test = np.clip(np.searchsorted(edges, x[test_rows], side="right") - 1, 0, nb - 1)
        count = np.bincount(k_fit, minlength=nb)
        means = np.bincount(k_fit, weights=r[fit_rows], minlength=nb) / np.maximum(count, 1)
        e0 = r[test_rows]
        g = likelihood_ratio(e0, e0 - means[k_test], dof=nb)
        tried += 1
        if g.testable and (best is None or g.p_value < best.p_value
                           or (g.p_value == best.p_value and g.statistic > best.statistic)):
            best, best_name = g, name
    if best is None:
        return StructureTest(p_value=float("nan"), statistic=float("nan"), dof=0,
                             variable=None, share_removed=0.0, effective_samples=0.0,
                             testable=False,
                             reason="no operating-point variable could be tested held out")
    return StructureTest(p_value=float(min(1.0, best.p_value * tried)),
                         statistic=best.statistic, dof=best.dof, variable=best_name,
                         share_removed=best.share_removed,
                         effective_samples=float(best.effective_samples[0]), testable=True)


def effective_tests(directions: Sequence[np.ndarray | None]) -> float:
    """Effective number of independent tests among correlated hypotheses (Galwey 2009).

    Hypotheses tried in one selection round are not independent tests: a Coulomb friction,
    the Coulomb + viscous family that contains it and a dead zone that equals it on a
    command of one sign fit nearly the same held-out direction, and under "no effect" their
    statistics move together. Bonferroni over all of them counts one question several
    times. Here each hypothesis is represented by its held-out direction (the change of the
    held-out prediction it makes, flattened over rows and channels); the eigenvalues λᵢ ≥ 0
    of the correlation matrix of these M directions give M_eff = (Σᵢ √λᵢ)² / Σᵢ λᵢ (Galwey,
    Genet. Epidemiol. 33, 2009): M orthogonal directions count M, M identical (or
    sign-flipped) ones count 1, and the count moves continuously in between (Li & Ji's
    rule jumps: two directions correlated 0.999 count 2.0 there, identical ones 1). A
    hypothesis with no direction (``None`` or constant) counts as one test of its own.

    Args:
        directions: per hypothesis, its held-out direction (any units; only correlations
            are read), all of one length, or None.

    Returns:
        M_eff, between 1 and the number of hypotheses (0 when there are none).
    """
    vecs = [np.ravel(d) for d in directions
            if d is not None and np.size(d) > 1 and np.std(d) > 0]
    lone = len(directions) - len(vecs)
    if len(vecs) <= 1:
        return float(len(vecs) + lone)
    # pairwise, in double precision, two directions at a time (no stacked copy of them all)
    corr = np.corrcoef(np.stack([np.asarray(v, dtype=np.float64) for v in vecs]))
    lam = np.clip(np.linalg.eigvalsh(corr), 0.0, None)
    m_eff = float(np.sum(np.sqrt(lam)) ** 2 / np.sum(lam))
    return float(min(max(m_eff, 1.0), len(vecs))) + lone
