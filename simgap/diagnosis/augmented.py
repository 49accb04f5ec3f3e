"""Step 4 of the diagnosis: the augmented model (nominal + named effects), saved as JSON.

The augmented model is an ordinary nominal-model object (``simgap.models.base``) so that the
envs, the identifiers and the diagnosis itself accept it:

* :class:`AugmentedManipulator` is a :class:`~simgap.models.manipulator.ManipulatorNominal`
  (hence a ``MechanicalNominalModel``) whose rigid body carries the payload, extra joint
  inertia and scaled gravity, and whose left-out torque tau_d(q, dq) holds the friction,
  bias and spring found. :meth:`~AugmentedManipulator.env_kwargs` gives exactly the
  arguments of ``ManipulatorFrictionEnv(friction=, disturbance=, true_params=)`` that build
  an env simulating it.
* :class:`AugmentedBicycle` is a :class:`~simgap.models.bicycle.BicycleNominal` with scaled
  mass, yaw inertia and axle stiffnesses, Magic-Formula axles where saturation was found,
  and the lateral/yaw biases; :meth:`~AugmentedBicycle.env_kwargs` gives the
  ``BicycleTireEnv`` argument ``plant=`` (each axle keeps its own fitted μ). Its two-state
  ``f`` uses the commanded steering; a steering lag needs the road-wheel angle as an extra
  state and is carried by :meth:`plant_theta` and the env.
* :class:`AugmentedMechanical` wraps any other mechanical model: M(q) and bias(q, dq) gain
  the effects' terms. Its value is a :class:`~simgap.models.effects.Plant` too, of the
  generic mechanical schema built from the model's joints and the vocabulary
  (:func:`mechanical_schema`), so every model's ``augmented_model.json`` holds a plant.

JSON layout (``save_model`` / ``load_model``)::

    {"schema": 1, "model": "manipulator2dof", "base_params": {...},
     "effects": [{"effect": "coulomb_friction", "channel": "joint2", "params": {"Fc": 0.26}}],
     "options": {"coulomb_sigma": [0.001, 0.001]}}
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from simgap.errors import ModelError, ModelFileError
from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.base import MechanicalNominalModel
from simgap.models.bicycle import BicycleNominal, BicycleParams, body_derivative
from simgap.models.effects import EffectInstance, Folded, Plant, PlantSchema, channel_index
from simgap.models.friction import FrictionParams
from simgap.models.tires import MagicFormulaTire, linear_force, magic_formula
from simgap.outputs import write_file

JOINTS = man.JOINTS
AXLES = bic.AXLES
DEFAULT_SIGMA = man.DEFAULT_SIGMA


def _p(effect: Mapping[str, Any]) -> dict[str, float]:
    return {k: float(v) for k, v in effect.get("params", {}).items()}


def manipulator_physics(effects: Sequence[Mapping[str, Any]],
                        base: man.ManipulatorParams | None = None,
                        sigma: Sequence[float] | float = DEFAULT_SIGMA
                        ) -> tuple[man.ManipulatorParams, FrictionParams, man.JointDisturbance]:
    """Vocabulary effects → (rigid-body params, friction, bias/spring) of the arm.

    Args:
        effects: dicts with ``effect``, ``channel`` (``joint1``/``joint2`` or None) and
            ``params`` in the vocabulary's units (Stribeck ``Fs`` is the breakaway torque).
        base: nominal parameters.
        sigma: tanh smoothing velocity of Coulomb/Stribeck terms (rad/s), per joint or one.

    Returns:
        ``ManipulatorParams`` (payload, extra_inertia, g), ``FrictionParams``,
        ``JointDisturbance``.
    """
    f = manipulator_plant(effects, base, sigma).folded
    return f.params, f.extras["friction"], f.extras["disturbance"]


def _instances(schema: PlantSchema, effects: Sequence[Mapping[str, Any]]
               ) -> tuple[EffectInstance, ...]:
    """Report effect dicts → plant instances.

    A system effect's report channel ("arm", "vehicle") says where the report lists it; it is
    not a plant channel.
    """
    out = []
    for e in effects:
        spec = schema.effect(e["effect"])
        out.append(EffectInstance(e["effect"],
                                  None if spec.scope == "system" else e.get("channel"), _p(e)))
    return tuple(out)


def _plant(schema: PlantSchema, base: Any, effects: Sequence[Mapping[str, Any]],
           **options: Any) -> Plant:
    try:
        return schema.plant(base, _instances(schema, effects), **options)
    except ModelError as err:
        raise ModelFileError(str(err)) from None


def manipulator_plant(effects: Sequence[Mapping[str, Any]],
                      base: man.ManipulatorParams | None = None,
                      sigma: Sequence[float] | float = DEFAULT_SIGMA) -> Plant:
    """Vocabulary effects (report dicts) → the arm's :class:`~simgap.models.effects.Plant`."""
    sig = (float(sigma),) * 2 if np.isscalar(sigma) else tuple(float(s) for s in sigma)
    return _plant(man.PLANT_SCHEMA, base, effects, coulomb_sigma=sig)


