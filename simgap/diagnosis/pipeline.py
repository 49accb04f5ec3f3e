"""The diagnosis pipeline: ``diagnose(recording, model) -> Report``.

    recording ─ recordings (validated) ─ systems.prepare (residual.py: filter, residual,
    noise floor) ─ locate (channels, segments, regions) ─ fit (effects.py vocabulary,
    held-out selection) ─ augmented (model object + JSON) ─ compare ─ report

How to plug in a model
----------------------
``diagnose`` accepts a model name (``"manipulator2dof"``, ``"bicycle"``), a nominal-model
object, or a ready *system adapter* (:mod:`simgap.diagnosis.systems`):

* **Mechanical systems** (anything with M(q) ddq + bias(q, dq) = tau, e.g. a 1-DOF prismatic
  axis): subclass :class:`simgap.models.base.MechanicalNominalModel`, implement ``M`` and
  ``bias`` (SI units; set ``residual_units`` to ``("N",)`` for a prismatic joint), and pass
  ``MechanicalSystem(model, ColumnMap(q=("pos",), dq=None, u=("voltage",),
  u_scale=(gain,)), channels=("axis",))``. ``dq=None`` differentiates positions twice;
  ``u_scale`` turns a logged voltage into force. The residual is then tau − M ddq − bias
  per joint and the joint-level vocabulary (friction, bias, spring, inertia, gravity) is
  tested; ``payload_mass`` only exists for the two-link arm.
* **State-space models with a force residual** like the bicycle: :class:`BicycleSystem`
  takes any :class:`~simgap.models.bicycle.BicycleNominal` (its parameters) and a
  :class:`ColumnMap` naming the vy, r, steering and vx columns (``u_scale`` converts e.g.
  steering-wheel angle to road-wheel angle).
* Something else: write an adapter with the same small interface (``prepare``,
  ``candidates``, ``rows``, ``zero_derivatives``, ``fit_mask``, ``locate_variables``,
  ``state_at``, ``derivative_at``, ``predicted_derivative``, ``step`` and the name/unit
  attributes) — see the two adapters, each ~200 lines.

The ``--model path.py:NAME`` loader (user files, column maps with scales/offsets) lives in
:mod:`simgap.diagnosis.custom` and builds one of these adapters.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simgap import plausibility
from simgap.diagnosis import locate
from simgap.diagnosis.augmented import AugmentedBicycle, AugmentedManipulator, AugmentedMechanical
from simgap.diagnosis.compare import Comparison, compare
from simgap.diagnosis.effects import report_params
from simgap.diagnosis.fit import Fitter, Selection, Term
from simgap.diagnosis.systems import BicycleSystem, MechanicalSystem
from simgap.errors import DiagnosisError
from simgap.models.base import MechanicalNominalModel
from simgap.models.bicycle import BicycleNominal, BicycleParams
from simgap.models.manipulator import ManipulatorNominal, ManipulatorParams
from simgap.recordings import Recording, RecordingError, read_recording, recording_from_arrays

MODELS = ("manipulator2dof", "bicycle")


#: The remainder left by the named effects is located when its RMS exceeds this many noise
#: floors and its mean square this share of the channel's residual.
REMAINDER_NOISE_FACTOR = 2.0
REMAINDER_SHARE = 0.1


@dataclass
class Report:
    """Everything the diagnosis found.

    Attributes:
        data: the ``report.json`` content (``spec/diagnosis.md`` schema 1).
        augmented: the augmented nominal model (nominal + named effects).
        system: the prepared adapter (signals, residual context).
        residual: residual on the uniform grid (N, C), channel units.
        noise: noise floor per channel.
        selection: the selection record (history, warnings).
        comparison: nominal vs augmented errors on the test part.
        fitted_pred: total fitted contribution on the grid (N, C), filtered.
        term_preds: per reported effect, its filtered contribution (N, C).
    """

    data: dict[str, Any]
    augmented: Any
    system: Any
    residual: np.ndarray
    noise: np.ndarray
    selection: Selection
    comparison: Comparison
    fitted_pred: np.ndarray
    term_preds: list[np.ndarray] = field(default_factory=list)

    @property
    def significant(self) -> bool:
        """Whether a mismatch beyond the noise was found."""
        return bool(self.data["mismatch"]["significant"])

    @property
    def effects(self) -> list[dict[str, Any]]:
        """The named effects (report.json ``effects``)."""
        return self.data["effects"]


def _apply_overrides(cls: type, overrides: Mapping[str, Any] | None, model: str):
    overrides = dict(overrides or {})
    names = {f for f in cls.__dataclass_fields__}
    for k, v in overrides.items():
        if k not in names:
            raise DiagnosisError(f"unknown parameter {k!r} for model {model}; "
                                 f"known: {', '.join(sorted(names))}")
        if not isinstance(v, (int, float, list, tuple)) or isinstance(v, bool):
            raise DiagnosisError(f"parameter {k!r} must be a number, got {v!r}")
    plausibility.check_params(cls, overrides, model)
    try:
        return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in overrides.items()})
    except (TypeError, ValueError) as err:
        raise DiagnosisError(f"bad parameter value for model {model}: {err}") from None


def make_system(model: str | Any, params: Mapping[str, Any] | None = None) -> Any:
    """Adapter for a model name, a nominal-model object or an adapter (returned as is)."""
    if isinstance(model, str):
        if model == "manipulator2dof":
            return MechanicalSystem(ManipulatorNominal(
                _apply_overrides(ManipulatorParams, params, model)), name=model)
        if model == "bicycle":
            return BicycleSystem(BicycleNominal(_apply_overrides(BicycleParams, params, model)))
        raise DiagnosisError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    if params:
        raise DiagnosisError("parameter overrides apply to built-in model names only")
    if isinstance(model, BicycleNominal):
        return BicycleSystem(model)
    if isinstance(model, MechanicalNominalModel):
        return MechanicalSystem(model)
    if hasattr(model, "prepare") and hasattr(model, "candidates"):
        return model
    raise DiagnosisError(f"cannot diagnose with {model!r}: pass a model name, a "
                         "MechanicalNominalModel, a BicycleNominal or a system adapter")


def fmt(value: float, stderr: float) -> tuple[str, str]:
    """Round a value and its stderr to the stderr's second significant digit."""
    if not np.isfinite(stderr) or stderr <= 0:
        return f"{value:.4g}", f"{stderr:.2g}"
    dec = max(0, int(-np.floor(np.log10(stderr))) + 1)
    return f"{value:.{dec}f}", f"{stderr:.{dec}f}"


