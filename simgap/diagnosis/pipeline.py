"""The diagnosis pipeline: ``diagnose(recording, model) -> Report``.

    recording ─ recordings (validated) ─ systems.prepare (residual.py: filter, residual,
    noise floor) ─ locate (channels, segments, regions) ─ fit (effects.py vocabulary,
    held-out selection) ─ augmented (model object + JSON) ─ compare ─ report

How to plug in a model
----------------------
``diagnose`` is the one entry point (the CLI calls it too). ``model`` is a built-in name
(``"manipulator2dof"``, ``"bicycle"``), ``"path/to/model.py:NAME"``
(:mod:`simgap.diagnosis.user_models`), a nominal-model object, or a ready *system adapter*
(:mod:`simgap.diagnosis.systems`). Whichever way a model comes in, it gets the same adapter
(:func:`make_system`):

* the two-link arm (``ManipulatorNominal``): inverse dynamics with the arm's fast kernels and
  the payload effect;
* any other :class:`simgap.models.base.MechanicalNominalModel` (e.g. a 1-DOF prismatic axis,
  :class:`~simgap.models.prismatic.RigidAxisNominal`): inverse dynamics over the model's own
  canonical columns (``obs_names``, ``input_names``) with its own units (N and m for a slider);
  velocities are read when the recording has them and derived from positions otherwise;
* a :class:`~simgap.models.bicycle.BicycleNominal`: the axle-force residual K⁻¹ g.

The recording is read into the model's canonical columns
(:class:`~simgap.recordings.RecordingSchema`); a file with other names or units is
translated by a :class:`~simgap.recordings.ColumnMap` (``columns=``, or the model's
``column_map``), e.g. a steering-wheel angle in degrees scaled to the road-wheel angle.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simgap import plausibility
from simgap.diagnosis import locate
from simgap.diagnosis.augmented import AugmentedBicycle, AugmentedManipulator, AugmentedMechanical
from simgap.diagnosis.compare import Comparison, compare
from simgap.diagnosis.effects import needs_context, nominal_corrections, report_params
from simgap.diagnosis.fit import ALPHA, Fitter, Selection, Term
from simgap.diagnosis.forms import Prepared
from simgap.diagnosis.shares import explained_section
from simgap.diagnosis.significance import StructureTest, structure_test
from simgap.diagnosis.systems import AdapterColumns, BicycleSystem, MechanicalSystem
from simgap.diagnosis.user_models import check_model, is_adapter, load_model_file
from simgap.diagnosis.user_models import column_map_of as _column_map_of
from simgap.diagnosis.validation import gap_segments
from simgap.errors import DiagnosisError
from simgap.models.base import MechanicalNominalModel
from simgap.models.bicycle import BicycleNominal
from simgap.models.manipulator import ManipulatorNominal
from simgap.recordings import (
    ColumnMap,
    Recording,
    RecordingError,
    RecordingSchema,
    conform,
    read_recording,
    recording_from_arrays,
)
from simgap.recordings import read as read_columns
from simgap.schema import check_input_hold
from simgap.systems import get_system, system_of_file, system_of_model

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
        system: the residual form (adapter) used.
        prepared: the recording as the form prepared it (immutable: signals, residual,
            noise floor, fit mask).
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
    prepared: Prepared
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


def resolve_model(model: str | Any, params: Mapping[str, Any] | None = None
                  ) -> tuple[Any, str | None]:
    """The nominal model (or ready adapter) a ``diagnose`` argument names.

    Args:
        model: a built-in name (:data:`MODELS`), ``path/to/model.py:NAME``, a nominal-model
            object or a ready adapter.
        params: overrides of the nominal parameters by name (built-in names only).

    Returns:
        (model or adapter, the ``path.py:NAME`` spec or ``None``).

    Raises:
        DiagnosisError: unknown name or parameter, overrides for a non-built-in model.
        CustomModelError: an unusable model file or model object.
    """
    if isinstance(model, str):
        if ":" not in model:  # a registered system (simgap.systems)
            try:
                spec = get_system(model, DiagnosisError)
            except DiagnosisError as err:
                raise DiagnosisError(f"{err}; or a user model path/to/model.py:NAME") from None
            if spec.residual_form is None or spec.nominal is None or spec.params_cls is None:
                raise DiagnosisError(f"system {model!r} has no diagnosis adapter")
            return spec.nominal(_apply_overrides(spec.params_cls, params, model), None), None
        if params:
            raise DiagnosisError(f"parameter overrides apply to built-in models only; set the "
                                 f"parameters in {model.rsplit(':', 1)[0]}")
        return load_model_file(model), model
    if params:
        raise DiagnosisError("parameter overrides apply to built-in model names only")
    if is_adapter(model):
        return model, None
    if not isinstance(model, MechanicalNominalModel | BicycleNominal):
        raise DiagnosisError(f"cannot diagnose with {model!r}: pass a model name, a "
                             "MechanicalNominalModel, a BicycleNominal or a system adapter")
    check_model(model)
    return model, None


def make_system(model: str | Any, params: Mapping[str, Any] | None = None, *,
                recorded: Iterable[str] | None = None) -> Any:
    """Adapter for a model name, a nominal-model object or an adapter (returned as is).

    One rule for every way in (Python API, CLI, built-in or user model): the two-link arm
    gets the arm's adapter, a bicycle-type model the force-residual adapter, and any other
    mechanical model an adapter over its own canonical columns and units.

    Args:
        model: see :func:`resolve_model`.
        params: overrides of the nominal parameters (built-in names).
        recorded: canonical columns the recording holds; decides whether a mechanical
            model's velocities are read or derived. ``None``: from the model's declaration.
    """
    obj, _ = resolve_model(model, params)
    return _adapter(obj, None if recorded is None else set(recorded))


def _adapter(model: Any, recorded: set[str] | None) -> Any:
    """The residual form of a model (its registered system's ``residual_form``).

    A model of no registered system gets the generic mechanical form over its own columns
    and units.
    """
    if is_adapter(model):
        return model
    spec = system_of_model(model)
    if spec is not None and spec.residual_form is not None:
        return spec.resolve("residual_form")(model)
    velocities = None
    if recorded is not None:
        n = len(model.input_names)
        velocities = all(c in recorded for c in tuple(model.obs_names)[n:2 * n])
    return MechanicalSystem(model, velocities=velocities)


def _column_map(columns: ColumnMap | Mapping[str, Any] | str | os.PathLike | None
                ) -> ColumnMap | None:
    """A column map from its object, JSON-dict or JSON-file form (``None`` stays ``None``)."""
    if isinstance(columns, Mapping):
        return ColumnMap.from_dict(columns)
    if isinstance(columns, str | os.PathLike):
        return ColumnMap.from_json(columns)
    return columns


def _with_hold(system: Any, hold: str | None) -> Any:
    """The adapter with a declared input hold in its columns (``None``: as it is)."""
    cols = getattr(system, "columns", None)
    if hold is None or not isinstance(cols, AdapterColumns) or cols.input_hold == hold:
        return system
    system.columns = dataclasses.replace(cols, input_hold=check_input_hold(hold))
    return system


def _read(recording: Recording | str | os.PathLike, model: Any,
          columns: ColumnMap | Mapping[str, Any] | str | os.PathLike | None) -> Recording:
    """The recording in the model's canonical columns (validated like a file).

    An explicit ``columns`` map always applies. The model's own ``column_map`` applies to
    files, and to in-memory recordings unless they already hold the canonical columns.
    """
    columns = _column_map(columns)
    if is_adapter(model):  # a ready adapter reads its own column names
        if columns is not None:
            raise DiagnosisError("a column map applies to models, not to a ready adapter")
        required = model.columns.required
        if isinstance(recording, Recording):
            return recording_from_arrays(recording.name, recording.columns, required,
                                         meta=recording.meta)
        return read_recording(recording, required)
    schema = RecordingSchema.of(model)
    cmap = columns
    if cmap is None and getattr(model, "column_map", None) is not None:
        cmap = _column_map_of(model)  # the model's own map, checked against its schema
        if isinstance(recording, Recording) and all(c in recording.columns
                                                    for c in schema.required):
            cmap = None  # an in-memory recording already in canonical columns
    if isinstance(recording, Recording):
        return conform(recording, schema, cmap)
    return read_columns(recording, schema, cmap)


def first_seconds(rec: Recording, duration: float) -> Recording:
    """Keep the first ``duration`` seconds of a recording (a quick look at a long one)."""
    if not np.isfinite(duration) or duration <= 0:
        raise DiagnosisError(f"duration must be a positive number of seconds, got "
                             f"{duration!r}")
    keep = rec.t <= rec.t[0] + duration
    return Recording(rec.name, {k: v[keep] for k, v in rec.columns.items()}, dict(rec.meta))


def fmt(value: float, stderr: float) -> tuple[str, str]:
    """Round a value and its stderr to the stderr's second significant digit."""
    if not np.isfinite(stderr) or stderr <= 0:
        return f"{value:.4g}", f"{stderr:.2g}"
    dec = max(0, int(-np.floor(np.log10(stderr))) + 1)
    return f"{value:.{dec}f}", f"{stderr:.{dec}f}"


def _channel_label(ch: str) -> str:
    return ch.replace("joint", "joint ").replace("_axle", " axle")


def _input_latency(system: Any, prepared: Any, term: Any, params: dict[str, float],
                   se: dict[str, float]) -> dict[str, Any] | None:
    """The identifiable input latency of a named input delay whose split is not determined.

    A log cannot tell how long each logged input was held before it acted (the hold lag,
    ½ log sample for a command held until the next sample, less for a log slower than its
    controller) from a transport delay: the input acts at t − (hold lag + delay) either
    way, and only that total is identified. When the columns declare the hold
    (``ColumnMap.input_hold``, ``--input-hold``), the split is the declaration's; when they
    do not (``"auto"``), the hold lag is the one the equation chose
    (``MechanicalSystem._choose_hold``, ZOH unless the data reject it), so the delay is
    reported *on top of an assumed hold*: measured on 100 Hz logs of a 500 Hz loop, a
    13.3 ms delay was read as 9.6 ms on a 5 ms hold (total 14.6 ms; true 13.3 + 1 ms).
    Then the entry states the total (s) with the delay's standard error (the hold lag is
    fixed in the fit, so the total's error is the delay's) and that the split is not
    determined.

    Returns:
        ``{"total": s, "stderr": s, "hold_lag": s, "split_determined": False, "text"}``,
        or None (not an input delay, a declared hold, or a form without a hold lag).
    """
    hold = getattr(getattr(prepared, "plan", None), "hold", None)
    cols = getattr(system, "columns", None)
    if term.effect.name != "input_delay" or hold is None or \
            getattr(cols, "input_hold", "auto") != "auto" or "delay" not in params:
        return None
    lag = float(hold) * prepared.dt
    total, err = float(params["delay"]) + lag, float(se.get("delay", float("nan")))
    v, s = fmt(1e3 * total, 1e3 * err)
    return {"total": total, "stderr": err, "hold_lag": lag, "split_determined": False,
            "text": (f"; total input latency (hold lag + delay) = {v} ± {s} ms, the "
                     f"identifiable quantity; the split is not determined: the delay is "
                     f"reported on an assumed hold lag of {1e3 * lag:.3g} ms, and any hold "
                     f"lag from 0 to half a log sample ({1e3 * 0.5 * prepared.dt:.3g} ms) "
                     "fits as well (declare the hold with --input-hold)")}


def _effect_entries(fitter: Fitter, sel: Selection, system: Any
                    ) -> tuple[list[dict], list[np.ndarray], list[tuple], float]:
    fit = sel.fit
    test = fitter.test
    r = fitter.r[test] * fitter.w
    total = fit.total(fitter.n, fitter.c)[test] * fitter.w
    resid = r - total
    slices = fit.slices()
    entries, preds, fitted = [], [], []
    for i, term in enumerate(fit.terms):
        if term.key in fitter.combinations:   # fitted as a combination, not named
            continue
        sl = slices[i]
        # what the effects this one needs on its channel fitted (Stribeck's Fs includes Fc)
        ctx = needs_context(term.effect, term.index, {
            (t.effect.name, t.index): (float(fit.lin[k][0]),
                                       float(fit.cov[slices[k].start, slices[k].start]),
                                       float(fit.cov[sl.start, slices[k].start]))
            for k, t in enumerate(fit.terms) if len(fit.lin[k])})
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
        testable = fitter.testable_held_out(term, fit.nl[i])  # information and power
        parts = []
        for name in params:
            v, s = fmt(params[name], se[name])
            unit = units[name]
            parts.append(f"{name} = {v} ± {s}{'' if unit == '-' else ' ' + unit}")
        where = "the whole arm" if term.effect.scope == "arm" else (
            "the vehicle" if term.effect.scope == "vehicle" else _channel_label(channel))
        text = (f"{term.effect.label[0].upper()}{term.effect.label[1:]} at {where}, "
                f"{', '.join(parts)}")
        corrections = nominal_corrections(term.effect, params)
        text += "".join(c["text"] for c in corrections.values())
        latency = _input_latency(system, fitter.prepared, term, params, se)
        if latency is not None:
            text += latency["text"]
        share = round(min(1.0, max(0.0, frac)), 4) if testable else 0.0
        held_out = "" if testable else (f"cannot test: the held-out part holds no information "
                                        f"about {term.effect.label} at {where}"
                                        + fitter.untestable_note(term))
        entries.append({"effect": term.effect.name, "channel": channel,
                        "parameters": {k: float(v) for k, v in params.items()},
                        "stderr": {k: float(v) for k, v in se.items()},
                        "units": units,
                        "explained_fraction": share,
                        "testable_held_out": bool(testable),
                        **({"nominal_correction": corrections} if corrections else {}),
                        **({"input_latency": latency} if latency is not None else {}),
                        "text": text,
                        "summary": (f"{text}, explains {100 * share:.0f} % of the held-out "
                                    f"residual "
                                    f"{'there' if term.index is not None else 'overall'}")
                        if testable else f"{text} ({held_out})"})
        preds.append(fit.pred[i])
        fitted.append((term.effect, term.index, fit.lin[i], fit.nl[i]))
    return entries, preds, fitted, float(np.sum(resid**2))


def diagnose(recording: Recording | str | os.PathLike, model: str | Any = "manipulator2dof",
             params: Mapping[str, Any] | None = None, *,
             columns: ColumnMap | Mapping[str, Any] | str | os.PathLike | None = None,
             horizon: float | None = None, train_fraction: float = 0.7,
             duration: float | None = None, input_hold: str | None = None) -> Report:
    """Diagnose a recording against a nominal model (the one entry point).

    The CLI (``simgap diagnose``) calls this too, so a model gives the same columns, units
    and numbers whether it is named on the command line or passed as an object.

    Args:
        recording: a :class:`Recording` or a CSV/Parquet path.
        model: ``"manipulator2dof"``, ``"bicycle"``, ``"path/to/model.py:NAME"``, a
            nominal-model object or a ready adapter.
        params: overrides of the nominal parameters by name (built-in models).
        columns: where the model's canonical columns come from in the file: a
            :class:`~simgap.recordings.ColumnMap`, a dict in its JSON form, or the path of
            such a JSON file. Default: the model's own ``column_map``, else the canonical
            names.
        horizon: simulation window of the comparison (s); default per system.
        train_fraction: earliest share of the recording used for fitting.
        duration: diagnose only the first ``duration`` seconds (s); ``None`` = all.
        input_hold: how the logged inputs relate to the acting ones: ``"zoh"`` (held until
            the next sample), ``"sample"`` (point samples) or ``"auto"`` (decided from the
            data). ``None``: the column map's ``input_hold``, else the model's declaration
            (its column map or recording schema), else ``"auto"``.

    Returns:
        The :class:`Report`. Its ``processing`` section records the model file and the
        column map used (and what the map changed, e.g. despiked rows).

    Raises:
        RecordingError: unusable recording (one-line message).
        DiagnosisError: unknown model or parameter.
        CustomModelError: unusable model file, model or column map.
    """
    by_file = system_of_file(model)  # a model file of a registered system (MJCF .xml)
    if by_file is not None:
        if params:
            raise DiagnosisError(f"parameter overrides do not apply to {model}; edit the file")
        return by_file.resolve("diagnose_file")(model, recording, columns=columns,
                                                duration=duration, horizon=horizon,
                                                train_fraction=train_fraction,
                                                input_hold=input_hold)
    obj, spec = resolve_model(model, params)
    columns = _column_map(columns)
    rec = _read(recording, obj, columns)
    if duration is not None:
        rec = first_seconds(rec, duration)
    # a declared hold: the argument, else the map's; the model's own in the adapter
    system = _with_hold(_adapter(obj, set(rec.columns)), input_hold if input_hold is not None
                        else getattr(columns, "input_hold", None))
    plausibility.check_recording(rec, system)  # units, magnitudes, motion (one line)
    report = _run(rec, system, horizon, train_fraction)
    processing = report.data["processing"]
    if spec is not None:
        processing["model_file"] = spec
    for key in ("column_map", "notes"):
        if key in rec.meta:
            processing[key] = rec.meta[key]
    if spec is not None and hasattr(report.augmented, "source"):
        report.augmented.source = spec
    return report


def _run(rec: Recording, system: Any, horizon: float | None,
         train_fraction: float) -> Report:
    """The pipeline on a validated recording in the adapter's columns."""
    try:
        res = system.prepare(rec)
    except ValueError as err:
        raise RecordingError(str(err).splitlines()[0]) from None
    plausibility.check_prepared(rec, system, res)
    stats = locate.channel_stats(system.channels, res.residual, res.noise_rms)
    mask = res.fit_mask
    segment = getattr(res, "segment", None)
    if segment is None:   # rows interpolated across a gap are not data: never fitted
        segment, inside = gap_segments(rec.t, res.t)
        mask = mask * ~inside[:, None]
    try:
        fitter = Fitter(system, res, train_fraction, mask=mask, segments=segment)
    except ValueError as err:
        raise RecordingError(f"{rec.name}: {err}") from None
    candidates = [Term(e, j, ch) for e, j, ch in system.candidates(res)]
    sel = fitter.select(candidates)
    entries, preds, fitted, sse_all = _effect_entries(fitter, sel, system)
    structure = structure_tests(system, res, fitter)
    level = ALPHA / max(len(stats), 1)
    # terms that passed their held-out test in the selection but whose parameters the data
    # do not determine (dropped by the joint identifiability check): a mismatch is there
    # (say where and what fits it), its shape is not named
    undetermined = [e for e in sel.tried if e.get("decision") == "not identifiable"
                    and e.get("p_value") is not None and e["p_value"] < ALPHA
                    and (e["effect"], e["channel"]) not in
                    {(k[0], system.channels[k[1]] if k[1] is not None else None)
                     for k in fitter.combinations}]
    # terms kept in the fit as a combination the data do not identify (fit.py, e.g. a dead
    # zone the command cannot tell from a relay): their significant gain is a mismatch too,
    # which their fit then explains (the residual after it would otherwise say "no mismatch")
    combined = [e for e in sel.tried if e.get("decision") == "not identifiable"
                and e.get("p_value") is not None and e["p_value"] < ALPHA
                and (e["effect"], e["channel"]) in
                {(k[0], system.channels[k[1]] if k[1] is not None else None)
                 for k in fitter.combinations}]
    mismatch = bool(entries) or bool(undetermined) or bool(combined) or any(
        s.significant and g.significant(level) for s, g in zip(stats, structure, strict=True))
    untested = [] if mismatch else untested_channels(stats, sel.tried, system)
    hit_channels = {e["channel"] for e in undetermined + combined}
    stats = [dataclasses.replace(s, significant=(s.significant and mismatch)
                                 or s.channel in hit_channels) for s in stats]
    sig_idx = [i for i, s in enumerate(stats) if s.significant] or list(range(fitter.c))
    r_te = fitter.r[fitter.test] * fitter.w
    resid_te = r_te - sel.fit.total(fitter.n, fitter.c)[fitter.test] * fitter.w
    base = float(np.sum(r_te[:, sig_idx] ** 2))
    unexplained = float(np.sum(resid_te[:, sig_idx] ** 2)) / base if base > 0 else 1.0
    noise_share = float(len(fitter.test) * len(sig_idx)) / base if base > 0 else 1.0
    significant = any(s.significant for s in stats) or bool(entries)
    segs, regs = [], []
    variables = system.locate_variables(res)
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
    del remainder
    comp = compare(system, res, fitted, fitter.t_split, horizon)
    if isinstance(system, BicycleSystem):
        vx_mean = float(np.mean(res.signals["vx"]))
        augmented = AugmentedBicycle([{"effect": e["effect"], "channel": e["channel"],
                                       "params": e["parameters"]} for e in entries],
                                     system.params, vx=max(vx_mean, 1.01), dt=res.dt)
    elif isinstance(system.model, ManipulatorNominal):
        augmented = AugmentedManipulator([{"effect": e["effect"], "channel": e["channel"],
                                           "params": e["parameters"]} for e in entries],
                                         system.model.params, sigma=res.coulomb_sigma,
                                         dt=res.dt)
    else:
        augmented = AugmentedMechanical(system.model, system, fitted,
                                        coulomb_sigma=res.coulomb_sigma, effects=[
            {"effect": e["effect"], "channel": e["channel"], "params": e["parameters"]}
            for e in entries])
    t = res.t
    spans = _block_spans(t, fitter.test, fitter.split.confirm_block)
    data = {
        "schema": 1,
        "model": system.name,
        "recording": rec.name,
        "samples": int(rec.n),
        "mismatch": {
            "significant": bool(significant),
            "channels": [{"channel": s.channel, "residual_rms": s.residual_rms,
                          "noise_rms": s.noise_rms, "significant": s.significant,
                          "unit": system.channel_units[i],
                          "structure": _structure_entry(structure[i], level)}
                         for i, s in enumerate(stats)],
            "segments": segs,
            "regions": regs,
        },
        "effects": entries,
        "unexplained_fraction": round(min(1.0, unexplained), 4),
        "noise_fraction": round(min(1.0, noise_share), 4),
        "warnings": sel.warnings,
        "tried": [_jsonable(e) for e in sel.tried],
        "identifiability": sel.identifiability,
        "verdict": verdict(entries, stats, system, unexplained if base > 0 and any(
            e["testable_held_out"] for e in entries) else None,
            bool(undetermined or combined), untested=untested),
        "fit": {
            "split": {"train": [float(t[0]), fitter.t_split],
                      "test": [fitter.t_split, float(t[-1])],
                      "test_blocks": spans,
                      "method": _split_method(spans, train_fraction,
                                              len(np.unique(fitter.split.valid_block))),
                      "rows": {"train": int(len(fitter.train)),
                               "validation": int(len(fitter.valid)),
                               "test": int(len(fitter.test))}},
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
            "sample_period_s": float(res.smoother.dt),
            "resampled_to_uniform_grid": bool(res.resampled),
            "savgol_window_samples": int(res.smoother.window),
            "column_noise_std": {k: float(v) for k, v in res.column_noise.items()},
            "filter": type(res.smoother).__name__,
            "segments": int(len(np.unique(res.segment))) if res.segment is not None else 1,
            "signal_notes": list(res.warnings),
        },
    }
    if undetermined:
        data["verdict"] += " Not determined on this data (a significant held-out gain, " \
            "not named): " + "; ".join(
                f"{e['effect']} at {_channel_label(e['channel'])} (p = {e['p_value']:.2g}; "
                + ", ".join(f"{k} = {v:.3g}" for k, v in e["params"].items()) + "): "
                + e["reason"] for e in undetermined)
    if fitter.combinations:   # fitted as identifiable combinations, not named (fit.py)
        data["verdict"] += (" Not identifiable on this data (fitted as a combination, not "
                            "named): " + "; ".join(fitter.combinations.values()))
    data["explained"] = explained_section(  # additive shares (simgap.diagnosis.shares)
        r_te[:, sig_idx], [(p[fitter.test] * fitter.w)[:, sig_idx] for p in preds], entries,
        [system.channels[i] for i in sig_idx], min(1.0, noise_share))
    return Report(data=data, augmented=augmented, system=system, prepared=res,
                  residual=res.residual,
                  noise=res.noise_rms, selection=sel, comparison=comp,
                  fitted_pred=sel.fit.total(fitter.n, fitter.c), term_preds=preds)


#: Variables derived from a derivative, beside ``system.derivative_names``: they share the
#: residual's differentiated measurement error and are not used by the structure test.
DERIVED_VARIABLES = ("ay",)


def structure_tests(system: Any, prepared: Prepared, fitter: Fitter) -> list[StructureTest]:
    """Per channel: whether the residual is a function of the operating point, held out.

    The mismatch test (issue 13, "significance as a statistical test with an honest
    floor"). A recording has a mismatch when an effect is named (it passed its own
    held-out tests) or when some channel's residual RMS exceeds the propagated noise floor
    by :data:`simgap.diagnosis.locate.SIGNIFICANCE` (the floor is itself estimated: the
    factor is its allowance, not an effect size) **and** that residual's dependence on the
    operating point passes :func:`.significance.structure_test` at ``ALPHA`` shared by the
    channels: binned means of each variable fitted on the fit part predict the outer test
    part better than zero, by a held-out likelihood ratio with N/τ effective samples whose
    variance is the error left (model-structure error and whatever the noise really is),
    not the sensor-noise floor. Coloured sensor noise, a jittered clock or a controller's
    torque noise can lift the residual far above a white floor (measured: 7x for 2 %
    AR(1) noise); none of them is a function of where the system is, so none of them
    makes a mismatch. Once a mismatch is established, each channel above its floor is
    flagged and located as before: the structure test has little power on a channel
    whose residual is a dynamic effect of few effective samples (a tire's relaxation lag
    on the rear axle of a 20 s log: 11x its floor, 19 effective held-out samples, p = 1),
    and leaving such a channel out would hide it from the unexplained share.

    Rows: the fitter's usable fit and outer test rows, per channel where it is unmasked.
    Variables: :meth:`locate_variables` without derivatives of the states
    (:data:`DERIVED_VARIABLES` and the system's ``derivative_names``), which share the
    residual's differentiated noise, plus the rate of each logged input (the equation's
    filter's derivative of it): the residual holds the input's error filtered, never
    differentiated, and a filtered noise is uncorrelated with its own derivative at the
    same instant, while dynamic effects the states alone miss (a tire's relaxation lag, an
    input delay) are functions of it (measured: a 1.5 m relaxation length left the rear
    axle's 11x-floor residual untested by the states, p = 1).
    """
    exclude = set(system.derivative_names) | set(DERIVED_VARIABLES)
    variables = {k: v for k, (v, _) in system.locate_variables(prepared).items()
                 if k not in exclude}
    names = tuple(getattr(getattr(system, "columns", None), "u", ()) or ())
    if prepared.inputs is not None and len(names) == prepared.inputs.shape[1]:
        rates = prepared.smoother(np.asarray(prepared.inputs, dtype=np.float64), 1)
        variables.update({f"d{k}/dt": rates[:, j] for j, k in enumerate(names)
                          if np.ptp(rates[:, j]) > 0})
    mask = np.asarray(fitter.mask) > 0
    out = []
    for c in range(fitter.c):
        fit_rows = fitter.fit_rows[mask[fitter.fit_rows, c]]
        test_rows = fitter.test[mask[fitter.test, c]]
        out.append(structure_test(prepared.residual[:, c], variables, fit_rows, test_rows))
    return out


def _structure_entry(g: StructureTest, level: float) -> dict[str, Any]:
    """report.json form of a channel's structure test."""
    return {"test": "held-out likelihood ratio of binned means of one operating-point "
                    "variable over zero, χ²(bins), N/τ effective samples, Bonferroni over "
                    "variables",
            "p_value": None if not np.isfinite(g.p_value) else float(g.p_value),
            "level": float(level), "variable": g.variable,
            "share_removed": round(float(g.share_removed), 4),
            "effective_samples": round(float(g.effective_samples), 1),
            "testable": g.testable, **({"reason": g.reason} if g.reason else {})}


def _split_method(spans: list, train_fraction: float, n_valid: int) -> str:
    """``fit.split.method`` in words (:func:`.validation.split_rows`)."""
    held = f"{100 * (1 - train_fraction):.0f} %"
    if not spans:
        return ("usable rows only (masked rows and a filter window at gaps left out); the "
                f"last {held} of them span the operating regions (direction, amplitude) of "
                f"the rest and are the outer test part; selection validated on {n_valid} "
                "blocks of the rest spread over time, then refitted on all of it")
    return ("usable rows only (masked rows and a filter window at gaps left out), cut into "
            "contiguous blocks assigned by operating region (direction x amplitude), as the "
            f"last rows do not span them; outer held-out part = {held} of them: "
            f"{len(spans)} blocks spread over the regions (test_blocks) and the last usable "
            f"rows (test, the rollouts' part); selection validated on {n_valid} blocks of "
            "the rest spread over the regions, then refitted on all of it")


def _block_spans(t: np.ndarray, rows: np.ndarray, labels: np.ndarray) -> list[list[float]]:
    """[start, end] times (s) of each outer held-out block (label ≥ 0; the tail is -1)."""
    return [[float(t[rows[labels == b].min()]), float(t[rows[labels == b].max()])]
            for b in np.unique(labels[labels >= 0])]


def _jsonable(entry: dict[str, Any]) -> dict[str, Any]:
    """A ``tried`` entry with non-finite numbers as None (valid JSON)."""
    out = {}
    for k, v in entry.items():
        if isinstance(v, float) and not np.isfinite(v):
            v = None
        out[k] = v
    return out


def untested_channels(stats: list[locate.ChannelStat], tried: list[dict], system: Any
                      ) -> list[tuple[locate.ChannelStat, str]]:
    """Channels whose residual exceeds the noise floor where no effect could be tested.

    "No mismatch beyond the noise" is an answer only where something was tested. A
    channel whose residual RMS is above ``locate.SIGNIFICANCE`` × its noise floor, and every
    effect tried there (or vehicle/arm-wide) was "cannot test" (the held-out part holds
    too few effective samples), is undecided: measured on a 20 s piece of the real race-car
    log, residual 15x the noise floor on the front axle, every candidate "cannot test" with
    3-4 effective held-out samples, and the verdict said the nominal model explained it.

    Returns:
        (channel stat, the first "cannot test" reason there) per such channel.
    """
    out = []
    for s in stats:
        if not s.significant:
            continue
        here = [e for e in tried if e.get("channel") in (s.channel, "vehicle", "arm", None)]
        if here and all(e.get("decision") == "cannot test" for e in here):
            out.append((s, str(here[0].get("reason", "cannot test"))))
    return out


def verdict(entries: list[dict], stats: list[locate.ChannelStat], system: Any,
            unexplained: float | None, undetermined: bool = False, *,
            untested: list[tuple[locate.ChannelStat, str]] | None = None) -> str:
    """One line: is there a mismatch, what is named, what is left.

    ``undetermined``: a term passed its held-out test but its parameters are not
    determined (said after this line). ``untested``: channels whose residual is above
    the noise floor where no effect could be tested (:func:`untested_channels`).
    """
    hit = [_channel_label(s.channel) for s in stats if s.significant]
    if not entries:
        if not hit and untested:
            where = ", ".join(f"{_channel_label(s.channel)} ({s.residual_rms / s.noise_rms:.3g}x "
                              "its noise floor)" for s, _ in untested)
            return (f"Cannot tell: the residual at {where} is above the noise, but no effect "
                    f"could be tested held out ({untested[0][1]}); record longer or more "
                    "varied motion.")
        if not hit:
            return "No mismatch beyond the noise: the nominal model explains this recording."
        why = ("what fits it held out is not determined by the data" if undetermined else
               "no vocabulary effect passed and replicated the held-out tests")
        return (f"Mismatch at {', '.join(hit)}, not explained by a named effect ({why}): "
                "located, not named.")
    names = "; ".join(e["text"] for e in entries)
    if unexplained is None:
        return f"Named: {names} (the held-out part cannot test them)."
    return (f"Named: {names}; {100 * (1 - min(1.0, unexplained)):.0f} % of the held-out "
            f"residual explained, {100 * min(1.0, unexplained):.0f} % left.")


def default_out_dir(recording: str | os.PathLike) -> Path:
    """``./simgap-report/<recording stem>/`` (spec default)."""
    return Path("simgap-report") / Path(recording).stem
