"""``IdentifierWrapper``: an online residual identifier running inside any env.

Works on every env whose ``env.unwrapped.nominal_model`` follows
:class:`simgap.models.base.NominalModel`. Per transition (obs_k, action_k) → obs_{k+1}:

    x_k = model.state(obs_k),  x_{k+1} = model.state(obs_{k+1}),
    u_k = model.input(a_k),  f_k = model.f(x_k, u_k),
    ĝ_k = identifier.step(x_k, u_k, f_k, x_{k+1})

(time indexing in :mod:`simgap.identifiers`), where a_k is ``info["applied_action"]`` if
the env reports it (the simgap envs do: the action after clipping), else the action clipped
to a ``Box`` action space, else the action as it is.

Keys added to ``info`` on every ``step`` (arrays are fresh copies):

* ``residual_estimate``: ĝ_k (n,), state units/s (compare ``info["residual_true"]``);
* ``state_estimate``: x̂_{k+1} (n,), the estimate of the state just returned;
* ``estimation_error``: x̃_{k+1} = x_{k+1} − x̂_{k+1} (n,);
* ``identifier_frozen``: bool;
* ``physical_residual_estimate``: ``model.physical_residual(x_k, ĝ_k)`` when the model has
  it (manipulator: joint torques tau_d, N·m; bicycle: axle forces K⁻¹ĝ, N);
* further keys with the same array (a copy each) where the model's registered system names
  them (:attr:`simgap.systems.SystemSpec.residual_info_keys`, looked up by ``model.name``):
  ``axle_force_residual_estimate`` for the bicycle.

``reset`` adds ``state_estimate`` (= x_0) and ``identifier_frozen``.

Resets (what carries over):

* ``reset()`` / ``reset(seed=None)``: an ordinary new episode. Everything learned is kept
  (weights, baseline 2's buffer and Generator); only the observer restarts at x̂ = x_0, z = 0.
* ``reset(seed=s)`` with an int: additionally restores the identifier's learned state
  (weights, z, buffer, sampling Generator, counters) to the *reset point*, by default the
  state at wrapper construction (:meth:`IdentifierWrapper.mark_reset_point` moves it, e.g.
  after pre-training). The frozen flag is not touched. A seeded reset therefore reproduces
  a run exactly, which is what gymnasium's and stable-baselines3's ``check_env`` test;
  ``reset_identifier_on_seed=False`` turns this off (then learning carries across seeded
  resets too).
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from simgap.envs._common import check_reset
from simgap.errors import SimgapError
from simgap.identifiers import Identifier, IdentifierConfig, IdentifierError, make_identifier
from simgap.identifiers.config import check_kind, preset
from simgap.models.base import NominalModel, wrap_angle


def __getattr__(name: str) -> Any:
    if name == "PRESET_FOR_MODEL":  # deprecated: the presets live in the system registry
        import warnings

        from simgap.systems import SYSTEMS

        warnings.warn("PRESET_FOR_MODEL is deprecated; use "
                      "simgap.systems.get_system(name).identifier_preset", DeprecationWarning,
                      stacklevel=2)
        return {n: s.identifier_preset for n, s in SYSTEMS.items() if s.identifier_preset}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _vec(a: Any) -> np.ndarray:
    """A float64 1-D array (no copy if it already is one)."""
    if type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 1:
        return a
    return np.asarray(a, dtype=np.float64).reshape(-1)


def _is_mujoco_env(env: gym.Env | Any) -> bool:
    base = getattr(env, "unwrapped", env)
    return type(getattr(base, "model", None)).__name__ == "MjModel" and hasattr(base, "data")


def nominal_model_of(env: gym.Env | Any, model: NominalModel | None = None) -> NominalModel:
    """The nominal model of ``env``, checked against the protocol.

    ``model`` if given, else ``env.unwrapped.nominal_model``, else one built from a Gymnasium
    MuJoCo env's ``model`` and ``data``.
    """
    if model is None:
        model = getattr(getattr(env, "unwrapped", env), "nominal_model", None)
    if model is None and _is_mujoco_env(env):  # Gymnasium's MuJoCo envs (model + data)
        from simgap.models.mujoco import from_mujoco_env

        try:
            model = from_mujoco_env(env)
        except SimgapError as err:
            raise IdentifierError(str(err)) from None
    if model is None:
        raise IdentifierError(f"{type(getattr(env, 'unwrapped', env)).__name__} has no "
                              f"'nominal_model' attribute; pass one with IdentifierWrapper(env, "
                              f"model=...) (see simgap.models.base.NominalModel)")
    if not isinstance(model, NominalModel):
        raise IdentifierError(f"nominal_model {model!r} lacks part of the NominalModel "
                              f"protocol (state_names, state_units, input_names, input_units, "
                              f"dt, state(obs), f(x, u))")
    return model


def resolve_config(model: NominalModel, kind: str,
                   config: IdentifierConfig | str | None) -> IdentifierConfig:
    """The identifier configuration the wrappers use for ``model``.

    Args:
        model: the nominal model (its ``dt`` and, for ``"system"``, its ``name``).
        kind: the identifier kind.
        config: an :class:`IdentifierConfig` (used as given); ``None`` or ``"auto"``: the
            scale-free ``preset("auto", kind, dt=model.dt)`` (the default, for any env);
            ``"system"``: the thesis reproduction preset registered for the model's system
            (:func:`simgap.systems.identifier_preset_of`; ``IdentifierError`` if the system
            is unregistered or has none); another string: that preset by name
            (``"manipulator"``, ``"bicycle"``).

    Raises:
        IdentifierError: an unknown preset name, or ``"system"`` without a registered preset.
    """
    if isinstance(config, IdentifierConfig):
        return config
    if config is None:
        config = "auto"
    if not isinstance(config, str):
        raise IdentifierError(f"config must be an IdentifierConfig, a preset name or None, "
                              f"got {config!r}")
    if config == "system":
        from simgap.systems import identifier_preset_of

        config = identifier_preset_of(model)
    return preset(config, kind, dt=model.dt)


def residual_info_keys(model: NominalModel) -> tuple[str, ...]:
    """Extra info keys of the physical-residual estimate, from the system registry."""
    from simgap.systems import residual_info_keys_of

    return residual_info_keys_of(model)


def build_identifier(model: NominalModel, identifier: str | Identifier,
                     config: IdentifierConfig | str | None, seed: int) -> Identifier:
    """Make (or check) the identifier that fits ``model``'s sizes and dt.

    ``config`` as in :func:`resolve_config`.
    """
    n, m = len(model.state_names), len(model.input_names)
    if isinstance(identifier, Identifier):
        if (identifier.n_states, identifier.n_inputs) != (n, m):
            raise IdentifierError(f"identifier has (n_states, n_inputs) = "
                                  f"{(identifier.n_states, identifier.n_inputs)}, the env's "
                                  f"nominal model needs {(n, m)}")
        if not np.isclose(identifier.dt, model.dt, rtol=1e-12, atol=0.0):
            raise IdentifierError(f"identifier dt={identifier.dt} s differs from the nominal "
                                  f"model's dt={model.dt} s")
        return identifier
    if not isinstance(identifier, str):
        raise IdentifierError(f"identifier must be a kind name or an Identifier, got "
                              f"{identifier!r}")
    kind = check_kind(identifier)
    return make_identifier(kind, n, m, model.dt, config=resolve_config(model, kind, config),
                           seed=seed)


def periodic_indices(model: NominalModel) -> np.ndarray:
    """``model.periodic_states`` (default none) as checked int indices into the state."""
    per = tuple(getattr(model, "periodic_states", ()) or ())
    n = len(model.state_names)
    for i in per:
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < n:
            raise IdentifierError(f"nominal model's periodic_states {per!r}: each entry must "
                                  f"be a state index in [0, {n})")
    return np.asarray(sorted(set(per)), dtype=np.int64)


def unwrap_pair(ident: Identifier, per: np.ndarray, x: np.ndarray, x_next: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """x_k, x_{k+1} with their angles ``per`` moved by whole turns next to the reference.

    The reference is x̂_k where the identifier runs an observer (once initialised), else x_k itself:
    x_k[i] → ref[i] + wrap(x_k[i] − ref[i]), x_{k+1}[i] → x_k[i] + wrap(x_{k+1}[i] − x_k[i])
    (the new x_k). The identifier then sees a continuous angle and its error x − x̂ is the
    wrapped error.
    """
    x = x.copy()
    x_next = x_next.copy()
    step = wrap_angle(x_next[per] - x[per])
    if ident.observes and ident.observer_initialised:
        ref = ident._field("observer")[0, per]
        x[per] = ref + wrap_angle(x[per] - ref)
    x_next[per] = x[per] + step
    return x, x_next


def action_to_input(model: NominalModel, space: gym.Space | None, action: Any) -> np.ndarray:
    """Return u = model.input(action clipped to a Box space), float64."""
    if isinstance(space, gym.spaces.Box):
        action = np.clip(np.asarray(action, dtype=np.float64), space.low, space.high)
    to_input = getattr(model, "input", None)
    u = to_input(action) if to_input is not None else action
    return np.asarray(u, dtype=np.float64).reshape(-1)


class IdentifierWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Run an online identifier on every transition; observations and rewards unchanged.

    Args:
        env: env with ``unwrapped.nominal_model`` (see the module docstring).
        identifier: ``"integral"`` (default, the proposed law), ``"instantaneous"``,
            ``"minibatch"``, or a ready :class:`~simgap.identifiers.Identifier` (its sizes and
            dt must match the model).
        frozen: start frozen (weights held; x̂ runs).
        config: identifier config; ``None`` (or ``"auto"``) = ``preset("auto", kind,
            dt=model.dt)``, the scale-free preset for any env. The thesis presets reproduce
            the thesis: ``config="system"`` takes the one registered for the model's system
            (:attr:`simgap.systems.SystemSpec.identifier_preset`), or name it:
            ``config="manipulator"`` / ``preset("manipulator", kind)`` (Table 4.3),
            ``"bicycle"`` (Table 4.4). See :func:`resolve_config`.
        seed: seed of the identifier's initial weights.
        reset_identifier_on_seed: see the module docstring.
        model: the nominal model f(x, u) of ``env`` (the ``NominalModel`` protocol); ``None``
            = ``env.unwrapped.nominal_model``. For a user's own env that does not carry one.
    """

    def __init__(self, env: gym.Env, identifier: str | Identifier = "integral", *,
                 frozen: bool = False, config: IdentifierConfig | str | None = None,
                 seed: int = 0,
                 reset_identifier_on_seed: bool = True,
                 model: NominalModel | None = None) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self, identifier=identifier, frozen=frozen, config=config, seed=seed,
            reset_identifier_on_seed=reset_identifier_on_seed, model=model)
        gym.Wrapper.__init__(self, env)
        self.nominal_model = nominal_model_of(env, model)
        self.identifier = build_identifier(self.nominal_model, identifier, config, seed)
        if frozen:
            self.identifier.freeze()
        self.reset_identifier_on_seed = bool(reset_identifier_on_seed)
        self._reset_point = self.identifier.state_dict()
        self._extra_keys = residual_info_keys(self.nominal_model)
        self._physical = getattr(self.nominal_model, "physical_residual", None)
        self._to_input = getattr(self.nominal_model, "input", None)
        space = env.action_space
        self._box = isinstance(space, gym.spaces.Box)
        self._low = np.asarray(space.low, dtype=np.float64) if self._box else None
        self._high = np.asarray(space.high, dtype=np.float64) if self._box else None
        self._x: np.ndarray | None = None
        self._periodic = periodic_indices(self.nominal_model)

    # ------------------------------------------------------------------ control
    def freeze(self) -> None:
        """Hold the weights (and buffer, z); x̂ keeps running."""
        self.identifier.freeze()

    def unfreeze(self) -> None:
        """Resume learning."""
        self.identifier.unfreeze()

    @property
    def frozen(self) -> bool:
        """Whether the identifier is frozen."""
        return self.identifier.frozen

    def mark_reset_point(self) -> None:
        """Make the identifier's current learned state the one a seeded reset restores."""
        self._reset_point = self.identifier.state_dict()

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and the observer (see the module docstring for what carries over)."""
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None and self.reset_identifier_on_seed:
            frozen = self.identifier.frozen
            self.identifier.load_state_dict(self._reset_point)
            if frozen:
                self.identifier.freeze()
            else:
                self.identifier.unfreeze()
        x0 = np.asarray(self.nominal_model.state(obs), dtype=np.float64).reshape(-1)
        self.identifier.reset_observer(x0)
        self._x = x0
        info["state_estimate"] = x0.copy()
        info["identifier_frozen"] = self.identifier.frozen
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env and the identifier (one transition)."""
        check_reset(self._x is not None, "IdentifierWrapper")  # EnvError (and gym's ResetNeeded)
        obs, reward, terminated, truncated, info = self.env.step(action)
        model = self.nominal_model
        x = self._x
        a = info.get("applied_action")  # what acted (the simgap envs report it)
        if a is None:
            if self._box:  # else assume the env applies the action clipped to its Box
                a = np.minimum(np.maximum(np.asarray(action, dtype=np.float64), self._low),
                               self._high)
            else:
                a = action
        u = _vec(a if self._to_input is None else self._to_input(a))
        x_next = _vec(model.state(obs))
        ident = self.identifier
        per = self._periodic
        x_new = x_next
        if per.size:  # feed the angles as the representatives nearest to the observer's
            x, x_next = unwrap_pair(ident, per, x, x_next)
        f = _vec(model.f(x, u))
        g = ident.step(x, u, f, x_next)
        info["residual_estimate"] = g
        if per.size:
            ident.wrap_observer(per)
            x_tilde = ident.x_tilde
            x_tilde[per] = wrap_angle(x_tilde[per])
            x_hat = ident.x_hat
            x_hat[per] = wrap_angle(x_hat[per])
            info["state_estimate"] = x_hat
            info["estimation_error"] = x_tilde
        else:
            info["state_estimate"] = ident.x_hat
            info["estimation_error"] = ident.x_tilde
        info["identifier_frozen"] = ident.frozen
        if self._physical is not None:
            phys = np.asarray(self._physical(x, g), dtype=np.float64)
            info["physical_residual_estimate"] = phys
            for key in self._extra_keys:
                info[key] = phys.copy()
        self._x = x_new
        return obs, reward, terminated, truncated, info
