"""Closed-loop experiments with and without the learned residual (benchmarks and notebooks).

Every run follows one pattern: pre-train an identifier inside an
:class:`~simgap.wrappers.IdentifierWrapper` on an excitation run with the plain controller,
freeze it, then run a tracking task with the plain controller and with the residual-using one
(frozen network, or online: a fresh identifier learning during the tracking run). Metrics:

* manipulator: joint-position tracking RMSE (rad) over both joints;
* bicycle: yaw-rate tracking RMSE (rad/s) and the peak |r − r_ref| (rad/s).

All runs are seeded and deterministic (the envs, the identifiers and the MPC use seeded
``numpy.random.Generator`` streams).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from simgap.control.compensation import (
    CompensatedFeedbackLinearization,
    ResidualNetwork,
    YawRateController,
)
from simgap.control.mpc import MPCConfig, SamplingMPC
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.manipulator import ManipulatorFrictionEnv
from simgap.envs.rollout import Rollout, rollout
from simgap.envs.scenarios import (
    FeedbackLinearizationController,
    QuinticReference,
    RandomWaypointReference,
    YawRateReference,
    slalom,
)
from simgap.identifiers import Identifier
from simgap.models.bicycle import has_lag_states, true_residual_vs
from simgap.models.manipulator import true_residual as manipulator_true_residual
from simgap.wrappers import IdentifierWrapper

#: ``identifier`` value that compensates with the simulator's exact residual (upper bound).
TRUE_RESIDUAL = "true"


@dataclass(frozen=True, kw_only=True)
class BicycleTask:
    """Yaw-rate tracking near the tire limit on a low-μ road.

    Attributes:
        vx: speed (m/s).
        mu: road friction (-).
        amplitude: yaw-rate reference amplitude (rad/s); vx·amplitude is the peak lateral
            acceleration asked for (m/s²), compare μ·g.
        period: reference period (s).
        train_front: front amplitude of the pre-training slalom (rad, rear steering 0).
        train_frequency: its frequency (Hz).
    """

    vx: float = 20.0
    mu: float = 0.5
    amplitude: float = 0.22
    period: float = 4.0
    train_front: float = 0.05
    train_frequency: float = 0.3

    @property
    def reference(self) -> YawRateReference:
        """The yaw-rate reference r_ref(t) (rad/s)."""
        return YawRateReference(amplitude=self.amplitude, period=self.period)

    def make_env(self) -> BicycleTireEnv:
        """Build the bicycle env of this task (Magic Formula truth, linear nominal)."""
        return BicycleTireEnv(vx=self.vx, mu=self.mu, reference=self.reference)


class TrueResidual:
    """The env's exact g(x, u) in the controller's residual interface (simulation only).

    What a perfect identifier would give: the upper bound of any compensation. Manipulator:
    thesis eq. 2.3 coordinates; bicycle: valid without tire relaxation and steering lag (the
    plant state is then (vy, r) alone).
    """

    def __init__(self, env: ManipulatorFrictionEnv | BicycleTireEnv) -> None:
        base = env.unwrapped
        self._base = base
        if isinstance(base, ManipulatorFrictionEnv):
            self.n_states, self.n_inputs = 4, 2
            self._la = np.ascontiguousarray(base.nominal_params.array)
        elif isinstance(base, BicycleTireEnv):
            if has_lag_states(base.plant.array):
                raise ValueError("TrueResidual needs a bicycle without relaxation or lag")
            self.n_states, self.n_inputs = 2, 2
            self._th_nom = np.concatenate([base.nominal_params.array, [base.vx]])
        else:
            raise TypeError(f"TrueResidual needs a simgap env, got {base!r}")

    def _one(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        base = self._base
        if self.n_states == 4:
            s = base.nominal_model.observation(x)
            return manipulator_true_residual(s, u, base.plant.array, self._la)
        s = np.zeros(6)
        s[:2] = x
        return true_residual_vs(s, u, base.plant.array, self._th_nom)

    def __call__(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """G (state units/s) for x (n,) or (K, n) and u (m,) or (K, m)."""
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        if x.ndim == 1 and u.ndim == 1:
            return self._one(x, u)
        k = max(x.shape[0] if x.ndim == 2 else 1, u.shape[0] if u.ndim == 2 else 1)
        xs = np.broadcast_to(x, (k, self.n_states))
        us = np.broadcast_to(u, (k, self.n_inputs))
        return np.array([self._one(np.ascontiguousarray(a), np.ascontiguousarray(b))
                         for a, b in zip(xs, us, strict=True)])


def rmse(a: np.ndarray) -> float:
    """Root mean square of all entries of ``a``."""
    a = np.asarray(a, dtype=np.float64)
    return float(np.sqrt(np.mean(a * a))) if a.size else float("nan")


# --------------------------------------------------------------------------- manipulator
def manipulator_pretrain(kind: str, seconds: float, *, seed: int = 0) -> Identifier:
    """Train an identifier for ``seconds`` (s) on random-waypoint FL tracking, then freeze."""
    env = ManipulatorFrictionEnv(reference=RandomWaypointReference(seed=seed))
    wrapped = IdentifierWrapper(env, kind, seed=seed)
    ctrl = FeedbackLinearizationController(env.nominal_model, env.reference)
    rollout(wrapped, ctrl, int(round(seconds / env.dt)), seed=seed)
    wrapped.identifier.freeze()
    return wrapped.identifier


def _compensating(env: Any, identifier: Identifier | str, online: bool, seed: int
                  ) -> tuple[IdentifierWrapper, ResidualNetwork]:
    """Wrap ``env`` with ``identifier`` and the residual network a controller compensates with.

    A kind name gives a fresh identifier that learns; an :class:`Identifier` learns only if
    ``online``, else it stays frozen.
    """
    wrapped = IdentifierWrapper(env, identifier, seed=seed, reset_identifier_on_seed=False)
    live = isinstance(identifier, str) or online
    if live:
        wrapped.unfreeze()
    else:
        wrapped.freeze()
    return wrapped, ResidualNetwork(wrapped.identifier, online=live)


def manipulator_tracking(identifier: Identifier | str | None, seconds: float, *,
                         online: bool = False, seed: int = 0,
                         reference: Any = None) -> Rollout:
    """FL tracking of the quintic reference for ``seconds`` (s), compensated if asked.

    Args:
        identifier: a trained identifier (frozen compensation), a kind name (online: a fresh
            identifier of that kind learns while it compensates), :data:`TRUE_RESIDUAL`
            (the exact residual, upper bound) or ``None`` (plain FL).
        seconds: run length (s).
        online: with an :class:`Identifier`, keep it learning during the run.
        seed: env reset seed.
        reference: joint reference (default :class:`QuinticReference`).
    """
    env = ManipulatorFrictionEnv(reference=reference or QuinticReference())
    base = FeedbackLinearizationController(env.nominal_model, env.reference)
    n = int(round(seconds / env.dt))
    if identifier is None:
        return rollout(env, base, n, seed=seed)
    if identifier == TRUE_RESIDUAL:
        return rollout(env, CompensatedFeedbackLinearization(base, TrueResidual(env)), n,
                       seed=seed)
    wrapped, residual = _compensating(env, identifier, online, seed)
    return rollout(wrapped, CompensatedFeedbackLinearization(base, residual), n, seed=seed)


def manipulator_rmse(ro: Rollout) -> float:
    """Joint-position tracking RMSE (rad) of a manipulator rollout."""
    return rmse(ro.next_obs[:, :2] - ro.info["reference"][:, :2])


# --------------------------------------------------------------------------- bicycle
def bicycle_pretrain(kind: str, task: BicycleTask, seconds: float, *, seed: int = 0
                     ) -> Identifier:
    """Train an identifier on a front-steer slalom of the task's road, then freeze it."""
    env = task.make_env()
    wrapped = IdentifierWrapper(env, kind, seed=seed)
    prog = slalom(front=task.train_front, rear=0.0, frequency=task.train_frequency,
                  duration=seconds)
    rollout(wrapped, prog.act, int(round(seconds / env.dt)), seed=seed)
    wrapped.identifier.freeze()
    return wrapped.identifier


