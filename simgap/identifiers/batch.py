"""N identifiers of one kind advanced together (vector envs): :class:`BatchIdentifier`.

Every row starts from the same initial weights (the same seed), then learns from its own
transitions; one numba kernel call advances all rows (the same kernel as for N = 1).
Baseline 2's mini-batch indices of all due rows come from one seeded Generator, drawn in
row order, so a batch run is reproducible but not row-for-row equal to N separate runs.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from simgap.identifiers import io
from simgap.identifiers import kernels as K
from simgap.identifiers.config import IdentifierConfig
from simgap.identifiers.core import IdentifierBase
from simgap.identifiers.errors import IdentifierError


class BatchIdentifier(IdentifierBase):
    """N identifiers in (N, …) arrays; attributes have a leading axis N.

    Args:
        kind: ``"instantaneous" | "integral" | "minibatch"``.
        n_envs: N.
        n_states, n_inputs, dt, config, seed: as for :func:`~simgap.identifiers.make_identifier`.
        threads: split the rows of the observer laws over numba's threads (bit-identical
            results). ``None``: from ``PARALLEL_MIN_ROWS`` = 256 rows up. numba's threads use
            GNU OpenMP here, and a process that forks after using them has its children
            killed ("fork() called from a process already using GNU OpenMP"): pass
            ``threads=False`` if this process will fork workers later (e.g. a
            ``gym.vector.AsyncVectorEnv`` created after stepping the batch), or start them
            with ``"spawn"`` / ``"forkserver"``.
    """

    def __init__(self, kind: str, n_envs: int, n_states: int, n_inputs: int, dt: float, *,
                 config: IdentifierConfig | None = None, seed: int = 0,
                 threads: bool | None = None) -> None:
        super().__init__(kind, n_states, n_inputs, dt, config=config, seed=seed, n_envs=n_envs)
        if threads is not None and not isinstance(threads, bool):
            raise IdentifierError(f"threads must be True, False or None, got {threads!r}")
        if threads is not None and not self._minibatch:
            self._kernel_name = "observer_step_parallel" if threads else "observer_step"

    def step(self, x: np.ndarray, u: np.ndarray, f: np.ndarray, x_next: np.ndarray,
             learn: np.ndarray | None = None) -> np.ndarray:
        """Advance every row by one transition (see :meth:`Identifier.step`).

        Args:
            x: x_k, shape (N, n).
            u: u_k, shape (N, m).
            f: f(x_k, u_k), shape (N, n).
            x_next: x_{k+1}, shape (N, n).
            learn: boolean (N,); rows with False are not transitions (e.g. the step after an
                autoreset) and change nothing. ``None`` = all rows.

        Returns:
            ĝ_k, shape (N, n) (rows with ``learn`` False hold their previous values).
        """
        on = K.FROZEN if self._frozen else K.LEARN
        if learn is None:
            if self._masked:
                self._act[:] = on
                self._masked = False
        else:
            lm = np.asarray(learn, dtype=bool).reshape(-1)
            if lm.size != self.n_envs:
                raise IdentifierError(f"learn mask needs {self.n_envs} entries, got {lm.size}")
            np.copyto(self._act, np.where(lm, on, K.SKIP))
            self._masked = True
        self._run(self._flat(x), self._flat(u), self._flat(f), self._flat(x_next))
        self._py_steps += 1
        if not self._frozen and not self._minibatch:
            self._py_updates += 1
        return self._field("g").copy()

    @staticmethod
    def _flat(a: np.ndarray) -> np.ndarray:
        if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous:
            return a.reshape(-1)
        return np.ascontiguousarray(a, dtype=np.float64).reshape(-1)

    def predict(self, x_bar: np.ndarray, index: int | None = None) -> np.ndarray:
        """ĝ with the current weights.

        Args:
            x_bar: with ``index``: (p,) or (K, p) evaluated by row ``index``'s network;
                without: (N, p), row i by network i.
            index: which identifier, or None.

        Returns:
            ĝ, shape (n,) / (K, n) with ``index``, else (N, n).
        """
        if index is not None:
            if not 0 <= int(index) < self.n_envs:
                raise IdentifierError(f"index {index} out of range for {self.n_envs} rows")
            return self._predict_row(int(index), x_bar)
        xb = np.asarray(x_bar, dtype=np.float64)
        if xb.shape != (self.n_envs, self.n_in):
            raise IdentifierError(f"x_bar must have shape ({self.n_envs}, {self.n_in}) without "
                                  f"index, got {xb.shape}")
        return np.stack([self._predict_row(i, xb[i]) for i in range(self.n_envs)])

    def reset_observer(self, rows: np.ndarray | None = None, x0: np.ndarray | None = None
                       ) -> None:
        """Re-initialise the observers of some rows; weights are kept.

        Args:
            rows: boolean mask or indices; None = all rows.
            x0: (N, n); x̂[rows] = x0[rows] and z = 0. None: x̂ = the x of the next step.
        """
        sel = np.arange(self.n_envs) if rows is None else np.asarray(rows)
        if sel.dtype == bool:
            sel = np.flatnonzero(sel)
        n = self.n_states
        if x0 is None:
            self._set_observer(sel, None)
            return
        x0a = np.asarray(x0, dtype=np.float64)
        if x0a.shape != (self.n_envs, n) or not np.all(np.isfinite(x0a[sel])):
            raise IdentifierError(f"reset_observer: x0 must be finite with shape "
                                  f"({self.n_envs}, {n}), got {x0a.shape}")
        self._set_observer(sel, x0a[sel])

    @property
    def W(self) -> np.ndarray:  # noqa: N802
        """Ŵ, shape (N, n, n_h)."""
        return self._W().copy()

    @property
    def V(self) -> np.ndarray:  # noqa: N802
        """V̂, shape (N, n_h, p)."""
        return self._V().copy()

    @property
    def g_hat(self) -> np.ndarray:
        """ĝ_k of the last step, (N, n)."""
        return self._field("g").copy()

    @property
    def x_bar(self) -> np.ndarray:
        """Network inputs of the last step, (N, p)."""
        return self._field("x_bar").copy()

    @property
    def x_hat(self) -> np.ndarray:
        """x̂_{k+1}, (N, n)."""
        return self._field("x_hat").copy()

    @property
    def x_tilde(self) -> np.ndarray:
        """x_{k+1} − x̂_{k+1}, (N, n)."""
        return self._field("x_tilde").copy()

    @property
    def observer_gain(self) -> np.ndarray:
        """a_d (1/s) each row's observer uses at the next step, (N,).

        See ``Identifier.observer_gain``.
        """
        return self._observer_gains()

    @property
    def e(self) -> np.ndarray:
        """Error signals of the last step, (N, n)."""
        return self._field("e").copy()

    @property
    def z(self) -> np.ndarray:
        """Integral error states, (N, n)."""
        return self._z().copy()

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Write to ``path`` (.npz + JSON meta, no pickle); see :meth:`Identifier.save`."""
        return io.write_npz(path, self._meta(), self._arrays(), overwrite=overwrite)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> BatchIdentifier:
        """Read a file written by :meth:`save`."""
        meta, arrays = io.read_npz(path)
        try:
            config = IdentifierConfig.from_dict(meta["config"])
            ident = cls(meta["kind"], meta["n_envs"], meta["n_states"], meta["n_inputs"],
                        meta["dt"], config=config, seed=meta["seed"])
            ident._load_arrays(meta, arrays, str(path))
        except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            raise io.load_guard(path, exc) from None
        return ident
