"""Which rows of a recording fit the effects and which test them.

A split at 70 % of the *time* fails on real logs: a free decay puts the large amplitudes in
training and only the small ones (or only stick phases, which the fit masks) in the test
part, so nothing can gain there; a gap in the log lets a filter window straddle two
unrelated stretches. The split here works on *usable rows* only:

* rows are the residual grid thinned to every ``window // 2``-th sample (the smoothing
  filter correlates neighbours), away from the recording's ends and from gaps by one filter
  window, and kept only where at least one channel is unmasked;
* the **outer test part** is the last ``1 − train_fraction`` of the usable rows (not of the
  time): it is never seen by the fit or the selection and gives the report's held-out
  numbers;
* the rows before it (the **fit part**) are cut into :data:`BLOCKS` contiguous blocks that
  never straddle a gap; an evenly spread ``1 − train_fraction`` of these blocks *validates*
  the selection, the others train it. Interleaved blocks see the same operating regions as
  the training blocks (amplitudes of a decay, both directions of a car that turns left and
  right in turns, the speeds of a ramp), which a single cut in time does not; the chosen
  terms are then refitted on the whole fit part.

Whether a part can test a term at all is measured by :func:`information_share`: the energy
of the term's regressors per held-out row relative to per training row. Where it is ~0 the
held-out part holds no information about the term, and the report says so instead of
calling the term useless.

A share above 0 is not yet enough: on a free decay the last usable rows hold the small
amplitudes, where a damping correction that is plain early on sits below the noise. Whether
the part *could* confirm a term is a power question, answered by :func:`detectable`: the
test statistic the part would give if the term were real at its fitted size (its held-out
contribution added back to the errors left with it) against the critical value of the
test. Below it, a real effect of that size would be missed at least half the time; when
the part also holds much less of the term's regressor energy per row than the fit part
(:data:`LOW_INFORMATION`), it holds too little information about the term to test it, and
the report says "cannot test" rather than "not confirmed" or "0 % explained". A term that
is merely small (as undetectable on a part as informative as the fit part) is tested as
usual: its validation gain must replicate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from simgap.diagnosis.significance import likelihood_ratio

#: Contiguous blocks the fit part is cut into (an evenly spread share validates).
BLOCKS = 20
#: Fewest thinned rows in a block.
MIN_BLOCK_ROWS = 5
#: Held-out regressor energy per row below this share of the training one: no information.
NO_INFORMATION = 1e-6
#: Held-out regressor energy per row below this share of the fit part's: a part that could
#: not detect a term there is "cannot test" (it holds too little of what fitted the term),
#: not evidence against it (:func:`detectable`).
LOW_INFORMATION = 0.25
#: A time step longer than this many median steps is a gap in the log.
GAP_STEPS = 5.0


@dataclass(frozen=True)
class Split:
    """Row indices (into the residual grid) of each part.

    Attributes:
        train: rows that fit the candidates during selection.
        valid: rows that score the candidates during selection (interleaved blocks).
        valid_block: block label of each ``valid`` row (tests keep blocks apart).
        fit: train ∪ valid, in time order: the final fit of the chosen terms.
        test: the outer held-out part (last usable rows).
        t_split: time (s) between the fit part and the test part.
    """

    train: np.ndarray
    valid: np.ndarray
    valid_block: np.ndarray
    fit: np.ndarray
    test: np.ndarray
    t_split: float


def usable_rows(n: int, window: int, mask: np.ndarray, segment: np.ndarray | None
                ) -> np.ndarray:
    """Thinned grid rows away from the ends and gaps, with at least one unmasked channel.

    Args:
        n: grid length.
        window: smoothing window (samples).
        mask: (n, C) fit mask (1 usable, 0 masked).
        segment: (n,) integer segment label per row (a new label after each gap), or None.
    """
    step, edge = max(1, window // 2), window
    rows = np.arange(edge, n - edge, step)
    if segment is not None and len(segment) == n:
        seg = np.asarray(segment)
        near = np.zeros(n, dtype=bool)
        for b in np.flatnonzero(np.diff(seg) != 0):
            near[max(0, b - edge + 1):b + edge + 1] = True
        rows = rows[~near[rows]]
    return rows[np.asarray(mask)[rows].any(axis=1)] if len(rows) else rows


def split_rows(t: np.ndarray, rows: np.ndarray, segment: np.ndarray | None,
               train_fraction: float) -> Split:
    """Split usable rows into training, validation (interleaved blocks) and outer test.

    Args:
        t: grid times (s).
        rows: usable rows (:func:`usable_rows`), increasing.
        segment: (n,) segment label per grid row, or None for one segment.
        train_fraction: share of the usable rows before the outer test part, and share of
            the blocks of that part that train.

    Raises:
        ValueError: too few usable rows for the three parts.
    """
    if not 0.0 < train_fraction < 1.0:
        raise ValueError(f"train_fraction must be in (0, 1), got {train_fraction!r}")
    k = int(round(train_fraction * len(rows)))
    if k < 4 * MIN_BLOCK_ROWS or len(rows) - k < 10:
        raise ValueError(f"recording too short: {len(rows)} usable rows (after masking and "
                         "thinning) cannot be split into training, validation and test parts")
    fit, test = rows[:k], rows[k:]
    seg = np.zeros(len(t), dtype=np.int64) if segment is None or len(segment) != len(t) \
        else np.asarray(segment)
    size = max(MIN_BLOCK_ROWS, len(fit) // BLOCKS)
    # a block ends every `size` rows and wherever the segment changes
    labels = np.zeros(len(fit), dtype=np.int64)
    block, count = 0, 0
    for i in range(len(fit)):
        if i and (count >= size or seg[fit[i]] != seg[fit[i - 1]]):
            block, count = block + 1, 0
        labels[i] = block
        count += 1
    nb = block + 1
    n_valid = min(nb - 1, max(1, int(round((1.0 - train_fraction) * nb))))
    chosen = np.unique(np.round((np.arange(n_valid) + 0.5) / n_valid * nb - 0.5).astype(int))
    is_valid = np.isin(labels, chosen)
    return Split(train=fit[~is_valid], valid=fit[is_valid], valid_block=labels[is_valid],
                 fit=fit, test=test, t_split=float(0.5 * (t[fit[-1]] + t[test[0]])))


def gap_segments(t_recorded: np.ndarray, t_grid: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Segment labels of grid rows from the recorded time stamps, and rows inside gaps.

    The fallback when the prepared residual carries no ``segment`` array: a recorded time
    step longer than :data:`GAP_STEPS` median steps is a gap; grid rows strictly inside it
    were interpolated, not measured.

    Args:
        t_recorded: the recording's time stamps (s), increasing.
        t_grid: the residual grid's times (s).

    Returns:
        (segment label per grid row, True for grid rows inside a gap).
    """
    tr = np.asarray(t_recorded, dtype=np.float64)
    tg = np.asarray(t_grid, dtype=np.float64)
    if tr.size < 3:
        return np.zeros(tg.size, dtype=np.int64), np.zeros(tg.size, dtype=bool)
    step = np.diff(tr)
    gaps = np.flatnonzero(step > GAP_STEPS * float(np.median(step)))
    seg = np.searchsorted(tr[gaps + 1], tg, side="right").astype(np.int64)
    inside = np.zeros(tg.size, dtype=bool)
    for g in gaps:
        inside |= (tg > tr[g]) & (tg < tr[g + 1])
    return seg, inside


