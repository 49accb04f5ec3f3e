"""``VectorIdentifierWrapper``: one identifier per sub-env of a vector env, one batched kernel.

For ``gym.make_vec(id, num_envs=N, vectorization_mode="sync")`` (any ``VectorEnv`` whose
``get_attr("nominal_model")`` returns the sub-envs' models). All N identifiers start from
the same initial weights (same seed) and learn from their own sub-env; a
:class:`~simgap.identifiers.BatchIdentifier` advances them in one numba call.

Autoreset (gymnasium 1.x, ``envs.metadata["autoreset_mode"]``):

* ``NEXT_STEP`` (default): the step after a sub-env terminated/truncated only resets it and
  ignores the action; it is not a transition: that row learns nothing, its observer restarts
  at the reset observation, and its info entries are masked out (``info["_residual_estimate"]``
  False for it).
* ``SAME_STEP``: a finishing sub-env's transition ends in ``info["final_obs"]``; the row learns
  from (x_k → state(final_obs)), then its observer restarts at the returned reset observation.
* ``DISABLED``: ``reset(options={"reset_mask": m})`` restarts the observers of the masked rows.

Info keys (gymnasium vector convention: an (N, …) array plus a boolean ``_key`` mask):
``residual_estimate``, ``state_estimate``, ``estimation_error``, ``physical_residual_estimate``
(when the model has ``physical_residual``; plus the keys its registered system names in
:attr:`~simgap.systems.SystemSpec.residual_info_keys`, ``axle_force_residual_estimate`` for
the bicycle), and ``identifier_frozen`` (bool). Reset semantics as for
:class:`~simgap.wrappers.IdentifierWrapper`: a seeded reset restores the reset point.

When every row shares one nominal model object (the native vector envs: ``gym.make_vec``'s
default mode) and the model has the row-batched ``states`` / ``inputs`` / ``f_rows`` of
:class:`~simgap.models.base.BaseNominalModel`, a step makes no per-row Python calls: the model
kernels take all rows at once (bit-identical to the per-row calls). Otherwise (the sync vector
env: one model per sub-env) the model is called row by row. Angles named by the model's
``periodic_states`` are fed as the representatives nearest to each row's x̂ and the reported
x̂ and estimation error are wrapped into (−π, π], as in the single-env wrapper.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from simgap.envs._common import check_reset
from simgap.identifiers import BatchIdentifier, IdentifierConfig, IdentifierError
from simgap.identifiers.config import check_kind
from simgap.models.base import NominalModel, wrap_angle
from simgap.wrappers.identifier_wrapper import (
    action_to_input,
    periodic_indices,
    residual_info_keys,
    resolve_config,
)


class VectorIdentifierWrapper(gym.vector.VectorWrapper):
    """Batched online identification over the sub-envs of a vector env.

    Args:
        env: the vector env.
        identifier: ``"integral"`` (default), ``"instantaneous"`` or ``"minibatch"``.
        frozen: start frozen.
        config: identifier config, or a preset name: default (``None``/``"auto"``)
            ``preset("auto", kind, dt=model.dt)``; ``"system"`` the thesis preset registered
            for the model's system (see :func:`~simgap.wrappers.identifier_wrapper.resolve_config`).
        seed: seed of the (shared) initial weights.
        reset_identifier_on_seed: a seeded reset restores the reset point (default True).
        threads: passed to :class:`~simgap.identifiers.BatchIdentifier`. Default ``False``
            (one core): numba's threads gained 1.35-1.55x on an idle machine and lost 4-46x
            at load 2.3-2.8 on the shared 2-core machine (issue 17); ``True`` on a machine of
            your own, ``None`` for the batch's own rule (threads from 256 rows up).
    """

    def __init__(self, env: gym.vector.VectorEnv, identifier: str = "integral", *,
                 frozen: bool = False, config: IdentifierConfig | str | None = None,
                 seed: int = 0, reset_identifier_on_seed: bool = True,
                 threads: bool | None = False) -> None:
        super().__init__(env)
        models = tuple(env.get_attr("nominal_model"))
        for mdl in models:
            if not isinstance(mdl, NominalModel):
                raise IdentifierError(f"sub-env nominal_model {mdl!r} does not follow the "
                                      f"NominalModel protocol")
        m0 = models[0]
        n, m = len(m0.state_names), len(m0.input_names)
        for mdl in models[1:]:
            if (len(mdl.state_names), len(mdl.input_names)) != (n, m) or mdl.dt != m0.dt:
                raise IdentifierError("all sub-envs need nominal models of equal sizes and dt")
        self.nominal_models = models
        kind = check_kind(identifier)
        config = resolve_config(m0, kind, config)
        self.identifier = BatchIdentifier(kind, env.num_envs, n, m, m0.dt, config=config,
                                          seed=seed, threads=threads)
        if frozen:
            self.identifier.freeze()
        self.reset_identifier_on_seed = bool(reset_identifier_on_seed)
        self._reset_point = self.identifier.state_dict()
        self.autoreset_mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if isinstance(self.autoreset_mode, str):
            self.autoreset_mode = AutoresetMode(self.autoreset_mode)
        self._physical = [getattr(mdl, "physical_residual", None) for mdl in models]
        self._extra_keys = residual_info_keys(m0)
        self._n, self._m = n, m
        self._batched = all(mdl is m0 for mdl in models) and all(
            callable(getattr(m0, name, None)) for name in ("states", "inputs", "f_rows"))
        self._periodic = periodic_indices(m0)
        self._x: np.ndarray | None = None
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._all_true = np.ones(self.num_envs, dtype=bool)  # templates of the info masks
        self._all_false = np.zeros(self.num_envs, dtype=bool)

    # ------------------------------------------------------------------ control
    def freeze(self) -> None:
        """Hold all weights; observers keep running."""
        self.identifier.freeze()

    def unfreeze(self) -> None:
        """Resume learning."""
        self.identifier.unfreeze()

    def mark_reset_point(self) -> None:
        """Make the current learned state the one a seeded reset restores."""
        self._reset_point = self.identifier.state_dict()

    def _states(self, obs: Any) -> np.ndarray:
        if self._batched:
            return np.asarray(self.nominal_models[0].states(obs), dtype=np.float64)
        return np.stack([np.asarray(mdl.state(o), dtype=np.float64).reshape(-1)
                         for mdl, o in zip(self.nominal_models, obs, strict=True)])

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset the sub-envs and observers (masked rows only with ``options["reset_mask"]``)."""
        mask = None
        if options is not None and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool).copy()
        obs, infos = self.env.reset(seed=seed, options=options)
        if seed is not None and self.reset_identifier_on_seed:
            frozen = self.identifier.frozen
            self.identifier.load_state_dict(self._reset_point)
            (self.identifier.freeze if frozen else self.identifier.unfreeze)()
        x0 = self._states(obs)
        if mask is None or self._x is None:
            self.identifier.reset_observer(None, x0)
            self._x = x0
            self._autoreset[:] = False
        else:
            self.identifier.reset_observer(mask, x0)
            self._x[mask] = x0[mask]
            self._autoreset[mask] = False
        return obs, infos

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        """Step all sub-envs, then all identifiers in one kernel call."""
        check_reset(self._x is not None, "VectorIdentifierWrapper")  # EnvError, ResetNeeded
        obs, rewards, terms, truncs, infos = self.env.step(actions)
        nn = self.num_envs
        space = self.env.single_action_space
        applied = infos.get("applied_action")
        if applied is not None and np.asarray(infos.get("_applied_action", True)).all():
            acts = applied
            space = None  # already what acted
        else:
            acts = actions
        u = self._inputs(space, acts)
        x = self._x
        obs_now = self._states(obs)
        x_next = obs_now  # read only below unless a SAME_STEP row or an angle changes it
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            restart = self._autoreset if self._autoreset.any() else None
            learn = self._all_true if restart is None else ~restart
        else:
            learn = self._all_true
            restart = None
            if self.autoreset_mode == AutoresetMode.SAME_STEP:
                done = np.asarray(terms, dtype=bool) | np.asarray(truncs, dtype=bool)
                if done.any():
                    finals = infos["final_obs"]
                    x_next = obs_now.copy()
                    for i in np.flatnonzero(done):
                        x_next[i] = np.asarray(self.nominal_models[i].state(finals[i]),
                                               dtype=np.float64).reshape(-1)
                    restart = done
        per = self._periodic
        if per.size:
            x, x_next = self._unwrap(per, x, x_next)
        if self._batched:
            f = np.asarray(self.nominal_models[0].f_rows(x, u), dtype=np.float64)
        else:
            f = np.stack([np.asarray(mdl.f(x[i], u[i]), dtype=np.float64).reshape(-1)
                          for i, mdl in enumerate(self.nominal_models)])
        ident = self.identifier
        g = ident.step(x, u, f, x_next, learn=None if restart is None else learn)
        x_hat, x_tilde = ident.x_hat, ident.x_tilde
        if per.size:
            ident.wrap_observer(per)
            x_hat[:, per] = wrap_angle(x_hat[:, per])
            x_tilde[:, per] = wrap_angle(x_tilde[:, per])
        infos["residual_estimate"] = g
        infos["_residual_estimate"] = learn.copy()
        infos["state_estimate"] = x_hat
        infos["_state_estimate"] = learn.copy()
        infos["estimation_error"] = x_tilde
        infos["_estimation_error"] = learn.copy()
        infos["identifier_frozen"] = (self._all_true if ident.frozen else self._all_false).copy()
        infos["_identifier_frozen"] = self._all_true.copy()
        if self._physical[0] is not None:
            if self._batched:
                phys = np.asarray(self._physical[0](x, g), dtype=np.float64).reshape(nn, -1)
            else:
                phys = np.stack([np.asarray(pr(x[i], g[i]), dtype=np.float64).reshape(-1)
                                 for i, pr in enumerate(self._physical)])
            infos["physical_residual_estimate"] = phys
            infos["_physical_residual_estimate"] = learn.copy()
            for key in self._extra_keys:
                infos[key] = phys.copy()
                infos[f"_{key}"] = learn.copy()
        if restart is not None:  # the rows that were reset (NEXT_STEP) or finished (SAME_STEP)
            ident.reset_observer(restart, obs_now)
        self._x = obs_now
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._autoreset = np.asarray(terms, dtype=bool) | np.asarray(truncs, dtype=bool)
        return obs, rewards, terms, truncs, infos

    # ------------------------------------------------------------------ helpers
    def _inputs(self, space: gym.Space | None, acts: Any) -> np.ndarray:
        """The input u of every row: actions (clipped to a Box ``space``) via ``model.input``."""
        if self._batched:
            a = np.asarray(acts, dtype=np.float64)
            if isinstance(space, gym.spaces.Box):
                a = np.clip(a, space.low, space.high)
            return np.asarray(self.nominal_models[0].inputs(a), dtype=np.float64)
        rows = list(gym.vector.utils.iterate(self.env.action_space, acts)) \
            if space is not None else list(np.asarray(acts))
        return np.stack([action_to_input(mdl, space, a)
                         for mdl, a in zip(self.nominal_models, rows, strict=True)])

    def _unwrap(self, per: np.ndarray, x: np.ndarray, x_next: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """Rows of (x_k, x_{k+1}) with angles moved by whole turns next to each row's x̂.

        As :func:`~simgap.wrappers.identifier_wrapper.unwrap_pair` per row: the reference is
        x̂_k where the row's observer is initialised (not for baseline 2 on measured x),
        else x_k itself.
        """
        x = x.copy()
        x_next = x_next.copy()
        step = wrap_angle(x_next[:, per] - x[:, per])
        ident = self.identifier
        if ident.observes:
            obs = ident._field("observer")  # [x̂ (n) | z (n) | initialised]
            ready = obs[:, 2 * self._n] != 0.0
            ref = obs[:, per]
            moved = ref + wrap_angle(x[:, per] - ref)
            x[:, per] = np.where(ready[:, None], moved, x[:, per])
        x_next[:, per] = x[:, per] + step
        return x, x_next
