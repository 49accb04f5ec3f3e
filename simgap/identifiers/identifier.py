"""One identifier (N = 1): :class:`Identifier`, :func:`make_identifier`, :func:`load_identifier`.

See the package docstring (:mod:`simgap.identifiers`) for the API and the exact time indexing
of :meth:`Identifier.step`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from simgap.identifiers import fastcall, io
from simgap.identifiers.config import IdentifierConfig
from simgap.identifiers.core import IdentifierBase
from simgap.identifiers.errors import IdentifierError
from simgap.identifiers.kernels import HP_NSTEPS, HP_NUPDATES, ready

_empty = np.empty


class Identifier(IdentifierBase):
    """One online identifier of the residual g(x, u) (thesis Ch. 3, Sec. 4.2).

    Build it with :func:`make_identifier`. Arrays returned by ``step`` and by the
    attributes are fresh copies.

    Attributes:
        kind: ``"instantaneous"``, ``"integral"`` or ``"minibatch"``.
        n_states: n; n_inputs: m; n_in: p = n + m; n_hidden: n_h.
        dt: sampling period Δt (s).
        config: the :class:`~simgap.identifiers.IdentifierConfig`.
        seed: seed of the initial weights (and of baseline 2's sampling Generator).
    """

    _DERIVED = (*IdentifierBase._DERIVED, "_g_view", "_xb_view", "_xh_view", "_xt_view",
                "_e_view", "_hot", "_step_kernel", "step")

    def __init__(self, kind: str, n_states: int, n_inputs: int, dt: float, *,
                 config: IdentifierConfig | None = None, seed: int = 0) -> None:
        super().__init__(kind, n_states, n_inputs, dt, config=config, seed=seed, n_envs=1)

    def _bind(self) -> None:
        super()._bind()
        self._g_view = self._field("g")[0]
        self._xb_view = self._field("x_bar")[0]
        self._xh_view = self._field("x_hat")[0]
        self._xt_view = self._field("x_tilde")[0]
        self._e_view = self._field("e")[0]
        # the hot path of the observer laws (compiled on first use, then from numba's cache):
        # the C caller if it is built (fastcall), else numba's dispatcher. The C caller falls
        # back on the general path itself, so it stands in for the method ``step`` (an
        # instance attribute: no Python frame per call; same results, tested)
        self.__dict__.pop("step", None)
        self._hot = (None if self._minibatch
                     else fastcall.observer_stepper(self._state, self.n_states, self._general))
        self._step_kernel = (None if self._minibatch or self._hot is not None
                             else ready("observer_step_single"))
        if self._hot is not None:
            self.step = self._hot

    def step(self, x: np.ndarray, u: np.ndarray, f: np.ndarray, x_next: np.ndarray
             ) -> np.ndarray:
        """Process one transition x_k --u_k--> x_{k+1} and return ĝ_k.

        Args:
            x: x_k, shape (n,), state units.
            u: u_k, shape (m,), input units.
            f: f(x_k, u_k), shape (n,), state units per second (the nominal derivative).
            x_next: x_{k+1}, shape (n,).

        Returns:
            ĝ_k (n,), state units per second, evaluated with the weights before this step's
            update (see the package docstring for what every attribute holds afterwards).

        Raises:
            IdentifierError: wrong sizes or non-finite inputs (identifier unchanged).
            IdentifierDivergedError: the update would make x̂ non-finite or a weight norm
                exceed ``config.max_weight_norm`` (identifier unchanged).
        """
        hot = self._hot
        if hot is not None:  # the C caller (also the instance's ``step``, see _bind)
            return hot(x, u, f, x_next)
        if not self._minibatch:  # numba's dispatcher
            g = _empty(self.n_states)
            try:
                if not self._step_kernel(self._state, x, u, f, x_next, g):
                    return g
            except TypeError:  # not float64 C-contiguous 1-D: the general path converts
                pass
        return self._general(x, u, f, x_next)

    def _general(self, x: np.ndarray, u: np.ndarray, f: np.ndarray, x_next: np.ndarray
                 ) -> np.ndarray:
        """The general path of :meth:`step` (converts the inputs, or raises the typed error)."""
        self._run(x, u, f, x_next)  # converts and retries, or raises the typed error
        return self._g_view.copy()

    @property
    def n_steps(self) -> int:
        """Transitions passed to :meth:`step` (successfully) since construction / reset."""
        return int(self._state[0, HP_NSTEPS])

    @property
    def n_updates(self) -> int:
        """Weight updates made: learning steps, or kept SGD steps for baseline 2."""
        return int(self._state[0, HP_NUPDATES])

    def predict(self, x_bar: np.ndarray) -> np.ndarray:
        """ĝ = Ŵ tanh(V̂ x̄) with the current weights; no state change.

        Args:
            x_bar: [x; u], shape (p,) or (K, p).

        Returns:
            ĝ of shape (n,) or (K, n), bit-identical to what :meth:`step` computes for the
            same x̄ and weights.
        """
        return self._predict_row(0, x_bar)

    def reset_observer(self, x0: np.ndarray | None = None) -> None:
        """Re-initialise the observer: x̂ = x0 and z = 0 (weights and buffer kept).

        Args:
            x0: new x̂ (n,); ``None`` means "x̂ = the x of the next step".
        """
        n = self.n_states
        if x0 is not None:
            x0 = np.asarray(x0, dtype=np.float64).reshape(-1)
            if x0.size != n or not np.all(np.isfinite(x0)):
                raise IdentifierError(f"reset_observer: x0 must be {n} finite values, "
                                      f"got {x0!r}")
        self._set_observer(slice(0, 1), x0)

    # attributes ------------------------------------------------------------------
    @property
    def W(self) -> np.ndarray:  # noqa: N802
        """Ŵ, shape (n, n_h)."""
        return self._W()[0].copy()

    @property
    def V(self) -> np.ndarray:  # noqa: N802
        """V̂, shape (n_h, p)."""
        return self._V()[0].copy()

    @property
    def g_hat(self) -> np.ndarray:
        """ĝ_k of the last step (n,), state units/s."""
        return self._g_view.copy()

    @property
    def x_bar(self) -> np.ndarray:
        """Network input of the last step (p,): [x̂_k; u_k] or [x_k; u_k].

        [x̂_k; u_k] for the observer laws and baseline 2 on x̂ (``minibatch_input``).
        """
        return self._xb_view.copy()

    @property
    def x_hat(self) -> np.ndarray:
        """x̂_{k+1} after the last step (n,); for baseline 2 the one-step prediction."""
        return self._xh_view.copy()

    @property
    def x_tilde(self) -> np.ndarray:
        """x_{k+1} − x̂_{k+1} after the last step (n,)."""
        return self._xt_view.copy()

    @property
    def observer_gain(self) -> float:
        """a_d (1/s) the observer uses at the next step.

        ``config.a_d``, or with the integral law's noise gate (``config.a_d_clean`` ≠ 0)
        a_d + ρ⁺ (a_d_clean − a_d) at the measured smooth share ρ⁺ of x̃: the gain that
        sets the quasi-static error x̃ ≈ (g − ĝ)/|a_d| (eq. 3.5).
        """
        return float(self._observer_gains()[0])

    @property
    def e(self) -> np.ndarray:
        """Error signal that drove the last update: x̃_k, z_k, or the prediction error."""
        return self._e_view.copy()

    @property
    def z(self) -> np.ndarray:
        """Integral error state z_{k+1} (n,); zero for the other kinds."""
        return self._z()[0].copy()

    @property
    def observer_initialised(self) -> bool:
        """False until the first step (or after ``reset_observer()`` without x0)."""
        return bool(self._initialised()[0])

    # persistence ------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Write the identifier to ``path`` (.npz + JSON meta, no pickle); returns the path.

        An existing file is replaced only with ``overwrite=True`` (atomically); otherwise
        :class:`~simgap.errors.OutputError` names it and nothing is written.
        """
        return io.write_npz(path, self._meta(), self._arrays(), overwrite=overwrite)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Identifier:
        """Read an identifier written by :meth:`save`; continues bit-identically."""
        return load_identifier(path)

    def __repr__(self) -> str:
        return (f"Identifier(kind={self.kind!r}, n_states={self.n_states}, "
                f"n_inputs={self.n_inputs}, dt={self.dt}, seed={self.seed}, "
                f"frozen={self._frozen}, n_steps={self.n_steps})")


def make_identifier(kind: str, n_states: int, n_inputs: int, dt: float, *,
                    config: IdentifierConfig | None = None, seed: int = 0) -> Identifier:
    """Build one identifier.

    Args:
        kind: ``"instantaneous"`` (eq. 3.8), ``"integral"`` (eq. 3.9, proposed) or
            ``"minibatch"`` (eq. 4.2-4.4).
        n_states: n, entries of the identifier state x.
        n_inputs: m, entries of the input u.
        dt: sampling period Δt (s).
        config: hyper-parameters; ``None`` = ``preset("manipulator", kind)`` (Table 4.3).
        seed: seed of the initial weights; equal seeds give equal weights for every kind.

    Returns:
        The :class:`Identifier`.
    """
    return Identifier(kind, n_states, n_inputs, dt, config=config, seed=seed)


def load_identifier(path: str | os.PathLike[str]) -> Identifier:
    """Read an :class:`Identifier` written by :meth:`Identifier.save`."""
    meta, arrays = io.read_npz(path)
    try:
        config = IdentifierConfig.from_dict(meta["config"])
        if int(meta.get("n_envs", 1)) != 1:
            raise IdentifierError("file holds a BatchIdentifier; use BatchIdentifier.load")
        ident = Identifier(meta["kind"], meta["n_states"], meta["n_inputs"], meta["dt"],
                           config=config, seed=meta["seed"])
        ident._load_arrays(meta, arrays, str(path))
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
        raise io.load_guard(path, exc) from None
    return ident

