"""A plant is nominal parameters plus named effect instances (value objects, no fitting code).

* :class:`Param` and :class:`EffectSpec` declare one effect of a system's vocabulary: its
  parameters (units with ``{effort}``/``{position}``/``{inertia}`` placeholders, bounds,
  injection range), whether it acts per channel (joint, axle) or on the whole system, what
  it needs, how an instance enters the plant (``write`` into the system's fold) and how the
  diagnosis fits it (:class:`FitSpec`: its contribution to the residual, written with the
  same ``models/`` functions the plant uses, the fit coordinates and their bounds, and the
  map back to the reported parameters).
* :class:`EffectInstance` is one effect with values: ``coulomb_friction@joint2, Fc=0.26``.
* :class:`PlantSchema` is what a system's kernel module declares about its plant: the
  parameter class, the channels, the vocabulary, the default options and the fold that turns
  a :class:`Plant` into the kernel array.
* :class:`Plant` is the value the envs, the generator and the augmented model hold; its
  :attr:`Plant.array` is the only producer of a plant kernel array.

Changing a plant makes a new value (``plant.with_effect("tire_saturation", mu=0.6)``), so
nothing derived from it (the env's ``mu``, its kernel array) can go stale.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any, Literal

import numpy as np

from simgap.errors import ModelError


@dataclass(frozen=True, kw_only=True)
class Param:
    """One parameter of an effect.

    Attributes:
        name: the reported, physical name (``"Fc"``, ``"mu"``, ``"q0"``).
        unit: unit with placeholders ``{effort}`` (N·m or N) and ``{position}`` (rad or m),
            formatted per channel by :func:`format_unit`.
        bounds: plausible physical range (inclusive); values outside are rejected.
        inject: range the generator's proof draws test values from (``None``: not drawn).
        signed: the proof also draws the value's sign.
        default: value used when an instance leaves the parameter out (``None``: required).
    """

    name: str
    unit: str = "-"
    bounds: tuple[float, float] = (-math.inf, math.inf)
    inject: tuple[float, float] | None = None
    signed: bool = False
    default: float | None = None


#: Signature of a fitted effect's contribution: ``fn(lin, nl, sig, index, ctx)`` returns the
#: effect's share of the physical residual, shape (N, n_channels), in channel units (N·m or
#: N). ``sig`` holds the recording's filtered signals by name, ``index`` is the channel (or
#: ``None`` for a whole-system effect) and ``ctx`` the diagnosis' read-only effect context
#: (Coulomb smoothing, gravity torques, axle stiffnesses, ...; see
#: ``simgap.diagnosis.forms.EffectContext``).
FitFn = Callable[[np.ndarray, np.ndarray, Mapping[str, np.ndarray], "int | None", Any],
                 np.ndarray]


@dataclass(frozen=True, kw_only=True)
class FitSpec:
    """How the diagnosis fits one effect (the fit side of an :class:`EffectSpec`).

    The fit coordinates may differ from the reported parameters (a reparametrisation that
    makes the contribution linear): the spring is fitted as k·q + c and reported as
    k·(q − q0); a ratio r is fitted as r − 1. ``to_report`` maps them back.

    Attributes:
        scope: where the diagnosis tests it: ``"joint"`` / ``"axle"`` (one candidate per
            channel) or ``"arm"`` / ``"vehicle"`` (all channels at once).
        lin: linear fit coordinates (the contribution is linear in them).
        lin_units: their units (templates, see :func:`format_unit`).
        lin_lower: lower bounds (sign constraints or plausibility limits).
        lin_upper: upper plausibility limits (``None``: unbounded).
        nl: nonlinear fit coordinates (fitted around a start grid).
        nl_units: their units (templates).
        nl_bounds: (low, high) per nonlinear coordinate.
        nl_grid: start values per nonlinear coordinate.
        nl_vanishes: per nonlinear coordinate, the bound at which the effect becomes the
            nominal (``"high"``: a road μ so large that the tire stays linear over any
            recorded slip; ``"low"``: a steering lag of a millisecond), or ``""`` (empty
            tuple: none). A term already chosen that a later hypothesis pushes onto that
            bound is made unnecessary by it (the diagnosis refits the hypothesis without it),
            not forced onto data it does not describe.
        uses_derivatives: the contribution depends on accelerations (mass-type effects).
        generalizes: simpler effects this one contains as a special case (same channel).
        generic: applies to any mechanical model (not only the system declaring it).
        on_input: the effect changes the input that acts (a delay, a dead zone), not the
            dynamics: a simulation applies it to the input (``input_map``) instead of adding
            its contribution.
        latency: the effect delays the action of the logged input (a transport delay, a
            first-order lag; its nonlinear coordinate in seconds). A low-pass filter on the
            logged motion delays it behind the logged input in the same way, so where the
            motion columns were low-passed before logging the diagnosis fits it and states
            the latency, but does not name it.
        input_map: ``input_map(nl, t, u) -> u_acting`` for an ``on_input`` effect: the input
            that acts on the channel, from the channel's held input ``u`` on the time grid
            ``t`` (s) and the nonlinear coordinates ``nl``.
        excitation: ``excitation(effect, lin, nl, u, noise, seen) -> str``: why the
            recorded input ``u`` (the channel's held input on the recording's valid samples,
            in time order) cannot identify the effect at its fitted values ("" when it
            can). ``seen(fn)`` is what the fit reads of a contribution ``fn(command)``
            (channel units): the function applied to the held command on the full grid,
            through the equation's filter, at the rows the tests read; ``noise`` is the std
            per independent one of those rows of the error the fit leaves there (channel
            units). Checked before the effect is named.
        confusable_with: same-channel effects whose regressors may coincide with this one's
            on some data (a dead zone on a command of one sign is a torque bias; on a
            command whose sign follows the velocity it is a Coulomb friction): the effect is
            named only where it stays determined with them fitted beside it (the same joint
            check as ``symmetric_with``).
        corrects: ``(coordinate, nominal coefficient)`` pairs: where the nominal model
            already holds this term (its own ``damping`` for viscous b), the coordinate is a
            signed correction of it, bounded below by −(the nominal's value) instead of by
            ``lin_lower``: "the nominal damping is 15 % too high" is b = −0.15·damping.
        symmetric_with: effects (any channel) that, scaled together with this one, leave
            the motion unchanged: mass, yaw inertia and all tire forces of a vehicle (its
            cornering stiffnesses) scaled by one factor. This effect is named only where it
            stays determined with those freed beside it (the diagnosis' joint check);
            otherwise the identifiable combination is reported.
        fn: the contribution, :data:`FitFn`.
        to_report: ``to_report(effect, lin, nl, cov, context) -> (params, stderr, units)``;
            ``None``: the fit coordinates are the reported parameters. ``context`` holds
            the fitted values of the effects this one ``needs`` on the same channel.
        for_data: ``for_data(effect, sig, index, ctx) -> effect | None``: the candidate as
            one recording allows it, for forms that scale the vocabulary to the data (any
            mechanical model but the built-in arm): bounds scaled to the recorded motion
            (Stribeck's vs), or ``None`` when the recording holds no information about it
            (gravity_mismatch of a model without gravity torques). ``sig``: the prepared
            signals; ``ctx``: the form's effect context. ``None``: used as declared.
        from_report: the inverse, ``from_report(params, context) -> (lin, nl)``: the fit
            coordinates of reported parameters (how a saved augmented model is simulated
            again); ``context`` as for ``to_report``. ``None`` with ``to_report`` unset:
            the coordinates are the parameters of the same names.
    """

    scope: Literal["joint", "axle", "arm", "vehicle"]
    lin: tuple[str, ...] = ()
    lin_units: tuple[str, ...] = ()
    lin_lower: tuple[float, ...] = ()
    lin_upper: tuple[float, ...] | None = None
    nl: tuple[str, ...] = ()
    nl_units: tuple[str, ...] = ()
    nl_bounds: tuple[tuple[float, float], ...] = ()
    nl_grid: tuple[tuple[float, ...], ...] = ()
    nl_vanishes: tuple[str, ...] = ()
    uses_derivatives: bool = False
    generalizes: tuple[str, ...] = ()
    generic: bool = True
    on_input: bool = False
    latency: bool = False
    corrects: tuple[tuple[str, str], ...] = ()
    symmetric_with: tuple[str, ...] = ()
    confusable_with: tuple[str, ...] = ()
    fn: FitFn = field(repr=False)
    to_report: Callable[..., tuple[dict[str, float], dict[str, float], dict[str, str]]] | None \
        = field(default=None, repr=False)
    from_report: Callable[[Mapping[str, float], Mapping[str, float]],
                          tuple[tuple[float, ...], tuple[float, ...]]] | None \
        = field(default=None, repr=False)
    for_data: Callable[[Any, Mapping[str, np.ndarray], int | None, Any], Any] | None \
        = field(default=None, repr=False)
    input_map: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None \
        = field(default=None, repr=False)
    excitation: Callable[[Any, np.ndarray, np.ndarray, np.ndarray, float, Any], str] | None \
        = field(default=None, repr=False)

    def coordinates(self, params: Mapping[str, float], context: Mapping[str, float] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """The fit coordinates (lin, nl) of reported parameters (inverse of ``to_report``).

        Raises:
            ModelError: the reparametrisation has no inverse declared, or a parameter is
                missing.
        """
        ctx = dict(context or {})
        try:
            if self.from_report is not None:
                lin, nl = self.from_report(params, ctx)
            elif self.to_report is None:
                lin, nl = [params[n] for n in self.lin], [params[n] for n in self.nl]
            else:
                raise ModelError(f"{self.fn.__name__}: reported parameters have no declared "
                                 "inverse (FitSpec.from_report)")
        except KeyError as err:
            raise ModelError(f"missing parameter {err} for the fit coordinates") from None
        return np.asarray(lin, dtype=np.float64), np.asarray(nl, dtype=np.float64)


def on_channel(values: np.ndarray, index: int, n_channels: int) -> np.ndarray:
    """An (N, n_channels) contribution that is ``values`` on channel ``index``, 0 elsewhere."""
    out = np.zeros((values.shape[0], n_channels))
    out[:, index] = values
    return out


def stderr_of(cov: np.ndarray, i: int) -> float:
    """Standard error of fit coordinate ``i`` from a covariance matrix (negative → 0)."""
    return float(np.sqrt(max(cov[i, i], 0.0)))


@dataclass(frozen=True, kw_only=True)
class EffectSpec:
    """One effect of a system's vocabulary (see the module docstring).

    Attributes:
        name: vocabulary name, e.g. ``"coulomb_friction"``.
        label: short human label.
        scope: ``"channel"`` (one instance per joint/axle) or ``"system"`` (whole plant).
        params: the parameters.
        write: ``write(acc, channel_index, values)`` applies one instance to the system's
            fold accumulator (``channel_index`` is ``None`` for system effects and for channel
            effects given without a channel when ``all_channels`` is set).
        all_channels: a channel effect may be given without a channel: it then acts on
            every channel (one road μ for both axles).
        needs: effects that must be present on the same channel (Stribeck needs Coulomb's
            Fc for its breakaway difference).
        vocabulary: ``False`` for effects that exist only to be injected (testing that the
            diagnosis forces nothing into its vocabulary).
        fit: how the diagnosis fits it (``None``: injectable only, not diagnosable).
    """

    name: str
    label: str
    scope: Literal["channel", "system"]
    params: tuple[Param, ...]
    write: Callable[[dict, int | None, Mapping[str, float]], None]
    all_channels: bool = False
    needs: tuple[str, ...] = ()
    vocabulary: bool = True
    fit: FitSpec | None = None

    def param(self, name: str) -> Param:
        """The parameter called ``name``."""
        for p in self.params:
            if p.name == name:
                return p
        raise ModelError(f"effect {self.name!r} has no parameter {name!r}")

    def check(self, channel: str | None, values: Mapping[str, float],
              channels: tuple[str, ...], error: type[Exception] = ModelError
              ) -> dict[str, float]:
        """Validate one instance; returns its values with defaults filled in.

        Raises:
            error: one line naming the effect and the wrong channel or parameter.
        """
        if self.scope == "channel":
            if (channel is None and not self.all_channels) or \
                    (channel is not None and channel not in channels):
                raise error(f"effect {self.name!r} needs a channel in {channels}"
                            f"{' or none' if self.all_channels else ''}, got {channel!r}")
        elif channel is not None:
            raise error(f"effect {self.name!r} acts on the whole system and takes no channel, "
                        f"got {channel!r}")
        names = tuple(p.name for p in self.params)
        unknown = sorted(set(values) - set(names))
        missing = [p.name for p in self.params if p.default is None and p.name not in values]
        if unknown or missing:
            raise error(f"effect {self.name!r} takes parameters {names}, got {sorted(values)}")
        out: dict[str, float] = {}
        for p in self.params:
            v = float(values[p.name]) if p.name in values else float(p.default)  # type: ignore
            lo, hi = p.bounds
            if not (math.isfinite(v) and lo <= v <= hi):
                raise error(f"effect {self.name!r} parameter {p.name} = {v!r} must be finite "
                            f"and within [{lo:g}, {hi:g}]")
            out[p.name] = v
        return out


def format_unit(unit: str, *, effort: str = "N·m", position: str = "rad") -> str:
    """Fill a :attr:`Param.unit` template for a revolute (N·m, rad) or prismatic (N, m) joint.

    ``{inertia}`` (effort per acceleration) reads kg·m² for a revolute and kg for a
    prismatic joint, ``{effort}·s²/{position}`` otherwise.
    """
    if "{inertia}" in unit:
        inertia = {("N·m", "rad"): "kg·m²", ("N", "m"): "kg"}.get(
            (effort, position), f"{effort}·s²/{position}")
        unit = unit.replace("{inertia}", inertia)
    return unit.replace("{effort}", effort).replace("{position}", position)


@dataclass(frozen=True)
class EffectInstance:
    """One named effect with values: vocabulary name, channel (or ``None``) and parameters."""

    name: str
    channel: str | None = None
    params: Mapping[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The schema-1 augmented-model/report form ``{"effect", "channel", "params"}``."""
        return {"effect": self.name, "channel": self.channel,
                "params": {k: float(v) for k, v in self.params.items()}}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> EffectInstance:
        """Inverse of :meth:`to_dict` (also accepts ``"name"`` for ``"effect"``)."""
        name = d.get("effect", d.get("name"))
        if not isinstance(name, str):
            raise ModelError(f"effect description without a name: {dict(d)!r}")
        return cls(name, d.get("channel"), {k: float(v) for k, v in
                                            dict(d.get("params", {})).items()})


@dataclass(frozen=True)
class Folded:
    """What a system's fold makes of a plant: effective parameters, kernel array, extras."""

    params: Any
    array: np.ndarray
    extras: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class PlantSchema:
    """A system's plant declaration (see the module docstring).

    Attributes:
        system: the system name (``"manipulator2dof"``, ``"bicycle"``).
        params_cls: the frozen parameter dataclass of the nominal/truth rigid body.
        channels: channel names of per-channel effects.
        vocabulary: the effects, in fold order.
        options: default plant options (non-effect settings such as the speed).
        fold: ``fold(plant) -> Folded`` builds the effective parameters and kernel array.
    """

    system: str
    params_cls: type
    channels: tuple[str, ...]
    vocabulary: tuple[EffectSpec, ...]
    options: Mapping[str, Any]
    fold: Callable[[Plant], Folded]

    def effect(self, name: str, error: type[Exception] = ModelError) -> EffectSpec:
        """The vocabulary entry ``name``; one error listing the known names otherwise."""
        for e in self.vocabulary:
            if e.name == name:
                return e
        raise error(f"unknown effect {name!r} for {self.system}; choose from "
                    f"{sorted(e.name for e in self.vocabulary)}")

    def plant(self, params: Any = None, effects: tuple[EffectInstance, ...] = (),
              **options: Any) -> Plant:
        """A :class:`Plant` of this system (``params`` default: the nominal parameters)."""
        return Plant(self, params if params is not None else self.params_cls(),
                     tuple(effects), options)


@dataclass(frozen=True)
class Plant:
    """Nominal parameters + named effect instances of one system (immutable).

    Args:
        schema: the system's :class:`PlantSchema`.
        params: the system's parameter dataclass (the rigid body before any effect).
        effects: effect instances, each naming an entry of the schema's vocabulary.
        options: plant options overriding the schema's defaults.

    Raises:
        ModelError: unknown effect, option, channel or parameter, or parameters of the
            wrong class (checked on construction).
    """

    schema: PlantSchema
    params: Any
    effects: tuple[EffectInstance, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        s = self.schema
        if not isinstance(self.params, s.params_cls):
            raise ModelError(f"{s.system} plant needs {s.params_cls.__name__}, got "
                             f"{self.params!r}")
        unknown = sorted(set(self.options) - set(s.options))
        if unknown:
            raise ModelError(f"unknown {s.system} plant option(s) {unknown}; known: "
                             f"{sorted(s.options)}")
        checked = []
        for e in self.effects:
            if not isinstance(e, EffectInstance):
                raise ModelError(f"plant effects must be EffectInstance, got {e!r}")
            spec = s.effect(e.name)
            checked.append(replace(e, params=spec.check(e.channel, e.params, s.channels)))
        object.__setattr__(self, "effects", tuple(checked))
        object.__setattr__(self, "options", {**s.options, **self.options})

    @property
    def system(self) -> str:
        """The system name."""
        return self.schema.system

    @cached_property
    def folded(self) -> Folded:
        """The fold's result (effective parameters, kernel array, extras), computed once."""
        return self.schema.fold(self)

    @property
    def array(self) -> np.ndarray:
        """The plant kernel array (layout in the system's kernel module). Do not mutate it."""
        return self.folded.array

    @property
    def true_params(self) -> Any:
        """The effective rigid-body parameters after the effects that change them."""
        return self.folded.params

    def has(self, name: str, channel: str | None = None) -> bool:
        """Whether an instance of ``name`` (on ``channel``, if given) is present."""
        return any(e.name == name and (channel is None or e.channel == channel)
                   for e in self.effects)

    def get(self, name: str, channel: str | None = None) -> EffectInstance | None:
        """The instance of ``name`` on ``channel`` (``None`` if absent)."""
        for e in self.effects:
            if e.name == name and e.channel == channel:
                return e
        return None

    def with_effect(self, name: str, channel: str | None = None, **params: float) -> Plant:
        """A new plant with the instance ``name@channel`` set (replacing one there).

        Parameters not given keep the replaced instance's values.
        """
        old = self.get(name, channel)
        merged = {**(dict(old.params) if old is not None else {}), **params}
        rest = tuple(e for e in self.effects if not (e.name == name and e.channel == channel))
        return replace(self, effects=(*rest, EffectInstance(name, channel, merged)))

    def without(self, name: str, channel: str | None = None) -> Plant:
        """A new plant without ``name`` (on ``channel``, or on every channel if ``None``)."""
        return replace(self, effects=tuple(
            e for e in self.effects
            if not (e.name == name and (channel is None or e.channel == channel))))

    def with_params(self, **changes: Any) -> Plant:
        """A new plant whose rigid-body parameters are ``dataclasses.replace``-d."""
        return replace(self, params=replace(self.params, **changes))

    def with_options(self, **options: Any) -> Plant:
        """A new plant with some options changed."""
        return replace(self, options={**self.options, **options})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form: ``{"system", "params", "effects", "options"}``."""
        return {"system": self.system,
                "params": {f.name: _jsonable(getattr(self.params, f.name))
                           for f in fields(self.params)},
                "effects": [e.to_dict() for e in self.effects],
                "options": {k: _jsonable(v) for k, v in self.options.items()}}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], schema: PlantSchema) -> Plant:
        """Inverse of :meth:`to_dict` for the given system schema."""
        if d.get("system", schema.system) != schema.system:
            raise ModelError(f"plant description is for {d.get('system')!r}, not "
                             f"{schema.system!r}")
        try:
            params = schema.params_cls(**{k: (tuple(v) if isinstance(v, list) else v)
                                          for k, v in dict(d.get("params", {})).items()})
        except TypeError as err:
            raise ModelError(f"{schema.system} plant parameters: {err}") from None
        opts = {k: (tuple(v) if isinstance(v, list) else v)
                for k, v in dict(d.get("options", {})).items()}
        return cls(schema, params, tuple(EffectInstance.from_dict(e)
                                         for e in d.get("effects", [])), opts)


def _jsonable(v: Any) -> Any:
    if isinstance(v, tuple | list | np.ndarray):
        return [float(x) for x in v]
    return float(v) if isinstance(v, int | float | np.floating) else v


def channel_index(channels: tuple[str, ...], channel: str | None) -> int | None:
    """Index of ``channel`` in ``channels`` (``None`` stays ``None``)."""
    return None if channel is None else channels.index(channel)