def information_share(regressors: np.ndarray, held_out: np.ndarray, train: np.ndarray
                      ) -> float:
    """Largest held-out/training ratio of regressor energy per row, over a term's regressors.

    Args:
        regressors: (N, C, k) regressors of one term on the grid (any units).
        held_out: held-out rows.
        train: training rows.

    Returns:
        max over regressors of (mean square on held-out rows)/(mean square on training
        rows); inf when a regressor is zero on the training rows but not held out, 1.0 when
        every regressor is zero on both (nothing to test either way).
    """
    x = np.asarray(regressors, dtype=np.float64)
    if x.ndim == 2:
        x = x[:, :, None]
    best = 0.0
    any_train = False
    for j in range(x.shape[2]):
        e_tr = float(np.mean(x[train, :, j] ** 2)) if len(train) else 0.0
        e_ho = float(np.mean(x[held_out, :, j] ** 2)) if len(held_out) else 0.0
        if e_tr > 0:
            any_train = True
            best = max(best, e_ho / e_tr)
        elif e_ho > 0:
            return float("inf")
    return best if any_train else 1.0


@dataclass(frozen=True)
class Power:
    """Whether a held-out part could detect a term of its fitted size.

    Attributes:
        detectable: the expected statistic reaches the critical value (and the part holds
            enough effective samples to test at all).
        expected: likelihood-ratio statistic the part gives if the term is real at its
            fitted size (nan when the part cannot be tested at all).
        critical: χ²(dof) critical value at the test's level.
    """

    detectable: bool
    expected: float
    critical: float


def detectable(errors: np.ndarray, contribution: np.ndarray, dof: int, alpha: float
               ) -> Power:
    """Could a held-out part confirm a term? (see the module docstring).

    Args:
        errors: (N, C) whitened errors the fit *with* the term leaves on the part.
        contribution: (N, C) the term's whitened contribution on the part.
        dof: the term's number of parameters.
        alpha: level of the confirmation test.

    Returns:
        The :class:`Power`: the statistic of :func:`~.significance.likelihood_ratio` between
        ``errors + contribution`` (the term left out, were it real) and ``errors``.
    """
    e = np.asarray(errors, dtype=np.float64)
    g = likelihood_ratio(e + np.asarray(contribution, dtype=np.float64), e, dof)
    crit = float(stats.chi2.isf(alpha, max(int(dof), 1)))
    return Power(detectable=bool(g.testable and g.statistic >= crit),
                 expected=float(g.statistic), critical=crit)