def bicycle_tracking(policy_kind: str, task: BicycleTask, seconds: float, *,
                     identifier: Identifier | str | None = None, online: bool = False,
                     mpc_config: MPCConfig | None = None, seed: int = 0
                     ) -> tuple[Rollout, np.ndarray]:
    """Yaw-rate tracking with ``"inversion"`` (:class:`YawRateController`) or ``"mpc"``.

    Args:
        policy_kind: ``"inversion"`` or ``"mpc"``.
        task: the road and reference.
        seconds: run length (s).
        identifier: trained identifier (frozen residual), kind name (online, fresh),
            :data:`TRUE_RESIDUAL` (the exact residual; for ``"mpc"``: the exact plant as
            prediction model), or ``None`` (nominal model alone).
        online: with an :class:`Identifier`, keep it learning during the run.
        mpc_config: MPC settings (``"mpc"`` only).
        seed: env reset seed and MPC seed.

    Returns:
        The rollout and the wall-clock compute time of each control call (s), shape (N,).
    """
    env = task.make_env()
    model = env.nominal_model
    n = int(round(seconds / env.dt))
    residual: Any = None
    run_env: Any = env
    exact = None
    if identifier == TRUE_RESIDUAL:
        if policy_kind == "mpc":
            exact = env.plant
        else:
            residual = TrueResidual(env)
    elif identifier is not None:
        run_env, residual = _compensating(env, identifier, online, seed)
    if policy_kind == "inversion":
        ctrl: Any = YawRateController(model, task.reference, residual)
    elif policy_kind == "mpc":
        ctrl = SamplingMPC(model, task.reference, residual, config=mpc_config, seed=seed,
                           exact_plant=exact)
    else:
        raise ValueError(f"policy_kind must be 'inversion' or 'mpc', got {policy_kind!r}")
    times: list[float] = []

    def timed(obs: np.ndarray, t: float) -> np.ndarray:
        t0 = time.perf_counter()
        u = ctrl(obs, t)
        times.append(time.perf_counter() - t0)
        return u

    ro = rollout(run_env, timed, n, seed=seed)
    return ro, np.asarray(times)