def _channel_label(ch: str) -> str:
    return ch.replace("joint", "joint ").replace("_axle", " axle")


def _effect_entries(fitter: Fitter, sel: Selection, system: Any
                    ) -> tuple[list[dict], list[np.ndarray], list[tuple], float]:
    fit = sel.fit
    test = fitter.test
    r = fitter.r[test] * fitter.w
    total = fit.total(fitter.n, fitter.c)[test] * fitter.w
    resid = r - total
    slices = fit.slices()
    entries, preds, fitted = [], [], []
    coulomb = {t.index: i for i, t in enumerate(fit.terms) if t.effect.name == "coulomb_friction"}
    for i, term in enumerate(fit.terms):
        sl = slices[i]
        ctx: dict[str, float] = {}
        if term.effect.name == "stribeck_friction" and term.index in coulomb:
            j = coulomb[term.index]
            ctx = {"Fc": float(fit.lin[j][0]), "var_Fc": float(fit.cov[slices[j], slices[j]][0, 0]),
                   "cov_A_Fc": float(fit.cov[sl.start, slices[j].start])}
        params, se, units = report_params(term.effect, fit.lin[i], fit.nl[i], fit.cov[sl, sl], ctx)
        p_i = fit.pred[i][test] * fitter.w
        cols = [term.index] if term.index is not None else list(range(fitter.c))
        without = resid[:, cols] + p_i[:, cols]
        base = float(np.sum(r[:, cols] ** 2))
        frac = (float(np.sum(without**2)) - float(np.sum(resid[:, cols] ** 2))) / base \
            if base > 0 else 0.0
        channel = term.channel
        if term.effect.scope == "arm":
            channel = system.channels[int(np.argmax(np.sum(p_i**2, axis=0)))]
        parts = []
        for name in params:
            v, s = fmt(params[name], se[name])
            unit = units[name]
            parts.append(f"{name} = {v} ± {s}{'' if unit == '-' else ' ' + unit}")
        where = "the whole arm" if term.effect.scope == "arm" else (
            "the vehicle" if term.effect.scope == "vehicle" else _channel_label(channel))
        text = (f"{term.effect.label[0].upper()}{term.effect.label[1:]} at {where}, "
                f"{', '.join(parts)}")
        entries.append({"effect": term.effect.name, "channel": channel,
                        "parameters": {k: float(v) for k, v in params.items()},
                        "stderr": {k: float(v) for k, v in se.items()},
                        "units": units,
                        "explained_fraction": round(min(1.0, max(0.0, frac)), 4),
                        "text": text,
                        "summary": f"{text}, explains {100 * min(1.0, max(0.0, frac)):.0f} % "
                                   f"of the residual "
                                   f"{'there' if term.index is not None else 'overall'}"})
        preds.append(fit.pred[i])
        fitted.append((term.effect, term.index, fit.lin[i], fit.nl[i]))
    return entries, preds, fitted, float(np.sum(resid**2))


