"""The system registry: every system simgap knows is one :class:`SystemSpec`, registered once.

Env registration, the identifier wrappers' preset lookup, ``simgap diagnose --model NAME``,
``simgap record --model NAME`` / :func:`simgap.diagnosis.generate.generate` and the env API
tests look systems up here (or iterate :data:`SYSTEMS`), so a new system is one
:func:`register_system` call, not a dozen edits, and an unknown name fails with one error
that lists the registered systems.

A user system registers through the same function (its env id, if it names one, is
registered with Gymnasium by that call)::

    from simgap.systems import SystemSpec, register_system

    register_system(SystemSpec(name="my_axis", params_cls=AxisParams,
                               nominal=lambda params, dt: AxisNominal(params, dt=dt),
                               identifier_preset="manipulator"))

Only ``name`` is required: a system registered with a preset alone lets the identifier
wrappers pick their configuration for a model whose ``name`` it is.

Fields that name code in higher layers (env entry points, the diagnosis adapter, the
generator) are ``"module:attribute"`` strings, resolved on use, so that importing the
registry imports neither gymnasium envs nor the diagnosis.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from simgap._envtable import BUILTIN_ENVS
from simgap.errors import ModelError
from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.effects import EffectSpec, Plant, PlantSchema
from simgap.schema import RecordingSchema


@dataclass(frozen=True, kw_only=True)
class SystemSpec:
    """One system (see the module docstring).

    Attributes:
        name: the one name (``NominalModel.name``, ``--model``, recording meta).
        params_cls: the frozen parameter dataclass (``None`` for a system without one).
        nominal: ``nominal(params, dt) -> NominalModel``; ``dt`` ``None`` = the default.
        plant_schema: the truth plant's declaration (vocabulary, options, fold), if the
            system has a simulated plant.
        recording: canonical recording columns.
        identifier_preset: key of the thesis identifier presets (``identifiers.config``);
            ``None``: the wrappers need an explicit ``config``.
        residual_form: ``"module:callable"`` turning a nominal model into the diagnosis
            adapter.
        generator: ``"module:function"`` making concealed-effect recordings.
        env_id: gymnasium id; with ``env_entry_point`` and ``max_episode_steps``.
        env_entry_point: ``"module:Class"`` of the env.
        max_episode_steps: default ``TimeLimit`` of ``gym.make``.
        model_files: file suffixes that name a model of this system (``".xml"`` for MJCF):
            ``diagnose(rec, "robot.xml")`` finds the system by its file.
        diagnose_file: ``"module:function"`` diagnosing a recording against such a file,
            ``fn(path, recording, **options) -> Report``.
        model_type: ``"module:Class"`` of the system's nominal models: a model object of
            this class (or a subclass) gets this system's ``residual_form``.
        vector_entry_point: ``"module:Class"`` of a native vector env (``gym.make_vec``'s
            default mode when set; ``vectorization_mode="sync"`` still gives the sync one).
        residual_info_keys: ``info`` keys under which the identifier wrappers report the
            physical-residual estimate besides ``physical_residual_estimate`` (a copy each),
            e.g. the bicycle's ``("axle_force_residual_estimate",)``.
    """

    name: str
    params_cls: type | None = None
    nominal: Callable[[Any, float | None], Any] | None = None
    plant_schema: PlantSchema | None = None
    recording: RecordingSchema | None = None
    identifier_preset: str | None = None
    residual_form: str | None = None
    generator: str | None = None
    env_id: str | None = None
    env_entry_point: str | None = None
    max_episode_steps: int | None = None
    model_files: tuple[str, ...] = ()
    diagnose_file: str | None = None
    model_type: str | None = None
    vector_entry_point: str | None = None
    residual_info_keys: tuple[str, ...] = ()

    @property
    def vocabulary(self) -> tuple[EffectSpec, ...]:
        """The effects of the system's plant (empty without a plant schema)."""
        return self.plant_schema.vocabulary if self.plant_schema is not None else ()

    def plant(self, params: Any = None, effects: tuple = (), **options: Any) -> Plant:
        """A truth :class:`~simgap.models.effects.Plant` of this system."""
        if self.plant_schema is None:
            raise ModelError(f"system {self.name!r} has no simulated plant")
        return self.plant_schema.plant(params, effects, **options)

    def resolve(self, field: str) -> Any:
        """Import the ``"module:attribute"`` named by one of the string fields."""
        target = getattr(self, field)
        if not target:
            raise ModelError(f"system {self.name!r} has no {field.replace('_', ' ')}")
        module, _, attr = target.partition(":")
        return getattr(importlib.import_module(module), attr)


#: The registered systems by name (built-ins first, then user systems in call order).
SYSTEMS: dict[str, SystemSpec] = {}


def register_system(spec: SystemSpec, *, replace: bool = False) -> SystemSpec:
    """Register a system so that every name lookup of simgap finds it.

    A system with an ``env_id`` (and ``env_entry_point``) has its Gymnasium env registered
    at once, so ``gym.make(spec.env_id)`` works right after this call (with
    ``max_episode_steps`` and ``vector_entry_point``). Registering the same env again is a
    no-op; an id that Gymnasium already holds with another entry point is refused unless
    ``replace`` is set.

    Args:
        spec: the system.
        replace: allow replacing a registered system of the same name (and its env id).

    Raises:
        ModelError: the name is taken (and ``replace`` is false), ``spec`` is not a
            :class:`SystemSpec`, only one of ``env_id`` / ``env_entry_point`` is given, or
            the env id is taken by another env (and ``replace`` is false).
    """
    if not isinstance(spec, SystemSpec):
        raise ModelError(f"register_system needs a SystemSpec, got {spec!r}")
    if spec.name in SYSTEMS and not replace:
        raise ModelError(f"system {spec.name!r} is already registered; pass replace=True")
    if bool(spec.env_id) != bool(spec.env_entry_point):
        raise ModelError(f"system {spec.name!r}: env_id and env_entry_point go together, got "
                         f"env_id={spec.env_id!r}, env_entry_point={spec.env_entry_point!r}")
    if spec.env_id:
        from simgap.envs.registration import register_env

        try:
            register_env(spec.env_id, spec.env_entry_point, spec.max_episode_steps,
                         spec.vector_entry_point, replace=replace)
        except ValueError as err:
            raise ModelError(f"system {spec.name!r}: {err}") from None
    SYSTEMS[spec.name] = spec
    return spec