def yaw_error(ro: Rollout) -> np.ndarray:
    """R − r_ref after each step (rad/s)."""
    return ro.next_obs[:, 1] - ro.info["r_ref"]


# --------------------------------------------------------------------------- studies
def compensation_study(*, kinds: tuple[str, ...] = ("instantaneous", "integral", "minibatch"),
                       train_seconds: float = 60.0, eval_seconds: float = 8.0,
                       task: BicycleTask | None = None, seed: int = 0) -> dict[str, Any]:
    """Tracking RMSE with and without compensation, per identifier, on both envs.

    Manipulator: FL on the quintic reference (joint RMSE, rad) plain, with the exact
    residual, and per identifier with its frozen network (pre-trained ``train_seconds`` on
    random waypoints) and online (fresh identifier learning during the run). Bicycle: the
    nominal-inverting yaw-rate controller (RMSE of r − r_ref, rad/s) likewise, pre-trained on a
    front-steer slalom of the task's road.
    """
    task = task or BicycleTask()
    out: dict[str, Any] = {"train_seconds": train_seconds, "eval_seconds": eval_seconds,
                           "seed": seed, "bicycle_task": task.__dict__}
    man: dict[str, Any] = {
        "plain": manipulator_rmse(manipulator_tracking(None, eval_seconds, seed=seed)),
        "true_residual": manipulator_rmse(
            manipulator_tracking(TRUE_RESIDUAL, eval_seconds, seed=seed))}
    bic: dict[str, Any] = {}
    ro, _ = bicycle_tracking("inversion", task, eval_seconds, seed=seed)
    bic["plain"] = _yaw_metrics(ro)
    ro, _ = bicycle_tracking("inversion", task, eval_seconds, identifier=TRUE_RESIDUAL,
                             seed=seed)
    bic["true_residual"] = _yaw_metrics(ro)
    for kind in kinds:
        ident = manipulator_pretrain(kind, train_seconds, seed=seed)
        ro = manipulator_tracking(ident, eval_seconds, seed=seed)
        man[kind] = {"frozen": manipulator_rmse(ro),
                     "residual_error_rms": rmse(ro.info["residual_estimate"][:, 2:]
                                                - ro.info["residual_true"][:, 2:]),
                     "online": manipulator_rmse(manipulator_tracking(kind, eval_seconds,
                                                                     seed=seed))}
        ident = bicycle_pretrain(kind, task, train_seconds, seed=seed)
        ro, _ = bicycle_tracking("inversion", task, eval_seconds, identifier=ident, seed=seed)
        ro_on, _ = bicycle_tracking("inversion", task, eval_seconds, identifier=kind,
                                    seed=seed)
        bic[kind] = {"frozen": _yaw_metrics(ro), "online": _yaw_metrics(ro_on),
                     "residual_error_rms": rmse(ro.info["residual_estimate"]
                                                - ro.info["residual_true"])}
    man["residual_true_rms"] = rmse(
        manipulator_tracking(None, eval_seconds, seed=seed).info["residual_true"][:, 2:])
    out["manipulator_rmse_rad"] = man
    out["bicycle"] = bic
    return out