class AugmentedManipulator(man.ManipulatorNominal):
    """The arm's nominal model plus the named effects (see the module docstring).

    Args:
        effects: vocabulary effects (dicts as in the report's ``effects``).
        base: nominal parameters.
        sigma: Coulomb/Stribeck smoothing velocity per joint (rad/s).
        dt: step period (s).
    """

    name = "manipulator2dof+effects"

    def __init__(self, effects: Sequence[Mapping[str, Any]] = (),
                 base: man.ManipulatorParams | None = None,
                 sigma: Sequence[float] | float = DEFAULT_SIGMA, dt: float = 0.002) -> None:
        plant = manipulator_plant(effects, base, sigma)
        params, friction, disturbance = plant.true_params, plant.folded.extras["friction"], \
            plant.folded.extras["disturbance"]
        super().__init__(params, dt=dt)
        self.plant = plant
        self.base_params = base or man.ManipulatorParams()
        self.effects = [dict(e) for e in effects]
        self.sigma = sigma
        self.friction, self.disturbance = friction, disturbance
        self.theta = plant.array

    def tau_d(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Left-out torque of the named friction/bias/spring effects (N·m)."""
        return man.tau_d(np.asarray(q, dtype=np.float64), np.asarray(dq, dtype=np.float64),
                         self.theta)

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """dx/dt in (q, p) with p = M_aug(q) dq: eq. 2.3 with u − tau_d(q, dq)."""
        x = np.asarray(x, dtype=np.float64)
        dq = self.observation(x)[2:]
        return man.nominal_derivative(x, np.asarray(u, dtype=np.float64) - self.tau_d(x[:2], dq),
                                      self._la)

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """C dq + G + tau_d (N·m) of the augmented arm."""
        return super().bias(q, dq) + self.tau_d(q, dq)

    def env_kwargs(self) -> dict[str, Any]:
        """Arguments of ``ManipulatorFrictionEnv`` whose plant is this model."""
        return {"friction": self.friction, "disturbance": self.disturbance,
                "true_params": self.params}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        return {"schema": 1, "model": "manipulator2dof",
                "base_params": {f.name: getattr(self.base_params, f.name)
                                for f in dataclasses.fields(self.base_params)},
                "effects": self.effects,
                "options": {"coulomb_sigma": list(np.broadcast_to(self.sigma, 2).astype(float)),
                            "dt": self.dt},
                "plant": self.plant.to_dict()}


def bicycle_physics(effects: Sequence[Mapping[str, Any]], base: BicycleParams | None = None
                    ) -> dict[str, Any]:
    """Vocabulary effects → true vehicle parameters and options of the bicycle."""
    return _phys(bicycle_plant(effects, base))


def _phys(plant: Plant) -> dict[str, Any]:
    f = plant.folded
    return {"mu": list(f.extras["axle_mu"]), "steering_lag": f.extras["steering_lag"],
            "lateral_bias": f.extras["lateral_bias"], "yaw_bias": f.extras["yaw_bias"],
            "params": f.params}


def bicycle_plant(effects: Sequence[Mapping[str, Any]], base: BicycleParams | None = None,
                  vx: float = 20.0, tire: MagicFormulaTire | None = None) -> Plant:
    """Vocabulary effects (report dicts) → the vehicle's :class:`~simgap.models.effects.Plant`."""
    mf = tire or MagicFormulaTire()
    return _plant(bic.PLANT_SCHEMA, base, effects, vx=vx, mf_C=mf.C, mf_E=mf.E)


class AugmentedBicycle(BicycleNominal):
    """The bicycle's nominal model plus the named effects (see the module docstring)."""

    name = "bicycle+effects"

    def __init__(self, effects: Sequence[Mapping[str, Any]] = (),
                 base: BicycleParams | None = None, vx: float = 20.0, dt: float = 0.01,
                 tire: MagicFormulaTire | None = None) -> None:
        plant = bicycle_plant(effects, base, vx, tire)
        phys = _phys(plant)
        super().__init__(phys["params"], vx=vx, dt=dt)
        self.plant = plant
        self.base_params = base or BicycleParams()
        self.effects = [dict(e) for e in effects]
        self.phys = phys
        self.tire = tire or MagicFormulaTire()

    def with_speed(self, vx: float) -> AugmentedBicycle:
        """Return the same augmented model at another speed (m/s)."""
        return AugmentedBicycle(self.effects, self.base_params, vx=vx, dt=self.dt,
                                tire=self.tire)

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """dx/dt with per-axle Magic Formula where named, biases added (commanded steering)."""
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        p = self.params
        slips = bic.slip_angles(x[0], x[1], u[0], u[1], self.vx, p.lf, p.lr)
        forces = [linear_force(alpha, ca) if mu is None else
                  magic_formula(alpha, ca, fz, mu, self.tire.C, self.tire.E)
                  for alpha, ca, fz, mu in zip(slips, (p.C_af, p.C_ar), p.axle_loads(),
                                               self.phys["mu"], strict=True)]
        dvy, dr = body_derivative(x[0], x[1], forces[0], forces[1], self.vx, p.array)
        return np.array([dvy + self.phys["lateral_bias"], dr + self.phys["yaw_bias"]])

    def env_kwargs(self) -> dict[str, Any]:
        """Arguments of ``BicycleTireEnv`` whose plant is this model: ``{"plant": ...}``.

        The env's plant is this model's :class:`~simgap.models.effects.Plant` at the
        model's speed, so each axle keeps its own fitted μ (``env.unwrapped.mu_axles``).
        """
        return {"plant": self.plant.with_options(vx=self.vx)}

    def plant_theta(self, vx: float | None = None) -> np.ndarray:
        """Plant array (:func:`simgap.models.bicycle.plant_array`) incl. the steering lag."""
        return self.plant.with_options(vx=vx or self.vx).array

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        return {"schema": 1, "model": "bicycle",
                "base_params": {f.name: getattr(self.base_params, f.name)
                                for f in dataclasses.fields(self.base_params)},
                "effects": self.effects, "options": {"vx": self.vx, "dt": self.dt},
                "plant": self.plant.to_dict()}


@dataclass(frozen=True)
class NoParams:
    """The parameters of a mechanical model that declares no parameter dataclass."""


def _fold_mechanical(plant: Plant) -> Folded:
    """A user mechanical model has no plant kernel: it is simulated in numpy (no array)."""
    return Folded(plant.params, np.zeros(0), {})


def mechanical_schema(model: MechanicalNominalModel, channels: Sequence[str] | None = None
                      ) -> PlantSchema:
    """The generic mechanical :class:`~simgap.models.effects.PlantSchema` of any model.

    Built from the model's joints and the mechanical vocabulary (the arm's effect
    declarations in :mod:`simgap.models.manipulator`, whose units are templates filled per
    joint): system = the model's name, parameters = its ``params`` dataclass (or
    :class:`NoParams`), channels = its joints. Where the model holds its own per-joint
    coefficients (``nominal_coefficients()``), the effects that correct them
    (``FitSpec.corrects``) may be negative, as the diagnosis fits them. Options: the Coulomb
    smoothing per joint (rad/s or m/s), the step ``dt`` (s) and the ``model_file``
    (``path.py:NAME``) the model is read from.
    """
    n = len(model.input_names)
    names = tuple(channels or getattr(model, "channel_names", ()) or ())
    if len(names) != n:
        names = tuple(f"joint{i + 1}" for i in range(n))
    params = getattr(model, "params", None)
    cls = type(params) if dataclasses.is_dataclass(params) else NoParams
    own = getattr(model, "nominal_coefficients", None)
    coefficients = own() if callable(own) else {}
    vocabulary = []
    for spec in man.VOCABULARY:
        if spec.fit is None:
            continue
        signed = {coord for coord, coef in spec.fit.corrects if coef in coefficients}
        if signed:
            spec = dataclasses.replace(spec, params=tuple(
                dataclasses.replace(p, bounds=(-math.inf, p.bounds[1])) if p.name in signed
                else p for p in spec.params))
        vocabulary.append(spec)
    return PlantSchema(system=str(getattr(model, "name", None) or type(model).__name__),
                       params_cls=cls, channels=names, vocabulary=tuple(vocabulary),
                       options={"coulomb_sigma": (1e-3,) * n,
                                "dt": float(getattr(model, "dt", 0.0) or 0.0),
                                "model_file": None},
                       fold=_fold_mechanical)


def mechanical_plant(model: MechanicalNominalModel, effects: Sequence[Mapping[str, Any]], *,
                     channels: Sequence[str] | None = None,
                     coulomb_sigma: Sequence[float] | None = None,
                     source: str | None = None) -> Plant:
    """Vocabulary effects (report dicts) → the :class:`Plant` of a mechanical model."""
    schema = mechanical_schema(model, channels)
    params = getattr(model, "params", None)
    options: dict[str, Any] = {"model_file": source}
    if coulomb_sigma is not None:
        options["coulomb_sigma"] = tuple(float(v) for v in coulomb_sigma)
    return _plant(schema, params if dataclasses.is_dataclass(params) else NoParams(), effects,
                  **options)


def terms_of_plant(plant: Plant, effects: Mapping[str, Any]) -> list[tuple]:
    """The fit terms (effect, channel index, lin, nl) that simulate a plant's instances.

    Args:
        plant: a mechanical plant (:func:`mechanical_plant`).
        effects: the diagnosis effects by name (units do not matter for simulation).

    Raises:
        ModelFileError: an instance no vocabulary effect of this form can simulate (e.g. a
            payload at a MuJoCo tip point: that model's augmented form is its corrected
            MJCF), or parameters without an inverse map.
    """
    out = []
    for inst in plant.effects:
        effect = effects.get(inst.name)
        if effect is None:
            raise ModelFileError(f"augmented model: effect {inst.name!r} cannot be simulated "
                                 f"on {plant.system} from its parameters")
        context: dict[str, float] = {}
        for need in effect.needs:   # e.g. Stribeck's Fs includes the same joint's Fc
            other = plant.get(need, inst.channel)
            if other is not None:
                context.update(other.params)
        try:
            lin, nl = effect.coordinates(inst.params, context)
        except ModelError as err:
            raise ModelFileError(f"augmented model: {inst.name}: {err}") from None
        out.append((effect, channel_index(plant.schema.channels, inst.channel), lin, nl))
    return out


class AugmentedMechanical(MechanicalNominalModel):
    """Any mechanical nominal model plus fitted effects: M + A(q), bias + b(q, dq).

    Its value is a :class:`~simgap.models.effects.Plant` of the model's generic mechanical
    schema (:func:`mechanical_schema`): the model's parameters plus the named effect
    instances, serialised like the arm's and the bicycle's (``to_dict()["plant"]``).

    Args:
        base: the nominal model.
        system: the :class:`~simgap.diagnosis.systems.MechanicalSystem` form of ``base``
            (the effects' context).
        fitted: (effect, index, lin, nl) tuples from the fit, which simulate the model
            exactly as the diagnosis compared it; ``None``: rebuilt from the plant's
            instances (:func:`terms_of_plant`, e.g. when read back from a file).
        coulomb_sigma: tanh smoothing velocity of the Coulomb/Stribeck terms per joint (rad/s
            or m/s), as the diagnosis used it; default 1e-3 (or the plant's).
        effects: the reported effects (dicts as in the report's ``effects``).
        source: ``path/to/model.py:NAME`` of a user model, so the JSON can be read back.
        plant: the augmented plant; default: built from ``effects``.

    The state is taken to be (q, dq) (2n entries); ``f`` returns (dq, ddq).
    """

    def __init__(self, base: MechanicalNominalModel, system: Any,
                 fitted: Sequence[tuple] | None = None, *,
                 coulomb_sigma: Sequence[float] | None = None,
                 effects: Sequence[Mapping[str, Any]] = (),
                 source: str | None = None, plant: Plant | None = None) -> None:
        self.base, self.system = base, system
        if plant is None:
            plant = mechanical_plant(base, effects, channels=system.channels,
                                     coulomb_sigma=coulomb_sigma, source=source)
        self._plant = plant
        self.effects = [dict(e) for e in effects] if effects else \
            [e.to_dict() for e in plant.effects]
        self.coulomb_sigma = np.array(plant.options["coulomb_sigma"], dtype=np.float64)
        self.coulomb_sigma.flags.writeable = False
        self.context = system.effect_context(self.coulomb_sigma)
        if fitted is None:
            from simgap.diagnosis.effects import MECHANICAL_EFFECTS

            fitted = terms_of_plant(plant, {e.name: e for e in MECHANICAL_EFFECTS})
        self.fitted = list(fitted)
        self.name = f"{getattr(base, 'name', 'mechanical')}+effects"
        for attr in ("state_names", "state_units", "input_names", "input_units", "dt"):
            setattr(self, attr, getattr(base, attr))

    @property
    def plant(self) -> Plant:
        """The augmented plant (the model's parameters + the named effect instances)."""
        return self._plant

    @property
    def source(self) -> str | None:
        """``path/to/model.py:NAME`` the nominal model is read from (``None``: not a file)."""
        return self._plant.options["model_file"]

    @source.setter
    def source(self, spec: str | None) -> None:
        self._plant = self._plant.with_options(model_file=spec)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (read back by :func:`simgap.diagnosis.load_augmented`).

        The arm's and the bicycle's layout: the reported effects beside the augmented
        :class:`~simgap.models.effects.Plant` (``"plant"``), plus ``"kind": "mechanical"``
        and the model file that rebuilds the nominal model.
        """
        params = getattr(self.base, "params", None)
        base = ({f.name: getattr(params, f.name) for f in dataclasses.fields(params)}
                if dataclasses.is_dataclass(params) else {})
        return {"schema": 1, "model": getattr(self.base, "name", "mechanical"),
                "kind": "mechanical", "model_file": self.source, "base_params": base,
                "effects": self.effects,
                "options": {"coulomb_sigma": [float(v) for v in self.coulomb_sigma],
                            "dt": float(self.dt)},
                "plant": self.plant.to_dict()}

    def _split(self, q, dq):
        a, b = self.system._effect_split(self.fitted, np.atleast_2d(q), np.atleast_2d(dq),
                                         self.context)
        return a[0], b[0]

    def M(self, q: np.ndarray) -> np.ndarray:  # noqa: N802
        """Mass matrix plus the effects' acceleration terms."""
        q = np.asarray(q, dtype=np.float64)
        return self.base.M(q) + self._split(q, np.zeros_like(q))[0]

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Bias plus the effects' velocity/position terms."""
        return self.base.bias(q, dq) + self._split(q, dq)[1]

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(dq, ddq) for x = (q, dq)."""
        x = np.asarray(x, dtype=np.float64)
        n = x.shape[0] // 2
        q, dq = x[:n], x[n:]
        ddq = np.linalg.solve(self.M(q), np.asarray(u, dtype=np.float64) - self.bias(q, dq))
        return np.concatenate([dq, ddq])


def save_model(model: AugmentedManipulator | AugmentedBicycle, path: str | os.PathLike, *,
               overwrite: bool = False) -> Path:
    """Write the augmented model's JSON (see the module docstring), atomically.

    An existing file is replaced only with ``overwrite=True``; otherwise
    :class:`~simgap.errors.OutputError` names it and nothing is written.
    """
    path = Path(path)
    text = json.dumps(model.to_dict(), indent=2)
    write_file(path, lambda tmp: tmp.write_text(text, encoding="utf-8"), overwrite=overwrite)
    return path


def model_from_dict(d: Mapping[str, Any]) -> AugmentedManipulator | AugmentedBicycle:
    """Rebuild an augmented model from its JSON description.

    The description holds the augmented :class:`~simgap.models.effects.Plant`
    (``"plant"``: ``Plant.to_dict()``) beside the report's effects; files written before
    it (no ``"plant"``) are read from ``base_params``, ``effects`` and ``options``.
    """
    if "plant" in d:
        return _from_plant(d)
    try:
        kind, effects, opts = d["model"], d.get("effects", []), d.get("options", {})
        if kind == "manipulator2dof":
            base = man.ManipulatorParams(**{k: (tuple(v) if isinstance(v, list) else v)
                                            for k, v in d.get("base_params", {}).items()})
            return AugmentedManipulator(effects, base, opts.get("coulomb_sigma", DEFAULT_SIGMA),
                                        dt=opts.get("dt", 0.002))
        if kind == "bicycle":
            base = BicycleParams(**d.get("base_params", {}))
            return AugmentedBicycle(effects, base, vx=opts.get("vx", 20.0),
                                    dt=opts.get("dt", 0.01))
    except (KeyError, TypeError) as err:
        raise ModelFileError(f"augmented model description is incomplete: {err}") from None
    raise ModelFileError(f"unknown model {d.get('model')!r} in augmented model description")


def _from_plant(d: Mapping[str, Any]) -> AugmentedManipulator | AugmentedBicycle:
    """An augmented model from the ``"plant"`` of its description (plus ``dt``)."""
    from simgap.systems import get_system

    pd = d["plant"]
    spec = get_system(str(pd.get("system", d.get("model"))), ModelFileError)
    if spec.plant_schema is None:
        raise ModelFileError(f"augmented model: system {spec.name!r} has no plant")
    try:
        plant = Plant.from_dict(pd, spec.plant_schema)
    except ModelError as err:
        raise ModelFileError(f"augmented model: {err}") from None
    effects = [e.to_dict() for e in plant.effects]
    dt = d.get("options", {}).get("dt")
    if plant.system == "manipulator2dof":
        return AugmentedManipulator(effects, plant.params, plant.options["coulomb_sigma"],
                                    dt=dt or 0.002)
    if plant.system == "bicycle":
        o = plant.options
        return AugmentedBicycle(effects, plant.params, vx=o["vx"], dt=dt or 0.01,
                                tire=MagicFormulaTire(C=o["mf_C"], E=o["mf_E"]))
    raise ModelFileError(f"augmented model: no augmented model class for {plant.system!r}")


def load_model(path: str | os.PathLike) -> AugmentedManipulator | AugmentedBicycle:
    """Read an augmented model JSON written by :func:`save_model`."""
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise ModelFileError(f"{path}: cannot read augmented model ({err})") from None
    return model_from_dict(d)
