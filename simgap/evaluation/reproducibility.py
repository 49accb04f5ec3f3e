"""The reproducibility test of thesis Sec. 4.1, for any identifier on any recorded rollout.

Procedure (thesis Fig. 4.1):

1. **Online estimation**: the identifier adapts on the recorded transitions k = 0, 1, …
   (``Identifier.step(x_k, u_k, f_k, x_{k+1})``); its online output ĝ_k is stored.
2. **Weight freezing** at each freeze time T_f: a deep copy of the identifier is taken after
   the last transition that starts before T_f (transitions with t_k < T_f, i.e. the weights
   Ŵ_{T_f}, V̂_{T_f} reached at t = T_f) and ``freeze()`` is called on the copy.
3. **Re-evaluation**: the frozen copy evaluates the whole history t_k < T_f,
   ĝ^frz_k = Ŵ_{T_f} tanh(V̂_{T_f} x̄_k), with ``predict``. By default x̄_k is the network
   input the identifier itself used online (``Identifier.x_bar``: [x̂_k; u_k] for the observer
   laws, [x_k; u_k] for baseline 2), so frozen and online outputs differ only by the weights;
   ``frozen_inputs="state"`` uses the measured [x_k; u_k] instead.

The online run continues past each T_f (one run gives all freeze times). This equals separate
runs frozen at each T_f because the recorded plant does not depend on the identifier (no
feedback of ĝ into the controller in the thesis' cases); a test checks the equivalence.

Time indexing: ``t[k]`` is the start of transition k (s); ĝ_k is the output during transition
k (weights before the k-th update, see :mod:`simgap.identifiers`); ``x_tilde_norm[k]`` is
‖x_{k+1} − x̂_{k+1}‖ at time t[k] + Δt.

Metrics on the result are computed by :mod:`simgap.evaluation.metrics`.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from simgap.envs.rollout import Rollout
from simgap.evaluation.errors import EvaluationError

FrozenInputs = Literal["x_bar", "state"]


@dataclass(frozen=True)
class Transitions:
    """A recorded rollout in identifier coordinates: everything an identifier needs.

    Attributes:
        t: start time of each transition (s), shape (N,), strictly increasing.
        x: identifier state x_k (state units), (N, n).
        u: input u_k (input units), (N, m).
        f: nominal derivative f(x_k, u_k) (state units/s), (N, n).
        x_next: x_{k+1}, (N, n).
        target: the target residual g(x_k, u_k) (state units/s), (N, n), e.g. the env's
            ``info["residual_true"]``.
        dt: sampling period Δt (s).
        extra: per-step arrays kept for plots (e.g. joint velocities, slip angles), each (N, …).
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    f: np.ndarray
    x_next: np.ndarray
    target: np.ndarray
    dt: float
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n_rows = np.shape(self.t)[0] if np.ndim(self.t) == 1 else -1
        if n_rows < 1:
            raise EvaluationError(f"Transitions.t must be a non-empty 1-D time array (s), got "
                                  f"shape {np.shape(self.t)}")
        n = np.shape(self.x)[1] if np.ndim(self.x) == 2 else -1
        for name, arr, width in (("x", self.x, n), ("f", self.f, n), ("x_next", self.x_next, n),
                                 ("target", self.target, n), ("u", self.u, None)):
            shape = np.shape(arr)
            if len(shape) != 2 or shape[0] != n_rows or (width is not None and shape[1] != width):
                want = f"({n_rows}, {'m' if width is None else width})"
                raise EvaluationError(f"Transitions.{name} must have shape {want}, got {shape}")
            if not np.all(np.isfinite(arr)):
                raise EvaluationError(f"Transitions.{name} contains NaN or inf")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise EvaluationError(f"Transitions.dt must be a positive time in s, got {self.dt!r}")
        if n_rows > 1 and not np.all(np.diff(self.t) > 0):
            raise EvaluationError("Transitions.t must be strictly increasing (s)")

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_states(self) -> int:
        """Return n, the number of states."""
        return int(self.x.shape[1])

    @property
    def n_inputs(self) -> int:
        """Return m, the number of inputs."""
        return int(self.u.shape[1])

    def head(self, n_steps: int) -> Transitions:
        """Return the first ``n_steps`` transitions."""
        sl = slice(0, int(n_steps))
        return Transitions(t=self.t[sl], x=self.x[sl], u=self.u[sl], f=self.f[sl],
                           x_next=self.x_next[sl], target=self.target[sl], dt=self.dt,
                           extra={k: v[sl] for k, v in self.extra.items()})


