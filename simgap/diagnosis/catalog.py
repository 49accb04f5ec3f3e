"""What ``simgap record --effect`` accepts: effects, channels, parameters with units.

:func:`injectable_effects` is the one place the command line reads the effect table from
(today :mod:`simgap.diagnosis.generate`'s ``MANIPULATOR_EFFECTS`` / ``BICYCLE_EFFECTS``, with
units from the vocabulary in :mod:`simgap.diagnosis.effects`), so that ``--list-effects``,
the docs and the error messages cannot disagree with what the generator takes.
"""

from __future__ import annotations

from dataclasses import dataclass

from simgap.errors import GeneratorError

#: Models ``simgap record --model`` accepts.
RECORD_MODELS = ("manipulator2dof", "bicycle")
#: Units of injection parameters that the vocabulary's fitted form names differently
#: (``cornering_stiffness`` etc. are fitted as ``ratio_minus_1``; the spring's rest angle
#: is reported, not fitted; ``tire_relaxation`` lies outside the vocabulary).
_EXTRA_UNITS = {"ratio": "-", "q0": "rad", "length": "m"}
#: Parameters the generator lets one leave out, with the value it then uses.
_DEFAULTS = {("spring", "q0"): 0.0}


@dataclass(frozen=True, kw_only=True)
class ParamInfo:
    """One parameter of an injectable effect.

    Attributes:
        name: parameter name as ``--effect`` takes it (``Fc``).
        unit: SI unit (``-`` for dimensionless ratios and scales).
        default: value used when the parameter is left out, ``None`` if it is required.
    """

    name: str
    unit: str
    default: float | None = None


@dataclass(frozen=True, kw_only=True)
class EffectInfo:
    """One effect ``simgap record`` can conceal in a recording.

    Attributes:
        name: vocabulary name (``coulomb_friction``).
        label: plain words ("Coulomb friction"); empty outside the vocabulary.
        channels: the channels it needs one of (``joint1``, ``joint2`` / ``front_axle``,
            ``rear_axle``), empty for whole-arm / whole-vehicle effects.
        params: its parameters, in the order the generator lists them.
        in_vocabulary: ``False`` for effects kept only to test that nothing is forced into
            the vocabulary (``tire_relaxation``).
    """

    name: str
    label: str
    channels: tuple[str, ...]
    params: tuple[ParamInfo, ...]
    in_vocabulary: bool


def injectable_effects(model: str) -> list[EffectInfo]:
    """The effects ``simgap record --model MODEL --effect ...`` accepts.

    Args:
        model: ``"manipulator2dof"`` or ``"bicycle"``.

    Raises:
        GeneratorError: unknown model.
    """
    from simgap.diagnosis import generate
    from simgap.diagnosis.effects import VOCABULARY

    tables = {"manipulator2dof": (generate.MANIPULATOR_EFFECTS, generate.JOINTS),
              "bicycle": (generate.BICYCLE_EFFECTS, generate.AXLES)}
    if model not in RECORD_MODELS:
        raise GeneratorError(f"unknown model {model!r}; use one of {list(RECORD_MODELS)}")
    table, channels = tables[model]
    rows = []
    for name, (per_channel, names) in table.items():
        voc = VOCABULARY.get(name)
        units = dict(_EXTRA_UNITS)
        if voc is not None:
            units.update(zip(voc.lin + voc.nl, voc.lin_units + voc.nl_units, strict=True))
        rows.append(EffectInfo(
            name=name, label=voc.label if voc is not None else "",
            channels=channels if per_channel else (),
            params=tuple(ParamInfo(name=p, unit=units.get(p, "?"),
                                   default=_DEFAULTS.get((name, p))) for p in names),
            in_vocabulary=voc is not None))
    return rows


def effect_table_lines(model: str) -> list[str]:
    """Plain-text table of :func:`injectable_effects` for ``simgap record --list-effects``."""
    rows = [("effect", "channel", "parameters (unit, default)", "meaning")]
    for e in injectable_effects(model):
        params = ", ".join(f"{p.name} ({p.unit}" + (f", default {p.default:g})"
                                                   if p.default is not None else ")")
                           for p in e.params)
        meaning = e.label if e.in_vocabulary else "outside the vocabulary (for tests)"
        rows.append((e.name, "|".join(e.channels) or "-", params, meaning))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = [f"{model}: --effect NAME[:CHANNEL][:k=v,...]"]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r[:3], widths, strict=True)) + "  " + r[3]
              for r in rows]
    return lines
