"""Identifiability of a set of named parameters as a whole, from their joint Jacobian.

Pairwise correlation misses joint symmetries: on a car driven in steady circles, mass, yaw
inertia and both axles' tire laws scaled together leave the motion unchanged, while no two
of them alone are collinear. The joint test is the singular value decomposition of the
Jacobian J (N samples × p parameters) of the residual model with respect to the
parameters, after scaling each column to unit norm (so that units, and rounding of the
inputs, cannot change the verdict):

* a right-singular vector vᵢ whose singular value sᵢ is small is a *combination*
  Σ vᵢⱼ·θⱼ/‖J_j‖ that the data do not determine; its standard error is σ/sᵢ in those
  scaled coordinates (σ the residual noise std, channel units);
* a combination is **not identifiable** when sᵢ/s_max < ``rel_tol`` (numerically
  collinear), or, when the noise and the fitted values are given, when its standard error
  exceeds the size of the fitted parameters' parts along it, Σⱼ|vᵢⱼθⱼ| (no cancellation
  between parameters: the data cannot tell the parameters that carry it from zero). The
  signed projection |vᵢ·θ| is no size: it vanishes whenever the parameters' scaled sizes
  happen to cancel along vᵢ, however well each one is determined (measured on the real
  EMPS log at 100 Hz: viscous b = 219 ± 4 N·s/m and Coulomb Fc = 19.2 ± 0.3 N, correlated
  +0.94, have nearly equal scaled sizes, and the signed projection called their difference
  "not determined"; b alone then took the Coulomb force, b = 414 N·s/m);
* the parameter correlation matrix is the normalised pseudo-inverse of JᵀJ.

The answer is either "all identifiable" or the list of combinations the data cannot tell
apart, named by the parameters that carry them, so that a report can name the
identifiable part and say which direction is left open.
"""

from __future__ import annotations

import itertools
from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np

from simgap.errors import DiagnosisError

#: Relative singular value below which a direction is numerically collinear.
REL_TOL = 1e-3
#: Parameters whose weight in an unidentifiable direction is below this share are not named.
NAME_SHARE = 0.1


@dataclass(frozen=True)
class Combination:
    """A direction in parameter space the data do not determine.

    Attributes:
        weights: parameter name → weight in the unit-norm direction (scaled coordinates;
            only names with |weight| ≥ NAME_SHARE).
        relative_singular_value: sᵢ/s_max of the direction.
        relative_error: standard error along the direction divided by the fitted vector's
            component along it (inf when no values were given and it is collinear).
    """

    weights: dict[str, float]
    relative_singular_value: float
    relative_error: float

    def describe(self) -> str:
        """One line: which parameters move together without changing the fit."""
        parts = [f"{'+' if w > 0 else '−'}{abs(w):.2f}·{n}" for n, w in
                 sorted(self.weights.items(), key=lambda kv: -abs(kv[1]))]
        return (" ".join(parts) + " (each scaled by its regressor's norm) cannot be "
                "determined from this data")


@dataclass(frozen=True)
class Identifiability:
    """Result of :func:`analyse`.

    Attributes:
        names: parameter names, in Jacobian column order.
        singular_values: of the column-normalised Jacobian, descending.
        condition: s_max / s_min (inf if singular).
        correlation: parameter correlation matrix (p × p).
        unidentifiable: the combinations the data do not determine (empty if none).
    """

    names: tuple[str, ...]
    singular_values: np.ndarray
    condition: float
    correlation: np.ndarray
    unidentifiable: tuple[Combination, ...]

    @property
    def identifiable(self) -> bool:
        """Whether every direction is determined."""
        return not self.unidentifiable

    def max_abs_correlation(self) -> float:
        """Largest |correlation| between two different parameters."""
        c = np.abs(self.correlation - np.diag(np.diag(self.correlation)))
        return float(np.max(c)) if c.size else 0.0