def transitions_from_rollout(ro: Rollout, model: Any, *,
                             target_key: str = "residual_true",
                             action_low: np.ndarray | None = None,
                             action_high: np.ndarray | None = None) -> Transitions:
    """Convert a :class:`~simgap.envs.rollout.Rollout` into identifier :class:`Transitions`.

    Args:
        ro: the rollout (obs, action, next_obs and ``info[target_key]``).
        model: the env's nominal model (``state(obs)``, ``f(x, u)``, ``dt``; optional
            ``input(action)``), see :mod:`simgap.models.base`.
        target_key: info key of the true residual g(x_k, u_k) (state units/s).
        action_low: lower action bound; with ``action_high``, actions are clipped as the env
            does before they act (the rollout stores them unclipped).
        action_high: upper action bound.

    Returns:
        The transitions; ``extra`` holds the observations ``obs`` (N, obs_dim).

    Raises:
        EvaluationError: the rollout has no ``info[target_key]`` or is empty.
    """
    if len(ro) == 0:
        raise EvaluationError("the rollout is empty")
    if target_key not in ro.info:
        raise EvaluationError(f"the rollout has no info[{target_key!r}] (the target residual); "
                              f"keys: {sorted(ro.info)}")
    action = np.asarray(ro.action, dtype=np.float64)
    if action_low is not None and action_high is not None:
        action = np.clip(action, action_low, action_high)
    to_input = getattr(model, "input", None)
    u = np.array([to_input(a) for a in action]) if to_input is not None else action
    x = np.array([model.state(o) for o in ro.obs], dtype=np.float64)
    x_next = np.array([model.state(o) for o in ro.next_obs], dtype=np.float64)
    f = np.array([model.f(xk, uk) for xk, uk in zip(x, u, strict=True)], dtype=np.float64)
    return Transitions(t=np.asarray(ro.t, dtype=np.float64), x=x, u=np.asarray(u, np.float64),
                       f=f, x_next=x_next,
                       target=np.asarray(ro.info[target_key], dtype=np.float64),
                       dt=float(model.dt), extra={"obs": np.asarray(ro.obs, np.float64)})


@dataclass(frozen=True)
class FrozenModel:
    """The identifier frozen at one freeze time and its re-evaluation of the history.

    Attributes:
        t_freeze: freeze time T_f (s).
        n_history: number of transitions with t_k < T_f (the re-evaluated history).
        W: Ŵ_{T_f}, (n, n_h) (empty if the identifier exposes no ``W``).
        V: V̂_{T_f}, (n_h, p) (empty if it exposes no ``V``).
        g_frozen: ĝ^frz_k = Ŵ_{T_f} tanh(V̂_{T_f} x̄_k) for k < n_history, (n_history, n).
        identifier: the frozen copy (``predict`` evaluates it anywhere, e.g. on a grid).
    """

    t_freeze: float
    n_history: int
    W: np.ndarray
    V: np.ndarray
    g_frozen: np.ndarray
    identifier: Any = field(repr=False)


@dataclass(frozen=True)
class ReproducibilityResult:
    """Outcome of :func:`reproducibility_test` for one identifier on one rollout.

    Attributes:
        kind: identifier kind (``identifier.kind`` if present, else its class name).
        t: transition start times (s), (K,) for the K processed transitions.
        target: target residual g(x_k, u_k), (K, n).
        g_online: online ĝ_k, (K, n).
        x_bar: network inputs x̄_k used online, (K, p).
        x_bar_state: measured [x_k; u_k], (K, p).
        x_tilde_norm: ‖x̃‖ after each transition, (K,) (state units, mixed if units differ).
        frozen: one :class:`FrozenModel` per freeze time, ascending.
        frozen_inputs: ``"x_bar"`` or ``"state"`` (what the frozen model re-evaluated).
        step_seconds: wall time of the online loop (s).
    """

    kind: str
    t: np.ndarray
    target: np.ndarray
    g_online: np.ndarray
    x_bar: np.ndarray
    x_bar_state: np.ndarray
    x_tilde_norm: np.ndarray
    frozen: tuple[FrozenModel, ...]
    frozen_inputs: str
    step_seconds: float

    def frozen_at(self, t_freeze: float) -> FrozenModel:
        """Return the :class:`FrozenModel` of freeze time ``t_freeze`` (s)."""
        for fm in self.frozen:
            if abs(fm.t_freeze - t_freeze) < 1e-9:
                return fm
        raise EvaluationError(f"no freeze time {t_freeze} s in this result; have "
                              f"{[fm.t_freeze for fm in self.frozen]}")


def _check_freeze_times(freeze_times: Sequence[float], tr: Transitions) -> tuple[float, ...]:
    try:
        times = tuple(sorted(float(v) for v in freeze_times))
    except (TypeError, ValueError):
        raise EvaluationError(f"freeze_times must be numbers (s), got {freeze_times!r}") from None
    if not times:
        raise EvaluationError("freeze_times is empty: give at least one freeze time T_f (s)")
    t_first, t_end = float(tr.t[0]), float(tr.t[-1] + tr.dt)
    for tf in times:
        if not np.isfinite(tf) or tf <= t_first or tf > t_end + 1e-9:
            raise EvaluationError(f"freeze time {tf} s is outside the recording "
                                  f"({t_first} s, {t_end} s]")
    return times