def get_system(name_or_model: str | Any, error: type[Exception] = ModelError) -> SystemSpec:
    """The registered system of a name or of a nominal model (its ``name``).

    Raises:
        error: one line naming the unknown system and listing the registered ones.
    """
    name = name_or_model if isinstance(name_or_model, str) \
        else getattr(name_or_model, "name", None)
    if name in SYSTEMS:
        return SYSTEMS[name]
    raise error(f"unknown model {name!r}; registered systems: {', '.join(SYSTEMS)} "
                "(add one with simgap.systems.register_system)")


def system_of_file(path: Any) -> SystemSpec | None:
    """The registered system whose ``model_files`` suffixes name ``path`` (or ``None``)."""
    import os

    if not isinstance(path, str | os.PathLike):
        return None
    name = os.fspath(path).lower()
    for spec in SYSTEMS.values():
        if spec.diagnose_file and any(name.endswith(s) for s in spec.model_files):
            return spec
    return None


def system_of_model(model: Any) -> SystemSpec | None:
    """The registered system whose ``model_type`` a nominal-model object is (or ``None``).

    The most recently registered matching system wins, so a user system registered for a
    subclass of a built-in model takes precedence.
    """
    for spec in reversed(list(SYSTEMS.values())):
        if spec.model_type is None:
            continue
        module, _, attr = spec.model_type.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr)
        except ImportError:  # an optional dependency (mujoco) that is not installed
            continue
        if isinstance(model, cls):
            return spec
    return None


def identifier_preset_of(model: Any) -> str:
    """The thesis identifier preset of a nominal model's registered system (by its ``name``).

    This is the *reproduction* preset (``identifiers.config.preset(name, kind)``, the thesis'
    Tables 4.3/4.4), used where a system's thesis results are reproduced and by the
    wrappers on request (``IdentifierWrapper(env, config="system")``); the wrappers'
    default stays the scale-free ``preset("auto", kind, dt=model.dt)``.

    Raises:
        IdentifierError: the model's system is not registered or has no preset; the message
            names the system and says to pass ``config=`` (or register the system).
    """
    from simgap.errors import IdentifierError

    name = getattr(model, "name", None)
    spec = SYSTEMS.get(name) if isinstance(name, str) else None
    if spec is None or spec.identifier_preset is None:
        why = "is not registered" if spec is None else "has no identifier preset"
        raise IdentifierError(f"system {name!r} of {type(model).__name__} {why}: pass config= "
                              "(an IdentifierConfig) or register the system with an "
                              "identifier_preset (simgap.systems.register_system)")
    return spec.identifier_preset


def residual_info_keys_of(model: Any) -> tuple[str, ...]:
    """The extra physical-residual ``info`` keys of a nominal model's registered system.

    Looked up by the model's ``name`` (``()`` for an unregistered model): what the identifier
    wrappers add besides ``physical_residual_estimate``.
    """
    name = getattr(model, "name", None)
    spec = SYSTEMS.get(name) if isinstance(name, str) else None
    return spec.residual_info_keys if spec is not None else ()


def _builtin(schema: PlantSchema, nominal_cls: type, columns: tuple[str, ...], *, preset: str,
             form: str, generator: str, residual_info_keys: tuple[str, ...] = ()
             ) -> SystemSpec:
    """A built-in system (env registration from :data:`simgap._envtable.BUILTIN_ENVS`)."""
    env_id, env, steps, vector = BUILTIN_ENVS[schema.system]
    return register_system(SystemSpec(
        model_type=f"{nominal_cls.__module__}:{nominal_cls.__name__}",
        name=schema.system, params_cls=schema.params_cls,
        nominal=lambda params, dt=None: nominal_cls(params, **({} if dt is None else {"dt": dt})),
        plant_schema=schema, recording=RecordingSchema(canonical=columns),
        identifier_preset=preset, residual_form=f"simgap.diagnosis.systems:{form}",
        generator=f"simgap.diagnosis.generate:{generator}", env_id=env_id,
        env_entry_point=env, max_episode_steps=steps, vector_entry_point=vector,
        residual_info_keys=residual_info_keys))


_builtin(man.PLANT_SCHEMA, man.ManipulatorNominal, man.RECORDING_COLUMNS, preset="manipulator",
         form="MechanicalSystem", generator="generate_manipulator")
_builtin(bic.PLANT_SCHEMA, bic.BicycleNominal, bic.RECORDING_COLUMNS, preset="bicycle",
         form="BicycleSystem", generator="generate_bicycle",
         residual_info_keys=("axle_force_residual_estimate",))

#: A MuJoCo model file (MJCF ``.xml`` or compiled ``.mjb``): any mechanical model MuJoCo
#: describes; no plant, generator or env of its own.
register_system(SystemSpec(
    name="mjcf", model_files=(".xml", ".mjb"),
    diagnose_file="simgap.diagnosis.mujoco:diagnose_mjcf",
    model_type="simgap.models.mujoco:MujocoNominal",
    residual_form="simgap.diagnosis.mujoco:MujocoSystem"))