def diagnose(recording: Recording | str | os.PathLike, model: str | Any = "manipulator2dof",
             params: Mapping[str, Any] | None = None, *, horizon: float | None = None,
             train_fraction: float = 0.7) -> Report:
    """Diagnose a recording against a nominal model.

    Args:
        recording: a :class:`Recording` or a CSV/Parquet path.
        model: ``"manipulator2dof"``, ``"bicycle"``, a nominal-model object or an adapter.
        params: overrides of the nominal parameters by name (built-in models).
        horizon: simulation window of the comparison (s); default per system.
        train_fraction: earliest share of the recording used for fitting.

    Returns:
        The :class:`Report`.

    Raises:
        RecordingError: unusable recording (one-line message).
        DiagnosisError: unknown model or parameter.
    """
    system = make_system(model, params)
    required = system.columns.required
    if isinstance(recording, Recording):  # validated like a file
        rec = recording_from_arrays(recording.name, recording.columns, required,
                                    meta=recording.meta)
    else:
        rec = read_recording(recording, required)
    plausibility.check_recording(rec, system)  # units, magnitudes, motion (one line)
    try:
        res = system.prepare(rec)
    except ValueError as err:
        raise RecordingError(str(err).splitlines()[0]) from None
    plausibility.check_prepared(rec, system)
    stats = locate.channel_stats(system.channels, res.residual, res.noise_rms)
    try:
        fitter = Fitter(system, res.residual, res.noise_rms, train_fraction,
                        mask=system.fit_mask())
    except ValueError as err:
        raise RecordingError(f"{rec.name}: {err}") from None
    candidates = [Term(e, j, ch) for e, j, ch in system.candidates()]
    sel = fitter.select(candidates)
    entries, preds, fitted, sse_all = _effect_entries(fitter, sel, system)
    sig_idx = [i for i, s in enumerate(stats) if s.significant] or list(range(fitter.c))
    r_te = fitter.r[fitter.test] * fitter.w
    resid_te = r_te - sel.fit.total(fitter.n, fitter.c)[fitter.test] * fitter.w
    base = float(np.sum(r_te[:, sig_idx] ** 2))
    unexplained = float(np.sum(resid_te[:, sig_idx] ** 2)) / base if base > 0 else 1.0
    noise_share = float(len(fitter.test) * len(sig_idx)) / base if base > 0 else 1.0
    significant = any(s.significant for s in stats) or bool(entries)
    segs, regs = [], []
    variables = system.locate_variables()
    # what the named effects leave over (stick phases masked as in the fit): the spec asks
    # for "where it sits" of what no term explains, so it is located too
    remainder = (fitter.r - sel.fit.total(fitter.n, fitter.c)) * fitter.mask
    for i, s in enumerate(stats):
        named_here = any(e["channel"] == s.channel for e in entries)
        if s.significant or named_here:
            segs += locate.segments(res.t, res.residual[:, i], s.noise_rms, s.channel)
            regs += [dict(reg, of="residual") for reg in locate.regions(
                s.channel, system.channel_units[i], res.residual[:, i], variables)]
        rem_ms = float(np.mean(remainder[:, i] ** 2))
        raw_ms = float(np.mean(fitter.r[:, i] ** 2))
        if (named_here and rem_ms > (REMAINDER_NOISE_FACTOR * s.noise_rms) ** 2
                and rem_ms > REMAINDER_SHARE * raw_ms):
            regs += [dict(reg, of="unexplained", text=f"unexplained remainder: {reg['text']}")
                     for reg in locate.regions(s.channel, system.channel_units[i],
                                               remainder[:, i], variables)]
    comp = compare(system, fitted, fitter.t_split, horizon)
    if isinstance(system, BicycleSystem):
        vx_mean = float(np.mean(system.sig["vx"]))
        augmented = AugmentedBicycle([{"effect": e["effect"], "channel": e["channel"],
                                       "params": e["parameters"]} for e in entries],
                                     system.params, vx=max(vx_mean, 1.01), dt=system.smoother.dt)
    elif isinstance(system.model, ManipulatorNominal):
        augmented = AugmentedManipulator([{"effect": e["effect"], "channel": e["channel"],
                                           "params": e["parameters"]} for e in entries],
                                         system.model.params, sigma=system.coulomb_sigma,
                                         dt=system.smoother.dt)
    else:
        augmented = AugmentedMechanical(system.model, system, fitted)
    t = res.t
    data = {
        "schema": 1,
        "model": system.name,
        "recording": rec.name,
        "samples": int(rec.n),
        "mismatch": {
            "significant": bool(significant),
            "channels": [{"channel": s.channel, "residual_rms": s.residual_rms,
                          "noise_rms": s.noise_rms, "significant": s.significant,
                          "unit": system.channel_units[i]} for i, s in enumerate(stats)],
            "segments": segs,
            "regions": regs,
        },
        "effects": entries,
        "unexplained_fraction": round(min(1.0, unexplained), 4),
        "noise_fraction": round(min(1.0, noise_share), 4),
        "warnings": sel.warnings,
        "fit": {
            "split": {"train": [float(t[0]), fitter.t_split],
                      "test": [fitter.t_split, float(t[-1])]},
            "nominal": {"derivative_rmse": comp.derivative_rmse["nominal"],
                        "rollout_rmse": comp.rollout_rmse["nominal"],
                        "rollout_score": comp.score["nominal"]},
            "augmented": {"derivative_rmse": comp.derivative_rmse["augmented"],
                          "rollout_rmse": comp.rollout_rmse["augmented"],
                          "rollout_score": comp.score["augmented"]},
            "derivative_names": list(system.derivative_names),
            "derivative_units": list(system.derivative_units),
            "rollout_names": list(system.state_names),
            "rollout_units": list(system.state_units),
            "horizon_s": comp.horizon,
            "method": (f"open-loop simulation over back-to-back {comp.horizon:g} s windows of "
                       "the test part, from the recorded (filtered) state with the recorded "
                       "inputs replayed; a controller in the loop is not modelled, its "
                       "recorded output is the input"),
        },
        "processing": {
            "sample_period_s": float(system.smoother.dt),
            "resampled_to_uniform_grid": bool(res.resampled),
            "savgol_window_samples": int(system.smoother.window),
            "column_noise_std": {k: float(v) for k, v in res.column_noise.items()},
        },
    }
    return Report(data=data, augmented=augmented, system=system, residual=res.residual,
                  noise=res.noise_rms, selection=sel, comparison=comp,
                  fitted_pred=sel.fit.total(fitter.n, fitter.c), term_preds=preds)


def default_out_dir(recording: str | os.PathLike) -> Path:
    """``./simgap-report/<recording stem>/`` (spec default)."""
    return Path("simgap-report") / Path(recording).stem