def reproducibility_test(identifier: Any, transitions: Transitions,
                         freeze_times: Sequence[float], *, t_end: float | None = None,
                         frozen_inputs: FrozenInputs = "x_bar",
                         progress: Callable[[int, int], None] | None = None
                         ) -> ReproducibilityResult:
    """Run the reproducibility test (thesis Sec. 4.1) of ``identifier`` on ``transitions``.

    Args:
        identifier: a fresh (or pre-trained) identifier with ``step(x, u, f, x_next)``,
            ``x_bar``, ``x_tilde``, ``freeze()`` and ``predict(x_bar)`` (optionally ``W``,
            ``V``, ``kind``, ``n_states``, ``n_inputs``), e.g. from
            :func:`simgap.identifiers.make_identifier`. It is advanced in place.
        transitions: the recorded rollout (:func:`transitions_from_rollout`).
        freeze_times: freeze times T_f (s), within the recording.
        t_end: stop the online run at this time (s); default: the end of the recording
            (accuracy metrics then cover the whole run).
        frozen_inputs: ``"x_bar"`` (the online network inputs; default) or ``"state"``
            ([x_k; u_k] measured) for the re-evaluation.
        progress: callback ``progress(done, total)`` called every 1,000 transitions.

    Returns:
        The :class:`ReproducibilityResult`.

    Raises:
        EvaluationError: bad freeze times, sizes or options.
        simgap.identifiers.IdentifierDivergedError: the identifier diverged online.
    """
    import time

    if frozen_inputs not in ("x_bar", "state"):
        raise EvaluationError(f"frozen_inputs must be 'x_bar' or 'state', got {frozen_inputs!r}")
    times = _check_freeze_times(freeze_times, transitions)
    n_total = len(transitions)
    if t_end is not None:
        if not (np.isfinite(t_end) and t_end >= times[-1]):
            raise EvaluationError(f"t_end must be >= the last freeze time {times[-1]} s, "
                                  f"got {t_end!r}")
        n_total = int(np.searchsorted(transitions.t, float(t_end) - 1e-9, side="left"))
        n_total = max(n_total, 1)
    n_states, n_inputs = transitions.n_states, transitions.n_inputs
    for name, want in (("n_states", n_states), ("n_inputs", n_inputs)):
        have = getattr(identifier, name, want)
        if have != want:
            raise EvaluationError(f"identifier has {name}={have} but the transitions have "
                                  f"{want}")
    # index after which the copy is frozen: transitions with t_k < T_f
    freeze_idx = [int(np.searchsorted(transitions.t, tf - 1e-9, side="left")) for tf in times]
    p = n_states + n_inputs
    g_online = np.empty((n_total, n_states))
    x_bar = np.empty((n_total, p))
    xt_norm = np.empty(n_total)
    snapshots: dict[int, Any] = {}
    tr = transitions
    next_freeze = 0
    t0 = time.perf_counter()
    for k in range(n_total):
        while next_freeze < len(freeze_idx) and freeze_idx[next_freeze] == k:
            snapshots[next_freeze] = copy.deepcopy(identifier)
            next_freeze += 1
        g_online[k] = identifier.step(tr.x[k], tr.u[k], tr.f[k], tr.x_next[k])
        x_bar[k] = identifier.x_bar
        xt_norm[k] = float(np.linalg.norm(identifier.x_tilde))
        if progress is not None and (k % 1000 == 999 or k == n_total - 1):
            progress(k + 1, n_total)
    while next_freeze < len(freeze_idx):
        snapshots[next_freeze] = copy.deepcopy(identifier)
        next_freeze += 1
    elapsed = time.perf_counter() - t0
    x_bar_state = np.concatenate([tr.x[:n_total], tr.u[:n_total]], axis=1)
    inputs = x_bar if frozen_inputs == "x_bar" else x_bar_state
    frozen = []
    for i, tf in enumerate(times):
        snap = snapshots[i]
        snap.freeze()
        kf = freeze_idx[i]
        g_frz = snap.predict(inputs[:kf]) if kf > 0 else np.empty((0, n_states))
        w = np.asarray(getattr(snap, "W", np.empty((0, 0))), dtype=np.float64)
        v = np.asarray(getattr(snap, "V", np.empty((0, 0))), dtype=np.float64)
        frozen.append(FrozenModel(t_freeze=tf, n_history=kf, W=w, V=v,
                                  g_frozen=np.asarray(g_frz),
                                  identifier=snap))
    kind = str(getattr(identifier, "kind", type(identifier).__name__))
    return ReproducibilityResult(kind=kind, t=tr.t[:n_total].copy(),
                                 target=tr.target[:n_total].copy(), g_online=g_online,
                                 x_bar=x_bar, x_bar_state=x_bar_state, x_tilde_norm=xt_norm,
                                 frozen=tuple(frozen), frozen_inputs=frozen_inputs,
                                 step_seconds=elapsed)
