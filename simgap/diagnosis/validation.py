"""Which rows of a recording fit the effects and which test them.

A split at 70 % of the *time* fails on real logs: a free decay puts the large amplitudes in
training and only the small ones (or only stick phases, which the fit masks) in the test
part, so nothing can gain there; a gap in the log lets a filter window straddle two
unrelated stretches. The split here works on *usable rows* only, in blocks assigned by
operating region:

* rows are the residual grid thinned to every ``window // 2``-th sample (the smoothing
  filter correlates neighbours), away from the recording's ends and from gaps by one filter
  window, and kept only where at least one channel is unmasked; where these are few (a long
  window), the split is made on them and each is then read as up to :data:`MAX_REFINE`
  finer rows in its own part and block (:func:`refinement`, :func:`refine`);
* these rows are cut into contiguous blocks that never straddle a gap (:data:`BLOCKS` of
  the rows before the tail, at least :data:`MIN_BLOCK_ROWS` rows, i.e. 2.5 filter windows);
  each block gets an **operating region** (:func:`block_regions`: the sign of each
  direction variable — joint velocities, a car's lateral velocity and yaw rate — and the
  amplitude level of their size) and, where the inputs are held in some blocks and move in
  others, an **input-activity** stratum (:func:`block_activity`: quiet, or the level of the
  inputs' rate), and the blocks, ordered by activity, region, then time, are assigned by
  systematic sampling: every part holds each region and the input's transients in
  proportion (a steering lag's or an input delay's information lies in the transients);
* the **outer held-out part** (``test``: report numbers and the final confirmation, never
  fitted and never used to pick) is the last ``1 − train_fraction`` of the usable rows (the
  *tail*, which the rollout comparison needs contiguous) when they span the operating
  regions of the rows before them (:func:`tail_covers`: both directions and the large
  amplitudes, read from the operating variables only, never from the residual) — a
  stationary excitation, where a cut in time loses nothing; otherwise (a decay, a log
  that turns one way then the other) it is a third of that share as blocks spread over
  the regions (:data:`SPREAD_SHARE`), with :data:`GUARD_ROWS` rows on each side in no
  part, plus a shorter tail;
* of the other blocks (the **fit part**), a ``1 − train_fraction`` share *validates* the
  selection, the others train it; the chosen terms are then refitted on the whole fit part.
  The fit part's blocks are also dealt into K **cross-validation folds**
  (:func:`fit_folds`, :attr:`Split.fold`): the validation blocks are fold 0, the training
  blocks are dealt in turn to folds 1 … K−1 in the same activity × region × time order
  (K = 3 at a 70/30 split), so that every fold holds each region and the input's
  transients in proportion.

Why blocks by region rather than a cut in time: a free decay puts the large amplitudes in
training and only the small ones (or only stick phases, which the fit masks) in a late
test part, where a damping correction fitted on the large swings sits below the noise and
can only be called "cannot test"; a log that turns left, then right, or ramps its speed,
trains and tests on different regions. Blocks of one region spread over the parts see the
same amplitudes, speeds and directions. Why contiguous blocks, not single rows: the
residual's errors are autocorrelated (filter, model-structure error), so a held-out row
next to a training row is not independent of it; within a block only the edges touch
other parts, and the confirmation blocks' edges are guarded.

With ``fit.CROSS_VALIDATE`` (``Fitter(cross_validate=True)``; off by default, see
below) the selection's tests read **blocked K-fold cross-validation** over these folds
(:meth:`.fit.Fitter.cv_errors`): every fit-part block is held out
once, predicted by the fit on the other folds, and the held-out errors of all folds are
pooled into one likelihood-ratio test (:func:`.significance.likelihood_ratio`: N/τ
effective samples from the pooled errors' autocorrelation, χ² with the hypothesis'
parameters). One stratified validation part tested a hypothesis on 30 % of the fit part;
the pooled folds test it on all of it (three times the held-out rows), and a pick no
longer rests on which blocks happened to validate (measured: the coloured-noise torque
bias of seed 2 went from p = 5.6e-4, above its level, to p = 1.6e-11; on half-window rows
the coloured-noise inertia, which lost to the spring by 6 % on the one part, now wins).
It costs little: the linear parameters of each fold come from per-fold sums xᵀx, xᵀy of
the whitened design (:func:`.fit.normal_lstsq`), one design per hypothesis on the fit
rows and K small bounded problems; the nonlinear parameters (Stribeck vs, a delay, a dead
zone, a steering lag) are not refitted per fold but held at the values fitted on the
training blocks (folds 1 … K−1). For fold 0 that is an honest held-out fit; folds 1 … K−1
saw their own rows in those one or two numbers. The leak is an in-sample fit of one or
two parameters spread over the whole fit part, which the χ² reference, counting every
parameter of the hypothesis against a held-out statistic centred below zero, absorbs;
refitting them per fold would multiply the nonlinear fits by K. The outer test part is
never touched by the folds: every claim still has to replicate there. Within a block
only the edges touch other folds (no guard rows between folds, as between training and
validation before). Why it is not the default: the extra power is real, and it also finds
real secondary structure that the vocabulary misnames. Measured
(``benchmarks/results/diagnosis_s8-cv_causes.md``): beside a vehicle mass mismatch a tire
saturation now gains on the folds *and* replicates on the outer test part, and so does a
viscous friction at joint 1 beside a 100 Hz Stribeck friction at joint 2 (noise presets:
2 rows with extra effects, 0 without cross-validation, after refusing a refit on a
plausibility limit, which removed two more and restored the proof); 240 clean recordings
stay at 0 claims. By default the selection tests on the validation blocks alone, as
before (bit for bit).

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
usual: its validation gain must replicate. The same rule words the selection's tests: a
hypothesis whose validation gain was not significant, on validation blocks that hold less
than :data:`LOW_INFORMATION` of its training regressor energy per row and could not have
detected it at its fitted size, is "cannot test", not "rejected"
(:meth:`.fit.Fitter._cannot_test`; wording only, the selection is unchanged).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from simgap.diagnosis.significance import likelihood_ratio

#: Contiguous blocks the rows before the tail are cut into (assigned by region).
BLOCKS = 20
#: Fewest thinned rows in a block.
MIN_BLOCK_ROWS = 5
#: Held-out regressor energy per row below this share of the training one: no information.
NO_INFORMATION = 1e-6
#: Held-out regressor energy per row below this share of the fit part's: a part that could
#: not detect a term there is "cannot test" (it holds too little of what fitted the term),
#: not evidence against it (:func:`detectable`).
LOW_INFORMATION = 0.25
#: Share of the outer held-out rows taken as blocks spread over the operating regions (the
#: rest is the tail, the last usable rows, which the rollout comparison needs contiguous).
SPREAD_SHARE = 1.0 / 3.0
#: A region (one sign of a direction variable, or the large amplitudes) holding this share
#: of the rows before the tail must hold at least :data:`COVER_RATIO` of that share of the
#: tail for the cut in time to be kept (:func:`tail_covers`).
REGION_SHARE = 0.2
COVER_RATIO = 0.25
#: Amplitude levels of the operating regions (:func:`block_regions`).
AMPLITUDE_LEVELS = 3
#: A block whose input-rate RMS is below this share of the log's is *quiet* (its rate
#: energy per row below 1 % of the log's mean): input-driven terms (a steering lag, an
#: input delay) hold no information there (:func:`block_activity`).
QUIET = 0.1
#: Fewest blocks of each kind (quiet, moving) for the activity stratum to be used: with 30 %
#: of the blocks held out, three blocks give every part a share by systematic sampling.
MIN_STRATUM_BLOCKS = 3
#: Activity levels of the moving blocks (quantiles of their input-rate RMS).
ACTIVITY_LEVELS = 2
#: Thinned rows on each side of a confirmation block left out of every part: the thinning
#: step is half a filter window, so two rows cover the window through which the smoothing
#: filter correlates a held-out row with its neighbours.
GUARD_ROWS = 2
#: A time step longer than this many median steps is a gap in the log.
GAP_STEPS = 5.0
#: Fewest usable rows the fits read before the thinning is refined (:func:`refinement`).
MIN_ROWS = 300
#: Finest thinning: half a window divided by this (an eighth of the window).
MAX_REFINE = 4


@dataclass(frozen=True)
class Split:
    """Row indices (into the residual grid) of each part.

    Attributes:
        train: rows that fit the candidates during selection.
        valid: rows that score the candidates during selection (blocks spread over the
            operating regions).
        valid_block: block label of each ``valid`` row (tests keep blocks apart).
        fit: train ∪ valid, in time order: the final fit of the chosen terms.
        test: every outer held-out row, in time order: the confirmation blocks and the
            tail (never fitted, never used to pick).
        t_split: time (s) between the fit part and the tail.
        tail: the last usable rows (after ``t_split``): the rollout comparison's part.
        confirm_block: block label of each ``test`` row (-1 for the tail).
        guard: rows next to a confirmation block, in no part (the smoothing filter
            correlates them with the block).
        fold: cross-validation fold of each ``fit`` row (:func:`fit_folds`): 0 for the
            validation blocks, 1 … K−1 for the training blocks, spread over the same
            activity × region × time order; empty when not made.
    """

    train: np.ndarray
    valid: np.ndarray
    valid_block: np.ndarray
    fit: np.ndarray
    test: np.ndarray
    t_split: float
    tail: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    confirm_block: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    guard: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    fold: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def folds(self) -> int:
        """Number of cross-validation folds of the fit part (0 when none were made)."""
        return int(self.fold.max()) + 1 if len(self.fold) else 0


def fit_folds(rest: np.ndarray, chosen: np.ndarray) -> dict[int, int]:
    """Fold of each fit-part block: the validation blocks, then the others spread.

    The validation blocks (``chosen``, a systematic sample of ``rest``) are fold 0; the
    other blocks, in the order of ``rest`` (input activity, operating region, then time),
    are dealt to folds 1 … K−1 in turn, with K − 1 the number of validation-sized shares
    they hold (2 at a 70/30 split: three folds of about equal size). Dealing in that order
    is systematic sampling again: each fold holds every region and activity level in
    proportion, as the validation blocks do.

    Args:
        rest: the fit part's blocks in stratum order.
        chosen: the validation blocks (a subset of ``rest``).

    Returns:
        block label -> fold.
    """
    held = set(np.asarray(chosen).tolist())
    others = [int(b) for b in rest if b not in held]
    k = max(1, int(round(len(others) / max(len(chosen), 1))))
    out = {int(b): 0 for b in chosen}
    out.update({b: 1 + i % k for i, b in enumerate(others)})
    return out


def usable_rows(n: int, window: int, mask: np.ndarray, segment: np.ndarray | None,
                step: int | None = None) -> np.ndarray:
    """Thinned grid rows away from the ends and gaps, with at least one unmasked channel.

    Args:
        n: grid length.
        window: smoothing window (samples).
        mask: (n, C) fit mask (1 usable, 0 masked).
        segment: (n,) integer segment label per row (a new label after each gap), or None.
        step: thinning step (samples); default half the window.
    """
    step, edge = max(1, window // 2 if step is None else int(step)), window
    rows = np.arange(edge, n - edge, step)
    if segment is not None and len(segment) == n:
        seg = np.asarray(segment)
        near = np.zeros(n, dtype=bool)
        for b in np.flatnonzero(np.diff(seg) != 0):
            near[max(0, b - edge + 1):b + edge + 1] = True
        rows = rows[~near[rows]]
    return rows[np.asarray(mask)[rows].any(axis=1)] if len(rows) else rows


def block_regions(regions: np.ndarray | None, rows: np.ndarray, labels: np.ndarray,
                  levels: int = AMPLITUDE_LEVELS) -> np.ndarray:
    """Operating-region stratum of each block: direction pattern × amplitude level.

    Args:
        regions: (n, R) direction variables on the grid (velocities, a car's lateral
            velocity and yaw rate; any units), or None.
        rows: the rows the blocks are made of.
        labels: block label (0 … B−1) of each row.
        levels: amplitude levels (quantiles over the blocks).

    Returns:
        (B,) integer stratum per block: the sign of each variable's block mean (direction)
        and the quantile level of the block's RMS of the variables, each divided by its own
        RMS over ``rows`` (amplitude, speed). All zeros when ``regions`` is None.
    """
    nb = int(labels.max()) + 1 if len(labels) else 0
    if regions is None or nb == 0:
        return np.zeros(nb, dtype=np.int64)
    x = np.asarray(regions, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    x = x[rows]
    scale = np.sqrt(np.mean(x**2, axis=0))
    x = x / np.where(scale > 0, scale, 1.0)
    count = np.bincount(labels, minlength=nb).astype(float)
    code = np.zeros(nb, dtype=np.int64)
    for j in range(x.shape[1]):
        mean = np.bincount(labels, weights=x[:, j], minlength=nb) / count
        code = 2 * code + (mean > 0)
    amp = np.sqrt(np.bincount(labels, weights=np.sum(x**2, axis=1), minlength=nb) / count)
    level = np.minimum((np.argsort(np.argsort(amp, kind="stable"), kind="stable") * levels)
                       // max(nb, 1), levels - 1)
    return code * levels + level


def block_activity(rates: np.ndarray | None, rows: np.ndarray, labels: np.ndarray,
                   quiet: float = QUIET) -> np.ndarray:
    """Input-activity stratum of each block: 0 where the inputs are held, ≥ 1 where they move.

    A term driven by the input's changes (a steering lag, an input delay) has its
    information where the input moves: on steady circles, the steering ramps between held
    levels (about a fifth of the log). The direction × amplitude regions
    (:func:`block_regions`) do not see them, and a systematic sample of blocks can then miss
    every ramp (measured: a steering lag's validation blocks held 0.09 % of its training
    regressor energy per row, its test "rejected" with p = 1). The activity stratum is used
    only when the log holds both quiet blocks (input-rate RMS below ``quiet`` times the
    log's) and moving ones, each at least :data:`MIN_STRATUM_BLOCKS` blocks; an excitation
    that keeps moving (a multisine, a chirp, an arm log with one short hold) has no such
    quiet stretch and its split is unchanged.

    Args:
        rates: (n, K) input rates on the grid (each input's time derivative; any units),
            or None.
        rows: the rows the blocks are made of.
        labels: block label (0 … B−1) of each row.
        quiet: a block is quiet below this share of the input-rate RMS over ``rows``.

    Returns:
        (B,) 0 for a quiet block, 1 … :data:`ACTIVITY_LEVELS` for a moving one (the
        quantile level of its input-rate RMS among the moving blocks); all zeros when
        ``rates`` is None, when the inputs never move, or when either kind holds fewer than
        :data:`MIN_STRATUM_BLOCKS` blocks.
    """
    nb = int(labels.max()) + 1 if len(labels) else 0
    none = np.zeros(nb, dtype=np.int64)
    if rates is None or nb == 0:
        return none
    x = np.asarray(rates, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    x = x[rows]
    scale = np.sqrt(np.mean(x**2, axis=0))
    x = x[:, scale > 0] / scale[scale > 0]
    if x.shape[1] == 0:
        return none
    count = np.bincount(labels, minlength=nb).astype(float)
    level = np.sqrt(np.bincount(labels, weights=np.mean(x**2, axis=1), minlength=nb) / count)
    moving = level >= quiet
    least = MIN_STRATUM_BLOCKS   # one or two blocks are no stratum to spread over parts
    if not least <= int(moving.sum()) <= nb - least:
        return none
    # moving blocks by activity level (rank halves): a block that holds a whole ramp and
    # one that holds its end are both spread over the parts
    out = moving.astype(np.int64)
    idx = np.flatnonzero(moving)
    rank = np.argsort(np.argsort(level[idx], kind="stable"), kind="stable")
    out[idx] = 1 + (rank * ACTIVITY_LEVELS) // len(idx)
    return out


def tail_covers(regions: np.ndarray, early: np.ndarray, tail: np.ndarray) -> bool:
    """Whether the last usable rows span the operating regions of the rows before them.

    Row by row, on the direction variables divided by their RMS over all these rows: each
    sign of each variable that holds at least :data:`REGION_SHARE` of the earlier rows,
    and the large amplitudes (a speed norm above the earlier rows' quantile ``1 −
    REGION_SHARE``), must hold at least a :data:`COVER_RATIO` of that share of the tail.
    Only the operating variables are read, never the residual: the choice of the split
    cannot favour an effect.

    Args:
        regions: (n, R) direction variables on the grid.
        early: rows before the tail.
        tail: the last rows.
    """
    x = np.asarray(regions, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    both = np.concatenate([early, tail])
    scale = np.sqrt(np.mean(x[both] ** 2, axis=0))
    x = x / np.where(scale > 0, scale, 1.0)
    a, b = x[early], x[tail]
    for j in range(x.shape[1]):
        for sign in (1.0, -1.0):
            share = float(np.mean(sign * a[:, j] > 0))
            if share >= REGION_SHARE and float(np.mean(sign * b[:, j] > 0)) < \
                    COVER_RATIO * share:
                return False
    speed_a, speed_b = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    big = float(np.quantile(speed_a, 1.0 - REGION_SHARE))
    return bool(np.mean(speed_b > big) >= COVER_RATIO * REGION_SHARE)


def _spread(order: np.ndarray, k: int) -> np.ndarray:
    """``k`` entries of ``order`` at evenly spaced positions (systematic sampling)."""
    if k <= 0:
        return np.zeros(0, dtype=order.dtype)
    pos = np.round((np.arange(k) + 0.5) / k * len(order) - 0.5).astype(int)
    return order[np.unique(np.clip(pos, 0, len(order) - 1))]


def split_rows(t: np.ndarray, rows: np.ndarray, segment: np.ndarray | None,
               train_fraction: float, regions: np.ndarray | None = None,
               rates: np.ndarray | None = None) -> Split:
    """Split usable rows into training, validation and outer held-out parts (blocks).

    The usable rows before the tail are cut into :data:`BLOCKS` contiguous blocks that
    never straddle a gap; each block gets its operating region (:func:`block_regions`:
    direction × amplitude). Blocks are ordered by region, then time, and assigned by
    systematic sampling over that order, so that every part holds each region in
    proportion (the same amplitudes, speeds and directions in training, validation and
    confirmation), and, within a region, blocks spread over time:

    * the **outer held-out part** (``test``) is :data:`SPREAD_SHARE` of ``1 −
      train_fraction`` of the usable rows as such blocks, plus the rest of it as the last
      usable rows (the **tail**, kept for the rollout comparison, which needs a
      contiguous stretch); rows next to a confirmation block (:data:`GUARD_ROWS`) are in
      no part;
    * of the remaining blocks, a ``1 − train_fraction`` share *validates* the selection,
      the others train it. When the tail spans the regions (:func:`tail_covers`) the log
      is stationary enough that blocks evenly spread in time span them too: no
      confirmation blocks, and validation blocks in time order (the split of a plain cut
      in time).

    Args:
        t: grid times (s).
        rows: usable rows (:func:`usable_rows`), increasing.
        segment: (n,) segment label per grid row, or None for one segment.
        train_fraction: share of the usable rows in the fit part (training and validation),
            and share of the fit part's blocks that train.
        regions: (n, R) direction variables on the grid that define the operating regions,
            or None (blocks then spread over time only).
        rates: (n, K) input rates on the grid (:func:`block_activity`), or None. Where the
            inputs are held in some blocks and move in others, the blocks are ordered by
            this activity first, so that every part holds the input's transients in
            proportion (the information of a steering lag or an input delay).

    Raises:
        ValueError: too few usable rows for the three parts.
    """
    if not 0.0 < train_fraction < 1.0:
        raise ValueError(f"train_fraction must be in (0, 1), got {train_fraction!r}")
    rows = np.asarray(rows)
    n_out = len(rows) - int(round(train_fraction * len(rows)))
    n_tail = n_out - int(round(SPREAD_SHARE * n_out))
    spread = regions is not None and n_tail >= 10 and len(rows) > n_out and not \
        tail_covers(regions, rows[:len(rows) - n_out], rows[len(rows) - n_out:])
    if not spread:
        n_tail = n_out      # the last rows span the regions: the cut in time is kept
    k = len(rows) - n_tail
    if k - (n_out - n_tail) < 4 * MIN_BLOCK_ROWS or n_tail < 10:
        raise ValueError(f"recording too short: {len(rows)} usable rows (after masking and "
                         "thinning) cannot be split into training, validation and test parts")
    early, tail = rows[:k], rows[k:]
    seg = np.zeros(len(t), dtype=np.int64) if segment is None or len(segment) != len(t) \
        else np.asarray(segment)
    size = max(MIN_BLOCK_ROWS, len(early) // BLOCKS)
    # a block ends every `size` rows and wherever the segment changes
    labels = np.zeros(len(early), dtype=np.int64)
    block, count = 0, 0
    for i in range(len(early)):
        if i and (count >= size or seg[early[i]] != seg[early[i - 1]]):
            block, count = block + 1, 0
        labels[i] = block
        count += 1
    nb = block + 1
    # a stationary log (the tail spans the regions) spreads validation over time as well
    region = block_regions(regions if spread else None, early, labels)
    active = block_activity(rates, early, labels)
    order = np.lexsort((np.arange(nb), region, active))  # by activity, region, then time
    n_conf = int(round((n_out - n_tail) / max(len(early), 1) * nb))
    n_conf = min(max(n_conf, 1 if n_out > n_tail else 0), nb - 2)
    conf = _spread(order, n_conf)
    rest = order[~np.isin(order, conf)]
    n_valid = min(len(rest) - 1, max(1, int(round((1.0 - train_fraction) * len(rest)))))
    chosen = _spread(rest, n_valid)
    is_conf = np.isin(labels, conf)
    is_guard = np.zeros(len(early), dtype=bool)
    pos = np.flatnonzero(is_conf)
    for g in range(1, GUARD_ROWS + 1):
        is_guard[np.clip(pos - g, 0, len(early) - 1)] = True
        is_guard[np.clip(pos + g, 0, len(early) - 1)] = True
    is_guard &= ~is_conf
    is_valid = np.isin(labels, chosen) & ~is_guard
    is_train = ~(is_valid | is_conf | is_guard)
    fit = early[is_valid | is_train]
    fold_of = fit_folds(rest, chosen)
    fold = np.array([fold_of[int(b)] for b in labels[is_valid | is_train]], dtype=np.int64)
    test = np.concatenate([early[is_conf], tail])
    return Split(train=early[is_train], valid=early[is_valid], valid_block=labels[is_valid],
                 fit=fit, test=test, t_split=float(0.5 * (t[early[-1]] + t[tail[0]])),
                 tail=tail, confirm_block=np.concatenate(
                     [labels[is_conf], np.full(len(tail), -1, dtype=np.int64)]),
                 guard=early[is_guard], fold=fold)


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


def refinement(n_rows: int) -> int:
    """How many rows to read per half filter window (1: the split's rows as they are).

    Rows a half window apart are the split's unit (blocks, guards), but they do not hold
    all the filtered residual's information: the kernel is not band-limited at that rate,
    and a nonlinear term fitted on few rows (a Stribeck bump on a long window) scatters
    far more than its information allows. Measured on a coloured-noise arm log (window
    125 samples, 133 usable rows): Stribeck's Fs over six noise draws scattered with a
    standard deviation of 0.20 N·m on the half-window rows and 0.057 N·m on rows an eighth
    of a window apart (τ ≈ 2 there, so ≈ 2x the effective samples). Where the half-window
    rows are fewer than :data:`MIN_ROWS` (a long window: a coloured or quantised error, a
    short log), each is refined into up to :data:`MAX_REFINE` rows; the held-out tests count
    N/τ effective samples, so the correlated neighbours are not counted as independent.
    Longer logs keep one row per half window (their cost grows with the rows).
    """
    if n_rows <= 0 or n_rows >= MIN_ROWS:
        return 1
    return int(min(MAX_REFINE, np.ceil(MIN_ROWS / n_rows)))


def refine(split: Split, coarse: np.ndarray, fine: np.ndarray, step: int) -> Split:
    """The split with each half-window row replaced by the finer rows it owns.

    A fine row belongs to the last coarse row at or before it, less than ``step`` samples
    (half a window) earlier; it joins that row's part (training, validation, confirmation
    block, tail, guard) and block label. Fine rows owned by no usable coarse row (after a
    masked one) are left out. The blocks, their regions and their assignment are the
    coarse split's: only the rows read inside them change.

    Args:
        split: the split of the coarse rows (:func:`split_rows`).
        coarse: the coarse usable rows it was made from, increasing.
        fine: finer usable rows (:func:`usable_rows` with a smaller step), increasing.
        step: the coarse thinning step (samples).
    """
    coarse, fine = np.asarray(coarse), np.asarray(fine)
    if len(coarse) == 0 or len(fine) == 0:
        return split
    owner = np.searchsorted(coarse, fine, side="right") - 1
    ok = owner >= 0
    ok[ok] &= fine[ok] - coarse[owner[ok]] < step
    fine, owner_row = fine[ok], coarse[owner[ok]]

    def part(rows: np.ndarray) -> np.ndarray:
        return fine[np.isin(owner_row, rows)]

    def labels(rows: np.ndarray, lab: np.ndarray) -> np.ndarray:
        sel = np.isin(owner_row, rows)
        return np.asarray(lab)[np.searchsorted(rows, owner_row[sel])]

    return Split(train=part(split.train), valid=part(split.valid),
                 valid_block=labels(split.valid, split.valid_block), fit=part(split.fit),
                 test=part(split.test), t_split=split.t_split, tail=part(split.tail),
                 confirm_block=labels(split.test, split.confirm_block),
                 guard=part(split.guard),
                 fold=labels(split.fit, split.fold) if len(split.fold) else split.fold)
