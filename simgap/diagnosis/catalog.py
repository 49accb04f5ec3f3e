"""What ``simgap record --effect`` accepts: effects, channels, parameters with units.

:func:`injectable_effects` is the one place the command line reads the effect table from
(the system registry's effect vocabulary, which the generator validates against), so that
``--list-effects``, the docs and the error messages cannot disagree with the generator.
"""

from __future__ import annotations

from dataclasses import dataclass

from simgap.errors import GeneratorError


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
    """The effects ``simgap record --model MODEL --effect ...`` accepts, from the registry.

    Names, channels, parameters, units and defaults all come from the system's effect
    vocabulary (:class:`~simgap.models.effects.EffectSpec` in
    :data:`simgap.systems.SYSTEMS`), the same objects the generator validates against.

    Args:
        model: a registered system with a generator (``"manipulator2dof"``, ``"bicycle"``).

    Raises:
        GeneratorError: unknown model, or a system without a recording generator.
    """
    from simgap.models.effects import format_unit
    from simgap.systems import SYSTEMS

    spec = SYSTEMS.get(model)
    if spec is None or spec.generator is None or spec.plant_schema is None:
        known = [n for n, s in SYSTEMS.items() if s.generator and s.plant_schema]
        raise GeneratorError(f"unknown model {model!r}; use one of {known}")
    schema = spec.plant_schema
    return [EffectInfo(
        name=e.name, label=e.label if e.vocabulary else "",
        channels=schema.channels if e.scope == "channel" else (),
        params=tuple(ParamInfo(name=p.name, unit=format_unit(p.unit), default=p.default)
                     for p in e.params),
        in_vocabulary=e.vocabulary) for e in schema.vocabulary]


def generator_options(model: str, **options: object) -> dict[str, object]:
    """The ``options`` that the registered system's generator takes (by parameter name).

    ``simgap record`` passes ``--program``/``--vx`` this way: a system whose generator has
    such a parameter gets them, with no per-model switch in the command.
    """
    import inspect

    from simgap.systems import get_system

    params = inspect.signature(get_system(model, GeneratorError).resolve("generator")).parameters
    return {k: v for k, v in options.items() if k in params}


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