def _yaw_metrics(ro: Rollout) -> dict[str, float]:
    e = yaw_error(ro)
    return {"rmse_rad_s": rmse(e), "max_abs_rad_s": float(np.max(np.abs(e))),
            "steps": len(ro)}


def mpc_study(*, kinds: tuple[str, ...] = ("instantaneous", "integral", "minibatch"),
              train_seconds: float = 60.0, eval_seconds: float = 8.0,
              task: BicycleTask | None = None, config: MPCConfig | None = None,
              seed: int = 0) -> dict[str, Any]:
    """Compare sampling MPC on the nominal model with nominal + each frozen network.

    Also runs the MPC with the exact plant as its prediction model (simulation-only bound).

    Returns per variant the yaw-rate RMSE and peak error (rad/s), the compute time per
    control step (s: mean, p50, p99, max) and the traces (t, r, r_ref, δ_f) for figures.
    """
    task = task or BicycleTask()
    cfg = config or MPCConfig()
    out: dict[str, Any] = {"train_seconds": train_seconds, "eval_seconds": eval_seconds,
                           "seed": seed, "task": task.__dict__, "mpc": cfg.__dict__,
                           "variants": {}}
    runs: list[tuple[str, Identifier | str | None]] = [("nominal", None),
                                                       ("exact plant (bound)", TRUE_RESIDUAL)]
    runs += [(f"nominal+{k}", bicycle_pretrain(k, task, train_seconds, seed=seed))
             for k in kinds]
    for name, ident in runs:
        ro, times = bicycle_tracking("mpc", task, eval_seconds, identifier=ident,
                                     mpc_config=cfg, seed=seed)
        timed = times[1:] if times.size > 1 else times  # drop the first call (JIT warm-up)
        out["variants"][name] = {
            **_yaw_metrics(ro),
            "compute_s": {"mean": float(timed.mean()), "p50": float(np.median(timed)),
                          "p99": float(np.quantile(timed, 0.99)), "max": float(timed.max())},
            "trace": {"t": (ro.t + task.make_env().dt).tolist(),
                      "r": ro.next_obs[:, 1].tolist(), "r_ref": ro.info["r_ref"].tolist(),
                      "delta_f": ro.action[:, 0].tolist()}}
    return out
