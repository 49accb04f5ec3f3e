"""Step 3 of the diagnosis: name the missing physics by held-out forward selection.

Every vocabulary effect at every channel is a hypothesis (a :class:`Term`). The residual is
whitened per channel by its noise floor and thinned to every ``window // 2``-th sample (the
Savitzky–Golay filter correlates neighbouring samples; thinning leaves nearly independent
ones, which keeps the standard errors honest and the fits fast). The earlier 70 % of the
recording trains, the later 30 % tests.

Forward selection: in each round every remaining term is fitted together with the terms
already chosen (training part only), and scored by how much it lowers the whitened squared
error on the *test* part. A term is accepted if that held-out reduction is at least
:data:`MIN_GAIN` per test sample of the channels it acts on (its contribution is then at
least half the noise floor in RMS)
and at least :data:`MIN_REL` of the remaining held-out error, and if no fitted parameter
sits on a plausibility limit (a term pushed onto its limit is being forced onto data it does
not describe, e.g. mass and stiffness shrunk tenfold together). A backward pass then drops any
chosen term whose removal costs less than that (a later term explained it better). When
several terms come within :data:`TIE` of the best reduction, the one with fewer parameters
wins (Coulomb before Stribeck, bias before spring); when a term with a different physical
meaning is nearly as good (:data:`ALIAS_GAIN`) and its held-out contribution is strongly
correlated with the chosen one (:data:`ALIAS_CORR`), the pair is reported as a collinearity
warning instead of silently picking one.

Fitting: linear parameters by bounded linear least squares (``scipy.optimize.lsq_linear``,
physical sign bounds such as Fc ≥ 0); nonlinear ones (Stribeck vs, tire mu, steering lag tau)
by ``scipy.optimize.least_squares`` over the nonlinear parameters with the linear ones
solved inside (variable projection), started from the best point of a coarse grid. Standard
errors: s²(JᵀJ)⁻¹ with the full Jacobian at the optimum, s² the whitened residual variance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from simgap.diagnosis.effects import Effect

MIN_GAIN = 0.25
MIN_REL = 0.02
TIE = 0.05
ALIAS_GAIN = 0.8
ALIAS_CORR = 0.9
MAX_EFFECTS = 6
TRAIN_FRACTION = 0.7


@dataclass(frozen=True)
class Term:
    """One hypothesis: an effect at a channel (``index`` None for whole-system effects)."""

    effect: Effect
    index: int | None
    channel: str

    @property
    def key(self) -> tuple[str, int | None]:
        """Identity of the term."""
        return (self.effect.name, self.index)


@dataclass
class FitResult:
    """A fitted set of terms.

    Attributes:
        terms: the terms.
        lin: linear parameters per term.
        nl: nonlinear parameters per term.
        cov: covariance of all parameters (per term: linear then nonlinear, in term order).
        pred: filtered contribution of each term on the full grid, (N, C) each.
        sse_test: whitened squared error on the test rows.
        sse_train: whitened squared error on the training rows.
    """

    terms: list[Term]
    lin: list[np.ndarray]
    nl: list[np.ndarray]
    cov: np.ndarray
    pred: list[np.ndarray]
    sse_test: float
    sse_train: float

    def total(self, n: int, c: int) -> np.ndarray:
        """Sum of the contributions (N, C)."""
        out = np.zeros((n, c))
        for p in self.pred:
            out += p
        return out

    def slices(self) -> list[slice]:
        """Index ranges of each term's parameters in :attr:`cov`."""
        out, i = [], 0
        for t in self.terms:
            out.append(slice(i, i + t.effect.n_params))
            i += t.effect.n_params
        return out


@dataclass
class Selection:
    """Outcome of the forward selection.

    Attributes:
        fit: final fit of the accepted terms (or of none).
        history: per round: accepted term, its held-out gain, runner-up gains.
        warnings: collinearity warnings (plain words, plus the effects involved).
    """

    fit: FitResult
    history: list[dict[str, Any]] = field(default_factory=list)
    warnings: list[dict[str, Any]] = field(default_factory=list)