def analyse(jacobian: np.ndarray, names: Sequence[str], *, noise_std: float | None = None,
            values: Sequence[float] | None = None, rel_tol: float = REL_TOL,
            nonlinear: Sequence[bool] | None = None) -> Identifiability:
    """Joint identifiability of the parameters whose regressors are ``jacobian``'s columns.

    Args:
        jacobian: (N, p) derivative of the residual model w.r.t. each parameter (channel
            units per parameter unit); rows may stack channels.
        names: the p parameter names.
        noise_std: residual noise std (channel units) for the statistical test; with
            ``values``, a direction is unidentifiable when its standard error exceeds the
            fitted vector's component along it. Use the effective noise (inflated by
            √τ for correlated residuals) where known.
        values: fitted parameter values (parameter units), in ``names`` order.
        rel_tol: relative singular value below which a direction counts as collinear.
        nonlinear: per parameter, whether it is a nonlinear one (a scale such as
            Stribeck's vs). Kept for callers: every direction, with or without one, is
            compared with Σ|vⱼθⱼ| (first measured on a quantised encoder's Stribeck term,
            Fs = 0.28 ± 0.13 N·m, vs = 0.21 ± 0.06 rad/s, "not determined" by a signed
            projection of ≈ 0; the same cancellation hits linear pairs, see above).

    Returns:
        The :class:`Identifiability` of the whole set.

    Raises:
        DiagnosisError: on a shape mismatch or non-finite Jacobian.
    """
    j = np.asarray(jacobian, dtype=np.float64)
    if j.ndim != 2 or j.shape[1] != len(names):
        raise DiagnosisError(f"identifiability: Jacobian of shape {j.shape} does not match "
                             f"{len(names)} parameter names")
    if not np.all(np.isfinite(j)):
        raise DiagnosisError("identifiability: the Jacobian holds non-finite values")
    norms = np.linalg.norm(j, axis=0)
    dead = norms == 0.0
    scaled = j / np.where(dead, 1.0, norms)
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    smax = float(s[0]) if s.size else 0.0
    cond = float(smax / s[-1]) if s.size and s[-1] > 0 else float("inf")
    gram_inv = np.linalg.pinv(scaled.T @ scaled)
    d = np.sqrt(np.clip(np.diag(gram_inv), 1e-300, None))
    corr = gram_inv / np.outer(d, d)
    theta = None
    if values is not None:
        theta = np.asarray(values, dtype=np.float64) * norms   # scaled coordinates
    combos = []
    for i, si in enumerate(s):
        rel = si / smax if smax > 0 else 0.0
        along = 0.0 if theta is None else float(np.sum(np.abs(vt[i] * theta)))
        err = (noise_std / si) if (noise_std is not None and si > 0) else float("inf")
        rel_err = err / along if along > 0 else float("inf")
        collinear = rel < rel_tol
        undetermined = noise_std is not None and theta is not None and rel_err > 1.0
        if collinear or undetermined:
            w = {n: float(x) for n, x in zip(names, vt[i], strict=True)
                 if abs(x) >= NAME_SHARE}
            combos.append(Combination(weights=w, relative_singular_value=float(rel),
                                      relative_error=float(rel_err)))
    for n, is_dead in zip(names, dead, strict=True):
        if is_dead:
            combos.append(Combination(weights={n: 1.0}, relative_singular_value=0.0,
                                      relative_error=float("inf")))
    return Identifiability(names=tuple(names), singular_values=s, condition=cond,
                           correlation=corr, unidentifiable=tuple(combos))


@dataclass(frozen=True)
class Determination:
    """How well the data determine some parameters with others freed beside them.

    Attributes:
        names: the parameters tested.
        standard_error: their standard errors with every other column freed (parameter
            units), from the joint Fisher information (the Schur complement of the others'
            block): √(σ²·[(JᵀJ)⁻¹]ᵢᵢ).
        retained: share of each parameter's own information (its column's energy) that is
            left once the others are freed, 1 − R² of its column on theirs, in [0, 1]:
            0 on an exact symmetry, 1 when the others are orthogonal to it.
        z: |value| / standard_error per parameter (the Wald statistic of "value = 0").
    """

    names: tuple[str, ...]
    standard_error: np.ndarray
    retained: np.ndarray
    z: np.ndarray

    def determined(self, z_crit: float, min_retained: float = REL_TOL**2) -> bool:
        """Whether every parameter is told from 0 at ``z_crit`` and not lost to a symmetry.

        ``min_retained`` is the information share below which the column counts as
        numerically collinear with the others (the square of :data:`REL_TOL`, a relative
        singular value).
        """
        return bool(np.all(self.retained >= min_retained) and np.all(self.z >= z_crit))


