"""The diagnosis' view of the effect vocabulary (``spec/diagnosis.md``), one object per effect.

Every :class:`Effect` is derived from a system's :class:`~simgap.models.effects.EffectSpec`
(its ``fit`` side: contribution, fit coordinates, bounds, reparametrisation, ``needs``), so
an effect is declared once, in its system's model module, and the generator, ``simgap
record``, the diagnosis, the proof and the augmented model all read the same declaration.

An effect's function maps parameters and the recording's filtered signals to its
contribution to the physical residual, shape (N, n_channels): joint torques tau_d (N·m) for
mechanical systems (the left-out term of M ddq + C dq + G + tau_d = u, spec ``models.md``),
axle lateral-force deviations Delta (N) for the bicycle (thesis eq. 2.4-2.7). Parameters are
split into *linear* ones (the contribution is linear in them: fitted by bounded least
squares) and *nonlinear* ones (Stribeck velocity vs, tire mu, steering lag tau: fitted by
``scipy.optimize.least_squares`` around a coarse grid).

Signals (``sig``) by system:

* mechanical: ``q``, ``dq``, ``ddq`` arrays (N, n) in rad (m), rad/s, rad/s², ``u`` (the
  filtered input) and ``idx`` (row indices into the full recording);
* bicycle: ``vy``, ``r``, ``dvy``, ``dr``, ``vx``, ``delta_f``, ``delta_r``, ``alpha_f``,
  ``alpha_r`` (N,) in SI units, and ``idx`` (used by effects with memory such as the
  steering lag).

The residual form passes an :class:`~simgap.diagnosis.forms.EffectContext` (coulomb
smoothing, gravity torques, payload regressor, axle stiffnesses, loads, K⁻¹, the lag filter,
and what other terms of the same model imply: the steering lag goes through a
tire_saturation term's Magic Formula on the same axle).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.effects import EffectSpec, FitFn, FitSpec, format_unit

EffectFn = FitFn


@dataclass(frozen=True, kw_only=True)
class Effect(FitSpec):
    """One vocabulary effect as the diagnosis fits it (built by :meth:`of`).

    The fit fields (``scope``, ``lin``, ``lin_lower``, ``nl_bounds``, ``fn``, ...) are those
    of :class:`~simgap.models.effects.FitSpec`, with units written for the channel the
    effect is tested on. A fit that ends on a plausibility limit (any bound other than a
    sign bound at 0) means the effect is being forced onto data it does not describe; such
    a term is not named.

    Attributes:
        name: vocabulary name (``spec/diagnosis.md``).
        label: plain words for the report ("Coulomb friction").
        needs: effects whose fitted values on the same channel its reported parameters
            include (Stribeck's breakaway Fs includes Coulomb's Fc).
        nominal: the nominal's value of each corrected coordinate on the tested channel
            (set by :meth:`with_nominal`; empty: the nominal has no such term).
        unit: fills a unit template (:func:`~simgap.models.effects.format_unit`) for the
            channel the effect is tested on.
    """

    name: str
    label: str
    needs: tuple[str, ...] = ()
    nominal: Mapping[str, float] = field(default_factory=dict)
    unit: Callable[[str], str] = field(default=format_unit, repr=False)

    @classmethod
    def of(cls, spec: EffectSpec, *, effort: str = "N·m", position: str = "rad") -> Effect:
        """The diagnosis effect of a vocabulary entry, units for one joint kind.

        Raises:
            ValueError: the entry has no fit side (it is injectable only).
        """
        fit = spec.fit
        if fit is None:
            raise ValueError(f"effect {spec.name!r} is not diagnosable (no fit side)")
        out = cls(name=spec.name, label=spec.label, needs=spec.needs,
                  **{f.name: getattr(fit, f.name) for f in fields(FitSpec)})
        return out.in_units(effort=effort, position=position, templates=fit)

    def in_units(self, *, effort: str, position: str, templates: Any = None) -> Effect:
        """The effect with its units written for a joint of ``effort``/``position`` units.

        ``templates`` (the :class:`~simgap.models.effects.FitSpec`) holds the unit
        templates; default: this effect's vocabulary entry.
        """
        fit = templates if templates is not None else VOCABULARY_SPECS[self.name].fit

        def unit(u: str) -> str:
            return format_unit(u, effort=effort, position=position)
        return replace(self, lin_units=tuple(unit(u) for u in fit.lin_units),
                       nl_units=tuple(unit(u) for u in fit.nl_units), unit=unit)

    def with_nominal(self, coefficients: Mapping[str, Any], index: int) -> Effect:
        """The effect as a signed correction of the nominal's own terms on channel ``index``.

        Args:
            coefficients: the nominal model's per-channel coefficients by name (its
                ``nominal_coefficients()``, e.g. ``{"damping": (0.4, 0.0)}``).
            index: the channel.

        Returns:
            The effect with each corrected coordinate's lower bound lowered to −(nominal
            value) where the nominal holds a positive value, and :attr:`nominal` set.
        """
        lower = list(self.lin_lower)
        nominal: dict[str, float] = {}
        for coord, coef in self.corrects:
            values = coefficients.get(coef)
            if values is None or coord not in self.lin:
                continue
            value = float(values[index])
            if value > 0:
                k = self.lin.index(coord)
                lower[k] = min(lower[k], -value)
                nominal[coord] = value
        if not nominal:
            return self
        return replace(self, lin_lower=tuple(lower), nominal=nominal)

    @property
    def upper(self) -> tuple[float, ...]:
        """Upper bounds of the linear parameters."""
        return self.lin_upper if self.lin_upper is not None else (np.inf,) * len(self.lin)

    @property
    def n_params(self) -> int:
        """Number of fitted parameters."""
        return len(self.lin) + len(self.nl)

    def __call__(self, lin: np.ndarray, nl: np.ndarray, sig: Mapping[str, np.ndarray],
                 index: int | None, sys: Any) -> np.ndarray:
        """Contribution to the residual, (N, n_channels), in channel units."""
        return self.fn(np.asarray(lin, dtype=np.float64), np.asarray(nl, dtype=np.float64),
                       sig, index, sys)


def identity_report(effect: Effect, lin: np.ndarray, nl: np.ndarray, cov: np.ndarray,
                    context: Mapping[str, Any]) -> tuple[dict, dict, dict]:
    """Report the internal parameters as they are; stderr from the covariance diagonal."""
    names = effect.lin + effect.nl
    units = effect.lin_units + effect.nl_units
    vals = np.concatenate([lin, nl])
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return ({n: float(v) for n, v in zip(names, vals, strict=True)},
            {n: float(s) for n, s in zip(names, se, strict=True)},
            dict(zip(names, units, strict=True)))


def _diagnosable(specs: tuple[EffectSpec, ...], *, generic: bool | None = None
                 ) -> tuple[Effect, ...]:
    """Diagnosable entries of a vocabulary, in the order candidates are tried in.

    Per-channel ones first, then whole-system ones, each in vocabulary order.
    """
    fit = [s for s in specs if s.fit is not None and s.vocabulary
           and (generic is None or s.fit.generic == generic)]
    ordered = [s for s in fit if s.scope == "channel"] + [s for s in fit if s.scope != "channel"]
    return tuple(Effect.of(s) for s in ordered)


#: Every vocabulary entry with a fit side, by name (both built-in systems).
VOCABULARY_SPECS: dict[str, EffectSpec] = {
    s.name: s for s in man.VOCABULARY + bic.VOCABULARY if s.fit is not None and s.vocabulary}
#: Effects of any mechanical model (per joint, then whole arm).
MECHANICAL_EFFECTS: tuple[Effect, ...] = _diagnosable(man.VOCABULARY, generic=True)
#: The two-link arm's own effects (payload at the tip of link 2, cubic stiffness).
ARM_EFFECTS: tuple[Effect, ...] = _diagnosable(man.VOCABULARY, generic=False)
PAYLOAD: Effect = next(e for e in ARM_EFFECTS if e.name == "payload_mass")
#: The vehicle's effects (per axle, then whole vehicle).
BICYCLE_EFFECTS: tuple[Effect, ...] = _diagnosable(bic.VOCABULARY)

VOCABULARY: dict[str, Effect] = {e.name: e for e in MECHANICAL_EFFECTS + ARM_EFFECTS
                                 + BICYCLE_EFFECTS}
#: Kept for one release: the axle signal keys now live with the vehicle's fit side.
AXLE_KEYS = bic.AXLE_KEYS


def needs_context(effect: Effect, index: int | None, fitted: Mapping[tuple[str, int | None],
                  tuple[float, float, float]]) -> dict[str, float]:
    """The fitted values an effect's report includes from the effects it ``needs``.

    Args:
        effect: the reported effect.
        index: its channel.
        fitted: ``(effect name, channel) -> (value, variance, covariance with this effect's
            first linear coordinate)`` of the first linear coordinate of the model's terms.

    Returns:
        ``{name: value, "var_" + name: variance, "cov_A_" + name: covariance}`` per needed
        effect present on the same channel (e.g. ``Fc``, ``var_Fc``, ``cov_A_Fc``).
    """
    ctx: dict[str, float] = {}
    for need in effect.needs:
        spec = VOCABULARY_SPECS.get(need)
        if spec is None or not spec.fit.lin or (need, index) not in fitted:
            continue
        name = spec.fit.lin[0]
        value, var, cov = fitted[(need, index)]
        ctx.update({name: value, f"var_{name}": var, f"cov_A_{name}": cov})
    return ctx


def nominal_corrections(effect: Effect, params: Mapping[str, float]) -> dict[str, dict]:
    """What a fitted correction does to the nominal's own coefficients (for the report).

    Returns:
        ``{coordinate: {"coefficient", "nominal", "corrected", "relative", "text"}}`` for
        each coordinate the effect corrects on a nominal that holds it; ``relative`` is the
        change over the nominal value: corrected = nominal·(1 + relative); ``nominal_error``
        is how far off the nominal was: nominal = corrected·(1 + nominal_error) ("the
        nominal damping is 15 % too high").
    """
    out: dict[str, dict] = {}
    names = dict(effect.corrects)
    for coord, nominal in effect.nominal.items():
        if coord not in params:
            continue
        corrected = nominal + float(params[coord])
        rel = float(params[coord]) / nominal
        # how far off the nominal was, relative to the corrected (fitted) value
        off = nominal / corrected - 1.0 if corrected > 0 else float("inf")
        verdict = "" if not np.isfinite(off) else (
            f": the nominal {names[coord]} is {100 * abs(off):.0f} % too "
            f"{'high' if off > 0 else 'low'}")
        out[coord] = {"coefficient": names[coord], "nominal": nominal, "corrected": corrected,
                      "relative": rel, "nominal_error": off,
                      "text": f" (the nominal {names[coord]} {nominal:.4g} → {corrected:.4g}, "
                              f"{100 * rel:+.0f} %{verdict})"}
    return out


def report_params(effect: Effect, lin: np.ndarray, nl: np.ndarray, cov: np.ndarray,
                  context: Mapping[str, Any] | None = None) -> tuple[dict, dict, dict]:
    """Return the reported (parameters, stderr, units) of a fitted effect."""
    fn = effect.to_report or identity_report
    params, stderr, units = fn(effect, np.asarray(lin), np.asarray(nl), np.asarray(cov),
                               dict(context or {}))
    return params, stderr, {k: effect.unit(u) for k, u in units.items()}