class Fitter:
    """Fits terms to a residual (see the module docstring).

    Args:
        system: the prepared system adapter (signals, smoother, effects' context).
        residual: physical residual on the uniform grid, (N, C).
        noise: noise floor per channel (C,).
        train_fraction: share of the recording (earliest) used for training.
    """

    def __init__(self, system: Any, residual: np.ndarray, noise: np.ndarray,
                 train_fraction: float = TRAIN_FRACTION, mask: np.ndarray | None = None
                 ) -> None:
        self.sys = system
        self.n, self.c = residual.shape
        self.mask = np.ones((self.n, self.c)) if mask is None else mask.astype(float)
        self.r = residual * self.mask
        self.w = 1.0 / np.maximum(noise, 1e-12)
        sm = system.smoother
        step = max(1, sm.window // 2)
        edge = sm.window
        rows = np.arange(edge, self.n - edge, step)
        t = system.t
        self.t_split = float(t[0] + train_fraction * (t[-1] - t[0]))
        self.train = rows[t[rows] < self.t_split]
        self.test = rows[t[rows] >= self.t_split]
        if len(self.train) < 10 or len(self.test) < 10:
            raise ValueError("recording too short to split into training and test parts")
        all_rows = np.arange(self.n)
        self.sig = system.rows(all_rows)
        self.sig0 = system.zero_derivatives(self.sig)
        # what the effects may read (forms.EffectContext); a bare adapter is its own context
        self.ctx = system.context() if hasattr(system, "context") else system
        self._cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self.y_tr = (self.r[self.train] * self.w).ravel()
        self.y_te = (self.r[self.test] * self.w).ravel()

    # -- model evaluation --------------------------------------------------------------
    def output(self, term: Term, lin: np.ndarray, nl: np.ndarray) -> np.ndarray:
        """Return the filtered contribution of a term on the full grid (N, C), channel units.

        The regressor goes through the same filter as the residual; acceleration terms are
        already filtered derivatives and are not filtered again.
        """
        e, sm = term.effect, self.sys.smoother
        if e.uses_derivatives:
            base = e(lin, nl, self.sig0, term.index, self.ctx)
            out = sm(base) + (e(lin, nl, self.sig, term.index, self.ctx) - base)
        else:
            out = sm(e(lin, nl, self.sig, term.index, self.ctx))
        return out * self.mask

    def basis(self, term: Term, nl: np.ndarray, rows: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Linear basis (R, C, n_lin) and offset (R, C) of a term at nonlinear values nl.

        Evaluated on the full grid (the filter needs it) and kept on ``rows`` only (default
        and cached: the training rows, all a design matrix is built on), so the cache holds
        a thinned slice instead of (N, C) arrays per term and value.
        """
        train = rows is None
        rows = self.train if train else rows
        key = (term.key, tuple(np.round(nl, 12)))
        if train and key in self._cache:
            return self._cache[key]
        e = term.effect
        k = len(e.lin)
        off = self.output(term, np.zeros(k), nl)
        cols = np.empty((len(rows), self.c, k))
        for i in range(k):
            unit = np.zeros(k)
            unit[i] = 1.0
            cols[:, :, i] = self.output(term, unit, nl)[rows] - off[rows]
        off = off[rows]
        if train and not e.nl:
            self._cache[key] = (cols, off)
        return cols, off

    def _context(self, terms: Sequence[Term], nls: Sequence[np.ndarray]) -> None:
        if hasattr(self.sys, "context"):
            self.ctx = self.sys.context([(t.effect, t.index, None, nl)
                                         for t, nl in zip(terms, nls, strict=True)])

    def _design(self, terms: Sequence[Term], nls: Sequence[np.ndarray], rows: np.ndarray):
        self._context(terms, nls)
        xs, off = [], np.zeros((len(rows), self.c))
        for t, nl in zip(terms, nls, strict=True):
            cols, o = self.basis(t, nl, None if rows is self.train else rows)
            off += o
            if cols.shape[2]:
                xs.append(cols * self.w[None, :, None])
        x = np.concatenate(xs, axis=2).reshape(len(rows) * self.c, -1) if xs else \
            np.zeros((len(rows) * self.c, 0))
        return x, (off * self.w).ravel()

    def _solve_lin(self, terms, nls):
        x, off = self._design(terms, nls, self.train)
        lower = np.array([b for t in terms for b in t.effect.lin_lower], dtype=float)
        upper = np.array([b for t in terms for b in t.effect.upper], dtype=float)
        if x.shape[1] == 0:
            return np.zeros(0), self.y_tr - off, x
        sol = lsq_linear(x, self.y_tr - off, bounds=(lower, upper),
                         method="bvls" if x.shape[1] <= 12 else "trf")
        return sol.x, self.y_tr - off - x @ sol.x, x

    def fit(self, terms: Sequence[Term], nl_start: Sequence[np.ndarray] | None = None
            ) -> FitResult:
        """Fit the terms on the training part; score them on the test part."""
        terms = list(terms)
        nls0 = [np.asarray(v, dtype=float) for v in (nl_start or
                [np.array([g[len(g) // 2] for g in t.effect.nl_grid]) for t in terms])]
        sizes = [len(t.effect.nl) for t in terms]
        lo = np.array([b[0] for t in terms for b in t.effect.nl_bounds], dtype=float)
        hi = np.array([b[1] for t in terms for b in t.effect.nl_bounds], dtype=float)

        def split(v):
            out, i = [], 0
            for s in sizes:
                out.append(np.asarray(v[i:i + s], dtype=float))
                i += s
            return out

        v0 = np.concatenate(nls0) if nls0 else np.zeros(0)
        if v0.size:
            log_lo, log_hi = np.log(lo), np.log(hi)

            def resid(z):
                return self._solve_lin(terms, split(np.exp(z)))[1]
            sol = least_squares(resid, np.clip(np.log(v0), log_lo + 1e-9, log_hi - 1e-9),
                                bounds=(log_lo, log_hi), diff_step=1e-4, max_nfev=60)
            v = np.exp(sol.x)
        else:
            v = v0
        nls = split(v)
        lin_all, res_tr, x = self._solve_lin(terms, nls)
        # Jacobian for the covariance: linear columns, then nonlinear by finite differences.
        jac_nl = []
        for i in range(v.size):
            h = 1e-4 * max(abs(v[i]), 1e-6)
            vp = v.copy()
            vp[i] += h
            xp, offp = self._design(terms, split(vp), self.train)
            pred_p = offp + (xp @ lin_all if xp.shape[1] else 0.0)
            xb, offb = self._design(terms, nls, self.train)
            pred_b = offb + (xb @ lin_all if xb.shape[1] else 0.0)
            jac_nl.append((pred_p - pred_b) / h)
        # order columns per term: its linear then its nonlinear parameters
        cols, li, ni = [], 0, 0
        for t in terms:
            for _ in t.effect.lin:
                cols.append(x[:, li])
                li += 1
            for _ in t.effect.nl:
                cols.append(jac_nl[ni])
                ni += 1
        n_p = len(cols)
        dof = max(len(res_tr) - n_p, 1)
        s2 = float(res_tr @ res_tr) / dof
        if n_p:
            jac = np.stack(cols, axis=1)
            cov = s2 * np.linalg.pinv(jac.T @ jac)
        else:
            cov = np.zeros((0, 0))
        lins, i = [], 0
        for t in terms:
            k = len(t.effect.lin)
            lins.append(lin_all[i:i + k])
            i += k
        self._context(terms, nls)
        pred = [self.output(t, lv, nv) for t, lv, nv in zip(terms, lins, nls, strict=True)]
        total = np.zeros((self.n, self.c))
        for p in pred:
            total += p
        e_te = ((self.r[self.test] - total[self.test]) * self.w).ravel()
        e_tr = ((self.r[self.train] - total[self.train]) * self.w).ravel()
        return FitResult(terms=terms, lin=lins, nl=nls, cov=cov, pred=pred,
                         sse_test=float(e_te @ e_te), sse_train=float(e_tr @ e_tr))

    @staticmethod
    def at_limit(fit: FitResult) -> list[str]:
        """Terms whose fitted parameters sit on a plausibility limit (not a sign bound)."""
        out = []
        for t, lin, nl in zip(fit.terms, fit.lin, fit.nl, strict=True):
            e = t.effect
            bounds = list(zip(e.lin_lower, e.upper, strict=True)) + list(e.nl_bounds)
            for v, (lo, hi) in zip(np.concatenate([lin, nl]), bounds, strict=True):
                span = (hi - lo) if np.isfinite(hi - lo) else max(abs(lo), abs(hi), 1.0)
                tol = 1e-3 * span
                if (np.isfinite(lo) and lo != 0.0 and v <= lo + tol) or \
                        (np.isfinite(hi) and v >= hi - tol):
                    out.append(f"{e.name}@{t.channel}")
                    break
        return out

    def fit_new(self, chosen: FitResult, term: Term) -> FitResult:
        """Fit ``chosen`` plus one new term, starting the new nonlinear ones on a grid."""
        starts = [np.asarray(v) for v in chosen.nl]
        if not term.effect.nl:
            return self.fit(chosen.terms + [term], starts + [np.zeros(0)])
        grid = np.array(np.meshgrid(*term.effect.nl_grid)).reshape(len(term.effect.nl), -1).T
        best, best_sse = None, np.inf
        for g in grid:
            x, off = self._design(chosen.terms + [term], starts + [g], self.train)
            lower = np.array([b for t in chosen.terms + [term] for b in t.effect.lin_lower])
            upper = np.array([b for t in chosen.terms + [term] for b in t.effect.upper])
            if x.shape[1]:
                sol = lsq_linear(x, self.y_tr - off, bounds=(lower, upper))
                r = self.y_tr - off - x @ sol.x
            else:
                r = self.y_tr - off
            sse = float(r @ r)
            if sse < best_sse:
                best, best_sse = g, sse
        return self.fit(chosen.terms + [term], starts + [best])

    # -- selection ---------------------------------------------------------------------
    def select(self, candidates: Sequence[Term]) -> Selection:
        """Forward selection by held-out improvement (see the module docstring)."""
        current = self.fit([])
        sel = Selection(fit=current)
        remaining = list(candidates)
        n_test = len(self.test) * self.c
        while remaining and len(current.terms) < MAX_EFFECTS:
            trials = [(t, self.fit_new(current, t)) for t in remaining]
            # A term pushed onto a plausibility limit is being forced: not a candidate.
            gains = np.array([current.sse_test - f.sse_test if not self.at_limit(f)
                              else -np.inf for _, f in trials])
            if not np.isfinite(gains).any():
                break
            best = float(gains.max())
            near = [i for i, g in enumerate(gains) if g >= best - TIE * abs(best)]
            pick = min(near, key=lambda i: (trials[i][0].effect.n_params, -gains[i]))
            term, fit = trials[pick]
            gain = float(gains[pick])
            n_aff = self._n_affected(term)
            ok = gain >= MIN_GAIN * n_aff and gain >= MIN_REL * current.sse_test
            sel.history.append({"term": f"{term.effect.name}@{term.channel}", "gain": gain,
                                "gain_per_sample": gain / n_aff, "accepted": bool(ok),
                                "runner_up": sorted(
                                    ((f"{t.effect.name}@{t.channel}", float(g))
                                     for (t, _), g in zip(trials, gains, strict=True)
                                     if np.isfinite(g)),
                                    key=lambda x: -x[1])[:4]})
            if not ok:
                break
            self._aliases(sel, term, fit, trials, gains, gain, current.sse_test)
            current = fit
            remaining = [t for t in remaining if t.key != term.key]
        sel.fit = self._prune(current, sel, n_test)
        return sel

    def _n_affected(self, term: Term) -> int:
        """Test samples of the channels a term acts on (one channel, or all)."""
        return len(self.test) * (1 if term.index is not None else self.c)

    def _prune(self, current: FitResult, sel: Selection, n_test: int) -> FitResult:
        """Backward pass: drop terms that a later term made unnecessary on held-out data."""
        while len(current.terms) > 1:
            trials = []
            for i in range(len(current.terms)):
                keep = [j for j in range(len(current.terms)) if j != i]
                f = self.fit([current.terms[j] for j in keep], [current.nl[j] for j in keep])
                trials.append((f.sse_test - current.sse_test, i, f))
            loss, i, f = min(trials, key=lambda x: x[0])
            t = current.terms[i]
            n_aff = self._n_affected(t)
            if loss >= MIN_GAIN * n_aff and loss >= MIN_REL * f.sse_test or self.at_limit(f):
                break
            sel.history.append({"term": f"{t.effect.name}@{t.channel}", "removed": True,
                                "loss_per_sample": float(loss / n_aff)})
            sel.warnings = [w for w in sel.warnings if w["effects"][0] != t.effect.name
                            or w["channels"][0] != t.channel]
            current = f
        return current

    def _aliases(self, sel: Selection, term: Term, fit: FitResult, trials, gains, gain,
                 base: float) -> None:
        """Warn where another candidate explains the same held-out residual as ``term``.

        ``gain``/``gains`` are reductions of the held-out weighted squared residual; the
        warning states them as shares of ``base``, that residual before this round.
        """
        mine = fit.pred[-1][self.test].ravel()
        for (t, f), g in zip(trials, gains, strict=True):
            if t.key == term.key or not np.isfinite(g) or g < ALIAS_GAIN * gain:
                continue
            same_ch = t.index == term.index
            nested = same_ch and (t.effect.name in term.effect.generalizes or
                                  term.effect.name in t.effect.generalizes)
            if nested:
                continue
            other = f.pred[-1][self.test].ravel()
            if np.std(mine) == 0 or np.std(other) == 0:
                continue
            corr = float(np.corrcoef(mine, other)[0, 1])
            if abs(corr) >= ALIAS_CORR:
                sel.warnings.append({
                    "effects": [term.effect.name, t.effect.name],
                    "channels": [term.channel, t.channel],
                    "correlation": corr,
                    "text": (f"{term.effect.label} at {term.channel} and {t.effect.label} at "
                             f"{t.channel} cannot be told apart on this data (each alone "
                             f"removes {_share(gain, base)} vs {_share(g, base)} of the "
                             f"held-out squared residual left before it; contributions "
                             f"correlated {corr:+.2f}); "
                             f"reported {term.effect.name} (fewer parameters or better fit). "
                             "Excite the system differently to separate them.")})


def _share(part: float, whole: float) -> str:
    """``part`` as a percentage of ``whole`` for report text ("83 %")."""
    return f"{100.0 * part / whole:.0f} %" if whole > 0 else "n/a"