def determination(jacobian: np.ndarray, names: Sequence[str], which: Sequence[str],
                  values: Sequence[float], *, noise_std: float = 1.0) -> Determination:
    """Standard errors of ``which`` with all the other parameters freed beside them.

    The answer to "do the data determine θᵢ when its symmetry partners are free?" is not
    the value a refit lands on (a weakly determined direction slides with the noise) but
    θᵢ's marginal uncertainty with the partners free: the joint information JᵀJ inverted
    (Fisher information, Cramér–Rao), and how much of θᵢ's own information the partners
    take (an exact symmetry takes all of it).

    Args:
        jacobian: (N, p) derivative of the residual model w.r.t. each parameter, rows
            whitened so that the residual noise std is ``noise_std`` (use the effective
            noise, inflated by √τ for correlated residuals).
        names: the p parameter names, in column order.
        which: the names to test.
        values: the p fitted values (parameter units), in ``names`` order.
        noise_std: residual noise std in the Jacobian's row units.

    Returns:
        The :class:`Determination` of ``which``.

    Raises:
        DiagnosisError: on a shape mismatch, an unknown name or a non-finite Jacobian.
    """
    j = np.asarray(jacobian, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if j.ndim != 2 or j.shape[1] != len(names) or v.shape != (len(names),):
        raise DiagnosisError(f"identifiability: Jacobian of shape {j.shape} and "
                             f"{v.shape[0] if v.ndim else 0} values do not match "
                             f"{len(names)} parameter names")
    if not np.all(np.isfinite(j)):
        raise DiagnosisError("identifiability: the Jacobian holds non-finite values")
    missing = [n for n in which if n not in names]
    if missing:
        raise DiagnosisError(f"identifiability: unknown parameters {missing}")
    idx = [list(names).index(n) for n in which]
    norms = np.linalg.norm(j, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    scaled = j / safe                       # unit columns: rounding/units cannot matter
    retained = np.zeros(len(idx))
    for n, i in enumerate(idx):
        if norms[i] == 0.0:
            continue
        others = np.delete(scaled, i, axis=1)
        col = scaled[:, i]
        if others.shape[1]:
            col = col - others @ np.linalg.lstsq(others, col, rcond=None)[0]
        # [(ĴᵀĴ)⁻¹]ᵢᵢ = 1/‖(I − P_others)Ĵᵢ‖² = 1/(1 − R²ᵢ) for a unit column
        retained[n] = min(float(col @ col), 1.0)
    se = np.full(len(idx), np.inf)
    ok = retained > 0
    se[ok] = noise_std / (np.sqrt(retained[ok]) * norms[idx][ok])
    z = np.abs(v[idx]) / se
    return Determination(names=tuple(which), standard_error=se, retained=retained,
                         z=z)


@dataclass(frozen=True)
class Symmetry:
    """A declared symmetry of a system: effects whose scales, changed together, leave the motion.

    Registry data on the system form (``symmetries``, e.g.
    :attr:`simgap.diagnosis.systems.BicycleSystem.symmetries`): scaling every member by one
    factor λ leaves the motion unchanged (a vehicle's mass, yaw inertia and both axles' tire
    laws: every force and every inertia ×λ). A fitted set whose chosen members carry scales
    ρᵢ (the absent members at their nominal, 1) then describes the same motion as λ·ρ for
    any λ: every absent member takes the scale λ, and each chosen member whose ρᵢ = 1/λ
    drops out. So one motion has several members' descriptions; the diagnosis names the
    simplest one that explains the data as well (:meth:`replacements`), and reports the
    identifiable combination where the data cannot tell them apart.

    Attributes:
        members: effect names; an effect fitted per channel is a member at every channel.
        description: what is scaled together, in words (for reports).
    """

    members: tuple[str, ...]
    description: str

    def includes(self, effect: str) -> bool:
        """Whether the effect named ``effect`` is a member."""
        return effect in self.members

    @staticmethod
    def replacements(chosen: Sequence[Hashable], members: Sequence[Hashable]
                     ) -> list[tuple[Hashable, ...]]:
        """Smaller member sets that may describe the same motion as ``chosen``, fewest first.

        With every member scaled by λ ≠ 1, each member absent from ``chosen`` carries λ, and
        a chosen member drops out only where its scale was 1/λ: an equivalent description
        holds every absent member plus some of the chosen ones. Only those with fewer terms
        than ``chosen`` are listed (the data decide whether one explains as well).

        Args:
            chosen: the members in the fitted set (keys: effect, channel).
            members: every member the selection could fit (keys), ``chosen`` among them.

        Returns:
            Candidate sets (tuples of keys), by size then order of ``chosen``.
        """
        absent = [m for m in members if m not in chosen]
        out: list[tuple[Hashable, ...]] = []
        for k in range(max(len(chosen) - len(absent), 0)):
            out += [(*absent, *kept) for kept in itertools.combinations(chosen, k)]
        return out
