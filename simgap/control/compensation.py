"""Feed-forward compensation of the learned residual ĝ on scripted controllers.

Manipulator (identifier state x = (q, p), thesis eq. 2.3): the plant is
dp/dt = Cᵀ dq − G + u + g_p, so the torque u = u_FL − ĝ_p(x, u) cancels the residual that the
feedback-linearisation controller (thesis eq. 4.8-4.9) leaves in the loop. ĝ depends on u
(the network input is x̄ = [x; u]); the algebraic loop is solved by ``n_iter`` fixed-point
passes starting from u_FL (friction does not depend on u, so one pass is exact for it).

Bicycle (x = (vy, r)): front-steer yaw-rate tracking by inverting the nominal model's yaw
equation, dr/dt = A₂ x + B₂ u (+ ĝ_r(x, u)) = a_des with a_des = ṙ_ref + k (r_ref − r). With
the residual the equation is nonlinear in δ_f (the saturating tire is in ĝ); it is solved on a
grid of candidate angles (one vectorised network call) refined by linear interpolation, and when
a_des is out of the tire's reach the angle that gets closest is used.

Both controllers read a :class:`ResidualNetwork` view of an identifier: ``online`` reads the
identifier's current weights at every call (it keeps learning inside an
:class:`~simgap.wrappers.IdentifierWrapper`), ``frozen`` copies the weights once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from simgap.envs.scenarios import FeedbackLinearizationController
from simgap.identifiers import Identifier, network_forward
from simgap.models.bicycle import BicycleNominal


class ResidualNetwork:
    """ĝ(x, u) from an identifier's network, either live (online) or a frozen copy.

    Args:
        identifier: the identifier whose network ĝ = Ŵ tanh(V̂ [x; u]) is used.
        online: ``True`` reads the identifier's current weights at every call (use it while
            the identifier learns); ``False`` copies Ŵ, V̂ now and never changes.
    """

    def __init__(self, identifier: Identifier, *, online: bool = False) -> None:
        if not isinstance(identifier, Identifier):
            raise TypeError(f"identifier must be a simgap Identifier, got {identifier!r}")
        self.identifier = identifier
        self.online = bool(online)
        self.n_states = identifier.n_states
        self.n_inputs = identifier.n_inputs
        self._W = identifier.W
        self._V = identifier.V

    @property
    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """(Ŵ (n, n_h), V̂ (n_h, n + m)) used now."""
        if self.online:
            return self.identifier.W, self.identifier.V
        return self._W, self._V

    def __call__(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """ĝ (state units/s) for x (n,) or (K, n) and u (m,) or (K, m) (broadcast)."""
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        lead = np.broadcast_shapes(x.shape[:-1], u.shape[:-1])
        if len(lead) > 1:
            raise ValueError(f"x and u must be 1-D or 2-D, got {x.shape} and {u.shape}")
        x_bar = np.concatenate([np.broadcast_to(x, lead + x.shape[-1:]),
                                np.broadcast_to(u, lead + u.shape[-1:])], axis=-1)
        if self.online:
            return self.identifier.predict(x_bar)
        return network_forward(self._W, self._V, x_bar)


class CompensatedFeedbackLinearization:
    """Manipulator FL controller with the residual fed forward: u = u_FL − ĝ_p(x, u).

    Args:
        controller: the plain :class:`~simgap.envs.scenarios.FeedbackLinearizationController`
            (nominal model, reference and gains).
        residual: ĝ source; ``None`` gives the plain controller (for A/B comparisons).
        n_iter: fixed-point passes of the algebraic loop u ↔ ĝ(x, u), ≥ 1.
    """

    def __init__(self, controller: FeedbackLinearizationController,
                 residual: ResidualNetwork | None = None, *, n_iter: int = 1) -> None:
        if not isinstance(controller, FeedbackLinearizationController):
            raise TypeError(f"controller must be a FeedbackLinearizationController, got "
                            f"{controller!r}")
        if residual is not None and residual.n_states != 4:
            raise ValueError(f"the manipulator residual has 4 states, got {residual.n_states}")
        if int(n_iter) < 1:
            raise ValueError(f"n_iter must be >= 1, got {n_iter!r}")
        self.controller = controller
        self.model = controller.model
        self.residual = residual
        self.n_iter = int(n_iter)

    def __call__(self, obs: np.ndarray, t: float) -> np.ndarray:
        """Joint torques (N·m), shape (2,), for observation (q, dq) (rad, rad/s) at t (s)."""
        u_fl = self.controller(obs, t)
        if self.residual is None:
            return u_fl
        x = self.model.state(obs)
        u = u_fl
        for _ in range(self.n_iter):
            u = u_fl - self.residual(x, u)[2:]
        return u


class YawRateController:
    """Front-steer yaw-rate tracking by nominal-model inversion, optionally with ĝ.

    Chooses δ_f (rad, rear angle 0) so that the model's yaw acceleration equals
    a_des = ṙ_ref(t) + gain·(r_ref(t) − r) (rad/s²).

    Args:
        model: nominal bicycle (A, B at the env's speed).
        reference: callable t (s) → r_ref (rad/s).
        residual: ĝ source; ``None`` inverts the nominal model alone (closed form).
        gain: yaw-rate error gain (1/s), > 0.
        steer_limit: |δ_f| bound (rad), > 0.
        n_grid: candidate angles of the residual inversion (≥ 3).
    """

    def __init__(self, model: BicycleNominal, reference: Callable[[float], float],
                 residual: ResidualNetwork | None = None, *, gain: float = 10.0,
                 steer_limit: float = 0.5, n_grid: int = 401) -> None:
        if not isinstance(model, BicycleNominal):
            raise TypeError(f"model must be a BicycleNominal, got {model!r}")
        if not callable(reference):
            raise TypeError(f"reference must be a callable t -> r_ref (rad/s), got "
                            f"{reference!r}")
        if not (np.isfinite(gain) and gain > 0):
            raise ValueError(f"gain must be a positive rate in 1/s, got {gain!r}")
        if not (np.isfinite(steer_limit) and steer_limit > 0):
            raise ValueError(f"steer_limit must be a positive angle in rad, got {steer_limit!r}")
        if int(n_grid) < 3:
            raise ValueError(f"n_grid must be >= 3, got {n_grid!r}")
        if residual is not None and (residual.n_states, residual.n_inputs) != (2, 2):
            raise ValueError("the bicycle residual must have 2 states and 2 inputs")
        self.model = model
        self.reference = reference
        self.residual = residual
        self.gain = float(gain)
        self.steer_limit = float(steer_limit)
        self._grid = np.linspace(-self.steer_limit, self.steer_limit, int(n_grid))
        self._u_grid = np.stack([self._grid, np.zeros_like(self._grid)], axis=1)

    def desired_yaw_acceleration(self, r: float, t: float) -> float:
        """a_des = ṙ_ref + gain·(r_ref − r) (rad/s²); ṙ_ref by a 1 ms central difference."""
        h = 1e-3
        r_ref = float(self.reference(t))
        dr_ref = (float(self.reference(t + h)) - float(self.reference(t - h))) / (2 * h)
        return dr_ref + self.gain * (r_ref - float(r))

    def __call__(self, obs: np.ndarray, t: float) -> np.ndarray:
        """Steering (δ_f, δ_r = 0) in rad for observation (vy, r) (m/s, rad/s) at t (s)."""
        x = np.asarray(obs, dtype=np.float64)
        a_des = self.desired_yaw_acceleration(x[1], t)
        a_row, b_f = self.model.A[1], self.model.B[1, 0]
        free = float(a_row @ x)
        if self.residual is None:
            delta = (a_des - free) / b_f
            return np.array([float(np.clip(delta, -self.steer_limit, self.steer_limit)), 0.0])
        g = self.residual(np.broadcast_to(x, self._u_grid.shape), self._u_grid)
        h = free + b_f * self._grid + g[:, 1] - a_des
        return np.array([_root_or_closest(self._grid, h), 0.0])


def _root_or_closest(grid: np.ndarray, h: np.ndarray) -> float:
    """Zero of h(grid) nearest the grid's centre by linear interpolation, else argmin |h|."""
    sign_change = np.nonzero(np.signbit(h[:-1]) != np.signbit(h[1:]))[0]
    if sign_change.size == 0:
        return float(grid[int(np.argmin(np.abs(h)))])
    mid = 0.5 * (grid.size - 1)
    i = int(sign_change[np.argmin(np.abs(sign_change - mid))])
    h0, h1 = h[i], h[i + 1]
    w = h0 / (h0 - h1) if h0 != h1 else 0.0
    return float(grid[i] + w * (grid[i + 1] - grid[i]))
